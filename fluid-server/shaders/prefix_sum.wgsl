// Exclusive prefix sum (scan) of u32, in place, multi-level.
//
// A workgroup scans one block of SCAN_BLOCK = WORKGROUP_SIZE * SCAN_ITEMS_PER_THREAD
// elements: each thread scans SCAN_ITEMS_PER_THREAD consecutive elements serially,
// the workgroup scans the per-thread totals (Hillis & Steele 1986, log2(WORKGROUP_SIZE)
// steps) and writes the block total to `block_sums`. prefix_sum.rs scans `block_sums`
// the same way, level after level, then `add_block_offsets` adds each block's scanned
// offset back, top level first. Sums wrap modulo 2^32 like the CPU twin.
//
// Needs from the prelude / prefix_sum.rs: WORKGROUP_SIZE, SCAN_ITEMS_PER_THREAD,
// linear_workgroup().

const SCAN_BLOCK: u32 = WORKGROUP_SIZE * SCAN_ITEMS_PER_THREAD;

struct ScanParams {
    // Elements in `data` at this level.
    n: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> scan: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;
// scan_blocks writes one total per block; add_block_offsets reads the scanned totals.
@group(0) @binding(2) var<storage, read_write> block_sums: array<u32>;

var<workgroup> tile: array<u32, SCAN_BLOCK>;
var<workgroup> thread_sums: array<u32, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn scan_blocks(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let block = linear_workgroup(wid, nwg);
    let base = block * SCAN_BLOCK;
    // Coalesced load: consecutive threads read consecutive elements.
    for (var k = 0u; k < SCAN_ITEMS_PER_THREAD; k++) {
        let t = k * WORKGROUP_SIZE + lid;
        let idx = base + t;
        var x = 0u;
        if idx < scan.n {
            x = data[idx];
        }
        tile[t] = x;
    }
    workgroupBarrier();

    // Serial exclusive scan of this thread's consecutive run.
    let run = lid * SCAN_ITEMS_PER_THREAD;
    var total = 0u;
    for (var k = 0u; k < SCAN_ITEMS_PER_THREAD; k++) {
        let x = tile[run + k];
        tile[run + k] = total;
        total += x;
    }
    thread_sums[lid] = total;
    workgroupBarrier();

    // Inclusive Hillis–Steele scan of the thread totals.
    for (var offset = 1u; offset < WORKGROUP_SIZE; offset = offset << 1u) {
        var left = 0u;
        if lid >= offset {
            left = thread_sums[lid - offset];
        }
        workgroupBarrier();
        thread_sums[lid] += left;
        workgroupBarrier();
    }
    let before = thread_sums[lid] - total;
    for (var k = 0u; k < SCAN_ITEMS_PER_THREAD; k++) {
        tile[run + k] += before;
    }
    workgroupBarrier();

    for (var k = 0u; k < SCAN_ITEMS_PER_THREAD; k++) {
        let t = k * WORKGROUP_SIZE + lid;
        let idx = base + t;
        if idx < scan.n {
            data[idx] = tile[t];
        }
    }
    let n_blocks = (scan.n + SCAN_BLOCK - 1u) / SCAN_BLOCK;
    if lid == WORKGROUP_SIZE - 1u && block < n_blocks {
        block_sums[block] = thread_sums[lid];
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn add_block_offsets(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let block = linear_workgroup(wid, nwg);
    let n_blocks = (scan.n + SCAN_BLOCK - 1u) / SCAN_BLOCK;
    // Block 0's offset is 0; blocks past the end exist only in a 2-D dispatch's last row.
    if block == 0u || block >= n_blocks {
        return;
    }
    let offset = block_sums[block];
    let base = block * SCAN_BLOCK;
    for (var k = 0u; k < SCAN_ITEMS_PER_THREAD; k++) {
        let idx = base + k * WORKGROUP_SIZE + lid;
        if idx < scan.n {
            data[idx] += offset;
        }
    }
}
