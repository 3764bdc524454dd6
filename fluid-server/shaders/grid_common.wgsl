// ---- grid_common.wgsl: the neighbour grid as pair kernels see it ----
//
// Bind groups are grouped by owner of the data (STYLE.md): group 0 = particles,
// **group 1 = grid** (this file), group 2 = bodies/markers, group 3 = params.
// Every pair kernel composes `shaders::module(gpu, label, &[GRID_COMMON_WGSL, own_wgsl])`
// and builds its pipeline with `shaders::compute_pipeline_with_layouts(..,
// &[Some(particles), Some(grid.bind_group_layout()), ..])`, then binds
// `grid.bind_group()` at group 1.
//
// After `NeighbourGrid::queue_sort` the particle arrays are sorted by cell: the
// particles of cell `ci` are the indices `cell_start[ci] .. cell_start[ci + 1u]`.
// Cells are `support / GRID_REACH` wide (neighbour_grid.rs, GRID_REACH), so the
// neighbours of a particle lie in the cells within GRID_REACH of its own on every
// axis. Cells are numbered x fastest, so the 2·GRID_REACH + 1 cells of one (y, z) row
// are one contiguous index range: the loop visits (2·GRID_REACH + 1)² rows.
//
// The loop every pair kernel uses (support radius h ≤ GRID_REACH · grid.cell_size):
//
//   let p_i = pos[i].xyz;
//   let c_i = cell_coord(p_i);
//   for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
//       for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
//           let js = row_range(c_i, dy, dz);          // empty when the row is outside
//           for (var j = js.x; j < js.y; j++) {
//               let r_ij = p_i - pos[j].xyz;
//               let r2 = dot(r_ij, r_ij);
//               if r2 >= h * h || j == i { continue; }   // j == i: skip self where needed
//               …                                      // w_ij, grad_w_ij, …
//           }
//       }
//   }
//
// The cell-by-cell form, equivalent, for kernels that want a per-cell step: the same
// two loops and a third over dx in -GRID_REACH..=GRID_REACH, skipping cells with
// `!cell_in_grid(c)` and visiting `cell_range(cell_index(c))`.
//
// Needs from the prelude: WORKGROUP_SIZE, GRID_REACH, linear_id.

// Mirror of neighbour_grid::GridParams (48 bytes; checked by tests/grid.rs).
struct GridParams {
    // Lower corner of the grid (xyz); w unused.
    origin: vec4<f32>,
    cell_size: f32,
    inv_cell_size: f32,
    n_particles: u32,
    n_cells: u32,
    // Cells per axis (xyz); w unused. n_cells = dims.x * dims.y * dims.z.
    dims: vec4<u32>,
}

@group(1) @binding(0) var<uniform> grid: GridParams;
// n_cells + 1 entries: exclusive prefix sum of the particle count per cell.
@group(1) @binding(1) var<storage, read> cell_start: array<u32>;

// Integer cell coordinates of a position (may lie outside 0..dims).
fn cell_coord(p: vec3<f32>) -> vec3<i32> {
    return vec3<i32>(floor((p - grid.origin.xyz) * grid.inv_cell_size));
}

fn cell_in_grid(c: vec3<i32>) -> bool {
    return all(c >= vec3<i32>(0)) && all(vec3<u32>(c) < grid.dims.xyz);
}

// Linear cell index, x fastest. `c` must be inside the grid.
fn cell_index(c: vec3<i32>) -> u32 {
    let u = vec3<u32>(c);
    return u.x + grid.dims.x * (u.y + grid.dims.y * u.z);
}

// Sorted particle indices [x, y) of cell `ci`.
fn cell_range(ci: u32) -> vec2<u32> {
    return vec2<u32>(cell_start[ci], cell_start[ci + 1u]);
}

// Sorted particle indices [x, y) of the cells (c.x − GRID_REACH ..= c.x + GRID_REACH,
// c.y + dy, c.z + dz), clipped to the grid; empty when that row lies outside.
fn row_range(c: vec3<i32>, dy: i32, dz: i32) -> vec2<u32> {
    let y = c.y + dy;
    let z = c.z + dz;
    let dims = vec3<i32>(grid.dims.xyz);
    if y < 0 || y >= dims.y || z < 0 || z >= dims.z {
        return vec2<u32>(0u, 0u);
    }
    let x0 = max(c.x - GRID_REACH, 0);
    let x1 = min(c.x + GRID_REACH, dims.x - 1);
    if x0 > x1 {
        return vec2<u32>(0u, 0u);
    }
    let row = grid.dims.x * (u32(y) + grid.dims.y * u32(z));
    return vec2<u32>(cell_start[row + u32(x0)], cell_start[row + u32(x1) + 1u]);
}

// ---- end of grid_common.wgsl ----
