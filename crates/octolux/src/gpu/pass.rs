//! Bind-group and dispatch helpers every compute pass uses: a bind group from (binding,
//! resource) pairs, slices of slotted parameter buffers, and named, timed dispatches over a
//! 1-D count or a 2-D image.

use super::{GpuContext, PassTimer};

/// Bytes per parameter slot: dynamic and sliced uniform offsets must be multiples of 256 on
/// every adapter.
pub const SLOT: u64 = 256;

/// A bind group for `pipeline`'s group 0 with exactly the given bindings.
pub fn bind(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, wgpu::BindingResource)],
) -> wgpu::BindGroup {
    bind_group_at(ctx, None, pipeline, 0, entries)
}

/// A bind group for `pipeline`'s group 0 binding each buffer whole.
pub fn bind_buffers(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<(u32, wgpu::BindingResource)> = buffers
        .iter()
        .map(|&(binding, buffer)| (binding, buffer.as_entire_binding()))
        .collect();
    bind(ctx, pipeline, &entries)
}

/// A bind group for group `index` of `pipeline` (whose layout is derived from its shader)
/// with exactly the given (binding, resource) entries.
pub fn bind_group_at(
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

/// A texture-view bind group entry.
pub fn texture_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    }
}

/// The slice of a slotted buffer holding one struct of `size` bytes at slot `slot`.
pub fn slot(buffer: &wgpu::Buffer, slot: u64, size: u64) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: slot * SLOT,
        size: wgpu::BufferSize::new(size),
    })
}

/// Number of workgroups of `group` invocations covering `n`.
pub fn groups(n: u32, group: u32) -> u32 {
    n.div_ceil(group)
}

/// Workgroups (x, y) of 64 invocations covering `n`, spread over y past the 65535 limit of one
/// dimension; kernels rebuild the linear index from `global_invocation_id` and the x count.
pub fn dispatch_size(n: u32) -> (u32, u32) {
    let groups = n.div_ceil(64).max(1);
    if groups <= 65535 {
        (groups, 1)
    } else {
        (65535, groups.div_ceil(65535))
    }
}

/// Records one compute dispatch of `workgroups` (x, y, z) with `group` at group 0 as the named
/// pass `name`.
pub fn dispatch_groups(
    timer: &mut PassTimer,
    name: &str,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    workgroups: [u32; 3],
) {
    timer.pass(name, |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(name),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
    });
}

/// Records a compute dispatch of `n` invocations (workgroups of 64, [`dispatch_size`]) as the
/// named pass `name`.
pub fn dispatch_1d(
    timer: &mut PassTimer,
    name: &str,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    n: u32,
) {
    let (x, y) = dispatch_size(n);
    dispatch_groups(timer, name, pipeline, group, [x, y, 1]);
}

/// Records an 8x8-workgroup compute pass over every pixel of a `width` x `height` image as the
/// named pass `name`.
pub fn dispatch_2d(
    timer: &mut PassTimer,
    name: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    width: u32,
    height: u32,
) {
    let workgroups = [width.div_ceil(8), height.div_ceil(8), 1];
    dispatch_groups(timer, name, pipeline, bind_group, workgroups);
}
