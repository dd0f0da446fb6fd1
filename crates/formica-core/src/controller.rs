//! The controller interface: readings in; wheel speeds, LEDs and attach out.
//!
//! A controller sees only its own [`Readings`] and its [`SensorLayout`], and draws randomness
//! only from the per-robot generator it is handed. It never sees the world.

use crate::scenario::Color;
use crate::sensors::{Readings, SensorLayout, SensorNeeds};

/// The random generator each robot owns (portable and seeded per robot).
pub type RobotRng = rand_pcg::Pcg64Mcg;

/// Attach / detach command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AttachCommand {
    /// Leave as is.
    #[default]
    Keep,
    /// Fix the robot to the body it touches (an object, or a robot already attached to one).
    Attach,
    /// Release the attachment.
    Detach,
}

/// What a controller asks of its actuators for the next tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuation {
    /// Left wheel speed (m/s), clamped to the model's maximum.
    pub left: f32,
    /// Right wheel speed (m/s).
    pub right: f32,
    /// LED colour.
    pub led: Color,
    /// Attach or detach.
    pub attach: AttachCommand,
}

impl Actuation {
    /// Wheel speeds from a forward speed (m/s) and a turn rate (rad/s).
    pub fn from_twist(forward: f32, turn: f32, layout: &SensorLayout) -> Self {
        let half = turn * layout.wheel_distance / 2.0;
        Self {
            left: forward - half,
            right: forward + half,
            ..Self::default()
        }
    }
    /// Same actuation with another LED colour.
    pub fn with_led(mut self, led: Color) -> Self {
        self.led = led;
        self
    }
}

/// A robot's decision-making, one instance per robot.
pub trait Controller: Send {
    /// Decides what to do this tick from this tick's readings.
    fn step(&mut self, readings: &Readings, rng: &mut RobotRng) -> Actuation;
    /// A short name of the current behaviour state, for viewers and metrics.
    fn state(&self) -> &'static str;
}

/// Builds controllers of one kind with one set of parameters.
pub struct ControllerFactory {
    /// Which sensors the controllers read.
    pub needs: SensorNeeds,
    make: Box<dyn Fn() -> Box<dyn Controller> + Send + Sync>,
}

impl ControllerFactory {
    /// A factory from a constructor closure.
    pub fn new(
        needs: SensorNeeds,
        make: impl Fn() -> Box<dyn Controller> + Send + Sync + 'static,
    ) -> Self {
        Self {
            needs,
            make: Box::new(make),
        }
    }
    /// A fresh controller.
    pub fn make(&self) -> Box<dyn Controller> {
        (self.make)()
    }
}

/// Parses controller parameters from a TOML table into `P`, rejecting unknown keys.
pub fn parse_params<P: serde::de::DeserializeOwned>(
    params: Option<&toml::Table>,
) -> Result<P, String> {
    let table = params.cloned().unwrap_or_default();
    toml::Value::Table(table)
        .try_into::<P>()
        .map_err(|e| e.message().trim().to_string())
}

/// Checks controller parameters: every `positive` value must be a finite number above zero,
/// every `non_negative` one a finite number at least zero. The error names the parameter.
pub fn check_params(positive: &[(&str, f32)], non_negative: &[(&str, f32)]) -> Result<(), String> {
    for &(name, v) in positive {
        if !(v > 0.0) || !v.is_finite() {
            return Err(format!("`{name}` must be a positive number, got {v}"));
        }
    }
    for &(name, v) in non_negative {
        if !(v >= 0.0) || !v.is_finite() {
            return Err(format!("`{name}` must be zero or more, got {v}"));
        }
    }
    Ok(())
}
