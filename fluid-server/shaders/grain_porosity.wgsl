// ---- grain_porosity.wgsl: the grains' solid fraction at each fluid particle, Robinson
// eq. (9) (CPU twin: porosity.rs) ----
// grain_solid_fraction: a team of TEAM_LANES threads per grain j (grid_common.wgsl), each
// over its share of the grain's rows, after every sort: a window start's and each fluid
// step's but the window's first, which sorts nothing (FluidSolver::start_sorted). To each
// fluid or wall particle a within the support it adds V_j W_aj, in counts of SOLID_UNIT
// (2^-31: a solid fraction up to 2 fits a u32; integer adds commute, so the sums are
// exact and independent of thread order). porosity(a) = 1 − the sum
// (grain_porosity_read.wgsl), held over the window.
// With coupling.porosity_pressure = "energy-pair" it also sums ∇ε (add_porosity_gradient,
// porosity.rs; a no-op otherwise).
// Needs: prelude, SPH constants, StepParams, grid_common, kernel, add_porosity_gradient.

@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// Solid fraction per particle, counts of SOLID_UNIT, permuted with the particles.
@group(0) @binding(16) var<storage, read_write> solid: array<atomic<u32>>;
// Per grain: xyz position relative to the solver origin at the window's start, w volume
// V (m³); xyz velocity (w: diameter).
@group(2) @binding(7) var<storage, read> grain_pos: array<vec4<f32>>;
@group(2) @binding(8) var<storage, read> grain_vel: array<vec4<f32>>;
// x: time since the window's start, s. The grains move by v τ within a window, so the
// porosity follows them every fluid step instead of jumping once a window.
@group(2) @binding(11) var<uniform> grain_tau: vec4<f32>;

const SOLID_COUNTS: f32 = 2147483648.0;

@compute @workgroup_size(WORKGROUP_SIZE)
fn grain_solid_fraction(@builtin(workgroup_id) wid: vec3<u32>,
                        @builtin(local_invocation_index) lid: u32,
                        @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = linear_id(wid, lid, nwg);
    let g = t / TEAM_LANES;
    if g >= arrayLength(&grain_pos) {
        return;
    }
    let p = grain_pos[g].xyz + grain_tau.x * grain_vel[g].xyz;
    let v = grain_pos[g].w;
    let c = cell_coord(p);
    for (var row = i32(t % TEAM_LANES); row < ROWS; row += i32(TEAM_LANES)) {
        let rs = row_ranges(c, team_row(row).x, team_row(row).y);
        for (var k = 0u; k < row_length(rs); k++) {
            let a = row_slot(rs, k);
            // Fluid and wall particles (a wall stands for fluid at the porosity
            // there: boundary_state_wgsl in porosity.rs); markers keep porosity 1.
            if !(is_fluid(id[a]) || is_wall(id[a])) {
                continue;
            }
            let r = pair_vec(p, pos[a].xyz);
            let r2 = dot(r, r);
            if r2 >= SUPPORT_RADIUS2 {
                continue;
            }
            // Robinson eq. (9), and with energy-pair its gradient (porosity.rs).
            let r_abs = sqrt(r2);
            atomicAdd(&solid[a], u32(round(v * kernel_w(r_abs) * SOLID_COUNTS)));
            add_porosity_gradient(a, v, r, r_abs);
        }
    }
}
