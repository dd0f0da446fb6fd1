//! `formica bench`: robot-ticks per second on the standard scaled transport world.

use crate::CliError;
use anyhow::Context;
use formica::world::{Overrides, World};
use serde::Serialize;

/// Arguments of `formica bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Swarm sizes to measure, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "20,100,1000,10000")]
    pub robots: Vec<usize>,
    /// Ticks to time per size (default: about 200,000 robot-ticks, at least 20 ticks).
    #[arg(long)]
    pub ticks: Option<u64>,
    /// Controller every robot runs.
    #[arg(long, default_value = "random-walk")]
    pub controller: String,
    /// Print one JSON line per size.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Line {
    robots: usize,
    ticks: u64,
    robot_ticks_per_s: f64,
    us_per_robot_tick: f64,
    peak_memory_mib: Option<f64>,
    setup_s: f64,
}

/// Peak resident memory of this process (MiB), from /proc (Linux only).
fn peak_memory_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Resets the peak so that each size reports its own (Linux >= 4.0; ignored elsewhere).
fn reset_peak_memory() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Runs the command.
pub fn main(a: Args) -> Result<(), CliError> {
    if a.robots.is_empty() || a.robots.contains(&0) {
        return Err(CliError::Input(
            "--robots: expected positive counts, e.g. 20,100,1000".into(),
        ));
    }
    if a.ticks == Some(0) {
        return Err(CliError::Input(
            "--ticks: expected a positive number of ticks".into(),
        ));
    }
    for &n in &a.robots {
        reset_peak_memory();
        let t0 = std::time::Instant::now();
        let sc = formica::bench::scenario(n, &a.controller)?;
        let mut w = World::new(&sc, &Overrides::default())?;
        // Warm up: let the broad phase and caches settle.
        for _ in 0..5 {
            w.step();
        }
        let setup_s = t0.elapsed().as_secs_f64();
        let ticks = a.ticks.unwrap_or(((200_000 / n) as u64).max(20));
        let t1 = std::time::Instant::now();
        for _ in 0..ticks {
            w.step();
        }
        let dt = t1.elapsed().as_secs_f64();
        let rts = (n as f64 * ticks as f64) / dt;
        let line = Line {
            robots: n,
            ticks,
            robot_ticks_per_s: rts,
            us_per_robot_tick: 1e6 / rts,
            peak_memory_mib: peak_memory_mib(),
            setup_s,
        };
        if a.json {
            outln!("{}", serde_json::to_string(&line).context("encoding JSON")?);
        } else {
            outln!(
                "N = {:>6}: {:>12.0} robot-ticks/s ({:.2} us per robot-tick, {} ticks), peak memory {} MiB",
                n,
                rts,
                line.us_per_robot_tick,
                ticks,
                line.peak_memory_mib.map_or("?".into(), |m| format!("{m:.1}"))
            );
        }
    }
    Ok(())
}
