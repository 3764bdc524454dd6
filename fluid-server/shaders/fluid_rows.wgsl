// ---- fluid_rows.wgsl (CPU twin: fluid_rows.rs) ----
// The fluid in each cell's row window: row_fluid[c] is the number of fluid particles
// sorted into the cells c.x − GRID_REACH ..= c.x + GRID_REACH of cell c's (y, z) row,
// the slots `row_ranges(c, 0, 0)` covers (clipped at a closed x face, wrapped on a
// periodic one). Written once per sort; ids move only with the sort, so the count stays
// exact for every pass until the next one, however far the particles have moved.
//
// The boundary passes sum over fluid neighbours only. A wall or marker particle in cell
// c_i skips row (dy, dz) of its neighbourhood when `row_has_fluid(c_i, dy, dz)` is false:
// that row holds no fluid slot, so walking it would add nothing, and the sums come out
// bit for bit the same. Most wall particles of a tank stand far from the fluid (25 067
// walls to 10 850 fluid in the SPHERIC-2 tank at δ = 0.04 m), and each walked its whole
// neighbourhood of walls (fluid_rows.rs gives the measured cost).
// Needs: prelude, SPH constants, StepParams, grid_common; a boundary pass declares
// `row_fluid` read-only (fluid_rows.rs, row_fluid_read_wgsl).

// Whether row (dy, dz) around cell c (inside the grid) holds any fluid slot.
fn row_has_fluid(c: vec3<i32>, dy: i32, dz: i32) -> bool {
    let row = row_base(c, dy, dz);
    return row != NO_ROW && row_fluid[row + u32(c.x)] > 0u;
}

// ---- kernels ----
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(0) @binding(19) var<storage, read_write> row_fluid: array<u32>;

// One thread per cell.
@compute @workgroup_size(WORKGROUP_SIZE)
fn fluid_rows(@builtin(workgroup_id) wid: vec3<u32>,
              @builtin(local_invocation_index) lid: u32,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let ci = linear_id(wid, lid, nwg);
    if ci >= grid.n_cells {
        return;
    }
    let dims = grid.dims.xyz;
    let c = vec3<i32>(vec3<u32>(ci % dims.x, (ci / dims.x) % dims.y, ci / (dims.x * dims.y)));
    let rs = row_ranges(c, 0, 0);
    var n = 0u;
    for (var k = 0u; k < row_length(rs); k++) {
        n += u32(is_fluid(id[row_slot(rs, k)]));
    }
    row_fluid[ci] = n;
}
