//! couplet's DEM server: the swappable `DemEngine` trait, its engines and registry, body geometry and coupling markers.

pub use engine::{ContactModel, DemEngine, DemError};
pub use geometry::BodyGeometry;
pub use markers::{LocalMarker, MarkerSet, fill_points, generate_markers};
pub use rapier_engine::RapierEngine;
pub use registry::{create_engine, engine_names};
pub use soft_sphere_engine::SoftSphereEngine;

pub mod contact_cells;
pub mod engine;
pub mod geometry;
pub mod markers;
pub mod rapier_engine;
pub mod registry;
pub mod server;
pub mod soft_sphere_engine;
