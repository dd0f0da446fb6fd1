//! Helpers shared by the integration tests.
#![allow(dead_code)]

use formica::experiment::{Run, RunOptions};
use formica::{Overrides, Scenario};

/// A 6 x 4 m arena with `body` appended (objects, lights, robots in TOML).
pub fn scenario(body: &str) -> Scenario {
    let text = format!("[arena]\nsize = [6.0, 4.0]\n{body}");
    Scenario::parse(&text, "test.toml").unwrap_or_else(|e| panic!("{e}"))
}

/// The text of shipped scenario `name` (a file in `scenarios/`).
pub fn shipped_text(name: &str) -> String {
    let path = format!("{}/../../scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Shipped scenario `name`, parsed and checked.
pub fn shipped(name: &str) -> Scenario {
    Scenario::parse(&shipped_text(name), name).unwrap_or_else(|e| panic!("{e}"))
}

/// Shipped scenario `name` with `sets` applied as `formica run --set KEY=VALUE` applies them
/// (each value is TOML text).
pub fn shipped_with(name: &str, sets: &[(&str, &str)]) -> Scenario {
    let overrides: Vec<(String, toml::Value)> = sets
        .iter()
        .map(|(k, v)| {
            let t: toml::Table =
                toml::from_str(&format!("v = {v}")).unwrap_or_else(|e| panic!("{k} = {v}: {e}"));
            (k.to_string(), t["v"].clone())
        })
        .collect();
    Scenario::parse_with_overrides(&shipped_text(name), name, &overrides, ("t", ""))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A run of `sc` with the given seed.
pub fn start(sc: &Scenario, seed: u64) -> Run {
    let opts = RunOptions {
        overrides: Overrides {
            seed: Some(seed),
            ..Default::default()
        },
        ..Default::default()
    };
    Run::new(sc, &opts).unwrap_or_else(|e| panic!("{e}"))
}

/// Stand-still robots at explicit poses `[x, y, heading_deg]`.
pub fn still_robots(poses: &[[f32; 3]]) -> String {
    robot_group("constant", "left = 0.0, right = 0.0", poses)
}

/// Robots that read proximity and light but stand still, with exact sensors.
pub fn watcher(poses: &[[f32; 3]]) -> String {
    watcher_with(poses, "noise = \"none\"")
}

/// Still proximity-and-light robots with the given `sensors` table (TOML, without braces).
pub fn watcher_with(poses: &[[f32; 3]], sensors: &str) -> String {
    format!(
        "{}sensors = {{ {sensors} }}\n",
        robot_group(
            "random-walk",
            "speed = 0.0, turn_every_s = 1e9, avoid_threshold = 10.0",
            poses,
        )
    )
}

/// Robots driving straight at `speed` from explicit poses.
pub fn pushers(poses: &[[f32; 3]], speed: f32) -> String {
    robot_group(
        "constant",
        &format!("left = {speed}, right = {speed}"),
        poses,
    )
}

/// A `[[robots]]` group running `controller` with `params` (TOML, without braces) from
/// explicit poses `[x, y, heading_deg]`.
pub fn robot_group(controller: &str, params: &str, poses: &[[f32; 3]]) -> String {
    let list: Vec<String> = poses
        .iter()
        .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
        .collect();
    format!(
        "[[robots]]\ncontroller = \"{controller}\"\nparams = {{ {params} }}\nplacement = {{ poses = [{}] }}\n",
        list.join(", ")
    )
}

/// The seed's transport box at `(x, y)`: 0.5 m, 50 kg, 0.5 m tall, floor friction 2.94 N.
pub fn seed_box(x: f32, y: f32) -> String {
    format!(
        "[[objects]]\nat = [{x}, {y}]\nshape = {{ box = [0.5, 0.5] }}\nmass = 50.0\nheight = 0.5\nfloor_mu = 0.006\n"
    )
}

/// Mean and standard deviation of `xs`.
pub fn moments(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    (mean, var.sqrt())
}
