//! Exclusive prefix sum of `u32` on the GPU (multi-level block scan) and its CPU twin.
//!
//! Level 0 scans `data` in blocks of [`SCAN_BLOCK`] elements and writes one total per
//! block; level 1 scans those totals the same way, and so on until one block is left
//! (20 M elements: 3 levels). Then each level's scanned totals are added back to the
//! level below. 2 + 2·(levels − 1) dispatches, no CPU round trip, in place.

use wgpu::util::DeviceExt;

use crate::gpu::Gpu;
use crate::shaders::{self, WORKGROUP_SIZE};
use crate::timing::{self, StageTimer};

/// Elements each thread scans serially before the workgroup-wide scan: 4 u32 make a
/// 16-byte run per thread and a 512-element block, so 3 levels cover 134 M elements.
pub const SCAN_ITEMS_PER_THREAD: u32 = 4;
/// Elements one workgroup scans.
pub const SCAN_BLOCK: u32 = WORKGROUP_SIZE * SCAN_ITEMS_PER_THREAD;

const PREFIX_SUM_WGSL: &str = include_str!("../shaders/prefix_sum.wgsl");

/// Why a scan cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum PrefixSumError {
    #[error("prefix sum over {n} u32 needs a buffer of {needed} bytes, `{label}` has {size}")]
    BufferTooSmall {
        label: String,
        n: u32,
        needed: u64,
        size: u64,
    },
    #[error("prefix sum buffer `{label}` lacks STORAGE usage (has {usage:?})")]
    MissingUsage {
        label: String,
        usage: wgpu::BufferUsages,
    },
    #[error(
        "prefix sum over {n} u32 ({bytes} bytes) exceeds the adapter's max storage buffer \
         binding size of {max} bytes"
    )]
    TooLarge { n: u32, bytes: u64, max: u64 },
}

#[repr(C)]
#[derive(bytemuck::Pod, bytemuck::Zeroable, Clone, Copy)]
struct ScanParams {
    n: u32,
    _pad: [u32; 3],
}

struct Level {
    n: u32,
    bind_group: wgpu::BindGroup,
    // Kept alive for the bind group.
    _params: wgpu::Buffer,
}

/// An in-place exclusive scan of the first `n` u32 of one buffer, set up once and
/// recorded every step.
pub struct PrefixSum {
    scan_blocks: wgpu::ComputePipeline,
    add_block_offsets: wgpu::ComputePipeline,
    levels: Vec<Level>,
    /// Block totals of every level (level k's totals are level k+1's data).
    block_sums: Vec<wgpu::Buffer>,
    n: u32,
}

impl PrefixSum {
    /// Bytes of the block totals this scan keeps (about 4 B per SCAN_BLOCK entries).
    pub fn scratch_bytes(&self) -> u64 {
        self.block_sums.iter().map(wgpu::Buffer::size).sum()
    }

    /// Prepares the scan of `data[0..n]` (`data` needs `STORAGE` usage).
    pub fn new(gpu: &Gpu, data: &wgpu::Buffer, n: u32) -> Result<PrefixSum, PrefixSumError> {
        let label = format!("{data:?}");
        if !data.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(PrefixSumError::MissingUsage {
                label,
                usage: data.usage(),
            });
        }
        let needed = u64::from(n) * 4;
        if data.size() < needed {
            return Err(PrefixSumError::BufferTooSmall {
                label,
                n,
                needed,
                size: data.size(),
            });
        }
        let max = gpu.storage_binding_limit;
        if needed > max {
            return Err(PrefixSumError::TooLarge {
                n,
                bytes: needed,
                max,
            });
        }

        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("prefix sum"),
                entries: &[
                    shaders::uniform_entry(0),
                    shaders::storage_entry(1, false),
                    shaders::storage_entry(2, false),
                ],
            });
        let consts = format!("const SCAN_ITEMS_PER_THREAD: u32 = {SCAN_ITEMS_PER_THREAD}u;\n");
        let module = shaders::module(gpu, "prefix sum", &[&consts, PREFIX_SUM_WGSL]);
        let scan_blocks = shaders::compute_pipeline_with_layouts(
            gpu,
            "prefix sum: scan blocks",
            &module,
            "scan_blocks",
            &[Some(&layout)],
        );
        let add_block_offsets = shaders::compute_pipeline_with_layouts(
            gpu,
            "prefix sum: add block offsets",
            &module,
            "add_block_offsets",
            &[Some(&layout)],
        );

        let mut levels = Vec::new();
        let mut block_sums: Vec<wgpu::Buffer> = Vec::new();
        let mut level_n = n;
        loop {
            let n_blocks = level_n.div_ceil(SCAN_BLOCK).max(1);
            let sums = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("prefix sum: block sums"),
                size: u64::from(n_blocks) * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let params = gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("prefix sum: level params"),
                    contents: bytemuck::bytes_of(&ScanParams {
                        n: level_n,
                        _pad: [0; 3],
                    }),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
            let level_data = block_sums.last().unwrap_or(data);
            let bind_group = shaders::bind_buffers(
                gpu,
                "prefix sum level",
                &layout,
                &[&params, level_data, &sums],
            );
            levels.push(Level {
                n: level_n,
                bind_group,
                _params: params,
            });
            block_sums.push(sums);
            if n_blocks <= 1 {
                break;
            }
            level_n = n_blocks;
        }
        Ok(PrefixSum {
            scan_blocks,
            add_block_offsets,
            levels,
            block_sums,
            n,
        })
    }

    /// Elements scanned.
    pub fn len(&self) -> u32 {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Number of levels (1 for n ≤ [`SCAN_BLOCK`]).
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Records the scan into an open compute pass (the caller labels and times it).
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        if self.n == 0 {
            return;
        }
        pass.set_pipeline(&self.scan_blocks);
        for level in &self.levels {
            let [x, y, z] = shaders::workgroups_for_groups(level.n.div_ceil(SCAN_BLOCK));
            pass.set_bind_group(0, &level.bind_group, &[]);
            pass.dispatch_workgroups(x, y, z);
        }
        pass.set_pipeline(&self.add_block_offsets);
        for level in self.levels.iter().rev().skip(1) {
            let [x, y, z] = shaders::workgroups_for_groups(level.n.div_ceil(SCAN_BLOCK));
            pass.set_bind_group(0, &level.bind_group, &[]);
            pass.dispatch_workgroups(x, y, z);
        }
    }

    /// Records the scan as its own compute pass labelled "prefix sum".
    pub fn queue(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut StageTimer>,
    ) {
        let mut pass = timing::begin_pass(timer, gpu, encoder, "prefix sum");
        self.record(&mut pass);
    }
}

/// CPU twin: exclusive scan with wrapping u32 addition, like the GPU.
pub fn exclusive_scan_cpu(input: &[u32]) -> Vec<u32> {
    let mut sum = 0u32;
    input
        .iter()
        .map(|&x| {
            let before = sum;
            sum = sum.wrapping_add(x);
            before
        })
        .collect()
}
