//! `constant`: fixed wheel speeds and LED. For calibration, tests and push experiments.

use crate::controller::{
    parse_params, Actuation, AttachCommand, Controller, ControllerFactory, RobotRng,
};
use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};
use serde::{Deserialize, Serialize};

/// Parameters of `constant`.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Left wheel speed (m/s).
    #[serde(default = "default_speed")]
    pub left: f32,
    /// Right wheel speed (m/s).
    #[serde(default = "default_speed")]
    pub right: f32,
    /// LED colour.
    #[serde(default)]
    pub led: Color,
    /// Attach to whatever the robot touches, as soon as it touches it.
    #[serde(default)]
    pub attach: bool,
    /// Motors off (the wheel speeds are ignored): the wheels roll freely along the heading and
    /// skid sideways.
    #[serde(default)]
    pub coast: bool,
    /// Compute camera readings (for tests and recordings of what robots see).
    #[serde(default)]
    pub camera: bool,
    /// Compute colour-scan readings (likewise).
    #[serde(default)]
    pub scan: bool,
}

fn default_speed() -> f32 {
    0.1
}

/// Builds the factory.
pub fn factory(
    params: Option<&toml::Table>,
    _layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    let p: Params = parse_params(params)?;
    let needs = SensorNeeds {
        camera: p.camera,
        scan: p.scan,
        ..SensorNeeds::default()
    };
    Ok(ControllerFactory::new(needs, move || Box::new(Constant(p))))
}

/// The constant controller.
pub struct Constant(Params);

impl Controller for Constant {
    fn step(&mut self, r: &Readings, _rng: &mut RobotRng) -> Actuation {
        let attach = if self.0.attach && !r.attached {
            AttachCommand::Attach
        } else {
            AttachCommand::Keep
        };
        Actuation {
            left: self.0.left,
            right: self.0.right,
            led: self.0.led,
            attach,
            coast: self.0.coast,
        }
    }
    fn state(&self) -> &'static str {
        "constant"
    }
}
