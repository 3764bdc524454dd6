// ---- fluid_rates.wgsl: continuity + momentum in one pair loop (CPU twins:
// continuity.rs, momentum.rs) ----
// Needs: prelude, SPH constants, StepParams, grid_common, kernel, continuity, momentum,
// `b_matrix(i)` and `grad_rho(i)` (fluid_rates.rs: from the gradient pass when the scene
// uses them, else I and 0), `wall_velocity(j)` (a no-slip wall's velocity in the viscous
// sums: Adami et al.'s 2 v_w − ṽ_w from the boundary pass, else its own), `b_hat(i)`
// (B̂_i of the corrected Laplacian, when LAPLACIAN_CORRECTION).
// With LAPLACIAN_CORRECTION the laminar term is Joubert eq. (13)'s
//   2ν Σ_j V_j ((u_i − u_j)/r_ij − e_ij · ⟨∇⊗u⟩ᶜ_i) s_ij,   s_ij = B̂_i : (e_ij ⊗ ∇W_ij),
// with ⟨∇⊗u⟩ᶜ_i = B_i Σ_j V_j ∇W_ij ⊗ (u_j − u_i) of the same loop's velocities. As
// e_ij · ⟨∇⊗u⟩ᶜ_i does not depend on j it factors out: the loop sums
//   A = Σ V s (u_i − u_j)/r,  Q = Σ V s e,  D = Σ V (u_j − u_i) ⊗ ∇W
// and the term is 2ν (A − D Bᵀ Q) (D's column b holds the ∂_b part).
// With MASS_CORRECTION continuity gains Joubert eq. (14)'s ρ_i Γ Δt (L15 − L16), the
// same factoring: L15 = 2 (Σ V s w (p_i − p_j)/r − (Σ V s w e)·⟨∇p⟩ᶜ_i), w = 2/(ρ_i + ρ_j),
// over every neighbour, L16 = Σ V (g_j − g_i)·B_i ∇W, g = ⟨∇p⟩ᶜ/ρ from the gradient pass (walls
// and markers: g_j = g_i). See continuity.rs for the twin and the choices.
// With VARIABLE_H (Robinson eqs. 10–12, 19; robinson_variable_h.rs) each particle has its
// own h from the step's smoothing pass: a pair counts when it lies in either support;
// ∇W_ij below is ∇W(h_i), the one the corrected forms and continuity take (eq. 10 with
// 1/Ω_i); the standard pressure term is eq. (12), P_i/(Ω_i ρ_i²) ∇W(h_i) +
// P_j/(Ω_j ρ_j²) ∇W(h_j); the viscous terms take the mean of ∇W(h_i) and ∇W(h_j).
// Without it smoothing_length() is H, omega() 1, and all of this compiles to the fixed-h
// code.
// With POROSITY_PAIR (coupling.porosity_pressure = "energy-pair", porosity.rs) the
// pressure sums take P ε in place of P (pressure_porosity), and the particle gains
// (P_i/ρ_i) ∇ε_i (porosity_gradient): with the EOS on ρ/ε (Robinson eq. 15) these are the
// terms that conserve energy; each grain gets the opposite of the ∇ε term
// (unresolved_coupling.wgsl). Otherwise pressure_porosity is 1 and the gradient 0.
// δ-SPH diffuses ρ/ε (`porosity(i)`, 1 without grains) and adds ε_i times it to dρ/dt;
// DIFFUSION_FOURTAKAS picks Fourtakas et al. 2019's term over Antuono et al. 2010's.
// A team of DENSE_LANES threads per fluid particle gathers from the neighbour cells
// (grid_common.wgsl, team_row): each lane sums its share of the rows, `dense_team_sum`
// adds the lanes' sums in lane order and the first lane writes (neighbour_grid.rs,
// dense_team_lanes, says when a particle gets more than one lane). No atomics.

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(0) @binding(5) var<storage, read_write> drho: array<f32>;
@group(0) @binding(6) var<storage, read_write> dvel: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn fluid_rates(@builtin(workgroup_id) wid: vec3<u32>,
               @builtin(local_invocation_index) lid: u32,
               @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg) / DENSE_LANES;
    let lane = lid % DENSE_LANES;
    let fluid_i = i < params.n_total && is_fluid(id[i]);
    var drho_i = 0.0;
    var acc = vec3<f32>(0.0);
    var lap_a = vec3<f32>(0.0);
    var lap_q = vec3<f32>(0.0);
    var lap_d = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var mc_a = 0.0;
    var mc_q = vec3<f32>(0.0);
    var mc_div = 0.0;
    if fluid_i {
        let p_i = pos[i].xyz;
        let u_i = vel[i].xyz;
        let rho_i = rho[i];
        let pr_i = press[i];
        let pe_i = pr_i * pressure_porosity(i);
        let c_i = cell_coord(p_i);
        let b_i = b_matrix(i);
        // The free-surface zone takes the standard forms (effects.free_surface).
        let corrected_i = !near_free_surface(i);
        let grad_rho_i = grad_rho(i);
        let eps_i = porosity(i);
        let rho_f_i = rho_i / eps_i;
        let bhat_i = b_hat(i);
        let g_i = grad_p(i) / rho_i;
        let h_i = smoothing_length(i);
        let omega_i = omega(i);
        let reach2_i = support2_at(h_i);
        for (var r = i32(lane); r < ROWS; r += i32(DENSE_LANES)) {
            let rs = row_ranges(c_i, team_row(r).x, team_row(r).y);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_ij, r_ij);
                let h_j = smoothing_length(j);
                if (r2 >= reach2_i && r2 >= support2_at(h_j)) || j == i {
                    continue;
                }
                let r_abs = sqrt(r2);
                let grad_w = grad_factor_at(r_abs, h_i) * r_ij;
                // ∇W(h_j), and the mean the viscous terms take (both ∇W with one h).
                var grad_w_j = grad_w;
                var grad_visc = grad_w;
                if VARIABLE_H {
                    grad_w_j = grad_factor_at(r_abs, h_j) * r_ij;
                    grad_visc = 0.5 * (grad_w + grad_w_j);
                }
                let u_ij = u_i - vel[j].xyz;
                let rho_j = rho[j];
                let m_j = pos[j].w;
                let pe_j = press[j] * pressure_porosity(j);
                if CORRECTED_CONTINUITY && corrected_i {
                    drho_i += corrected_continuity_term(m_j, rho_i, rho_j, u_ij, b_i * grad_w);
                } else {
                    drho_i += continuity_term(m_j, u_ij, grad_w) / omega_i;
                }
                if GRADIENT_CORRECTION && corrected_i {
                    acc += corrected_pressure_term(m_j, pe_i, rho_i, pe_j, rho_j, b_i * grad_w);
                } else if VARIABLE_H {
                    acc += robinson_pressure_term(m_j, pe_i / omega_i, rho_i, pe_j / omega(j), rho_j, grad_w, grad_w_j);
                } else {
                    acc += pressure_term(m_j, pe_i, rho_i, pe_j, rho_j, grad_w);
                }
                if MASS_CORRECTION {
                    let r = sqrt(r2);
                    let e = r_ij / r;
                    let v_j = m_j / rho_j;
                    let vs = v_j * dot(e, bhat_i * grad_w);
                    let w = 2.0 / (rho_i + rho_j);
                    mc_a += vs * w * (pr_i - press[j]) / r;
                    mc_q += (vs * w) * e;
                    let g_j = select(g_i, grad_p(j) / rho_j, is_fluid(id[j]));
                    mc_div += v_j * dot(g_j - g_i, b_i * grad_w);
                }
                if DENSITY_DIFFUSION && is_fluid(id[j]) {
                    if DIFFUSION_FOURTAKAS {
                        drho_i += eps_i * fourtakas2019_diffusion_term(m_j, rho_f_i, rho_j / porosity(j), rho_j, r_ij, r2, grad_w, params.gravity.xyz);
                    } else {
                        drho_i += eps_i * antuono2010_diffusion_term(m_j, rho_f_i, rho_j / porosity(j), rho_j, r_ij, r2, grad_w, grad_rho_i, grad_rho(j));
                    }
                }
                // Free-slip walls carry pressure but no shear.
                let wall = is_wall(id[j]);
                let viscous = NO_SLIP_WALLS || !wall;
                // A branch, not select(): select loads wall_velocity(j) for every pair.
                var u_visc = u_ij;
                if wall {
                    u_visc = u_i - wall_velocity(j);
                }
                if LAPLACIAN_CORRECTION && viscous {
                    let r = sqrt(r2);
                    let e = r_ij / r;
                    let v_j = m_j / rho_j;
                    let vs = v_j * dot(e, bhat_i * grad_w);
                    lap_a += (vs / r) * u_visc;
                    lap_q += vs * e;
                    let vgw = v_j * grad_w;
                    lap_d -= mat3x3<f32>(u_visc * vgw.x, u_visc * vgw.y, u_visc * vgw.z);
                } else if LAMINAR_VISCOSITY && viscous {
                    acc += morris1997_viscous_term(m_j, rho_i, rho_j, r_ij, r2, u_visc, grad_visc);
                }
                if ARTIFICIAL_VISCOSITY && viscous {
                    acc += monaghan1992_artificial_viscous_term(m_j, rho_i, rho_j, r_ij, r2, u_visc, grad_visc);
                }
            }
        }
    }
    // The team's sums, in uniform control flow (the flags are constants).
    let s0 = dense_team_sum(vec4<f32>(acc, drho_i), lid);
    acc = s0.xyz;
    drho_i = s0.w;
    if LAPLACIAN_CORRECTION || MASS_CORRECTION {
        let s1 = dense_team_sum(vec4<f32>(lap_a, mc_a), lid);
        let s2 = dense_team_sum(vec4<f32>(lap_q, mc_div), lid);
        lap_a = s1.xyz;
        mc_a = s1.w;
        lap_q = s2.xyz;
        mc_div = s2.w;
    }
    if MASS_CORRECTION {
        mc_q = dense_team_sum(vec4<f32>(mc_q, 0.0), lid).xyz;
    }
    if LAPLACIAN_CORRECTION {
        lap_d = mat3x3<f32>(dense_team_sum(vec4<f32>(lap_d[0], 0.0), lid).xyz,
                            dense_team_sum(vec4<f32>(lap_d[1], 0.0), lid).xyz,
                            dense_team_sum(vec4<f32>(lap_d[2], 0.0), lid).xyz);
    }
    if !fluid_i || lane != 0u {
        return;
    }
    let rho_i = rho[i];
    if LAPLACIAN_CORRECTION {
        acc += 2.0 * NU * (lap_a - lap_d * (transpose(b_matrix(i)) * lap_q));
    }
    if POROSITY_PAIR {
        acc += (press[i] / rho_i) * porosity_gradient(i);
    }
    if MASS_CORRECTION {
        let l15 = 2.0 * (mc_a - dot(mc_q, grad_p(i)));
        drho_i += rho_i * MASS_CORRECTION_GAMMA * params.dt * (l15 - mc_div);
    }
    drho[i] = drho_i;
    dvel[i] = vec4<f32>(acc + params.gravity.xyz, 0.0);
}
