//! Same scenario + seed = bit-identical results. A golden digest guards against drift.

mod common;
use common::*;
use formica::experiment::{run, RunOptions};
use formica::{Overrides, Scenario};

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// FNV-1a of the result (wall time zeroed) and of every robot's trajectory, and the result.
fn digest_of(sc: &Scenario, seed: u64, duration_s: Option<f32>) -> (u64, String) {
    digest_threads(sc, seed, duration_s, 1)
}

/// [`digest_of`] with sensing and control on `threads` threads.
fn digest_threads(
    sc: &Scenario,
    seed: u64,
    duration_s: Option<f32>,
    threads: usize,
) -> (u64, String) {
    let opts = RunOptions {
        overrides: Overrides {
            seed: Some(seed),
            duration_s,
            ..Default::default()
        },
        record: true,
        robot_every: 1,
        threads,
    };
    let (mut result, traj) = run(sc, &opts).unwrap();
    result.wall_time_s = 0.0;
    let text = format!(
        "{}{}",
        serde_json::to_string(&result).unwrap(),
        serde_json::to_string(&traj).unwrap()
    );
    (
        fnv1a(text.as_bytes()),
        serde_json::to_string(&result).unwrap(),
    )
}

fn digest(seed: u64) -> (u64, String) {
    let sc = scenario(&format!(
        "[[lights]]\nat = [2.5, 0.0]\n{}[[robots]]\ncount = 20\ncontroller = \"random-walk\"\nplacement = {{ random = {{ min = [-2.0, -2.0], max = [2.0, 2.0] }} }}\n[run]\nduration_s = 30\n",
        seed_box(-1.0, 0.0),
    ));
    digest_of(&sc, seed, None)
}

#[test]
fn same_seed_same_bits() {
    assert_eq!(digest(7), digest(7));
    assert_ne!(digest(7).0, digest(8).0);
}

// Golden digests, one per built-in controller. Update one only for an intended change of
// physics, sensors or that controller, and say so in the commit message: each is one line,
// and a failing test prints the new value.

/// `random-walk`: 20 robots round a box, 30 s.
const GOLDEN: u64 = 0x8b95_54b6_c8a9_4c2f;
/// `constant`: 6 robots driving into a movable box at two wheel speeds, 20 s.
const GOLDEN_CONSTANT: u64 = 0x4a19_dc20_1280_a25e;
/// `occlusion`: `scenarios/seed-transport.toml`, 30 s.
const GOLDEN_OCCLUSION: u64 = 0xefbb_1348_df9b_0dbd;
/// `filling`: `scenarios/seed-fill-u.toml`, 30 s.
const GOLDEN_FILLING: u64 = 0xd1b0_bc37_a571_b29c;
/// `fill-transport`: `scenarios/fill-transport-u.toml`, 30 s.
const GOLDEN_FILL_TRANSPORT: u64 = 0x61cb_21d6_777c_f8f9;

fn check_golden(name: &str, constant: &str, golden: u64, (d, json): (u64, String)) {
    assert_eq!(
        d, golden,
        "{name}: digest changed to {d:#x}; if the change is intended, set {constant} to it \
         (and say why in the commit message); result: {json}"
    );
}

#[test]
fn golden_digest() {
    check_golden("random-walk", "GOLDEN", GOLDEN, digest(42));
}

#[test]
fn golden_digest_constant() {
    let mut poses = String::new();
    for k in 0..6 {
        poses.push_str(&format!("[-1.2, {:.2}, 0.0], ", -0.5 + 0.2 * k as f32));
    }
    let sc = scenario(&format!(
        "{}[[robots]]\ncontroller = \"constant\"\nparams = {{ left = 0.1, right = 0.12 }}\nplacement = {{ poses = [{poses}] }}\n[run]\nduration_s = 20\n",
        seed_box(0.0, 0.0),
    ));
    check_golden(
        "constant",
        "GOLDEN_CONSTANT",
        GOLDEN_CONSTANT,
        digest_of(&sc, 42, None),
    );
}

#[test]
fn golden_digest_occlusion() {
    let sc = shipped("seed-transport.toml");
    check_golden(
        "occlusion",
        "GOLDEN_OCCLUSION",
        GOLDEN_OCCLUSION,
        digest_of(&sc, 42, Some(30.0)),
    );
}

#[test]
fn golden_digest_filling() {
    let sc = shipped("seed-fill-u.toml");
    check_golden(
        "filling",
        "GOLDEN_FILLING",
        GOLDEN_FILLING,
        digest_of(&sc, 42, Some(30.0)),
    );
}

#[test]
fn golden_digest_fill_transport() {
    let sc = shipped("fill-transport-u.toml");
    check_golden(
        "fill-transport",
        "GOLDEN_FILL_TRANSPORT",
        GOLDEN_FILL_TRANSPORT,
        digest_of(&sc, 42, Some(30.0)),
    );
}

// The same golden digests with sensing and control on two threads: bit-identical.

#[test]
fn golden_digests_on_two_threads() {
    let sc = shipped("seed-transport.toml");
    check_golden(
        "occlusion, 2 threads",
        "GOLDEN_OCCLUSION",
        GOLDEN_OCCLUSION,
        digest_threads(&sc, 42, Some(30.0), 2),
    );
    let sc = shipped("fill-transport-u.toml");
    check_golden(
        "fill-transport, 2 threads",
        "GOLDEN_FILL_TRANSPORT",
        GOLDEN_FILL_TRANSPORT,
        digest_threads(&sc, 42, Some(30.0), 2),
    );
    let sc = shipped("seed-fill-u.toml");
    check_golden(
        "filling, 2 threads",
        "GOLDEN_FILLING",
        GOLDEN_FILLING,
        digest_threads(&sc, 42, Some(30.0), 2),
    );
}

/// A swarm large enough for the work to be split between threads (the benchmark's transport
/// and fill-transport worlds): the same bits on 1, 2 and 3 threads.
#[test]
fn large_swarms_same_bits_on_any_thread_count() {
    use formica::bench::Workload;
    for (workload, n) in [(Workload::Transport, 200), (Workload::FillTransport, 150)] {
        let sc = workload.scenario(n).unwrap();
        let one = digest_threads(&sc, 3, Some(8.0), 1);
        for threads in [2, 3] {
            assert_eq!(
                digest_threads(&sc, 3, Some(8.0), threads),
                one,
                "{} with {n} robots on {threads} threads",
                workload.name()
            );
        }
    }
}
