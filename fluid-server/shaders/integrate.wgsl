// ---- integrate.wgsl: Joubert eqs. (20)–(23) (CPU twin: integrate.rs) ----
// predict: f* = fⁿ + Δt dfⁿ/dt (eq. 20), p* = EOS(ρ*), fⁿ kept in rho_n/vel_n.
// correct: f** = fⁿ + Δt df*/dt (eq. 21), f^{n+1} = ½(f* + f**) (eq. 22), p^{n+1} = EOS,
//          r^{n+1} = rⁿ + Δt u^{n+1} (eq. 23): positions move once per step, so both
//          derivative evaluations see rⁿ and one neighbour grid serves the step.
// Positions and densities are summed with compensation (Kahan; Knuth's two-sum): an
// increment Δt u or Δt dρ/dt below half a unit in the last place of x or ρ is lost to
// f32 rounding outright, every step. In a slow viscous column (the water–glycerol CPB:
// u ~ 1e-4 m/s, Δt ~ 2.5 μs, x ~ 5 mm, ulp 4.7e-10 m; ρ ~ 1150, ulp 1.2e-4) the fluid
// near the floor did not move at all while its velocity said 5e-5 m/s, and its density
// stood still for milliseconds (results/2026-12-01-lavapipe-cpb/comparison.md). So
// low_words keeps, per particle, what rounding took off x (xyz) and ρ (w), and the next
// step adds it back: f32 pairs hold about 48 bits. Velocities are not compensated: their
// increments are large against their own ulp. predict leaves vel_n.w = Δt dρⁿ/dt for
// correct, which rebuilds ρ^{n+1} = ρⁿ + ½(Δt dρⁿ/dt + Δt dρ*/dt) from ρⁿ and both
// increments (the f32 ρ* has lost them). Shifting and the bodies' non-penetration move
// positions by more than an ulp and leave the low words as they are.
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
@group(0) @binding(20) var<storage, read_write> low_words: array<vec4<f32>>;

// a + b as the f32 sum s and its rounding error e, s + e = a + b exactly (Knuth's
// two-sum: no assumption on |a| against |b|). WGSL cannot mark arithmetic exact, and a
// compiler free to use real-number algebra folds (a + b) − a to b and the error to 0
// (Mesa's did: the regression test positions_and_densities_keep_increments_below_half_an_ulp
// failed with the plain form); each intermediate is therefore multiplied by
// opaque_one(), 1 at run time, which no such rule can see through.
fn two_sum(a: f32, b: f32) -> vec2<f32> {
    let one = opaque_one();
    let s = (a + b) * one;
    let bb = (s - a) * one;
    let a_part = (s - bb) * one;
    return vec2<f32>(s, (a - a_part) + (b - bb));
}

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
    // Joubert eq. (20); vel_n.w keeps Δt dρⁿ/dt for correct.
    let d_rho = dt * drho[i];
    rho_n[i] = r0;
    vel_n[i] = vec4<f32>(u0.xyz, d_rho);
    let r_star = r0 + d_rho;
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
    let low = low_words[i];
    // Joubert eqs. (21)–(22), ρ^{n+1} = ρⁿ + ½(Δt dρⁿ/dt + Δt dρ*/dt), compensated.
    let r = two_sum(rho_n[i], low.w + 0.5 * (vel_n[i].w + dt * drho[i]));
    let u_new = 0.5 * (vel[i].xyz + vel_n[i].xyz + dt * dvel[i].xyz);
    rho[i] = r.x;
    vel[i] = vec4<f32>(u_new, 0.0);
    press[i] = tait_pressure(r.x / porosity(i));
    // Joubert eq. (23), compensated.
    let p = pos[i];
    let dx = low.xyz + dt * u_new;
    let x = two_sum(p.x, dx.x);
    let y = two_sum(p.y, dx.y);
    let z = two_sum(p.z, dx.z);
    pos[i] = vec4<f32>(x.x, y.x, z.x, p.w);
    low_words[i] = vec4<f32>(x.y, y.y, z.y, r.y);
}
