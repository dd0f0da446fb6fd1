//! Steps the benchmark world for profiling: `cargo run --release --example profile_bench -- 1000 200`.

use formica::world::{Overrides, World};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(Ok(1000), |s| s.parse())?;
    let ticks: u64 = args.next().map_or(Ok(200), |s| s.parse())?;
    let sc = formica::bench::scenario(n, "random-walk")?;
    let mut w = World::new(&sc, &Overrides::default())?;
    let t = std::time::Instant::now();
    for _ in 0..ticks {
        w.step();
    }
    let s = t.elapsed().as_secs_f64();
    println!(
        "{n} robots, {ticks} ticks: {:.0} robot-ticks/s",
        n as f64 * ticks as f64 / s
    );
    Ok(())
}
