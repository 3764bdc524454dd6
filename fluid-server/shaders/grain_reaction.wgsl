// ---- grain_reaction.wgsl: the grains' reaction on the fluid, Robinson eqs. (26)–(27)
// (CPU twin: unresolved_coupling.rs, grain_reaction_cpu) ----
// spread_grain_reaction: a team of threads per grain j (below), at a window's start, after
// sample_grains. To each fluid particle a within the support it adds the acceleration
//     −f_j W_aj / (S_j ρ_a),
// Robinson eq. (26) divided by m_a, with f_j the grain's whole fluid force (eq. 23) and
// S_j = Σ_b (m/ρ_b) W_jb the Shepard sum sample_grains left (eq. 27; the coupling length
// h_c is the fluid's h). Summed over a, m times it is −f_j: the fluid receives exactly
// what the grains lose. The sums are 64-bit fixed point, counts of params.reaction_unit
// (unresolved_coupling.rs chooses the unit from the window's forces: its bound is 2^33
// counts, with room below the 2^38 that stay exact for the superficial density), each
// component a low word (u32) and a high word (i32) with the carry propagated by hand:
// integer adds commute, so the sums are exact and do not depend on the order in which
// threads meet a particle, and runs repeat bit for bit.
// grain_reaction_read.wgsl reads the sums back; add_grain_reaction
// (grain_reaction_add.wgsl) adds them to du/dt.
// Needs: prelude, SPH constants, StepParams, grid_common, kernel.

@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// Low and high words of the counts, four per particle (x, y, z, unused), permuted with
// the particles by the sort.
@group(0) @binding(14) var<storage, read_write> reaction_lo: array<atomic<u32>>;
@group(0) @binding(15) var<storage, read_write> reaction_hi: array<atomic<i32>>;
// Per grain: xyz position relative to the solver origin, w volume V (m³).
@group(2) @binding(7) var<storage, read> grain_pos: array<vec4<f32>>;
// Three vec4 per grain: (u_f, S_j), (V ρθ̄, 0), (drag, 0) (unresolved_coupling.wgsl).
@group(2) @binding(10) var<storage, read> grain_sample: array<vec4<f32>>;

// Adds `counts` (a whole number, |counts| < 2^38) to slot `k` as a 64-bit integer.
// Split at 2^16: `low` is exact (a difference of two floats whose exact value, an
// integer below 2^16, is representable), and so is `high` (|high| < 2^22).
// An add of 0 is skipped, which changes no sum: the high word's is 0 for most pairs
// (a count in [0, 2^32) without a carry, or a negative one whose low word carries).
// On lavapipe, where atomics are most of this pass, the RTI's spread went from 77 to
// 59 ms (2026-12-01, `couplet bench scenes/rayleigh-taylor.toml`, beside another run).
fn add_counts(k: u32, counts: f32) {
    if counts == 0.0 {
        return;
    }
    let high = floor(counts / 65536.0);
    let low = u32(counts - high * 65536.0);
    let h = i32(high);
    let lo = (bitcast<u32>(h) << 16u) | low;
    let old = atomicAdd(&reaction_lo[k], lo);
    let carry = select(0, 1, old + lo < old);
    let hi = (h >> 16u) + carry;
    if hi != 0 {
        atomicAdd(&reaction_hi[k], hi);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn spread_grain_reaction(@builtin(workgroup_id) wid: vec3<u32>,
                         @builtin(local_invocation_index) lid: u32,
                         @builtin(num_workgroups) nwg: vec3<u32>) {
    // A team of TEAM_LANES threads per grain (grid_common.wgsl), each over its share of
    // the rows: the adds are integer, so the sums are the same whatever the order.
    let t = linear_id(wid, lid, nwg);
    let g = t / TEAM_LANES;
    if g >= arrayLength(&grain_sample) / 3u {
        return;
    }
    let s = grain_sample[3u * g].w;
    if s == 0.0 {
        // No fluid within reach: the grain felt no force, the fluid gets none.
        return;
    }
    // Robinson eq. (23): the resolved part plus the drag.
    let f = grain_sample[3u * g + 1u].xyz + grain_sample[3u * g + 2u].xyz;
    let p = grain_pos[g].xyz;
    let c = cell_coord(p);
    for (var row = i32(t % TEAM_LANES); row < ROWS; row += i32(TEAM_LANES)) {
        let rs = row_ranges(c, team_row(row).x, team_row(row).y);
        for (var k = 0u; k < row_length(rs); k++) {
            let a = row_slot(rs, k);
            if !is_fluid(id[a]) {
                continue;
            }
            let r = pair_vec(p, pos[a].xyz);
            let r2 = dot(r, r);
            if r2 >= SUPPORT_RADIUS2 {
                continue;
            }
            // Robinson eqs. (26)–(27), per unit mass, in counts.
            let counts = round((-kernel_w(sqrt(r2)) / (s * rho[a] * params.reaction_unit)) * f);
            add_counts(4u * a, counts.x);
            add_counts(4u * a + 1u, counts.y);
            add_counts(4u * a + 2u, counts.z);
        }
    }
}
