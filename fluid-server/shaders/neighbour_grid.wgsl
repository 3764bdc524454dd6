// Counting sort of particles by grid cell, part 1 and 3 (part 2 is prefix_sum.wgsl,
// part 4 reorder.wgsl):
//   count_cells: one thread per particle wraps its position into the period on
//                periodic axes, finds its cell, takes a rank inside it with one
//                atomicAdd on the cell's counter (the only atomics of the sort);
//   (prefix sum of the counters → cell_start)
//   scatter:     unordered[cell_start[cell] + rank] = i (no atomics);
//   order_slots: one thread per slot counts the particles of its cell with a smaller
//                index and writes src_of[cell_start + count] = its particle, so the
//                order inside a cell is the order before the sort, not the atomics'.
//
// Composed after the prelude and grid_common.wgsl (group 1 = grid). count_cells binds
// only grid params at group 1: its counters are the cell_start buffer itself, bound
// read-write at group 0 before the scan turns them into cell_start.

// Mirror of neighbour_grid::GridErrorRecord (32 bytes). The first particle found
// outside the grid since the last reset is recorded; later ones only count.
struct GridErrorRecord {
    outside_count: atomic<u32>,
    index: u32,
    id: u32,
    _pad: u32,
    position: vec4<f32>,
}

// Read-write: positions are wrapped into the period on periodic axes here.
@group(0) @binding(0) var<storage, read_write> count_pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> count_cell_of: array<u32>;
@group(0) @binding(3) var<storage, read_write> count_rank: array<u32>;
@group(0) @binding(4) var<storage, read_write> grid_error: GridErrorRecord;
// The registered id buffer, or a one-element stand-in when none is registered.
@group(0) @binding(5) var<storage, read> count_ids: array<u32>;

// Exponent bits all set: ±inf or NaN. Bit test, because comparisons with NaN may be
// folded away by the driver's compiler.
const F32_EXPONENT_MASK: u32 = 0x7f800000u;

fn is_finite3(p: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(p) & vec3<u32>(F32_EXPONENT_MASK);
    return all(e != vec3<u32>(F32_EXPONENT_MASK));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn count_cells(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = linear_id(wid, lid, nwg);
    if i >= grid.n_particles {
        return;
    }
    var p = count_pos[i];
    let finite = is_finite3(p.xyz);
    if finite && any(periodic_axes()) {
        // Back into the period [origin, origin + period) on periodic axes (the
        // integrator moves particles across the faces); inv_period = 0 elsewhere.
        let wrapped = p.xyz - grid.period.xyz * floor((p.xyz - grid.origin.xyz) * grid.inv_period.xyz);
        p = vec4<f32>(wrapped, p.w);
        count_pos[i] = p;
    }
    // Same arithmetic as cell_coord(), so the sort and the pair loops agree (a position
    // rounding onto the upper periodic face lands in cell dims, which wraps to 0).
    let q_raw = floor((p.xyz - grid.origin.xyz) * grid.inv_cell_size.xyz);
    let q = select(q_raw, vec3<f32>(wrap_cell(vec3<i32>(q_raw))), periodic_axes());
    let dims_f = vec3<f32>(grid.dims.xyz);
    let inside = finite && all(q >= vec3<f32>(0.0)) && all(q < dims_f);
    var ci = 0u;
    if inside {
        ci = cell_index(vec3<i32>(q));
    } else {
        // Still sorted (into the nearest cell; cell 0 when non-finite) so that the
        // permutation stays complete; NeighbourGrid::check reports it.
        let first = atomicAdd(&grid_error.outside_count, 1u);
        if first == 0u {
            grid_error.index = i;
            grid_error.id = count_ids[min(i, arrayLength(&count_ids) - 1u)];
            grid_error.position = p;
        }
        if finite {
            let c = clamp(q, vec3<f32>(0.0), dims_f - vec3<f32>(1.0));
            ci = cell_index(vec3<i32>(c));
        }
    }
    count_cell_of[i] = ci;
    count_rank[i] = atomicAdd(&counts[ci], 1u);
}

@group(0) @binding(10) var<storage, read> scatter_cell_of: array<u32>;
@group(0) @binding(11) var<storage, read> scatter_rank: array<u32>;
// Sorted slot → index before the sort, in the atomics' order inside a cell.
@group(0) @binding(12) var<storage, read_write> unordered: array<u32>;
// Gather map: sorted slot → index before the sort, stable inside a cell.
@group(0) @binding(13) var<storage, read_write> src_of: array<u32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn scatter(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = linear_id(wid, lid, nwg);
    if i >= grid.n_particles {
        return;
    }
    let dst = cell_start[scatter_cell_of[i]] + scatter_rank[i];
    unordered[dst] = i;
}

// ORDER_MAX_SLICE is composed in from neighbour_grid::GRID_ORDER_MAX_SLICE (see there).

// Makes the sort deterministic: a particle's slot is its cell's start plus the number
// of particles of the cell with a smaller index before the sort (a stable counting
// sort), so a run repeats bit for bit. Each thread loops at most ORDER_MAX_SLICE
// times: lavapipe ends any shader's loops after 65535 iterations in all (Mesa's
// LP_MAX_TGSI_LOOP_ITERATIONS), which cut short the insertion sort this replaces
// (regression test grid_sort_is_stable_in_cells_far_from_sorted).
@compute @workgroup_size(WORKGROUP_SIZE)
fn order_slots(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let s = linear_id(wid, lid, nwg);
    if s >= grid.n_particles {
        return;
    }
    let v = unordered[s];
    let c = scatter_cell_of[v];
    let lo = cell_start[c];
    let hi = cell_start[c + 1u];
    if hi - lo > ORDER_MAX_SLICE {
        src_of[s] = v;
        return;
    }
    var smaller = 0u;
    for (var k = lo; k < hi; k++) {
        smaller += select(0u, 1u, unordered[k] < v);
    }
    src_of[lo + smaller] = v;
}
