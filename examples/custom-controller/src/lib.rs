//! A worked example of extending Formica without forking it: a controller ([`phototaxis`]), a
//! loop function that adds a stop rule and end-of-run fields ([`gathering`]) and a robot model
//! ([`demo_bot`]), registered next to the built-ins. `src/main.rs` hands the registry to
//! `formica_cli::main_with`, which gives every `formica` subcommand with them in it.
//!
//! ```
//! let registry = custom_controller::registry()?;
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/phototaxis.toml");
//! let scenario = registry.load(path.as_ref())?;
//! let (result, _) = formica::run(&scenario, &Default::default())?;
//! assert_eq!(result.controller, "phototaxis");
//! assert!(result.extra.contains_key("gathered_fraction"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use formica::{Registry, RegistryError};

pub mod gathering;
pub mod phototaxis;

/// The model `demo-bot`: a Khepera IV with a ring of 16 light sensors instead of 8.
pub fn demo_bot() -> formica::robot::RobotModel {
    let light_angles = (0..16)
        .map(|i| formica::geometry::wrap_angle((22.5 * i as f32).to_radians()))
        .collect();
    formica::robot::RobotModel {
        light_angles,
        light_spread: 2,
        ..formica::robot::RobotModel::khepera4()
    }
}

/// The built-ins plus `phototaxis`, `gathering` and `demo-bot`.
pub fn registry() -> Result<Registry, RegistryError> {
    let mut registry = Registry::builtin();
    registry
        .controller("phototaxis", phototaxis::factory)?
        .loop_functions("gathering", gathering::build)?
        .model("demo-bot", demo_bot())?;
    Ok(registry)
}
