//! GPU stage timing: seconds per labelled compute pass, summed over many steps.
//!
//! Every stage of a step is one labelled compute pass begun with [`begin_pass`]:
//!
//! ```ignore
//! let mut pass = timing::begin_pass(timer.as_deref_mut(), gpu, &mut encoder, "sph: density");
//! pass.set_pipeline(…); …
//! drop(pass);
//! // end of the step, before submitting:
//! if let Some(t) = timer.as_deref_mut() { t.finish(gpu, &mut encoder); }
//! gpu.queue.submit([encoder.finish()]);
//! if let Some(t) = timer.as_deref_mut() { let totals = t.collect(gpu)?; }
//! ```
//!
//! With `timer = None` (normal runs) `begin_pass` is a plain labelled pass: no query,
//! no submit, nothing to pay. With a timer (bench mode):
//! - **timestamps** (`gpu.timestamps`): the pass carries begin/end timestamp writes
//!   into a query set; `finish` resolves them into a buffer, `collect` maps it (one
//!   wait per `collect`, so call it once per step or less often, up to `max_stages`
//!   passes between two calls);
//! - a stage made of several passes and copies is timed as one span:
//!   `timing::begin_span(timer.as_deref_mut(), gpu, &mut encoder, "grid: reorder")`, then
//!   untimed passes (`begin_pass(None, …)`) and copies, then `timing::end_span(…)`;
//! - **wall clock** (no timestamp queries): `begin_pass` first submits what the
//!   encoder holds and waits, charging the elapsed time to the previous stage, so every
//!   stage is submitted and waited for on its own. Commands recorded between two
//!   passes (copies, clears) are charged to the earlier pass.

use std::time::Instant;

use crate::gpu::{Gpu, GpuError};

/// How a [`StageTimer`] measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimingMode {
    /// GPU timestamp queries at the start and end of each pass.
    Timestamps,
    /// Host wall time around a submit + wait per pass.
    WallClock,
}

struct Timestamps {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Queries available (two per pass).
    capacity: u32,
    /// Labels of the passes timed since the last `collect`; pass k uses queries 2k, 2k+1.
    labels: Vec<String>,
    /// Passes whose queries `finish` has resolved.
    resolved: u32,
    /// Nanoseconds per timestamp tick (`Queue::get_timestamp_period`).
    period_ns: f64,
}

/// Accumulates seconds per stage label; see the module doc.
pub struct StageTimer {
    timestamps: Option<Timestamps>,
    /// Wall mode: the stage now running and when it was submitted.
    pending: Option<(String, Instant)>,
    /// Label, total seconds, number of passes; in first-seen order.
    totals: Vec<(String, f64, u64)>,
    /// Passes not timed because more than `max_stages` ran between two `collect`s.
    dropped: u64,
    /// Timestamps: the query pair of the span now open.
    open_span: Option<u32>,
}

impl StageTimer {
    /// A timer for up to `max_stages` passes between two [`StageTimer::collect`]s.
    pub fn new(gpu: &Gpu, max_stages: u32) -> StageTimer {
        let timestamps = (gpu.timestamps && max_stages > 0).then(|| {
            let count = (2 * max_stages).min(wgpu::QUERY_SET_MAX_QUERIES);
            let bytes = u64::from(count) * u64::from(wgpu::QUERY_SIZE);
            Timestamps {
                query_set: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("stage timer"),
                    ty: wgpu::QueryType::Timestamp,
                    count,
                }),
                resolve: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("stage timer resolve"),
                    size: bytes,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                readback: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("stage timer readback"),
                    size: bytes,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                capacity: count,
                labels: Vec::new(),
                resolved: 0,
                period_ns: f64::from(gpu.queue.get_timestamp_period()),
            }
        });
        StageTimer {
            timestamps,
            pending: None,
            totals: Vec::new(),
            dropped: 0,
            open_span: None,
        }
    }

    pub fn mode(&self) -> TimingMode {
        if self.timestamps.is_some() {
            TimingMode::Timestamps
        } else {
            TimingMode::WallClock
        }
    }

    /// Passes that ran untimed because the query set was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Begins a labelled compute pass timed by this timer (see the module doc).
    pub fn begin_pass<'e>(
        &mut self,
        gpu: &Gpu,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
    ) -> wgpu::ComputePass<'e> {
        match &mut self.timestamps {
            Some(ts) => {
                let k = ts.labels.len() as u32;
                if 2 * k + 2 > ts.capacity {
                    self.dropped += 1;
                    return plain_pass(encoder, label);
                }
                ts.labels.push(label.to_owned());
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(label),
                    timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                        query_set: &ts.query_set,
                        beginning_of_pass_write_index: Some(2 * k),
                        end_of_pass_write_index: Some(2 * k + 1),
                    }),
                })
            }
            None => {
                self.flush_wall(gpu, encoder);
                self.pending = Some((label.to_owned(), Instant::now()));
                plain_pass(encoder, label)
            }
        }
    }

    /// Starts a stage that is more than one compute pass, or includes copies: its
    /// time runs from here to [`StageTimer::end_span`]. Passes inside a span are
    /// begun untimed (plain `encoder.begin_compute_pass` or `begin_pass(None, …)`).
    /// Timestamps are written by empty compute passes, so only `TIMESTAMP_QUERY` is
    /// needed.
    pub fn begin_span(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, label: &str) {
        match &mut self.timestamps {
            Some(ts) => {
                let k = ts.labels.len() as u32;
                if 2 * k + 2 > ts.capacity {
                    self.dropped += 1;
                    self.open_span = None;
                    return;
                }
                ts.labels.push(label.to_owned());
                self.open_span = Some(k);
                mark(encoder, label, &ts.query_set, 2 * k);
            }
            None => {
                self.flush_wall(gpu, encoder);
                self.pending = Some((label.to_owned(), Instant::now()));
            }
        }
    }

    /// Ends the span begun by [`StageTimer::begin_span`].
    pub fn end_span(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        match &mut self.timestamps {
            Some(ts) => {
                if let Some(k) = self.open_span.take() {
                    mark(encoder, "span end", &ts.query_set, 2 * k + 1);
                }
            }
            None => self.flush_wall(gpu, encoder),
        }
    }

    /// Ends a step's timing; call on the step's encoder right before submitting it.
    /// Timestamps: resolves the queries into the readback buffer. Wall clock: submits,
    /// waits and charges the last stage.
    pub fn finish(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        match &mut self.timestamps {
            Some(ts) => {
                let n = 2 * ts.labels.len() as u32;
                if n == 0 {
                    return;
                }
                // Resolve from 0: the destination offset must be 256-byte aligned
                // (QUERY_RESOLVE_BUFFER_ALIGNMENT), and re-resolving is harmless.
                encoder.resolve_query_set(&ts.query_set, 0..n, &ts.resolve, 0);
                let bytes = u64::from(n) * u64::from(wgpu::QUERY_SIZE);
                encoder.copy_buffer_to_buffer(&ts.resolve, 0, &ts.readback, 0, bytes);
                ts.resolved = ts.labels.len() as u32;
            }
            None => self.flush_wall(gpu, encoder),
        }
    }

    fn flush_wall(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        let fresh = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("stage timer"),
            });
        let recorded = std::mem::replace(encoder, fresh);
        gpu.queue.submit([recorded.finish()]);
        // A failed wait leaves the stage uncharged; the next real readback reports it.
        let waited = gpu.wait().is_ok();
        if let Some((label, t0)) = self.pending.take()
            && waited
        {
            let s = t0.elapsed().as_secs_f64();
            self.add(&label, s);
        }
    }

    fn add(&mut self, label: &str, seconds: f64) {
        match self.totals.iter_mut().find(|(l, _, _)| l == label) {
            Some(t) => {
                t.1 += seconds;
                t.2 += 1;
            }
            None => self.totals.push((label.to_owned(), seconds, 1)),
        }
    }

    /// Reads the timestamps of the submitted passes (waits for the GPU), adds them
    /// to the totals and returns the totals so far: (label, seconds summed over all
    /// passes with that label), in first-seen order. Call after submitting the encoder
    /// that [`StageTimer::finish`] was called on.
    pub fn collect(&mut self, gpu: &Gpu) -> Result<Vec<(String, f64)>, GpuError> {
        if let Some(ts) = &mut self.timestamps {
            let resolved = ts.resolved as usize;
            let mut samples = Vec::new();
            if resolved > 0 {
                let bytes = resolved as u64 * 2 * u64::from(wgpu::QUERY_SIZE);
                let (tx, rx) = std::sync::mpsc::channel();
                ts.readback
                    .map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
                        let _ = tx.send(r);
                    });
                gpu.wait()?;
                let readback_err = |reason: String| GpuError::Readback {
                    buffer: "stage timer readback".into(),
                    reason,
                };
                match rx.recv() {
                    Ok(Ok(())) => {}
                    Ok(Err(e)) => return Err(readback_err(e.to_string())),
                    Err(e) => return Err(readback_err(e.to_string())),
                }
                let ticks: Vec<u64> = {
                    let view = ts
                        .readback
                        .get_mapped_range(0..bytes)
                        .map_err(|e| readback_err(e.to_string()))?;
                    bytemuck::pod_collect_to_vec(&view[..])
                };
                ts.readback.unmap();
                for (k, label) in ts.labels.iter().take(resolved).enumerate() {
                    let dt = ticks[2 * k + 1].saturating_sub(ticks[2 * k]) as f64;
                    samples.push((label.clone(), dt * ts.period_ns * 1e-9));
                }
            }
            // Passes begun after `finish` were never resolved: their times are lost.
            self.dropped += (ts.labels.len() - resolved) as u64;
            ts.labels.clear();
            ts.resolved = 0;
            for (label, s) in samples {
                self.add(&label, s);
            }
        }
        Ok(self.totals())
    }

    /// The totals so far without reading anything back.
    pub fn totals(&self) -> Vec<(String, f64)> {
        self.totals
            .iter()
            .map(|(l, s, _)| (l.clone(), *s))
            .collect()
    }

    /// The totals with the number of passes behind each: (label, seconds, passes).
    pub fn totals_with_counts(&self) -> Vec<(String, f64, u64)> {
        self.totals.clone()
    }

    /// Forgets the totals (e.g. after warm-up steps).
    pub fn reset(&mut self) {
        self.totals.clear();
        self.dropped = 0;
    }
}

/// An empty compute pass whose only job is to write timestamp `index`.
fn mark(encoder: &mut wgpu::CommandEncoder, label: &str, query_set: &wgpu::QuerySet, index: u32) {
    let _ = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: Some(index),
            end_of_pass_write_index: None,
        }),
    });
}

fn plain_pass<'e>(encoder: &'e mut wgpu::CommandEncoder, label: &str) -> wgpu::ComputePass<'e> {
    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    })
}

/// [`StageTimer::begin_span`] when `timer` is `Some`; nothing otherwise.
pub fn begin_span(
    timer: Option<&mut StageTimer>,
    gpu: &Gpu,
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
) {
    if let Some(t) = timer {
        t.begin_span(gpu, encoder, label);
    }
}

/// [`StageTimer::end_span`] when `timer` is `Some`; nothing otherwise.
pub fn end_span(timer: Option<&mut StageTimer>, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
    if let Some(t) = timer {
        t.end_span(gpu, encoder);
    }
}

/// A labelled compute pass, timed when `timer` is `Some`. Pass
/// `timer.as_deref_mut()` to reuse an `Option<&mut StageTimer>` for several passes.
pub fn begin_pass<'e>(
    timer: Option<&mut StageTimer>,
    gpu: &Gpu,
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
) -> wgpu::ComputePass<'e> {
    match timer {
        Some(t) => t.begin_pass(gpu, encoder, label),
        None => plain_pass(encoder, label),
    }
}
