// ---- joubert2020_gradients.wgsl: the per-step gradient pass (CPU twin:
// joubert2020_gradients.rs) ----
// A team of DENSE_LANES threads per fluid particle (one on a CPU adapter), once per step
// after the grid sort. Over the support
// (all kinds of neighbour, V_j = m/ρ_j):
//   M_i = −Σ_j V_j ∇W_ij ⊗ r_ij                  the truncation matrix (Joubert eq. 10;
//                                               ⟨∇f⟩_i = M_i ∇f_i for a linear f)
//   B_i = M_i⁻¹ if det M_i ≥ B_DET_MIN, else I   (near-singular: counted in diag[1])
//   ⟨∇f⟩ᶜ_i = B_i Σ_j V_j (f_j − f_i) ∇W_ij      for f = u_x, u_y, u_z, p, ρ/ε (eqs. 7, 9–10;
//                                               ρ/ε: the renormalised gradient of δ-SPH,
//                                               of the intrinsic density among grains)
//   s_i = r̄_i² Σ_j (m_j/(m_0 ε_j)) e_ij / r_ij²  the shift direction of eq. (17) before
//                                               its factor β ‖u‖max Δt, each neighbour
//                                               counted as the lattice particles
//                                               (m_0 = LATTICE_MASS) it stands for: among
//                                               unresolved grains a particle's mass is
//                                               ε m_0 (initial_mass.rs, porosity.rs)
// and the largest fluid speed of the step (diag[0], f32 bits: non-negative floats
// order like their bit patterns).
// With B_HAT_SOLVE (the corrected Laplacian or the mass correction) also B̂_i of Joubert eq. (11): with q(e) = (e_x², e_y², e_z²,
// e_x e_y, e_x e_z, e_y e_z) and ∇W_ij = F(r) r_ij (a radial kernel),
//   Ĉ_(cd)(mn) = Σ_j V_j F r² q_cd q_mn + R_(mn) · (B_i P_(cd)),
//   P_(cd) = Σ_j V_j F r³ q_cd e,  R_(mn) = Σ_j V_j F r q_mn e  (vectors),
// and B̂_i symmetric with B̂ : Ĉ = −I on symmetric Hessians: a 6 × 6 system (columns of
// the off-diagonal B̂ entries doubled) solved by Gaussian elimination with partial
// pivoting. Near-singular (B_i fell back to I, or a pivot below LAP_PIVOT_MIN of the
// largest entry): B̂ = I (Morris's operator with the gradient term) and counted in
// diag[1] with the B fallbacks; `store_bhat` writes it (joubert2020_gradients.rs).
// With variable h (robinson_variable_h.rs) every sum takes particle i's own h_i.
// GRAD_U, GRAD_P, GRAD_RHO, SHIFT_SUMS and STORE_B (joubert2020_gradients.rs,
// GradientFields) say which of ∇u, ∇p, ∇ρ/ε, s_i and B_i the scene reads; the others are
// neither summed nor written, and the gradient buffer holds GRAD_STRIDE vec4 a particle,
// each field read at its GRAD_SLOT_*.
// Needs: prelude, SPH constants, StepParams, grid_common, kernel, store_bhat,
// smoothing_length, porosity (porosity.rs: 1 without grains).

// Exponents (of e_x, e_y, e_z) of the symmetric pairs xx, yy, zz, xy, xz, yz: the
// order of B̂'s entries and of the system's rows and columns.
const PAIR_EXPONENTS = array<vec3<u32>, 6>(
    vec3<u32>(2u, 0u, 0u), vec3<u32>(0u, 2u, 0u), vec3<u32>(0u, 0u, 2u),
    vec3<u32>(1u, 1u, 0u), vec3<u32>(1u, 0u, 1u), vec3<u32>(0u, 1u, 1u));

// The 15 quartic monomials of e in four vec4 (slots 0..14, see quartic_slot).
fn quartic_a(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(x2.x * x2.x, x2.y * x2.y, x2.z * x2.z, x2.x * e.x * e.y);
}
fn quartic_b(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(x2.x * e.x * e.z, e.x * x2.y * e.y, x2.y * e.y * e.z, e.x * x2.z * e.z);
}
fn quartic_c(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(e.y * x2.z * e.z, x2.x * x2.y, x2.x * x2.z, x2.y * x2.z);
}
fn quartic_d(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(x2.x * e.y * e.z, e.x * x2.y * e.z, e.x * e.y * x2.z, 0.0);
}
// Slot of e_x^n.x e_y^n.y e_z^n.z (n.x + n.y + n.z = 4) in quartic_a..d.
fn quartic_slot(n: vec3<u32>) -> u32 {
    let key = n.x * 25u + n.y * 5u + n.z;
    switch key {
        case 100u: { return 0u; }   // xxxx
        case 20u: { return 1u; }    // yyyy
        case 4u: { return 2u; }     // zzzz
        case 80u: { return 3u; }    // xxxy
        case 76u: { return 4u; }    // xxxz
        case 40u: { return 5u; }    // xyyy
        case 16u: { return 6u; }    // yyyz
        case 28u: { return 7u; }    // xzzz
        case 8u: { return 8u; }     // yzzz
        case 60u: { return 9u; }    // xxyy
        case 52u: { return 10u; }   // xxzz
        case 12u: { return 11u; }   // yyzz
        case 56u: { return 12u; }   // xxyz
        case 36u: { return 13u; }   // xyyz
        default: { return 14u; }    // xyzz (key 32)
    }
}
// The 10 cubic monomials of e in three vec4 (slots 0..9, see cubic_slot).
fn cubic_a(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(x2.x * e.x, x2.y * e.y, x2.z * e.z, x2.x * e.y);
}
fn cubic_b(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(x2.x * e.z, e.x * x2.y, x2.y * e.z, e.x * x2.z);
}
fn cubic_c(e: vec3<f32>) -> vec4<f32> {
    let x2 = e * e;
    return vec4<f32>(e.y * x2.z, e.x * e.y * e.z, 0.0, 0.0);
}
// Slot of e_x^n.x e_y^n.y e_z^n.z (n.x + n.y + n.z = 3) in cubic_a..c.
fn cubic_slot(n: vec3<u32>) -> u32 {
    let key = n.x * 25u + n.y * 5u + n.z;
    switch key {
        case 75u: { return 0u; }    // xxx
        case 15u: { return 1u; }    // yyy
        case 3u: { return 2u; }     // zzz
        case 55u: { return 3u; }    // xxy
        case 51u: { return 4u; }    // xxz
        case 35u: { return 5u; }    // xyy
        case 11u: { return 6u; }    // yyz
        case 27u: { return 7u; }    // xzz
        case 7u: { return 8u; }     // yzz
        default: { return 9u; }     // xyz (key 31)
    }
}

// Solves the 6 × 6 system of the header for B̂ (entries xx, yy, zz, xy, xz, yz);
// returns false when a pivot is below LAP_PIVOT_MIN of the largest entry.
fn solve_bhat(a_in: array<f32, 36>, out: ptr<function, array<f32, 6>>) -> bool {
    var a = a_in;
    var x = array<f32, 6>(-1.0, -1.0, -1.0, 0.0, 0.0, 0.0);
    var scale = 0.0;
    for (var k = 0u; k < 36u; k++) {
        scale = max(scale, abs(a[k]));
    }
    for (var col = 0u; col < 6u; col++) {
        var piv = col;
        for (var r = col + 1u; r < 6u; r++) {
            if abs(a[6u * r + col]) > abs(a[6u * piv + col]) {
                piv = r;
            }
        }
        if !(abs(a[6u * piv + col]) > LAP_PIVOT_MIN * scale) {
            return false;
        }
        if piv != col {
            for (var k = 0u; k < 6u; k++) {
                let t = a[6u * col + k];
                a[6u * col + k] = a[6u * piv + k];
                a[6u * piv + k] = t;
            }
            let t = x[col];
            x[col] = x[piv];
            x[piv] = t;
        }
        for (var r = col + 1u; r < 6u; r++) {
            let f = a[6u * r + col] / a[6u * col + col];
            for (var k = col; k < 6u; k++) {
                a[6u * r + k] -= f * a[6u * col + k];
            }
            x[r] -= f * x[col];
        }
    }
    for (var ci = 0u; ci < 6u; ci++) {
        let row = 5u - ci;
        var acc = x[row];
        for (var k = row + 1u; k < 6u; k++) {
            acc -= a[6u * row + k] * x[k];
        }
        x[row] = acc / a[6u * row + row];
    }
    *out = x;
    return true;
}

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// Columns of B_i: bmat[3i + c] (with STORE_B; else 16 bytes, never written).
@group(0) @binding(9) var<storage, read_write> bmat: array<vec4<f32>>;
// From g = GRAD_STRIDE i: grads[g + GRAD_SLOT_U + 0..2] = ⟨∇u_x⟩ᶜ, ⟨∇u_y⟩ᶜ, ⟨∇u_z⟩ᶜ;
// [g + GRAD_SLOT_P] = ⟨∇p⟩ᶜ; [g + GRAD_SLOT_S] = s_i; [g + GRAD_SLOT_RHO] = ⟨∇ρ⟩ᶜ; only
// the fields read (16 bytes, never written, when none is).
@group(0) @binding(10) var<storage, read_write> grads: array<vec4<f32>>;
@group(3) @binding(4) var<storage, read_write> diag: array<atomic<u32>, 4>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn gradients(@builtin(workgroup_id) wid: vec3<u32>,
             @builtin(local_invocation_index) lid: u32,
             @builtin(num_workgroups) nwg: vec3<u32>) {
    // A team of DENSE_LANES threads per fluid particle (neighbour_grid.rs,
    // dense_team_lanes): each lane sums its share of the rows, `dense_team_sum` adds the
    // lanes' sums in lane order, and the first lane finishes the particle.
    let i = linear_id(wid, lid, nwg) / DENSE_LANES;
    let lane = lid % DENSE_LANES;
    let fluid_i = i < params.n_total && is_fluid(id[i]);
    var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var gux = vec3<f32>(0.0);
    var guy = vec3<f32>(0.0);
    var guz = vec3<f32>(0.0);
    var gp = vec3<f32>(0.0);
    var grho = vec3<f32>(0.0);
    var r_sum = 0.0;
    var count = 0.0;
    var s = vec3<f32>(0.0);
    // Corrected Laplacian sums (header), only with B_HAT_SOLVE: C1 is fully
    // symmetric (15 quartic monomials of e), P and R too (10 cubic ones each), so the
    // loop keeps 10 vec4 accumulators (see quartic/cubic below).
    var q4a = vec4<f32>(0.0);
    var q4b = vec4<f32>(0.0);
    var q4c = vec4<f32>(0.0);
    var q4d = vec4<f32>(0.0);
    var p3a = vec4<f32>(0.0);
    var p3b = vec4<f32>(0.0);
    var p3c = vec4<f32>(0.0);
    var r3a = vec4<f32>(0.0);
    var r3b = vec4<f32>(0.0);
    var r3c = vec4<f32>(0.0);
    if fluid_i {
        let p_i = pos[i].xyz;
        let u_i = vel[i].xyz;
        let pr_i = press[i];
        let c_i = cell_coord(p_i);
        let rho_i = rho[i];
        // δ-SPH's renormalised gradient is of the intrinsic density ρ/ε (1 without grains).
        let rho_f_i = rho_i / porosity(i);
        // Variable h: B_i from particle i's own kernel, the one its rates take.
        let h_i = smoothing_length(i);
        let reach2 = support2_at(h_i);
        for (var row = i32(lane); row < ROWS; row += i32(DENSE_LANES)) {
            let rs = row_ranges(c_i, team_row(row).x, team_row(row).y);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_ij, r_ij);
                if r2 >= reach2 || j == i {
                    continue;
                }
                let r = sqrt(r2);
                let rho_j = rho[j];
                let vgw = (pos[j].w / rho_j) * grad_factor_at(r, h_i) * r_ij;
                // −V_j ∇W ⊗ r_ij: column c is −V_j ∇W r_ij[c].
                m -= mat3x3<f32>(vgw * r_ij.x, vgw * r_ij.y, vgw * r_ij.z);
                // Only the fields the scene reads (joubert2020_gradients.rs, GradientFields).
                if GRAD_U {
                    let du = vel[j].xyz - u_i;
                    gux += du.x * vgw;
                    guy += du.y * vgw;
                    guz += du.z * vgw;
                }
                if GRAD_P {
                    gp += (press[j] - pr_i) * vgw;
                }
                if GRAD_RHO {
                    grho += (rho_j / porosity(j) - rho_f_i) * vgw;
                }
                if SHIFT_SUMS {
                    r_sum += r;
                    count += 1.0;
                    s += (pos[j].w / (LATTICE_MASS * porosity(j))) * r_ij / (r2 * r);
                }
                if B_HAT_SOLVE {
                    let e = r_ij / r;
                    let vf = (pos[j].w / rho_j) * grad_factor_at(r, h_i);
                    let w1 = vf * r2;
                    q4a += w1 * quartic_a(e);
                    q4b += w1 * quartic_b(e);
                    q4c += w1 * quartic_c(e);
                    q4d += w1 * quartic_d(e);
                    let c3a = cubic_a(e);
                    let c3b = cubic_b(e);
                    let c3c = cubic_c(e);
                    p3a += (w1 * r) * c3a;
                    p3b += (w1 * r) * c3b;
                    p3c += (w1 * r) * c3c;
                    r3a += (vf * r) * c3a;
                    r3b += (vf * r) * c3b;
                    r3c += (vf * r) * c3c;
                }
            }
        }
    }
    // The team's sums, in uniform control flow (the GRAD_* flags and B_HAT_SOLVE are
    // constants).
    let t0 = dense_team_sum(vec4<f32>(m[0], r_sum), lid);
    let t1 = dense_team_sum(vec4<f32>(m[1], count), lid);
    let t2 = dense_team_sum(vec4<f32>(m[2], s.x), lid);
    m = mat3x3<f32>(t0.xyz, t1.xyz, t2.xyz);
    r_sum = t0.w;
    count = t1.w;
    if GRAD_U || SHIFT_SUMS {
        let t3 = dense_team_sum(vec4<f32>(gux, s.y), lid);
        let t4 = dense_team_sum(vec4<f32>(guy, s.z), lid);
        s = vec3<f32>(t2.w, t3.w, t4.w);
        gux = t3.xyz;
        guy = t4.xyz;
    }
    if GRAD_U {
        guz = dense_team_sum(vec4<f32>(guz, 0.0), lid).xyz;
    }
    if GRAD_P {
        gp = dense_team_sum(vec4<f32>(gp, 0.0), lid).xyz;
    }
    if GRAD_RHO {
        grho = dense_team_sum(vec4<f32>(grho, 0.0), lid).xyz;
    }
    if B_HAT_SOLVE {
        q4a = dense_team_sum(q4a, lid);
        q4b = dense_team_sum(q4b, lid);
        q4c = dense_team_sum(q4c, lid);
        q4d = dense_team_sum(q4d, lid);
        p3a = dense_team_sum(p3a, lid);
        p3b = dense_team_sum(p3b, lid);
        p3c = dense_team_sum(p3c, lid);
        r3a = dense_team_sum(r3a, lid);
        r3b = dense_team_sum(r3b, lid);
        r3c = dense_team_sum(r3c, lid);
    }
    if !fluid_i || lane != 0u {
        return;
    }
    let u_i = vel[i].xyz;
    let det = determinant(m);
    var b = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    var singular = det < B_DET_MIN;
    if !singular {
        // Inverse by the adjugate: the rows of M⁻¹ are the cross products of M's columns.
        b = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1]))) * (1.0 / det);
    }
    if B_HAT_SOLVE {
        var bhat = array<f32, 6>(1.0, 1.0, 1.0, 0.0, 0.0, 0.0);
        if !singular {
            let q4 = array<f32, 16>(q4a.x, q4a.y, q4a.z, q4a.w, q4b.x, q4b.y, q4b.z, q4b.w,
                                    q4c.x, q4c.y, q4c.z, q4c.w, q4d.x, q4d.y, q4d.z, q4d.w);
            let p3 = array<f32, 12>(p3a.x, p3a.y, p3a.z, p3a.w, p3b.x, p3b.y, p3b.z, p3b.w,
                                    p3c.x, p3c.y, p3c.z, p3c.w);
            let r3 = array<f32, 12>(r3a.x, r3a.y, r3a.z, r3a.w, r3b.x, r3b.y, r3b.z, r3b.w,
                                    r3c.x, r3c.y, r3c.z, r3c.w);
            var a = array<f32, 36>();
            for (var row = 0u; row < 6u; row++) {
                let pr = PAIR_EXPONENTS[row];
                let p_row = vec3<f32>(p3[cubic_slot(pr + vec3<u32>(1u, 0u, 0u))],
                                      p3[cubic_slot(pr + vec3<u32>(0u, 1u, 0u))],
                                      p3[cubic_slot(pr + vec3<u32>(0u, 0u, 1u))]);
                let bp = b * p_row;
                for (var col = 0u; col < 6u; col++) {
                    let pc = PAIR_EXPONENTS[col];
                    let r_col = vec3<f32>(r3[cubic_slot(pc + vec3<u32>(1u, 0u, 0u))],
                                          r3[cubic_slot(pc + vec3<u32>(0u, 1u, 0u))],
                                          r3[cubic_slot(pc + vec3<u32>(0u, 0u, 1u))]);
                    // Off-diagonal B̂ entries appear twice in B̂ : Ĉ.
                    let mult = select(2.0, 1.0, col < 3u);
                    a[6u * row + col] = mult * (q4[quartic_slot(pr + pc)] + dot(r_col, bp));
                }
            }
            var x = array<f32, 6>();
            if solve_bhat(a, &x) {
                bhat = x;
            } else {
                singular = true;
            }
        }
        store_bhat(i, vec4<f32>(bhat[0], bhat[1], bhat[2], 0.0), vec4<f32>(bhat[3], bhat[4], bhat[5], 0.0));
    }
    if singular {
        atomicAdd(&diag[1], 1u);
    }
    if STORE_B {
        // w of the first column: 1 in the free-surface zone (the rates take the standard
        // forms).
        bmat[3u * i] = vec4<f32>(b[0], select(0.0, 1.0, FREE_SURFACE_SWITCH && det < FREE_SURFACE_DET));
        bmat[3u * i + 1u] = vec4<f32>(b[1], 0.0);
        bmat[3u * i + 2u] = vec4<f32>(b[2], 0.0);
    }
    let g = GRAD_STRIDE * i;
    if GRAD_U {
        grads[g + GRAD_SLOT_U] = vec4<f32>(b * gux, 0.0);
        grads[g + GRAD_SLOT_U + 1u] = vec4<f32>(b * guy, 0.0);
        grads[g + GRAD_SLOT_U + 2u] = vec4<f32>(b * guz, 0.0);
    }
    if GRAD_P {
        grads[g + GRAD_SLOT_P] = vec4<f32>(b * gp, 0.0);
    }
    if GRAD_RHO {
        grads[g + GRAD_SLOT_RHO] = vec4<f32>(b * grho, 0.0);
    }
    if SHIFT_SUMS {
        var r_mean = 0.0;
        if count > 0.0 {
            r_mean = r_sum / count;
        }
        grads[g + GRAD_SLOT_S] = vec4<f32>(r_mean * r_mean * s, 0.0);
    }
    atomicMax(&diag[0], bitcast<u32>(length(u_i)));
}
