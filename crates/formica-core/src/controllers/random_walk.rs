//! `random-walk`: wander with obstacle avoidance. A baseline, and the benchmark's load: it
//! reads proximity and light every tick.

use crate::controller::{parse_params, Actuation, Controller, ControllerFactory, RobotRng};
use crate::ops;
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// Parameters of `random-walk`.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Cruise speed (m/s).
    #[serde(default = "default_speed")]
    pub speed: f32,
    /// Mean seconds between random turns.
    #[serde(default = "default_turn_every")]
    pub turn_every_s: f32,
    /// Length of the summed proximity vector (each sensor's reading along its bearing) above
    /// which the robot turns away.
    #[serde(default = "default_avoid")]
    pub avoid_threshold: f32,
}

fn default_speed() -> f32 {
    0.1
}
fn default_turn_every() -> f32 {
    5.0
}
fn default_avoid() -> f32 {
    0.1
}

/// Builds the factory.
pub fn factory(
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let p: Params = parse_params(params)?;
    let layout = layout.clone();
    Ok(ControllerFactory::new(
        SensorNeeds {
            proximity: true,
            light: true,
            ..SensorNeeds::default()
        },
        move || {
            Box::new(RandomWalk {
                p: p.clone(),
                layout: layout.clone(),
                turn_left_s: 0.0,
                turn_rate: 0.0,
                last_time_s: 0.0,
                avoiding: false,
            })
        },
    ))
}

/// The random-walk controller.
pub struct RandomWalk {
    p: Params,
    layout: SensorLayout,
    turn_left_s: f32,
    turn_rate: f32,
    avoiding: bool,
    last_time_s: f32,
}

impl Controller for RandomWalk {
    fn step(&mut self, r: &Readings, rng: &mut RobotRng) -> Actuation {
        let dt = (r.time_s - self.last_time_s).max(0.0);
        self.last_time_s = r.time_s;
        // Sum of proximity vectors: where the obstacles are.
        let (mut sx, mut sy) = (0.0f32, 0.0f32);
        for (v, a) in r.proximity.iter().zip(&self.layout.proximity_angles) {
            sx += v * ops::cos(*a);
            sy += v * ops::sin(*a);
        }
        let strength = (sx * sx + sy * sy).sqrt();
        let led = if crate::controllers::occlusion::light_contrast(&r.light) > 0.1 {
            Color::Yellow
        } else {
            Color::Off
        };
        if strength > self.p.avoid_threshold {
            self.avoiding = true;
            // Turn away from the obstacle side.
            let away = if sy > 0.0 { -1.0 } else { 1.0 };
            let fwd = if sx > 0.0 { 0.0 } else { self.p.speed };
            return Actuation::from_twist(fwd, away * 2.0, &self.layout).with_led(led);
        }
        self.avoiding = false;
        if self.turn_left_s <= 0.0 {
            if rng.random::<f32>() < dt / self.p.turn_every_s.max(0.1) {
                self.turn_left_s = rng.random_range(0.3..1.5);
                self.turn_rate = if rng.random::<bool>() { 1.5 } else { -1.5 };
            }
            Actuation::from_twist(self.p.speed, 0.0, &self.layout).with_led(led)
        } else {
            self.turn_left_s -= dt;
            Actuation::from_twist(self.p.speed * 0.3, self.turn_rate, &self.layout).with_led(led)
        }
    }

    fn state(&self) -> &'static str {
        if self.avoiding {
            "avoid"
        } else if self.turn_left_s > 0.0 {
            "turn"
        } else {
            "walk"
        }
    }
}
