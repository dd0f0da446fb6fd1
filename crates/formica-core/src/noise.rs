//! Sensor noise: the presets per robot model, and how noise is applied to a reading.
//!
//! A scenario picks a preset with `sensors = { noise = "realistic" }` (the default) or asks for
//! a noise-free run with `noise = "none"`; any explicit key (`light_noise = 0.1`, ...) overrides
//! the preset's value. [`NoiseModel`] holds the resolved numbers.
//!
//! **How noise is applied** (as the hardware has it):
//!
//! - IR proximity and light readings are photodiode intensities: their spread grows with the
//!   signal (a relative, *multiplicative* part) on top of a constant electronic floor (an
//!   *additive* part), `v (1 + r e1) + f e2` with `e1`, `e2` standard normal. A reading of
//!   exactly zero (nothing in range) keeps only the floor. The result is clamped to [0, 1], the
//!   range over which the converter saturates.
//! - Light sensors also see **ambient light**, a level added to every sensor before the noise,
//!   so that a light hidden by the object reads low, never exactly zero.
//! - Positioning (own pose), the object beacon and the cameras: additive Gaussian noise on
//!   each coordinate (heading and bearings wrapped to (-pi, pi]); camera and scan distances
//!   carry relative noise.
//!
//! **Where the preset's numbers come from.** The Khepera IV's sensors were characterised on
//! hardware by Soares, Navarro and Martinoli, "The Khepera IV Mobile Robot: Performance
//! Evaluation, Sensory Data and Software Toolbox" (ROBOT 2015, Springer AISC 417, 2016). The
//! copies of that paper reachable from this project hold its first page only, so its figures
//! could not be read; every number below is therefore an assumption, with its reason, chosen on
//! the cautious side so that the behaviours are tested against at least as much noise as the
//! paper is likely to report. Replace them when the paper's values are checked (one table in
//! [`preset`]).
//!
//! | key | Khepera IV preset | reason |
//! |---|---|---|
//! | `proximity_noise` | 0.05 (5 % of the reading) | reflected-IR readings spread with the signal; 5 % is the spread commonly assumed for such sensors and the middle of the range the robustness study sweeps (0-0.2) |
//! | `proximity_floor` | 0.005 (0.5 % of full scale) | a few counts of the 10-bit converter; the Khepera toolbox's own IR response measurement (`jsoares/khepera4toolbox`, `Examples/infrared_proximity_sensor_response`) levels off at about 0.2 % of the saturated value far from any obstacle |
//! | `light_noise` | 0.05 | the light sensors are the same photodiodes read in ambient mode |
//! | `light_floor` | 0.005 | as `proximity_floor` |
//! | `ambient_light` | 0.05 | a lit laboratory: a uniform level well below a goal light's 0.33 at the far end of the seed's arena (5.5 m) |
//! | `position_noise` | 0.01 m | an overhead tracking system, as the seed's "positioning sensor" needs on real robots (about 1 cm) |
//! | `heading_noise` | 0.05 rad (2.9 deg) | the same tracker's heading |
//! | `beacon_noise` | 0.01 m | the object's position from the same tracker |
//! | `camera_noise` | 0.02 rad | blob bearing from a pixel position (a few pixels of an omnidirectional image) |
//! | `camera_distance_noise` | 0.1 (10 %) | blob distance from the blob's image radius: coarse |
//! | `scan_noise` | 0.05 (5 %) | range from the image row of a colour edge (Queiroz & MacRae's panoramic cameras) |
//!
//! Foot-bot and e-puck: no hardware characterisation was found; they take the same relative
//! values (an assumption).

use crate::geometry::wrap_angle;
use crate::ops;
use crate::robot::ModelKind;
use rand::Rng;
use serde::{Deserialize, Serialize};

/// A named set of noise levels.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum NoisePreset {
    /// Noise as measured (or, where no measurement was found, assumed) for the robot model.
    #[default]
    Realistic,
    /// No noise and no ambient light: every reading exact (ask for it explicitly).
    None,
}

impl NoisePreset {
    /// Lower-case name, as in scenario files.
    pub fn name(self) -> &'static str {
        match self {
            NoisePreset::Realistic => "realistic",
            NoisePreset::None => "none",
        }
    }
}

/// Resolved noise levels of one robot group (standard deviations unless said otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NoiseModel {
    /// Proximity: relative spread (fraction of the reading).
    pub proximity_noise: f32,
    /// Proximity: additive spread (reading units).
    pub proximity_floor: f32,
    /// Light: relative spread (fraction of the reading).
    pub light_noise: f32,
    /// Light: additive spread (reading units).
    pub light_floor: f32,
    /// Ambient light level added to every light sensor (reading units).
    pub ambient_light: f32,
    /// Positioning: per coordinate (m).
    pub position_noise: f32,
    /// Positioning: heading (rad).
    pub heading_noise: f32,
    /// Object beacon: per coordinate (m).
    pub beacon_noise: f32,
    /// Blob camera: bearing (rad).
    pub camera_noise: f32,
    /// Blob camera: relative distance spread.
    pub camera_distance_noise: f32,
    /// Colour scan: relative range spread.
    pub scan_noise: f32,
}

/// The noise levels of `preset` for robot model `kind` (see the module documentation for the
/// sources and assumptions).
pub fn preset(kind: ModelKind, preset: NoisePreset) -> NoiseModel {
    match preset {
        NoisePreset::None => NoiseModel::default(),
        NoisePreset::Realistic => {
            let khepera = NoiseModel {
                proximity_noise: 0.05,
                proximity_floor: 0.005,
                light_noise: 0.05,
                light_floor: 0.005,
                ambient_light: 0.05,
                position_noise: 0.01,
                heading_noise: 0.05,
                beacon_noise: 0.01,
                camera_noise: 0.02,
                camera_distance_noise: 0.1,
                scan_noise: 0.05,
            };
            match kind {
                // No hardware characterisation found: the Khepera IV's relative values.
                ModelKind::Khepera4 | ModelKind::FootBot | ModelKind::EPuck => khepera,
            }
        }
    }
}

/// The largest magnitude a [`Gauss::normal`] draw can have: its uniform draws are multiples of
/// 2^-24, so `-2 ln u1 <= 48 ln 2` and `|z| <= 5.77`. Bounds of noisy readings rest on it.
pub const MAX_NORMAL: f32 = 5.8;

/// Standard normal draws for one robot's readings in one tick: the Box–Muller transform of two
/// uniform draws gives two independent normals, and the second is kept for the next call (so
/// noise costs half the transcendental functions). Built on the same portable functions as
/// [`ops::standard_normal`]; the draws depend only on the generator's state, so results stay
/// bit-identical on every platform.
pub struct Gauss<'a, R: Rng> {
    rng: &'a mut R,
    spare: Option<f32>,
}

impl<'a, R: Rng> Gauss<'a, R> {
    /// Draws from `rng`.
    pub fn new(rng: &'a mut R) -> Self {
        Self { rng, spare: None }
    }

    /// A standard normal sample.
    pub fn normal(&mut self) -> f32 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        // u1 in (0, 1], so that ln(u1) is finite.
        let u1 = 1.0 - self.rng.random::<f32>();
        let u2 = self.rng.random::<f32>();
        let r = (-2.0 * ops::ln(u1)).sqrt();
        let (s, c) = ops::sin_cos(std::f32::consts::TAU * u2);
        self.spare = Some(r * s);
        r * c
    }

    /// `v` plus noise of spread `sd` (nothing drawn when `sd` is not positive).
    pub fn add(&mut self, v: f32, sd: f32) -> f32 {
        if sd > 0.0 {
            v + sd * self.normal()
        } else {
            v
        }
    }

    /// A photodiode reading with relative spread `rel` and additive spread `floor`, clamped to
    /// [0, 1]: `v (1 + rel e1) + floor e2`. Draws nothing for a spread that is zero, nor for the
    /// relative part of a zero reading.
    pub fn intensity(&mut self, v: f32, rel: f32, floor: f32) -> f32 {
        let mut x = v;
        if rel > 0.0 && v != 0.0 {
            x += v * rel * self.normal();
        }
        if floor > 0.0 {
            x += floor * self.normal();
        }
        x.clamp(0.0, 1.0)
    }

    /// An angle with additive spread `sd`, wrapped to (-pi, pi].
    pub fn angle(&mut self, a: f32, sd: f32) -> f32 {
        wrap_angle(self.add(a, sd))
    }

    /// A distance with relative spread `rel`, never negative.
    pub fn distance(&mut self, d: f32, rel: f32) -> f32 {
        if rel > 0.0 {
            (d * (1.0 + rel * self.normal())).max(0.0)
        } else {
            d
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn paired_normals_have_unit_spread_and_no_correlation() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let mut g = Gauss::new(&mut rng);
        let n = 100_000;
        let xs: Vec<f64> = (0..n).map(|_| f64::from(g.normal())).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.01 && (var.sqrt() - 1.0).abs() < 0.01,
            "{mean} {var}"
        );
        // The two halves of each pair are uncorrelated.
        let cov = xs.chunks(2).map(|p| p[0] * p[1]).sum::<f64>() / (n / 2) as f64;
        assert!(cov.abs() < 0.015, "covariance {cov}");
    }

    /// A generator whose every draw is all ones: the largest uniform value, so the smallest
    /// `u1` the transform sees.
    struct AllOnes;

    impl rand::RngCore for AllOnes {
        fn next_u32(&mut self) -> u32 {
            u32::MAX
        }
        fn next_u64(&mut self) -> u64 {
            u64::MAX
        }
        fn fill_bytes(&mut self, dst: &mut [u8]) {
            dst.fill(u8::MAX);
        }
    }

    #[test]
    fn no_normal_draw_exceeds_max_normal_and_the_bound_is_tight() {
        let mut rng = AllOnes;
        let mut g = Gauss::new(&mut rng);
        let z = g.normal();
        assert!(z.abs() <= MAX_NORMAL && z.abs() > 5.7, "{z}");
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        let mut g = Gauss::new(&mut rng);
        assert!((0..1_000_000).all(|_| g.normal().abs() <= MAX_NORMAL));
    }
}
