//! The counts of the dynamic updates reach the CPU through a ring of
//! [`READBACK_SLOTS`](super::ring::READBACK_SLOTS)
//! staging buffers: each update copies its control block, and the previous update's, into a
//! free one, mapped when the frame is submitted; [`Svo::poll_dynamic`] picks up what the GPU
//! has finished without blocking, [`Svo::sync_dynamic`] waits for it. An update that ran out
//! of its reserve is reported here, naming what ran out.

use super::ring::{FAILED, FREE, MAPPED, WAITING};
use super::state::{SvoDynamic, PARAMS_LAST};
use super::{DynamicCounts, DynamicReserve};
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::svo::control::{SvoControl, BRICK_OVERFLOW, CONTROL_BYTES};
use crate::voxel::svo::Svo;
use crate::{Error, Result};
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How long a blocking update waits, once the GPU is idle, for its readback's callback to be
/// run by whichever thread collected it.
const CALLBACK_WAIT: Duration = Duration::from_secs(10);

impl SvoDynamic {
    /// Records the copy of update `update`'s control block, and of the previous update's, into
    /// a free readback slot, mapped when the frame is submitted; none when every slot is
    /// taken (a later update is read back instead).
    pub(super) fn queue_readback(
        &mut self,
        timer: &mut PassTimer,
        control: &wgpu::Buffer,
        update: u64,
        triangles: usize,
    ) {
        let params = &self.params;
        let Some(slot) = self
            .readbacks
            .iter_mut()
            .find(|r| r.state.load(Ordering::Acquire) == FREE)
        else {
            return;
        };
        slot.state.store(WAITING, Ordering::Release);
        slot.update = update;
        slot.triangles = triangles;
        let state = slot.state.clone();
        timer.untimed(|encoder| {
            encoder.copy_buffer_to_buffer(control, 0, &slot.buffer, 0, Some(CONTROL_BYTES));
            encoder.copy_buffer_to_buffer(
                params,
                PARAMS_LAST,
                &slot.buffer,
                CONTROL_BYTES,
                Some(CONTROL_BYTES),
            );
            encoder.map_buffer_on_submit(&slot.buffer, wgpu::MapMode::Read, .., move |r| {
                state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
        });
    }
}

impl Svo {
    /// Picks up, without blocking, the counts of the dynamic updates the GPU has finished
    /// since the last poll (`device.poll(PollType::Poll)`, then every mapped readback), and
    /// sets [`Svo::node_count`], [`Svo::brick_count`], [`Svo::fragment_count`] and
    /// [`Svo::dynamic_levels`] to the latest of them. Returns that update's counts, `None`
    /// when no new update has finished (or the octree has no dynamic part).
    ///
    /// Latency: an update's counts arrive once the frame it was recorded into has been
    /// submitted and has run; polled once per frame, that is typically one or two frames
    /// after it was recorded.
    ///
    /// Fails when one of the updates read back ran out of the reserve, naming the update and
    /// what ran out (the counts are applied all the same).
    pub fn poll_dynamic(&mut self, ctx: &GpuContext) -> Result<Option<DynamicCounts>> {
        if self.dynamic.is_none() {
            return Ok(None);
        }
        let _ = ctx.device.poll(wgpu::PollType::Poll);
        self.take_readbacks()
    }

    /// Waits until the GPU has finished all submitted work, then does what
    /// [`Svo::poll_dynamic`] does: afterwards the octree's counts are those of the latest
    /// dynamic update submitted. For tests and tools; a renderer polls instead.
    ///
    /// Where another thread polls the same device, it may be the one that sees the GPU finish,
    /// and the readback it collected is then handed over a moment after this wait returns;
    /// the next poll picks it up ([`SvoBuilder::update_dynamic`](crate::voxel::svo::SvoBuilder::update_dynamic)
    /// waits for its own update's).
    pub fn sync_dynamic(&mut self, ctx: &GpuContext) -> Result<Option<DynamicCounts>> {
        if self.dynamic.is_none() {
            return Ok(None);
        }
        ctx.wait_idle()?;
        self.take_readbacks()
    }

    /// [`Svo::sync_dynamic`] for an update known to be submitted: after the wait, also waits
    /// (at most [`CALLBACK_WAIT`]) for its readback's mapping callback. Another thread polling
    /// the same device may be the one that saw the frame finish; wgpu runs the callbacks it
    /// collected on that thread after its poll, so they can land a moment after this thread's
    /// wait has returned. Returns the counts of the latest update applied by either pickup.
    pub(super) fn sync_dynamic_update(
        &mut self,
        ctx: &GpuContext,
        update: u64,
    ) -> Result<Option<DynamicCounts>> {
        let first = self.sync_dynamic(ctx)?;
        let start = std::time::Instant::now();
        let pending = |svo: &Svo| {
            svo.dynamic.as_ref().is_some_and(|d| {
                d.readbacks
                    .iter()
                    .any(|r| r.update == update && r.state.load(Ordering::Acquire) == WAITING)
            })
        };
        if !pending(self) {
            return Ok(first);
        }
        while pending(self) && start.elapsed() < CALLBACK_WAIT {
            let _ = ctx.device.poll(wgpu::PollType::Poll);
            std::thread::yield_now();
        }
        Ok(self.take_readbacks()?.or(first))
    }

    /// Applies the counts of every readback the GPU has filled, in update order, and reports
    /// the first read-back failure or exhausted reserve.
    fn take_readbacks(&mut self) -> Result<Option<DynamicCounts>> {
        let depth = self.levels.len();
        let Some(dynamic) = self.dynamic.as_mut() else {
            return Ok(None);
        };
        let mut done = dynamic.finished_readbacks();
        done.sort_by_key(|d| d.update);
        let reserve = dynamic.reserve;
        let mut latest = None;
        let mut error = None;
        for readback in done {
            let (update, triangles) = (readback.update, readback.triangles);
            let (ctl, last) = match readback.blocks {
                Ok(blocks) => blocks,
                Err(e) => {
                    error.get_or_insert(Error::Gpu(format!(
                        "reading back the counts of dynamic update {update}: {e}"
                    )));
                    continue;
                }
            };
            let node_count = ctl.node_count.min(dynamic.node_capacity);
            let brick_count = ctl.brick_count.min(dynamic.brick_capacity);
            let last_needed = last.needed_ranges[depth - 1].end.min(reserve.needed);
            let counts = DynamicCounts {
                update,
                fragments: ctl.dynamic_fragments,
                nodes: node_count - self.static_nodes,
                bricks: brick_count - self.static_bricks,
                dirty: ctl.needed_count.min(reserve.needed) + last_needed,
            };
            if update > dynamic.applied {
                dynamic.applied = update;
                self.node_count = node_count;
                self.brick_count = brick_count;
                self.fragment_count = counts.fragments;
                self.dynamic_levels = ctl.dynamic_level_ranges(depth as u32);
                latest = Some(counts);
            }
            let exhausted = exhausted(&ctl, &reserve);
            if !exhausted.is_empty() && error.is_none() {
                error = Some(Error::InvalidArgument(format!(
                    "the octree's dynamic reserve is too small for the {triangles} dynamic \
                     triangles of update {update}: it ran out of {}; build it with a larger \
                     DynamicReserve",
                    exhausted.join(" and ")
                )));
            }
        }
        match error {
            Some(e) => Err(e),
            None => Ok(latest),
        }
    }
}

/// What an update whose control block is `ctl` ran out of, in words.
fn exhausted(ctl: &SvoControl, reserve: &DynamicReserve) -> Vec<String> {
    let mut exhausted = Vec::new();
    if ctl.dynamic_fragments > reserve.fragments {
        exhausted.push(format!(
            "fragments ({} reserved, {} needed)",
            reserve.fragments, ctl.dynamic_fragments
        ));
    }
    if ctl.node_overflow != 0 {
        exhausted.push(format!("nodes ({} reserved)", reserve.nodes));
    }
    match ctl.dynamic_overflow {
        0 => {}
        BRICK_OVERFLOW => exhausted.push(format!("bricks ({} reserved)", reserve.bricks)),
        _ => exhausted.push(format!(
            "occupied or needed nodes ({} / {} reserved; {} occupied, {} needed)",
            reserve.occupied, reserve.needed, ctl.occupied_count, ctl.needed_count
        )),
    }
    exhausted
}

/// One readback the GPU has filled: the update's control block and the previous update's.
struct FinishedReadback {
    update: u64,
    triangles: usize,
    blocks: std::result::Result<(SvoControl, SvoControl), String>,
}

impl SvoDynamic {
    /// The readbacks mapped (or failed) since the last call; their slots are free again.
    fn finished_readbacks(&mut self) -> Vec<FinishedReadback> {
        let mut done = Vec::new();
        for slot in &mut self.readbacks {
            let blocks = match slot.state.load(Ordering::Acquire) {
                MAPPED => {
                    let blocks = slot
                        .buffer
                        .get_mapped_range(..)
                        .map(|bytes| {
                            let (ctl, last) = bytes.split_at(CONTROL_BYTES as usize);
                            (SvoControl::from_bytes(ctl), SvoControl::from_bytes(last))
                        })
                        .map_err(|e| e.to_string());
                    slot.buffer.unmap();
                    blocks
                }
                FAILED => Err("mapping the readback failed".to_string()),
                _ => continue,
            };
            slot.state.store(FREE, Ordering::Release);
            done.push(FinishedReadback {
                update: slot.update,
                triangles: slot.triangles,
                blocks,
            });
        }
        done
    }
}
