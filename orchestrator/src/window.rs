//! Choice of the coupling window from every side's limits.

use couplet_protocol::Scene;

/// The coupling window and the substeps it implies on each side.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WindowPlan {
    /// Coupling window Δt_w, s.
    pub window: f64,
    /// Number of windows to reach `time.end` (the window divides `end` exactly).
    pub windows: u64,
    /// Fluid substeps per window (0 without fluid).
    pub fluid_substeps: u32,
    /// DEM substeps per window (0 without a DEM server).
    pub dem_substeps: u32,
    /// Which limit set the window, in words.
    pub reason: String,
}

/// Picks the window: the fluid's stable step (Joubert eq. 24: acoustic CFL and viscous
/// limit) times `coupling.window_substeps`; without fluid, the DEM step; without a DEM
/// server, the output interval (nothing to exchange). Then no longer than a twentieth
/// of the fastest unresolved grain's drag relaxation time ([`grain_relaxation`]), than
/// the time sound takes to cross the coupling length where grains move freely
/// ([`grain_sound_crossing`]), than `time.max_window` or the output interval (so
/// snapshots fall on windows), and shrunk so that a whole number of windows reaches
/// `time.end` exactly.
pub fn choose_window(scene: &Scene, fluid_dt: Option<f64>, dem_dt: Option<f64>) -> WindowPlan {
    let mut candidates: Vec<(f64, String)> = Vec::new();
    if dem_dt.is_none() {
        // Nothing to couple: the fluid substeps through whole output intervals, and the
        // orchestrator only hears from it when there is something to record.
    } else if let Some(dt) = fluid_dt {
        let k = scene.coupling.window_substeps;
        candidates.push((
            dt * k as f64,
            format!("fluid stable step {dt:.3e} s × {k} fluid step(s) per window"),
        ));
    } else if let Some(dt) = dem_dt {
        candidates.push((dt, format!("DEM step {dt:.3e} s (no fluid)")));
    }
    if let Some(t_d) = grain_relaxation(scene) {
        candidates.push((
            t_d / 20.0,
            format!("unresolved grains' drag relaxation t_d = {t_d:.3e} s / 20 (Robinson eq. 36)"),
        ));
    }
    if let Some(t_a) = grain_sound_crossing(scene) {
        candidates.push((
            t_a,
            format!(
                "free unresolved grains: sound crosses the coupling length h in \
                 h/c_s = {t_a:.3e} s"
            ),
        ));
    }
    if let Some(w) = scene.time.max_window {
        candidates.push((w, format!("time.max_window {w:.3e} s")));
    }
    candidates.push((
        scene.time.output_interval,
        format!("output interval {:.3e} s", scene.time.output_interval),
    ));
    candidates.push((scene.time.end, format!("end time {:.3e} s", scene.time.end)));
    let (w_max, reason) = candidates
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((scene.time.end, "end time".into()));
    let windows = (scene.time.end / w_max).ceil().max(1.0) as u64;
    let window = scene.time.end / windows as f64;
    let substeps =
        |dt: Option<f64>| dt.map_or(0, |dt| (window / dt * (1.0 - 1e-12)).ceil().max(1.0) as u32);
    WindowPlan {
        window,
        windows,
        fluid_substeps: substeps(fluid_dt),
        dem_substeps: substeps(dem_dt),
        reason,
    }
}

/// The shortest drag relaxation time `t_d = m / b` of the scene's unresolved grains,
/// with b the drag per unit slip of a lone grain in creeping flow, Stokes's `3π μ d`
/// (Robinson eq. 34; the other laws tend to it, Dallavalle's to 0.96 of it, as Re → 0).
/// The fluid's force on a grain is held over a window, so the window must be short
/// against t_d: Robinson eq. (36) asks for t_d / 20. At higher Re or lower porosity the
/// drag per unit slip grows and t_d shrinks: `time.max_window` bounds the window further.
/// `None` without grains.
pub fn grain_relaxation(scene: &Scene) -> Option<f64> {
    let f = scene.fluid.as_ref()?;
    let mu = f.density * f.kinematic_viscosity;
    scene
        .grains()
        .into_iter()
        .filter_map(|i| {
            let b = &scene.bodies[i];
            let couplet_protocol::Shape::Sphere { radius } = b.shape else {
                return None;
            };
            let m = b.density * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
            Some(m / (3.0 * std::f64::consts::PI * mu * 2.0 * radius))
        })
        .min_by(f64::total_cmp)
}

/// `h / c_s`, the time a pressure signal takes to cross the coupling length h (the
/// fluid's smoothing length, Robinson's h_c, eq. 9), where unresolved grains move freely
/// (dynamic, not in a translation group). Within a window the grains' forces are sampled
/// at its start and held, and the fluid sees the grains moving at their window-start
/// velocities, so their motion, and through the porosity the fluid's pressure (eq. 15 on
/// ρ/ε), lags the fluid by about a window. A sound wave whose period is near that lag is then fed instead of
/// damped: the RTI's 1.1 mm quick at α = 0 (water, windows of 20 fluid steps, 44.5 μs
/// = 2.4 h/c_s) grew a standing wave through its block, layers of fluid and grains
/// moving up and down in turn 4 grain layers apart (0.55 mm, a sound period of 55 μs),
/// ×2 a millisecond from 12 ms, and blew up at 17.8 ms; with 10, 5 or 2 steps (1.2,
/// 0.6, 0.24 h/c_s) no such wave grew to 17 ms, the fluid's largest speed 4.2 mm/s
/// against 88 mm/s (ARCHITECTURE.md, "A window longer than the sound's crossing of h
/// feeds a sound wave"). Robinson steps the SPH and the DEM together (§3.2), a window of
/// one step. A rigid block (a translation group) cannot compress, so it is exempt: the
/// constant-porosity block keeps its 20 steps. `None` without free grains.
pub fn grain_sound_crossing(scene: &Scene) -> Option<f64> {
    let f = scene.fluid.as_ref()?;
    scene
        .bodies
        .iter()
        .any(|b| {
            scene.is_grain(b)
                && b.motion == couplet_protocol::scene::Motion::Dynamic
                && b.translation_group.is_none()
        })
        .then(|| f.smoothing_length() / f.sound_speed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn scene(extra: &str) -> Scene {
        let text = format!(
            "[meta]\nname = \"w\"\n[time]\nend = 1.0\noutput_interval = 0.1\n{extra}\n[domain]\nmin = [0,0,0]\nmax = [1,1,1]\n"
        );
        Scene::parse(&text, Path::new("w.toml")).unwrap()
    }

    #[test]
    fn window_is_fluid_step_and_divides_end() {
        let p = choose_window(&scene(""), Some(3e-4), Some(1e-3));
        // ceil(1 / 3e-4) windows of 1/3334 s.
        assert_eq!(p.windows, 3334);
        assert!((p.window * p.windows as f64 - 1.0).abs() < 1e-12);
        assert!(p.window <= 3e-4);
        assert_eq!(p.fluid_substeps, 1);
        assert_eq!(p.dem_substeps, 1);
    }

    #[test]
    fn fluid_alone_steps_through_output_intervals() {
        let p = choose_window(&scene(""), Some(3e-4), None);
        assert_eq!(p.windows, 10);
        assert_eq!(p.fluid_substeps, 334);
    }

    #[test]
    fn max_window_and_output_interval_bound_the_window() {
        let p = choose_window(&scene("max_window = 0.05"), None, Some(0.2));
        assert!((p.window - 0.05).abs() < 1e-15);
        assert_eq!(p.dem_substeps, 1);
        let p = choose_window(&scene(""), None, Some(0.5));
        assert!((p.window - 0.1).abs() < 1e-15, "{p:?}");
    }

    /// A grain of d = 0.1 mm, ρ = 2500 in water (μ = 1e-3): t_d = ρ d²/(18 μ) = 1.389e-3 s
    /// (`stokes_settling_examples.csv`, tau_noAM), so the window is at most t_d / 20.
    #[test]
    fn grains_bound_the_window_by_their_drag_relaxation() {
        let s = scene(
            "[fluid]\ndensity = 1000.0\nkinematic_viscosity = 1e-6\nsound_speed = 1.0\n\
             spacing = 0.1\nblocks = [{ min = [0, 0, 0], max = [1, 0.5, 1] }]\n\
             [[bodies]]\nname = \"grain\"\nshape.sphere.radius = 5e-5\ndensity = 2500.0\n\
             position = [0.5, 0.25, 0.5]\ncoupling = \"unresolved\"",
        );
        let t_d = grain_relaxation(&s).unwrap();
        assert!((t_d - 1.3888889e-3).abs() < 1e-9, "t_d = {t_d}");
        let p = choose_window(&s, Some(1e-3), Some(1e-3));
        assert!(
            p.window <= t_d / 20.0 && p.window > 0.99 * t_d / 20.0,
            "{p:?}"
        );
        assert!(p.reason.contains("Robinson eq. 36"), "{}", p.reason);
    }

    /// Regression (rti_alpha_0_window_lag, 2026-12-05): the RTI in water at α = 0 ran
    /// windows of 20 fluid steps (2.4 h/c_s) and grew a sound wave through its block
    /// until it blew up (`grain_sound_crossing`). A free grain bounds the window by h/c_s,
    /// here the RTI's water: h = 1.5 δ = 1.8375e-4 m, c_s = 10 m/s, 18.4 μs, 9 of its
    /// 2.23 μs fluid steps where 20 were asked for (t_d/20 = 78 μs does not bind); a grain
    /// in a translation group (the constant-porosity block) keeps the 20.
    #[test]
    fn free_grains_bound_the_window_by_the_sound_crossing_of_h() {
        let grain = |group: &str| {
            scene(&format!(
                "[fluid]\ndensity = 1000.0\nkinematic_viscosity = 8.9e-7\nsound_speed = 10.0\n\
                 spacing = 1.225e-4\nsupport = 3.0\nkernel = \"wendland-c2\"\n\
                 blocks = [{{ min = [0, 0, 0], max = [1, 0.5, 1] }}]\n\
                 [coupling]\nwindow_substeps = 20\n[dem]\nengine = \"soft-sphere\"\n\
                 [dem.soft_sphere]\ncontact = \"linear\"\nstiffness = 1e-4\n\
                 [[bodies]]\nname = \"grain\"\nshape.sphere.radius = 5e-5\ndensity = 2500.0\n\
                 position = [0.5, 0.25, 0.5]\ncoupling = \"unresolved\"\n{group}"
            ))
        };
        let dt = 2.23e-6;
        let free = grain("");
        let t_a = grain_sound_crossing(&free).unwrap();
        assert!((t_a - 1.8375e-5).abs() < 1e-12, "h/c = {t_a}");
        let p = choose_window(&free, Some(dt), Some(1e-3));
        assert!(p.window <= t_a && p.window > 0.999 * t_a, "{p:?}");
        assert_eq!(p.fluid_substeps, 9, "{p:?}");
        assert!(p.reason.contains("sound crosses"), "{}", p.reason);
        let rigid = grain("translation_group = \"block\"");
        assert_eq!(grain_sound_crossing(&rigid), None);
        let p = choose_window(&rigid, Some(dt), Some(1e-3));
        assert_eq!(p.fluid_substeps, 20, "{p:?}");
    }
}
