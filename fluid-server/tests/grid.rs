//! Neighbour grid: the counting sort and the WGSL pair-loop helpers against brute force.
//!
//! Every test holds `shared_test_gpu()` for its whole body (one GPU, serialised).

use couplet_fluid::gpu::{Gpu, shared_test_gpu};
use couplet_fluid::neighbour_grid::{
    GATHER_BUFFERS_PER_PASS, GRID_COMMON_WGSL, GRID_REACH_CPU, GRID_REACH_RANGE, GridBox,
    GridError, GridParams, NeighbourGrid, grid_reach_wgsl,
};
use couplet_fluid::shaders;
use couplet_fluid::timing::{StageTimer, TimingMode};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wgpu::util::DeviceExt;

fn buffer_init<T: bytemuck::Pod>(gpu: &Gpu, label: &str, data: &[T]) -> wgpu::Buffer {
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        })
}

/// The particle arrays of a test: pos (w = id as f32), vel, rho (f32), id (u32).
struct Particles {
    pos: Vec<[f32; 4]>,
    vel: Vec<[f32; 4]>,
    rho: Vec<f32>,
    id: Vec<u32>,
}

impl Particles {
    fn from_positions(xyz: &[[f32; 3]]) -> Particles {
        let n = xyz.len();
        Particles {
            pos: xyz
                .iter()
                .enumerate()
                .map(|(i, p)| [p[0], p[1], p[2], i as f32])
                .collect(),
            vel: (0..n)
                .map(|i| [i as f32 * 0.5, -(i as f32), 3.0, i as f32 + 0.25])
                .collect(),
            rho: (0..n).map(|i| 1000.0 + i as f32 * 1e-3).collect(),
            id: (0..n as u32).collect(),
        }
    }
}

struct OnGpu {
    pos: wgpu::Buffer,
    vel: wgpu::Buffer,
    rho: wgpu::Buffer,
    id: wgpu::Buffer,
}

fn upload_and_register(gpu: &Gpu, grid: &mut NeighbourGrid, p: &Particles) -> OnGpu {
    let b = OnGpu {
        pos: buffer_init(gpu, "pos", &p.pos),
        vel: buffer_init(gpu, "vel", &p.vel),
        rho: buffer_init(gpu, "rho", &p.rho),
        id: buffer_init(gpu, "id", &p.id),
    };
    grid.register(&b.pos, 16).unwrap();
    grid.register(&b.vel, 16).unwrap();
    grid.register(&b.rho, 4).unwrap();
    grid.register_ids(&b.id).unwrap();
    b
}

/// `scene(n, seed, GRID_REACH_CPU)` on the GPU, its pos, vel, rho and ids
/// registered with a grid of support 0.125 over the closed box [0, 1] × [0, 0.75] ×
/// [0, 0.5].
fn scene_in_box(gpu: &Gpu, n: usize, seed: u64) -> (Particles, NeighbourGrid, OnGpu) {
    let parts = Particles::from_positions(&scene(n, seed, GRID_REACH_CPU));
    let mut grid = NeighbourGrid::new(
        gpu,
        GridBox::closed([0.0; 3], [1.0, 0.75, 0.5]),
        0.125,
        GRID_REACH_CPU,
        n as u32,
    )
    .unwrap();
    let b = upload_and_register(gpu, &mut grid, &parts);
    (parts, grid, b)
}

fn sort(gpu: &Gpu, grid: &NeighbourGrid, b: &OnGpu) {
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    grid.queue_sort(gpu, &mut encoder, &b.pos, None);
    gpu.queue.submit([encoder.finish()]);
}

/// Seeded particles in the box [0, 1] × [0, 0.75] × [0, 0.5] (support 0.125, cells of
/// 0.125 / `reach`, padding of one support): uniform ones, a dense cluster, points
/// exactly on cell faces/edges/corners (dyadic for reach 1, 2, 4; for 3 only the
/// multiples of 0.125 are exact in f32 — still cell faces), exact duplicates, points in
/// the padding, all shuffled.
fn scene(n: usize, seed: u64, reach: u32) -> Vec<[f32; 3]> {
    let cell = 0.125 / reach as f32;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut v = Vec::with_capacity(n);
    let max = [1.0f32, 0.75, 0.5];
    while v.len() < n {
        let kind = v.len() % 10;
        let p = match kind {
            // Uniform over the box.
            0..=4 => std::array::from_fn(|a| rng.random_range(0.0..=max[a])),
            // Dense cluster straddling cell faces at 0.25 and 0.375.
            5 | 6 => {
                std::array::from_fn(|a| [0.25, 0.375, 0.25][a] + rng.random_range(-0.04..0.04))
            }
            // On cell faces: one, two or three coordinates on a multiple of H.
            7 | 8 => {
                let mut p: [f32; 3] = std::array::from_fn(|a| rng.random_range(0.0..=max[a]));
                for a in 0..3 {
                    if rng.random_bool(0.6) {
                        let cells = (max[a] / cell) as u32;
                        p[a] = rng.random_range(0..=cells) as f32 * cell;
                    }
                }
                p
            }
            // In the padding (inside the grid, outside the box), or a duplicate.
            _ => {
                if rng.random_bool(0.5) && !v.is_empty() {
                    v[rng.random_range(0..v.len())]
                } else {
                    let a = rng.random_range(0..3);
                    let mut p: [f32; 3] = std::array::from_fn(|a| rng.random_range(0.0..=max[a]));
                    p[a] = if rng.random_bool(0.5) {
                        -0.1
                    } else {
                        max[a] + 0.1
                    };
                    p
                }
            }
        };
        v.push(p);
    }
    v.shuffle(&mut rng);
    v
}

const NEIGHBOUR_TEST_WGSL: &str = r#"
struct TestParams { radius: f32, n: u32, near: f32, _p1: u32 }
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
// Per particle, two entries: (count, Σ id, Σ id², count by the cell-by-cell loop)
// within `radius`, then (count, Σ id, Σ id², 0) within `near` < radius by the short
// search (`cells_within` and `row_ranges_within`, as `nearest_surface_marker` does).
@group(0) @binding(2) var<storage, read_write> out: array<vec4<u32>>;
@group(3) @binding(0) var<uniform> test: TestParams;

@compute @workgroup_size(WORKGROUP_SIZE)
fn count_neighbours(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = linear_id(wid, lid, nwg);
    if i >= grid.n_particles { return; }
    let r2_max = test.radius * test.radius;
    let p_i = pos[i].xyz;
    let c_i = cell_coord(p_i);
    var count = 0u;
    var id_sum = 0u;
    var id_sq = 0u;
    for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
        for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
            let rs = row_ranges(c_i, dy, dz);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r_ij, r_ij);
                if r2 >= r2_max || j == i { continue; }
                count += 1u;
                id_sum += ids[j];
                id_sq += ids[j] * ids[j];
            }
        }
    }
    var count_cells = 0u;
    for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
        for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
            for (var dx = -GRID_REACH; dx <= GRID_REACH; dx++) {
                let c = wrap_cell(c_i + vec3<i32>(dx, dy, dz));
                if !cell_in_grid(c) { continue; }
                let js = cell_range(cell_index(c));
                for (var j = js.x; j < js.y; j++) {
                    let r_ij = pair_vec(p_i, pos[j].xyz);
                    if dot(r_ij, r_ij) >= r2_max || j == i { continue; }
                    count_cells += 1u;
                }
            }
        }
    }
    out[2u * i] = vec4<u32>(count, id_sum, id_sq, count_cells);
    let near2 = test.near * test.near;
    let reach = cells_within(test.near);
    var near = vec4<u32>(0u);
    for (var dz = -reach.z; dz <= reach.z; dz++) {
        for (var dy = -reach.y; dy <= reach.y; dy++) {
            let rs = row_ranges_within(c_i, dy, dz, reach.x);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                if dot(r_ij, r_ij) >= near2 || j == i { continue; }
                near += vec4<u32>(1u, ids[j], ids[j] * ids[j], 0u);
            }
        }
    }
    out[2u * i + 1u] = near;
}
"#;

/// r_i − r_j as `pair_vec` computes it in f32 (nearest image where `period[a]` > 0;
/// WGSL `round` is ties-to-even), without fused multiply-add.
fn pair_vec(a: [f32; 4], b: [f32; 4], period: [f32; 4], inv_period: [f32; 4]) -> [f32; 3] {
    std::array::from_fn(|k| {
        let d = a[k] - b[k];
        d - period[k] * (d * inv_period[k]).round_ties_even()
    })
}

/// Same f32 arithmetic as the GPU's `dot` without fused multiply-add.
fn r2(d: [f32; 3]) -> f32 {
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Whether `r2` involves no rounding after the subtractions (dyadic points on cell
/// faces): then the GPU gets the same value with or without fused multiply-add, and a
/// distance of exactly `radius` is a sure exclusion rather than a tie.
fn exact_r2(d: [f32; 3]) -> bool {
    let e = d.map(f64::from);
    e[0] * e[0] + e[1] * e[1] + e[2] * e[2] == f64::from(r2(d))
}

/// Relative band around r² inside which the GPU's `dot` (possibly fused multiply-add)
/// and the CPU's unfused sum may round to opposite sides of the test: pairs there are
/// ties, counted as "either" (unless `exact_r2`). Tie counts are printed; 1e-6 is
/// ~8 ulp of r², FMA changes r² by at most 1-2 ulp.
const TIE_BAND: f32 = 1e-6;

/// The grid finds exactly the pairs a brute-force O(n²) search finds, at every reach R
/// (`GRID_REACH_RANGE`, the values `COUPLET_GRID_REACH` may set).
///
/// Reference: brute force on the CPU over the *sorted* f32 positions read back from the
/// GPU, with the same f32 test `r² < radius²`; radius = the support the grid was built
/// for (R cells, the loop's limit), and again a shorter one, δ at support 2.4 δ,
/// searched as the nearest surface marker is (`cells_within`, `row_ranges_within`: one
/// cell either side at R = 2, so that the periodic test also checks rows that wrap at
/// that reach). Per particle the neighbour set is compared by count, Σ id and Σ id²
/// (wrapping u32) — exact for every particle without a tie (|r² − radius²| ≤ 1e-6
/// radius², not exact); particles with ties must lie between the sure count and sure +
/// tied.
#[test]
fn grid_neighbours_match_brute_force() {
    let gpu = shared_test_gpu().unwrap();
    let h = 0.125;
    for r in GRID_REACH_RANGE {
        let grid =
            NeighbourGrid::new(&gpu, GridBox::closed([0.0; 3], [1.0, 0.75, 0.5]), h, r, 1).unwrap();
        let cell = (h / f64::from(r)) as f32;
        assert_eq!(grid.params.cell_size, [cell, cell, cell, 0.0]);
        // (extent + 2 pad) / cell + 1 per axis, pad = one support = R cells:
        // (1.25, 1.0, 0.75) / (h / R) + 1 = (10, 8, 6) R + 1 (11 × 9 × 7 for R = 1).
        assert_eq!(grid.params.dims, [10 * r + 1, 8 * r + 1, 6 * r + 1, 0]);
        assert_eq!(
            grid.params.n_cells,
            (10 * r + 1) * (8 * r + 1) * (6 * r + 1)
        );
        neighbours_match_brute_force(&gpu, [false; 3], 2024 + u64::from(r), r);
    }
}

/// The same on a grid periodic in x and z (the axes where rows wrap and where whole
/// rows wrap), at every reach: pairs across the periodic faces are found through the
/// nearest image, none twice. The test's points beyond the box on those axes are
/// wrapped by the sort. Reference: brute force with the nearest image in f32.
#[test]
fn grid_periodic_neighbours_match_brute_force() {
    let gpu = shared_test_gpu().unwrap();
    let h = 0.125;
    let periodic = [true, false, true];
    let bounds = GridBox {
        min: [0.0; 3],
        max: [1.0, 0.75, 0.5],
        periodic,
    };
    for r in GRID_REACH_RANGE {
        let grid = NeighbourGrid::new(&gpu, bounds, h, r, 1).unwrap();
        // Periodic: length / (h / R) whole cells, no padding; closed y as above.
        assert_eq!(grid.params.dims, [8 * r, 8 * r + 1, 4 * r, 0]);
        assert_eq!(grid.params.period, [1.0, 0.0, 0.5, 0.0]);
        neighbours_match_brute_force(&gpu, periodic, 77 + u64::from(r), r);
    }
}

/// A period shorter than 2R + 1 cells of support/R would see pairs twice: refused by
/// name. A period of 2.4 supports holds R = 3's seven cells but not R = 2's five, and
/// is refused at every R, so that whether a scene runs does not depend on
/// `COUPLET_GRID_REACH`.
/// Reference: the bound (2R + 1)/R supports, 2.5 at R = 2.
#[test]
fn grid_refuses_a_period_too_short_for_any_adapter() {
    let gpu = shared_test_gpu().unwrap();
    let h = 0.125;
    for r in GRID_REACH_RANGE {
        for z in [0.25, 0.3] {
            let short = GridBox {
                min: [0.0; 3],
                max: [1.0, 0.75, z],
                periodic: [true, false, true],
            };
            let err = NeighbourGrid::new(&gpu, short, h, r, 1)
                .err()
                .unwrap_or_else(|| panic!("a period of {z} m at support {h} m and R = {r}"));
            assert!(
                matches!(err, GridError::PeriodTooShort { axis: 2, reach, .. } if reach == r),
                "{err}"
            );
            assert!(
                err.to_string().contains(&format!("R = {GRID_REACH_CPU}")),
                "{err}"
            );
        }
        // 2.5 supports (R = 1 needs 3).
        let fits = GridBox {
            min: [0.0; 3],
            max: [1.0, 0.75, 0.3125],
            periodic: [true, false, true],
        };
        assert_eq!(
            NeighbourGrid::new(&gpu, fits, h, r, 1).is_ok(),
            r > 1,
            "R = {r}"
        );
    }
}

fn neighbours_match_brute_force(gpu: &Gpu, periodic: [bool; 3], seed: u64, reach: u32) {
    let n = 12_000;
    let h = 0.125;
    // The short search's radius: δ at support 2.4 δ (the nearest surface marker's
    // search, `body_non_penetration.wgsl`), one cell either side at R = 2.
    let near = h / 2.4;
    let xyz = scene(n, seed, reach);
    let parts = Particles::from_positions(&xyz);
    let bounds = GridBox {
        min: [0.0; 3],
        max: [1.0, 0.75, 0.5],
        periodic,
    };
    let mut grid = NeighbourGrid::new(gpu, bounds, h, reach, n as u32).unwrap();
    let b = upload_and_register(gpu, &mut grid, &parts);
    sort(gpu, &grid, &b);
    grid.check(gpu).unwrap();

    let pos: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
    let ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();

    // GPU pair count through grid_common.wgsl, groups 0 (particles), 1 (grid), 3 (params).
    let out = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("neighbour test out"),
        size: n as u64 * 32,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let test_params = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("neighbour test params"),
            contents: bytemuck::cast_slice(&[
                (h as f32).to_bits(),
                n as u32,
                (near as f32).to_bits(),
                0,
            ]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
    let particles_layout = gpu
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("test particles"),
            entries: &[
                shaders::storage_entry(0, true),
                shaders::storage_entry(1, true),
                shaders::storage_entry(2, false),
            ],
        });
    let params_layout = gpu
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("test params"),
            entries: &[shaders::uniform_entry(0)],
        });
    let module = shaders::module(
        gpu,
        "neighbour test",
        &[
            &grid_reach_wgsl(reach),
            GRID_COMMON_WGSL,
            NEIGHBOUR_TEST_WGSL,
        ],
    );
    let pipeline = shaders::compute_pipeline_with_layouts(
        gpu,
        "neighbour test",
        &module,
        "count_neighbours",
        &[
            Some(&particles_layout),
            Some(grid.bind_group_layout()),
            None,
            Some(&params_layout),
        ],
    );
    let particles_bg = shaders::bind_buffers(
        gpu,
        "test particles",
        &particles_layout,
        &[&b.pos, &b.id, &out],
    );
    let params_bg = shaders::bind_buffers(gpu, "test params", &params_layout, &[&test_params]);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &particles_bg, &[]);
        pass.set_bind_group(1, grid.bind_group(), &[]);
        pass.set_bind_group(3, &params_bg, &[]);
        shaders::dispatch_linear(&mut pass, n as u32);
    }
    gpu.queue.submit([encoder.finish()]);
    let got: Vec<[u32; 4]> = gpu.read_buffer(&out, 0, 2 * n as u64).unwrap();

    for (entry, radius) in [(0, h), (1, near)] {
        let radius2 = (radius as f32) * (radius as f32);
        let (lo, hi) = (radius2 * (1.0 - TIE_BAND), radius2 * (1.0 + TIE_BAND));
        let mut tied_particles = 0;
        let mut pairs = 0u64;
        for i in 0..n {
            let (mut sure, mut tied, mut id_sum, mut id_sq) = (0u32, 0u32, 0u32, 0u32);
            for j in 0..n {
                if j == i {
                    continue;
                }
                let d = pair_vec(pos[i], pos[j], grid.params.period, grid.params.inv_period);
                let d2 = r2(d);
                if d2 < lo {
                    sure += 1;
                    id_sum = id_sum.wrapping_add(ids[j]);
                    id_sq = id_sq.wrapping_add(ids[j].wrapping_mul(ids[j]));
                } else if d2 < hi && !exact_r2(d) {
                    tied += 1;
                }
            }
            pairs += u64::from(sure);
            let [count, gsum, gsq, count_cells] = got[2 * i + entry];
            if entry == 0 {
                assert_eq!(
                    count, count_cells,
                    "particle slot {i}: row loop and cell-by-cell loop disagree"
                );
            }
            if tied == 0 {
                assert_eq!(
                    (count, gsum, gsq),
                    (sure, id_sum, id_sq),
                    "particle id {} at {:?}: GPU (count, Σid, Σid²) within {radius} vs brute force",
                    ids[i],
                    pos[i]
                );
            } else {
                tied_particles += 1;
                assert!(
                    (sure..=sure + tied).contains(&count),
                    "particle id {}: GPU count {count} within {radius} outside brute force [{sure}, {}]",
                    ids[i],
                    sure + tied
                );
            }
        }
        println!(
            "neighbours within {radius}: {n} particles, {pairs} ordered pairs (mean {:.1} per \
             particle), {tied_particles} particle(s) with a tie at |r| = {radius}",
            pairs as f64 / n as f64
        );
    }
}

/// Every registered buffer is permuted by the same permutation; `cell_start` is a
/// monotone exclusive prefix with `cell_start[n_cells] == n`, each sorted particle
/// lies in its cell's range, and the sort is stable. Reference: the arrays before upload (bit-exact).
#[test]
fn grid_sort_permutes_every_registered_buffer() {
    let gpu = shared_test_gpu().unwrap();
    let n = 20_000;
    let (parts, grid, b) = scene_in_box(&gpu, n, 7);
    assert_eq!(grid.registered(), 4);

    for round in 0..2 {
        // The second sort runs on sorted data: counters must be cleared each time.
        sort(&gpu, &grid, &b);
        grid.check(&gpu).unwrap();
        let pos: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
        let vel: Vec<[f32; 4]> = gpu.read_buffer(&b.vel, 0, n as u64).unwrap();
        let rho: Vec<f32> = gpu.read_buffer(&b.rho, 0, n as u64).unwrap();
        let ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
        let nc = grid.params.n_cells as usize;
        let cell_start: Vec<u32> = gpu.read_buffer(&grid.cell_start, 0, nc as u64 + 1).unwrap();

        let mut seen = vec![false; n];
        for (j, &id) in ids.iter().enumerate() {
            let k = id as usize;
            assert!(
                k < n && !seen[k],
                "round {round}: id {id} at slot {j} repeated or out of range"
            );
            seen[k] = true;
            assert_eq!(
                bytemuck::cast::<_, [u32; 4]>(pos[j]),
                bytemuck::cast::<_, [u32; 4]>(parts.pos[k])
            );
            assert_eq!(
                bytemuck::cast::<_, [u32; 4]>(vel[j]),
                bytemuck::cast::<_, [u32; 4]>(parts.vel[k])
            );
            assert_eq!(rho[j].to_bits(), parts.rho[k].to_bits());
        }

        assert_eq!(cell_start[0], 0);
        assert_eq!(cell_start[nc], n as u32, "cell_start[n_cells] must be n");
        assert!(
            cell_start.windows(2).all(|w| w[0] <= w[1]),
            "cell_start not monotone"
        );
        // Stable: inside every cell the particles keep their order before the sort,
        // so the ids (0..n before the first sort) ascend within each cell, and the
        // second sort of already sorted data is the identity.
        for c in 0..nc {
            let slice = &ids[cell_start[c] as usize..cell_start[c + 1] as usize];
            assert!(
                slice.windows(2).all(|w| w[0] < w[1]),
                "round {round}: cell {c} ids {slice:?} not in their previous order"
            );
        }
        if round == 1 {
            let map: Vec<u32> = gpu.read_buffer(grid.gather_map(), 0, n as u64).unwrap();
            let moved = map
                .iter()
                .enumerate()
                .filter(|(j, s)| **s != *j as u32)
                .count();
            assert_eq!(
                moved, 0,
                "re-sorting sorted particles moved {moved} of them"
            );
        }
        let g = &grid.params;
        for (j, p) in pos.iter().enumerate() {
            // Same f32 arithmetic as cell_coord(): (p − origin) · inv_cell_size, floor.
            let c: [u32; 3] =
                std::array::from_fn(|a| ((p[a] - g.origin[a]) * g.inv_cell_size[a]).floor() as u32);
            let ci = (c[0] + g.dims[0] * (c[1] + g.dims[1] * c[2])) as usize;
            assert!(
                (cell_start[ci] as usize..cell_start[ci + 1] as usize).contains(&j),
                "round {round}: slot {j} at {p:?} (cell {ci}) outside its cell range"
            );
        }
    }
}

/// More registered buffers of each size than one reorder pass gathers, registered with
/// the sizes interleaved: every one is permuted as the ids are, bit for bit, in passes
/// of at most `GATHER_BUFFERS_PER_PASS` buffers of one size (16-byte ones first, each
/// size in registration order), and a registration after a sort makes the next sort
/// plan its passes again. Reference: the values written before the sort, a function of
/// each particle's id and the buffer's index.
#[test]
fn grid_reorder_gathers_many_buffers_a_pass_alike() {
    let gpu = shared_test_gpu().unwrap();
    let n = 5_000;
    // pos and vel (16 bytes), rho and id (4 bytes).
    let (parts, mut grid, b) = scene_in_box(&gpu, n, 11);
    let extra = 2 * GATHER_BUFFERS_PER_PASS + 1;
    let wide_value = |k: u32, i: u32| [k * 100_003 + i, i ^ (k << 20), !i, k.wrapping_mul(i)];
    let narrow_value = |k: u32, i: u32| i.wrapping_mul(2_654_435_761) ^ (k << 24);
    let mut wide = Vec::new();
    let mut narrow = Vec::new();
    for k in 0..extra as u32 {
        let w: Vec<[u32; 4]> = (0..n as u32).map(|i| wide_value(k, i)).collect();
        wide.push(buffer_init(&gpu, "wide", &w));
        grid.register(wide.last().unwrap(), 16).unwrap();
        let v: Vec<u32> = (0..n as u32).map(|i| narrow_value(k, i)).collect();
        narrow.push(buffer_init(&gpu, "narrow", &v));
        grid.register(narrow.last().unwrap(), 4).unwrap();
    }
    assert_eq!(grid.reorder_passes(), None, "no sort yet");
    sort(&gpu, &grid, &b);
    grid.check(&gpu).unwrap();

    let per_size = 2 + extra;
    let chunks = |bytes: u32| {
        (0..per_size)
            .step_by(GATHER_BUFFERS_PER_PASS)
            .map(move |first| (bytes, (per_size - first).min(GATHER_BUFFERS_PER_PASS)))
    };
    let expected: Vec<(u32, usize)> = chunks(16).chain(chunks(4)).collect();
    assert_eq!(grid.reorder_passes(), Some(expected));

    let ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
    let pos: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
    let rho: Vec<f32> = gpu.read_buffer(&b.rho, 0, n as u64).unwrap();
    let mut seen = vec![false; n];
    for (j, &id) in ids.iter().enumerate() {
        assert!(!seen[id as usize], "id {id} twice");
        seen[id as usize] = true;
        assert_eq!(
            bytemuck::cast::<_, [u32; 4]>(pos[j]),
            bytemuck::cast::<_, [u32; 4]>(parts.pos[id as usize])
        );
        assert_eq!(rho[j].to_bits(), parts.rho[id as usize].to_bits());
    }
    for k in 0..extra {
        let w: Vec<[u32; 4]> = gpu.read_buffer(&wide[k], 0, n as u64).unwrap();
        let v: Vec<u32> = gpu.read_buffer(&narrow[k], 0, n as u64).unwrap();
        for (j, &id) in ids.iter().enumerate() {
            assert_eq!(w[j], wide_value(k as u32, id), "wide buffer {k}, slot {j}");
            assert_eq!(
                v[j],
                narrow_value(k as u32, id),
                "narrow buffer {k}, slot {j}"
            );
        }
    }

    let late = buffer_init(&gpu, "late", &vec![0u32; n]);
    grid.register(&late, 4).unwrap();
    assert_eq!(
        grid.reorder_passes(),
        None,
        "a registration drops the old passes"
    );
    sort(&gpu, &grid, &b);
    let last = grid.reorder_passes().unwrap();
    assert_eq!(last.iter().map(|p| p.1).sum::<usize>(), 2 * per_size + 1);
}

/// Buffers lent to the reorder as scratch: a pass gathers into the smallest lent buffer
/// it fits (pos and vel, 32 B a particle, into the 32-byte loan rather than the 48-byte
/// one; ρ and id, 8 B, into the 16-byte one), the grid then holds no scratch of its own,
/// and the registered buffers are permuted as the ids are, bit for bit, as without a
/// loan. A registered buffer cannot be lent, nor a lent one registered, nor one too
/// small. Reference: the arrays before upload.
#[test]
fn grid_reorder_gathers_into_lent_buffers() {
    let gpu = shared_test_gpu().unwrap();
    let n = 5_000;
    let (parts, mut grid, b) = scene_in_box(&gpu, n, 13);
    sort(&gpu, &grid, &b);
    assert_eq!(
        grid.reorder_scratch_bytes(),
        Some(n as u64 * (32 + 8)),
        "without a loan: scratch for pos, vel (16 B each), ρ and id (4 B each)"
    );
    let lend = |label: &str, bytes: usize| buffer_init(&gpu, label, &vec![7u8; n * bytes]);
    let (wide48, wide32, narrow16) = (lend("48", 48), lend("32", 32), lend("16", 16));
    grid.lend_scratch(&wide48, 48).unwrap();
    grid.lend_scratch(&narrow16, 16).unwrap();
    grid.lend_scratch(&wide32, 32).unwrap();
    assert_eq!(grid.reorder_passes(), None, "a loan drops the old passes");
    resort_shuffled(&gpu, &grid, &b, n);
    assert_eq!(grid.reorder_passes(), Some(vec![(16, 2), (4, 2)]));
    assert_eq!(
        grid.reorder_scratch_bytes(),
        Some(0),
        "every pass in a loan"
    );
    assert_sorted_copy_of(&gpu, &b, &parts, n);
    // The 48-byte loan was left alone: the 32-byte one fitted pos and vel.
    let untouched: Vec<u8> = gpu.read_buffer(&wide48, 0, 48 * n as u64).unwrap();
    assert!(
        untouched.iter().all(|&x| x == 7),
        "the 48-byte loan was written"
    );

    let refused = |r: Result<(), GridError>, what: &str| match r {
        Err(GridError::BadBuffer { reason, .. }) => assert!(reason.contains(what), "{reason}"),
        other => panic!("expected BadBuffer ({what}), got {other:?}"),
    };
    refused(grid.lend_scratch(&b.vel, 16), "registered");
    refused(grid.register(&narrow16, 4), "lent");
    refused(grid.lend_scratch(&lend("small", 8), 16), "bytes need");
}

/// Shuffles the (sorted) arrays of `scene_in_box` on the GPU, so that the next sort
/// moves every particle, and sorts them again.
fn resort_shuffled(gpu: &Gpu, grid: &NeighbourGrid, b: &OnGpu, n: usize) {
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(5));
    let pos_now: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
    let vel_now: Vec<[f32; 4]> = gpu.read_buffer(&b.vel, 0, n as u64).unwrap();
    let rho_now: Vec<f32> = gpu.read_buffer(&b.rho, 0, n as u64).unwrap();
    let id_now: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
    fn shuffled<T: bytemuck::Pod>(v: &[T], order: &[usize]) -> Vec<T> {
        order.iter().map(|&k| v[k]).collect()
    }
    let write = |buf: &wgpu::Buffer, bytes: &[u8]| gpu.queue.write_buffer(buf, 0, bytes);
    write(&b.pos, bytemuck::cast_slice(&shuffled(&pos_now, &order)));
    write(&b.vel, bytemuck::cast_slice(&shuffled(&vel_now, &order)));
    write(&b.rho, bytemuck::cast_slice(&shuffled(&rho_now, &order)));
    write(&b.id, bytemuck::cast_slice(&shuffled(&id_now, &order)));
    sort(gpu, grid, b);
    grid.check(gpu).unwrap();
}

/// Every particle of `parts` once in the GPU's arrays, with its own position, velocity
/// and density bit for bit (whatever the slot), found by its id.
fn assert_sorted_copy_of(gpu: &Gpu, b: &OnGpu, parts: &Particles, n: usize) {
    let pos: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
    let vel: Vec<[f32; 4]> = gpu.read_buffer(&b.vel, 0, n as u64).unwrap();
    let rho: Vec<f32> = gpu.read_buffer(&b.rho, 0, n as u64).unwrap();
    let ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
    let mut seen = vec![false; n];
    for (j, &id) in ids.iter().enumerate() {
        let k = id as usize;
        assert!(!seen[k], "id {id} twice");
        seen[k] = true;
        let bits = |v: [f32; 4]| bytemuck::cast::<_, [u32; 4]>(v);
        assert_eq!(bits(pos[j]), bits(parts.pos[k]), "pos at slot {j}");
        assert_eq!(bits(vel[j]), bits(parts.vel[k]), "vel at slot {j}");
        assert_eq!(rho[j].to_bits(), parts.rho[k].to_bits(), "ρ at slot {j}");
    }
}

/// A loan too small for a whole pass takes the 16-byte buffers it holds off a pass with
/// scratch of its own: with 8 and 16 B lent, ρ and id (8 B) go into the 8-byte loan and
/// vel into the 16-byte one, a pass of its own, which leaves pos's 16 B of scratch
/// instead of pos's and vel's 32. The sort's result is the same.
/// Reference: the arrays before upload (bit-exact), the passes counted by hand.
#[test]
fn grid_reorder_splits_a_pass_into_a_loan_too_small_for_it() {
    let gpu = shared_test_gpu().unwrap();
    let n = 5_000;
    let (parts, mut grid, b) = scene_in_box(&gpu, n, 17);
    let lend = |label: &str, bytes: usize| buffer_init(&gpu, label, &vec![7u8; n * bytes]);
    let (wide16, narrow8) = (lend("16", 16), lend("8", 8));
    grid.lend_scratch(&wide16, 16).unwrap();
    grid.lend_scratch(&narrow8, 8).unwrap();
    sort(&gpu, &grid, &b);
    resort_shuffled(&gpu, &grid, &b, n);
    assert_eq!(grid.reorder_passes(), Some(vec![(16, 1), (16, 1), (4, 2)]));
    assert_eq!(
        grid.reorder_scratch_bytes(),
        Some(n as u64 * 16),
        "pos's slice"
    );
    assert_sorted_copy_of(&gpu, &b, &parts, n);
}

/// A particle beyond the padded box is reported by id and position, never clamped
/// silently; so is a NaN position. A particle in the padding is fine. Reference: the
/// positions placed by the test.
#[test]
fn grid_reports_particle_outside() {
    let gpu = shared_test_gpu().unwrap();
    let n = 1000;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut xyz: Vec<[f32; 3]> = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random_range(0.0..1.0)))
        .collect();
    // In the padding of one support (0.1): inside the grid, no error.
    xyz[10] = [-0.09, 1.09, 0.5];
    let parts = Particles::from_positions(&xyz);
    let mut grid = NeighbourGrid::new(
        &gpu,
        GridBox::closed([0.0; 3], [1.0; 3]),
        0.1,
        GRID_REACH_CPU,
        n as u32,
    )
    .unwrap();
    let b = upload_and_register(&gpu, &mut grid, &parts);
    sort(&gpu, &grid, &b);
    grid.check(&gpu).unwrap();

    // Ids in the arrays after the sort; move the particle with id 500 far out.
    let ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
    let mut pos: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
    let slot = ids.iter().position(|&id| id == 500).unwrap();
    pos[slot] = [0.5, 1.35, 0.5, pos[slot][3]];
    gpu.queue
        .write_buffer(&b.pos, 0, bytemuck::cast_slice(&pos));
    sort(&gpu, &grid, &b);
    match grid.check(&gpu) {
        Err(GridError::ParticleOutside {
            id,
            index,
            position,
            outside,
            ..
        }) => {
            assert_eq!(id, Some(500));
            assert_eq!(index as usize, slot);
            assert_eq!(position, [0.5, 1.35, 0.5]);
            assert_eq!(outside, 1);
        }
        other => panic!("expected ParticleOutside for id 500, got {other:?}"),
    }
    let msg = grid.check(&gpu).unwrap_err().to_string();
    assert!(msg.contains("particle id 500"), "message: {msg}");
    println!("outside: {msg}");
    // The permutation stays complete even with a particle outside.
    let mut ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
    ids.sort_unstable();
    assert!(ids.iter().enumerate().all(|(k, &id)| id == k as u32));

    // NaN position: reported as well.
    grid.reset_error(&gpu);
    let ids: Vec<u32> = gpu.read_buffer(&b.id, 0, n as u64).unwrap();
    let mut pos: Vec<[f32; 4]> = gpu.read_buffer(&b.pos, 0, n as u64).unwrap();
    for p in pos.iter_mut() {
        p[1] = p[1].min(0.9);
    }
    let slot = ids.iter().position(|&id| id == 123).unwrap();
    pos[slot][0] = f32::NAN;
    gpu.queue
        .write_buffer(&b.pos, 0, bytemuck::cast_slice(&pos));
    sort(&gpu, &grid, &b);
    match grid.check(&gpu) {
        Err(GridError::ParticleOutside {
            id,
            position,
            outside,
            ..
        }) => {
            assert_eq!(id, Some(123));
            assert!(position[0].is_nan());
            assert_eq!(outside, 1);
        }
        other => panic!("expected ParticleOutside for id 123, got {other:?}"),
    }
}

/// The WGSL `GridParams` (grid_common.wgsl) reads every field at the offset the Rust
/// struct writes it. Reference: the Rust struct's bytes.
#[test]
fn grid_params_layout_agrees_with_wgsl() {
    let gpu = shared_test_gpu().unwrap();
    let grid = NeighbourGrid::new(
        &gpu,
        GridBox::closed([0.0; 3], [1.0; 3]),
        0.5,
        GRID_REACH_CPU,
        16,
    )
    .unwrap();
    let params = GridParams {
        origin: [1.5, -2.5, 3.25, 4.75],
        cell_size: [0.125, 0.25, 0.5, 1.0],
        inv_cell_size: [8.0, 4.0, 2.0, 1.0],
        dims: [7, 8, 9, 10],
        period: [0.0, 2.0, 0.0, 3.0],
        inv_period: [0.0, 0.5, 0.0, 1.0 / 3.0],
        n_particles: 123_456,
        n_cells: 789,
        _pad: [11, 12],
    };
    let params_buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
    let out = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("out"),
        size: 112,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    const WGSL: &str = r#"
@group(0) @binding(0) var<storage, read_write> out: array<u32, 28>;
@compute @workgroup_size(1)
fn main() {
    let f = array<vec4<f32>, 6>(grid.origin, grid.cell_size, grid.inv_cell_size,
                                bitcast<vec4<f32>>(grid.dims), grid.period, grid.inv_period);
    for (var k = 0u; k < 6u; k++) {
        let v = bitcast<vec4<u32>>(f[k]);
        out[4u * k] = v.x;
        out[4u * k + 1u] = v.y;
        out[4u * k + 2u] = v.z;
        out[4u * k + 3u] = v.w;
    }
    out[24] = grid.n_particles;
    out[25] = grid.n_cells;
    out[26] = grid._pad0;
    out[27] = grid._pad1 + cell_start[0] * 0u;
}
"#;
    let out_layout = gpu
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("out"),
            entries: &[shaders::storage_entry(0, false)],
        });
    let module = shaders::module(
        &gpu,
        "layout test",
        &[&grid_reach_wgsl(GRID_REACH_CPU), GRID_COMMON_WGSL, WGSL],
    );
    let pipeline = shaders::compute_pipeline_with_layouts(
        &gpu,
        "layout test",
        &module,
        "main",
        &[Some(&out_layout), Some(grid.bind_group_layout())],
    );
    let grid_bg = shaders::bind_buffers(
        &gpu,
        "grid",
        grid.bind_group_layout(),
        &[&params_buffer, &grid.cell_start],
    );
    let out_bg = shaders::bind_buffers(&gpu, "out", &out_layout, &[&out]);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &out_bg, &[]);
        pass.set_bind_group(1, &grid_bg, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    let got: Vec<u32> = gpu.read_buffer(&out, 0, 28).unwrap();
    let want: [u32; 28] = bytemuck::cast(params);
    assert_eq!(got, want.to_vec());
}

/// Workgroup split: 1-D up to 65535 workgroups, then x × y covering every thread.
/// `read_buffers` returns each range as `read_buffer` does, ranges of any length (an
/// odd one, an empty one) from several buffers in one submission. Reference: the bytes
/// uploaded.
#[test]
fn gpu_reads_several_ranges_in_one_round_trip() {
    let gpu = shared_test_gpu().unwrap();
    let a: Vec<u32> = (0..64).map(|i| i * 7 + 1).collect();
    let b: Vec<[f32; 4]> = (0..16).map(|i| [i as f32, -0.5, 1e-3, f32::NAN]).collect();
    let (ga, gb) = (buffer_init(&gpu, "a", &a), buffer_init(&gpu, "b", &b));
    let [x, y, z, w] = gpu
        .read_buffers([(&ga, 8, 6), (&gb, 32, 48), (&ga, 0, 0), (&ga, 0, 256)])
        .unwrap();
    let a_bytes: &[u8] = bytemuck::cast_slice(&a);
    let b_bytes: &[u8] = bytemuck::cast_slice(&b);
    assert_eq!(x, &a_bytes[8..14]);
    assert_eq!(y, &b_bytes[32..80]);
    assert!(z.is_empty());
    assert_eq!(w, a_bytes);
    let one: Vec<[u32; 4]> = gpu.read_buffer(&gb, 2, 3).unwrap();
    assert_eq!(bytemuck::cast_slice::<[u32; 4], u8>(&one), &b_bytes[32..80]);
}

#[test]
fn gpu_workgroups_split() {
    assert_eq!(shaders::workgroups(0), [0, 1, 1]);
    assert_eq!(shaders::workgroups(1), [1, 1, 1]);
    assert_eq!(shaders::workgroups(128), [1, 1, 1]);
    assert_eq!(shaders::workgroups(129), [2, 1, 1]);
    assert_eq!(shaders::workgroups(65535 * 128), [65535, 1, 1]);
    let [x, y, z] = shaders::workgroups(65535 * 128 + 1);
    assert_eq!((x, y, z), (65535, 2, 1));
    let n = 400_000_000u32;
    let [x, y, _] = shaders::workgroups(n);
    assert!(x <= 65535 && u64::from(x) * u64::from(y) * 128 >= u64::from(n));
}

/// Stage timer: every pass of a sort is reported under its label with a finite,
/// non-negative time (no wall-clock value is asserted). Prints the sort's stage times
/// for 262 144 particles (the SPHERIC-2 size) on this machine.
#[test]
fn gpu_stage_timer_reports_sort_stages() {
    let gpu = shared_test_gpu().unwrap();
    println!("device: {}", gpu.describe());
    let n = 262_144u32;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    // Dam-break box 1.6 × 0.67 × 0.6 m, support 2.4 dp with dp ≈ 0.0125.
    let xyz: Vec<[f32; 3]> = (0..n)
        .map(|_| {
            [
                rng.random_range(0.0..1.6),
                rng.random_range(0.0..0.67),
                rng.random_range(0.0..0.6),
            ]
        })
        .collect();
    let parts = Particles::from_positions(&xyz);
    let mut grid = NeighbourGrid::new(
        &gpu,
        GridBox::closed([0.0; 3], [1.6, 0.67, 0.6]),
        0.03,
        GRID_REACH_CPU,
        n,
    )
    .unwrap();
    let b = upload_and_register(&gpu, &mut grid, &parts);
    let mut timer = StageTimer::new(&gpu, 16);
    let steps = 5;
    for _ in 0..steps {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        grid.queue_sort(&gpu, &mut encoder, &b.pos, Some(&mut timer));
        timer.finish(&gpu, &mut encoder);
        gpu.queue.submit([encoder.finish()]);
        timer.collect(&gpu).unwrap();
    }
    grid.check(&gpu).unwrap();
    let totals = timer.totals_with_counts();
    println!(
        "timing mode {:?}, {} cells",
        timer.mode(),
        grid.params.n_cells
    );
    for label in [
        "grid: count",
        "grid: scan",
        "grid: scatter",
        "grid: order",
        "grid: reorder",
    ] {
        let (_, s, count) = totals
            .iter()
            .find(|(l, _, _)| l == label)
            .unwrap_or_else(|| panic!("no time for {label}: {totals:?}"));
        assert_eq!(*count, steps);
        assert!(s.is_finite() && *s >= 0.0);
        println!("  {label}: {:.3} ms per sort", s / steps as f64 * 1e3);
    }
    assert_eq!(timer.dropped(), 0);
    if gpu.timestamps {
        assert_eq!(timer.mode(), TimingMode::Timestamps);
    }
}
