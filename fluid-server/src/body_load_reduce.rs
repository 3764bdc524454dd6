//! Per-body sum of the marker loads: one workgroup per body over its contiguous marker
//! range, a strided partial sum per thread and a tree reduction across the workgroup
//! (no serial f32 accumulation over the whole range). Reads back only
//! 2 × n_bodies vec4 per window. WGSL: `shaders/body_load_reduce.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::sph_kernel::{Access, BODIES, PARAMS, SphKernel, body_binding as bb};

pub const BODY_LOAD_REDUCE_WGSL: &str = include_str!("../shaders/body_load_reduce.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: reduce_body_loads",
        &[&consts, STEP_PARAMS_WGSL, BODY_LOAD_REDUCE_WGSL],
        "reduce_body_loads",
        &[
            (
                BODIES,
                &[
                    (bb::MARKER_LOAD, Access::Read),
                    (bb::MARKER_LOAD_C, Access::Read),
                    (bb::LOAD_RANGES, Access::Read),
                    (bb::BODY_LOADS, Access::ReadWrite),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        None,
    )
}

/// CPU twin: pairwise (recursive halving) sum of `values`, in f64.
pub fn pairwise_sum(values: &[[f64; 3]]) -> [f64; 3] {
    match values.len() {
        0 => [0.0; 3],
        1 => values[0],
        n => {
            let (a, b) = values.split_at(n / 2);
            let (x, y) = (pairwise_sum(a), pairwise_sum(b));
            [x[0] + y[0], x[1] + y[1], x[2] + y[2]]
        }
    }
}
