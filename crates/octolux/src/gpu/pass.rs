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

/// A bind group entry binding the whole of `buffer`.
pub fn buffer_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
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

/// Byte offset of element `slot` of an array of indirect dispatch arguments (`DispatchArgs`
/// of `gpu/dispatch.wgsl`, wgpu's `DispatchIndirectArgs`).
pub fn indirect_offset(slot: u32) -> u64 {
    slot as u64 * std::mem::size_of::<wgpu::util::DispatchIndirectArgs>() as u64
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

/// A bind group kept from frame to frame while the resources it binds stay the same: a pass
/// whose inputs live as long as the technique (the frame's G-buffer and camera, the
/// technique's own buffers) binds the same group every frame instead of making a new one.
/// Resources are compared by identity; the kept group holds its resources until a different
/// set replaces it.
#[derive(Default)]
pub struct KeptBindGroup {
    kept: std::sync::Mutex<Option<(BindingKey, wgpu::BindGroup)>>,
}

/// The resources of a bind group by binding.
type BindingKey = Vec<(u32, ResourceKey)>;

/// What identifies a bound resource (handles compare by identity).
#[derive(Clone, PartialEq)]
enum ResourceKey {
    Buffer(wgpu::Buffer, u64, Option<u64>),
    Sampler(wgpu::Sampler),
    View(wgpu::TextureView),
    /// Any other kind: never matches, so the group is made again.
    Other,
}

impl ResourceKey {
    fn of(resource: &wgpu::BindingResource) -> ResourceKey {
        match resource {
            wgpu::BindingResource::Buffer(b) => {
                ResourceKey::Buffer(b.buffer.clone(), b.offset, b.size.map(|s| s.get()))
            }
            wgpu::BindingResource::Sampler(s) => ResourceKey::Sampler((*s).clone()),
            wgpu::BindingResource::TextureView(v) => ResourceKey::View((*v).clone()),
            _ => ResourceKey::Other,
        }
    }
}

impl KeptBindGroup {
    /// The bind group of group 0 of `pipeline` with exactly `entries`: the kept one where the
    /// entries bind the same resources as last time, else a new one, kept in its place.
    pub fn get(
        &self,
        ctx: &GpuContext,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        entries: &[(u32, wgpu::BindingResource)],
    ) -> wgpu::BindGroup {
        self.get_at(ctx, label, pipeline, 0, entries)
    }

    /// [`KeptBindGroup::get`] for group `index` of `pipeline`.
    pub fn get_at(
        &self,
        ctx: &GpuContext,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        index: u32,
        entries: &[(u32, wgpu::BindingResource)],
    ) -> wgpu::BindGroup {
        let key: BindingKey = entries
            .iter()
            .map(|(binding, resource)| (*binding, ResourceKey::of(resource)))
            .collect();
        let mut kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((old, group)) = kept.as_ref() {
            if *old == key && !key.iter().any(|(_, k)| *k == ResourceKey::Other) {
                return group.clone();
            }
        }
        let group = bind_group_at(ctx, Some(label), pipeline, index, entries);
        *kept = Some((key, group.clone()));
        group
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuOptions;

    /// The same resources give the kept group back; another buffer or offset gives a new one.
    #[test]
    fn a_kept_bind_group_is_made_again_only_for_other_resources() {
        let ctx = GpuContext::shared(&GpuOptions::default()).expect("a GPU adapter");
        let module = ctx.shader(
            "kept test",
            "@group(0) @binding(0) var<storage, read_write> b: array<u32>;\n\
             @compute @workgroup_size(1) fn main() { b[0] = 1u; }",
        );
        let pipeline = ctx.compute_pipeline("kept test", &module, "main");
        let buffer = |label| {
            ctx.create_buffer(
                "kept test",
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: 512,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                },
            )
        };
        let (a, b) = (buffer("a"), buffer("b"));
        let kept = KeptBindGroup::default();
        let group = |buffer: &wgpu::Buffer, offset| {
            let resource = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer,
                offset,
                size: wgpu::BufferSize::new(16),
            });
            kept.get(&ctx, "kept test", &pipeline, &[(0, resource)])
        };
        let first = group(&a, 0);
        assert_eq!(group(&a, 0), first);
        let other = group(&b, 0);
        assert_ne!(other, first);
        assert_ne!(group(&b, 256), other);
        ctx.ledger.release_owner("kept test");
    }
}
