// ---- robinson_variable_h.wgsl: Robinson's variable smoothing length (CPU twin:
// robinson_variable_h.rs) ----
// Once per step after the sort, one thread per particle:
//   h_i = H (V_i/δ³)^(1/3),  V_i = m_i/ρ_i                         (Robinson eq. 19)
//   Ω_i = 1 − (∂h_i/∂ρ_i) Σ_j m_j ∂W_ij(h_i)/∂h_i                   (eq. 11)
//       = 1 − (1/(3ρ_i)) Σ_j m_j (3 W_ij + r_ij² F_ij)(h_i)
// with ∂h/∂ρ = −h/(3ρ) from eq. (19) and ∂W/∂h = −(3W + r ∂W/∂r)/h for a kernel
// σ(h) f(r/h), σ ∝ h⁻³. The sum runs over every particle within h_i's support,
// itself included (its 3W(0)). Walls and markers keep (H, 1): their volume is δ³ by
// construction (boundary_state_wgsl), which eq. (19) maps to H.
// Needs: prelude, SPH constants, StepParams, grid_common, kernel.

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// (h_i, Ω_i) per particle, written after every sort (not permuted).
@group(0) @binding(17) var<storage, read_write> smoothing: array<vec2<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn smoothing_lengths(@builtin(workgroup_id) wid: vec3<u32>,
                     @builtin(local_invocation_index) lid: u32,
                     @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total {
        return;
    }
    if !is_fluid(id[i]) {
        smoothing[i] = vec2<f32>(H, 1.0);
        return;
    }
    let p_i = pos[i].xyz;
    let rho_i = rho[i];
    let h_i = variable_h_of(pos[i].w, rho_i);
    let reach2 = support2_at(h_i);
    let c_i = cell_coord(p_i);
    var sum = 0.0;
    for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
        for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
            let rs = row_ranges(c_i, dy, dz);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_ij, r_ij);
                if r2 >= reach2 {
                    continue;
                }
                let r = sqrt(r2);
                sum += pos[j].w * (3.0 * kernel_w_h(r, h_i) + r2 * kernel_grad_factor_h(r, h_i));
            }
        }
    }
    smoothing[i] = vec2<f32>(h_i, 1.0 - sum / (3.0 * rho_i));
}
