//! Per-pass timing. With `TIMESTAMP_QUERY` every pass writes GPU timestamps at its start and
//! end; without it each pass is submitted on its own and timed on the CPU around submit + wait,
//! which includes encoding and driver overhead and is labelled as such.

use super::GpuContext;
use crate::{Error, Result};
use std::time::Instant;

/// Where pass times come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum TimingSource {
    /// GPU timestamp queries around each pass.
    GpuTimestamps,
    /// CPU wall time around encoding, submitting and waiting for each pass on its own.
    CpuSubmitWait,
}

impl TimingSource {
    /// Short label for tables.
    pub fn label(self) -> &'static str {
        match self {
            TimingSource::GpuTimestamps => "GPU timestamps",
            TimingSource::CpuSubmitWait => "CPU submit+wait",
        }
    }
}

/// Time of one named pass in one frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassTiming {
    /// Pass name (also used as the ledger owner of its resources where it has any).
    pub name: String,
    /// Milliseconds.
    pub ms: f64,
    /// How it was measured.
    pub source: TimingSource,
}

/// Timestamp-write slots for the pass being recorded; hand them to the pass descriptor(s).
#[derive(Clone, Copy)]
pub struct PassStamps<'a> {
    set: Option<&'a wgpu::QuerySet>,
    begin: u32,
}

impl<'a> PassStamps<'a> {
    /// Timestamp writes for a compute pass that is the whole named pass.
    pub fn compute(&self) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
        self.compute_part(true, true)
    }

    /// Timestamp writes for a render pass that is the whole named pass.
    pub fn render(&self) -> Option<wgpu::RenderPassTimestampWrites<'a>> {
        self.render_part(true, true)
    }

    /// For a named pass made of several compute passes: the first writes the start, the last
    /// the end.
    pub fn compute_part(
        &self,
        first: bool,
        last: bool,
    ) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
        let set = self.set?;
        (first || last).then_some(wgpu::ComputePassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: first.then_some(self.begin),
            end_of_pass_write_index: last.then_some(self.begin + 1),
        })
    }

    /// For a named pass made of several render passes: the first writes the start, the last
    /// the end.
    pub fn render_part(
        &self,
        first: bool,
        last: bool,
    ) -> Option<wgpu::RenderPassTimestampWrites<'a>> {
        let set = self.set?;
        (first || last).then_some(wgpu::RenderPassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: first.then_some(self.begin),
            end_of_pass_write_index: last.then_some(self.begin + 1),
        })
    }
}

struct Queries {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    capacity: u32,
}

/// Records named passes into command encoders and measures them.
pub struct PassTimer {
    ctx: GpuContext,
    queries: Option<Queries>,
    encoder: Option<wgpu::CommandEncoder>,
    names: Vec<String>,
    cpu: Vec<PassTiming>,
}

impl PassTimer {
    /// Most passes per frame that get GPU timestamps; later ones are timed as part of nothing.
    pub const MAX_PASSES: u32 = 128;

    /// A timer using GPU timestamps when the context has them.
    pub fn new(ctx: &GpuContext) -> PassTimer {
        let queries = ctx.timestamps.then(|| {
            let capacity = Self::MAX_PASSES * 2;
            Queries {
                set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: capacity,
                }),
                resolve: ctx.create_buffer(
                    "timers",
                    &wgpu::BufferDescriptor {
                        label: Some("timestamp resolve"),
                        size: capacity as u64 * 8,
                        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    },
                ),
                capacity,
            }
        });
        PassTimer {
            ctx: ctx.clone(),
            queries,
            encoder: None,
            names: Vec::new(),
            cpu: Vec::new(),
        }
    }

    /// How this timer measures.
    pub fn source(&self) -> TimingSource {
        if self.queries.is_some() {
            TimingSource::GpuTimestamps
        } else {
            TimingSource::CpuSubmitWait
        }
    }

    /// Records one named pass: `record` gets the encoder and the timestamp slots for its pass
    /// descriptor(s).
    pub fn pass<R>(
        &mut self,
        name: &str,
        record: impl FnOnce(&mut wgpu::CommandEncoder, PassStamps<'_>) -> R,
    ) -> R {
        match &self.queries {
            Some(q) => {
                let index = self.names.len() as u32;
                let encoder = self.encoder.get_or_insert_with(|| {
                    self.ctx
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("frame"),
                        })
                });
                let stamps = if index * 2 + 1 < q.capacity {
                    self.names.push(name.to_string());
                    PassStamps {
                        set: Some(&q.set),
                        begin: index * 2,
                    }
                } else {
                    PassStamps {
                        set: None,
                        begin: 0,
                    }
                };
                record(encoder, stamps)
            }
            None => {
                // Anything recorded earlier goes first so this pass is timed on its own.
                self.flush();
                let start = Instant::now();
                let mut encoder = self
                    .ctx
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) });
                let result = record(
                    &mut encoder,
                    PassStamps {
                        set: None,
                        begin: 0,
                    },
                );
                self.ctx.queue.submit([encoder.finish()]);
                let _ = self.ctx.device.poll(wgpu::PollType::wait_indefinitely());
                self.cpu.push(PassTiming {
                    name: name.to_string(),
                    ms: start.elapsed().as_secs_f64() * 1e3,
                    source: TimingSource::CpuSubmitWait,
                });
                result
            }
        }
    }

    /// Records untimed work (uploads, copies) into the current frame's encoder.
    pub fn untimed(&mut self, record: impl FnOnce(&mut wgpu::CommandEncoder)) {
        let encoder = self.encoder.get_or_insert_with(|| {
            self.ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("frame"),
                })
        });
        record(encoder);
    }

    fn flush(&mut self) {
        if let Some(encoder) = self.encoder.take() {
            self.ctx.queue.submit([encoder.finish()]);
        }
    }

    /// Submits everything recorded, waits for it, and returns this frame's pass times in
    /// recording order.
    pub fn finish_frame(&mut self) -> Result<Vec<PassTiming>> {
        let names = std::mem::take(&mut self.names);
        let Some(q) = &self.queries else {
            self.flush();
            self.ctx.wait_idle()?;
            self.ctx.check_errors()?;
            return Ok(std::mem::take(&mut self.cpu));
        };
        if names.is_empty() {
            self.flush();
            self.ctx.wait_idle()?;
            self.ctx.check_errors()?;
            return Ok(Vec::new());
        }
        let count = names.len() as u32 * 2;
        if let Some(mut encoder) = self.encoder.take() {
            encoder.resolve_query_set(&q.set, 0..count, &q.resolve, 0);
            self.ctx.queue.submit([encoder.finish()]);
        }
        let bytes = super::read_buffer(&self.ctx, &q.resolve, 0, count as u64 * 8)?;
        let ticks: &[u64] = bytemuck::try_cast_slice(&bytes)
            .map_err(|e| Error::Gpu(format!("timestamp readback: {e}")))?;
        let period_ns = self.ctx.queue.get_timestamp_period() as f64;
        Ok(names
            .into_iter()
            .enumerate()
            .map(|(i, name)| PassTiming {
                name,
                ms: ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * period_ns * 1e-6,
                source: TimingSource::GpuTimestamps,
            })
            .collect())
    }
}
