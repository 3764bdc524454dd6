//! Diagnostic: initial accelerations of the hydrostatic tank (CPU twins).
use couplet_fluid::adami2012_boundary_pressure::boundary_pressure_cpu;
use couplet_fluid::momentum::momentum_cpu;
use couplet_fluid::{SphConstants, initial_particles};
use couplet_protocol::Scene;
use std::path::Path;

fn main() {
    let support: f64 = std::env::args().nth(1).map_or(2.0, |s| s.parse().unwrap());
    let text = format!(
        r#"
[meta]
name = "t"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.32, 0.2]
[fluid]
density = 1000.0
kinematic_viscosity = 0.0
sound_speed = 17.5
spacing = 0.02
support = {support}
blocks = [{{ min = [0.0, 0.0, 0.0], max = [0.2, 0.3, 0.2] }}]
[effects]
viscosity = "none"
"#
    );
    let scene = Scene::parse(&text, Path::new("t.toml")).unwrap();
    let c = SphConstants::from_scene(&scene).unwrap();
    let mut set = initial_particles(&scene, &c).unwrap();
    let bp = boundary_pressure_cpu(&c, &set);
    for (i, v) in bp.iter().enumerate() {
        if let Some((p, r)) = v {
            set.press[i] = *p;
            set.rho[i] = *r;
        }
    }
    // Column at x = z = 0.09 (lattice index 4): acc_y per height.
    for i in 0..set.kinds.n_fluid {
        let p = set.pos[i];
        if (p[0] - 0.09).abs() < 1e-6 && (p[2] - 0.09).abs() < 1e-6 {
            let a = momentum_cpu(&c, &set, i);
            println!(
                "y = {:.5}  rho = {:.4}  p = {:8.2}  acc_y = {:+.4}",
                p[1], set.rho[i], set.press[i], a[1]
            );
        }
    }
}
