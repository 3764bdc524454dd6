// ---- grain_reaction_read.wgsl: the grains' reaction per fluid particle as an
// acceleration (m/s²), from the 64-bit counts spread_grain_reaction left
// (grain_reaction.wgsl). One rounding: below 2^38 counts |hi| ≤ 2^6, so
// hi · 2^16 + the top half of lo is an exact i32 below 2^24. ----
// Needs: StepParams.

@group(0) @binding(14) var<storage, read> reaction_lo: array<vec4<u32>>;
@group(0) @binding(15) var<storage, read> reaction_hi: array<vec4<i32>>;

fn grain_reaction(i: u32) -> vec3<f32> {
    let lo = reaction_lo[i].xyz;
    let top = reaction_hi[i].xyz * 65536 + vec3<i32>(lo >> vec3<u32>(16u));
    return params.reaction_unit * (vec3<f32>(top) * 65536.0 + vec3<f32>(lo & vec3<u32>(0xffffu)));
}
