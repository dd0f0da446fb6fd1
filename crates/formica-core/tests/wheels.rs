//! Wheel speed errors (`robots[].wheels`): the spreads a file gives, drawn from the robot's own
//! stream, and nothing at all without them.

mod common;

use formica::{Overrides, World};

/// `n` robots driving `left`, `right` with the given `wheels` table, in a large empty arena.
fn world(n: usize, left: f32, right: f32, wheels: &str, seed: u64) -> World {
    let text = format!(
        "[arena]\nsize = [60.0, 60.0]\n[[robots]]\ncount = {n}\ncontroller = \"constant\"\n\
         params = {{ left = {left}, right = {right} }}\n\
         placement = {{ random = {{ min = [-29.0, -29.0], max = [29.0, 29.0] }} }}\n{wheels}"
    );
    let sc = formica::Scenario::parse(&text, "wheels.toml").unwrap_or_else(|e| panic!("{e}"));
    World::new(
        &sc,
        &Overrides {
            seed: Some(seed),
            ..Overrides::default()
        },
    )
    .unwrap()
}

#[test]
fn without_wheel_errors_robots_turn_their_wheels_as_commanded_capped() {
    let mut w = world(3, 0.05, 9.0, "", 1);
    w.step();
    w.step();
    let top = w.groups[0].model.max_speed;
    for r in &w.robots {
        assert_eq!(r.wheel_speeds(), [0.05, top]);
    }
}

#[test]
fn each_wheel_has_a_fixed_factor_with_the_bias_spread() {
    // 2,000 robots, two wheels each: the factors' mean is 1 and their spread the bias (within
    // 5 %), and they do not change from tick to tick.
    let mut w = world(2000, 0.1, 0.1, "wheels = { bias = 0.05 }", 3);
    w.step();
    w.step();
    let first: Vec<[f32; 2]> = w.robots.iter().map(|r| r.wheel_speeds()).collect();
    let f: Vec<f64> = first
        .iter()
        .flatten()
        .map(|v| f64::from(*v) / 0.1 - 1.0)
        .collect();
    let (mean, sd) = common::moments(&f);
    assert!(mean.abs() < 0.005, "mean factor - 1 = {mean}");
    assert!((sd / 0.05 - 1.0).abs() < 0.05, "spread {sd}");
    w.step();
    assert!(w
        .robots
        .iter()
        .zip(&first)
        .all(|(r, s)| r.wheel_speeds() == *s));
    // Left and right differ: a robot told to drive straight curves.
    assert!(first.iter().filter(|s| s[0] != s[1]).count() > 1990);
}

#[test]
fn wheel_noise_is_drawn_every_tick_with_its_spread() {
    // One robot, 50,000 ticks, two wheels: 10^5 draws of `1 + noise e`.
    let mut w = world(1, 0.05, 0.05, "wheels = { noise = 0.05 }", 5);
    let mut f = Vec::with_capacity(100_000);
    for _ in 0..50_000 {
        w.step();
        let s = w.robots[0].wheel_speeds();
        f.extend(s.iter().map(|v| f64::from(*v) / 0.05 - 1.0));
    }
    let (mean, sd) = common::moments(&f);
    assert!(mean.abs() < 0.001, "mean {mean}");
    assert!((sd / 0.05 - 1.0).abs() < 0.05, "spread {sd}");
}

#[test]
fn wheel_errors_are_deterministic_and_move_no_other_draw() {
    let run = |wheels: &str| {
        let mut w = world(20, 0.1, 0.08, wheels, 9);
        for _ in 0..50 {
            w.step();
        }
        w
    };
    let (a, b) = (
        run("wheels = { noise = 0.1, bias = 0.1 }"),
        run("wheels = { noise = 0.1, bias = 0.1 }"),
    );
    let poses = |w: &World| w.robots.iter().map(|r| r.readings.pose).collect::<Vec<_>>();
    assert_eq!(poses(&a), poses(&b));
    // With and without wheel errors, the first tick's readings (before anyone moved) are the
    // same: the sensors' noise comes from another stream.
    let first = |wheels: &str| {
        let mut w = world(20, 0.1, 0.08, wheels, 9);
        w.step();
        w.robots
            .iter()
            .map(|r| r.readings.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(
        format!("{:?}", first("")),
        format!("{:?}", first("wheels = { noise = 0.1, bias = 0.1 }"))
    );
    assert_ne!(poses(&a), poses(&run("")));
}

#[test]
fn wheel_spreads_out_of_range_are_refused_at_their_line() {
    for (wheels, says) in [
        ("wheels = { noise = 0.6 }", "robots[0].wheels.noise"),
        ("wheels = { bias = -0.1 }", "robots[0].wheels.bias"),
        ("wheels = { slip = 0.1 }", "unknown field `slip`"),
    ] {
        let text = format!(
            "[arena]\nsize = [6.0, 4.0]\n[[robots]]\ncontroller = \"constant\"\n\
             placement = {{ poses = [[0.0, 0.0, 0.0]] }}\n{wheels}\n"
        );
        let e = formica::Scenario::parse(&text, "w.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("w.toml:6:") && e.contains(says), "{wheels}: {e}");
    }
}
