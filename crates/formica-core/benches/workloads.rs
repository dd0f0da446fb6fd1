//! `cargo bench -p formica-core --bench workloads`: criterion measurements of one tick of the
//! benchmark workloads of `formica bench` ([`formica::bench::Workload`]), so that a speed
//! regression shows in one command. Throughput is in robots per tick, so criterion's
//! "elem/s" are robot-ticks per second.
//!
//! Each world is stepped 100 ticks first (robots reach the objects), then every sample steps
//! on from where the last ended. `FORMICA_BENCH_ROBOTS=100,5000` changes the sizes (default
//! 100 and 1000); `transport-2t` is the transport workload with sensing and control on two
//! threads.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use formica::bench::Workload;
use formica::world::{Overrides, World};

fn sizes() -> Vec<usize> {
    std::env::var("FORMICA_BENCH_ROBOTS")
        .ok()
        .map(|v| v.split(',').filter_map(|s| s.trim().parse().ok()).collect())
        .filter(|v: &Vec<usize>| !v.is_empty())
        .unwrap_or_else(|| vec![100, 1000])
}

fn world(workload: Workload, n: usize, threads: usize) -> World {
    let sc = workload.scenario(n).expect("benchmark scenario");
    let mut w = World::new(&sc, &Overrides::default()).expect("benchmark world");
    w.set_threads(threads).expect("threads");
    for _ in 0..100 {
        w.step();
    }
    w
}

fn workloads(c: &mut Criterion) {
    let runs = Workload::ALL
        .iter()
        .map(|w| (w.name().to_string(), *w, 1))
        .chain([("transport-2t".to_string(), Workload::Transport, 2)]);
    for (name, workload, threads) in runs {
        let mut g = c.benchmark_group(name);
        g.sample_size(10);
        for n in sizes() {
            let mut w = world(workload, n, threads);
            g.throughput(Throughput::Elements(n as u64));
            g.bench_function(BenchmarkId::from_parameter(n), |b| b.iter(|| w.step()));
        }
        g.finish();
    }
}

criterion_group!(benches, workloads);
criterion_main!(benches);
