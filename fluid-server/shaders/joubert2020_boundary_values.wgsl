// ---- joubert2020_boundary_values.wgsl (CPU twin: joubert2020_boundary_values.rs) ----
// Joubert §2.5–2.6: one layer of boundary particles on each domain face, and the
// markers on body surfaces. One thread per wall or marker particle w, before every
// rate evaluation. Over its fluid neighbours f only
// (V_f = m/ρ_f; the other boundary particles' values are what is being computed):
//   M_w = −Σ_f V_f ∇W_wf ⊗ r_wf,  B_w = M_w⁻¹              (Joubert eq. 10, one-sided)
//   S = B_w Σ_f V_f ∇W_wf,  S' = B_w Σ_f V_f/ρ_f ∇W_wf,  P = B_w Σ_f V_f p_f/ρ_f ∇W_wf
// and with n̂ the wall normal (its sign cancels):
//   p_w = (n̂·P − n̂·g + n̂·a_w − n̂·⟨∇·τ/ρ⟩_w) / n̂·S'          (Joubert eq. 25)
// with a_w the surface's acceleration (0 for domain walls, the rigid-body acceleration
// of the point for markers; from the particle's BoundaryFrame) and the viscous term
// left out (see joubert2020_boundary_values.rs); ρ_w from the inverted
// Tait equation, times the porosity among unresolved grains (with the mass:
// boundary_state_wgsl in porosity.rs). No-slip particles and markers keep their
// velocity (a Dirichlet condition);
// particles on symmetry planes (wall_normal.w = 1) take the tangential velocity of
// eq. (27) with ∂u/∂n = 0, u_w = n̂·(B_w Σ_f V_f u_f ∇W_wf) / n̂·S, and zero velocity
// along every axis their normal has a component on (the planes are axis-aligned).
// Where the one-sided M_w is near-singular (tr M/3 < B_DET_MIN, or
// det M < B_DET_MIN (tr M/3)³, or |n̂·S| δ < B_DET_MIN) the particle takes Adami et
// al.'s (2012) uncorrected extrapolation instead and is counted in diag[2]. No fluid
// neighbour: p = 0, ρ = ρ0, symmetry velocity 0.
// Rows without fluid are skipped (row_has_fluid, fluid_rows.wgsl): the sums are over
// fluid only.
// Needs: prelude, SPH constants, B_DET_MIN, StepParams, grid_common, row_fluid
// (fluid_rows.rs), kernel, tait_eos.

// ---- kernels ----
// `pos`, boundary_density and store_boundary_mass: porosity.rs, boundary_state_wgsl.
@group(0) @binding(1) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rho: array<f32>;
@group(0) @binding(3) var<storage, read_write> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// Mirror of joubert2020_boundary_values::BoundaryFrame, indexed by id − n_fluid.
struct BoundaryFrame {
    // xyz the unit normal; w = 1 on a symmetry plane.
    normal: vec4<f32>,
    // xyz the surface's acceleration, m/s².
    acc: vec4<f32>,
}
@group(0) @binding(13) var<storage, read> frames: array<BoundaryFrame>;
@group(3) @binding(4) var<storage, read_write> diag: array<atomic<u32>, 4>;

// Boundary threads write only their own entries and read only fluid entries: no race.
@compute @workgroup_size(WORKGROUP_SIZE)
fn joubert2020_boundary_values(@builtin(workgroup_id) wid: vec3<u32>,
                               @builtin(local_invocation_index) lid: u32,
                               @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || is_fluid(id[i]) {
        return;
    }
    let frame = frames[id[i] - params.n_fluid];
    let n = frame.normal.xyz;
    let a_w = frame.acc.xyz;
    let symmetry = frame.normal.w > 0.5;
    let p_i = pos[i].xyz;
    let c_i = cell_coord(p_i);
    var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var s = vec3<f32>(0.0);
    var s_rho = vec3<f32>(0.0);
    var sp = vec3<f32>(0.0);
    var sux = vec3<f32>(0.0);
    var suy = vec3<f32>(0.0);
    var suz = vec3<f32>(0.0);
    // Adami et al. (2012) eq. (27), the fallback.
    var sum_pw = 0.0;
    var sum_rho_r_w = vec3<f32>(0.0);
    var sum_w = 0.0;
    var sum_vw = vec3<f32>(0.0);
    for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
        for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
            // No fluid in the row, nothing to add (fluid_rows.wgsl).
            if !row_has_fluid(c_i, dy, dz) {
                continue;
            }
            let rs = row_ranges(c_i, dy, dz);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_wf = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_wf, r_wf);
                if r2 >= SUPPORT_RADIUS2 || !is_fluid(id[j]) {
                    continue;
                }
                let r = sqrt(r2);
                let rho_j = rho[j];
                let u_j = vel[j].xyz;
                let vgw = (pos[j].w / rho_j) * kernel_grad_factor(r) * r_wf;
                m -= mat3x3<f32>(vgw * r_wf.x, vgw * r_wf.y, vgw * r_wf.z);
                s += vgw;
                s_rho += vgw / rho_j;
                sp += (press[j] / rho_j) * vgw;
                sux += u_j.x * vgw;
                suy += u_j.y * vgw;
                suz += u_j.z * vgw;
                let w = kernel_w(r);
                sum_pw += press[j] * w;
                sum_rho_r_w += rho_j * w * r_wf;
                sum_w += w;
                sum_vw += u_j * w;
            }
        }
    }
    if sum_w <= 0.0 {
        press[i] = 0.0;
        rho[i] = boundary_density(i, 0.0);
        store_boundary_mass(i);
        if symmetry {
            vel[i] = vec4<f32>(0.0);
        }
        return;
    }
    let scale = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    let det = determinant(m);
    var ok = scale >= B_DET_MIN && det >= B_DET_MIN * scale * scale * scale;
    var p_w = 0.0;
    var u_w = vec3<f32>(0.0);
    if ok {
        // Inverse by the adjugate (as in joubert2020_gradients.wgsl).
        let b = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1]))) * (1.0 / det);
        let n_s = dot(n, b * s);
        ok = abs(n_s) * SPACING >= B_DET_MIN;
        if ok {
            // Joubert eq. (25), viscous term left out (header).
            p_w = (dot(n, b * sp) - dot(n, params.gravity.xyz) + dot(n, a_w)) / dot(n, b * s_rho);
            // Joubert eq. (27) with ∂u/∂n = 0.
            u_w = vec3<f32>(dot(n, b * sux), dot(n, b * suy), dot(n, b * suz)) / n_s;
        }
    }
    if !ok {
        atomicAdd(&diag[2], 1u);
        p_w = (sum_pw + dot(params.gravity.xyz - a_w, sum_rho_r_w)) / sum_w;
        u_w = sum_vw / sum_w;
    }
    press[i] = p_w;
    rho[i] = boundary_density(i, p_w);
    store_boundary_mass(i);
    if symmetry {
        vel[i] = vec4<f32>(select(u_w, vec3<f32>(0.0), n != vec3<f32>(0.0)), 0.0);
    }
}
