//! Sensors: what a controller reads ([`Readings`]) and how the simulator computes it
//! ([`sense`]).
//!
//! - IR proximity: one ray per sensor from the body outward, cast only against colliders whose
//!   bounding boxes are near the robot (one box query per robot), through the model's curve.
//! - Light: ARGoS's law, `exp(-2 D / I)`, spread over neighbouring sensors, and blocked by
//!   bodies taller than the line of sight (see [`light_blocked`]).
//! - Positioning (own pose) and an object beacon (the object's centre in the world frame).
//! - Colour-blob camera: bearing, distance and colour of lit LEDs and coloured bodies in range,
//!   hidden by anything in between.
//!
//! Each can carry seeded Gaussian noise.

use crate::geometry::{wrap_angle, Pose, Vec2};
use crate::ops;
use crate::physics::{Nearby, Physics, Tag};
use crate::robot::RobotModel;
use crate::scenario::{Color, SensorOptions};
use rand::Rng;

/// One coloured blob seen by the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blob {
    /// Bearing in the robot's frame (rad, counter-clockwise from straight ahead).
    pub bearing: f32,
    /// Distance from the robot's centre to the nearest point of the seen body (m).
    pub distance: f32,
    /// Colour.
    pub color: Color,
    /// Whether the blob is a robot's LED ring (false: a coloured body such as an object).
    pub is_robot: bool,
}

/// What a controller sees in one tick. Controllers never see the world.
#[derive(Debug, Clone, Default)]
pub struct Readings {
    /// Simulated time (s).
    pub time_s: f32,
    /// Proximity readings in [0, 1], one per sensor (angles in [`SensorLayout`]).
    pub proximity: Vec<f32>,
    /// Light readings in [0, 1], one per sensor.
    pub light: Vec<f32>,
    /// Own pose from the positioning sensor.
    pub pose: Pose,
    /// The object's centre in the world frame, if the robot has the beacon.
    pub beacon: Option<Vec2>,
    /// Camera blobs (empty without a camera).
    pub blobs: Vec<Blob>,
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
    /// The layout of a model.
    pub fn of(model: &RobotModel) -> Self {
        Self {
            proximity_angles: model.proximity_angles.clone(),
            light_angles: model.light_angles.clone(),
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
}

/// What the world tells the sensors, besides the physics.
pub struct SenseContext<'a> {
    /// Geometry and ray casts.
    pub physics: &'a Physics,
    /// Lights.
    pub lights: &'a [Light],
    /// Height of the body behind a tag.
    pub height: &'a dyn Fn(Tag) -> f32,
    /// Colour a camera sees for a tag (robots: their LEDs; `Off` is invisible).
    pub color: &'a dyn Fn(Tag) -> Color,
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

/// Per-robot scratch space reused across ticks (no allocation in the hot loop).
#[derive(Debug, Default)]
pub struct Scratch {
    near: Vec<Nearby>,
}

fn noisy(v: f32, sd: f32, rng: &mut impl Rng) -> f32 {
    ops::gaussian(v, sd, rng)
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
    opts: &SensorOptions,
    me: Tag,
    pose: Pose,
    scratch: &mut Scratch,
    rng: &mut impl Rng,
    out: &mut Readings,
) {
    let center = pose.position();
    // Positioning.
    out.pose = Pose::new(
        noisy(pose.x, opts.position_noise, rng),
        noisy(pose.y, opts.position_noise, rng),
        wrap_angle(noisy(pose.theta, opts.heading_noise, rng)),
    );
    out.beacon = if needs.beacon {
        ctx.beacon.map(|b| {
            Vec2::new(
                noisy(b.x, opts.position_noise, rng),
                noisy(b.y, opts.position_noise, rng),
            )
        })
    } else {
        None
    };

    // Proximity: one box query, then rays against the few shapes found.
    out.proximity.clear();
    if needs.proximity {
        out.proximity.resize(model.proximity_angles.len(), 0.0);
        let reach = model.radius + model.proximity_range;
        ctx.physics.nearby(center, reach + 0.01, &mut scratch.near);
        let others = scratch.near.iter().any(|n| n.tag != me);
        if others {
            for (i, a) in model.proximity_angles.iter().enumerate() {
                let th = pose.theta + a;
                let dir = ops::unit(th);
                let hit = ctx
                    .physics
                    .cast_local(&scratch.near, Some(me), center, dir, reach);
                if let Some((k, toi)) = hit {
                    let h = (ctx.height)(scratch.near[k].tag);
                    if h >= model.proximity_height {
                        let d = (toi - model.radius).max(0.0);
                        out.proximity[i] = model.proximity_curve.reading(d, model.proximity_range);
                    }
                }
            }
        }
        if opts.proximity_noise > 0.0 {
            for v in &mut out.proximity {
                *v = noisy(*v, opts.proximity_noise, rng).clamp(0.0, 1.0);
            }
        }
    }

    // Light.
    out.light.clear();
    if needs.light {
        out.light.resize(model.light_angles.len(), 0.0);
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
                model.spread_light(bearing, value, &mut out.light);
            }
        }
        if opts.light_noise > 0.0 {
            for v in &mut out.light {
                *v = noisy(*v, opts.light_noise, rng).clamp(0.0, 1.0);
            }
        }
    }

    // Camera.
    out.blobs.clear();
    if needs.camera {
        let range = opts.camera_range;
        ctx.physics.nearby(center, range, &mut scratch.near);
        for k in 0..scratch.near.len() {
            let n = scratch.near[k];
            if n.tag == me {
                continue;
            }
            let color = (ctx.color)(n.tag);
            if color == Color::Off {
                continue;
            }
            let is_robot = matches!(n.tag, Tag::Robot(_));
            let target = ctx.physics.nearest_point_of(&n, center);
            let to = target - center;
            let dist = to.length();
            if dist > range || dist < 1e-6 {
                continue;
            }
            let dir = to / dist;
            // Visible if nothing else is hit first on the way, or if what is hit first is
            // lower than both the camera and the target (the camera sees over it: a tall object
            // stays visible over a ring of robots; robots still hide each other's LEDs).
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
            let bearing = ops::angle_of(to);
            let distance = dist;
            out.blobs.push(Blob {
                bearing: wrap_angle(noisy(bearing - pose.theta, opts.camera_noise, rng)),
                distance: (distance * (1.0 + noisy(0.0, opts.camera_noise, rng))).max(0.0),
                color,
                is_robot,
            });
        }
    }
}
