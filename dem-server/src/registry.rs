//! The DEM engine registry: a scene's `dem.engine` name → an engine built from the scene.
//! Adding an engine is one file, one arm here and one line in the conformance suite.

use crate::engine::{DemEngine, DemError};
use crate::rapier_engine::RapierEngine;
use crate::soft_sphere_engine::SoftSphereEngine;
use couplet_protocol::Scene;

/// Names `dem.engine` may take, in the order `couplet plan` lists them.
pub fn engine_names() -> &'static [&'static str] {
    &[RapierEngine::NAME, SoftSphereEngine::NAME]
}

/// Builds the engine the scene names (`scene.dem.engine`).
pub fn create_engine(scene: &Scene) -> Result<Box<dyn DemEngine>, DemError> {
    match scene.dem.engine.as_str() {
        RapierEngine::NAME => Ok(Box::new(RapierEngine::new(scene)?)),
        SoftSphereEngine::NAME => Ok(Box::new(SoftSphereEngine::new(scene)?)),
        other => Err(DemError::UnknownEngine {
            name: other.to_owned(),
            valid: engine_names().join(", "),
        }),
    }
}
