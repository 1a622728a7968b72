//! The ring of staging buffers the dynamic updates' counts reach the CPU through: each slot's
//! buffer and its mapping state (see `readback.rs` for how updates use them).

use crate::gpu::GpuContext;
use crate::voxel::svo::control::CONTROL_BYTES;
use crate::voxel::svo::OWNER;
use std::sync::atomic::AtomicU8;
use std::sync::Arc;

/// Staging buffers of the counts readback: an update whose frame finds none free (the GPU is
/// more than this many updates behind) is not read back; a later one is.
pub const READBACK_SLOTS: usize = 4;

/// Mapping state of a readback slot.
pub(super) const FREE: u8 = 0;
pub(super) const WAITING: u8 = 1;
pub(super) const MAPPED: u8 = 2;
pub(super) const FAILED: u8 = 3;

/// One staging buffer of the counts readback: the control block after the update, then the
/// one it started from.
pub(super) struct Readback {
    pub(super) buffer: wgpu::Buffer,
    pub(super) state: Arc<AtomicU8>,
    /// The update it holds, and that update's triangle count (for the error message).
    pub(super) update: u64,
    pub(super) triangles: usize,
}

impl Readback {
    /// Staging buffer `k` of the ring, free.
    pub(super) fn new(ctx: &GpuContext, k: usize) -> Readback {
        Readback {
            buffer: ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some(&format!("dynamic counts readback {k}")),
                    size: 2 * CONTROL_BYTES,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            ),
            state: Arc::new(AtomicU8::new(FREE)),
            update: 0,
            triangles: 0,
        }
    }
}
