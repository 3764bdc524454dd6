// ---- integrate.wgsl: Joubert eqs. (20)–(23) (CPU twin: integrate.rs) ----
// predict: f* = fⁿ + Δt dfⁿ/dt (eq. 20), p* = EOS(ρ*), fⁿ kept in rho_n/vel_n.
// correct: f** = fⁿ + Δt df*/dt (eq. 21), f^{n+1} = ½(f* + f**) (eq. 22), p^{n+1} = EOS,
//          r^{n+1} = rⁿ + Δt u^{n+1} (eq. 23): positions move once per step, so both
//          derivative evaluations see rⁿ and one neighbour grid serves the step.
// Fluid particles only: walls never move; markers are placed by marker_update.
// Pressure from Robinson eq. (15): ρ is the superficial density ε ρ_f, so the EOS takes
// ρ/ε (`porosity(i)`, 1 without grains).
// Needs: prelude, SPH constants, StepParams, tait_eos (library), porosity (porosity.rs).

// ---- kernels ----
@group(0) @binding(0) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rho: array<f32>;
@group(0) @binding(3) var<storage, read_write> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(0) @binding(5) var<storage, read> drho: array<f32>;
@group(0) @binding(6) var<storage, read> dvel: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> rho_n: array<f32>;
@group(0) @binding(8) var<storage, read_write> vel_n: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn predict(@builtin(workgroup_id) wid: vec3<u32>,
           @builtin(local_invocation_index) lid: u32,
           @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    let dt = params.dt;
    let r0 = rho[i];
    let u0 = vel[i];
    rho_n[i] = r0;
    vel_n[i] = u0;
    // Joubert eq. (20).
    let r_star = r0 + dt * drho[i];
    rho[i] = r_star;
    vel[i] = vec4<f32>(u0.xyz + dt * dvel[i].xyz, 0.0);
    press[i] = tait_pressure(r_star / porosity(i));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn correct(@builtin(workgroup_id) wid: vec3<u32>,
           @builtin(local_invocation_index) lid: u32,
           @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    let dt = params.dt;
    // Joubert eqs. (21)–(22).
    let r_new = 0.5 * (rho[i] + rho_n[i] + dt * drho[i]);
    let u_new = 0.5 * (vel[i].xyz + vel_n[i].xyz + dt * dvel[i].xyz);
    rho[i] = r_new;
    vel[i] = vec4<f32>(u_new, 0.0);
    press[i] = tait_pressure(r_new / porosity(i));
    // Joubert eq. (23).
    pos[i] = vec4<f32>(pos[i].xyz + dt * u_new, pos[i].w);
}
