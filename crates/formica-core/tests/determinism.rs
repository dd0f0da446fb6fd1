//! Same scenario + seed = bit-identical results. A golden digest guards against drift.

mod common;
use common::*;
use formica::experiment::{run, RunOptions};
use formica::Overrides;

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn digest(seed: u64) -> (u64, String) {
    let sc = scenario(&format!(
        "[[lights]]\nat = [2.5, 0.0]\n{}[[robots]]\ncount = 20\ncontroller = \"random-walk\"\nplacement = {{ random = {{ min = [-2.0, -2.0], max = [2.0, 2.0] }} }}\n[run]\nduration_s = 30\n",
        seed_box(-1.0, 0.0),
    ));
    let opts = RunOptions {
        overrides: Overrides {
            seed: Some(seed),
            ..Default::default()
        },
        record: true,
        robot_every: 1,
    };
    let (mut result, traj) = run(&sc, &opts).unwrap();
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

#[test]
fn same_seed_same_bits() {
    assert_eq!(digest(7), digest(7));
    assert_ne!(digest(7).0, digest(8).0);
}

/// Update only for an intended change of physics, sensors or the random-walk controller, and
/// say so in the commit message.
const GOLDEN: u64 = 0x8b95_54b6_c8a9_4c2f;

#[test]
fn golden_digest() {
    let (d, json) = digest(42);
    assert_eq!(d, GOLDEN, "digest changed to {d:#x}; result: {json}");
}
