//! Light injection into the sparse voxel octree (Arnebäck 2017 §3.2): every leaf voxel gets
//! outgoing radiance `emission + albedo / pi x E`, where `E` is the direct irradiance from the
//! renderer's lights with visibility from the renderer's shadow-map array (the same PCF lookup
//! as the deferred lighting, taken half a voxel above the voxel centre along its normal). The
//! leaf radiance fills the leaf bricks of an RGBA16F radiance pool (radiance, opacity) exactly
//! as albedo fills the albedo bricks, and the octree's neighbour transfer and mip kernels then
//! filter it upward, so every level holds the same corner-sampled lattice filter of radiance
//! as of albedo ([`crate::voxel::svo::cpu::lattices`] of the voxel radiance is the reference).
//!
//! Per leaf voxel the build keeps the sums of its fragments' albedo, emission and normal
//! ([`LEAF_SUM_WORDS`] words), which is what injection reads.

use crate::frame::light_bindings;
use crate::frame::ShadowLookup;
use crate::gpu::pass::{bind_buffers, dispatch_1d, SLOT};
use crate::gpu::shader::library_shader;
use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::voxel::svo::bindings::group0_with;
use crate::voxel::svo::control::args_offset;
use crate::voxel::svo::steps::{filter_steps, record_steps};
use crate::voxel::svo::{Svo, SvoBuilder};
use crate::voxel::voxelize::FragmentList;
use crate::{Error, Result};

/// Injections recorded before one submission (each writes its parameters to its own slots).
const INJECT_SLOTS: u64 = 4;

/// Words kept per occupied leaf voxel: albedo sums (3), fragment count, emission sums (3,
/// fixed point x1024), normal sums (3, snorm8 as two's complement).
pub const LEAF_SUM_WORDS: u32 = 10;

/// `AccumulateParams` of `svo/inject.wgsl`: the accumulation of a fragment list into the
/// static leaves' sums.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct AccumulateParams {
    /// Fragments in the list.
    pub(super) fragments: u32,
    /// Levels of the octree.
    pub(super) depth: u32,
    /// The static leaf nodes `[first_leaf, first_leaf + leaf_count)`.
    pub(super) first_leaf: u32,
    pub(super) leaf_count: u32,
}

/// `InjectParams` of `svo/inject.wgsl`: one injection dispatch (the static leaves or the
/// dynamic ones).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct InjectParams {
    pub(super) origin: [f32; 3],
    pub(super) voxel_size: f32,
    /// The leaf nodes `[first_leaf, first_leaf + leaf_count)` (static leaves only).
    pub(super) first_leaf: u32,
    pub(super) leaf_count: u32,
    pub(super) lights: u32,
    pub(super) pool_bricks: u32,
    pub(super) static_nodes: u32,
    pub(super) first_static_leaf: u32,
    /// `voxel_radiance` slot of the first leaf.
    pub(super) first_slot: u32,
    pub(super) has_dynamic: u32,
    /// 1: the leaves are the dynamic nodes of level `leaf_level`, read on the GPU.
    pub(super) dynamic_leaves: u32,
    pub(super) leaf_level: u32,
    /// 1: the dispatch takes part in multiple bounces.
    pub(super) bounce: u32,
    /// Capacity of the dynamic leaves' table of last frame's irradiance (0: none).
    pub(super) bounce_table_capacity: u32,
}

/// Multiple bounces through the octree's leaves: per `voxel_radiance` slot, the indirect
/// irradiance to add to a voxel's direct irradiance (RGBA16F pairs, written by a cone gather)
/// and the voxel geometry that the injection writes for that gather (coordinates with bit 30
/// set for an occupied voxel, then the snorm8x4 normal). Both are 8 bytes per slot, as
/// `voxel_radiance`; `irradiance` covers the static leaves, `geometry` also the dynamic
/// part's reserve.
///
/// The static leaves keep their slots from frame to frame, the dynamic ones do not (the part
/// is rebuilt every frame): their irradiance goes through `tables`, two tables keyed by voxel
/// coordinates, one filled by this frame's gather while the injection reads the other.
pub struct SvoBounce {
    /// Indirect irradiance per static slot, read by the injection.
    pub irradiance: wgpu::Buffer,
    /// Voxel geometry per slot (static, then the dynamic reserve's), written by the injection.
    pub geometry: wgpu::Buffer,
    /// With a dynamic part: the two tables of the dynamic voxels' irradiance.
    pub tables: Option<[SvoBounceTable; 2]>,
    /// Which table the injection reads (`frame % 2`); the gather fills the other.
    pub frame: u32,
}

/// Irradiance gathered at the dynamic voxels, by voxel (`voxel/svo/bounce_table.wgsl`).
pub struct SvoBounceTable {
    /// `capacity` keys (the geometry word, 0 = empty).
    pub keys: wgpu::Buffer,
    /// `capacity` RGBA16F values (two words each).
    pub values: wgpu::Buffer,
    /// Entries, a power of two.
    pub capacity: u32,
}

impl SvoBounce {
    /// The table the injection reads this frame.
    pub fn read_table(&self) -> Option<&SvoBounceTable> {
        self.tables.as_ref().map(|t| &t[(self.frame % 2) as usize])
    }

    /// The table this frame's gather fills.
    pub fn write_table(&self) -> Option<&SvoBounceTable> {
        self.tables
            .as_ref()
            .map(|t| &t[(self.frame % 2) as usize ^ 1])
    }
}

/// The injection kernel, with or without the facing pool's bindings and stores.
fn inject_pipeline(ctx: &GpuContext, facing: bool) -> wgpu::ComputePipeline {
    let source = library_shader("voxel/svo/inject", &[("facing", facing)]);
    let module = ctx.shader("svo inject (facing)", &source);
    ctx.compute_pipeline("svo inject (facing)", &module, "inject")
}

/// The accumulation and injection kernels.
pub(crate) struct SvoLight {
    leaf_mask: wgpu::ComputePipeline,
    leaf_slots: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    inject: wgpu::ComputePipeline,
    /// The injection that also writes the facing pool, compiled when first needed.
    inject_facing: std::cell::OnceCell<wgpu::ComputePipeline>,
    /// The injection's parameters, one [`SLOT`] per part (static leaves, dynamic leaves) and
    /// injection recorded before one submission (writes land at the submission), up to
    /// [`INJECT_SLOTS`] of them.
    params: wgpu::Buffer,
    /// The timer submission of the last injection and the injections recorded before it.
    params_used: std::cell::Cell<(u64, u64)>,
    /// The bind group per injection slot and part, kept while its resources are.
    groups: Vec<crate::gpu::pass::KeptBindGroup>,
    /// 16-byte stand-ins for absent bindings: one read, one written (a dispatch may not use
    /// one buffer as both).
    placeholder: wgpu::Buffer,
    placeholder_out: wgpu::Buffer,
}

impl SvoLight {
    pub(crate) fn new(ctx: &GpuContext) -> SvoLight {
        let source = library_shader("voxel/svo/inject", &[("facing", false)]);
        let module = ctx.shader("svo inject", &source);
        let owner = crate::voxel::svo::OWNER;
        let small = |label: &str| {
            ctx.create_buffer(
                owner,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                },
            )
        };
        SvoLight {
            leaf_mask: ctx.compute_pipeline("svo leaf masks", &module, "leaf_mask"),
            leaf_slots: ctx.compute_pipeline("svo leaf slots", &module, "leaf_slots"),
            accumulate: ctx.compute_pipeline("svo leaf sums", &module, "accumulate"),
            inject: ctx.compute_pipeline("svo inject", &module, "inject"),
            inject_facing: std::cell::OnceCell::new(),
            params: crate::gpu::alloc::param_slots(ctx, owner, "inject params", 2 * INJECT_SLOTS),
            params_used: std::cell::Cell::new((u64::MAX, 0)),
            groups: (0..2 * INJECT_SLOTS).map(|_| Default::default()).collect(),
            placeholder: small("inject placeholder"),
            placeholder_out: small("inject placeholder (bounce)"),
        }
    }

    /// Sums every fragment into its leaf voxel; returns the compact sums buffer
    /// (`voxel/svo/leaf_sums.wgsl`: an index word per leaf node, then [`LEAF_SUM_WORDS`] per occupied
    /// voxel) and the times of the passes submitted so far (this reads back the number of
    /// occupied voxels to size the buffer).
    pub(crate) fn accumulate(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        list: &FragmentList,
        child: &wgpu::Buffer,
        depth: u32,
        leaves: (u32, u32),
    ) -> Result<(wgpu::Buffer, Vec<PassTiming>)> {
        let owner = crate::voxel::svo::OWNER;
        let leaf_count = leaves.1 - leaves.0;
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let buffer = |label: &str, words: u64| {
            ctx.create_buffer(
                owner,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: (words * 4).max(16),
                    usage,
                    mapped_at_creation: false,
                },
            )
        };
        // Index words + the slot counter.
        let index = buffer("leaf index (build)", leaf_count as u64 + 1);
        let params = ctx.create_buffer_init(
            owner,
            "leaf sum params",
            bytemuck::bytes_of(&AccumulateParams {
                fragments: list.count,
                depth,
                first_leaf: leaves.0,
                leaf_count,
            }),
            wgpu::BufferUsages::STORAGE,
        );
        let fragments_group = |pipeline: &wgpu::ComputePipeline, sums: &wgpu::Buffer| {
            let mut buffers = vec![(0, &params), (1, &list.buffer)];
            if std::ptr::eq(pipeline, &self.accumulate) {
                buffers.push((2, &list.triangles));
            }
            buffers.extend([(3, child), (4, sums)]);
            bind_buffers(ctx, pipeline, &buffers)
        };
        let group = fragments_group(&self.leaf_mask, &index);
        dispatch_1d(timer, "svo leaf masks", &self.leaf_mask, &group, list.count);
        let group = bind_buffers(ctx, &self.leaf_slots, &[(0, &params), (4, &index)]);
        dispatch_1d(
            timer,
            "svo leaf slots",
            &self.leaf_slots,
            &group,
            leaf_count,
        );
        let timings = timer.finish_frame()?;
        let counter = read_buffer(ctx, &index, leaf_count as u64 * 4, 4)?;
        let occupied = bytemuck::cast_slice::<u8, u32>(&counter)[0] as u64;
        let words = leaf_count as u64 + occupied * LEAF_SUM_WORDS as u64;
        let limit = ctx.device.limits().max_storage_buffer_binding_size;
        if words * 4 > limit || occupied >= 1 << 24 {
            return Err(Error::InvalidArgument(format!(
                "the octree's leaf sums ({occupied} occupied voxels, {} bytes) exceed what this \
                 GPU can bind ({limit} bytes); use a lower resolution",
                words * 4
            )));
        }
        let sums = buffer("leaf sums", words);
        timer.untimed(|encoder| {
            encoder.copy_buffer_to_buffer(&index, 0, &sums, 0, Some(leaf_count as u64 * 4))
        });
        let group = fragments_group(&self.accumulate, &sums);
        dispatch_1d(timer, "svo leaf sums", &self.accumulate, &group, list.count);
        ctx.ledger.forget(owner, "leaf sum params");
        ctx.ledger.forget(owner, "leaf index (build)");
        Ok((sums, timings))
    }

    /// Records the leaf injection of `svo` (before its transfer and mip passes), with the
    /// static leaves' multiple-bounce inputs and outputs where given.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn inject_leaves(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &crate::voxel::svo::Svo,
        shadows: ShadowLookup<'_>,
        lights: &wgpu::Buffer,
        light_count: u32,
        bounce: Option<&SvoBounce>,
    ) -> Result<()> {
        let (first, end) = svo.levels.last().copied().unwrap_or((0, 0));
        let grid = &svo.grid;
        let dynamic = svo.dynamic.as_ref();
        // Static leaves, then the dynamic part's leaves (their radiance slots follow), whose
        // range and dispatch size the last dynamic update left on the GPU.
        let depth = svo.levels.len() as u32;
        let mut parts = vec![(first, end - first, 0, None)];
        if dynamic.is_some() && depth > 0 {
            let leaf = depth - 1;
            // The first leaf is read on the GPU from the leaf level's dynamic node range.
            parts.push((
                leaf,
                0,
                end - first,
                Some(crate::voxel::svo::control::ARGS_DYN_NODES + leaf),
            ));
        }
        // One parameter slot per part and injection of this submission (tests record several).
        let submission = timer.submissions();
        let injection = match self.params_used.get() {
            (s, used) if s == submission => used,
            _ => 0,
        };
        if injection >= INJECT_SLOTS {
            return Err(Error::InvalidArgument(format!(
                "octree injection: more than {INJECT_SLOTS} recorded before one submission \
                 (finish the frame between them)"
            )));
        }
        self.params_used.set((submission, injection + 1));
        let params_buffer = &self.params;
        let (placeholder, placeholder_out) = (&self.placeholder, &self.placeholder_out);
        let (dyn_sums, dyn_state) = match dynamic {
            Some(d) => (&d.sums, d.state()),
            None => (placeholder, placeholder),
        };
        let table = bounce.and_then(SvoBounce::read_table);
        let (keys, values) = table.map_or((placeholder, placeholder), |t| (&t.keys, &t.values));
        for (i, &(node, count, slot, indirect)) in parts.iter().enumerate() {
            // The dynamic part's `node` is its level, whose range is read on the GPU.
            let dynamic_leaves = indirect.is_some();
            let params = InjectParams {
                origin: grid.origin.to_array(),
                voxel_size: grid.voxel_size,
                first_leaf: if dynamic_leaves { 0 } else { node },
                leaf_count: count,
                lights: light_count,
                pool_bricks: svo.pool_bricks,
                static_nodes: svo.static_nodes,
                first_static_leaf: first,
                first_slot: slot,
                has_dynamic: dynamic.is_some() as u32,
                dynamic_leaves: dynamic_leaves as u32,
                leaf_level: if dynamic_leaves { node } else { 0 },
                // The static leaves keep their slots from frame to frame; the dynamic ones
                // find last frame's irradiance in the bounce table.
                bounce: (i == 0 && bounce.is_some() || i == 1 && table.is_some()) as u32,
                bounce_table_capacity: if i == 0 {
                    0
                } else {
                    table.map_or(0, |t| t.capacity)
                },
            };
            let at = 2 * injection + i as u64;
            ctx.queue
                .write_buffer(params_buffer, at * SLOT, bytemuck::bytes_of(&params));
            let name = if i == 0 {
                "svo inject"
            } else {
                "svo inject (dynamic)"
            };
            self.inject_part(
                ctx,
                timer,
                svo,
                (
                    crate::gpu::pass::slot(params_buffer, at, size_of::<InjectParams>() as u64),
                    &self.groups[at as usize],
                ),
                [dyn_sums, dyn_state],
                bounce.map_or([placeholder, placeholder_out, keys, values], |b| {
                    [&b.irradiance, &b.geometry, keys, values]
                }),
                light_bindings(lights, shadows),
                (name, count, indirect),
            );
        }
        Ok(())
    }

    /// One injection dispatch over `count` leaves, or indirectly from slot `indirect` of the
    /// octree's dispatch arguments, with its parameters, the dynamic part's sums and state, the
    /// bounce buffers and the lights with their shadow maps.
    #[allow(clippy::too_many_arguments)]
    fn inject_part(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &crate::voxel::svo::Svo,
        (params, kept): (wgpu::BindingResource<'_>, &crate::gpu::pass::KeptBindGroup),
        [dyn_sums, dyn_state]: [&wgpu::Buffer; 2],
        [bounce_in, bounce_out, table_keys, table_values]: [&wgpu::Buffer; 4],
        lights: [(u32, wgpu::BindingResource<'_>); 4],
        (name, count, indirect): (&str, u32, Option<u32>),
    ) {
        let buffers: [(u32, &wgpu::Buffer); 15] = [
            (11, &svo.leaf_sums),
            (12, &svo.coord),
            (13, &svo.brick_plus_one),
            (18, &svo.voxel_radiance),
            (19, &svo.radiance[0]),
            (20, &svo.radiance[1]),
            (21, &svo.radiance[2]),
            (22, &svo.radiance[3]),
            (23, dyn_sums),
            (24, dyn_state),
            (25, &svo.control),
            (26, bounce_in),
            (27, bounce_out),
            (28, table_keys),
            (29, table_values),
        ];
        let mut entries: Vec<(u32, wgpu::BindingResource)> = buffers
            .iter()
            .map(|&(binding, buffer)| (binding, buffer.as_entire_binding()))
            .collect();
        entries.push((10, params));
        entries.extend(lights);
        let pipeline = match &svo.facing {
            Some(facing) => {
                entries.extend((0..4).map(|k| (30 + k as u32, facing[k].as_entire_binding())));
                self.inject_facing
                    .get_or_init(|| inject_pipeline(ctx, true))
            }
            None => &self.inject,
        };
        let group = kept.get(ctx, name, pipeline, &entries);
        let Some(slot) = indirect else {
            dispatch_1d(timer, name, pipeline, &group, count);
            return;
        };
        timer.pass(name, |encoder, stamps| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(name),
                timestamp_writes: stamps.compute(),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups_indirect(&svo.args, args_offset(slot));
        });
    }
}

/// Work counts of the radiance mip (`gpu/work.rs`): its dispatches, one after another; the
/// static part's texels filtered from their children (27 per node above the leaves) and its
/// neighbour transfers (one per node and axis, a face of 9 texels where the neighbour
/// exists), each twice with the facing pool. The dynamic part's nodes are known only on the
/// GPU and are not counted.
const RADIANCE_MIP_WORK: &[&str] = &[
    "dispatches",
    "static texels filtered",
    "static face transfers",
];

impl SvoBuilder {
    /// direct irradiance from the first `light_count` lights of `lights` (the renderer's light
    /// buffer, `array<Light>` of `frame/lights.wgsl`), with visibility from the shadow maps
    /// (`shadows`, the renderer's [`crate::frame::ShadowMaps::lookup`]); then the neighbour
    /// transfer and mip filter upward, level by level. Units: radiance in W/(m^2 sr).
    #[allow(clippy::too_many_arguments)]
    pub fn inject(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &Svo,
        shadows: crate::frame::ShadowLookup<'_>,
        lights: &wgpu::Buffer,
        light_count: u32,
    ) -> Result<()> {
        self.inject_with_bounce(ctx, timer, svo, shadows, lights, light_count, None)
    }

    /// [`SvoBuilder::inject`] with multiple bounces: the static leaves add the irradiance of
    /// `bounce` to their direct irradiance and write their geometry into it for the next
    /// gather ([`crate::voxel::svo::inject::SvoBounce`]).
    #[allow(clippy::too_many_arguments)]
    pub fn inject_with_bounce(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &Svo,
        shadows: crate::frame::ShadowLookup<'_>,
        lights: &wgpu::Buffer,
        light_count: u32,
        bounce: Option<&crate::voxel::svo::inject::SvoBounce>,
    ) -> Result<()> {
        let needed = light_count as u64 * crate::frame::LIGHT_BYTES;
        if lights.size() < needed.max(crate::frame::LIGHT_BYTES) {
            return Err(Error::InvalidArgument(format!(
                "octree injection: {light_count} lights need a light buffer of {needed} bytes \
                 (at least one light's), it has {}",
                lights.size()
            )));
        }
        if svo.levels.is_empty() {
            return Ok(());
        }
        self.light
            .inject_leaves(ctx, timer, svo, shadows, lights, light_count, bounce)?;
        // The transfer and mip kernels bind the build layout: no fragments or triangles;
        // with facing, the facing pool after it, filtered in the same dispatches.
        let placeholder = &self.mip_placeholder;
        let mut buffers = vec![
            placeholder,
            placeholder,
            &svo.child,
            &svo.neighbours,
            &svo.coord,
            &svo.brick_plus_one,
            &svo.control,
        ];
        buffers.extend(&svo.radiance);
        let (group, pipelines) = match &svo.facing {
            Some(facing) => {
                let filter = self.facing_filter(ctx);
                buffers.extend(facing);
                let group = group0_with(ctx, &filter.layout0, &svo.level_params, &buffers);
                (group, &filter.pipelines)
            }
            None => (
                group0_with(ctx, &self.layout0, &svo.level_params, &buffers),
                &self.pipelines,
            ),
        };
        let args_group = self.args_group(ctx, &svo.args);
        let depth = svo.levels.len() as u32;
        let steps = filter_steps(depth, svo.dynamic.is_some(), self.fuse_coarse);
        // Each dispatch waits for the one before: on a GPU the coarse levels' cost is their
        // number more than their few nodes.
        let pools = if svo.facing.is_some() { 2 } else { 1 };
        let nodes = |d: usize| svo.levels.get(d).map_or(0, |&(a, b)| u64::from(b - a));
        let leaf = svo.levels.len() - 1;
        let counts = [
            steps.len() as u64,
            (0..leaf).map(nodes).sum::<u64>() * 27 * pools,
            (0..=leaf).map(nodes).sum::<u64>() * 3 * pools,
        ];
        for (quantity, n) in counts.into_iter().enumerate() {
            crate::gpu::work::add(ctx, "svo radiance mip", RADIANCE_MIP_WORK, quantity, n)?;
        }
        record_steps(
            pipelines,
            timer,
            "svo radiance mip",
            &group,
            (&args_group, None),
            &svo.args,
            0,
            &steps,
        );
        Ok(())
    }
}
