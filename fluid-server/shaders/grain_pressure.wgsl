// ---- grain_pressure.wgsl: each unresolved grain's pressure force under
// coupling.porosity_pressure = "energy-pair" (CPU twin: unresolved_coupling.rs,
// grain_pressure_force_cpu) ----
// grain_pressure_force: a team of TEAM_LANES threads per grain j (grid_common.wgsl), each
// over its share of the grain's rows, their sums added in lane order by the first, after
// every fluid_rates of a window. The
// fluid's rates hold (P_a/ρ_a) ∇ε_a, ∇ε_a = Σ_j V_j F(r) (x_j − x_a) from the solid
// fraction's pass (porosity.rs); the grains' share of it, summed over the same pairs
// (fluid particles a, grains at x_j + v τ, this stage's P_a and ρ_a), is
//     f_j = −V_j Σ_a (m_a/ρ_a) P_a ∇_j W_ja,     ∇_j W_ja = F(r) (x_j − x_a),
// so that m_a times the fluid's term summed over a is −Σ_j f_j. It is added with the
// stage's load weight (½ per stage over the window's substeps, as the markers' loads
// are), so that after the window grain_pressure holds the average force over exactly
// the stages the fluid took: the grains receive what the fluid lost, to f32 round-off.
// In the continuum f_j = −V_j ∇P (the buoyancy with a hydrostatic P).
// Needs: prelude, SPH constants, StepParams, grid_common, kernel.

@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// Per grain: xyz position relative to the solver origin at the window's start, w volume
// V (m³); xyz velocity (w: diameter).
@group(2) @binding(7) var<storage, read> grain_pos: array<vec4<f32>>;
@group(2) @binding(8) var<storage, read> grain_vel: array<vec4<f32>>;
// x: time since the window's start, s (the grains moved by v τ, as the porosity has them).
@group(2) @binding(11) var<uniform> grain_tau: vec4<f32>;
// Per grain: xyz the window's weighted sum of f_j, N.
@group(2) @binding(12) var<storage, read_write> grain_pressure: array<vec4<f32>>;

var<workgroup> part: array<vec3<f32>, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn grain_pressure_force(@builtin(workgroup_id) wid: vec3<u32>,
                        @builtin(local_invocation_index) lid: u32,
                        @builtin(num_workgroups) nwg: vec3<u32>) {
    let g = linear_id(wid, lid, nwg) / TEAM_LANES;
    let lane = lid % TEAM_LANES;
    let grain = g < arrayLength(&grain_pressure);
    var sum = vec3<f32>(0.0);
    if grain {
        let p = grain_pos[g].xyz + grain_tau.x * grain_vel[g].xyz;
        let c = cell_coord(p);
        for (var row = i32(lane); row < ROWS; row += i32(TEAM_LANES)) {
            let rs = row_ranges(c, team_row(row).x, team_row(row).y);
            for (var k = 0u; k < row_length(rs); k++) {
                let a = row_slot(rs, k);
                if !is_fluid(id[a]) {
                    continue;
                }
                // r = x_j − x_a.
                let r = pair_vec(p, pos[a].xyz);
                let r2 = dot(r, r);
                if r2 >= SUPPORT_RADIUS2 {
                    continue;
                }
                sum += (pos[a].w / rho[a] * press[a] * kernel_grad_factor(sqrt(r2))) * r;
            }
        }
    }
    part[lid] = sum;
    workgroupBarrier();
    if !grain || lane != 0u {
        return;
    }
    for (var l = 1u; l < TEAM_LANES; l++) {
        sum += part[lid + l];
    }
    grain_pressure[g] += vec4<f32>(-params.load_weight * grain_pos[g].w * sum, 0.0);
}
