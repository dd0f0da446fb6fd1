//! `formica`: run, check and benchmark swarm cooperative-transport scenarios.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[macro_use]
mod console;

mod cmd_bench;
mod cmd_check;
mod cmd_export;
mod cmd_merge;
mod cmd_record;
mod cmd_report;
mod cmd_run;
mod cmd_serve;
mod cmd_slurm;
mod cmd_sweep;
mod gallery;
mod output;
mod plots;
mod provenance;
mod replay;
mod stats;
mod store;
mod sweep;

/// Formica: a simulator and behaviour suite for cooperative transport by robot swarms.
#[derive(Parser)]
#[command(name = "formica", version = provenance::LONG_VERSION, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario headless (one seed, or a range of seeds in parallel).
    Run(cmd_run::Args),
    /// Validate a scenario file and describe what it sets up.
    Check(cmd_check::Args),
    /// Measure robot-ticks per second on the standard scaled transport world.
    Bench(cmd_bench::Args),
    /// Run a parameter sweep into a SQLite result store (resumable).
    Sweep(cmd_sweep::Args),
    /// Export a result store to CSV.
    Export(cmd_export::Args),
    /// Plots and a Markdown summary from a result store.
    Report(cmd_report::Args),
    /// Merge shard result stores into one.
    Merge(cmd_merge::Args),
    /// Write (and optionally submit) a Slurm job-array script for a sweep.
    Slurm(cmd_slurm::Args),
    /// Serve a live viewer of a scenario on 127.0.0.1.
    Serve(cmd_serve::Args),
    /// Render a run to an animated GIF.
    Record(cmd_record::Args),
}

/// An error with the exit code it deserves: 2 for bad input, 1 otherwise.
pub enum CliError {
    /// The user's input (scenario file, arguments) is wrong.
    Input(String),
    /// Something else failed (I/O, ...).
    Other(anyhow::Error),
}

impl From<formica::ScenarioError> for CliError {
    fn from(e: formica::ScenarioError) -> Self {
        CliError::Input(e.to_string())
    }
}

impl From<anyhow::Error> for CliError {
    fn from(e: anyhow::Error) -> Self {
        CliError::Other(e)
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let r = match cli.command {
        Command::Run(a) => cmd_run::main(a),
        Command::Check(a) => cmd_check::main(a),
        Command::Bench(a) => cmd_bench::main(a),
        Command::Sweep(a) => cmd_sweep::main(a),
        Command::Export(a) => cmd_export::main(a),
        Command::Report(a) => cmd_report::main(a),
        Command::Merge(a) => cmd_merge::main(a),
        Command::Slurm(a) => cmd_slurm::main(a),
        Command::Serve(a) => cmd_serve::main(a),
        Command::Record(a) => cmd_record::main(a),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Input(m)) => {
            eprintln!("error: {m}");
            ExitCode::from(2)
        }
        Err(CliError::Other(e)) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}
