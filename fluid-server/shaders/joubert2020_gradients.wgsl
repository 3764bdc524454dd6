// ---- joubert2020_gradients.wgsl: the per-step gradient pass (CPU twin:
// joubert2020_gradients.rs) ----
// One thread per fluid particle, once per step after the grid sort. Over the support
// (all kinds of neighbour, V_j = m/ρ_j):
//   M_i = −Σ_j V_j ∇W_ij ⊗ r_ij                  the truncation matrix (Joubert eq. 10;
//                                               ⟨∇f⟩_i = M_i ∇f_i for a linear f)
//   B_i = M_i⁻¹ if det M_i ≥ B_DET_MIN, else I   (near-singular: counted in diag[1])
//   ⟨∇f⟩ᶜ_i = B_i Σ_j V_j (f_j − f_i) ∇W_ij      for f = u_x, u_y, u_z, p, ρ (eqs. 7, 9–10;
//                                               ρ: the renormalised gradient of δ-SPH)
//   s_i = r̄_i² Σ_j e_ij / r_ij²                  the shift direction of eq. (17) before
//                                               its factor β ‖u‖max Δt
// and the largest fluid speed of the step (diag[0], f32 bits: non-negative floats
// order like their bit patterns).
// Needs: prelude, SPH constants, StepParams, grid_common, kernel.

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// Columns of B_i: bmat[3i + c].
@group(0) @binding(9) var<storage, read_write> bmat: array<vec4<f32>>;
// grads[6i + 0..2] = ⟨∇u_x⟩ᶜ, ⟨∇u_y⟩ᶜ, ⟨∇u_z⟩ᶜ; [6i + 3] = ⟨∇p⟩ᶜ; [6i + 4] = s_i;
// [6i + 5] = ⟨∇ρ⟩ᶜ.
@group(0) @binding(10) var<storage, read_write> grads: array<vec4<f32>>;
@group(3) @binding(4) var<storage, read_write> diag: array<atomic<u32>, 4>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn gradients(@builtin(workgroup_id) wid: vec3<u32>,
             @builtin(local_invocation_index) lid: u32,
             @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    let p_i = pos[i].xyz;
    let u_i = vel[i].xyz;
    let pr_i = press[i];
    let c_i = cell_coord(p_i);
    var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var gux = vec3<f32>(0.0);
    var guy = vec3<f32>(0.0);
    var guz = vec3<f32>(0.0);
    var gp = vec3<f32>(0.0);
    var grho = vec3<f32>(0.0);
    let rho_i = rho[i];
    var r_sum = 0.0;
    var count = 0.0;
    var s = vec3<f32>(0.0);
    for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
        for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
            let rs = row_ranges(c_i, dy, dz);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_ij, r_ij);
                if r2 >= SUPPORT_RADIUS2 || j == i {
                    continue;
                }
                let r = sqrt(r2);
                let rho_j = rho[j];
                let vgw = (MASS / rho_j) * kernel_grad_factor(r) * r_ij;
                // −V_j ∇W ⊗ r_ij: column c is −V_j ∇W r_ij[c].
                m -= mat3x3<f32>(vgw * r_ij.x, vgw * r_ij.y, vgw * r_ij.z);
                let du = vel[j].xyz - u_i;
                gux += du.x * vgw;
                guy += du.y * vgw;
                guz += du.z * vgw;
                gp += (press[j] - pr_i) * vgw;
                grho += (rho_j - rho_i) * vgw;
                r_sum += r;
                count += 1.0;
                s += r_ij / (r2 * r);
            }
        }
    }
    let det = determinant(m);
    var b = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    if det >= B_DET_MIN {
        // Inverse by the adjugate: the rows of M⁻¹ are the cross products of M's columns.
        b = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1]))) * (1.0 / det);
    } else {
        atomicAdd(&diag[1], 1u);
    }
    bmat[3u * i] = vec4<f32>(b[0], 0.0);
    bmat[3u * i + 1u] = vec4<f32>(b[1], 0.0);
    bmat[3u * i + 2u] = vec4<f32>(b[2], 0.0);
    grads[6u * i] = vec4<f32>(b * gux, 0.0);
    grads[6u * i + 1u] = vec4<f32>(b * guy, 0.0);
    grads[6u * i + 2u] = vec4<f32>(b * guz, 0.0);
    grads[6u * i + 3u] = vec4<f32>(b * gp, 0.0);
    grads[6u * i + 5u] = vec4<f32>(b * grho, 0.0);
    var r_mean = 0.0;
    if count > 0.0 {
        r_mean = r_sum / count;
    }
    grads[6u * i + 4u] = vec4<f32>(r_mean * r_mean * s, 0.0);
    atomicMax(&diag[0], bitcast<u32>(length(u_i)));
}
