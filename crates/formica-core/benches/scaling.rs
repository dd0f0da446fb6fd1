//! `cargo bench --bench scaling`: robot-ticks per second on the standard benchmark world
//! (0.8 m^2 per robot, one box, one light, every robot sensing and driving) as the swarm grows.
//! The same measurement as `formica bench`, without the CLI.

use formica::world::{Overrides, World};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` passes `--bench`; ignore flags, take an optional list of sizes.
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![20, 100, 1000, 10_000]
    } else {
        sizes
    };
    let mut base = None;
    for n in sizes {
        let sc = formica::bench::scenario(n, "random-walk")?;
        let mut w = World::new(&sc, &Overrides::default())?;
        for _ in 0..5 {
            w.step();
        }
        let ticks = ((300_000 / n) as u64).max(30);
        let t = Instant::now();
        for _ in 0..ticks {
            w.step();
        }
        let s = t.elapsed().as_secs_f64();
        let rate = n as f64 * ticks as f64 / s;
        let us = 1e6 / rate;
        let rel = *base.get_or_insert(us);
        println!(
            "N = {n:>6}: {rate:>12.0} robot-ticks/s, {us:.3} us per robot-tick ({:.2}x the first size)",
            us / rel
        );
    }
    Ok(())
}
