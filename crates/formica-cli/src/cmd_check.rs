//! `formica check SCENARIO`: validate a file and describe what it sets up.

use crate::CliError;
use formica::experiment::{object_size, Run, RunOptions};
use formica::Scenario;
use std::path::PathBuf;

/// Arguments of `formica check`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
}

/// Loads the scenario, builds its world (placing robots with the file's seed) and describes it.
pub fn main(a: Args) -> Result<(), CliError> {
    let sc = Scenario::load(&a.scenario)?;
    let run = Run::new(&sc, &RunOptions::default())?;
    let w = &run.world;
    let s = &sc.spec;
    outln!("{}: OK", sc.file);
    outln!("  name: {}", sc.name);
    if let Some(d) = &s.description {
        outln!("  description: {}", d.trim());
    }
    outln!(
        "  arena: {} x {} m, {} extra walls",
        s.arena.size[0],
        s.arena.size[1],
        s.walls.len()
    );
    for (i, l) in s.lights.iter().enumerate() {
        let goal = if w.goal_light == Some(i) {
            " (goal)"
        } else {
            ""
        };
        outln!(
            "  light {i}: at ({}, {}), height {} m, intensity {}{goal}",
            l.at[0],
            l.at[1],
            l.height,
            l.intensity
        );
    }
    for (i, o) in w.objects.iter().enumerate() {
        let c = w.object_center(i);
        let kind = if o.movable { "movable" } else { "static" };
        let friction = s.objects[i].get_ref().floor_mu * o.mass * formica::physics::GRAVITY;
        outln!(
            "  object {i} \"{}\": {kind}, {} part(s), centre ({:.3}, {:.3}), {} kg, height {} m, size {:.3} m, floor friction {:.2} N",
            o.name,
            o.parts.len(),
            c.x,
            c.y,
            o.mass,
            o.height,
            object_size(w, i),
            friction,
        );
        if o.movable {
            let pushers: Vec<String> = w
                .groups
                .iter()
                .map(|g| {
                    let n = (friction / g.model.max_force).floor() as usize + 1;
                    format!("{} {:?}", n, g.model.kind)
                })
                .collect();
            if !pushers.is_empty() {
                outln!(
                    "    needs at least {} pushing together to move",
                    pushers.join(" or ")
                );
            }
        }
    }
    for (g, grp) in w.groups.iter().enumerate() {
        let n = w.robots.iter().filter(|r| r.group == g).count();
        let needs = grp.needs();
        outln!(
            "  robots[{g}]: {n} x {:?}, controller {}, sensors: proximity={} light={} beacon={} camera={}",
            grp.model.kind, grp.controller, needs.proximity, needs.light, needs.beacon, needs.camera
        );
    }
    outln!(
        "  run: {} ticks/s, {} physics steps/tick, {} s, seed {}",
        s.run.tick_hz,
        s.run.substeps,
        s.run.duration_s,
        s.run.seed
    );
    if let Some(r) = run.goal_radius() {
        outln!(
            "  stop: success within {r:.3} m of the goal; wall: {}",
            s.stop.on_wall
        );
    }
    Ok(())
}
