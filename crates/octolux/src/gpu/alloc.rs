//! Allocation helpers: buffers and image targets recorded in the memory ledger under an owner.

use super::pass::SLOT;
use super::GpuContext;
use crate::Result;

/// A storage buffer of `bytes` (at least 16) recorded in the ledger; copyable both ways.
pub fn storage(ctx: &GpuContext, owner: &str, label: &str, bytes: u64) -> wgpu::Buffer {
    ctx.create_buffer(
        owner,
        &wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        },
    )
}

/// A read-only parameter buffer of `slots` [`SLOT`]-byte slots recorded in the ledger, for
/// parameters that differ between dispatches of one pipeline (one slot per cascade or level).
/// These are storage, not uniform, buffers: Mesa's lavapipe specialises a shader on the values
/// of small uniform blocks that decide branches, compiling a new variant whenever they change
/// between dispatches and keeping every variant, which grew memory by every frame.
pub fn param_slots(ctx: &GpuContext, owner: &str, label: &str, slots: u64) -> wgpu::Buffer {
    ctx.create_buffer(
        owner,
        &wgpu::BufferDescriptor {
            label: Some(label),
            size: slots.max(1) * SLOT,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        },
    )
}

/// A uniform buffer of `slots` [`SLOT`]-byte slots recorded in the ledger.
pub fn uniform(ctx: &GpuContext, owner: &str, label: &str, slots: u64) -> wgpu::Buffer {
    ctx.create_buffer(
        owner,
        &wgpu::BufferDescriptor {
            label: Some(label),
            size: slots.max(1) * SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        },
    )
}

/// A `width` x `height` 2-D image of `format` recorded in the ledger, with its default view;
/// always copyable to the CPU (tests and readback).
pub fn image_target(
    ctx: &GpuContext,
    owner: &str,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> (wgpu::Texture, wgpu::TextureView) {
    let texture = ctx.create_texture(
        owner,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: usage | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        },
    );
    let view = texture.create_view(&Default::default());
    (texture, view)
}

/// A [`storage`] buffer, or a clear error (ending in `remedy`) where one binding of `bytes`
/// exceeds what the adapter allows.
pub fn checked_storage(
    ctx: &GpuContext,
    owner: &str,
    label: &str,
    bytes: u64,
    remedy: &str,
) -> Result<wgpu::Buffer> {
    ctx.check_storage_binding(&format!("{owner}: its {label}"), bytes, remedy)?;
    Ok(storage(ctx, owner, label, bytes))
}
