// ---- joubert2020_body_loads.wgsl (CPU twin: joubert2020_body_loads.rs) ----
// Joubert eqs. (31)–(32): per surface marker i (fill points, of area 0, carry none)
//   t_i = (−p_i n_i + μ (∇u + ∇uᵀ)_i · n_i) ΔS_i,   ∇u_i = Σ_f V_f (u_f − u_i) ⊗ B_i ∇W_if
// over fluid neighbours f (V_f = m/ρ_f, μ = ρ0 ν), moment (r_i − r_cg) × t_i about the
// body's centre of mass extrapolated like the markers (r_cg + v_cg τ).
// With GRADIENT_CORRECTION, B_i = M_i⁻¹ with the one-sided M_i = −Σ_f V_f ∇W_if ⊗ r_if
// (Joubert eq. 10 over the fluid only, as in joubert2020_boundary_values.wgsl): the
// gradient of a linear field is then exact at the surface, where the uncorrected sum
// sees half a support. Where M_i is near-singular (tr M/3 < B_DET_MIN or
// det M < B_DET_MIN (tr M/3)³) B_i = I and count_one_sided_fallback() counts it
// (diag[2], composed in by joubert2020_body_loads.rs). Without the correction B_i = I.
// Each evaluation adds weight·(t_i, M_i) to the marker's slot (indexed by marker id, so
// in DEM order) with Kahan compensation; the window average is the sum.
// reduce_body_loads then sums each body's contiguous marker range in one workgroup
// with a tree reduction.
// Needs: prelude, SPH constants, B_DET_MIN, count_one_sided_fallback, StepParams,
// grid_common, kernel, marker_update (library).

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(2) @binding(0) var<storage, read> markers_in: array<Marker>;
@group(2) @binding(1) var<storage, read> bodies: array<Body>;
@group(2) @binding(2) var<storage, read> clock: Clock;
// Two vec4 per marker: force (xyz), moment (xyz); window sums.
@group(2) @binding(3) var<storage, read_write> marker_load: array<vec4<f32>>;
// Kahan compensation of marker_load.
@group(2) @binding(4) var<storage, read_write> marker_load_c: array<vec4<f32>>;

fn kahan_add(k: u32, x: vec4<f32>) {
    let y = x - marker_load_c[k];
    let s = marker_load[k];
    let t = s + y;
    marker_load_c[k] = (t - s) - y;
    marker_load[k] = t;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn marker_loads(@builtin(workgroup_id) wid: vec3<u32>,
                @builtin(local_invocation_index) lid: u32,
                @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_marker(id[i]) {
        return;
    }
    let k = marker_index(id[i]);
    let m = markers_in[k];
    // A fill point (area 0, inside the body) has no surface: its slot stays at the
    // window's cleared zero, and no one-sided B is formed or counted for it.
    if m.pos_area.w == 0.0 {
        return;
    }
    let n = m.normal.xyz;
    let p_i = pos[i].xyz;
    let u_i = vel[i].xyz;
    var traction = -press[i] * n;
    if NU > 0.0 {
        let c_i = cell_coord(p_i);
        var grad_u = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        var m_i = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
            for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
                let rs = row_ranges(c_i, dy, dz);
                for (var k = 0u; k < row_length(rs); k++) {
                    let j = row_slot(rs, k);
                    let r_ij = pair_vec(p_i, pos[j].xyz);
                    let r2 = dot(r_ij, r_ij);
                    if r2 >= SUPPORT_RADIUS2 || !is_fluid(id[j]) {
                        continue;
                    }
                    let grad_w = kernel_grad_factor(sqrt(r2)) * r_ij;
                    let v_j = pos[j].w / rho[j];
                    let du = v_j * (vel[j].xyz - u_i);
                    // Column b holds Σ V du ∇W_b (before B: ∂u/∂x_b).
                    grad_u += mat3x3<f32>(du * grad_w.x, du * grad_w.y, du * grad_w.z);
                    if GRADIENT_CORRECTION {
                        let vgw = v_j * grad_w;
                        m_i -= mat3x3<f32>(vgw * r_ij.x, vgw * r_ij.y, vgw * r_ij.z);
                    }
                }
            }
        }
        if GRADIENT_CORRECTION {
            let scale = (m_i[0][0] + m_i[1][1] + m_i[2][2]) / 3.0;
            let det = determinant(m_i);
            if scale >= B_DET_MIN && det >= B_DET_MIN * scale * scale * scale {
                // B by the adjugate (as in joubert2020_gradients.wgsl); ∂u_a/∂x_b =
                // Σ_c D_ac B_bc, i.e. G = D Bᵀ.
                let b = transpose(mat3x3<f32>(cross(m_i[1], m_i[2]), cross(m_i[2], m_i[0]), cross(m_i[0], m_i[1]))) * (1.0 / det);
                grad_u = grad_u * transpose(b);
            } else {
                count_one_sided_fallback();
            }
        }
        // (∇u + ∇uᵀ)·n = G n + Gᵀ n.
        traction += (RHO0 * NU) * (grad_u * n + n * grad_u);
    }
    traction *= m.pos_area.w;
    let b = bodies[bitcast<u32>(m.vel_body.w)];
    let arm = p_i - (b.cg.xyz + clock.tau * b.vel.xyz);
    let w = params.load_weight;
    kahan_add(2u * k, vec4<f32>(w * traction, 0.0));
    kahan_add(2u * k + 1u, vec4<f32>(w * cross(arm, traction), 0.0));
}
