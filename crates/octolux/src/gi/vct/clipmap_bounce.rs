//! Multiple bounces on the clipmap (`clipmap_bounce.wgsl`): the indirect irradiance every
//! voxel slot gathered, which the next frame's injection adds to its direct irradiance.
//!
//! Per frame, in order: the slots the clipmap revoxelised lose their bounce
//! ([`ClipmapBounce::clear_revoxelised`], before the injection); after it, the voxels of this
//! frame's set gather through cones (the list, its indirect dispatch and the gather,
//! [`BounceList`]).

use super::bounce_list::{bounce_spread, BounceList};
use super::clipmap_tail::ClipmapTail;
use super::tracer::ConeTracer;
use super::VctSettings;
use crate::gpu::alloc::storage;
use crate::gpu::pass::{dispatch_1d, KeptBindGroup, SLOT};
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::clipmap::sample::{clip_bindings, CLIP_BINDINGS, CLIP_RADIANCE_BINDING};
use crate::voxel::clipmap::{Clipmap, UpdateBox};
use crate::Result;
use glam::IVec3;

const OWNER: &str = "vct-clipmap";

/// Bindings of `clipmap_bounce.wgsl`: its parameter block, the clipmap's normals, the bounce
/// irradiance and one box.
const PARAMS: u32 = 20;
const NORMALS: u32 = 21;
const IRRADIANCE: u32 = 22;
const BOX: u32 = 23;

/// Multiple bounces on the clipmap: the indirect irradiance every voxel slot gathered (two
/// words per slot: RGB as half floats, layout of the clipmap's voxels), the gather over the
/// listed voxels and the pass that clears the revoxelised boxes.
pub(super) struct ClipmapBounce {
    pub(super) irradiance: wgpu::Buffer,
    /// The voxels that gather this frame.
    list: BounceList,
    gather: wgpu::ComputePipeline,
    clear: wgpu::ComputePipeline,
    /// The [`BounceParams`] block, written every frame.
    params: wgpu::Buffer,
    /// The boxes a frame clears, one [`BounceBox`] per [`SLOT`] (grown when a frame has more
    /// than it holds), and the clear's bind group per box.
    boxes: wgpu::Buffer,
    clear_groups: Vec<KeptBindGroup>,
    gather_group: KeptBindGroup,
    /// Frames over which every voxel gathers once (`bounce_frames`), and frames gathered so
    /// far: together they pick this frame's set of voxels.
    pub(super) sets: u32,
    frame: u32,
}

/// Parameter block `BounceParams` of `clipmap_bounce.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BounceParams {
    /// Voxel slots (`levels * res^3`).
    slots: u32,
    /// This frame's set of voxels ([`bounce_spread`]).
    spread: u32,
}

/// `BounceBox` of `clipmap_bounce.wgsl`: one box of one level, which the clear zeroes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BounceBox {
    /// First voxel (world-voxel coordinates of the level).
    lo: [i32; 3],
    /// The box's level.
    level: u32,
    /// Voxels along each axis.
    size: [u32; 3],
    _pad: u32,
}

impl BounceBox {
    fn new(b: &UpdateBox) -> BounceBox {
        BounceBox {
            lo: b.lo.to_array(),
            level: b.level,
            size: (b.hi - b.lo).max(IVec3::ZERO).as_uvec3().to_array(),
            _pad: 0,
        }
    }
}

/// Boxes the clear's box buffer holds at first.
const BOX_ROOM: u64 = 16;

/// A box buffer for `boxes` boxes.
fn box_buffer(ctx: &GpuContext, label: &str, boxes: u64) -> wgpu::Buffer {
    storage(ctx, OWNER, label, boxes.max(1) * SLOT)
}

/// `boxes` as one [`BounceBox`] per [`SLOT`].
fn box_bytes(boxes: &[UpdateBox]) -> Vec<u8> {
    let mut bytes = vec![0u8; boxes.len() * SLOT as usize];
    for (k, b) in boxes.iter().enumerate() {
        let at = k * SLOT as usize;
        bytes[at..at + std::mem::size_of::<BounceBox>()]
            .copy_from_slice(bytemuck::bytes_of(&BounceBox::new(b)));
    }
    bytes
}

/// Box `k` of a box buffer, as a binding.
fn box_binding(buffer: &wgpu::Buffer, k: usize) -> (u32, wgpu::BindingResource<'_>) {
    (
        BOX,
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer,
            offset: k as u64 * SLOT,
            size: wgpu::BufferSize::new(std::mem::size_of::<BounceBox>() as u64),
        }),
    )
}

impl ClipmapBounce {
    pub(super) fn new(
        ctx: &GpuContext,
        settings: &VctSettings,
        tracer: &ConeTracer,
    ) -> ClipmapBounce {
        let slots = settings.levels as u64 * (settings.resolution as u64).pow(3);
        let module = tracer.bounce_module(ctx);
        ClipmapBounce {
            list: BounceList::new(ctx, OWNER, &module, slots as u32),
            irradiance: storage(ctx, OWNER, "bounce irradiance", slots * 8),
            gather: ctx.compute_pipeline("bounce", &module, "bounce"),
            clear: ctx.compute_pipeline("bounce clear", &module, "bounce_clear"),
            params: storage(
                ctx,
                OWNER,
                "bounce params",
                std::mem::size_of::<BounceParams>() as u64,
            ),
            boxes: box_buffer(ctx, "bounce boxes", BOX_ROOM),
            clear_groups: Vec::new(),
            gather_group: KeptBindGroup::default(),
            sets: settings.bounce_frames,
            frame: 0,
        }
    }

    /// Before the injection: the slots of every box the clipmap rewrote this frame lose their
    /// bounce light (a wrapped slot holds another voxel now; a moving object changed the
    /// voxels around it). `info` is the clipmap's `ClipInfo` block.
    pub(super) fn clear_revoxelised(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        info: &wgpu::Buffer,
        clipmap: &Clipmap,
    ) {
        let boxes: Vec<UpdateBox> = clipmap
            .last_revoxelised()
            .iter()
            .filter(|b| b.volume() > 0)
            .copied()
            .collect();
        if boxes.is_empty() {
            return;
        }
        if self.boxes.size() < boxes.len() as u64 * SLOT {
            let room = (boxes.len() as u64).next_power_of_two();
            self.boxes = box_buffer(ctx, "bounce boxes", room);
        }
        ctx.queue.write_buffer(&self.boxes, 0, &box_bytes(&boxes));
        self.clear_groups
            .resize_with(self.clear_groups.len().max(boxes.len()), Default::default);
        for (k, b) in boxes.iter().enumerate() {
            let entries = [
                (CLIP_BINDINGS, info.as_entire_binding()),
                (IRRADIANCE, self.irradiance.as_entire_binding()),
                box_binding(&self.boxes, k),
            ];
            let group = self.clear_groups[k].get(ctx, "bounce clear", &self.clear, &entries);
            dispatch_1d(
                timer,
                "bounce clear",
                &self.clear,
                &group,
                b.volume() as u32,
            );
        }
    }

    /// After the injection and the tail: this frame's set of voxels gathers indirect
    /// irradiance for the next frame (every voxel once in `sets` frames), through `radiance`
    /// (the clipmap's, described by `info`) and `tail`.
    pub(super) fn gather(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (info, clipmap, radiance): (&wgpu::Buffer, &Clipmap, &wgpu::Buffer),
        tail: &ClipmapTail,
        tracer: &ConeTracer,
    ) -> Result<()> {
        let params = BounceParams {
            slots: clipmap.settings.slots() as u32,
            spread: bounce_spread(self.sets, self.frame),
        };
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.frame = self.frame.wrapping_add(1);
        let [info, voxels] = clip_bindings(info, &clipmap.voxels);
        let shared = [
            (NORMALS, clipmap.normals.as_entire_binding()),
            (IRRADIANCE, self.irradiance.as_entire_binding()),
        ];
        let mut entries = vec![
            info.clone(),
            (CLIP_RADIANCE_BINDING, radiance.as_entire_binding()),
            (5, tracer.bounce_params().as_entire_binding()),
            (13, tail.buffer.as_entire_binding()),
        ];
        entries.extend(shared.iter().cloned());
        entries.extend(self.list.gather_entries());
        entries.extend(tracer.bounce_work(ctx, "bounce")?);
        let gather = self
            .gather_group
            .get(ctx, "vct bounce", &self.gather, &entries);
        let mut list = vec![info, voxels, (PARAMS, self.params.as_entire_binding())];
        list.extend(shared);
        self.list
            .record(ctx, timer, "bounce", &list, &self.gather, &gather);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn bounce_blocks_mirror_the_wgsl_ones() {
        let module = "gi/vct/clipmap_bounce";
        let flags = &[("facing", false)];
        assert_mirrors_wgsl!(BounceParams, module, "BounceParams", [slots, spread], flags);
        assert_mirrors_wgsl!(
            BounceBox,
            module,
            "BounceBox",
            [lo, level, size, _pad],
            flags
        );
    }
}
