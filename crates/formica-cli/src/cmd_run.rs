//! `formica run SCENARIO`: run one seed, or a range of seeds in parallel.

use crate::{output, stats, CliError};
use anyhow::Context;
use formica::experiment::{Run, RunOptions};
use formica::{Overrides, RunResult, Scenario};
use rayon::prelude::*;
use std::path::PathBuf;

/// Arguments of `formica run`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    /// Seed (default: the file's `run.seed`).
    #[arg(long, conflicts_with = "seeds")]
    pub seed: Option<u64>,
    /// Run seeds A to B inclusive in parallel, e.g. `--seeds 1..100`.
    #[arg(long, value_name = "A..B")]
    pub seeds: Option<String>,
    /// Simulated time limit in seconds (default: the file's `run.duration_s`).
    #[arg(long)]
    pub duration: Option<f32>,
    /// Use this controller for every robot group.
    #[arg(long)]
    pub controller: Option<String>,
    /// Override any scenario key, as sweep files do: `--set robots.0.count=10`,
    /// `--set 'robots.0.params.perception="camera"'` (the value is TOML; a bare word is taken
    /// as a string). Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Write trajectories (CSV), the result (JSON) and a picture (PNG) into this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print JSON lines instead of text.
    #[arg(long)]
    pub json: bool,
    /// Worker threads for `--seeds` (default: all cores). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run even if the physics step is too coarse for contacts to hold (see `formica check`).
    #[arg(long)]
    pub force: bool,
}

/// Parses a seed range `A..B` (inclusive; `A..=B` also accepted).
pub fn seed_range(s: &str) -> Option<std::ops::RangeInclusive<u64>> {
    let (a, b) = s.split_once("..")?;
    let a: u64 = a.trim().parse().ok()?;
    let b: u64 = b.trim().trim_start_matches('=').parse().ok()?;
    (a <= b).then_some(a..=b)
}

/// Parses `--seeds A..B`.
pub fn parse_seeds(s: &str) -> Result<std::ops::RangeInclusive<u64>, CliError> {
    seed_range(s)
        .ok_or_else(|| CliError::Input(format!("--seeds: expected A..B with A <= B, got `{s}`")))
}

/// Loads the scenario with the `--set` overrides applied.
pub fn load(path: &std::path::Path, set: &[String]) -> Result<Scenario, CliError> {
    if set.is_empty() {
        return Ok(Scenario::load(path)?);
    }
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::Input(format!("{file}: cannot read: {e}")))?;
    let mut overrides = Vec::with_capacity(set.len());
    for item in set {
        let (key, value) = item
            .split_once('=')
            .ok_or_else(|| CliError::Input(format!("--set: expected KEY=VALUE, got `{item}`")))?;
        let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.trim().to_string()));
        overrides.push((key.trim().to_string(), value));
    }
    let origin = set.join("\n");
    Ok(Scenario::parse_with_overrides(
        &text,
        &file,
        &overrides,
        ("--set", &origin),
    )?)
}

fn overrides(a: &Args, seed: Option<u64>) -> Overrides {
    Overrides {
        seed,
        duration_s: a.duration,
        controller: a.controller.clone(),
    }
}

fn describe(r: &RunResult) -> String {
    let gd = r
        .goal_distance_m
        .map_or(String::new(), |d| format!(", goal distance {d:.3} m"));
    let fill = match (r.object_robots, r.convexity_after) {
        (Some(n), Some(c)) => format!(", {n} robots attached, convexity {c:.3}"),
        _ => String::new(),
    };
    let extra: String = r.extra.iter().map(|(k, v)| format!(", {k} {v}")).collect();
    format!(
        "{} seed {}: {} after {:.1} s ({} ticks, {} robots){gd}, object path {:.3} m, path efficiency {:.3}{fill}{extra}, {:.2} s wall time",
        r.scenario,
        r.seed,
        r.outcome.name(),
        r.sim_time_s,
        r.ticks,
        r.robots,
        r.object_path_m,
        r.path_efficiency,
        r.wall_time_s
    )
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    let sc = load(&a.scenario, &a.set)?;
    crate::check_controller(a.controller.as_deref())?;
    if let (Some(w), false) = (sc.physics_warning(), a.force) {
        return Err(CliError::Input(format!(
            "{}: {w}; --force runs it anyway",
            sc.file
        )));
    }
    if let Some(d) = a.duration {
        if !(d > 0.0 && d.is_finite()) {
            return Err(CliError::Input(format!(
                "--duration: expected a positive number of seconds, got {d}"
            )));
        }
    }
    match &a.seeds {
        Some(s) => run_many(&a, &sc, parse_seeds(s)?),
        None => run_one(&a, &sc),
    }
}

fn run_one(a: &Args, sc: &Scenario) -> Result<(), CliError> {
    let opts = RunOptions {
        overrides: overrides(a, a.seed),
        record: a.out.is_some(),
        robot_every: 1,
    };
    let mut run = Run::new(sc, &opts)?;
    run.run_to_end();
    let result = run.result();
    if a.json {
        outln!(
            "{}",
            serde_json::to_string(&result).context("encoding JSON")?
        );
    } else {
        outln!("{}", describe(&result));
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        if let Some(tr) = run.trajectories() {
            output::write_trajectories(dir, tr)?;
            let path: Vec<_> = tr
                .object
                .iter()
                .map(|s| formica::geometry::Vec2::new(s.x, s.y))
                .collect();
            let overlay = formica_render::Overlay {
                path: &path,
                goal_radius: run.goal_radius(),
            };
            formica_render::save_png(&run.world, 900, &overlay, &dir.join("final.png"))
                .map_err(anyhow::Error::msg)?;
        }
        let json = serde_json::to_string_pretty(&result).context("encoding JSON")?;
        std::fs::write(dir.join("result.json"), json + "\n")
            .with_context(|| format!("writing {}", dir.join("result.json").display()))?;
        if !a.json {
            outln!(
                "wrote {}/{{object.csv, robots.csv, result.json, final.png}}",
                dir.display()
            );
        }
    }
    Ok(())
}

fn run_many(a: &Args, sc: &Scenario, seeds: std::ops::RangeInclusive<u64>) -> Result<(), CliError> {
    // Check the scenario builds before fanning out, so errors are reported once.
    Run::new(
        sc,
        &RunOptions {
            overrides: overrides(a, Some(*seeds.start())),
            ..Default::default()
        },
    )?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let results: Vec<Result<RunResult, formica::ScenarioError>> = pool.install(|| {
        seeds
            .clone()
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|seed| {
                let opts = RunOptions {
                    overrides: overrides(a, Some(seed)),
                    ..Default::default()
                };
                formica::run(sc, &opts).map(|(r, _)| r)
            })
            .collect()
    });
    let results: Vec<RunResult> = results.into_iter().collect::<Result<_, _>>()?;
    let summary = stats::summarize(&sc.name, &results);
    if a.json {
        for r in &results {
            outln!("{}", serde_json::to_string(r).context("encoding JSON")?);
        }
        outln!(
            "{}",
            serde_json::to_string(&summary).context("encoding JSON")?
        );
    } else {
        for r in &results {
            outln!("{}", describe(r));
        }
        outln!(
            "{}: {} trials, success {:.1} % (95 % CI {:.1}-{:.1} %), median time {}, mean path efficiency {:.3}",
            summary.scenario,
            summary.trials,
            100.0 * summary.success_rate,
            100.0 * summary.success_ci95[0],
            100.0 * summary.success_ci95[1],
            summary.median_time_s.map_or("n/a (under half succeeded)".into(), |t| format!("{t:.1} s")),
            summary.mean_path_efficiency
        );
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut lines = String::new();
        for r in &results {
            lines += &(serde_json::to_string(r).context("encoding JSON")? + "\n");
        }
        std::fs::write(dir.join("results.jsonl"), lines).context("writing results.jsonl")?;
        std::fs::write(
            dir.join("summary.json"),
            serde_json::to_string_pretty(&summary).context("encoding JSON")? + "\n",
        )
        .context("writing summary.json")?;
    }
    Ok(())
}
