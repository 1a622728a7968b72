//! GPU plumbing: device and adapter choice ([`GpuContext`]), per-pass timers ([`PassTimer`])
//! and the memory ledger ([`MemoryLedger`]) every GPU resource is counted in.

mod context;
mod ledger;
mod readback;
mod timer;

pub use context::{AdapterChoice, GpuContext, GpuOptions, ResourceCounts, Timestamps, ADAPTER_ENV};
pub use ledger::{LedgerEntry, MemoryLedger};
pub use readback::{read_buffer, read_texture};
pub use timer::{slowest_first, PassTimer, PassTiming, TimingSource, PROFILE_STEPS_ENV};

/// A compute-stage storage-buffer entry of a bind group layout at `binding`.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A bind group for group `index` of `pipeline` (whose layout is derived from its shader)
/// with exactly the given (binding, resource) entries.
pub(crate) fn bind_group_at(
    ctx: &GpuContext,
    label: Option<&str>,
    pipeline: &wgpu::ComputePipeline,
    index: u32,
    entries: &[(u32, wgpu::BindingResource)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: resource.clone(),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label,
        layout: &pipeline.get_bind_group_layout(index),
        entries: &entries,
    })
}
