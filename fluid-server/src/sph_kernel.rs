//! A compiled SPH compute kernel with explicit bind group layouts, and its bound form.
//!
//! Every operator declares the bindings its WGSL uses as `(group, [(binding, Access)])`
//! lists; [`SphKernel::bind`] builds the bind groups from whatever buffers the caller
//! maps to them. Group 1 is always the neighbour grid's own layout and bind group
//! (`grid_common.wgsl`), so pair kernels share it.

use crate::gpu::Gpu;
use crate::shaders;

/// How a kernel uses a binding (must match the WGSL declaration exactly).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    Read,
    ReadWrite,
    Uniform,
}

/// Bindings of one group: `(binding, access)`.
pub type GroupBindings<'a> = &'a [(u32, Access)];

/// Group index of the particle arrays.
pub const PARTICLES: u32 = 0;
/// Group index of the neighbour grid (owned by `neighbour_grid.rs`).
pub const GRID: u32 = 1;
/// Group index of bodies and markers.
pub const BODIES: u32 = 2;
/// Group index of the per-window parameters and diagnostics.
pub const PARAMS: u32 = 3;

/// Particle arrays, group 0: the binding numbers every kernel uses.
pub mod particle_binding {
    pub const POS: u32 = 0;
    pub const VEL: u32 = 1;
    pub const RHO: u32 = 2;
    pub const PRESS: u32 = 3;
    pub const ID: u32 = 4;
    pub const DRHO: u32 = 5;
    pub const DVEL: u32 = 6;
    pub const RHO_N: u32 = 7;
    pub const VEL_N: u32 = 8;
    /// B matrix of Joubert eq. (10), three vec4 columns per particle (gradient pass).
    pub const BMAT: u32 = 9;
    /// Corrected ∇u_x, ∇u_y, ∇u_z, ∇p, the raw shift and ∇ρ, six vec4 per particle.
    pub const GRADS: u32 = 10;
    /// No-slip walls' velocity in the viscous sums, 2 v_w − ṽ_w (Adami et al. 2012),
    /// one vec4 per particle, written by the boundary pass (walls only).
    pub const WALL_VEL: u32 = 11;
    /// B̂_i of the corrected Laplacian (Joubert eq. 11), symmetric: two vec4 per
    /// particle, (B̂_xx, B̂_yy, B̂_zz, 0), (B̂_xy, B̂_xz, B̂_yz, 0) (gradient pass).
    pub const BHAT: u32 = 12;
    /// Joubert boundaries' `BoundaryFrame` (unit normal, symmetry flag, acceleration),
    /// two vec4 per wall or marker particle indexed by `id − n_fluid` (not permuted).
    pub const BOUNDARY_FRAME: u32 = 13;
    /// The grains' reaction on each fluid particle (Robinson eq. 26), 64-bit fixed
    /// point: low words (vec4<u32>) and high words (vec4<i32>), permuted by the sort
    /// (`grain_reaction.wgsl`); only with `coupling.two_way` grains.
    pub const REACTION_LO: u32 = 14;
    pub const REACTION_HI: u32 = 15;
    /// The grains' solid fraction at each particle (Robinson eq. 9), u32 counts of
    /// 2^-31, permuted by the sort (`grain_porosity.wgsl`); only in scenes with grains.
    pub const SOLID: u32 = 16;
    /// (h_i, Ω_i) of Robinson's variable smoothing length (eqs. 11, 19), one vec2 per
    /// particle, written after every sort (not permuted); only with variable h.
    pub const SMOOTHING: u32 = 17;
    /// ∇ε of the grains' porosity at each particle (the gradient of Robinson eq. 9),
    /// i32 counts of 2^-24/h, four per particle, permuted by the sort; only with
    /// `coupling.porosity_pressure = "energy-pair"` ([`crate::porosity`]).
    pub const SOLID_GRAD: u32 = 18;
    /// The fluid particles in each neighbour-grid cell's row window (one u32 per cell,
    /// not per particle), written after every sort ([`crate::fluid_rows`]).
    pub const ROW_FLUID: u32 = 19;
    /// What f32 rounds off a fluid particle's position (xyz) and density (w) each step,
    /// carried into the next (compensated summation, `integrate.wgsl`), one vec4 per
    /// particle, permuted by the sort.
    pub const LOW_WORDS: u32 = 20;
}

/// Bodies and markers, group 2.
pub mod body_binding {
    pub const MARKERS_IN: u32 = 0;
    pub const BODIES: u32 = 1;
    pub const CLOCK: u32 = 2;
    pub const MARKER_LOAD: u32 = 3;
    pub const MARKER_LOAD_C: u32 = 4;
    pub const LOAD_RANGES: u32 = 5;
    pub const BODY_LOADS: u32 = 6;
}

/// Parameters and diagnostics, group 3.
pub mod param_binding {
    pub const PARAMS: u32 = 0;
    pub const STATUS: u32 = 1;
    pub const BAD_VALUES: u32 = 2;
    pub const COUNTS: u32 = 3;
    /// Per-step diagnostics of the gradient pass: [0] max fluid speed (f32 bits),
    /// [1] particles with a near-singular truncation matrix, [2] Joubert boundary
    /// particles and markers (corrected ∇u of the loads) whose one-sided matrix was
    /// (per evaluation, two per step).
    pub const DIAG: u32 = 4;
    /// Per-workgroup partial sums of the window's telemetry (`window_stats.wgsl`).
    pub const PARTIALS: u32 = 5;
}

/// The WGSL part before this line is a function library other modules may include;
/// after it come the file's own bindings and entry points.
pub const KERNEL_SECTION: &str = "// ---- kernels ----";

/// The library part of a WGSL file (everything before [`KERNEL_SECTION`]).
pub fn library(src: &'static str) -> &'static str {
    src.split(KERNEL_SECTION).next().unwrap_or(src)
}

/// One of a kernel's own bind groups: its index, its layout, and each binding's access.
type GroupLayout = (u32, wgpu::BindGroupLayout, Vec<(u32, Access)>);

/// A compute pipeline and the layouts of its own (non-grid) groups.
pub struct SphKernel {
    pub label: &'static str,
    pipeline: wgpu::ComputePipeline,
    groups: Vec<GroupLayout>,
    uses_grid: bool,
}

/// A kernel with its bind groups: ready to dispatch.
pub struct BoundKernel {
    pub label: &'static str,
    pipeline: wgpu::ComputePipeline,
    groups: Vec<(u32, wgpu::BindGroup)>,
}

impl SphKernel {
    /// Compiles `entry` of the module made of `parts` (after the prelude). `groups` lists
    /// the kernel's bindings in groups 0, 2, 3; `grid_layout` is the neighbour grid's
    /// layout for pair kernels (group 1), `None` otherwise.
    pub fn new(
        gpu: &Gpu,
        label: &'static str,
        parts: &[&str],
        entry: &str,
        groups: &[(u32, GroupBindings<'_>)],
        grid_layout: Option<&wgpu::BindGroupLayout>,
    ) -> SphKernel {
        let module = shaders::module(gpu, label, parts);
        let own: Vec<GroupLayout> = groups
            .iter()
            .map(|(g, bindings)| {
                let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
                    .iter()
                    .map(|(b, a)| match a {
                        Access::Read => shaders::storage_entry(*b, true),
                        Access::ReadWrite => shaders::storage_entry(*b, false),
                        Access::Uniform => shaders::uniform_entry(*b),
                    })
                    .collect();
                let layout =
                    gpu.device
                        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                            label: Some(label),
                            entries: &entries,
                        });
                (*g, layout, bindings.to_vec())
            })
            .collect();
        let n_groups = own
            .iter()
            .map(|(g, _, _)| *g + 1)
            .max()
            .unwrap_or(0)
            .max(if grid_layout.is_some() { GRID + 1 } else { 0 });
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> = (0..n_groups)
            .map(|g| {
                if g == GRID && grid_layout.is_some() {
                    grid_layout
                } else {
                    own.iter().find(|(og, _, _)| *og == g).map(|(_, l, _)| l)
                }
            })
            .collect();
        let pipeline = shaders::compute_pipeline_with_layouts(gpu, label, &module, entry, &layouts);
        SphKernel {
            label,
            pipeline,
            groups: own,
            uses_grid: grid_layout.is_some(),
        }
    }

    /// Binds the kernel: `buffer(group, binding)` supplies each declared binding.
    /// Returns `None` when a binding has no buffer (a programming error the caller
    /// reports).
    pub fn bind<'a>(
        &self,
        gpu: &Gpu,
        buffer: impl Fn(u32, u32) -> Option<&'a wgpu::Buffer>,
        grid: Option<&wgpu::BindGroup>,
    ) -> Option<BoundKernel> {
        let mut groups = Vec::new();
        for (g, layout, bindings) in &self.groups {
            let mut entries = Vec::new();
            for (b, _) in bindings.iter() {
                entries.push(wgpu::BindGroupEntry {
                    binding: *b,
                    resource: buffer(*g, *b)?.as_entire_binding(),
                });
            }
            let bg = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(self.label),
                layout,
                entries: &entries,
            });
            groups.push((*g, bg));
        }
        if self.uses_grid {
            groups.push((GRID, grid?.clone()));
        }
        Some(BoundKernel {
            label: self.label,
            pipeline: self.pipeline.clone(),
            groups,
        })
    }
}

impl BoundKernel {
    /// Records the kernel for `n` threads (one per element) into `pass`.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, n: u32) {
        if n == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        for (g, bg) in &self.groups {
            pass.set_bind_group(*g, bg, &[]);
        }
        shaders::dispatch_linear(pass, n);
    }

    /// Records the kernel for `groups` workgroups (workgroup-per-item kernels).
    pub fn dispatch_groups(&self, pass: &mut wgpu::ComputePass<'_>, groups: u32) {
        if groups == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        for (g, bg) in &self.groups {
            pass.set_bind_group(*g, bg, &[]);
        }
        let [x, y, z] = shaders::workgroups_for_groups(groups);
        pass.dispatch_workgroups(x, y, z);
    }
}
