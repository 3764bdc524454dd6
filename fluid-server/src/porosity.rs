//! Porosity of unresolved grains, Robinson eq. (9): at a point x,
//!
//! ε(x) = 1 − Σ_j W(|x − x_j|, h_c) V_j
//!
//! over the grains j within the support, V_j a grain's volume, h_c the coupling length
//! (Robinson sets it to the fluid's smoothing length, and so do we: the kernel is the
//! fluid's). At a grain the sum includes the grain itself.
//!
//! On the CPU in f64: the fluid server evaluates it at the grains each window (their drag,
//! Robinson eqs. 28–33) and at the fluid particles once, for their initial mass and
//! density; the fluid particles' porosity during a run comes from the GPU
//! (`grain_solid_fraction`, [`crate::unresolved_coupling`]), with this as its twin.
//!
//! With `coupling.porosity_pressure = "energy-pair"` the GPU pass also sums ∇ε at each
//! particle (twin: [`PorosityField::gradient`]) for the fluid's pressure terms.
//!
//! Grains are binned in hashed cells one support wide ([`CellHash`]); on a periodic axis the
//! cells divide the period and distances are minimum images. Many points are summed on
//! the worker pool's threads. At the grains, window after window, [`GrainPorosity`]
//! keeps each grain's neighbours in a list across windows instead of binning anew.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::kernel::{KERNEL_WGSL, SmoothingKernel, norm};
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::sph_kernel::{Access, BODIES, PARAMS, PARTICLES, SphKernel, particle_binding as pb};
use crate::unresolved_coupling::grain_binding;
use couplet_protocol::Scene;
use couplet_protocol::cell_hash::CellHash;
use rayon::prelude::*;

pub const GRAIN_POROSITY_WGSL: &str = include_str!("../shaders/grain_porosity.wgsl");
pub const POROSITY_READ_WGSL: &str = include_str!("../shaders/grain_porosity_read.wgsl");
/// Without grains the porosity is 1 everywhere and no buffer is bound.
const NO_POROSITY_WGSL: &str = "fn porosity(i: u32) -> f32 {
    return 1.0;
}
";

/// `porosity(i)` for a kernel that needs it (the EOS, the integrator, the blow-up
/// check), and the binding to add to its group 0 when the scene has grains.
pub fn porosity_wgsl(c: &SphConstants) -> (&'static str, Option<(u32, Access)>) {
    if c.grains {
        (POROSITY_READ_WGSL, Some((pb::SOLID, Access::Read)))
    } else {
        (NO_POROSITY_WGSL, None)
    }
}

/// A boundary pass's `pos` binding and its wall state among grains (CPU twin:
/// [`boundary_state_cpu`]). Where grains reach a wall the wall particle stands for fluid
/// at the porosity there (Robinson §3.1): superficial density ε ρ(p) and mass ε m, so its
/// volume m/ρ is the lattice's and its terms in the fluid's sums (m_w P_w/ρ_w² beside
/// m_f P_f/ρ_f², m_w u·∇W in continuity) are those of the fluid it stands for. At
/// porosity 1 a fluid particle's pair term with it, m_w (P_a/ρ_a² + P_w/ρ_w²), was
/// (1/ε² + 1)/(2/ε) of the fluid's own (+2.5 % at ε = 0.8, +13 % at 0.6) and its
/// continuity term 1/ε of it.
/// Markers keep porosity 1 (`grain_solid_fraction` adds nothing to them). Without grains
/// `pos` is read-only and the state is the plain one.
pub fn boundary_state_wgsl(c: &SphConstants) -> (String, Vec<(u32, Access)>) {
    if c.grains {
        (
            format!("{WALL_POS_RW_WGSL}{POROSITY_READ_WGSL}{WALL_STATE_AMONG_GRAINS_WGSL}"),
            vec![(pb::POS, Access::ReadWrite), (pb::SOLID, Access::Read)],
        )
    } else {
        (
            PLAIN_WALL_STATE_WGSL.to_owned(),
            vec![(pb::POS, Access::Read)],
        )
    }
}

const WALL_POS_RW_WGSL: &str =
    "@group(0) @binding(0) var<storage, read_write> pos: array<vec4<f32>>;
";
const WALL_STATE_AMONG_GRAINS_WGSL: &str = "fn boundary_density(i: u32, p: f32) -> f32 {
    return porosity(i) * tait_density(p);
}
fn store_boundary_mass(i: u32) {
    if is_wall(id[i]) {
        pos[i].w = porosity(i) * LATTICE_MASS;
    }
}
";
const PLAIN_WALL_STATE_WGSL: &str =
    "@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
fn boundary_density(i: u32, p: f32) -> f32 {
    return tait_density(p);
}
fn store_boundary_mass(i: u32) {}
";

/// CPU twin of [`boundary_state_wgsl`]: a wall particle's (density, mass) at pressure `p`
/// where the porosity is `eps`.
pub fn boundary_state_cpu(c: &SphConstants, p: f64, eps: f64) -> (f64, f64) {
    (eps * c.density(p), eps * c.mass)
}

/// `energy-pair` (`coupling.porosity_pressure`): `grain_solid_fraction` also sums the
/// porosity's gradient at each fluid and wall particle,
///
/// ∇ε_a = −Σ_j V_j ∇_a W_aj = Σ_j V_j F(r_aj) (x_j − x_a)   (the gradient of eq. 9),
///
/// in i32 counts of 2^-24/h per component (`solid_grad`, four per particle, permuted
/// like the solid fraction): integer adds commute, so the sums do not depend on the
/// order in which grains reach a particle. Range 2^7/h, against |∇ε| ≤ 2/h or so for a
/// lattice; a count is 6e-8/h, some 1e-7 of a block face's gradient. CPU twin:
/// [`PorosityField::gradient`].
/// The unit of the ∇ε sums: this many counts make 1/h (`POROSITY_GRADIENT_COUNTS` and
/// `porosity_gradient` below write it as 16777216.0).
pub const POROSITY_GRADIENT_COUNTS_PER_INV_H: f64 = 16_777_216.0;

/// ∇ε as the `solid_grad` buffer holds it for one particle (tests read it back).
pub fn porosity_gradient_from_counts(c: &SphConstants, counts: [i32; 4]) -> [f64; 3] {
    let unit = 1.0 / (POROSITY_GRADIENT_COUNTS_PER_INV_H * c.kernel.h);
    [0, 1, 2].map(|k| f64::from(counts[k]) * unit)
}

const POROSITY_GRADIENT_ADD_WGSL: &str =
    "@group(0) @binding(18) var<storage, read_write> solid_grad: array<atomic<i32>>;
const POROSITY_GRADIENT_COUNTS: f32 = 16777216.0 * H;
// r = x_j − x_a (grain minus particle), at distance r_abs.
fn add_porosity_gradient(a: u32, v: f32, r: vec3<f32>, r_abs: f32) {
    let counts = round(v * kernel_grad_factor(r_abs) * POROSITY_GRADIENT_COUNTS * r);
    atomicAdd(&solid_grad[4u * a], i32(counts.x));
    atomicAdd(&solid_grad[4u * a + 1u], i32(counts.y));
    atomicAdd(&solid_grad[4u * a + 2u], i32(counts.z));
}
";
const NO_POROSITY_GRADIENT_ADD_WGSL: &str =
    "fn add_porosity_gradient(a: u32, v: f32, r: vec3<f32>, r_abs: f32) {}
";

/// The fluid's pressure terms under `energy-pair`: `pressure_porosity(i)` (the ε that
/// multiplies P in the pair sum) and `porosity_gradient(i)` (∇ε_i, read from the sums
/// of [`POROSITY_GRADIENT_ADD_WGSL`]); 1 and 0 otherwise, so the terms are Robinson's.
/// Needs `porosity(i)` ([`porosity_wgsl`]). Returns the WGSL and the bindings to add to
/// group 0.
pub fn porosity_pair_wgsl(c: &SphConstants) -> (&'static str, Vec<(u32, Access)>) {
    if c.porosity_pair {
        (
            POROSITY_GRADIENT_READ_WGSL,
            vec![(pb::SOLID_GRAD, Access::Read)],
        )
    } else {
        (NO_POROSITY_PAIR_WGSL, Vec::new())
    }
}

const POROSITY_GRADIENT_READ_WGSL: &str =
    "@group(0) @binding(18) var<storage, read> solid_grad: array<i32>;
fn pressure_porosity(i: u32) -> f32 {
    return porosity(i);
}
fn porosity_gradient(i: u32) -> vec3<f32> {
    let k = 4u * i;
    return vec3<f32>(f32(solid_grad[k]), f32(solid_grad[k + 1u]), f32(solid_grad[k + 2u]))
        * (INV_H / 16777216.0);
}
";
const NO_POROSITY_PAIR_WGSL: &str = "fn pressure_porosity(i: u32) -> f32 {
    return 1.0;
}
fn porosity_gradient(i: u32) -> vec3<f32> {
    return vec3<f32>(0.0);
}
";

/// Compiles `grain_solid_fraction` (Robinson eq. 9 at the fluid particles, and with
/// `energy-pair` its gradient).
pub fn solid_fraction_kernel(
    gpu: &Gpu,
    c: &SphConstants,
    grid_layout: &wgpu::BindGroupLayout,
) -> SphKernel {
    let mut particles = vec![
        (pb::POS, Access::Read),
        (pb::ID, Access::Read),
        (pb::SOLID, Access::ReadWrite),
    ];
    let gradient = if c.porosity_pair {
        particles.push((pb::SOLID_GRAD, Access::ReadWrite));
        POROSITY_GRADIENT_ADD_WGSL
    } else {
        NO_POROSITY_GRADIENT_ADD_WGSL
    };
    SphKernel::new(
        gpu,
        "sph: grain_solid_fraction",
        &[
            &c.wgsl(),
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            KERNEL_WGSL,
            gradient,
            GRAIN_POROSITY_WGSL,
        ],
        "grain_solid_fraction",
        &[
            (PARTICLES, &particles),
            (
                BODIES,
                &[
                    (grain_binding::POS, Access::Read),
                    (grain_binding::VEL, Access::Read),
                    (grain_binding::TAU, Access::Uniform),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// Where porosity is summed: the kernel, its support radius, and the period of each
/// axis (0: not periodic) with the domain's lower corner on it.
#[derive(Debug, Clone, Copy)]
pub struct PorosityField {
    pub kernel: SmoothingKernel,
    pub support: f64,
    /// Period per axis, m (0: not periodic).
    pub period: [f64; 3],
    /// Lower corner of the domain (the periodic axes wrap from it).
    pub origin: [f64; 3],
}

/// A grain as the porosity sees it: centre and solid volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solid {
    pub position: [f64; 3],
    pub volume: f64,
}

impl PorosityField {
    /// The scene's field: the fluid's kernel, world coordinates, the domain's periods.
    pub fn of_scene(c: &SphConstants, scene: &Scene) -> PorosityField {
        let d = &scene.domain;
        PorosityField {
            kernel: c.kernel,
            support: c.support_radius(),
            period: std::array::from_fn(|k| {
                if d.periodic[k] {
                    d.max[k] - d.min[k]
                } else {
                    0.0
                }
            }),
            origin: d.min,
        }
    }

    /// r_a − r_b as the nearest image on periodic axes.
    #[cfg(test)]
    fn separation(&self, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        crate::particles::nearest_image(a, b, self.period)
    }

    /// Threads [`PorosityField::porosity`] and [`PorosityField::gradient`] run on for
    /// `points` points: one below [`PARALLEL_MIN_POINTS`], else the worker pool's (rayon's:
    /// the machine's threads unless `RAYON_NUM_THREADS` says otherwise).
    pub fn threads(points: usize) -> usize {
        if points < PARALLEL_MIN_POINTS {
            1
        } else {
            rayon::current_num_threads()
        }
    }

    /// `at(p, bins)` for each of `points`, split into one run of consecutive points per
    /// thread. Each value is its own point's sum, so the bits do not depend on the
    /// thread count.
    fn each_point<T: Copy + Default + Send>(
        &self,
        points: &[[f64; 3]],
        solids: &[Solid],
        at: impl Fn([f64; 3], &Bins) -> T + Sync,
    ) -> Vec<T> {
        let bins = Bins::new(self, solids);
        par_map(points.len(), |i| at(points[i], &bins))
    }

    /// ε at each of `points` (Robinson eq. 9), from `solids`.
    pub fn porosity(&self, points: &[[f64; 3]], solids: &[Solid]) -> Vec<f64> {
        self.each_point(points, solids, |p, bins| {
            let mut solid = 0.0;
            bins.each_solid_near(p, |r, j| {
                // Robinson eq. (9).
                solid += self.kernel.w(norm(r)) * solids[j].volume;
            });
            1.0 - solid
        })
    }

    /// ∇ε at each of `points`, the gradient of eq. (9): −Σ_j V_j ∇W(x − x_j) (CPU twin of
    /// the `energy-pair` sums in `grain_solid_fraction`).
    pub fn gradient(&self, points: &[[f64; 3]], solids: &[Solid]) -> Vec<[f64; 3]> {
        self.each_point(points, solids, |p, bins| {
            let mut g = [0.0; 3];
            bins.each_solid_near(p, |r, j| {
                let f = self.kernel.grad_factor(norm(r)) * solids[j].volume;
                for k in 0..3 {
                    g[k] -= f * r[k];
                }
            });
            g
        })
    }
}

/// `f(i)` for i in 0..n, on the worker pool's threads from [`PARALLEL_MIN_POINTS`] on
/// ([`PorosityField::threads`]). Each value is its own index's, so the bits do not depend
/// on the thread count.
fn par_map<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    if PorosityField::threads(n) == 1 {
        return (0..n).map(f).collect();
    }
    (0..n).into_par_iter().map(&f).collect()
}

/// Robinson eq. (9) at the grains themselves, once a window (their drag, eqs. 28–33),
/// from a neighbour list kept across windows (a Verlet list): each grain's list holds
/// the grains within the support plus a skin, and is rebuilt once any grain has moved
/// more than half the skin from where it was at the build, so no grain can enter the
/// support unlisted. Between builds a window sums only its list (about 1.3 times the
/// grains in the support) instead of the 27 cells one support wide around it (about 6
/// times), each pair at the periodic image found at the build (no `round` per pair): at
/// the RTI's 15 300 grains on two threads 4.70 ms a window against 18.2 ms binned anew
/// (`couplet bench scenes/rayleigh-taylor.toml`, 2026-11-29; on an H200's 16 threads
/// the binned sum took 5.8 ms of the RTI's 21 ms window). Each list is sorted by grain
/// index and a grain's terms are summed in that order, whatever was listed beyond the
/// support, so the porosity's bits do not depend on when the list was built: a run
/// restored from a checkpoint, which builds anew, continues as the saved one would have.
#[derive(Debug, Clone)]
pub struct GrainPorosity {
    field: PorosityField,
    /// Grain i's list is `near[start[i]..start[i + 1]]`: each entry a grain's index in
    /// its low [`IMAGE_SHIFT`] bits and, above them, the periodic image it is seen at,
    /// fixed at the build (per axis 2 bits: 0, 1 or 2 for 0, +1 or −1 periods, 3 for
    /// more, found again each window).
    start: Vec<usize>,
    near: Vec<u32>,
    /// The grains' positions at the last build.
    built_at: Vec<[f64; 3]>,
    /// Lists built so far.
    builds: u64,
}

/// The skin of [`GrainPorosity`]'s lists, as a fraction of the support: the lists hold
/// (1 + s)³ ≈ 1.33 times the grains within the support at s = 0.1, and are rebuilt once a
/// grain has moved s/2 of the support (20 µm at the CPB's 0.4 mm; its block settles at
/// 3 mm/s, 0.3 µm a window).
pub const GRAIN_LIST_SKIN: f64 = 0.1;

/// Bits of a [`GrainPorosity`] list entry that hold the grain's index; the 6 above hold
/// its periodic image.
const IMAGE_SHIFT: u32 = 26;

impl GrainPorosity {
    pub fn new(field: PorosityField) -> GrainPorosity {
        GrainPorosity {
            field,
            start: Vec::new(),
            near: Vec::new(),
            built_at: Vec::new(),
            builds: 0,
        }
    }

    /// Lists built so far (the first call builds one).
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// ε at each of `grains` (Robinson eq. 9, each grain its own neighbour), from the
    /// lists, rebuilt first if a grain has moved half the skin (a jump across a period
    /// counts as a move: the lists hold each pair's image) or the grains changed.
    ///
    /// # Panics
    /// With 2^26 grains or more (the index bits of a list entry).
    pub fn porosity(&mut self, grains: &[Solid]) -> Vec<f64> {
        assert!(grains.len() < 1 << IMAGE_SHIFT, "{} grains", grains.len());
        let skin = GRAIN_LIST_SKIN * self.field.support;
        let moved = |i: usize| {
            let (a, b) = (grains[i].position, self.built_at[i]);
            let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 0.25 * skin * skin
        };
        if self.built_at.len() != grains.len() || (0..grains.len()).any(moved) {
            self.build(grains, skin);
        }
        let (r2max, kernel) = (self.field.support * self.field.support, self.field.kernel);
        let (start, near, period) = (&self.start, &self.near, self.field.period);
        par_map(grains.len(), |i| {
            let mut solid = 0.0;
            let x = grains[i].position;
            for &e in &near[start[i]..start[i + 1]] {
                let g = &grains[(e & ((1 << IMAGE_SHIFT) - 1)) as usize];
                // x_i − x_j less its image's periods: the arithmetic of
                // `particles::nearest_image`, with the image it found at the build.
                let r: [f64; 3] = std::array::from_fn(|k| {
                    let d = x[k] - g.position[k];
                    match (e >> (IMAGE_SHIFT + 2 * k as u32)) & 3 {
                        0 => d,
                        1 => d - period[k],
                        2 => d - -period[k],
                        _ => d - period[k] * (d / period[k]).round(),
                    }
                });
                let r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
                if r2 < r2max {
                    // Robinson eq. (9).
                    solid += kernel.w(r2.sqrt()) * g.volume;
                }
            }
            1.0 - solid
        })
    }

    fn build(&mut self, grains: &[Solid], skin: f64) {
        let wide = PorosityField {
            support: self.field.support + skin,
            ..self.field
        };
        let bins = Bins::new(&wide, grains);
        let period = self.field.period;
        let lists: Vec<Vec<u32>> = par_map(grains.len(), |i| {
            let mut l = Vec::new();
            let x = grains[i].position;
            bins.each_solid_near(x, |_, j| {
                let image = (0..3).fold(j as u32, |e, k| {
                    let p = period[k];
                    let n = if p > 0.0 {
                        ((x[k] - grains[j].position[k]) / p).round()
                    } else {
                        0.0
                    };
                    // Grains unwrapped and drifted more than a period apart: found
                    // again each window, as `nearest_image` does.
                    let bits = match n as i64 {
                        0 => 0,
                        1 => 1,
                        -1 => 2,
                        _ => 3,
                    };
                    e | bits << (IMAGE_SHIFT + 2 * k as u32)
                });
                l.push(image);
            });
            // By grain index, whatever the image bits: the order of the sum.
            l.sort_unstable_by_key(|e| e & ((1 << IMAGE_SHIFT) - 1));
            l
        });
        self.start.clear();
        self.start.push(0);
        self.near.clear();
        for l in &lists {
            self.near.extend_from_slice(l);
            self.start.push(self.near.len());
        }
        self.built_at = grains.iter().map(|g| g.position).collect();
        self.builds += 1;
    }
}

/// Points from which [`PorosityField::porosity`], [`PorosityField::gradient`] and
/// [`GrainPorosity::porosity`] split over the machine's threads. The fluid server sums
/// at every grain once a window, on the CPU between the GPU's steps, where on a GPU it
/// can set the window's pace: at 15 300 grains (the CPB and RTI) the sum took 97.5 ms on
/// one thread before it was binned in a `CellHash` and split, 17.5 ms after on two
/// (2026-11-29, `couplet bench scenes/rayleigh-taylor.toml`), and its neighbour lists
/// made it four times cheaper again ([`GrainPorosity`]). Below this many points,
/// handing them to the worker pool costs more than it saves.
const PARALLEL_MIN_POINTS: usize = 2048;

/// Solids binned for look-ups within one support: a [`CellHash`] of cells at least one
/// support wide (on a periodic axis they divide the period), over the solids' positions
/// wrapped into the periodic box, so that a nearest image is at most one period away.
struct Bins {
    hash: CellHash,
    /// Each solid's position from the field's origin, wrapped into [0, period) on
    /// periodic axes.
    at: Vec<[f64; 3]>,
    origin: [f64; 3],
    /// Period per axis (0: open).
    period: [f64; 3],
    r2max: f64,
}

impl Bins {
    fn new(field: &PorosityField, solids: &[Solid]) -> Bins {
        let mut bins = Bins {
            hash: CellHash::default(),
            at: Vec::new(),
            origin: field.origin,
            period: field.period,
            r2max: field.support * field.support,
        };
        bins.at = solids.iter().map(|s| bins.wrap(s.position)).collect();
        let period = field.period.map(|l| (l > 0.0).then_some(l));
        (bins.hash).build(&bins.at, field.support, [0.0; 3], period);
        bins
    }

    /// `p` from the origin, wrapped into [0, period) on periodic axes.
    fn wrap(&self, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| {
            let (q, l) = (p[k] - self.origin[k], self.period[k]);
            if l > 0.0 { q - l * (q / l).floor() } else { q }
        })
    }

    /// Calls `visit(r_pj, j)` for every solid j within the support of `p`, with
    /// r_pj = p − x_j the nearest image, each solid once.
    fn each_solid_near(&self, p: [f64; 3], mut visit: impl FnMut([f64; 3], usize)) {
        let q = self.wrap(p);
        let half = self.period.map(|l| 0.5 * l);
        // The buckets' slices walked directly: through `CellHash::candidates`' flat_map
        // the sums took 15 % longer.
        let (buckets, m) = self.hash.near_buckets(q);
        for &b in &buckets[..m] {
            for &j in self.hash.bucket(b) {
                let x = self.at[j as usize];
                // Both wrapped: the nearest image is at most one period away.
                let r: [f64; 3] = std::array::from_fn(|k| {
                    let d = q[k] - x[k];
                    if self.period[k] > 0.0 && d > half[k] {
                        d - self.period[k]
                    } else if self.period[k] > 0.0 && d < -half[k] {
                        d + self.period[k]
                    } else {
                        d
                    }
                });
                if r[0] * r[0] + r[1] * r[1] + r[2] * r[2] < self.r2max {
                    visit(r, j as usize);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use couplet_protocol::KernelKind;

    fn field(period: [f64; 3]) -> PorosityField {
        let kernel = SmoothingKernel::new(KernelKind::WendlandC2, 2e-4);
        PorosityField {
            kernel,
            support: kernel.radius(),
            period,
            origin: [0.0; 3],
        }
    }

    /// Grains jittered (±0.15 of the spacing) about a lattice at ε = 0.8, six spacings
    /// across in y and z and filling x's period, so that lists cross it; `seed` picks the
    /// jitter.
    fn jittered_grains(f: &PorosityField, seed: u64) -> Vec<Solid> {
        let d: f64 = 1e-4;
        let v = std::f64::consts::PI / 6.0 * d.powi(3);
        let dr = (v / 0.2).cbrt();
        let mut state = seed;
        let mut jitter = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.3 * dr
        };
        let n = (f.period[0] / dr).round() as usize;
        let mut g = Vec::new();
        for i in 0..n {
            for j in 0..6 {
                for k in 0..6 {
                    let x = [i as f64 * dr, j as f64 * dr, k as f64 * dr];
                    g.push(Solid {
                        position: std::array::from_fn(|a| x[a] + jitter()),
                        volume: v,
                    });
                }
            }
        }
        g
    }

    /// The grains' porosity from the lists kept across windows equals eq. (9) summed
    /// afresh ([`PorosityField::porosity`], to f64 round-off: the terms are added in
    /// another order) at the build, after moves under half the skin (no rebuild), after
    /// one grain moves past it and after it is carried two periods on (rebuilds). Its
    /// bits do not depend on when the lists were built: lists built at the first
    /// positions and used at the moved ones give what lists built at the moved ones give
    /// (a run restored from a checkpoint builds anew).
    #[test]
    fn grain_lists_give_eq_9_and_the_same_bits_whenever_built() {
        let mut f = field([0.0; 3]);
        f.period[0] = 14.0 * (std::f64::consts::PI / 6.0 * 1e-12 / 0.2).cbrt();
        let mut g = jittered_grains(&f, 7);
        let close = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        let mut lists = GrainPorosity::new(f);
        let centres = |g: &[Solid]| g.iter().map(|s| s.position).collect::<Vec<_>>();
        let e = lists.porosity(&g);
        let fresh = f.porosity(&centres(&g), &g);
        assert!(close(&e, &fresh) < 1e-14, "{}", close(&e, &fresh));
        assert!(e.iter().all(|x| *x > 0.6 && *x < 0.95), "{e:?}");
        assert_eq!(lists.builds(), 1);
        // Every grain 0.9 of half the skin along a diagonal of its own (random signs),
        // some across the period: pairs close in by up to 0.9 of the skin, so lists
        // without one would miss grains that came into the support.
        let step = 0.9 * 0.5 * GRAIN_LIST_SKIN * f.support / 3f64.sqrt();
        let mut state = 11u64;
        for s in g.iter_mut() {
            for k in 0..3 {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s.position[k] += if state >> 63 == 1 { step } else { -step };
            }
        }
        let moved = lists.porosity(&g);
        assert_eq!(lists.builds(), 1, "moved under half the skin: no rebuild");
        assert!(close(&moved, &f.porosity(&centres(&g), &g)) < 1e-14);
        assert_eq!(
            moved,
            GrainPorosity::new(f).porosity(&g),
            "bits depend on the build"
        );
        // One grain past half the skin: rebuilt, and still eq. (9).
        g[100].position[1] += 0.6 * GRAIN_LIST_SKIN * f.support;
        let after = lists.porosity(&g);
        assert_eq!(lists.builds(), 2);
        assert!(close(&after, &f.porosity(&centres(&g), &g)) < 1e-14);
        assert_ne!(after[100], moved[100]);
        // The same grain two periods along x, unwrapped (a DEM that does not wrap): a
        // rebuild, its pairs two periods apart, and the same porosity.
        let mut far = g.clone();
        far[100].position[0] += 2.0 * f.period[0];
        let e_far = lists.porosity(&far);
        assert_eq!(lists.builds(), 3);
        assert!(close(&e_far, &after) < 1e-14, "{}", close(&e_far, &after));
    }

    /// A lone grain: ε = 1 − V W(0) at its centre (Robinson eq. 9 with one term) and 1
    /// beyond the support. Reference: the kernel's value at 0.
    #[test]
    fn lone_grain() {
        let f = field([0.0; 3]);
        let v = std::f64::consts::PI / 6.0 * 1e-12; // d = 0.1 mm
        let g = [Solid {
            position: [1e-3; 3],
            volume: v,
        }];
        let e = f.porosity(&[[1e-3; 3], [1e-3 + 1.01 * f.support, 1e-3, 1e-3]], &g);
        assert!((e[0] - (1.0 - v * f.kernel.w(0.0))).abs() < 1e-15, "{e:?}");
        assert_eq!(e[1], 1.0);
    }

    /// Inside a cubic lattice of grains of spacing Δr (Robinson §4: Δr = (V/(1 − ε))^(1/3)
    /// for porosity ε) the kernel sum is the lattice's number density: ε within 0.5 % of
    /// the lattice's 0.8 at h = 2d (Δr/h = 0.69), Robinson's setting for the CPB.
    #[test]
    fn lattice_of_grains_has_its_porosity() {
        let f = field([0.0; 3]);
        let d: f64 = 1e-4;
        let v = std::f64::consts::PI / 6.0 * d.powi(3);
        let dr = (v / 0.2).cbrt();
        let mut g = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                for k in 0..20 {
                    g.push(Solid {
                        position: [i as f64 * dr, j as f64 * dr, k as f64 * dr],
                        volume: v,
                    });
                }
            }
        }
        let mid = 9.5 * dr;
        let e = f.porosity(&[[mid; 3], [9.0 * dr; 3]], &g);
        println!("lattice porosity: {e:?}");
        for x in e {
            assert!((x - 0.8).abs() < 0.004, "ε = {x}");
        }
    }

    /// The lattice ripple of eq. (9) that made the CPB's aligned columns drift
    /// (ARCHITECTURE.md, "The fluid's lattice must not be the grains'"): ε = 0.8 grains
    /// on a cubic lattice, Wendland C2 at h = 1.5 Δr. Along a row through grain sites ε
    /// runs from 0.79937 (at a site) to 0.79993 (halfway), ±2.8e-4; along a row midway
    /// between rows of sites from 0.80016 to 0.80028, ±6e-5. Reference: the same sums
    /// done independently in Python (9³ neighbouring cells) on 2026-11-28; bounds ±5e-6.
    #[test]
    fn lattice_porosity_ripples_with_the_lattice() {
        let d: f64 = 1e-4;
        let v = std::f64::consts::PI / 6.0 * d.powi(3);
        let dr = (v / 0.2).cbrt();
        let kernel = SmoothingKernel::new(KernelKind::WendlandC2, 1.5 * dr);
        let f = PorosityField {
            kernel,
            support: kernel.radius(),
            period: [0.0; 3],
            origin: [0.0; 3],
        };
        let g: Vec<Solid> = (0..20 * 20 * 20)
            .map(|n| Solid {
                position: [n % 20, n / 20 % 20, n / 400].map(|i| i as f64 * dr),
                volume: v,
            })
            .collect();
        let at = |x: f64, y: f64| f.porosity(&[[x * dr, y * dr, x * dr]], &g)[0];
        let (site, half) = (at(10.0, 10.0), at(10.0, 10.5));
        let (between_lo, between_hi) = (at(10.5, 10.0), at(10.5, 10.5));
        println!("ripple: on a row {site} … {half}, between rows {between_lo} … {between_hi}");
        for (got, want) in [
            (site, 0.799372),
            (half, 0.799929),
            (between_lo, 0.800158),
            (between_hi, 0.800284),
        ] {
            assert!((got - want).abs() < 5e-6, "ε = {got}, want {want}");
        }
    }

    /// 300 grains (V = 1e-13 m³) at random points of the box `period`, and `points`
    /// points reaching `overhang` periods beyond it on each side; seeded (an LCG).
    fn random_grains_and_points(
        period: [f64; 3],
        overhang: f64,
        points: usize,
        mut seed: u64,
    ) -> (Vec<Solid>, Vec<[f64; 3]>) {
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let solids: Vec<Solid> = (0..300)
            .map(|_| Solid {
                position: std::array::from_fn(|k| rnd() * period[k]),
                volume: 1e-13,
            })
            .collect();
        let points = (0..points)
            .map(|_| {
                std::array::from_fn(|k| (rnd() * (1.0 + 2.0 * overhang) - overhang) * period[k])
            })
            .collect();
        (solids, points)
    }

    /// `gradient` is the derivative of `porosity` (eq. 9): against central differences
    /// of ε with a step of 1e-4 h, at 200 random points of a periodic box holding 300
    /// random grains, to 1e-5 of the largest |∇ε| (the differences' truncation, O(step²),
    /// and their round-off, 1e-16/step, are both far below it).
    #[test]
    fn gradient_is_the_derivative_of_the_porosity() {
        let s = field([0.0; 3]).support;
        let period = [3.1 * s, 2.2 * s, 3.1 * s];
        let f = field(period);
        let (solids, points) = random_grains_and_points(period, 0.0, 200, 777);
        let got = f.gradient(&points, &solids);
        let step = 1e-4 * f.kernel.h;
        let (mut worst, mut largest) = (0.0f64, 0.0f64);
        for (p, g) in points.iter().zip(&got) {
            for k in 0..3 {
                let (mut a, mut b) = (*p, *p);
                a[k] += step;
                b[k] -= step;
                let e = f.porosity(&[a, b], &solids);
                let fd = (e[0] - e[1]) / (2.0 * step);
                worst = worst.max((g[k] - fd).abs());
                largest = largest.max(fd.abs());
            }
        }
        println!("∇ε: max |Δ| = {worst:e} of {largest:e} 1/m");
        assert!(
            largest > 0.0 && worst < 1e-5 * largest,
            "{worst:e} of {largest:e}"
        );
    }

    /// The hashed sum equals the all-pairs sum with minimum images, on a box periodic in
    /// x and z of 3.1 supports (cells not a whole number of supports) and 2.2 supports
    /// in y (two cells, whose ±1 neighbours coincide): 300 random grains, 200 random
    /// points, to 1e-14.
    #[test]
    fn hashed_sum_matches_all_pairs_with_periodic_images() {
        let s = field([0.0; 3]).support;
        let period = [3.1 * s, 2.2 * s, 3.1 * s];
        let f = field(period);
        let (solids, points) = random_grains_and_points(period, 0.1, 200, 12345);
        let got = f.porosity(&points, &solids);
        for (p, e) in points.iter().zip(got) {
            let mut solid = 0.0;
            for g in &solids {
                let r = f.separation(*p, g.position);
                let r = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
                if r < s {
                    solid += f.kernel.w(r) * g.volume;
                }
            }
            assert!((e - (1.0 - solid)).abs() < 1e-14, "{e} vs {}", 1.0 - solid);
        }
    }

    /// From `PARALLEL_MIN_POINTS` points the sums run on the machine's threads; each
    /// point's ε and ∇ε keep the bits they have summed alone on one thread (so a run
    /// gives the same numbers on any machine): 3000 random points, 300 grains, a box
    /// periodic in x and z.
    #[test]
    fn threaded_sums_match_one_thread_bit_for_bit() {
        let s = field([0.0; 3]).support;
        let period = [3.1 * s, 0.0, 3.1 * s];
        let f = field(period);
        let (solids, mut points) =
            random_grains_and_points([3.1 * s, 4.0 * s, 3.1 * s], 0.1, 3000, 4242);
        assert!(points.len() >= PARALLEL_MIN_POINTS);
        points.iter_mut().for_each(|p| p[1] -= 0.5 * s);
        let (eps, grad) = (f.porosity(&points, &solids), f.gradient(&points, &solids));
        let mut near = 0;
        for (i, p) in points.iter().enumerate() {
            assert_eq!(f.porosity(&[*p], &solids)[0].to_bits(), eps[i].to_bits());
            assert_eq!(
                f.gradient(&[*p], &solids)[0].map(f64::to_bits),
                grad[i].map(f64::to_bits)
            );
            near += usize::from(eps[i] < 1.0);
        }
        println!(
            "{} threads; {near} of {} points near a grain",
            PorosityField::threads(points.len()),
            points.len()
        );
        assert!(near > 1000, "{near}");
    }
}
