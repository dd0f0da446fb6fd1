//! `gathering`: loop functions for runs with `phototaxis` robots and a goal light.
//!
//! - per tick: the fraction of released robots within [`RADIUS_M`] of the goal light's floor
//!   point, and the first time it reached [`TARGET_FRACTION`];
//! - stop rule: `success` once every robot is within the radius;
//! - end-of-run fields (in the JSON line, one result-store column each): `gathered_fraction`
//!   (at the end) and `gather_time_s` (when [`TARGET_FRACTION`] was first reached; null if
//!   never).
//!
//! Runs without a `phototaxis` group or without a goal light do not get them, so the built-in
//! scenarios run through this binary exactly as through `formica`.

use formica::{LoopFunctions, Outcome, RunResult, Scenario, World};

/// Distance from the light's floor point that counts as gathered (m).
pub const RADIUS_M: f32 = 0.6;
/// Fraction of the robots for `gather_time_s`.
pub const TARGET_FRACTION: f64 = 0.8;

/// The loop functions of one run, or `None` when it has no `phototaxis` group or no goal.
pub fn build(_sc: &Scenario, world: &World) -> Option<Box<dyn LoopFunctions>> {
    world.goal()?;
    if !world.groups.iter().any(|g| g.controller == "phototaxis") {
        return None;
    }
    Some(Box::new(Gathering {
        fraction: 0.0,
        reached_s: None,
    }))
}

/// State of the gathering metrics.
pub struct Gathering {
    fraction: f64,
    reached_s: Option<f64>,
}

/// Robots within [`RADIUS_M`] of the goal, and robots released.
fn gathered(world: &World) -> (usize, usize) {
    let Some(goal) = world.goal() else {
        return (0, 0);
    };
    let mut near = 0;
    let mut released = 0;
    for (i, r) in world.robots.iter().enumerate() {
        if r.body.is_some() {
            released += 1;
            if (world.robot_pose(i).position() - goal).length() <= RADIUS_M {
                near += 1;
            }
        }
    }
    (near, released)
}

impl LoopFunctions for Gathering {
    fn post_step(&mut self, world: &World) {
        let (near, released) = gathered(world);
        self.fraction = near as f64 / released.max(1) as f64;
        if self.reached_s.is_none() && self.fraction >= TARGET_FRACTION {
            self.reached_s = Some(world.time_s);
        }
    }

    fn is_finished(&self, world: &World) -> Option<Outcome> {
        let (near, _) = gathered(world);
        (near == world.robots.len()).then_some(Outcome::Success)
    }

    fn finish(&self, _world: &World, result: &mut RunResult) {
        result
            .extra
            .insert("gathered_fraction".into(), self.fraction.into());
        result
            .extra
            .insert("gather_time_s".into(), self.reached_s.into());
    }
}
