//! GPU exclusive scan against its CPU twin `exclusive_scan_cpu` (exact: integer sums,
//! wrapping modulo 2^32 on both sides). Serialised on the one GPU via `shared_test_gpu`.

use couplet_fluid::gpu::shared_test_gpu;
use couplet_fluid::prefix_sum::{PrefixSum, SCAN_BLOCK, exclusive_scan_cpu};
use couplet_fluid::shaders::{MAX_WORKGROUPS_PER_DIMENSION, WORKGROUP_SIZE};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wgpu::util::DeviceExt;

fn gpu_scan(input: &[u32]) -> (Vec<u32>, usize) {
    let gpu = shared_test_gpu().unwrap();
    let buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scan input"),
            contents: bytemuck::cast_slice(input),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
    let scan = PrefixSum::new(&gpu, &buffer, input.len() as u32).unwrap();
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    scan.queue(&gpu, &mut encoder, None);
    gpu.queue.submit([encoder.finish()]);
    let out = gpu
        .read_buffer::<u32>(&buffer, 0, input.len() as u64)
        .unwrap();
    (out, scan.levels())
}

fn check(n: usize, max_value: u32, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let input: Vec<u32> = (0..n).map(|_| rng.random_range(0..=max_value)).collect();
    let (gpu, levels) = gpu_scan(&input);
    let cpu = exclusive_scan_cpu(&input);
    let first_bad = gpu.iter().zip(&cpu).position(|(g, c)| g != c);
    assert!(
        first_bad.is_none(),
        "n = {n}: GPU scan differs from the CPU twin first at {:?}: gpu {:?} cpu {:?}",
        first_bad,
        first_bad.map(|i| gpu[i]),
        first_bad.map(|i| cpu[i])
    );
    println!("prefix sum n = {n}: exact over {levels} level(s)");
}

/// Sizes around the workgroup and block sizes, one level, two levels, three levels.
#[test]
fn prefix_sum_matches_cpu_twin_exactly() {
    let wg = WORKGROUP_SIZE as usize;
    let block = SCAN_BLOCK as usize;
    for (k, n) in [
        1,
        7,
        wg - 1,
        wg,
        wg + 1,
        block - 1,
        block,
        block + 1,
        wg * wg + 5,          // > WG² elements
        block * block - 3,    // largest two-level size
        block * block + 1000, // three levels
        3_000_017,
    ]
    .into_iter()
    .enumerate()
    {
        check(n, 1000, k as u64);
    }
}

/// Full-range values: the sums wrap modulo 2^32 identically on both sides.
#[test]
fn prefix_sum_wraps_like_cpu_twin() {
    check(100_003, u32::MAX, 42);
}

/// More than 65535 blocks: the dispatch splits into x × y workgroups and kernels must
/// recover the block index with `linear_workgroup`. 65536 blocks is the most that fits
/// lavapipe's 128 MiB storage binding limit.
#[test]
fn prefix_sum_two_dimensional_dispatch() {
    let n = MAX_WORKGROUPS_PER_DIMENSION as usize * SCAN_BLOCK as usize + 300;
    check(n, 3, 7);
}
