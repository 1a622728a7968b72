//! Per-pass timing. With `TIMESTAMP_QUERY` every pass writes GPU timestamps at its start and
//! end; without it each pass is submitted on its own and timed on the CPU around submit + wait,
//! which includes encoding and driver overhead and is labelled as such.

use super::GpuContext;
use crate::{Error, Result};
use std::sync::{Arc, Mutex};
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

/// The passes of `timings` as lines `name: ms`, slowest first (for profiling output).
pub fn slowest_first(timings: &[PassTiming]) -> String {
    let mut sorted: Vec<&PassTiming> = timings.iter().collect();
    sorted.sort_by(|a, b| b.ms.total_cmp(&a.ms));
    sorted
        .iter()
        .map(|t| format!("  {:>8.3} ms  {}\n", t.ms, t.name))
        .collect()
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

/// Timestamps of a frame on their way back to the CPU (see [`PassTimer::finish_frame_pipelined`]).
struct InFlight {
    staging: wgpu::Buffer,
    names: Vec<String>,
    mapped: Arc<Mutex<Option<std::result::Result<(), wgpu::BufferAsyncError>>>>,
}

/// Environment variable that makes multi-step passes time each step (see
/// [`PassTimer::profile_steps`]).
pub const PROFILE_STEPS_ENV: &str = "OCTOLUX_PROFILE_STEPS";

/// Frames whose timestamps may be in flight at once; a fourth frame waits for the first.
const FRAMES_IN_FLIGHT: usize = 3;

/// Records named passes into command encoders and measures them.
pub struct PassTimer {
    ctx: GpuContext,
    queries: Option<Queries>,
    encoder: Option<wgpu::CommandEncoder>,
    names: Vec<String>,
    cpu: Vec<PassTiming>,
    in_flight: std::collections::VecDeque<InFlight>,
    spare: Vec<wgpu::Buffer>,
    submissions: u64,
    /// Inside [`PassTimer::scoped`]: the technique whose passes are being recorded.
    scope: Option<String>,
    /// Inside [`PassTimer::record_into`]: `encoder` is the caller's, which only the caller
    /// submits.
    external: bool,
}

impl PassTimer {
    /// Most passes per frame that get GPU timestamps; later ones are timed as part of nothing.
    pub const MAX_PASSES: u32 = 128;

    /// The context the passes are recorded on (its work counters, where it has them).
    pub(crate) fn context(&self) -> &GpuContext {
        &self.ctx
    }

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
            in_flight: Default::default(),
            spare: Vec::new(),
            submissions: next_submission(),
            scope: None,
            external: false,
        }
    }

    /// Records the passes of `record` into the caller's `encoder` instead of the timer's own:
    /// nothing is submitted, the caller does that. With GPU timestamps the frame's queries are
    /// resolved into the same encoder and read back once the caller has submitted it (their
    /// times come from [`PassTimer::take_timings`], a frame or two later); without them the
    /// passes are recorded untimed. Work the timer recorded earlier is submitted first.
    pub fn record_into<R>(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        record: impl FnOnce(&mut PassTimer) -> R,
    ) -> R {
        self.begin_external(encoder);
        let result = record(self);
        self.end_external(encoder);
        result
    }

    /// Starts recording into the caller's `encoder` (it is swapped for an empty placeholder
    /// until [`PassTimer::end_external`], which must follow with the same encoder).
    pub fn begin_external(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.flush();
        let placeholder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("octolux placeholder"),
            });
        self.encoder = Some(std::mem::replace(encoder, placeholder));
        self.external = true;
        // The caller's submission is the next one: writes queued now land with it.
        self.submissions = next_submission();
    }

    /// Ends [`PassTimer::begin_external`]: resolves this frame's timestamps into the caller's
    /// encoder and gives it back.
    pub fn end_external(&mut self, encoder: &mut wgpu::CommandEncoder) {
        if !self.external {
            return;
        }
        let names = std::mem::take(&mut self.names);
        if let (Some(q), Some(own), false) = (&self.queries, &mut self.encoder, names.is_empty()) {
            let bytes = names.len() as u64 * 16;
            let staging = self
                .spare
                .pop()
                .unwrap_or_else(|| staging_buffer(&self.ctx, q));
            own.resolve_query_set(&q.set, 0..names.len() as u32 * 2, &q.resolve, 0);
            own.copy_buffer_to_buffer(&q.resolve, 0, &staging, 0, bytes);
            let mapped: Arc<Mutex<_>> = Arc::default();
            let sink = mapped.clone();
            own.map_buffer_on_submit(&staging, wgpu::MapMode::Read, ..bytes, move |r| {
                *sink.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
            });
            self.in_flight.push_back(InFlight {
                staging,
                names,
                mapped,
            });
        }
        self.external = false;
        if let Some(caller) = self.encoder.take() {
            // The placeholder goes back unused.
            drop(std::mem::replace(encoder, caller));
        }
    }

    /// The pass times of the most recent frame recorded by [`PassTimer::record_into`] whose
    /// timestamps have come back since the last call (None while none has, and always without
    /// GPU timestamps). Does not block.
    pub fn take_timings(&mut self) -> Result<Option<Vec<PassTiming>>> {
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        self.collect_mapped()
    }

    /// The submission the commands recorded now go in: a number no other submission of any
    /// timer in this process has. Data written with `Queue::write_buffer` lands at the next
    /// submission, so a pass that reuses a buffer it wrote can tell from this whether its
    /// earlier write is still pending.
    pub fn submissions(&self) -> u64 {
        self.submissions
    }

    /// Whether passes made of several dispatches should time each dispatch as a pass of its
    /// own (`OCTOLUX_PROFILE_STEPS=1`): for finding the expensive step of a multi-step pass
    /// such as the octree build. Off by default, because each extra pass boundary costs a
    /// little GPU time and the per-frame pass list gets long.
    pub fn profile_steps(&self) -> bool {
        static STEPS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
        *STEPS.get_or_init(|| std::env::var(PROFILE_STEPS_ENV).is_ok_and(|v| v == "1"))
    }

    /// How this timer measures.
    pub fn source(&self) -> TimingSource {
        if self.queries.is_some() {
            TimingSource::GpuTimestamps
        } else {
            TimingSource::CpuSubmitWait
        }
    }

    /// Runs `record` with every pass it records named `<scope> <pass>` (unless the pass's name
    /// already starts with `scope`): the renderer scopes a technique's update by the
    /// technique's name, so that shared machinery (the cone tracer, the octree build, the
    /// probe engine) shows under the technique that ran it.
    pub fn scoped<R>(&mut self, scope: &str, record: impl FnOnce(&mut PassTimer) -> R) -> R {
        let outer = self.scope.replace(scope.to_string());
        let result = record(self);
        self.scope = outer;
        result
    }

    /// Records one named pass: `record` gets the encoder and the timestamp slots for its pass
    /// descriptor(s).
    pub fn pass<R>(
        &mut self,
        name: &str,
        record: impl FnOnce(&mut wgpu::CommandEncoder, PassStamps<'_>) -> R,
    ) -> R {
        let name = &scoped_name(self.scope.as_deref(), name);
        // A caller's frame whose earlier timestamps never came back (not submitted) goes untimed.
        let stamped = !self.external || self.in_flight.len() < FRAMES_IN_FLIGHT;
        match (&self.queries, self.external) {
            (Some(q), _) if stamped => {
                let index = self.names.len() as u32;
                let encoder = self.encoder.get_or_insert_with(|| {
                    self.ctx
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("frame"),
                        })
                });
                let stamps = if index * 2 + 1 < q.capacity {
                    self.names.push(name.clone());
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
            (_, true) => {
                let encoder = self.encoder.get_or_insert_with(|| {
                    self.ctx
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("frame"),
                        })
                });
                record(
                    encoder,
                    PassStamps {
                        set: None,
                        begin: 0,
                    },
                )
            }
            _ => {
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
                self.submissions = next_submission();
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
            self.submissions = next_submission();
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
            self.submissions = next_submission();
        }
        let bytes = super::read_buffer(&self.ctx, &q.resolve, 0, count as u64 * 8)?;
        let ticks: &[u64] = bytemuck::try_cast_slice(&bytes)
            .map_err(|e| Error::Gpu(format!("timestamp readback: {e}")))?;
        Ok(self.timings(names, ticks))
    }

    /// Pass times from the begin and end timestamps of each named pass.
    fn timings(&self, names: Vec<String>, ticks: &[u64]) -> Vec<PassTiming> {
        let period_ns = self.ctx.queue.get_timestamp_period() as f64;
        names
            .into_iter()
            .enumerate()
            .map(|(i, name)| PassTiming {
                name,
                ms: ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * period_ns * 1e-6,
                source: TimingSource::GpuTimestamps,
            })
            .collect()
    }

    /// Submits everything recorded without waiting for the GPU, and returns the pass times of
    /// the most recent earlier frame whose timestamps have come back (None while none has):
    /// a real-time loop keeps recording frames while the GPU works. At most three frames are
    /// in flight; a fourth waits for the oldest. Without GPU timestamps every pass was already
    /// waited for (CPU submit + wait), so this frame's times are returned.
    pub fn finish_frame_pipelined(&mut self) -> Result<Option<Vec<PassTiming>>> {
        if self.queries.is_none() {
            return self.finish_frame().map(Some);
        }
        let names = std::mem::take(&mut self.names);
        if names.is_empty() {
            self.flush();
        } else {
            if self.in_flight.len() >= FRAMES_IN_FLIGHT {
                self.ctx.wait_idle()?;
            }
            let Some(q) = &self.queries else {
                return Ok(None);
            };
            let bytes = names.len() as u64 * 16;
            let staging = self
                .spare
                .pop()
                .unwrap_or_else(|| staging_buffer(&self.ctx, q));
            if let Some(mut encoder) = self.encoder.take() {
                encoder.resolve_query_set(&q.set, 0..names.len() as u32 * 2, &q.resolve, 0);
                encoder.copy_buffer_to_buffer(&q.resolve, 0, &staging, 0, bytes);
                self.ctx.queue.submit([encoder.finish()]);
                self.submissions = next_submission();
            }
            let mapped: Arc<Mutex<_>> = Arc::default();
            let sink = mapped.clone();
            staging.map_async(wgpu::MapMode::Read, ..bytes, move |r| {
                *sink.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
            });
            self.in_flight.push_back(InFlight {
                staging,
                names,
                mapped,
            });
        }
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        self.ctx.check_errors()?;
        self.collect_mapped()
    }

    /// Takes every in-flight frame whose timestamps are mapped, oldest first, and returns the
    /// times of the newest of them.
    fn collect_mapped(&mut self) -> Result<Option<Vec<PassTiming>>> {
        let mut latest = None;
        while let Some(front) = self.in_flight.front() {
            let state = front
                .mapped
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .take();
            let Some(state) = state else { break };
            let Some(frame) = self.in_flight.pop_front() else {
                break;
            };
            state.map_err(|e| Error::Gpu(format!("timestamp readback: {e}")))?;
            let bytes = frame.names.len() as u64 * 16;
            let ticks: Vec<u64> = {
                let view = frame
                    .staging
                    .get_mapped_range(..bytes)
                    .map_err(|e| Error::Gpu(format!("timestamp readback: {e}")))?;
                bytemuck::pod_collect_to_vec(&view)
            };
            frame.staging.unmap();
            self.spare.push(frame.staging);
            latest = Some(self.timings(frame.names, &ticks));
        }
        Ok(latest)
    }
}

/// A buffer the timestamps of one frame are copied to and mapped from.
fn staging_buffer(ctx: &GpuContext, q: &Queries) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("timestamp readback"),
        size: q.capacity as u64 * 8,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The name a pass called `name` is recorded under inside `scope`: `<scope> <name>`, unless the
/// name already starts with the scope's word.
pub fn scoped_name(scope: Option<&str>, name: &str) -> String {
    match scope {
        Some(scope)
            if name != scope
                && !name
                    .strip_prefix(scope)
                    .is_some_and(|rest| rest.starts_with(' ')) =>
        {
            format!("{scope} {name}")
        }
        _ => name.to_string(),
    }
}

/// A submission number no timer has used yet.
fn next_submission() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

#[cfg(test)]
mod scope_tests {
    use super::scoped_name;

    #[test]
    fn passes_are_named_after_the_technique_that_runs_them() {
        assert_eq!(scoped_name(None, "svo inject"), "svo inject");
        assert_eq!(
            scoped_name(Some("vct-svo"), "svo inject"),
            "vct-svo svo inject"
        );
        assert_eq!(scoped_name(Some("vct-svo"), "trace"), "vct-svo trace");
        assert_eq!(scoped_name(Some("lpv"), "lpv propagate"), "lpv propagate");
        assert_eq!(scoped_name(Some("lpv"), "lpvx"), "lpv lpvx");
        assert_eq!(scoped_name(Some("vpl"), "vpl"), "vpl");
    }
}
