//! Built-in controllers, by name.

use crate::controller::ControllerFactory;
use crate::sensors::SensorLayout;

pub mod constant;
pub mod fill_transport;
pub mod filling;
pub mod occlusion;
pub mod random_walk;

/// Names accepted in scenario files and on the command line.
pub const NAMES: &[&str] = &[
    "random-walk",
    "constant",
    "filling",
    "fill-transport",
    "occlusion",
];

/// Builds the factory for controller `name` with `params` for robots with `layout`.
pub fn factory(
    name: &str,
    params: Option<&toml::Table>,
    layout: &SensorLayout,
) -> Result<ControllerFactory, String> {
    match name {
        "random-walk" => random_walk::factory(params, layout),
        "constant" => constant::factory(params, layout),
        "filling" => filling::factory(params, layout),
        "fill-transport" => fill_transport::factory(params, layout),
        "occlusion" => occlusion::factory(params, layout),
        _ => Err(format!(
            "unknown controller `{name}`, expected one of {}",
            NAMES.join(", ")
        )),
    }
}
