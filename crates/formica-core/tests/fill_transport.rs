//! `fill-transport`: filling the cavity of a movable concave object, then carrying the pseudo
//! object to the goal, on the shipped scenarios.

mod common;
use common::start;

use formica::{Outcome, Scenario};

fn shipped(name: &str) -> Scenario {
    let path = format!("{}/../../scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    Scenario::load(path.as_ref()).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `name` with `seed` to the end and checks the whole mission: robots attached inside the
/// cavity (the pseudo object is clearly more convex), then the object reached the goal.
fn fills_then_delivers(name: &str, seed: u64) {
    let sc = shipped(name);
    let mut run = start(&sc, seed);
    let outcome = run.run_to_end();
    let r = run.result();
    let attached = r.object_robots.unwrap_or(0);
    let before = r.convexity_before.unwrap_or(1.0);
    let after = r.convexity_after.unwrap_or(0.0);
    assert_eq!(
        outcome,
        Outcome::Success,
        "{name} seed {seed}: {outcome:?} after {:.0} s, goal distance {:?}",
        r.sim_time_s,
        r.goal_distance_m
    );
    assert!(
        attached >= 3,
        "{name} seed {seed}: {attached} robots attached"
    );
    assert!(
        after >= before + 0.1,
        "{name} seed {seed}: convexity {before:.2} -> {after:.2}"
    );
    // Some robots must still be free to push: attached robots' wheels exert no force.
    assert!(attached < run.world.robots.len(), "every robot attached");
}

#[test]
fn fill_transport_fills_and_delivers_the_u() {
    for seed in 1..=2 {
        fills_then_delivers("fill-transport-u.toml", seed);
    }
}

#[test]
fn fill_transport_fills_and_delivers_the_arc() {
    // The arc's cavity faces the goal: fillers push the object the wrong way before they
    // attach, and the pushers must take the robots-filled mouth as part of the object.
    for seed in 1..=2 {
        fills_then_delivers("fill-transport-arc.toml", seed);
    }
}
