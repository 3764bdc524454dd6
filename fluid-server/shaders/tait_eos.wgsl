// ---- tait_eos.wgsl: Joubert eq. (4) (CPU twin: tait_eos.rs) ----

// p = ρ0 c²/γ ((ρ/ρ0)^γ − 1) + P_b: Joubert eq. (4), with the scene's background
// pressure P_b (BACKGROUND_PRESSURE, fluid.background_pressure; 0 by default). With
// e = (ρ − ρ0)/ρ0 (the difference exact in f32) the bracket is (1 + e)^γ − 1, summed
// as Σ C(γ, k) e^k by Horner's rule near ρ0, where pow(ρ/ρ0, γ) − 1 would cancel
// (TAIT_SERIES_LIMIT, constants.rs).
fn tait_pressure(rho: f32) -> f32 {
    let e = (rho - RHO0) / RHO0;
    if abs(e) >= TAIT_SERIES_LIMIT {
        return TAIT_B * (pow(1.0 + e, GAMMA) - 1.0) + BACKGROUND_PRESSURE;
    }
    var c = TAIT_SERIES;
    var s = 0.0;
    for (var k = TAIT_SERIES_TERMS - 1; k >= 0; k = k - 1) {
        s = (s + c[k]) * e;
    }
    return TAIT_B * s + BACKGROUND_PRESSURE;
}

// Joubert eq. (4) inverted: ρ = ρ0 (1 + (p − P_b)/B)^(1/γ); the base is bounded below by
// MIN_TAIT_BASE (constants.rs) so a wall with a nearly empty support stays finite.
fn tait_density(p: f32) -> f32 {
    return RHO0 * pow(max(1.0 + (p - BACKGROUND_PRESSURE) / TAIT_B, MIN_TAIT_BASE), 1.0 / GAMMA);
}

// ---- kernels ----
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read_write> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;

// Pressure of every fluid particle from its density (start of a run and after the
// grains' porosity changes; inside a step the EOS is fused into the integrator's passes).
// Needs `porosity(i)` (porosity.rs).
@compute @workgroup_size(WORKGROUP_SIZE)
fn tait_eos(@builtin(workgroup_id) wid: vec3<u32>,
            @builtin(local_invocation_index) lid: u32,
            @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    // Robinson eq. (15): the superficial density over ε is the intrinsic one.
    press[i] = tait_pressure(rho[i] / porosity(i));
}
