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
// The loop every pair kernel uses (support radius h ≤ GRID_REACH · every cell edge):
//
//   let p_i = pos[i].xyz;
//   let c_i = cell_coord(p_i);
//   for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
//       for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
//           let rs = row_ranges(c_i, dy, dz);         // empty when the row is outside
//           for (var k = 0u; k < row_length(rs); k++) {
//               let j = row_slot(rs, k);
//               let r_ij = pair_vec(p_i, pos[j].xyz);  // nearest image on periodic axes
//               let r2 = dot(r_ij, r_ij);
//               if r2 >= h * h || j == i { continue; }   // j == i: skip self where needed
//               …                                      // w_ij, grad_w_ij, …
//           }
//       }
//   }
//
// A row is one contiguous range of sorted slots, or two when it wraps around a periodic
// x axis; `row_slot` walks both. On a periodic axis the grid spans one period in at
// least 2·GRID_REACH + 1 cells, so no cell (and no pair) is visited twice.
//
// The cell-by-cell form, equivalent, for kernels that want a per-cell step: the same
// two loops and a third over dx in -GRID_REACH..=GRID_REACH, skipping cells with
// `!cell_in_grid(c)` and visiting `cell_range(cell_index(c))` (no periodic wrap: only
// for closed grids).
//
// A team of TEAM_LANES threads can share one item's rows (neighbour_grid.rs, TEAM_LANES):
// thread t of the dispatch serves item t / TEAM_LANES as lane t % TEAM_LANES and visits
// the rows lane, lane + TEAM_LANES, … below ROWS, `team_row(r)` giving row r's (dy, dz):
//
//   for (var r = i32(lane); r < ROWS; r += i32(TEAM_LANES)) {
//       let rs = row_ranges(c_i, team_row(r).x, team_row(r).y);
//       …
//   }
//
// Needs from the prelude: WORKGROUP_SIZE, GRID_REACH, TEAM_LANES, linear_id.

// Mirror of neighbour_grid::GridParams (112 bytes; checked by tests/grid.rs). Every
// vec4's w is unused.
struct GridParams {
    // Lower corner of the grid.
    origin: vec4<f32>,
    // Cell edge per axis, and its inverse.
    cell_size: vec4<f32>,
    inv_cell_size: vec4<f32>,
    // Cells per axis. n_cells = dims.x * dims.y * dims.z.
    dims: vec4<u32>,
    // Period per axis (0: not periodic), and its inverse (0: not periodic).
    period: vec4<f32>,
    inv_period: vec4<f32>,
    n_particles: u32,
    n_cells: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> grid: GridParams;
// n_cells + 1 entries: exclusive prefix sum of the particle count per cell.
@group(1) @binding(1) var<storage, read> cell_start: array<u32>;

fn periodic_axes() -> vec3<bool> {
    return grid.period.xyz > vec3<f32>(0.0);
}

// `c` modulo the cell count on periodic axes; unchanged on closed ones.
fn wrap_cell(c: vec3<i32>) -> vec3<i32> {
    let d = vec3<i32>(grid.dims.xyz);
    return select(c, ((c % d) + d) % d, periodic_axes());
}

// Integer cell coordinates of a position, wrapped on periodic axes (may lie outside
// 0..dims on a closed axis).
fn cell_coord(p: vec3<f32>) -> vec3<i32> {
    return wrap_cell(vec3<i32>(floor((p - grid.origin.xyz) * grid.inv_cell_size.xyz)));
}

// r_i − r_j, as the nearest image on periodic axes.
fn pair_vec(p_i: vec3<f32>, p_j: vec3<f32>) -> vec3<f32> {
    let r = p_i - p_j;
    return r - grid.period.xyz * round(r * grid.inv_period.xyz);
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

// Sorted particle indices of the cells (c.x − GRID_REACH ..= c.x + GRID_REACH,
// c.y + dy, c.z + dz) as two ranges [x, y) and [z, w): the second is empty unless
// the row wraps around a periodic x axis. Rows beyond a closed face are empty; a
// closed x axis clips the row to the grid.
fn row_ranges(c: vec3<i32>, dy: i32, dz: i32) -> vec4<u32> {
    return row_ranges_within(c, dy, dz, GRID_REACH);
}

// `row_base` of a row beyond a closed face (no cell has this index: the grid's cell
// count is checked against the largest binding, so it stays far below).
const NO_ROW: u32 = 0xffffffffu;

// The index of cell (0, c.y + dy, c.z + dz), wrapped on periodic y and z, or NO_ROW when
// that row lies beyond a closed face.
fn row_base(c: vec3<i32>, dy: i32, dz: i32) -> u32 {
    let dims = vec3<i32>(grid.dims.xyz);
    let periodic = periodic_axes();
    var y = c.y + dy;
    var z = c.z + dz;
    if periodic.y {
        y = (y + dims.y) % dims.y;
    }
    if periodic.z {
        z = (z + dims.z) % dims.z;
    }
    if y < 0 || y >= dims.y || z < 0 || z >= dims.z {
        return NO_ROW;
    }
    return grid.dims.x * (u32(y) + grid.dims.y * u32(z));
}

// `row_ranges` over the cells c.x − reach ..= c.x + reach, reach ≤ GRID_REACH.
fn row_ranges_within(c: vec3<i32>, dy: i32, dz: i32, reach: i32) -> vec4<u32> {
    let dims = vec3<i32>(grid.dims.xyz);
    let periodic = periodic_axes();
    let row = row_base(c, dy, dz);
    if row == NO_ROW {
        return vec4<u32>(0u);
    }
    var x0 = c.x - reach;
    var x1 = c.x + reach;
    if periodic.x {
        // dims.x ≥ 2·GRID_REACH + 1, so at most one end wraps.
        if x0 < 0 {
            return vec4<u32>(cell_start[row + u32(x0 + dims.x)], cell_start[row + grid.dims.x],
                             cell_start[row], cell_start[row + u32(x1) + 1u]);
        }
        if x1 >= dims.x {
            return vec4<u32>(cell_start[row + u32(x0)], cell_start[row + grid.dims.x],
                             cell_start[row], cell_start[row + u32(x1 - dims.x) + 1u]);
        }
    }
    x0 = max(x0, 0);
    x1 = min(x1, dims.x - 1);
    if x0 > x1 {
        return vec4<u32>(0u);
    }
    let first = cell_start[row + u32(x0)];
    let last = cell_start[row + u32(x1) + 1u];
    return vec4<u32>(first, last, last, last);
}

// Cells on each side of a particle's own that hold every point within `d` of it
// (d ≤ support): ceil(d / cell edge) per axis, as |⌊a⌋ − ⌊b⌋| ≤ ⌈|a − b|⌉. Searches
// shorter than the support (the nearest marker within δ) loop over these, not GRID_REACH.
fn cells_within(d: f32) -> vec3<i32> {
    return min(vec3<i32>(ceil(d * grid.inv_cell_size.xyz)), vec3<i32>(GRID_REACH));
}

// Slots in the row of `row_ranges`.
fn row_length(rs: vec4<u32>) -> u32 {
    return (rs.y - rs.x) + (rs.w - rs.z);
}

// The k-th slot of the row, k < row_length(rs).
fn row_slot(rs: vec4<u32>, k: u32) -> u32 {
    let first = rs.y - rs.x;
    return select(rs.z + (k - first), rs.x + k, k < first);
}

// Rows of a particle's neighbourhood, (2·GRID_REACH + 1)², numbered dy fastest.
const ROWS: i32 = (2 * GRID_REACH + 1) * (2 * GRID_REACH + 1);
// (dy, dz) of row r.
fn team_row(r: i32) -> vec2<i32> {
    return vec2<i32>(r % (2 * GRID_REACH + 1) - GRID_REACH, r / (2 * GRID_REACH + 1) - GRID_REACH);
}

// ---- end of grid_common.wgsl ----
