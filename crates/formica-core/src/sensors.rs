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
//!   every coloured body with the exact distance to its surface.
//! - Colour scan, as Queiroz and MacRae's panoramic cameras: a ring of bearing bins, each the
//!   colour of the first body its ray meets (object colour, LED colour, black for an unlit
//!   robot, grey for a wall, [`Color::Off`] for nothing) and a coarse, noisy range.
//!
//! Noise as the hardware has it (see [`crate::noise`]): relative plus additive on proximity and
//! light (clamped to [0, 1]), additive on positions and bearings, relative on distances.
//!
//! Every reading is a fixed-size vector per robot (sizes in [`SensorLayout`]), except the
//! camera's blobs, a list of at most [`MAX_BLOBS`], nearest first, so that a binding can hand
//! them out as flat arrays `[robots, sensors]`.

use crate::geometry::{wrap_angle, Pose, Vec2};
use crate::noise;
use crate::ops;
use crate::physics::{Nearby, Physics, Tag};
use crate::robot::RobotModel;
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
    /// The object's centre in the world frame, if the robot has the beacon and is in range.
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
    pub height: &'a dyn Fn(Tag) -> f32,
    /// Colour of a tag as cameras see it (robots: their LEDs, `Off` when unlit; walls: grey).
    pub color: &'a dyn Fn(Tag) -> Color,
    /// Centre and radius of each robot (by index; unreleased robots are never asked).
    pub robots: &'a [(Vec2, f32)],
    /// The object beacon: the target object's centre.
    pub beacon: Option<Vec2>,
    /// Height of the tallest robot (m): beyond where a light ray rises above it, robots need
    /// not be checked.
    pub robot_height: f32,
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

/// Per-robot scratch space reused across ticks (no allocation in the hot loop).
#[derive(Debug, Default)]
pub struct Scratch {
    near: Vec<Nearby>,
    /// Colour scan: first hit per bin (distance, index into `near`).
    scan: Vec<(f32, usize)>,
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
    out.beacon = match ctx.beacon {
        Some(b) if needs.beacon && (b - center).length() <= cfg.beacon_range => Some(Vec2::new(
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
    scratch: &mut Scratch,
    rng: &mut noise::Gauss<'_, impl Rng>,
    out: &mut Vec<f32>,
) {
    let center = pose.position();
    out.resize(model.light_angles.len(), 0.0);
    for light in ctx.lights {
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
        // Walls and objects (few) anywhere along the ray.
        let mut blocked = ctx.physics.fixtures().iter().any(|n| {
            ctx.physics
                .ray_entry(n, center, dir, dist)
                .is_some_and(|t| blocks(n.tag, t))
        });
        // Robots only where the ray is still below the tallest robot: a short stretch.
        if !blocked {
            let rise = (light.height - model.light_height) / dist;
            let reach = if rise > 0.0 {
                ((ctx.robot_height - model.light_height) / rise).clamp(0.0, dist)
            } else {
                dist
            };
            if reach > 0.0 {
                let mid = center + dir * (reach / 2.0);
                ctx.physics.nearby(mid, reach / 2.0, &mut scratch.near);
                blocked = scratch.near.iter().any(|n| {
                    n.tag != me
                        && matches!(n.tag, Tag::Robot(_))
                        && ctx
                            .physics
                            .ray_entry(n, center, dir, reach)
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
        let hidden = near.iter().any(|m| {
            if m.tag == me || m.tag == n.tag || misses(ctx, m, center, dir, dist) {
                return false;
            }
            let Some(t_in) = ctx.physics.ray_entry(m, center, dir, dist) else {
                return false;
            };
            let t_out = ctx
                .physics
                .ray_entry(m, target, -dir, dist)
                .map_or(t_in, |s| dist - s);
            sight_blocked(
                model.camera_height,
                led_h,
                dist,
                t_in,
                t_out,
                (ctx.height)(m.tag),
            )
        });
        if hidden {
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

/// Whether a body surely misses the segment from `from` along `dir` (unit) for `len`: a cheap
/// test before the exact ray cast (a robot's disc, or a wall's or object's bounding box).
fn misses(ctx: &SenseContext<'_>, n: &Nearby, from: Vec2, dir: Vec2, len: f32) -> bool {
    let Tag::Robot(q) = n.tag else {
        let Some((lo, hi)) = ctx.physics.fixture_box(n) else {
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
            let dir = to / dist;
            let hidden = scratch.near.iter().any(|m| {
                if m.tag == me || misses(ctx, m, center, dir, dist) {
                    return false;
                }
                let Some(t_in) = ctx.physics.ray_entry(m, center, dir, dist) else {
                    return false;
                };
                let t_out = ctx
                    .physics
                    .ray_entry(m, light.position, -dir, dist)
                    .map_or(t_in, |s| dist - s);
                sight_blocked(
                    model.camera_height,
                    light.height,
                    dist,
                    t_in,
                    t_out,
                    (ctx.height)(m.tag),
                )
            });
            if hidden {
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
    let ray = |i: usize| ops::unit(pose.theta + width * i as f32);
    for (k, n) in scratch.near.iter().enumerate() {
        if n.tag == me {
            continue;
        }
        let try_bin = |i: usize, best: &mut [(f32, usize)]| {
            let limit = best[i].0.min(range);
            if let Some(t) = ctx.physics.ray_entry(n, center, ray(i), limit) {
                if t < best[i].0 {
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
                match bearing_span(ctx.physics.fixture_box(n), center, pose.theta) {
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
