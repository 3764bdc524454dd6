//! The list of GPU stages a scene runs, and why: a pure function of the scene, used by
//! the solver to build its passes and by `couplet plan` (which needs no GPU).

use couplet_protocol::{
    DensityDiffusionForm, DragLawName, Scene, ViscosityModel, WallKind, WallModel,
};

use crate::neighbour_grid::{GRID_REACH_CPU, GRID_REACH_GPU};

/// One GPU stage of a fluid step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stage {
    /// Stable stage name, also the label prefix of its compute passes.
    pub name: &'static str,
    /// Why the scene runs it.
    pub reason: String,
}

pub const NEIGHBOUR_GRID: &str = "neighbour_grid";
pub const MARKER_UPDATE: &str = "marker_update";
pub const BOUNDARY_PRESSURE: &str = "adami2012_boundary_pressure";
pub const JOUBERT_BOUNDARY_VALUES: &str = "joubert2020_boundary_values";
pub const CONTINUITY: &str = "continuity";
pub const MOMENTUM_PRESSURE: &str = "momentum_pressure";
pub const MORRIS1997_VISCOSITY: &str = "morris1997_viscosity";
pub const CORRECTED_LAPLACIAN_VISCOSITY: &str = "joubert2020_laplacian_viscosity";
pub const MONAGHAN1992_ARTIFICIAL_VISCOSITY: &str = "monaghan1992_artificial_viscosity";
pub const GRAVITY: &str = "gravity";
pub const INTEGRATE: &str = "joubert2020_predictor_corrector";
pub const BODY_LOADS: &str = "joubert2020_body_loads";
pub const BODY_NON_PENETRATION: &str = "body_non_penetration";
pub const WALL_NON_PENETRATION: &str = "wall_non_penetration";
pub const BLOWUP_CHECK: &str = "blowup_check";
pub const GRADIENTS: &str = "joubert2020_gradients";
pub const PARTICLE_SHIFTING: &str = "particle_shifting";
pub const DENSITY_DIFFUSION: &str = "antuono2010_density_diffusion";
pub const FOURTAKAS_DENSITY_DIFFUSION: &str = "fourtakas2019_density_diffusion";
pub const MASS_CORRECTION: &str = "joubert2020_mass_correction";
pub const SAMPLE_GRAINS: &str = "robinson_sample_grains";
pub const GRAIN_REACTION: &str = "robinson_grain_reaction";
pub const VARIABLE_H: &str = "robinson_variable_h";

/// Names of the axes `k` (x, y, z) for which `pick(k)` holds.
fn axis_names(pick: impl Fn(usize) -> bool) -> Vec<&'static str> {
    ["x", "y", "z"]
        .into_iter()
        .enumerate()
        .filter_map(|(k, a)| pick(k).then_some(a))
        .collect()
}

/// The stages of one fluid step for `scene`, in execution order. Effects that are off
/// are absent. Continuity, the pressure gradient, the viscous terms and gravity are one
/// fused pair loop on the GPU (`fluid_rates`); they are listed separately because they
/// are switched separately.
pub fn stages(scene: &Scene) -> Vec<Stage> {
    let mut out = Vec::new();
    let Some(f) = &scene.fluid else {
        return out;
    };
    let mut push = |name: &'static str, reason: String| out.push(Stage { name, reason });
    let variable_h = scene
        .effects
        .variable_smoothing_length
        .then(|| f.max_smoothing_ratio());
    let periodic = axis_names(|k| scene.domain.periodic[k]);
    let radius = f.support_radius() * variable_h.unwrap_or(1.0);
    push(
        NEIGHBOUR_GRID,
        format!(
            "cell size ≥ support/R = {:.3e} m on a GPU (R = {GRID_REACH_GPU}), {:.3e} m on a CPU adapter (R = {GRID_REACH_CPU}){}; stable counting sort by cell once per step, then the fluid in each cell's row of 2R + 1 cells, so that the boundary passes skip rows without fluid (fluid_rows){}",
            radius / f64::from(GRID_REACH_GPU),
            radius / f64::from(GRID_REACH_CPU),
            match variable_h {
                Some(r) => format!(" (the support of the largest h, {r} h: variable h)"),
                None => String::new(),
            },
            if periodic.is_empty() {
                String::new()
            } else {
                format!(
                    "; periodic in {} (nearest-image pairs, positions wrapped at the sort)",
                    periodic.join(", ")
                )
            },
        ),
    );
    let laminar = scene.effects.viscosity == ViscosityModel::Laminar && f.kinematic_viscosity > 0.0;
    let correction = scene.effects.gradient_correction;
    let laplacian = scene.effects.laplacian_correction && laminar;
    let beta = scene.effects.particle_shifting;
    let delta = scene.effects.density_diffusion;
    let fourtakas = scene.effects.density_diffusion_form == DensityDiffusionForm::Fourtakas;
    let gamma_mc = scene.effects.mass_correction;
    if let Some(r) = variable_h {
        push(
            VARIABLE_H,
            format!(
                "effects.variable_smoothing_length: h_i = h (V_i/δ³)^(1/3) (Robinson eq. 19) and the grad-h factor Ω_i (eq. 11) of every fluid particle once per step after the sort; h_i ≤ {r} h (fluid.max_smoothing_ratio); on a uniform lattice Ω = {:.4} (the kernel sum's error at support {}δ)",
                crate::SphConstants::from_scene(scene)
                    .map_or(f64::NAN, |c| crate::robinson_variable_h::lattice_omega(&c)),
                f.support
            ),
        );
    }
    let antuono = delta > 0.0 && !fourtakas;
    if correction || laplacian || beta > 0.0 || antuono {
        let users: Vec<&str> = [
            (correction, "effects.gradient_correction"),
            (
                laplacian,
                "effects.laplacian_correction (B̂ of eq. 11, a 6 × 6 solve)",
            ),
            (beta > 0.0, "effects.particle_shifting (Taylor terms)"),
            (antuono, "effects.density_diffusion (renormalised ∇ρ)"),
            (
                gamma_mc > 0.0,
                "effects.mass_correction (∇p, and B̂ of eq. 11 for eq. 15)",
            ),
        ]
        .iter()
        .filter_map(|(on, name)| on.then_some(*name))
        .collect();
        push(
            GRADIENTS,
            format!(
                "{}: B = M⁻¹ of Joubert eq. (10){} once per step after the sort{}",
                users.join(", "),
                crate::SphConstants::from_scene(scene).map_or(String::new(), |c| {
                    let f = crate::joubert2020_gradients::GradientFields::of(&c);
                    let fields: Vec<&str> = [
                        (f.grad_u, "corrected ∇u"),
                        (f.grad_p, "corrected ∇p"),
                        (f.grad_rho, "corrected ∇ρ"),
                        (f.shift, "the shift direction of eq. (17)"),
                    ]
                    .iter()
                    .filter_map(|(on, name)| on.then_some(*name))
                    .collect();
                    fields.iter().map(|f| format!(", {f}")).collect()
                }),
                if scene.free_surface_switch() {
                    format!(
                        "; effects.free_surface: where det M < {} of a complete support's (the rows whose support reaches past the fluid's edge) continuity and pressure keep the standard forms",
                        crate::joubert2020_gradients::FREE_SURFACE_FRACTION
                    )
                } else {
                    String::new()
                }
            ),
        );
    }
    let resolved = scene.has_resolved_bodies();
    if resolved {
        push(MARKER_UPDATE, "resolved bodies: markers placed from the DEM's coupling points, extrapolated x += v·τ inside the window".into());
    }
    let walls = match scene.domain.walls {
        WallKind::NoSlip => "no-slip",
        WallKind::FreeSlip => "free-slip",
    };
    let obstacles = scene
        .bodies
        .iter()
        .filter(|b| scene.is_fluid_obstacle(b))
        .count();
    let walls = if scene.domain.periodic.iter().all(|p| *p) {
        "no"
    } else {
        walls
    };
    if scene.domain.wall_model == WallModel::Joubert {
        let d = &scene.domain;
        let symmetric = axis_names(|k| d.is_symmetry_axis(k));
        let held = axis_names(|k| !d.periodic[k] && !d.is_symmetry_axis(k));
        push(
            JOUBERT_BOUNDARY_VALUES,
            format!(
                "one layer of boundary particles on the faces (Joubert §2.5){}{}{}: pressure by the Neumann condition of eq. (25), B over the fluid neighbours, twice per step",
                if held.is_empty() {
                    String::new()
                } else {
                    format!("; no-slip {} faces hold their velocity", held.join(", "))
                },
                if symmetric.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; {} faces are symmetry planes (velocity by eq. 27, ∂u/∂n = 0)",
                        symmetric.join(", ")
                    )
                },
                if scene.has_resolved_bodies() {
                    "; body markers with the rigid-body acceleration of each point (§2.6)"
                } else {
                    ""
                },
            ),
        );
    } else {
        push(
            BOUNDARY_PRESSURE,
            format!(
                "{walls} domain walls{}{}{}: wall pressure extrapolated from the fluid (Adami, Hu & Adams 2012){}, twice per step",
                {
                    let d = &scene.domain;
                    let symmetric = axis_names(|k| !d.periodic[k] && d.symmetry[k]);
                    if symmetric.is_empty() || walls == "free-slip" {
                        String::new()
                    } else {
                        format!(
                            " ({} faces symmetry planes: the fluid's velocity mirrored across them)",
                            symmetric.join(", ")
                        )
                    }
                },
                if obstacles > 0 {
                    format!(", {obstacles} fixed box obstacle(s)")
                } else {
                    String::new()
                },
                if resolved {
                    ", body markers and the fill points behind them (inside the bodies, as wall layers behind a face)"
                } else {
                    ""
                },
                if walls == "no-slip" && (laminar || scene.effects.artificial_viscosity > 0.0) {
                    "; no-slip walls' viscous velocity 2 v_w − ṽ_w"
                } else {
                    ""
                }
            ),
        );
    }
    if correction {
        push(
            CONTINUITY,
            if scene.grains().is_empty() {
                "Joubert eq. (12): −ρ_i Σ V_j (u_j − u_i)·B_i∇W_ij".into()
            } else if variable_h.is_some() {
                "superficial density, Robinson eq. (10): (1/Ω_i) Σ m_j u_ij·∇W_ij(h_i) (not Joubert's corrected eq. 12: among grains only this form is the time derivative of the summation density)".into()
            } else {
                "superficial density, Robinson eq. (10) at fixed h: Σ m_j u_ij·∇W_ij (not Joubert's corrected eq. 12: among grains only this form is the time derivative of the summation density)".into()
            },
        );
        push(
            MOMENTUM_PRESSURE,
            "Joubert eq. (13): −(1/ρ_i) Σ V_j (p_j − p_i) B_i∇W_ij".into(),
        );
    } else if variable_h.is_some() {
        push(
            CONTINUITY,
            "Robinson eq. (10): (1/Ω_i) Σ m_j u_ij·∇W_ij(h_i)".into(),
        );
        push(
            MOMENTUM_PRESSURE,
            "Robinson eq. (12): −Σ m_j (p_i/(Ω_i ρ_i²) ∇W(h_i) + p_j/(Ω_j ρ_j²) ∇W(h_j))".into(),
        );
    } else {
        push(
            CONTINUITY,
            "weakly compressible density (standard form of Joubert eq. 12, no gradient correction)"
                .into(),
        );
        push(
            MOMENTUM_PRESSURE,
            "symmetric pressure gradient −Σ m (p_i/ρ_i² + p_j/ρ_j²) ∇W".into(),
        );
    }
    if delta > 0.0 {
        push(
            if fourtakas {
                FOURTAKAS_DENSITY_DIFFUSION
            } else {
                DENSITY_DIFFUSION
            },
            format!(
                "effects.density_diffusion δ = {delta}: δ-SPH ({}) in the continuity pair loop{}",
                if fourtakas {
                    "Fourtakas et al. 2019: the hydrostatic density difference removed, no gradients"
                } else {
                    "Antuono et al. 2010: renormalised ∇ρ"
                },
                if scene.grains().is_empty() {
                    ""
                } else {
                    ", of the intrinsic density ρ/ε among grains"
                }
            ),
        );
    }
    if gamma_mc > 0.0 {
        push(
            MASS_CORRECTION,
            format!(
                "effects.mass_correction Γ = {gamma_mc}: Joubert eq. (14) ρ_i Γ Δt (eq. 15 − eq. 16) in the continuity pair loop"
            ),
        );
    }
    if laplacian {
        push(
            CORRECTED_LAPLACIAN_VISCOSITY,
            format!(
                "effects.laplacian_correction: Joubert eq. (13) 2ν Σ V_j ((u_i − u_j)/r − e·⟨∇⊗u⟩ᶜ) B̂_i : (e ⊗ ∇W), ν = {:e} m²/s",
                f.kinematic_viscosity
            ),
        );
    } else if laminar {
        push(
            MORRIS1997_VISCOSITY,
            format!(
                "effects.viscosity = laminar, ν = {:e} m²/s",
                f.kinematic_viscosity
            ),
        );
    }
    if scene.effects.artificial_viscosity > 0.0 {
        push(
            MONAGHAN1992_ARTIFICIAL_VISCOSITY,
            format!(
                "effects.artificial_viscosity α = {}",
                scene.effects.artificial_viscosity
            ),
        );
    }
    if scene.gravity.on_fluid && scene.gravity.vector.iter().any(|g| *g != 0.0) {
        push(
            GRAVITY,
            format!(
                "gravity.on_fluid = true, g = {:?} m/s²",
                scene.gravity.vector
            ),
        );
    }
    push(
        INTEGRATE,
        "Joubert eqs. (20)–(23): predictor, corrector, average; positions once per step".into(),
    );
    if beta > 0.0 {
        push(
            PARTICLE_SHIFTING,
            format!(
                "effects.particle_shifting β = {beta}: Joubert eqs. (17)–(19) after the corrector"
            ),
        );
    }
    // Every non-periodic axis has a wall face (+y has its floor even with an open top).
    let walled = axis_names(|k| !scene.domain.periodic[k]);
    let beyond_walls = "a fluid particle beyond a wall face after the step is mirrored back across it and its velocity into the wall removed";
    if resolved {
        push(
            BODY_NON_PENETRATION,
            format!(
                "resolved bodies: a fluid particle behind the tangent plane of its nearest surface marker after the step is mirrored back and its inward relative velocity removed; then {beyond_walls}; counted per window (not in Joubert)"
            ),
        );
    } else if !walled.is_empty() {
        push(
            WALL_NON_PENETRATION,
            format!(
                "walls on {}: {beyond_walls}; counted per window (not in Joubert)",
                walled.join(", ")
            ),
        );
    }
    if resolved {
        push(
            BODY_LOADS,
            format!(
                "resolved bodies: Joubert eqs. (31)–(32) over the markers{}, averaged over the window, tree-reduced per body",
                if scene.effects.gradient_correction {
                    ", ∇u corrected by a one-sided B"
                } else {
                    ""
                }
            ),
        );
    }
    let grains = scene.grains().len();
    if grains > 0 {
        let law = match scene.coupling.drag {
            DragLawName::Stokes => "Stokes (Robinson eq. 28)",
            DragLawName::CoulsonRichardson => "Coulson–Richardson (Robinson eq. 29)",
            DragLawName::DiFelice => "Dallavalle + Di Felice (Robinson eqs. 30–33)",
            DragLawName::ErgunWenYu => "Ergun / Wen–Yu, switch at ε = 0.8 (DEMocritus eqs. 36–37)",
            DragLawName::ErgunWenYuBlend => {
                "Ergun / Wen–Yu, Huilin–Gidaspow blend (DEMocritus eqs. 36–37)"
            }
        };
        push(
            SAMPLE_GRAINS,
            format!(
                "{grains} unresolved grain(s), once per window at its start: Shepard-interpolated u_f and V(−∇P + ∇·τ) (Robinson eqs. 8, 23–25), drag {law} at the grain's porosity (Robinson eq. 9, on the CPU); the fluid's porosity (eq. 9, grain_solid_fraction) scales its equation of state (eq. 15)"
            ),
        );
        if scene.coupling.two_way {
            push(
                GRAIN_REACTION,
                "two-way: each grain's force spread over the fluid in its support at the window's start, −f_j W/(S_j ρ) per unit mass (Robinson eqs. 26–27, 64-bit fixed-point sums: momentum exact, order-independent), added to du/dt at every rate evaluation".into(),
            );
        }
    }
    push(
        BLOWUP_CHECK,
        "once per window: non-finite or runaway density/velocity, grid overflow".into(),
    );
    out
}
