// ---- unresolved_coupling.wgsl: the fluid's force on unresolved grains (CPU twin:
// unresolved_coupling.rs) ----
// At each grain, Shepard-corrected sums over the fluid particles within the support
// (Robinson eq. 8): the fluid velocity u_f, and the resolved force V ρθ̄ of eqs.
// (23)–(25), θ_b being particle b's SPH acceleration without gravity and without the
// grains' reaction (dvel − g − grain_reaction, eq. 25);
// then the drag of the scene's law (drag.wgsl) on the slip u_f − v at the grain's
// porosity. Needs: prelude, SPH constants, StepParams, grid_common, kernel, drag,
// DRAG_LAW and FLUID_MU (unresolved_coupling.rs), `grain_reaction(j)`
// (grain_reaction_read.wgsl, or zero one-way).
// With POROSITY_PAIR (coupling.porosity_pressure = "energy-pair") sample_grains leaves the
// resolved force 0, so that only the drag is spread back (grain_reaction.wgsl), and
// grain_pressure_force below gives each grain the exact opposite of the fluid's
// (P/ρ) ∇ε terms on its account, accumulated over the window as the fluid takes them.

@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(0) @binding(6) var<storage, read> dvel: array<vec4<f32>>;
// Per grain: xyz position relative to the solver origin, w volume V (m³).
@group(2) @binding(7) var<storage, read> grain_pos: array<vec4<f32>>;
// Per grain: xyz velocity, w diameter d (m).
@group(2) @binding(8) var<storage, read> grain_vel: array<vec4<f32>>;
// Per grain: porosity ε at the grain.
@group(2) @binding(9) var<storage, read> grain_porosity: array<f32>;
// Three vec4 per grain: (u_f, Σ V_b W), (V ρθ̄, 0; 0 under energy-pair), (drag, 0).
@group(2) @binding(10) var<storage, read_write> grain_sample: array<vec4<f32>>;

// Per lane: (Σ V W u, Σ V W) and Σ m θ W.
var<workgroup> part_u: array<vec4<f32>, WORKGROUP_SIZE>;
var<workgroup> part_theta: array<vec3<f32>, WORKGROUP_SIZE>;

// A team of TEAM_LANES threads per grain (grid_common.wgsl), each over its share of the
// rows; the team's first lane adds their sums in lane order and writes.
@compute @workgroup_size(WORKGROUP_SIZE)
fn sample_grains(@builtin(workgroup_id) wid: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32,
                 @builtin(num_workgroups) nwg: vec3<u32>) {
    let g = linear_id(wid, lid, nwg) / TEAM_LANES;
    let lane = lid % TEAM_LANES;
    let grain = g < arrayLength(&grain_porosity);
    var uw = vec4<f32>(0.0);
    var theta = vec3<f32>(0.0);
    if grain {
        let p = grain_pos[g].xyz;
        let c = cell_coord(p);
        for (var row = i32(lane); row < ROWS; row += i32(TEAM_LANES)) {
            let rs = row_ranges(c, team_row(row).x, team_row(row).y);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                if !is_fluid(id[j]) {
                    continue;
                }
                let r = pair_vec(p, pos[j].xyz);
                let r2 = dot(r, r);
                if r2 >= SUPPORT_RADIUS2 {
                    continue;
                }
                let w = kernel_w(sqrt(r2));
                let vw = pos[j].w / rho[j] * w;
                uw += vec4<f32>(vw * vel[j].xyz, vw);
                if !POROSITY_PAIR {
                    // Robinson eq. (24): Σ m_b θ_b W / Σ (m_b/ρ_b) W.
                    theta += pos[j].w * w * (dvel[j].xyz - params.gravity.xyz - grain_reaction(j));
                }
            }
        }
    }
    part_u[lid] = uw;
    part_theta[lid] = theta;
    workgroupBarrier();
    if !grain || lane != 0u {
        return;
    }
    for (var l = 1u; l < TEAM_LANES; l++) {
        uw += part_u[lid + l];
        theta += part_theta[lid + l];
    }
    let u = uw.xyz;
    let shepard = uw.w;
    if shepard == 0.0 {
        // No fluid within the support: no fluid force (the grain is in the air).
        grain_sample[3u * g] = vec4<f32>(0.0);
        grain_sample[3u * g + 1u] = vec4<f32>(0.0);
        grain_sample[3u * g + 2u] = vec4<f32>(0.0);
        return;
    }
    let u_f = u / shepard;
    let resolved = grain_pos[g].w * theta / shepard;
    let drag = drag_force(DRAG_LAW, grain_porosity[g], grain_vel[g].w, RHO0, FLUID_MU,
                          u_f - grain_vel[g].xyz);
    grain_sample[3u * g] = vec4<f32>(u_f, shepard);
    grain_sample[3u * g + 1u] = vec4<f32>(resolved, 0.0);
    grain_sample[3u * g + 2u] = vec4<f32>(drag, 0.0);
}
