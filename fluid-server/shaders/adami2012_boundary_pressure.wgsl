// ---- adami2012_boundary_pressure.wgsl (CPU twin: adami2012_boundary_pressure.rs) ----
// Adami, Hu & Adams (2012) eq. (27), the uncorrected analogue of Joubert eq. (25):
//   p_w = [Σ_f p_f W_wf + (g − a_w)·Σ_f ρ_f r_wf W_wf] / Σ_f W_wf
// over fluid neighbours f, with g the gravity on the fluid and a_w = 0 (walls are
// fixed; markers' accelerations reach only Joubert's boundary pass). ρ_w from the
// inverted Tait equation, times the porosity among unresolved grains (with the mass:
// boundary_state_wgsl in porosity.rs). No fluid neighbour: p = 0, ρ = ρ0 (ε ρ0).
// A fill point of a resolved body (fill_side(i).w = 1) sums only the fluid in front of
// its nearest surface, (x_f − x_w)·n > 0 (adami2012_boundary_pressure.rs says why).
// No-slip walls also get their velocity for the viscous sums, 2 v_w − ṽ_w with
// ṽ_w = Σ_f v_f W_wf / Σ_f W_wf (Adami et al. 2012, §2.3), through
// `store_wall_velocity(i, v)` (adami2012_boundary_pressure.rs: a no-op when off); the
// layers of a symmetry plane (ADAMI_SYMMETRY) take ṽ_w mirrored across it instead.
// Rows without fluid are skipped (row_has_fluid, fluid_rows.wgsl): the sums are over
// fluid only.
// Needs: prelude, SPH constants, StepParams, grid_common, kernel, tait_eos (library),
// row_fluid (fluid_rows.rs), fill_side (adami2012_boundary_pressure.rs).

// ---- kernels ----
// The axes across which the wall particle at x mirrors the fluid's velocity: those of
// the symmetry planes it stands behind, none if it also stands behind a no-slip face
// (the edge belongs to the wall) or behind no face (an obstacle). CPU twin:
// SphConstants::symmetry_mirror.
fn symmetry_mirror(x: vec3<f32>) -> vec3<bool> {
    let behind = (x < WALL_LO) | (x > WALL_HI);
    let held = any(behind & !ADAMI_SYMMETRY);
    return behind & ADAMI_SYMMETRY & vec3<bool>(!held);
}

// `pos`, boundary_density and store_boundary_mass: porosity.rs, boundary_state_wgsl.
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rho: array<f32>;
@group(0) @binding(3) var<storage, read_write> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;

// A team of TEAM_LANES lanes per particle (grid_common.wgsl; neighbour_grid.rs says
// why): each lane sums its share of the particle's rows, and the team's first lane adds
// the partial sums in lane order (deterministic) and writes.
// Teams of fluid particles sum nothing; wall and marker teams write only their own
// entries and read only fluid entries, so there is no race.
// Per lane: (Σ ρ_f r_wf W, Σ p_f W) and (Σ v_f W, Σ W).
var<workgroup> part_rp: array<vec4<f32>, WORKGROUP_SIZE>;
var<workgroup> part_vw: array<vec4<f32>, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn adami2012_boundary_pressure(@builtin(workgroup_id) wid: vec3<u32>,
                               @builtin(local_invocation_index) lid: u32,
                               @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg) / TEAM_LANES;
    let lane = lid % TEAM_LANES;
    let boundary = i < params.n_total && !is_fluid(id[i]);
    var rp = vec4<f32>(0.0);
    var vw = vec4<f32>(0.0);
    if boundary {
        let p_i = pos[i].xyz;
        let c_i = cell_coord(p_i);
        // With variable h the extrapolation kernel is the largest h's, so that every wall
        // layer a fluid particle can reach has fluid within its support (constants.rs,
        // wall_kernel); otherwise H.
        let reach2 = support2_at(MAX_H);
        let side = fill_side(i);
        for (var r = i32(lane); r < ROWS; r += i32(TEAM_LANES)) {
            // No fluid in the row, nothing to add (fluid_rows.wgsl).
            if !row_has_fluid(c_i, team_row(r).x, team_row(r).y) {
                continue;
            }
            let rs = row_ranges(c_i, team_row(r).x, team_row(r).y);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_wf = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_wf, r_wf);
                if r2 >= reach2 || !is_fluid(id[j]) || (side.w > 0.0 && dot(r_wf, side.xyz) >= 0.0) {
                    continue;
                }
                let w = w_at(sqrt(r2), MAX_H);
                rp += vec4<f32>(rho[j] * w * r_wf, press[j] * w);
                vw += vec4<f32>(vel[j].xyz * w, w);
            }
        }
    }
    part_rp[lid] = rp;
    part_vw[lid] = vw;
    workgroupBarrier();
    if !boundary || lane != 0u {
        return;
    }
    for (var l = 1u; l < TEAM_LANES; l++) {
        rp += part_rp[lid + l];
        vw += part_vw[lid + l];
    }
    let sum_rho_r_w = rp.xyz;
    let sum_pw = rp.w;
    let sum_vw = vw.xyz;
    let sum_w = vw.w;
    let p_i = pos[i].xyz;
    if sum_w > 0.0 {
        // a_w = 0 (see the header).
        let p_w = (sum_pw + dot(params.gravity.xyz, sum_rho_r_w)) / sum_w;
        press[i] = p_w;
        rho[i] = boundary_density(i, p_w);
    } else {
        press[i] = 0.0;
        rho[i] = boundary_density(i, 0.0);
    }
    store_boundary_mass(i);
    if is_wall(id[i]) {
        let v_w = vel[i].xyz;
        let v_f = sum_vw / sum_w;
        let mirror = symmetry_mirror(p_i);
        let v = select(2.0 * v_w - v_f, select(v_f, -v_f, mirror), any(mirror));
        store_wall_velocity(i, select(v_w, v, sum_w > 0.0));
    }
}
