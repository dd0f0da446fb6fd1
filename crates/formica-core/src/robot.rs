//! Robot models (body, drive and sensor layouts) and the built-in ones: Khepera IV, foot-bot,
//! e-puck.
//!
//! Figures come from ARGoS 3's models of these robots (its Khepera IV plugin, the foot-bot and
//! the e-puck) and the robots' published specifications.

use crate::ops;
use crate::registry::{Registry, RegistryError};
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;

/// Rolling resistance of wheels with the motors off, as a fraction of the drive force (see
/// [`RobotModel::coast_force`]).
pub const COAST_FRACTION: f32 = 0.1;

/// Which built-in robot a group uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// K-Team Khepera IV (the seed paper's robot).
    #[default]
    Khepera4,
    /// ARGoS foot-bot.
    FootBot,
    /// e-puck (Chen et al.'s robot).
    EPuck,
}

/// How an IR proximity sensor turns a distance into a reading in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ProximityCurve {
    /// Khepera IV: 1 below `near`, `a * exp(-b d) - c` up to the range, 0 beyond.
    Exponential {
        /// Distance below which the reading saturates at 1.
        near: f32,
        /// Gain.
        a: f32,
        /// Decay per metre.
        b: f32,
        /// Offset.
        c: f32,
    },
    /// Foot-bot: 1 below `near`, `k / (d + e)` beyond.
    Inverse {
        /// Distance below which the reading saturates at 1.
        near: f32,
        /// Numerator.
        k: f32,
        /// Denominator offset.
        e: f32,
    },
    /// Linear fall-off from 1 at the body to 0 at the range (e-puck approximation).
    Linear,
}

impl ProximityCurve {
    /// Reading for a hit at distance `d` beyond the body, with the sensor's `range`.
    pub fn reading(&self, d: f32, range: f32) -> f32 {
        if d > range {
            return 0.0;
        }
        let v = match *self {
            ProximityCurve::Exponential { near, a, b, c } => {
                if d < near {
                    1.0
                } else {
                    a * ops::exp(-b * d) - c
                }
            }
            ProximityCurve::Inverse { near, k, e } => {
                if d < near {
                    1.0
                } else {
                    k / (d + e)
                }
            }
            ProximityCurve::Linear => 1.0 - d.max(0.0) / range,
        };
        v.clamp(0.0, 1.0)
    }

    /// The distance beyond the body (m) that a reading `v` stands for, with the sensor's
    /// `range`: the curve's inverse, clamped to 0 to `range`. A saturated reading (1 or more)
    /// reads 0, nothing (0 or less) the range.
    pub fn distance(&self, v: f32, range: f32) -> f32 {
        if v <= 0.0 {
            return range;
        }
        if v >= 1.0 {
            return 0.0;
        }
        let d = match *self {
            ProximityCurve::Exponential { a, b, c, .. } => -ops::ln((v + c) / a) / b,
            ProximityCurve::Inverse { k, e, .. } => k / v - e,
            ProximityCurve::Linear => (1.0 - v) * range,
        };
        d.clamp(0.0, range)
    }
}

/// A robot model: body, drive limits and sensor layout. A scenario names one registered in its
/// [`Registry`] (`model = "..."`); a new model usually starts from a built-in one:
/// `RobotModel { max_speed: 0.3, ..RobotModel::khepera4() }`.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotModel {
    /// The built-in model this one is or derives from: a label only, nothing depends on it (the
    /// registered name is [`Group::model_name`](crate::world::Group::model_name)).
    pub kind: ModelKind,
    /// Body radius (m).
    pub radius: f32,
    /// Body height (m).
    pub height: f32,
    /// Mass (kg).
    pub mass: f32,
    /// Distance between the wheels (m).
    pub wheel_distance: f32,
    /// Largest wheel speed (m/s); commands are clamped to it.
    pub max_speed: f32,
    /// Cap on the drive force (N).
    pub max_force: f32,
    /// Cap on the drive torque (N m).
    pub max_torque: f32,
    /// Proximity sensor bearings (rad, robot frame).
    pub proximity_angles: Vec<f32>,
    /// Height of the proximity ring above the floor (m).
    pub proximity_height: f32,
    /// Proximity range beyond the body (m).
    pub proximity_range: f32,
    /// Distance-to-reading curve.
    pub proximity_curve: ProximityCurve,
    /// Light sensor bearings (rad, robot frame).
    pub light_angles: Vec<f32>,
    /// Height of the light sensors above the floor (m).
    pub light_height: f32,
    /// A light's reading spreads over the nearest sensor and this many neighbours each side.
    pub light_spread: usize,
    /// Height of the colour-blob camera and colour scan (m).
    pub camera_height: f32,
    /// Height of the LEDs that cameras see (m).
    pub led_height: f32,
}

fn ring(n: usize, first_deg: f32) -> Vec<f32> {
    (0..n)
        .map(|i| (first_deg + 360.0 * i as f32 / n as f32).to_radians())
        .map(crate::geometry::wrap_angle)
        .collect()
}

impl ModelKind {
    /// Every built-in model, in the order they are registered.
    pub const ALL: [ModelKind; 3] = [ModelKind::Khepera4, ModelKind::FootBot, ModelKind::EPuck];

    /// The name scenarios use for it (`model = "..."`).
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Khepera4 => "khepera4",
            ModelKind::FootBot => "foot-bot",
            ModelKind::EPuck => "e-puck",
        }
    }
}

/// Registers the built-in models under their scenario names (`khepera4`, `foot-bot`, `e-puck`).
pub fn register(registry: &mut Registry) -> Result<(), RegistryError> {
    for kind in ModelKind::ALL {
        registry.model(kind.name(), RobotModel::of(kind))?;
    }
    Ok(())
}

impl RobotModel {
    /// The built-in model of the given kind.
    pub fn of(kind: ModelKind) -> Self {
        match kind {
            ModelKind::Khepera4 => Self::khepera4(),
            ModelKind::FootBot => Self::footbot(),
            ModelKind::EPuck => Self::epuck(),
        }
    }

    /// Khepera IV: disc r = 0.0704 m, 8 IR + 8 light sensors.
    pub fn khepera4() -> Self {
        Self {
            kind: ModelKind::Khepera4,
            radius: 0.0704,
            height: 0.053 + 0.0047,
            mass: 0.4,
            wheel_distance: 0.1054,
            max_speed: 0.8,
            max_force: 1.5,
            max_torque: 1.5,
            proximity_angles: ring(8, 0.0),
            proximity_height: 0.0145,
            proximity_range: 0.12,
            proximity_curve: ProximityCurve::Exponential {
                near: 0.04,
                a: 4.14,
                b: 33.0,
                c: 0.085,
            },
            light_angles: ring(8, 0.0),
            light_height: 0.0145,
            light_spread: 1,
            camera_height: 0.06,
            // Three RGB LEDs on the top plate.
            led_height: 0.053,
        }
    }

    /// ARGoS foot-bot: disc r = 0.085 m, 24 IR + 24 light sensors.
    pub fn footbot() -> Self {
        Self {
            kind: ModelKind::FootBot,
            radius: 0.085_036_76,
            height: 0.146_899_73,
            mass: 1.6,
            wheel_distance: 0.14,
            max_speed: 0.3,
            max_force: 15.0,
            max_torque: 150.0,
            proximity_angles: ring(24, 7.5),
            proximity_height: 0.06,
            proximity_range: 0.1,
            proximity_curve: ProximityCurve::Inverse {
                near: 0.009_889_556,
                k: 0.010_052_7,
                e: 0.000_163_144,
            },
            light_angles: ring(24, 7.5),
            light_height: 0.06,
            light_spread: 6,
            camera_height: 0.14,
            // The LED ring round the body.
            led_height: 0.12,
        }
    }

    /// e-puck: disc r = 0.037 m, 8 IR sensors (approximate layout), 8 light sensors.
    pub fn epuck() -> Self {
        Self {
            kind: ModelKind::EPuck,
            radius: 0.037,
            height: 0.05,
            mass: 0.15,
            wheel_distance: 0.053,
            max_speed: 0.13,
            max_force: 0.5,
            max_torque: 0.5,
            proximity_angles: [17.0f32, 49.0, 90.0, 150.0, 210.0, 270.0, 311.0, 343.0]
                .iter()
                .map(|d| crate::geometry::wrap_angle(d.to_radians()))
                .collect(),
            proximity_height: 0.03,
            proximity_range: 0.05,
            proximity_curve: ProximityCurve::Linear,
            light_angles: ring(8, 0.0),
            light_height: 0.03,
            light_spread: 1,
            camera_height: 0.05,
            led_height: 0.045,
        }
    }

    /// Rolling resistance (N) of the wheels with the motors off ([`Physics::drive`]'s `coast`):
    /// [`COAST_FRACTION`] of the drive force. An assumption (a geared motor back-driven), not
    /// a measured figure.
    ///
    /// [`Physics::drive`]: crate::physics::Physics::drive
    pub fn coast_force(&self) -> f32 {
        COAST_FRACTION * self.max_force
    }

    /// Largest torque the wheels resist with when locked (an attached robot braking): the drive
    /// force at the wheels, `max_force * wheel_distance / 2`, or the drive torque if smaller.
    pub fn brake_torque(&self) -> f32 {
        (self.max_force * self.wheel_distance / 2.0).min(self.max_torque)
    }

    /// Distributes a light of strength `value` arriving from `bearing` (robot frame) over the
    /// sensors, adding into `out` (one slot per light sensor).
    pub fn spread_light(&self, bearing: f32, value: f32, out: &mut [f32]) {
        let n = self.light_angles.len();
        if n == 0 || value <= 0.0 {
            return;
        }
        let mut nearest = 0;
        let mut best = f32::MAX;
        for (i, a) in self.light_angles.iter().enumerate() {
            let d = crate::geometry::wrap_angle(bearing - a).abs();
            if d < best {
                best = d;
                nearest = i;
            }
        }
        let k = self.light_spread.min(n / 2);
        for off in -(k as isize)..=(k as isize) {
            let i = (nearest as isize + off).rem_euclid(n as isize) as usize;
            let d = crate::geometry::wrap_angle(bearing - self.light_angles[i]).abs();
            let w = 1.0 - 2.0 * d / PI;
            if w > 0.0 {
                out[i] = (out[i] + value * w).clamp(0.0, 1.0);
            }
        }
    }

    /// Light strength for a light of `intensity` at 3D distance `distance` (before spreading).
    pub fn light_value(distance: f32, intensity: f32) -> f32 {
        if intensity <= 0.0 {
            return 0.0;
        }
        let d = distance / intensity;
        if d <= 2.5 {
            ops::exp(-2.0 * d)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_inverts_every_models_curve() {
        for m in [
            RobotModel::khepera4(),
            RobotModel::footbot(),
            RobotModel::epuck(),
        ] {
            let (c, range) = (m.proximity_curve, m.proximity_range);
            // Where the reading is neither saturated nor nothing, the distance it stands for is
            // the one that gave it, to within a tenth of a millimetre.
            for i in 1..100 {
                let d = range * i as f32 / 100.0;
                let v = c.reading(d, range);
                if v > 0.0 && v < 1.0 {
                    let back = c.distance(v, range);
                    assert!(
                        (back - d).abs() < 1e-4,
                        "{:?}: {d} -> {v} -> {back}",
                        m.kind
                    );
                }
            }
            assert_eq!(c.distance(1.0, range), 0.0);
            assert_eq!(c.distance(0.0, range), range);
            assert_eq!(c.distance(-0.1, range), range);
            assert_eq!(c.distance(1.3, range), 0.0);
        }
    }

    #[test]
    fn khepera_curve_matches_reference_points() {
        let m = RobotModel::khepera4();
        let r = |d| m.proximity_curve.reading(d, m.proximity_range);
        assert_eq!(r(0.02), 1.0);
        assert!((r(0.06) - (4.14 * ops::exp(-33.0f32 * 0.06) - 0.085)).abs() < 1e-6);
        assert_eq!(r(0.13), 0.0);
        // Monotone decreasing over the range.
        let mut last = 1.0;
        for i in 0..=120 {
            let v = r(i as f32 * 0.001);
            assert!(v <= last + 1e-6);
            last = v;
        }
    }

    #[test]
    fn light_spreads_to_nearest_and_neighbours() {
        let m = RobotModel::khepera4();
        let mut out = vec![0.0; 8];
        m.spread_light(0.0, 0.5, &mut out);
        assert!((out[0] - 0.5).abs() < 1e-6);
        assert!((out[1] - 0.25).abs() < 1e-6 && (out[7] - 0.25).abs() < 1e-6);
        assert_eq!(out[4], 0.0);
    }
}
