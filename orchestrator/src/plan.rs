//! `couplet plan`: what a scene will run and why — processes, GPU stages, time-step
//! limits, window and substeps — without running it.

use crate::run::{RunError, resolve_scene};
use crate::window::choose_window;
use std::fmt::Write;
use std::path::Path;

/// The plan as text (markdown-ish, for a terminal).
pub fn plan(scene_path: &Path, overrides: &[(String, String)]) -> Result<String, RunError> {
    let (scene, _) = resolve_scene(scene_path, overrides)?;
    let mut o = String::new();
    let w = &mut o;
    let _ = writeln!(w, "scene: {} ({})", scene.meta.name, scene_path.display());
    if let Some(src) = &scene.meta.source {
        let _ = writeln!(w, "source: {src}");
    }
    for warning in scene.warnings() {
        let _ = writeln!(w, "warning: {warning}");
    }

    let _ = writeln!(w, "\nprocesses:");
    let fluid_limits = match &scene.fluid {
        Some(_) => Some(couplet_fluid::limits::FluidLimits::from_scene(&scene).map_err(fluid_err)?),
        None => None,
    };
    match &scene.fluid {
        Some(_) => {
            let _ = writeln!(w, "  fluid-server: yes — the scene has a [fluid] section");
        }
        None => {
            let _ = writeln!(w, "  fluid-server: no — the scene has no [fluid] section");
        }
    }
    let obstacles: Vec<&str> = scene
        .bodies
        .iter()
        .filter(|b| scene.is_fluid_obstacle(b))
        .map(|b| b.name.as_str())
        .collect();
    if scene.needs_dem() {
        let movers: Vec<&str> = scene
            .bodies
            .iter()
            .filter(|b| !scene.is_fluid_obstacle(b))
            .map(|b| b.name.as_str())
            .collect();
        // A grain lattice makes thousands of bodies: name the first few.
        let listed = if movers.len() > 8 {
            format!("{:?} … and {} more", &movers[..6], movers.len() - 6)
        } else {
            format!("{movers:?}")
        };
        let _ = writeln!(
            w,
            "  dem-server:   yes — engine `{}` for {} bodies {listed}",
            scene.dem.engine,
            movers.len()
        );
        let ramp = scene.gravity.excess_weight_ramp;
        if ramp > 0.0 {
            let _ = writeln!(
                w,
                "                the bodies the fluid sees take their weight beyond buoyancy over {ramp} s \
                 (gravity.excess_weight_ramp, quintic)"
            );
        }
    } else {
        let _ = writeln!(w, "  dem-server:   no — no body moves or needs markers");
    }
    if !obstacles.is_empty() {
        let _ = writeln!(
            w,
            "  fixed boxes {obstacles:?} are wall particles in the fluid (obstacles), no DEM needed for them"
        );
    }

    if let Some(f) = &scene.fluid {
        let consts =
            couplet_fluid::constants::SphConstants::from_scene(&scene).map_err(fluid_err)?;
        let set =
            couplet_fluid::particles::initial_particles(&scene, &consts).map_err(fluid_err)?;
        let markers =
            couplet_dem::markers::MarkerSet::from_scene(&scene).map_err(|e| RunError::Io {
                what: "generating markers".into(),
                source: std::io::Error::other(e.to_string()),
            })?;
        let fill = markers.local().iter().filter(|m| m.area == 0.0).count();
        let _ = writeln!(
            w,
            "\nfluid: δ = {} m, kernel {:?}, support {} δ (h = {:.3e} m), c_s = {} m/s, ν = {} m²/s",
            f.spacing,
            f.kernel,
            f.support,
            f.smoothing_length(),
            f.sound_speed,
            f.kinematic_viscosity
        );
        // The lattice inside a resolved body is removed by the fluid server when the
        // body's markers first arrive (`carve_out_bodies`), so with bodies this is the
        // lattice's count, not the run's.
        let carved = if !markers.is_empty() {
            " (on the lattice; those inside the bodies are removed when their markers arrive)"
        } else {
            ""
        };
        let _ = writeln!(
            w,
            "  particles: {} fluid{carved}, {} wall, {} body markers ({} on surfaces, {fill} fill points inside)",
            set.kinds.n_fluid,
            set.kinds.n_wall,
            markers.len(),
            markers.len() - fill
        );
        let _ = writeln!(w, "\nGPU stages (in dispatch order):");
        let stages = couplet_fluid::plan::stages(&scene);
        let width = stages.iter().map(|s| s.name.len()).max().unwrap_or(0);
        for s in stages {
            let _ = writeln!(w, "  {:<width$}  {}", s.name, s.reason);
        }
        let _ = writeln!(
            w,
            "  (an effect that is off dispatches nothing and allocates nothing)"
        );
    }

    let _ = writeln!(w, "\ntime-step limits:");
    if let Some(l) = &fluid_limits {
        let _ = writeln!(
            w,
            "  fluid acoustic CFL   {:.3e} s  (Joubert eq. 24: s δ_min/(c_s + u_max), s = {}, u_max = c_s/10, δ_min = {:e} m)",
            l.dt_acoustic, scene.time.cfl, l.delta_min
        );
        let _ = writeln!(
            w,
            "  fluid viscous        {:.3e} s  (Joubert eq. 24: s δ_min²/ν, or Morris's 0.125 h²/ν if smaller)",
            l.dt_viscous
        );
        let _ = writeln!(w, "  fluid step           {:.3e} s", l.dt);
    }
    // The engine's own limit, as its server will report it in its hello.
    let dem_dt = match scene.needs_dem() {
        false => None,
        true => Some(
            couplet_dem::create_engine(&scene)
                .map_err(|e| RunError::Io {
                    what: "building the DEM engine".into(),
                    source: std::io::Error::other(e.to_string()),
                })?
                .stable_dt(),
        ),
    };
    if let Some(dt) = dem_dt {
        let why = if scene.dem.engine == couplet_dem::SoftSphereEngine::NAME {
            "the contact duration over dem.soft_sphere.steps_per_contact (Robinson §3.2), at most dem.max_dt"
        } else {
            "dem.max_dt; rapier's constraint solver is stable for contacts at any step"
        };
        let _ = writeln!(w, "  DEM step             {dt:.3e} s  ({why})");
    }
    let p = choose_window(&scene, fluid_limits.as_ref().map(|l| l.dt), dem_dt);
    let _ = writeln!(
        w,
        "\ncoupling: {:?}, window {:.3e} s set by {}",
        scene.coupling.scheme, p.window, p.reason
    );
    let _ = writeln!(
        w,
        "  {} windows to t = {} s; substeps per window: fluid {}, DEM {}",
        p.windows, scene.time.end, p.fluid_substeps, p.dem_substeps
    );
    let _ = writeln!(w, "  output every {} s", scene.time.output_interval);

    let _ = writeln!(w, "\nadapter:");
    match couplet_fluid::gpu::Gpu::new() {
        Ok(g) => {
            let _ = writeln!(w, "  {}", g.describe());
        }
        Err(e) => {
            let _ = writeln!(w, "  none: {e}");
        }
    }
    Ok(o)
}

fn fluid_err(e: couplet_fluid::error::FluidError) -> RunError {
    RunError::Io {
        what: "preparing the fluid".into(),
        source: std::io::Error::other(e.to_string()),
    }
}
