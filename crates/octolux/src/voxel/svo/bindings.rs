//! What the octree's kernels bind: group 0 (the per-level parameter slots and
//! the buffers) and the table of kernels with the groups each binds beyond it. Shared by the
//! build, injection and the dynamic part.

use crate::gpu::{storage_entry, GpuContext};

/// Which bind groups beyond group 0 a kernel uses: group 1 (the dispatch arguments, which a
/// kernel dispatched indirectly must not bind) and group 2 (the dynamic part).
#[derive(Clone, Copy)]
pub(super) struct Groups {
    pub(super) args: bool,
    pub(super) dynamic: bool,
}

/// Kernels by entry point, with the groups they bind beyond group 0.
pub(super) type Pipelines =
    std::collections::HashMap<&'static str, (wgpu::ComputePipeline, Groups)>;

/// Group 0's layout of the octree kernels: the per-level parameter slots (read-only storage
/// with a dynamic offset, "Parameter blocks" in voxel/mod.rs), fragments and triangles
/// (read-only), and read-write storage buffers up to binding `last`.
pub(super) fn layout0_with(device: &wgpu::Device, label: &str, last: u32) -> wgpu::BindGroupLayout {
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: true,
            min_binding_size: wgpu::BufferSize::new(32),
        },
        count: None,
    }];
    entries.push(storage_entry(1, true));
    entries.push(storage_entry(2, true));
    entries.extend((3..=last).map(|b| storage_entry(b, false)));
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// Group 0 of the octree kernels over `layout`: `params` (per-level slots) and `buffers` at
/// bindings 1...
pub(super) fn group0_with(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let mut entries = vec![wgpu::BindGroupEntry {
        binding: 0,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: params,
            offset: 0,
            size: wgpu::BufferSize::new(32),
        }),
    }];
    for (i, b) in buffers.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: i as u32 + 1,
            resource: b.as_entire_binding(),
        });
    }
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("svo"),
        layout,
        entries: &entries,
    })
}
