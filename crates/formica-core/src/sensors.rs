//! Sensors: what a controller reads ([`Readings`]) and how the simulator computes it
//! ([`sense`]).
//!
//! - IR proximity: one ray per sensor from the body outward, cast only against colliders whose
//!   bounding boxes are near the robot (one box query per robot), through the model's curve.
//! - Light: ARGoS's law, `exp(-2 D / I)`, spread over neighbouring sensors, blocked by bodies
//!   taller than the line of sight (see [`light_blocked`]), plus ambient light.
//! - Positioning (own pose) and an object beacon (the object's centre, within `beacon_range`).
//! - Colour-blob camera, as ARGoS's: bearing, distance estimate and colour of the lit LEDs of
//!   other robots in range, unless a body taller than the line of sight hides them (see
//!   [`sight_blocked`]), and of lights that have a colour (a coloured goal region). No object
//!   bodies, no identity. `camera = "oracle"` (an ablation) adds
//!   every coloured body, with the distance to its surface (the camera's noise on it) instead
//!   of to an LED.
//! - Colour scan, as Queiroz and MacRae's panoramic cameras: a ring of bearing bins, each the
//!   colour of the first body its ray meets (object colour, LED colour, black for an unlit
//!   robot, grey for a wall, [`Color::Off`] for nothing) and a coarse, noisy range.
//!
//! Noise as the hardware has it (see [`crate::noise`]): relative plus additive on proximity and
//! light (clamped to [0, 1]), additive on positions and bearings, relative on distances.
//!
//! Every reading is a fixed-size vector per robot (sizes in [`SensorLayout`]), except the
//! camera's blobs, a list of at most [`MAX_BLOBS`] robots' LEDs, nearest first, then the
//! coloured lights in sight, so that a binding can hand
//! them out as flat arrays `[robots, sensors]`.

use crate::geometry::{wrap_angle, Pose, Vec2};
use crate::noise;
use crate::ops;
use crate::physics::{Nearby, Physics, Tag};
use crate::robot::{ProximityCurve, RobotModel};
use crate::scenario::{CameraKind, Color, SensorConfig};
use rand::Rng;
use std::f32::consts::{PI, TAU};

/// Most LED blobs the camera reports (the nearest); coloured lights come on top.
pub const MAX_BLOBS: usize = 16;

/// One coloured blob seen by the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blob {
    /// Bearing in the robot's frame (rad, counter-clockwise from straight ahead).
    pub bearing: f32,
    /// Estimated distance (m): to the LED (robot centre) for the blob camera; to the nearest
    /// point of the body with the oracle.
    pub distance: f32,
    /// Colour.
    pub color: Color,
}

/// What a controller sees in one tick. Controllers never see the world.
#[derive(Debug, Clone, Default)]
pub struct Readings {
    /// Simulated time (s).
    pub time_s: f32,
    /// Proximity readings in [0, 1], one per sensor (angles in [`SensorLayout`]).
    pub proximity: Vec<f32>,
    /// Light readings in [0, 1], one per sensor (ambient light included).
    pub light: Vec<f32>,
    /// Own pose from the positioning sensor.
    pub pose: Pose,
    /// The centre of the nearest movable object in the world frame (of the target object when
    /// none is movable), if the robot has the beacon and is within range of it.
    pub beacon: Option<Vec2>,
    /// Camera blobs, nearest first: at most [`MAX_BLOBS`] LEDs (the nearest) and every
    /// coloured light in sight (empty without a camera).
    pub blobs: Vec<Blob>,
    /// Colour scan: the colour each bin sees (bins at [`SensorLayout::scan_angles`]; empty
    /// without a scan).
    pub scan_color: Vec<Color>,
    /// Colour scan: range from the robot's centre to what each bin sees (m); the scan's range
    /// where it sees nothing.
    pub scan_range: Vec<f32>,
    /// Whether the robot is attached to a body.
    pub attached: bool,
}

/// Static facts a controller needs to interpret readings (sensor bearings, speed limits).
#[derive(Debug, Clone, PartialEq)]
pub struct SensorLayout {
    /// Proximity sensor bearings (rad).
    pub proximity_angles: Vec<f32>,
    /// Light sensor bearings (rad).
    pub light_angles: Vec<f32>,
    /// Colour scan bin bearings (rad; bin `i` at `2 pi i / bins`).
    pub scan_angles: Vec<f32>,
    /// Colour scan range (m).
    pub scan_range: f32,
    /// Blob camera range (m).
    pub camera_range: f32,
    /// Largest wheel speed (m/s).
    pub max_speed: f32,
    /// Body radius (m).
    pub radius: f32,
    /// Wheel distance (m).
    pub wheel_distance: f32,
    /// Proximity range beyond the body (m).
    pub proximity_range: f32,
    /// How the model's proximity sensors turn a distance into a reading (its calibration:
    /// [`ProximityCurve::distance`] inverts it).
    pub proximity_curve: ProximityCurve,
    /// The largest radius (m) of the objects the beacon tracks (the farthest point of an
    /// outline from its centre of mass), as the positioning system that gives their centres
    /// knows them; `None` with no such object, or outside a world. Controllers may size
    /// themselves to it, as an experimenter would set their parameters by hand.
    pub beacon_radius: Option<f32>,
    /// Control period (s): `1 / run.tick_hz`, the time between two readings (0.1 outside a
    /// world). A proportional turn stays stable if its gain times this is at most 1.
    pub tick_s: f32,
}

impl SensorLayout {
    /// The layout of a model with the given sensor settings.
    pub fn of(model: &RobotModel, cfg: &SensorConfig) -> Self {
        let n = cfg.scan_bins.max(1);
        Self {
            proximity_angles: model.proximity_angles.clone(),
            light_angles: model.light_angles.clone(),
            scan_angles: (0..n)
                .map(|i| wrap_angle(TAU * i as f32 / n as f32))
                .collect(),
            scan_range: cfg.scan_range,
            camera_range: cfg.camera_range,
            max_speed: model.max_speed,
            radius: model.radius,
            wheel_distance: model.wheel_distance,
            proximity_range: model.proximity_range,
            proximity_curve: model.proximity_curve,
            beacon_radius: None,
            tick_s: 0.1,
        }
    }

    /// The largest stable gain of a proportional turn, `turn = gain * error`, at this control
    /// period: `gain`, or `1 / tick_s` if that is less (a turn that, held for a tick, would
    /// overshoot the error it corrects makes the heading swing; at 1 Hz the built-in
    /// controllers' gain of 3 turned robots back and forth by 170 degrees each tick).
    pub fn turn_gain(&self, gain: f32) -> f32 {
        if self.tick_s > 0.0 {
            gain.min(1.0 / self.tick_s)
        } else {
            gain
        }
    }
}

/// Which sensors a controller uses; the others are not computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SensorNeeds {
    /// IR proximity.
    pub proximity: bool,
    /// Light sensors.
    pub light: bool,
    /// Object beacon.
    pub beacon: bool,
    /// Colour-blob camera.
    pub camera: bool,
    /// Colour scan.
    pub scan: bool,
}

/// A light in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Floor position.
    pub position: Vec2,
    /// Height (m).
    pub height: f32,
    /// Intensity.
    pub intensity: f32,
    /// Colour the blob camera sees it in ([`Color::Off`]: not seen by cameras).
    pub color: Color,
}

/// What the world tells the sensors, besides the physics.
pub struct SenseContext<'a> {
    /// Geometry and ray casts.
    pub physics: &'a Physics,
    /// Lights.
    pub lights: &'a [Light],
    /// Height of the body behind a tag.
    pub height: &'a (dyn Fn(Tag) -> f32 + Sync),
    /// Colour of a tag as cameras see it (robots: their LEDs, `Off` when unlit; walls: grey).
    pub color: &'a (dyn Fn(Tag) -> Color + Sync),
    /// Centre and radius of each robot (by index; unreleased robots are never asked).
    pub robots: &'a [(Vec2, f32)],
    /// The object beacons: the movable objects' centres (the target object's when none is
    /// movable).
    pub beacons: &'a Beacons,
    /// Height of the tallest robot (m): beyond where a light ray rises above it, robots need
    /// not be checked.
    pub robot_height: f32,
    /// Per light (same order as `lights`), the walls and objects by direction from it, or
    /// empty to test every fixture.
    pub shadows: &'a [Shadows],
}

/// The explicit occlusion rule. A ray runs from the sensor at `sensor_height` to a light at
/// `light_height`, `light_dist` away on the floor. A body entered at floor distance `t` blocks
/// it when the body is taller than the ray there (the entry point is the ray's lowest point
/// inside the body, since the ray rises toward the light).
pub fn light_blocked(
    sensor_height: f32,
    light_height: f32,
    light_dist: f32,
    t: f32,
    body_height: f32,
) -> bool {
    let h = sensor_height + (light_height - sensor_height) * (t / light_dist.max(1e-6));
    body_height > h
}

/// The same rule for any line of sight: from `from_height` to `to_height`, `dist` away on the
/// floor, through a body of `body_height` that the line enters at floor distance `t_in` and
/// leaves at `t_out`. The body blocks it when it is taller than the line at the line's lowest
/// point inside it (one of the two ends, the line being straight).
pub fn sight_blocked(
    from_height: f32,
    to_height: f32,
    dist: f32,
    t_in: f32,
    t_out: f32,
    body_height: f32,
) -> bool {
    let h = |t: f32| from_height + (to_height - from_height) * (t / dist.max(1e-6));
    body_height > h(t_in).min(h(t_out))
}

/// Points (the object beacons) and a grid of them that finds the nearest to a robot in about
/// constant time, however many there are.
#[derive(Debug, Default, Clone)]
pub struct Beacons {
    points: Vec<Vec2>,
    min: Vec2,
    cell: f32,
    nx: usize,
    ny: usize,
    /// `starts[c]..starts[c + 1]` index `order` for cell `c`.
    starts: Vec<u32>,
    /// Point indices sorted by cell.
    order: Vec<u32>,
}

impl Beacons {
    /// Sets the points (and rebuilds the grid).
    pub fn set(&mut self, points: impl IntoIterator<Item = Vec2>) {
        self.points.clear();
        self.points.extend(points);
        self.starts.clear();
        self.order.clear();
        let n = self.points.len();
        if n <= 4 {
            return;
        }
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for p in &self.points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let span = (hi - lo).max(Vec2::splat(1e-3));
        // About one point per cell.
        self.cell = (span.x * span.y / n as f32)
            .sqrt()
            .max(span.x.max(span.y) / 1024.0);
        self.min = lo;
        self.nx = (span.x / self.cell) as usize + 1;
        self.ny = (span.y / self.cell) as usize + 1;
        self.starts.resize(self.nx * self.ny + 1, 0);
        let cells: Vec<usize> = self.points.iter().map(|p| self.cell_of(*p)).collect();
        for &c in &cells {
            self.starts[c + 1] += 1;
        }
        for c in 0..self.nx * self.ny {
            self.starts[c + 1] += self.starts[c];
        }
        let mut fill = self.starts.clone();
        self.order.resize(n, 0);
        for (i, &c) in cells.iter().enumerate() {
            self.order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
    }

    /// The points.
    pub fn points(&self) -> &[Vec2] {
        &self.points
    }

    fn cell_xy(&self, p: Vec2) -> (usize, usize) {
        let d = (p - self.min) / self.cell;
        (
            (d.x.max(0.0) as usize).min(self.nx - 1),
            (d.y.max(0.0) as usize).min(self.ny - 1),
        )
    }

    fn cell_of(&self, p: Vec2) -> usize {
        let (x, y) = self.cell_xy(p);
        y * self.nx + x
    }

    /// The point nearest to `p` (the first in order among equally near ones).
    pub fn nearest(&self, p: Vec2) -> Option<Vec2> {
        let better = |best: Option<(f32, u32)>, i: u32| {
            let d = (self.points[i as usize] - p).length_squared();
            match best {
                Some((bd, bi)) if (bd, bi) <= (d, i) => best,
                _ => Some((d, i)),
            }
        };
        let mut best = None;
        if self.starts.is_empty() {
            for i in 0..self.points.len() {
                best = better(best, i as u32);
            }
            return best.map(|(_, i)| self.points[i as usize]);
        }
        let (cx, cy) = self.cell_xy(p);
        for k in 0..self.nx.max(self.ny) {
            let (x0, x1) = (cx.saturating_sub(k), (cx + k).min(self.nx - 1));
            let (y0, y1) = (cy.saturating_sub(k), (cy + k).min(self.ny - 1));
            for y in y0..=y1 {
                let edge_row = y + k == cy || y == cy + k;
                for x in x0..=x1 {
                    // Only the ring at Chebyshev distance k (the inside was searched).
                    if !edge_row && x + k != cx && x != cx + k {
                        continue;
                    }
                    let c = y * self.nx + x;
                    for &i in &self.order[self.starts[c] as usize..self.starts[c + 1] as usize] {
                        best = better(best, i);
                    }
                }
            }
            // Every point not yet seen lies in a cell beyond a side of the searched square
            // that has cells beyond it (the border cells hold the points beyond the grid too),
            // so at least `margin` away (less 0.1 mm for rounding).
            let lo = self.min + Vec2::new(x0 as f32, y0 as f32) * self.cell;
            let hi = self.min + Vec2::new(x1 as f32 + 1.0, y1 as f32 + 1.0) * self.cell;
            let mut margin = f32::INFINITY;
            if x0 > 0 {
                margin = margin.min(p.x - lo.x);
            }
            if y0 > 0 {
                margin = margin.min(p.y - lo.y);
            }
            if x1 + 1 < self.nx {
                margin = margin.min(hi.x - p.x);
            }
            if y1 + 1 < self.ny {
                margin = margin.min(hi.y - p.y);
            }
            if margin == f32::INFINITY {
                break;
            }
            if let Some((bd, _)) = best {
                let m = margin - 1e-4;
                if m > 0.0 && bd < m * m {
                    break;
                }
            }
        }
        best.map(|(_, i)| self.points[i as usize])
    }
}

/// A pseudo-angle of `v` in [0, 4): increasing with the angle from +x, cheaper than `atan2`
/// (the "diamond angle").
fn diamond(v: Vec2) -> f32 {
    let s = v.x.abs() + v.y.abs();
    if s == 0.0 {
        return 0.0;
    }
    match (v.x >= 0.0, v.y >= 0.0) {
        (true, true) => v.y / s,
        (false, true) => 1.0 - v.x / s,
        (false, false) => 2.0 - v.y / s,
        (true, false) => 3.0 + v.x / s,
    }
}

/// The walls and objects as seen from one light: which of them lie in each direction from it
/// (by pseudo-angle bins), and how near to the light each comes. A ray from a robot to the
/// light can only enter a fixture whose directions include the robot's and that comes at
/// least as near to the light as the robot is, so the light's occlusion test asks only those
/// (the same exact ray test, on far fewer bodies).
#[derive(Debug, Default, Clone)]
pub struct Shadows {
    light: Vec2,
    bins: usize,
    /// Fixtures the light is inside of (or next to): asked always, with their distance.
    always: Vec<(u32, f32)>,
    /// `starts[b]..starts[b + 1]` index `items` for bin `b`.
    starts: Vec<u32>,
    /// (fixture index, its nearest distance to the light).
    items: Vec<(u32, f32)>,
    spans: Vec<(i64, i64, f32)>,
}

/// Slack of the direction bins (pseudo-angle units, about radians), far above rounding.
const SHADOW_SLACK: f32 = 1e-3;

impl Shadows {
    /// Rebuilds for a light at `light` and fixture boxes `boxes` (lower, upper corners), in
    /// fixture order.
    pub fn build(&mut self, light: Vec2, boxes: impl ExactSizeIterator<Item = (Vec2, Vec2)>) {
        self.light = light;
        self.always.clear();
        self.items.clear();
        self.spans.clear();
        self.bins = (8 * boxes.len()).clamp(64, 1 << 16);
        let k = self.bins as f32 / 4.0;
        for (i, (lo, hi)) in boxes.enumerate() {
            let near = light.clamp(lo, hi);
            let dmin = (near - light).length();
            let pad = Vec2::splat(1e-3);
            if light.cmpge(lo - pad).all() && light.cmple(hi + pad).all() {
                self.always.push((i as u32, dmin));
                self.spans.push((1, 0, 0.0));
                continue;
            }
            let pc = diamond((lo + hi) * 0.5 - light);
            let (mut a, mut b) = (0.0f32, 0.0f32);
            for c in [lo, hi, Vec2::new(lo.x, hi.y), Vec2::new(hi.x, lo.y)] {
                let mut d = diamond(c - light) - pc;
                if d >= 2.0 {
                    d -= 4.0;
                } else if d < -2.0 {
                    d += 4.0;
                }
                a = a.min(d);
                b = b.max(d);
            }
            let b0 = ((pc + a - SHADOW_SLACK) * k).floor() as i64;
            let b1 = ((pc + b + SHADOW_SLACK) * k).floor() as i64;
            if b1 - b0 + 1 >= self.bins as i64 {
                self.always.push((i as u32, dmin));
                self.spans.push((1, 0, 0.0));
                continue;
            }
            self.spans.push((b0, b1, dmin));
        }
        self.starts.clear();
        self.starts.resize(self.bins + 1, 0);
        let n = self.bins as i64;
        for &(b0, b1, _) in &self.spans {
            for b in b0..=b1 {
                self.starts[b.rem_euclid(n) as usize + 1] += 1;
            }
        }
        for b in 0..self.bins {
            self.starts[b + 1] += self.starts[b];
        }
        let mut fill = self.starts.clone();
        self.items.resize(self.starts[self.bins] as usize, (0, 0.0));
        for (i, &(b0, b1, d)) in self.spans.iter().enumerate() {
            for b in b0..=b1 {
                let c = b.rem_euclid(n) as usize;
                self.items[fill[c] as usize] = (i as u32, d);
                fill[c] += 1;
            }
        }
    }

    /// Calls `f` with each fixture (index, in no set order) that the segment from `p` to the
    /// light, `dist` long, may enter; stops and returns true when `f` does.
    pub fn any_toward(&self, p: Vec2, dist: f32, mut f: impl FnMut(usize) -> bool) -> bool {
        let reach = dist + 1e-3 * (1.0 + dist);
        for &(i, d) in &self.always {
            if d <= reach && f(i as usize) {
                return true;
            }
        }
        let k = self.bins as f32 / 4.0;
        let b = ((diamond(p - self.light) * k) as usize).min(self.bins - 1);
        let (s, e) = (self.starts[b] as usize, self.starts[b + 1] as usize);
        for &(i, d) in &self.items[s..e] {
            if d <= reach && f(i as usize) {
                return true;
            }
        }
        false
    }
}

/// Per-robot scratch space reused across ticks (no allocation in the hot loop).
#[derive(Debug, Default)]
pub struct Scratch {
    near: Vec<Nearby>,
    /// Colour scan: first hit per bin (distance, index into `near`).
    scan: Vec<(f32, usize)>,
    /// Colour scan: the bins' ray directions.
    rays: Vec<Vec2>,
}

/// Computes one robot's readings in place.
#[expect(
    clippy::too_many_arguments,
    reason = "one call site; the arguments are the sensor inputs"
)]
pub fn sense(
    ctx: &SenseContext<'_>,
    model: &RobotModel,
    needs: SensorNeeds,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    scratch: &mut Scratch,
    rng: &mut impl Rng,
    out: &mut Readings,
) {
    let nz = &cfg.noise;
    let center = pose.position();
    let mut gauss = noise::Gauss::new(rng);
    let rng = &mut gauss;
    // Positioning.
    out.pose = Pose::new(
        rng.add(pose.x, nz.position_noise),
        rng.add(pose.y, nz.position_noise),
        rng.angle(pose.theta, nz.heading_noise),
    );
    let beacon = if needs.beacon {
        ctx.beacons.nearest(center)
    } else {
        None
    };
    out.beacon = match beacon {
        Some(b) if (b - center).length() <= cfg.beacon_range => Some(Vec2::new(
            rng.add(b.x, nz.beacon_noise),
            rng.add(b.y, nz.beacon_noise),
        )),
        _ => None,
    };

    out.proximity.clear();
    if needs.proximity {
        proximity(ctx, model, cfg, me, pose, scratch, rng, &mut out.proximity);
    }
    out.light.clear();
    if needs.light {
        light(ctx, model, cfg, me, pose, scratch, rng, &mut out.light);
    }
    out.blobs.clear();
    if needs.camera {
        match cfg.camera {
            CameraKind::Blob => {
                blob_camera(ctx, model, cfg, me, pose, scratch, rng, &mut out.blobs)
            }
            CameraKind::Oracle => {
                oracle_camera(ctx, model, cfg, me, pose, scratch, rng, &mut out.blobs);
            }
        }
        out.blobs.sort_by(|a, b| a.distance.total_cmp(&b.distance));
        out.blobs.truncate(MAX_BLOBS);
        if ctx.lights.iter().any(|l| l.color != Color::Off) {
            light_blobs(ctx, model, cfg, me, pose, scratch, rng, &mut out.blobs);
            out.blobs.sort_by(|a, b| a.distance.total_cmp(&b.distance));
        }
    }
    out.scan_color.clear();
    out.scan_range.clear();
    if needs.scan {
        scan(ctx, cfg, me, pose, scratch, rng, out);
    }
}

/// IR proximity: one box query, then rays against the few shapes found.
#[expect(clippy::too_many_arguments, reason = "private helper of `sense`")]
fn proximity(
    ctx: &SenseContext<'_>,
    model: &RobotModel,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    scratch: &mut Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Vec<f32>,
) {
    let center = pose.position();
    out.resize(model.proximity_angles.len(), 0.0);
    let reach = model.radius + model.proximity_range;
    ctx.physics.nearby(center, reach + 0.01, &mut scratch.near);
    let others = scratch.near.iter().any(|n| n.tag != me);
    if others {
        for (i, a) in model.proximity_angles.iter().enumerate() {
            let dir = ops::unit(pose.theta + a);
            let hit = ctx
                .physics
                .cast_local(&scratch.near, Some(me), center, dir, reach);
            if let Some((k, toi)) = hit {
                let h = (ctx.height)(scratch.near[k].tag);
                if h >= model.proximity_height {
                    let d = (toi - model.radius).max(0.0);
                    out[i] = model.proximity_curve.reading(d, model.proximity_range);
                }
            }
        }
    }
    let nz = &cfg.noise;
    for v in out.iter_mut() {
        *v = rng.intensity(*v, nz.proximity_noise, nz.proximity_floor);
    }
}

/// Light sensors: every light in range and in sight, spread over the ring, plus ambient light.
#[expect(clippy::too_many_arguments, reason = "private helper of `sense`")]
fn light(
    ctx: &SenseContext<'_>,
    model: &RobotModel,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    _scratch: &mut Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Vec<f32>,
) {
    let center = pose.position();
    out.resize(model.light_angles.len(), 0.0);
    for (li, light) in ctx.lights.iter().enumerate() {
        let to = light.position - center;
        let dist = to.length();
        let dh = light.height - model.light_height;
        let d3 = (dist * dist + dh * dh).sqrt();
        let value = RobotModel::light_value(d3, light.intensity);
        if value <= 0.0 || dist < 1e-6 {
            continue;
        }
        let dir = to / dist;
        let blocks = |tag: Tag, t: f32| {
            light_blocked(model.light_height, light.height, dist, t, (ctx.height)(tag))
        };
        // Walls and objects anywhere along the ray (those in the robot's direction from the
        // light, when the light's shadows are known).
        let fixtures = ctx.physics.fixtures();
        let hits = |k: usize| {
            let n = &fixtures[k];
            ctx.physics
                .ray_entry(n, center, dir, dist)
                .is_some_and(|t| blocks(n.tag, t))
        };
        let mut blocked = match ctx.shadows.get(li) {
            Some(sh) => sh.any_toward(center, dist, hits),
            None => (0..fixtures.len()).any(hits),
        };
        // Robots only where the ray is still below the tallest robot: a short stretch.
        if !blocked {
            let rise = (light.height - model.light_height) / dist;
            let reach = if rise > 0.0 {
                ((ctx.robot_height - model.light_height) / rise).clamp(0.0, dist)
            } else {
                dist
            };
            if reach > 0.0 {
                // Only the grid cells along that stretch.
                blocked = ctx.physics.robots_along(center, dir, reach, |n| {
                    n.tag != me
                        && ctx
                            .physics
                            .ray_entry(&n, center, dir, reach)
                            .is_some_and(|t| blocks(n.tag, t))
                });
            }
        }
        if !blocked {
            let bearing = wrap_angle(ops::angle_of(to) - pose.theta);
            model.spread_light(bearing, value, out);
        }
    }
    let nz = &cfg.noise;
    for v in out.iter_mut() {
        let lit = (*v + nz.ambient_light).min(1.0);
        *v = rng.intensity(lit, nz.light_noise, nz.light_floor);
    }
}

/// The colour-blob camera as ARGoS has it: lit LEDs of other robots within range whose line of
/// sight (camera height to LED height) no taller body cuts.
#[expect(clippy::too_many_arguments, reason = "private helper of `sense`")]
fn blob_camera(
    ctx: &SenseContext<'_>,
    model: &RobotModel,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    scratch: &mut Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Vec<Blob>,
) {
    let center = pose.position();
    let range = cfg.camera_range;
    ctx.physics.nearby(center, range, &mut scratch.near);
    let near = &scratch.near;
    for n in near {
        let Tag::Robot(j) = n.tag else { continue };
        if n.tag == me {
            continue;
        }
        let color = (ctx.color)(n.tag);
        if matches!(color, Color::Off | Color::Black) {
            continue;
        }
        let Some(&(target, _)) = ctx.robots.get(j) else {
            continue;
        };
        let to = target - center;
        let dist = to.length();
        if dist > range || dist < 1e-6 {
            continue;
        }
        let dir = to / dist;
        // The LEDs are at the other robot's `led_height`; robots of one group share a model,
        // and groups mixing models are rare: the viewer's own model stands in for it.
        let led_h = model.led_height;
        let sight = Sight {
            from: center,
            to: target,
            dir,
            dist,
            from_h: model.camera_height,
            to_h: led_h,
        };
        if sight.cut(ctx, near, &[me, n.tag]) {
            continue;
        }
        let nz = &cfg.noise;
        out.push(Blob {
            bearing: rng.angle(ops::angle_of(to) - pose.theta, nz.camera_noise),
            distance: rng.distance(dist, nz.camera_distance_noise),
            color,
        });
    }
}

/// A line of sight from a camera at `from` (height `from_h`) to a point `to` at height `to_h`,
/// `dist` apart along the unit `dir`.
struct Sight {
    from: Vec2,
    to: Vec2,
    dir: Vec2,
    dist: f32,
    from_h: f32,
    to_h: f32,
}

impl Sight {
    /// Whether a body of `near` other than those tagged `skip` is tall enough where the line
    /// crosses it to cut the line ([`sight_blocked`]).
    fn cut(&self, ctx: &SenseContext<'_>, near: &[Nearby], skip: &[Tag]) -> bool {
        let (dir, dist) = (self.dir, self.dist);
        near.iter().any(|m| {
            if skip.contains(&m.tag) || misses(ctx, m, self.from, dir, dist) {
                return false;
            }
            let Some(t_in) = ctx.physics.ray_entry(m, self.from, dir, dist) else {
                return false;
            };
            let t_out = ctx
                .physics
                .ray_entry(m, self.to, -dir, dist)
                .map_or(t_in, |s| dist - s);
            sight_blocked(
                self.from_h,
                self.to_h,
                dist,
                t_in,
                t_out,
                (ctx.height)(m.tag),
            )
        })
    }
}

/// Whether a body surely misses the segment from `from` along `dir` (unit) for `len`: a cheap
/// test before the exact ray cast (a robot's disc, or a wall's or object's bounding box).
fn misses(ctx: &SenseContext<'_>, n: &Nearby, from: Vec2, dir: Vec2, len: f32) -> bool {
    let Tag::Robot(q) = n.tag else {
        let Some((lo, hi)) = ctx.physics.fixture_box_of(n) else {
            return false;
        };
        let to = from + dir * len;
        let m = 1e-4;
        return from.x.max(to.x) < lo.x - m
            || from.x.min(to.x) > hi.x + m
            || from.y.max(to.y) < lo.y - m
            || from.y.min(to.y) > hi.y + m;
    };
    let Some(&(p, r)) = ctx.robots.get(q) else {
        return false;
    };
    let rel = p - from;
    let t = rel.dot(dir);
    let r = r * 1.001 + 1e-4;
    t < -r || t > len + r || (rel - dir * t).length() > r
}

/// Coloured lights (a goal region of a colour, as Queiroz and MacRae's) as blobs: each light
/// with a colour within the camera's range whose line of sight (camera height to the light's
/// height) no taller body cuts; the distance is to its floor point. Uses the bodies the camera
/// found near the robot (`scratch.near`).
#[expect(clippy::too_many_arguments, reason = "private helper of `sense`")]
fn light_blobs(
    ctx: &SenseContext<'_>,
    model: &RobotModel,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    scratch: &Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Vec<Blob>,
) {
    let center = pose.position();
    for light in ctx.lights {
        if light.color == Color::Off {
            continue;
        }
        let to = light.position - center;
        let dist = to.length();
        if dist > cfg.camera_range {
            continue;
        }
        if dist > 1e-6 {
            let sight = Sight {
                from: center,
                to: light.position,
                dir: to / dist,
                dist,
                from_h: model.camera_height,
                to_h: light.height,
            };
            if sight.cut(ctx, &scratch.near, &[me]) {
                continue;
            }
        }
        let nz = &cfg.noise;
        out.push(Blob {
            bearing: rng.angle(ops::angle_of(to) - pose.theta, nz.camera_noise),
            distance: rng.distance(dist, nz.camera_distance_noise),
            color: light.color,
        });
    }
}

/// The oracle camera (an ablation): every coloured body in range, robots by their LEDs and
/// objects by their colour, with the distance to its nearest surface point; hidden only by
/// what the ray meets first unless that is lower than both the camera and the target.
#[expect(clippy::too_many_arguments, reason = "private helper of `sense`")]
fn oracle_camera(
    ctx: &SenseContext<'_>,
    model: &RobotModel,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    scratch: &mut Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Vec<Blob>,
) {
    let center = pose.position();
    let range = cfg.camera_range;
    ctx.physics.nearby(center, range, &mut scratch.near);
    for k in 0..scratch.near.len() {
        let n = scratch.near[k];
        if n.tag == me || matches!(n.tag, Tag::Wall(_)) {
            continue;
        }
        let color = (ctx.color)(n.tag);
        if matches!(color, Color::Off | Color::Black) {
            continue;
        }
        let target = ctx.physics.nearest_point_of(&n, center);
        let to = target - center;
        let dist = to.length();
        if dist > range || dist < 1e-6 {
            continue;
        }
        let dir = to / dist;
        let first = ctx
            .physics
            .cast_local(&scratch.near, Some(me), center, dir, dist + 0.01);
        let visible = match first {
            Some((j, t)) => {
                j == k
                    || t >= dist - 1e-3
                    || (ctx.height)(scratch.near[j].tag)
                        < (ctx.height)(n.tag).min(model.camera_height)
            }
            None => true,
        };
        if !visible {
            continue;
        }
        let nz = &cfg.noise;
        out.push(Blob {
            bearing: rng.angle(ops::angle_of(to) - pose.theta, nz.camera_noise),
            distance: rng.distance(dist, nz.camera_distance_noise),
            color,
        });
    }
}

/// The bearings (robot frame) under which a box `(min, max)` lies as seen from `center`: the
/// middle bearing and the half-width (rad), widened by a milliradian so that rays grazing a
/// corner stay in; `None` without a box or from inside it.
fn bearing_span(b: Option<(Vec2, Vec2)>, center: Vec2, heading: f32) -> Option<(f32, f32)> {
    let (lo, hi) = b?;
    if center.x >= lo.x && center.x <= hi.x && center.y >= lo.y && center.y <= hi.y {
        return None;
    }
    let mid = ops::angle_of((lo + hi) * 0.5 - center);
    let (mut a, mut z) = (0.0f32, 0.0f32);
    for c in [lo, hi, Vec2::new(lo.x, hi.y), Vec2::new(hi.x, lo.y)] {
        let o = wrap_angle(ops::angle_of(c - center) - mid);
        a = a.min(o);
        z = z.max(o);
    }
    Some((
        wrap_angle(mid + (a + z) / 2.0 - heading),
        (z - a) / 2.0 + 1e-3,
    ))
}

/// The colour scan: per bin, the first body its ray meets within range. Robots are cast only
/// in the bins their disc spans; walls and objects (few) in every bin.
fn scan(
    ctx: &SenseContext<'_>,
    cfg: &SensorConfig,
    me: Tag,
    pose: Pose,
    scratch: &mut Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Readings,
) {
    let center = pose.position();
    let bins = cfg.scan_bins.max(1);
    let range = cfg.scan_range;
    let width = TAU / bins as f32;
    ctx.physics.nearby(center, range, &mut scratch.near);
    scratch.scan.clear();
    scratch.scan.resize(bins, (f32::INFINITY, usize::MAX));
    // Each bin's ray direction, computed when first needed (NaN until then).
    scratch.rays.clear();
    scratch.rays.resize(bins, Vec2::NAN);
    let rays = std::cell::RefCell::new(std::mem::take(&mut scratch.rays));
    let ray = |i: usize| {
        let mut r = rays.borrow_mut();
        if r[i].x.is_nan() {
            r[i] = ops::unit(pose.theta + width * i as f32);
        }
        r[i]
    };
    // Robots first: they are cheap to cast and, being near, shorten the rays cast at walls and
    // objects after them. Each bin keeps the nearest hit, the lowest index among equals, which
    // does not depend on the order the bodies are tried in.
    let robots_first = scratch
        .near
        .iter()
        .enumerate()
        .filter(|(_, n)| matches!(n.tag, Tag::Robot(_)))
        .chain(
            scratch
                .near
                .iter()
                .enumerate()
                .filter(|(_, n)| !matches!(n.tag, Tag::Robot(_))),
        );
    for (k, n) in robots_first {
        if n.tag == me {
            continue;
        }
        let try_bin = |i: usize, best: &mut [(f32, usize)]| {
            // Just past the best so far: a compound shape reports only hits strictly before
            // its limit, and a body met at the same distance with a lower index must win.
            let limit = best[i].0.next_up().min(range);
            if let Some(t) = ctx.physics.ray_entry(n, center, ray(i), limit) {
                if t < best[i].0 || (t == best[i].0 && k < best[i].1) {
                    best[i] = (t, k);
                }
            }
        };
        match n.tag {
            Tag::Robot(j) => {
                let Some(&(p, r)) = ctx.robots.get(j) else {
                    continue;
                };
                let to = p - center;
                let d = to.length();
                if d - r > range {
                    continue;
                }
                let half = if d <= r { PI } else { ops::asin(r / d) };
                let a = wrap_angle(ops::angle_of(to) - pose.theta);
                let lo = ((a - half) / width).ceil() as i64;
                let hi = ((a + half) / width).floor() as i64;
                for b in lo..=hi.min(lo + bins as i64 - 1) {
                    try_bin(b.rem_euclid(bins as i64) as usize, &mut scratch.scan);
                }
            }
            Tag::Wall(_) | Tag::Object(_) => {
                // Only the bins whose rays can meet its bounding box (all of them from inside).
                match bearing_span(ctx.physics.fixture_box_of(n), center, pose.theta) {
                    Some((a, half)) => {
                        let lo = ((a - half) / width).ceil() as i64;
                        let hi = ((a + half) / width).floor() as i64;
                        for b in lo..=hi.min(lo + bins as i64 - 1) {
                            try_bin(b.rem_euclid(bins as i64) as usize, &mut scratch.scan);
                        }
                    }
                    None => {
                        for i in 0..bins {
                            try_bin(i, &mut scratch.scan);
                        }
                    }
                }
            }
        }
    }
    scratch.rays = rays.into_inner();
    let step = cfg.scan_step;
    for &(t, k) in &scratch.scan {
        if k == usize::MAX {
            out.scan_color.push(Color::Off);
            out.scan_range.push(range);
            continue;
        }
        let tag = scratch.near[k].tag;
        let color = match (tag, (ctx.color)(tag)) {
            (Tag::Robot(_), Color::Off) => Color::Black,
            (Tag::Wall(_), _) => Color::Grey,
            (_, c) => c,
        };
        let mut d = rng.distance(t, cfg.noise.scan_noise);
        if step > 0.0 {
            d = (d / step).round() * step;
        }
        out.scan_color.push(color);
        out.scan_range.push(d.clamp(0.0, range));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The grid search finds what a scan of every point finds (the first of equally near),
    /// for points inside and far outside the grid.
    #[test]
    fn nearest_beacon_matches_a_full_scan() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        for n in [1, 3, 5, 17, 200] {
            let pts: Vec<Vec2> = (0..n)
                .map(|_| Vec2::new(rng.random_range(-20.0..20.0), rng.random_range(-5.0..5.0)))
                .collect();
            let mut b = Beacons::default();
            b.set(pts.iter().copied());
            for _ in 0..2000 {
                let p = Vec2::new(rng.random_range(-40.0..40.0), rng.random_range(-30.0..30.0));
                let mut best = (f32::MAX, 0);
                for (i, q) in pts.iter().enumerate() {
                    let d = (*q - p).length_squared();
                    if d < best.0 {
                        best = (d, i);
                    }
                }
                assert_eq!(b.nearest(p), Some(pts[best.1]), "{n} points, at {p:?}");
            }
        }
    }

    /// The direction index offers every fixture a ray to the light enters.
    #[test]
    fn shadows_offer_every_box_the_ray_meets() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(4);
        let boxes: Vec<(Vec2, Vec2)> = (0..60)
            .map(|_| {
                let c = Vec2::new(rng.random_range(-30.0..30.0), rng.random_range(-20.0..20.0));
                let h = Vec2::new(rng.random_range(0.05..2.0), rng.random_range(0.05..2.0));
                (c - h, c + h)
            })
            .collect();
        let light = Vec2::new(25.0, 0.0);
        let mut sh = Shadows::default();
        sh.build(light, boxes.iter().copied());
        for _ in 0..3000 {
            let p = Vec2::new(rng.random_range(-31.0..31.0), rng.random_range(-21.0..21.0));
            let dist = (light - p).length();
            let mut offered = vec![false; boxes.len()];
            sh.any_toward(p, dist, |i| {
                offered[i] = true;
                false
            });
            for (i, (lo, hi)) in boxes.iter().enumerate() {
                // Sample the segment: a point inside the box must have been offered.
                let meets = (0..=400).any(|k| {
                    let q = p + (light - p) * (k as f32 / 400.0);
                    q.cmpge(*lo).all() && q.cmple(*hi).all()
                });
                assert!(!meets || offered[i], "box {i} from {p:?}");
            }
        }
    }
}
