//! Device setup: one Vulkan adapter, the limits it offers, optional timestamp queries.
//!
//! couplet runs on the Vulkan backend only: NVIDIA's driver on GPU machines, Mesa's
//! lavapipe (Vulkan on the CPU) in CI and on developer machines (DESIGN.md, "Numbers
//! on the GPU"). Only what both offer is required; timestamps are optional.

use std::sync::{Mutex, MutexGuard, OnceLock};

use crate::neighbour_grid::{
    DENSE_LANES_ENV, GRID_REACH_RANGE, TEAM_LANES_ENV, dense_team_lanes, grid_reach_for,
    team_lanes_for, team_lanes_valid,
};

/// Storage buffers a single kernel may bind. The corrected SPH scheme's pair kernels
/// bind about this many particle arrays; lavapipe and NVIDIA both offer far more.
pub const MIN_STORAGE_BUFFERS_PER_STAGE: u32 = 10;

/// Why no device could be created or a GPU transfer failed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum GpuError {
    /// No Vulkan adapter is visible to wgpu.
    #[error(
        "no Vulkan adapter found (backends tried: {tried}). On a machine without a GPU install \
         Mesa's lavapipe: `apt-get install mesa-vulkan-drivers`; with an NVIDIA GPU install its driver, \
         and libglvnd, which NVIDIA's Vulkan driver loads (`libGLdispatch.so.0`: `apt-get install libglvnd0`)."
    )]
    NoAdapter { tried: String },
    /// The adapter exists but does not offer what couplet needs.
    #[error("the Vulkan adapter `{adapter}` is unsuitable: {reason}")]
    Unsuitable { adapter: String, reason: String },
    /// `request_device` failed.
    #[error("creating the Vulkan device failed: {0}")]
    Device(String),
    /// Waiting for the GPU failed (device lost, timeout).
    #[error("waiting for the GPU failed: {0}")]
    Poll(String),
    /// Mapping a staging buffer for readback failed.
    #[error("reading back GPU buffer `{buffer}` failed: {reason}")]
    Readback { buffer: String, reason: String },
    /// `COUPLET_GRID_REACH` is set to something other than a whole number in
    /// `GRID_REACH_RANGE`.
    #[error(
        "COUPLET_GRID_REACH = {value:?} is not a whole number from {} to {}: it sets the \
         neighbour grid's cells per support radius (unset: {} on a CPU adapter, {} on a GPU)",
        GRID_REACH_RANGE.start(), GRID_REACH_RANGE.end(),
        crate::neighbour_grid::GRID_REACH_CPU,
        crate::neighbour_grid::GRID_REACH_GPU
    )]
    BadGridReach { value: String },
    /// `COUPLET_TEAM_LANES` is set to something other than a divisor of the workgroup size.
    #[error(
        "COUPLET_TEAM_LANES = {value:?} is not a whole number that divides the workgroup size \
         ({}): it sets the lanes per item of the team passes (unset: {} on a CPU adapter, {} \
         on a GPU)",
        crate::shaders::WORKGROUP_SIZE,
        crate::neighbour_grid::TEAM_LANES_CPU,
        crate::neighbour_grid::TEAM_LANES_GPU
    )]
    BadTeamLanes { value: String },
    /// `COUPLET_DENSE_LANES` is set to something other than a divisor of the workgroup size.
    #[error(
        "COUPLET_DENSE_LANES = {value:?} is not a whole number that divides the workgroup size \
         ({}): it sets the lanes per fluid particle of the fused rates pass (unset: from the \
         particle count, at most the team lanes)",
        crate::shaders::WORKGROUP_SIZE
    )]
    BadDenseLanes { value: String },
    /// `COUPLET_STEPS_PER_SUBMIT` is set to something other than 1 to `MAX_STEPS_PER_SUBMIT`.
    #[error(
        "COUPLET_STEPS_PER_SUBMIT = {value:?} is not a whole number from 1 to {}: it sets the \
         fluid steps recorded into one GPU submission (unset: {})",
        MAX_STEPS_PER_SUBMIT,
        STEPS_PER_SUBMIT_DEFAULT
    )]
    BadStepsPerSubmit { value: String },
}

/// The environment variable that overrides the neighbour grid's reach R (cells per
/// support radius, `neighbour_grid::grid_reach_for` the adapter), for measuring R on a machine
/// without a rebuild. Results do not depend on R beyond round-off (the order of the
/// sums); speed does.
pub const GRID_REACH_ENV: &str = "COUPLET_GRID_REACH";

/// Fluid steps recorded into one command buffer and submitted together, at most, unless
/// [`STEPS_PER_SUBMIT_ENV`] sets another count: a window's submissions hold 1, 2, 4, …
/// steps up to it (the last may hold fewer). Each `queue.submit` has a fixed cost on
/// the CPU (wgpu's validation and resource tracking, the driver's fence) and the GPU can
/// start a submission only once the CPU has recorded all of it: one step a submission
/// pays the first every step, a whole window in one would make the GPU wait for the
/// window's recording, and the doubling lets the GPU start on the first step at once. A
/// chosen figure, not a measured one: on an H200 (2026-11-29) δ = L/25's cavity, 5 000
/// fluid particles, ran about 900 steps/s whatever its scheme, where its GPU stages
/// were a fraction of the 1.1 ms a step took, and recording a step takes 0.1–0.3 ms
/// (`couplet bench` prints the recording and the submission apart). On lavapipe the
/// submit runs the work, and a run is the same to the bit at any count.
pub const STEPS_PER_SUBMIT_DEFAULT: u32 = 8;

/// The most steps one submission may hold (the grains' τ slots, one per step).
pub const MAX_STEPS_PER_SUBMIT: u32 = 64;

/// The environment variable that sets the steps per submission (1 to
/// [`MAX_STEPS_PER_SUBMIT`]), for measuring it on a GPU without a rebuild.
pub const STEPS_PER_SUBMIT_ENV: &str = "COUPLET_STEPS_PER_SUBMIT";

/// The device and queue every fluid kernel runs on.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// `TIMESTAMP_QUERY` is enabled: compute passes can carry timestamp writes
    /// (see `timing::StageTimer`). `TIMESTAMP_QUERY_INSIDE_ENCODERS`/`_PASSES` are
    /// enabled as well whenever the adapter offers them.
    pub timestamps: bool,
    /// The neighbour grid's reach R set by [`GRID_REACH_ENV`], if it is set: every grid
    /// takes it in place of the adapter's (`neighbour_grid::grid_reach_for`). Public so
    /// that a test can build grids at each R on the one test device (`shared_test_gpu`
    /// restores it).
    pub grid_reach_override: Option<u32>,
    /// The reach [`GRID_REACH_ENV`] set, if it is set.
    grid_reach_env: Option<u32>,
    /// Lanes per item of the team passes (`neighbour_grid::team_lanes_for`), which every
    /// solver created on this device compiles and dispatches with: [`TEAM_LANES_ENV`]'s if
    /// set, else the adapter's ([`Gpu::adapter_team_lanes`]). Public so that a parity
    /// test can run a pass at each count on the one test device (`shared_test_gpu`
    /// restores it).
    pub team_lanes: u32,
    /// The lanes [`TEAM_LANES_ENV`] set, if it is set.
    team_lanes_override: Option<u32>,
    /// The lanes per particle [`DENSE_LANES_ENV`] set for the dense team passes, if it
    /// is set.
    dense_lanes_override: Option<u32>,
    /// Fluid steps a submission holds: [`STEPS_PER_SUBMIT_ENV`]'s if set, else
    /// [`STEPS_PER_SUBMIT_DEFAULT`]. Public so that a test can compare counts on the one
    /// test device (`shared_test_gpu` restores it).
    pub steps_per_submit: u32,
    steps_per_submit_override: Option<u32>,
    /// The most bytes one storage binding may hold, which the solver checks every buffer
    /// against before binding it (wgpu would panic): the device's limit, 2³¹ − 1 at
    /// most under wgpu. Public so that a test can lower it to exercise those checks at a
    /// small size (`shared_test_gpu` restores it).
    pub storage_binding_limit: u64,
}

/// The whole number the environment variable `name` sets, if it is set: `Err` with what
/// it holds when that is not a whole number `valid` accepts.
fn env_knob(name: &str, valid: impl Fn(u32) -> bool) -> Result<Option<u32>, String> {
    match std::env::var(name) {
        Err(_) => Ok(None),
        Ok(value) => match value.trim().parse::<u32>() {
            Ok(v) if valid(v) => Ok(Some(v)),
            _ => Err(value),
        },
    }
}

/// Adapters ordered by how much we want them: a real GPU before a software one.
fn preference(device_type: wgpu::DeviceType) -> u32 {
    match device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

impl Gpu {
    /// Opens the preferred Vulkan adapter (discrete > integrated > virtual > other > CPU)
    /// with the adapter's own limits and the optional timestamp features it offers.
    pub fn new() -> Result<Gpu, GpuError> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<Gpu, GpuError> {
        let backends = wgpu::Backends::VULKAN;
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        let mut adapters = instance.enumerate_adapters(backends).await;
        adapters.sort_by_key(|a| preference(a.get_info().device_type));
        let Some(adapter) = adapters.into_iter().next() else {
            return Err(GpuError::NoAdapter {
                tried: format!("{backends:?}"),
            });
        };
        let adapter_info = adapter.get_info();
        let limits = adapter.limits();
        if limits.max_storage_buffers_per_shader_stage < MIN_STORAGE_BUFFERS_PER_STAGE {
            return Err(GpuError::Unsuitable {
                adapter: adapter_info.name.clone(),
                reason: format!(
                    "it offers {} storage buffers per shader stage, couplet needs at least {}",
                    limits.max_storage_buffers_per_shader_stage, MIN_STORAGE_BUFFERS_PER_STAGE
                ),
            });
        }
        let offered = adapter.features();
        let optional = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        let required_features = offered & optional;
        let timestamps = required_features.contains(wgpu::Features::TIMESTAMP_QUERY);
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("couplet-fluid"),
                required_features,
                required_limits: limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let grid_reach_override = env_knob(GRID_REACH_ENV, |r| GRID_REACH_RANGE.contains(&r))
            .map_err(|value| GpuError::BadGridReach { value })?;
        let team_lanes_override = env_knob(TEAM_LANES_ENV, team_lanes_valid)
            .map_err(|value| GpuError::BadTeamLanes { value })?;
        let team_lanes =
            team_lanes_override.unwrap_or_else(|| team_lanes_for(adapter_info.device_type));
        let dense_lanes_override = env_knob(DENSE_LANES_ENV, team_lanes_valid)
            .map_err(|value| GpuError::BadDenseLanes { value })?;
        let steps_per_submit_override = env_knob(STEPS_PER_SUBMIT_ENV, |k| {
            (1..=MAX_STEPS_PER_SUBMIT).contains(&k)
        })
        .map_err(|value| GpuError::BadStepsPerSubmit { value })?;
        let storage_binding_limit = device.limits().max_storage_buffer_binding_size;
        Ok(Gpu {
            device,
            queue,
            adapter_info,
            timestamps,
            grid_reach_override,
            grid_reach_env: grid_reach_override,
            team_lanes,
            team_lanes_override,
            dense_lanes_override,
            steps_per_submit: steps_per_submit_override.unwrap_or(STEPS_PER_SUBMIT_DEFAULT),
            steps_per_submit_override,
            storage_binding_limit,
        })
    }

    /// The neighbour grid's reach R: [`GRID_REACH_ENV`]'s if set, else
    /// `neighbour_grid::grid_reach_for` the adapter type (2 on lavapipe, 3 on a GPU).
    pub fn grid_reach(&self) -> u32 {
        self.grid_reach_override
            .unwrap_or_else(|| grid_reach_for(self.adapter_info.device_type))
    }

    /// The team passes' lanes per item this device starts with: [`TEAM_LANES_ENV`]'s if
    /// set, else `neighbour_grid::team_lanes_for` its adapter type.
    pub fn adapter_team_lanes(&self) -> u32 {
        self.team_lanes_override
            .unwrap_or_else(|| team_lanes_for(self.adapter_info.device_type))
    }

    /// Lanes per fluid particle of the dense team passes of a solver of `n` particles:
    /// [`DENSE_LANES_ENV`]'s if set, else `neighbour_grid::dense_team_lanes` at most
    /// [`Gpu::team_lanes`].
    pub fn dense_lanes(&self, n: usize) -> u32 {
        self.dense_lanes_override
            .unwrap_or_else(|| dense_team_lanes(n, self.team_lanes))
    }

    /// Bytes of memory the driver holds for this device's live buffers: wgpu-hal's count
    /// of each buffer's allocation, alignment included (wgpu's `counters` feature). It
    /// counts every buffer, the mapped read-back ones (host memory on a discrete GPU)
    /// too. It waits for the device first, so that buffers dropped before are freed.
    pub fn buffer_memory(&self) -> Result<u64, GpuError> {
        self.wait()?;
        let bytes = self.device.get_internal_counters().hal.buffer_memory.read();
        Ok(u64::try_from(bytes).unwrap_or(0))
    }

    /// One line for logs and `couplet plan`: name, driver, backend, timestamps, the team
    /// passes' lanes, the grid reach (and the dense passes' lanes when [`DENSE_LANES_ENV`]
    /// sets them).
    pub fn describe(&self) -> String {
        let i = &self.adapter_info;
        format!(
            "{} ({:?}, driver {} {}, backend {:?}, timestamps {}, team lanes {}{}{}, grid reach {}{}{})",
            i.name,
            i.device_type,
            i.driver,
            i.driver_info,
            i.backend,
            if self.timestamps { "yes" } else { "no" },
            self.team_lanes,
            match self.team_lanes_override {
                Some(_) => format!(" from {TEAM_LANES_ENV}"),
                None => String::new(),
            },
            match self.dense_lanes_override {
                Some(l) => format!(", dense lanes {l} from {DENSE_LANES_ENV}"),
                None => String::new(),
            },
            self.grid_reach(),
            match self.grid_reach_override {
                Some(_) => format!(" from {GRID_REACH_ENV}"),
                None => String::new(),
            },
            match self.steps_per_submit_override {
                Some(k) => format!(", {k} steps a submission from {STEPS_PER_SUBMIT_ENV}"),
                None => String::new(),
            }
        )
    }

    /// Blocks until all submitted work has finished.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Poll(e.to_string()))
    }

    /// Copies `len` elements of `T` starting at element `first` of `buffer` (which needs
    /// `COPY_SRC`) to the CPU. Submits and waits: for tests, checks and output, never
    /// inside a step.
    pub fn read_buffer<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        first: u64,
        len: u64,
    ) -> Result<Vec<T>, GpuError> {
        let elem = std::mem::size_of::<T>() as u64;
        let [bytes] = self.read_buffers([(buffer, first * elem, len * elem)])?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Copies each `(buffer, offset, bytes)` range (the buffers need `COPY_SRC`; offsets
    /// multiples of 4) to the CPU with one submission and one wait, as
    /// [`Gpu::read_buffer`] does for one. Each wait is a round trip to the GPU (the device
    /// drained, a staging buffer mapped), so a check that needs several buffers reads
    /// them together.
    pub fn read_buffers<const N: usize>(
        &self,
        parts: [(&wgpu::Buffer, u64, u64); N],
    ) -> Result<[Vec<u8>; N], GpuError> {
        // Copies must be multiples of 4 bytes (wgpu::COPY_BUFFER_ALIGNMENT), and each part
        // starts its own 4-byte word of the staging buffer.
        let align = |b: u64| b.div_ceil(wgpu::COPY_BUFFER_ALIGNMENT) * wgpu::COPY_BUFFER_ALIGNMENT;
        let mut at = [0u64; N];
        let mut total = 0;
        for (k, &(_, _, bytes)) in parts.iter().enumerate() {
            at[k] = total;
            total += align(bytes);
        }
        let names = || {
            (parts.iter())
                .map(|p| format!("{:?}", p.0))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if total == 0 {
            return Ok(std::array::from_fn(|_| Vec::new()));
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback staging"),
            size: total,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("readback"),
            });
        for (k, &(buffer, offset, bytes)) in parts.iter().enumerate() {
            if bytes > 0 {
                encoder.copy_buffer_to_buffer(buffer, offset, &staging, at[k], align(bytes));
            }
        }
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        let failed = |reason: String| GpuError::Readback {
            buffer: names(),
            reason,
        };
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(failed(e.to_string())),
            Err(e) => return Err(failed(e.to_string())),
        }
        let out = {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| failed(e.to_string()))?;
            std::array::from_fn(|k| view[at[k] as usize..(at[k] + parts[k].2) as usize].to_vec())
        };
        staging.unmap();
        Ok(out)
    }
}

static TEST_GPU: OnceLock<Result<Mutex<Gpu>, GpuError>> = OnceLock::new();

/// The one `Gpu` of a test process. Tests run on several threads but there is one
/// GPU (or one lavapipe): every GPU test holds this lock for its whole body, which
/// serialises them and spares each the cost of opening a device. A test that
/// panicked while holding the lock does not poison the others. Each lock restores the
/// device's own team lanes ([`Gpu::adapter_team_lanes`]), grid reach, steps a submission
/// and storage binding limit, so a test that sets [`Gpu::team_lanes`],
/// [`Gpu::grid_reach_override`] or [`Gpu::storage_binding_limit`] changes no other test.
pub fn shared_test_gpu() -> Result<MutexGuard<'static, Gpu>, GpuError> {
    match TEST_GPU.get_or_init(|| Gpu::new().map(Mutex::new)) {
        Ok(m) => {
            let mut gpu = m.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            gpu.team_lanes = gpu.adapter_team_lanes();
            gpu.grid_reach_override = gpu.grid_reach_env;
            gpu.steps_per_submit = gpu
                .steps_per_submit_override
                .unwrap_or(STEPS_PER_SUBMIT_DEFAULT);
            gpu.storage_binding_limit = gpu.device.limits().max_storage_buffer_binding_size;
            Ok(gpu)
        }
        Err(e) => Err(e.clone()),
    }
}
