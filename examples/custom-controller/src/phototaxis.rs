//! `phototaxis`: drive toward the brightest light, turn away from obstacles, and wander where no
//! light reaches (in a shadow, or beyond the lights' range).
//!
//! Parameters (all optional):
//!
//! | key | default | meaning |
//! |---|---|---|
//! | `speed` | 0.15 | cruise speed (m/s), at most the model's top speed |
//! | `turn_gain` | 2.0 | turn rate (rad/s) per radian between the heading and the light |
//! | `avoid_threshold` | 0.3 | proximity reading above which the robot turns away |
//! | `dark_below` | 0.02 | total light reading below which the robot wanders |
//!
//! LED: yellow while it homes, off otherwise. States: `homing`, `avoiding`, `wandering`.

use formica::controller::{
    check_params, parse_params, Actuation, Controller, ControllerFactory, RobotRng,
};
use formica::geometry::Vec2;
use formica::ops;
use formica::scenario::Color;
use formica::sensors::{Readings, SensorLayout, SensorNeeds};
use rand::Rng;
use serde::Deserialize;

/// Parameters of `phototaxis`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Cruise speed (m/s).
    #[serde(default = "default_speed")]
    pub speed: f32,
    /// Turn rate per radian of heading error (1/s).
    #[serde(default = "default_turn_gain")]
    pub turn_gain: f32,
    /// Proximity reading above which the robot turns away.
    #[serde(default = "default_avoid")]
    pub avoid_threshold: f32,
    /// Summed light reading below which the robot wanders.
    #[serde(default = "default_dark")]
    pub dark_below: f32,
}

fn default_speed() -> f32 {
    0.15
}
fn default_turn_gain() -> f32 {
    2.0
}
fn default_avoid() -> f32 {
    0.3
}
fn default_dark() -> f32 {
    0.02
}

/// Parses and checks the parameters, and builds the factory: a parameter error comes back as
/// text, which the scenario error places at the group's `params` line.
pub fn factory(
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let p: Params = parse_params(params)?;
    check_params(
        &[("speed", p.speed), ("turn_gain", p.turn_gain)],
        &[
            ("avoid_threshold", p.avoid_threshold),
            ("dark_below", p.dark_below),
        ],
    )?;
    if p.speed > layout.max_speed {
        return Err(format!(
            "`speed` = {} m/s is above this model's top speed of {} m/s",
            p.speed, layout.max_speed
        ));
    }
    let needs = SensorNeeds {
        proximity: true,
        light: true,
        ..SensorNeeds::default()
    };
    let layout = layout.clone();
    Ok(ControllerFactory::new(needs, move || {
        Box::new(Phototaxis {
            p,
            layout: layout.clone(),
            state: "wandering",
            wander_turn: 0.0,
        })
    }))
}

/// The controller of one robot.
pub struct Phototaxis {
    p: Params,
    layout: SensorLayout,
    state: &'static str,
    wander_turn: f32,
}

/// The sum of `values[i]` times the unit vector at `angles[i]`.
fn weighted_direction(values: &[f32], angles: &[f32]) -> Vec2 {
    values
        .iter()
        .zip(angles)
        .fold(Vec2::new(0.0, 0.0), |acc, (&v, &a)| acc + ops::unit(a) * v)
}

impl Controller for Phototaxis {
    fn step(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        let p = self.p;
        let turn_max = 2.0 * p.speed.max(0.05) / self.layout.wheel_distance;
        let near = r.proximity.iter().copied().fold(0.0, f32::max);
        if near > p.avoid_threshold {
            // Turn away from where the proximity readings point; drive on once facing away.
            self.state = "avoiding";
            let toward = weighted_direction(&r.proximity, &self.layout.proximity_angles);
            let away = ops::angle_of(-toward);
            let forward = p.speed * ops::cos(away).max(0.0);
            let turn = (p.turn_gain * away).clamp(-turn_max, turn_max);
            return Actuation::from_twist(forward, turn, &self.layout);
        }
        let light: f32 = r.light.iter().sum();
        if light < p.dark_below {
            // Wander: a new random turn rate now and then, from the robot's own generator.
            self.state = "wandering";
            if rng.random::<f32>() < 0.05 {
                self.wander_turn = rng.random_range(-1.0..1.0) * turn_max / 2.0;
            }
            return Actuation::from_twist(p.speed, self.wander_turn, &self.layout);
        }
        self.state = "homing";
        let bearing = ops::angle_of(weighted_direction(&r.light, &self.layout.light_angles));
        let turn = (p.turn_gain * bearing).clamp(-turn_max, turn_max);
        let forward = p.speed * ops::cos(bearing).max(0.2);
        Actuation::from_twist(forward, turn, &self.layout).with_led(Color::Yellow)
    }

    fn state(&self) -> &'static str {
        self.state
    }
}
