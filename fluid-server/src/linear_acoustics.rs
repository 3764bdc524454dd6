//! The fluid's rates linearised about rest, from the f64 CPU twins: whether a scheme's
//! spatial operators conserve the energy of small motions, or can grow a mode by
//! themselves (ARCHITECTURE.md, "Joubert's one-layer walls grow a mode").
//!
//! The state is x = (ρ'_a, u_a) of every fluid particle a about rest on the scene's start
//! lattice (ρ = ρ0, u = 0; the scene must have no gravity, so that rest is a steady
//! state). Its rates are one step's, in the solver's order: the equation of state at the
//! fluid, the walls' and the fixed bodies' markers' values (Joubert eq. 25 with
//! `domain.wall_model = "joubert"`, else Adami's extrapolation), then (dρ/dt, du/dt)
//! ([`crate::fluid_rates::fluid_rates_cpu`]). At rest they are linear in x, but for
//! Monaghan's α, which acts only on approaching pairs, so α > 0 is refused. The energy of small
//! motions, E = Σ_a m_a (c² ρ'_a²/ρ0² + |u_a|²)/2, is conserved by the linear rates J
//! exactly when W J is skew-symmetric, W = diag(m c²/ρ0², m, m, m) a particle
//! ([`RestState::energy_weights`]).
//!
//! The CPU twins sum over all pairs (to the nearest image on a periodic axis, as the
//! GPU), so the scene must be small: each evaluation costs (fluid + walls)² pair tests.

use crate::adami2012_boundary_pressure::boundary_pressure_with_fill_cpu;
use crate::constants::SphConstants;
use crate::error::FluidError;
use crate::fluid_rates::fluid_rates_cpu;
use crate::joubert2020_boundary_values::{BoundaryFrame, boundary_values_cpu, wall_frames};
use crate::particles::{Kind, ParticleSet, initial_particles};
use crate::solver::with_marker_particles;
use couplet_protocol::{CouplingPoint, Scene};
use std::io::Write;

/// The largest perturbation [`RestState::apply`] takes, as a velocity over the sound
/// speed (a density part counts as c ρ'/ρ0): small enough that the equation of state's
/// curvature, which the central difference cancels to second order, leaves J at
/// round-off, large enough that the rates stand well above it.
const PROBE: f64 = 1e-6;

/// A scene's fluid at rest, ready to give its rates and their linearisation.
pub struct RestState {
    pub c: SphConstants,
    set: ParticleSet,
    /// Joubert's boundaries' frames, walls then markers (empty under Adami's model).
    frames: Vec<BoundaryFrame>,
    /// Under Adami's model, the nearest surface's normal of each marker entry that is a
    /// fill point (by `id − marker_base`), `None` for surface markers.
    fill_normals: Vec<Option<[f64; 3]>>,
    fluid: Vec<usize>,
}

impl RestState {
    /// The scene's start lattice at ρ0 and rest. Refused: gravity on the fluid (rest
    /// would not be steady), α > 0 (not linear), resolved bodies (give their markers to
    /// [`Self::with_bodies`]), grains (not modelled here).
    pub fn new(scene: &Scene) -> Result<Self, FluidError> {
        Self::with_bodies(scene, &[])
    }

    /// [`Self::new`] with the scene's resolved bodies held fixed where `points` (the
    /// DEM's coupling points at their poses: surface markers, then under Adami's model
    /// the fill points of area 0) put them: the fluid inside them carved out and a
    /// marker particle for each point, as the solver's first `set_bodies` makes them
    /// (`solver::with_marker_particles`). Their boundary values come each evaluation
    /// from Joubert eq. (25) at the markers under Joubert's model, from Adami's
    /// extrapolation (one-sided at fill points) under Adami's. Refused: a scene with
    /// marker-coupled bodies and no points.
    pub fn with_bodies(scene: &Scene, points: &[CouplingPoint]) -> Result<Self, FluidError> {
        let c = SphConstants::from_scene(scene)?;
        if c.gravity_fluid.iter().any(|g| *g != 0.0) {
            return Err(FluidError::LinearAcoustics(format!(
                "gravity {:?} m/s² acts on the fluid, so rest is not a steady state; give \
                 gravity.vector = [0, 0, 0] (or gravity.on_fluid = false)",
                c.gravity_fluid
            )));
        }
        if c.alpha > 0.0 {
            return Err(FluidError::LinearAcoustics(format!(
                "effects.artificial_viscosity = {} acts only between approaching particles, \
                 so the rates are not linear at rest; give 0",
                c.alpha
            )));
        }
        if !scene.grain_lattices.is_empty() {
            return Err(FluidError::LinearAcoustics(
                "the scene has grains; this linearisation takes the fluid, its walls and \
                 resolved bodies alone"
                    .into(),
            ));
        }
        if points.is_empty() && scene.bodies.iter().any(|b| scene.is_marker_coupled(b)) {
            return Err(FluidError::LinearAcoustics(
                "the scene has resolved bodies: give their coupling points (the DEM's \
                 markers at the bodies' poses) to RestState::with_bodies"
                    .into(),
            ));
        }
        let lattice = initial_particles(scene, &c)?;
        let mut frames = if c.joubert_walls {
            wall_frames(scene, &lattice)
        } else {
            Vec::new()
        };
        // Carved and appended in world coordinates (origin 0), the twins' frame.
        let mut set = if points.is_empty() {
            lattice
        } else {
            with_marker_particles(&c, lattice, points, [0.0; 3])
        };
        let normal = |p: &CouplingPoint| p.normal.map(f64::from);
        let fill_normals = points
            .iter()
            .map(|p| (p.measure == 0.0 && !c.joubert_walls).then(|| normal(p)))
            .collect();
        if c.joubert_walls {
            frames.extend(
                points
                    .iter()
                    .map(|p| BoundaryFrame::marker(p.normal, [0.0; 3])),
            );
        }
        let fluid: Vec<usize> = (0..set.len())
            .filter(|&i| set.kinds.kind(set.id[i]) == Kind::Fluid)
            .collect();
        for &a in &fluid {
            set.rho[a] = c.rho0;
            set.vel[a] = [0.0; 3];
        }
        Ok(Self {
            c,
            set,
            frames,
            fill_normals,
            fluid,
        })
    }

    /// The state's size: four numbers (ρ', u_x, u_y, u_z) a fluid particle.
    pub fn len(&self) -> usize {
        4 * self.fluid.len()
    }

    pub fn is_empty(&self) -> bool {
        self.fluid.is_empty()
    }

    /// The fluid particles' positions, in the state's order.
    pub fn positions(&self) -> Vec<[f64; 3]> {
        self.fluid.iter().map(|&a| self.set.pos[a]).collect()
    }

    /// The wall particles' count (Adami's layers or Joubert's one).
    pub fn n_wall(&self) -> usize {
        self.set.kinds.n_wall
    }

    /// W of the energy E = xᵀ W x / 2 (module doc), a weight per state entry.
    pub fn energy_weights(&self) -> Vec<f64> {
        let s = (self.c.sound_speed / self.c.rho0).powi(2);
        (self.fluid.iter())
            .flat_map(|&a| {
                let m = self.set.mass[a];
                [m * s, m, m, m]
            })
            .collect()
    }

    /// The rates (dρ/dt, du/dt of each fluid particle, the state's order) at rest + `x`.
    pub fn rates(&self, x: &[f64]) -> Vec<f64> {
        assert_eq!(x.len(), self.len(), "a state of 4 entries a fluid particle");
        let mut s = self.set.clone();
        for (k, &a) in self.fluid.iter().enumerate() {
            s.rho[a] = self.c.rho0 + x[4 * k];
            s.vel[a] = [x[4 * k + 1], x[4 * k + 2], x[4 * k + 3]];
            s.press[a] = self.c.pressure(s.rho[a]);
        }
        // The boundary pass before the rates, as the solver runs it: Joubert eq. (25) at
        // his one layer, Adami's extrapolation at Adami's layers. (Until 2026-12-07
        // Adami's walls kept the rest state's p = 0 here, a pressure-release wall:
        // regression linearised_adami_walls_extrapolate.)
        if self.c.joubert_walls {
            let values = boundary_values_cpu(&self.c, &s, &self.frames);
            for (i, v) in values.into_iter().enumerate() {
                if let Some(v) = v {
                    (s.press[i], s.rho[i], s.vel[i]) = (v.press, v.rho, v.vel);
                }
            }
        } else {
            let marker_base = s.kinds.marker_base();
            let fill_side = |i: usize| {
                let id = s.id[i] as usize;
                (id >= marker_base)
                    .then(|| self.fill_normals[id - marker_base])
                    .flatten()
            };
            let values = boundary_pressure_with_fill_cpu(&self.c, &s, fill_side);
            for (i, v) in values.into_iter().enumerate() {
                if let Some((p, rho)) = v {
                    (s.press[i], s.rho[i]) = (p, rho);
                }
            }
        }
        // The step enters the rates through the mass correction only.
        let r = fluid_rates_cpu(&self.c, &s, 1e-5);
        (self.fluid.iter())
            .flat_map(|&a| {
                let (drho, du) = r[a].expect("a fluid particle's rates");
                [drho, du[0], du[1], du[2]]
            })
            .collect()
    }

    /// The whole J, row-major, [`Self::len`] squared: column k is J applied to entry k's
    /// unit (ρ' in units of ρ0/c, so both halves probe alike) over that unit.
    /// `progress(columns done, columns)` is called every 400 columns.
    pub fn jacobian(&self, mut progress: impl FnMut(usize, usize)) -> Vec<f64> {
        let n = self.len();
        let mut jac = vec![0.0; n * n];
        let mut e = vec![0.0; n];
        for col in 0..n {
            e[col] = if col % 4 == 0 {
                self.c.rho0 / self.c.sound_speed
            } else {
                1.0
            };
            for (row, v) in self.apply(&e).iter().enumerate() {
                jac[row * n + col] = v / e[col];
            }
            e[col] = 0.0;
            if col % 400 == 399 {
                progress(col + 1, n);
            }
        }
        jac
    }

    /// Writes [`Self::jacobian`] to `out`: a little-endian u64 n, then J as n × n
    /// little-endian f64, row-major; and to `out.txt` each fluid particle's position and
    /// its four energy weights, in the state's order (what
    /// `results/2026-12-07-cpu-wall-mode/modes.py` reads).
    pub fn write_jacobian(
        &self,
        out: &std::path::Path,
        progress: impl FnMut(usize, usize),
    ) -> std::io::Result<()> {
        let jac = self.jacobian(progress);
        let mut f = std::io::BufWriter::new(std::fs::File::create(out)?);
        f.write_all(&(self.len() as u64).to_le_bytes())?;
        for x in &jac {
            f.write_all(&x.to_le_bytes())?;
        }
        f.flush()?;
        let mut side = out.as_os_str().to_owned();
        side.push(".txt");
        let mut p = std::io::BufWriter::new(std::fs::File::create(side)?);
        let w = self.energy_weights();
        for (k, x) in self.positions().iter().enumerate() {
            let wk = &w[4 * k..4 * k + 4];
            writeln!(
                p,
                "{} {} {} {} {} {} {}",
                x[0], x[1], x[2], wk[0], wk[1], wk[2], wk[3]
            )?;
        }
        p.flush()
    }

    /// The markers' count (0 without bodies).
    pub fn n_markers(&self) -> usize {
        self.set.kinds.n_markers
    }

    /// The fastest growth rate of small motions, 1/s: x' = J x integrated from `x0` by
    /// `steps` classical Runge–Kutta steps of `dt`, x rescaled to |x|_W = 1 after each
    /// (|x|²_W = Σ W x², [`Self::energy_weights`]), the mean of ln |x|_W's growth a step
    /// over the second half, over `dt`. As the steps go it tends to the largest Re λ of
    /// J's eigenvalues that `x0` holds (a power iteration on one step's propagator). A
    /// neutral mode (λ = iω) reads slightly negative, RK4 damping it by |R(iωΔt)| < 1;
    /// `dt` must keep ωΔt under RK4's limit of 2.8 for the fastest ω, or the step itself
    /// grows. Each step costs four [`Self::apply`], eight evaluations of the rates.
    pub fn growth_rate(&self, x0: &[f64], dt: f64, steps: usize) -> f64 {
        let w = self.energy_weights();
        let norm = |x: &[f64]| {
            (x.iter().zip(&w))
                .map(|(v, w)| w * v * v)
                .sum::<f64>()
                .sqrt()
        };
        let axpy = |x: &[f64], a: f64, k: &[f64]| -> Vec<f64> {
            x.iter().zip(k).map(|(x, k)| x + a * k).collect()
        };
        let n0 = norm(x0);
        assert!(n0 > 0.0, "x0 must not be zero");
        let mut x: Vec<f64> = x0.iter().map(|v| v / n0).collect();
        let mut log_growth = 0.0;
        for step in 0..steps {
            let k1 = self.apply(&x);
            let k2 = self.apply(&axpy(&x, 0.5 * dt, &k1));
            let k3 = self.apply(&axpy(&x, 0.5 * dt, &k2));
            let k4 = self.apply(&axpy(&x, dt, &k3));
            for i in 0..x.len() {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            let n = norm(&x);
            if step >= steps / 2 {
                log_growth += n.ln();
            }
            x.iter_mut().for_each(|v| *v /= n);
        }
        log_growth / ((steps - steps / 2) as f64 * dt)
    }

    /// J x, J the rates' Jacobian at rest, by a central difference of [`Self::rates`]
    /// along x, scaled to [`PROBE`].
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let rho_per_u = self.c.rho0 / self.c.sound_speed;
        let size = (0..x.len())
            .map(|k| {
                if k % 4 == 0 {
                    x[k].abs() / rho_per_u
                } else {
                    x[k].abs()
                }
            })
            .fold(0.0, f64::max);
        if size == 0.0 {
            return vec![0.0; x.len()];
        }
        let h = PROBE * self.c.sound_speed / size;
        let plus: Vec<f64> = x.iter().map(|v| h * v).collect();
        let minus: Vec<f64> = x.iter().map(|v| -h * v).collect();
        let (rp, rm) = (self.rates(&plus), self.rates(&minus));
        rp.iter()
            .zip(&rm)
            .map(|(p, m)| (p - m) / (2.0 * h))
            .collect()
    }
}
