//! Speed of one 20-robot `seed-transport` trial (occlusion controller, 20 simulated minutes).
//!
//! `cargo bench -p formica-core --bench transport` prints wall-clock seconds per trial, single
//! threaded, for two measures:
//!
//! - `fixed`: exactly 20 simulated minutes (12,000 ticks), the stop rules switched off, so
//!   the robots keep pushing the box (into the east wall if it gets there);
//! - `to-outcome`: the trial as `formica run` plays it, until success, wall or timeout.
//!
//! Optional arguments: `--seeds N` (default 5) and `--scenario FILE`.

use formica::experiment::{Run, RunOptions};
use formica::{Overrides, Scenario};
use std::time::Instant;

fn main() {
    let mut seeds: u64 = 5;
    let mut path = format!(
        "{}/../../scenarios/seed-transport.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seeds" => seeds = args.next().and_then(|v| v.parse().ok()).unwrap_or(seeds),
            "--scenario" => path = args.next().unwrap_or(path),
            _ => {} // `cargo bench` passes `--bench`
        }
    }
    let sc = match Scenario::load(path.as_ref()) {
        Ok(sc) => sc,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let ticks = (sc.spec.run.duration_s * sc.spec.run.tick_hz).round() as u64;
    let opts = |seed| RunOptions {
        overrides: Overrides {
            seed: Some(seed),
            ..Default::default()
        },
        ..Default::default()
    };

    let mut fixed = Vec::new();
    let mut outcome = Vec::new();
    for seed in 1..=seeds {
        let Ok(mut run) = Run::new(&sc, &opts(seed)) else {
            eprintln!("cannot build the world");
            std::process::exit(2);
        };
        let t = Instant::now();
        for _ in 0..ticks {
            run.world.step();
        }
        fixed.push(t.elapsed().as_secs_f64());

        let Ok(mut run) = Run::new(&sc, &opts(seed)) else {
            std::process::exit(2);
        };
        let t = Instant::now();
        let o = run.run_to_end();
        outcome.push((t.elapsed().as_secs_f64(), o, run.world.time_s));
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
    println!(
        "{}: {} robots, {} ticks ({} simulated s) per fixed trial, {} seeds",
        sc.name,
        sc.robot_count(),
        ticks,
        sc.spec.run.duration_s,
        seeds
    );
    println!(
        "fixed      : mean {:.3} s/trial, max {:.3} s/trial",
        mean(&fixed),
        max(&fixed)
    );
    let ow: Vec<f64> = outcome.iter().map(|o| o.0).collect();
    let sim: Vec<f64> = outcome.iter().map(|o| o.2).collect();
    println!(
        "to-outcome : mean {:.3} s/trial, max {:.3} s/trial (mean simulated {:.0} s; outcomes {:?})",
        mean(&ow),
        max(&ow),
        mean(&sim),
        outcome.iter().map(|o| o.1.name()).collect::<Vec<_>>()
    );
}
