//! Choice of the coupling window from every side's limits.

use couplet_protocol::Scene;

/// The coupling window and the substeps it implies on each side.
#[derive(Debug, Clone, PartialEq)]
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
/// server, the output interval (nothing to exchange). Then no longer
/// than `time.max_window` or the output interval (so snapshots fall on windows), and
/// shrunk so that a whole number of windows reaches `time.end` exactly.
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
}
