//! The octree's dynamic part (Arnebäck 2017 §3.1.7): static geometry is voxelized and built
//! once, moving geometry is rebuilt every frame in a section of the node and brick pools
//! reserved after the static part, so a moving object never forces a full rebuild.
//!
//! An octree built with [`SvoBuilder::build_with_reserve`] keeps room for
//! [`DynamicReserve::nodes`] nodes and [`DynamicReserve::bricks`] bricks after its static
//! ones. [`SvoBuilder::record_dynamic`] (or its blocking form [`SvoBuilder::update_dynamic`])
//! then, on the GPU (`svo/dynamic.wgsl`):
//!
//! 1. undoes the previous update: static nodes drop the children, bricks and neighbour links
//!    that pointed into the dynamic section, and the section is cleared;
//! 2. voxelizes the dynamic triangles only, and walks the levels as the static build does,
//!    but only for them: flag the occupied nodes, flag their 26-neighbourhoods as needed,
//!    subdivide needed nodes that have no children (new nodes after the static ones), link
//!    the new nodes (including the +x/+y/+z links of static nodes next to them); needed nodes
//!    without a brick get one after the static bricks;
//! 3. sums the dynamic fragments per leaf voxel next to the static sums (a voxel shared by
//!    static and dynamic geometry averages both: the static sums are never modified);
//! 4. recomputes the bricks of every node whose lattice the dynamic geometry changes now or
//!    changed in the previous update (the needed nodes of both updates: a lattice value
//!    changes only on the closed region of an occupied node, level after level), by
//!    gathering from the leaf sums and from the finer level, and writes every texel into all
//!    the bricks that share it, so shared faces stay identical.
//!
//! All of this is proportional to the dynamic geometry, not to the scene (except clearing the
//! reserved section, a fill of its bytes). Nothing waits for the GPU: the voxelization appends
//! to a fragment list of reserved capacity, every pass is sized on the GPU (indirect
//! dispatches written by one-invocation kernels from the counters), and what the next update
//! needs of this one (its node count, its dynamic node ranges and needed-list ranges) stays on
//! the GPU: the next update copies the control block into its parameter block
//! (`copy_buffer_to_buffer`) before resetting it. The CPU only uploads the moving triangles.
//!
//! The counts ([`Svo::node_count`], [`Svo::brick_count`], [`Svo::fragment_count`],
//! [`Svo::dynamic_levels`]) and an exhausted reserve reach the CPU later, through a ring of
//! [`READBACK_SLOTS`] small staging buffers: each update copies the control block into a
//! free one, which is mapped when the frame's commands are submitted; [`Svo::poll_dynamic`]
//! (called by every [`SvoBuilder::record_dynamic`]) picks up, without blocking, what the GPU
//! has finished, typically the update of one or two frames before. [`Svo::sync_dynamic`]
//! waits for it.
//!
//! Gathered texels are filtered from the finer level's 8-bit texels where the build filters
//! 16-bit ones, so they can differ from a full rebuild by a few 8-bit steps; both agree with
//! the exact lattice ([`crate::voxel::svo::cpu::lattices`]) within the tolerance the tests state.

mod readback;
mod ring;
pub(super) mod state;

pub use ring::READBACK_SLOTS;
pub(crate) use state::{bind_group_layout, StaticPart, SvoDynamic};

use crate::gpu::{GpuContext, PassTimer, PassTiming};
use crate::voxel::svo::control::{SvoControl, ARGS_DYN_NODES, MAX_LEVELS};
use crate::voxel::svo::steps::Dispatch;
use crate::voxel::svo::{Svo, SvoBuilder};
use crate::voxel::VoxelTriangle;
use crate::{Error, Result};

/// The dynamic update's kernels (`svo/dynamic.wgsl`).
pub(crate) const ENTRY_POINTS: &[&str] = &[
    "dyn_begin",
    "dyn_finish_fragments",
    "dyn_unlink",
    "dyn_reset",
    "dyn_flag_occupied",
    "dyn_finish_occupied",
    "dyn_flag_needed",
    "dyn_finish_needed",
    "dyn_subdivide",
    "dyn_finish_nodes",
    "dyn_link",
    "dyn_assign_bricks",
    "dyn_accumulate",
    "dyn_leaf_gather",
    "dyn_mip_gather",
];

// Indirect argument slots, as in `svo/dynamic.wgsl`.
const ARGS_OCC: u32 = 32;
const ARGS_NEED: u32 = 48;
const ARGS_ALL_NEEDED: u32 = 63;
const ARGS_FRAGMENTS: u32 = 64;
const ARGS_UNLINK: u32 = 65;
const ARGS_RESET: u32 = 66;
const ARGS_LAST_NEED: u32 = 67;
/// Room kept for the dynamic part after the static nodes and bricks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DynamicReserve {
    /// Nodes the dynamic geometry may add (20 bytes + 8 of bookkeeping each).
    pub nodes: u32,
    /// Bricks it may add (108 bytes of albedo + 216 of radiance each).
    pub bricks: u32,
    /// Nodes it may occupy, all levels together (a leaf among them keeps 320 bytes of sums).
    pub occupied: u32,
    /// Nodes it may need (occupied or next to an occupied node), all levels together.
    pub needed: u32,
    /// Voxel fragments of the dynamic triangles (one per triangle piece and voxel it touches;
    /// 8 bytes each).
    pub fragments: u32,
}

impl DynamicReserve {
    /// No dynamic part.
    pub const NONE: DynamicReserve = DynamicReserve {
        nodes: 0,
        bricks: 0,
        occupied: 0,
        needed: 0,
        fragments: 0,
    };

    /// Room for `nodes` dynamic nodes, as many bricks and needed nodes, a quarter as many
    /// occupied nodes (an occupied node is needed with its 26 neighbours) and four times as
    /// many fragments (an occupied leaf has up to 8 voxels, each touched by a few pieces).
    pub fn new(nodes: u32) -> DynamicReserve {
        DynamicReserve {
            nodes,
            bricks: nodes,
            occupied: (nodes / 4).max(64),
            needed: nodes,
            fragments: nodes.saturating_mul(4).max(256),
        }
    }
}

/// What one [`SvoBuilder::update_dynamic`] produced.
#[derive(Clone, Debug)]
pub struct DynamicUpdate {
    /// Voxel fragments of the dynamic triangles.
    pub fragments: u32,
    /// Nodes added after the static part.
    pub nodes: u32,
    /// Bricks added after the static part.
    pub bricks: u32,
    /// Nodes whose bricks were recomputed (this update's needed nodes and the previous
    /// update's static ones).
    pub dirty: u32,
    /// Pass times: clear, voxelization, structure, bricks.
    pub timings: Vec<PassTiming>,
}

/// The counts of one dynamic update, read back after the GPU ran it
/// ([`Svo::poll_dynamic`], [`Svo::sync_dynamic`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DynamicCounts {
    /// The update (1 for the first [`SvoBuilder::record_dynamic`] of the octree, then 2, ...).
    pub update: u64,
    /// Voxel fragments of its dynamic triangles (more than the reserve when it ran out).
    pub fragments: u32,
    /// Nodes it added after the static part.
    pub nodes: u32,
    /// Bricks it added after the static part.
    pub bricks: u32,
    /// Nodes whose bricks it recomputed (its needed nodes and the previous update's).
    pub dirty: u32,
}

fn no_dynamic_part() -> Error {
    Error::InvalidArgument(
        "this octree has no dynamic part: build it with SvoBuilder::build_with_reserve".into(),
    )
}

impl SvoBuilder {
    /// The octree of `scene` (at time 0) in the cube grid of `resolution`^3 voxels enclosing
    /// its bounds: its static objects built once, and room for a dynamic part where it has
    /// animated objects (nodes and bricks: their distinct voxels at time 0 x 16, for the
    /// 26-neighbourhoods of every level and for poses that touch more voxels; fragments: at
    /// least twice theirs at time 0), which [`SvoBuilder::record_dynamic`] fills every
    /// frame. `owner` names the technique in the error for a scene without geometry.
    pub fn build_scene(
        &self,
        ctx: &GpuContext,
        scene: &crate::scene::Scene,
        resolution: u32,
        owner: &str,
    ) -> Result<Svo> {
        let bounds = scene.gi_bounds_at(0.0);
        if !(bounds.0.is_finite() && bounds.1.is_finite() && bounds.0.cmple(bounds.1).all()) {
            return Err(Error::InvalidArgument(format!(
                "{owner} needs a scene with geometry; its bounds are {} to {}",
                bounds.0, bounds.1
            )));
        }
        let grid = crate::voxel::VoxelGrid::enclosing(bounds, resolution)?;
        let (still, moving) = crate::voxel::scene_triangles_split(scene, &scene.frame(0.0, 0));
        let (svo, _) = if moving.is_empty() {
            self.build(ctx, &grid, &still)?
        } else {
            // Fragments, one per triangle piece and voxel: a dense mesh has several per voxel.
            let fragments = crate::voxel::voxelize::cpu::voxelize(&grid, &moving);
            let voxels: std::collections::HashSet<[u32; 3]> =
                fragments.iter().map(|(v, _)| *v).collect();
            let nodes = (voxels.len() as u32)
                .saturating_mul(16)
                .clamp(4096, 1 << 22);
            let mut reserve = DynamicReserve::new(nodes);
            reserve.fragments = reserve
                .fragments
                .max((fragments.len() as u32).saturating_mul(2));
            self.build_with_reserve(ctx, &grid, &still, reserve)?
        };
        Ok(svo)
    }

    /// Replaces the dynamic part of `svo` (built with [`SvoBuilder::build_with_reserve`]) by
    /// the voxels of `tris`, leaving the static part as built, and waits for the result: it
    /// records [`SvoBuilder::record_dynamic`] into a timer of its own, submits it and calls
    /// [`Svo::sync_dynamic`]. For tests and tools; a renderer calls `record_dynamic` every
    /// frame instead, which never waits. An empty `tris` removes the dynamic part.
    /// Afterwards the octree's structure, bricks and leaf sums are those of static + dynamic
    /// geometry together, and its counts are this update's; [`SvoBuilder::inject`] lights
    /// both parts.
    ///
    /// Fails when the octree has no reserve, or when the dynamic geometry needs more
    /// fragments, nodes, bricks or list entries than reserved (the octree then holds a
    /// partial dynamic part until the next successful update).
    pub fn update_dynamic(
        &self,
        ctx: &GpuContext,
        svo: &mut Svo,
        tris: &[VoxelTriangle],
    ) -> Result<DynamicUpdate> {
        let mut timer = PassTimer::new(ctx);
        let recorded = self.record_dynamic(ctx, &mut timer, svo, tris);
        // Submitted even when an earlier update's error is reported: this one was recorded.
        let timings = timer.finish_frame()?;
        let update = recorded?;
        let counts = svo.sync_dynamic_update(ctx, update)?;
        match counts {
            Some(c) if c.update == update => Ok(DynamicUpdate {
                fragments: c.fragments,
                nodes: c.nodes,
                bricks: c.bricks,
                dirty: c.dirty,
                timings,
            }),
            _ => Err(Error::Gpu(format!(
                "the counts of dynamic update {update} were not read back (every readback \
                 slot was taken by a frame that was recorded but never submitted)"
            ))),
        }
    }

    /// Records the replacement of `svo`'s dynamic part by the voxels of `tris` into `timer`
    /// (the frame's encoder), without submitting, waiting or reading anything back: the
    /// moving triangles are uploaded, everything else (sizes of the passes, the ranges the
    /// next update undoes) stays on the GPU. The octree is up to date for every pass recorded
    /// after this one into the same frame ([`SvoBuilder::inject`], sampling) and for later
    /// frames; several updates may go into one frame.
    ///
    /// Returns the update's number (1, 2, ... since the build), which its
    /// [`DynamicCounts::update`] will carry. The counts of `svo` ([`Svo::node_count`],
    /// [`Svo::brick_count`], [`Svo::fragment_count`], [`Svo::dynamic_levels`]) are those of
    /// the latest update the GPU has finished and this octree has polled: this method polls
    /// ([`Svo::poll_dynamic`]) before recording, so they are usually one or two frames old.
    ///
    /// Fails without recording anything when the octree has no reserve or is too deep; fails
    /// *after* recording this update (which then runs normally when the frame is submitted)
    /// when the poll finds that an earlier update ran out of its reserve: the error names the
    /// update and what ran out. The octree recovers at the first later update that fits.
    pub fn record_dynamic(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &mut Svo,
        tris: &[VoxelTriangle],
    ) -> Result<u64> {
        let depth = svo.levels.len();
        if svo.dynamic.is_none() {
            return Err(no_dynamic_part());
        }
        if !(2..=MAX_LEVELS).contains(&depth) {
            return Err(Error::InvalidArgument(format!(
                "the dynamic part needs an octree of 2 to {MAX_LEVELS} levels, this one has {depth}"
            )));
        }
        let earlier = svo.poll_dynamic(ctx);
        let Some(mut dynamic) = svo.dynamic.take() else {
            return Err(no_dynamic_part());
        };
        let recorded = self.record_update(ctx, timer, svo, &mut dynamic, tris);
        svo.dynamic = Some(dynamic);
        let update = recorded?;
        earlier.map(|_| update)
    }

    /// [`SvoBuilder::record_dynamic`] of an octree with a dynamic part, as its passes.
    fn record_update(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &Svo,
        dynamic: &mut SvoDynamic,
        tris: &[VoxelTriangle],
    ) -> Result<u64> {
        let depth = svo.levels.len() as u32;
        // 1. Restart the counters: the previous update's control block goes to the parameter
        //    block (what the undo reads), the reset block over the control block.
        dynamic.restart(timer, &svo.control);

        // 2. Voxelize the dynamic triangles, appending to the dynamic fragment list and
        //    counting into the control block (unless they are the previous update's).
        let triangles = self.voxelize_dynamic(ctx, timer, svo, dynamic, tris)?;
        let this = 1 - dynamic.last;
        let group0 = self.dynamic_group0(ctx, svo, dynamic, &triangles);
        let group2 = self.dynamic_group2(ctx, svo, dynamic, this);
        let args_group = self.dynamic_args_group(ctx, svo, dynamic);
        let groups = (&args_group, Some(&group2));
        let record =
            |timer: &mut PassTimer, name: &str, steps: &[(&'static str, u32, Dispatch)]| {
                self.record(timer, name, &group0, groups, &svo.args, 0, steps)
            };

        // 3. Undo the previous update: unlink its nodes from the static ones, reset its
        //    needed nodes' state, then clear the dynamic section.
        record(timer, "svo dynamic clear", &CLEAR_STEPS);
        dynamic.clear_section(timer, svo);

        // 4. Structure: flag, subdivide and link as the static build does, for the dynamic
        //    fragments only, then give the needed nodes without one a brick.
        record(timer, "svo dynamic structure", &structure_steps(depth));

        // 5. Bricks: sum the dynamic fragments per leaf voxel, then gather the bricks of this
        //    update's and the previous update's needed nodes, finest level first.
        record(timer, "svo dynamic bricks", &brick_steps(depth));
        dynamic.last = this;
        dynamic.recorded += 1;
        let update = dynamic.recorded;

        // 6. Queue the counts' read-back, mapped once the frame is submitted.
        dynamic.queue_readback(timer, &svo.control, update, tris.len());
        Ok(update)
    }

    /// Records the voxelization of `tris` into the dynamic fragment list and returns their
    /// upload. The triangles are world-space (a moving object's change every frame), and the
    /// CPU snaps them to the grid before uploading them with their pieces and work items, so
    /// triangles that differ from the previous update's are uploaded and voxelized again; the
    /// same triangles (an object at rest, a frame of the same time) keep the previous
    /// update's upload and fragments, and only their count is restored.
    fn voxelize_dynamic(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &Svo,
        dynamic: &mut SvoDynamic,
        tris: &[VoxelTriangle],
    ) -> Result<wgpu::Buffer> {
        if let Some((last, triangles)) = &dynamic.triangles {
            if last.as_slice() == tris {
                dynamic.keep_fragments(timer, &svo.control);
                return Ok(triangles.clone());
            }
        }
        dynamic.triangles = None;
        let owner = "svo dynamic";
        let counter = (std::mem::offset_of!(SvoControl, dynamic_fragments) / 4) as u32;
        let triangles = self.voxelizer.append(
            ctx,
            timer,
            (owner, "svo dynamic voxelize"),
            &svo.grid,
            tris,
            (&dynamic.fragments, &svo.control, counter),
        )?;
        ctx.ledger.forget(owner, "triangles");
        dynamic.triangles = Some((tris.to_vec(), triangles.clone()));
        Ok(triangles)
    }

    /// A dynamic kernel (whose layout holds groups 0, 1 and 2) for the kept bind groups.
    fn dynamic_pipeline(&self) -> &wgpu::ComputePipeline {
        &self.pipelines["dyn_begin"].0
    }

    /// Group 0 of the dynamic kernels: the build layout over the octree's buffers, with the
    /// dynamic fragments and triangles; kept while the triangles' upload is.
    fn dynamic_group0(
        &self,
        ctx: &GpuContext,
        svo: &Svo,
        dynamic: &SvoDynamic,
        triangles: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let params = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &dynamic.level_params,
            offset: 0,
            size: wgpu::BufferSize::new(32),
        });
        let buffers = [
            &dynamic.fragments,
            triangles,
            &svo.child,
            &svo.neighbours,
            &svo.coord,
            &svo.brick_plus_one,
            &svo.control,
            &svo.bricks[0],
            &svo.bricks[1],
            &svo.bricks[2],
            &svo.bricks[3],
        ];
        let entries: Vec<(u32, wgpu::BindingResource)> = std::iter::once((0, params))
            .chain((1..).zip(buffers.map(|b| b.as_entire_binding())))
            .collect();
        let pipeline = self.dynamic_pipeline();
        dynamic.groups.group0.get(ctx, "svo", pipeline, &entries)
    }

    /// Group 1 of the dynamic kernels (the dispatch arguments), kept.
    fn dynamic_args_group(
        &self,
        ctx: &GpuContext,
        svo: &Svo,
        dynamic: &SvoDynamic,
    ) -> wgpu::BindGroup {
        let entries = [(0, svo.args.as_entire_binding())];
        let pipeline = self.dynamic_pipeline();
        dynamic
            .groups
            .args
            .get_at(ctx, "svo args", pipeline, 1, &entries)
    }

    /// Group 2 of the dynamic kernels, with needed list `this` written and the other one (the
    /// previous update's) read; one kept per `this`.
    fn dynamic_group2(
        &self,
        ctx: &GpuContext,
        svo: &Svo,
        dynamic: &SvoDynamic,
        this: usize,
    ) -> wgpu::BindGroup {
        let entries = [
            (1, &dynamic.params),
            (2, &dynamic.state),
            (3, &dynamic.occupied),
            (4, &dynamic.needed[this]),
            (5, &dynamic.needed[1 - this]),
            (6, &dynamic.sums),
            (7, &svo.leaf_sums),
        ]
        .map(|(binding, buffer)| (binding, buffer.as_entire_binding()));
        let pipeline = self.dynamic_pipeline();
        dynamic.groups.group2[this].get_at(ctx, "svo dynamic", pipeline, 2, &entries)
    }
}

/// The undo of the previous update, sized from its control block.
const CLEAR_STEPS: [(&str, u32, Dispatch); 3] = [
    ("dyn_begin", 0, Dispatch::One),
    ("dyn_unlink", 0, Dispatch::Indirect(ARGS_UNLINK)),
    ("dyn_reset", 0, Dispatch::Indirect(ARGS_RESET)),
];

/// The dynamic structure pass: per level, flag the nodes the dynamic fragments occupy and
/// their 26-neighbourhoods (each sized by the one before), subdivide the needed nodes without
/// children and link the new nodes of the next level; then the bricks.
fn structure_steps(depth: u32) -> Vec<(&'static str, u32, Dispatch)> {
    let mut steps = vec![("dyn_finish_fragments", 0, Dispatch::One)];
    for d in 0..depth {
        steps.push(("dyn_flag_occupied", d, Dispatch::Indirect(ARGS_FRAGMENTS)));
        steps.push(("dyn_finish_occupied", d, Dispatch::One));
        steps.push(("dyn_flag_needed", d, Dispatch::Indirect(ARGS_OCC + d)));
        steps.push(("dyn_finish_needed", d, Dispatch::One));
        if d + 1 < depth {
            steps.push(("dyn_subdivide", d, Dispatch::Indirect(ARGS_NEED + d)));
            steps.push(("dyn_finish_nodes", d, Dispatch::One));
            steps.push((
                "dyn_link",
                d + 1,
                Dispatch::Indirect(ARGS_DYN_NODES + d + 1),
            ));
        }
    }
    steps.push(("dyn_assign_bricks", 0, Dispatch::Indirect(ARGS_ALL_NEEDED)));
    steps
}

/// The dynamic brick pass: the leaf sums, then per level from the leaves up the gather of
/// this update's needed nodes and of the previous update's (parameter slot depth + d).
fn brick_steps(depth: u32) -> Vec<(&'static str, u32, Dispatch)> {
    let leaf = depth - 1;
    let mut steps = vec![("dyn_accumulate", leaf, Dispatch::Indirect(ARGS_FRAGMENTS))];
    for d in (0..depth).rev() {
        let entry = if d == leaf {
            "dyn_leaf_gather"
        } else {
            "dyn_mip_gather"
        };
        steps.push((entry, d, Dispatch::PerNode(ARGS_NEED + d)));
        steps.push((entry, depth + d, Dispatch::PerNode(ARGS_LAST_NEED + d)));
    }
    steps
}
