//! The built-in controllers. Each module's `factory` parses its parameters and builds its
//! controllers; [`register`] adds them all to a [`Registry`] through the same call a user's
//! controller goes through.

use crate::registry::{Registry, RegistryError};

pub mod constant;
pub mod fill_transport;
pub mod filling;
pub mod occlusion;
pub mod random_walk;
pub mod relay;

/// Registers the built-in controllers under their scenario names.
pub fn register(registry: &mut Registry) -> Result<(), RegistryError> {
    registry
        .controller("random-walk", random_walk::factory)?
        .controller("constant", constant::factory)?
        .controller("filling", filling::factory)?
        .controller("fill-transport", fill_transport::factory)?
        .controller("occlusion", occlusion::factory)?;
    Ok(())
}
