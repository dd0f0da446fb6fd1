//! Filling metrics: robots attached to the object, fill time, convexity of the pseudo object
//! (object plus attached robots) and how much of the cavity they cover; and the `on_filled`
//! stop rule.
//!
//! Areas are measured by sampling a 5 mm grid over the convex hull's bounding box, which is
//! exact to well under 1 % for the seed's shapes and robots.

use crate::experiment::{LoopFunctions, Outcome, RunResult};
use crate::geometry::{convex_hull, Vec2};
use crate::ops;
use crate::scenario::Scenario;
use crate::world::World;
use rapier2d::parry::utils::point_in_convex_poly2d;

/// Grid step of the area sampling (m).
pub const AREA_STEP_M: f32 = 0.005;

/// Areas of the pseudo object (object + attached robots).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillAreas {
    /// Area of the union of the object and attached robots (m^2).
    pub pseudo: f64,
    /// Area of its convex hull (m^2).
    pub hull: f64,
    /// Area of the hull not covered by the object itself (the cavity) (m^2).
    pub cavity: f64,
    /// Part of the cavity covered by attached robots (m^2).
    pub cavity_covered: f64,
}

impl FillAreas {
    /// Area / hull area.
    pub fn convexity(&self) -> f64 {
        if self.hull > 0.0 {
            (self.pseudo / self.hull).min(1.0)
        } else {
            1.0
        }
    }
    /// Covered part of the cavity (1 when there is no cavity).
    pub fn cavity_filled(&self) -> f64 {
        if self.cavity > 1e-9 {
            self.cavity_covered / self.cavity
        } else {
            1.0
        }
    }
}

/// Robots attached to object `obj`: (centre, radius).
pub fn attached_discs(world: &World, obj: usize) -> Vec<(Vec2, f32)> {
    world
        .robots
        .iter()
        .enumerate()
        .filter(|(_, r)| r.attached.is_some_and(|(_, o)| o == obj))
        .map(|(i, _)| (world.robot_pose(i).position(), world.robot_model(i).radius))
        .collect()
}

/// Measures the pseudo object of object `obj` with the given discs attached. The cavity is the
/// part of the object's own convex hull outside the object (it moves with the object); the
/// convexity is measured on the pseudo object and the hull of the pseudo object.
pub fn fill_areas(world: &World, obj: usize, discs: &[(Vec2, f32)]) -> FillAreas {
    let mut pts: Vec<Vec2> = world.object_outlines(obj).into_iter().flatten().collect();
    let object_hull = convex_hull(&pts);
    for (c, r) in discs {
        for k in 0..24 {
            let a = std::f32::consts::TAU * k as f32 / 24.0;
            pts.push(*c + ops::unit(a) * *r);
        }
    }
    let hull = convex_hull(&pts);
    let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    for p in &hull {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let body = world.objects[obj].body;
    let step = AREA_STEP_M;
    let cell = f64::from(step) * f64::from(step);
    let nx = ((hi.x - lo.x) / step).ceil() as usize;
    let ny = ((hi.y - lo.y) / step).ceil() as usize;
    let mut a = FillAreas {
        pseudo: 0.0,
        hull: 0.0,
        cavity: 0.0,
        cavity_covered: 0.0,
    };
    for iy in 0..ny {
        for ix in 0..nx {
            let p = Vec2::new(
                lo.x + (ix as f32 + 0.5) * step,
                lo.y + (iy as f32 + 0.5) * step,
            );
            if !point_in_convex_poly2d(p, &hull) {
                continue;
            }
            a.hull += cell;
            let in_obj = world.physics.contains(body, p);
            let in_robot = discs
                .iter()
                .any(|(c, r)| (p - *c).length_squared() <= r * r);
            if in_obj || in_robot {
                a.pseudo += cell;
            }
            if !in_obj && point_in_convex_poly2d(p, &object_hull) {
                a.cavity += cell;
                if in_robot {
                    a.cavity_covered += cell;
                }
            }
        }
    }
    a
}

/// Filling metrics and the `on_filled` stop rule.
pub struct FillHooks {
    on_filled: Option<f32>,
    before: Option<f64>,
    concave: bool,
}

impl FillHooks {
    /// Hooks for a world built from `sc`; measures the object's convexity at the start.
    pub fn new(sc: &Scenario, world: &World) -> Self {
        let before = world.target.map(|t| fill_areas(world, t, &[]).convexity());
        Self {
            on_filled: sc.spec.stop.on_filled,
            before,
            concave: before.is_some_and(|c| c < 0.995),
        }
    }

    /// Robots attached to object `obj` (the pseudo object's robots).
    fn attached(world: &World, obj: usize) -> usize {
        world
            .robots
            .iter()
            .filter(|r| r.attached.is_some_and(|(_, o)| o == obj))
            .count()
    }
}

impl LoopFunctions for FillHooks {
    fn is_finished(&self, world: &World) -> Option<Outcome> {
        let frac = self.on_filled?;
        let t = world.target?;
        let all_released = world.released() == world.robots.len();
        let n = world.robots.len().max(1) as f32;
        (all_released && Self::attached(world, t) as f32 / n >= frac).then_some(Outcome::Success)
    }

    fn finish(&self, world: &World, r: &mut RunResult) {
        let Some(t) = world.target else { return };
        let attached = Self::attached(world, t);
        if !self.concave && attached == 0 && self.on_filled.is_none() {
            return;
        }
        let discs = attached_discs(world, t);
        let after = fill_areas(world, t, &discs);
        r.object_robots = Some(attached);
        r.fill_time_s = world
            .robots
            .iter()
            .filter(|r| r.attached.is_some_and(|(_, o)| o == t))
            .filter_map(|r| r.attached_at_s)
            .fold(None, |m: Option<f32>, x| Some(m.map_or(x, |m| m.max(x))))
            .map(f64::from);
        r.convexity_before = self.before;
        r.convexity_after = Some(after.convexity());
        r.cavity_filled = Some(after.cavity_filled());
    }
}
