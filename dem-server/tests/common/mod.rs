//! Scene builders shared by the dem-server tests: a 1 m domain, optional fluid.
#![allow(dead_code)]

use couplet_protocol::Scene;
use std::path::Path;

/// A DEM-only scene: 1 m cube domain with an open top, default gravity (0, −9.81, 0).
pub const BASE: &str = r#"
[meta]
name = "dem-test"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0, 0, 0]
max = [1, 1, 1]
"#;

/// Water (ρ = 1000 kg/m³) filling the lower half of the domain, δ = 0.02 m.
pub const WATER: &str = r#"
[fluid]
density = 1000.0
kinematic_viscosity = 1e-6
sound_speed = 20.0
spacing = 0.02
blocks = [{ min = [0, 0, 0], max = [1, 0.5, 1] }]
"#;

/// Parses `BASE` followed by `extra` (which may set `[gravity]`, `[dem]`, `[fluid]`, bodies).
pub fn scene(extra: &str) -> Scene {
    let text = format!("{BASE}\n{extra}");
    Scene::parse(&text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// `[[bodies]]` table of a sphere.
pub fn sphere(name: &str, radius: f64, density: f64, position: [f64; 3], extra: &str) -> String {
    format!(
        "[[bodies]]\nname = \"{name}\"\nshape.sphere.radius = {radius:?}\ndensity = {density:?}\nposition = {position:?}\n{extra}\n"
    )
}

/// `[[bodies]]` table of a box.
pub fn cuboid(
    name: &str,
    half_extents: [f64; 3],
    density: f64,
    position: [f64; 3],
    extra: &str,
) -> String {
    format!(
        "[[bodies]]\nname = \"{name}\"\nshape.box.half_extents = {half_extents:?}\ndensity = {density:?}\nposition = {position:?}\n{extra}\n"
    )
}
