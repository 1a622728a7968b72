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

use crate::gpu::{GpuContext, PassTimer, PassTiming};
use crate::voxel::svo::control::{level_params, ARGS_DYN_NODES, BRICK_COUNTER, CONTROL_WORDS};
use crate::voxel::svo::steps::Dispatch;
use crate::voxel::svo::{Svo, SvoBuilder, OWNER};
use crate::voxel::VoxelTriangle;
use crate::{Error, Result};
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

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

// Words of `control` and indirect slots, as in `svo/dynamic.wgsl`.
const DYN_NODES: usize = 64;
const NEED_RANGE: usize = 104;
const OCC_COUNT: usize = 124;
const NEED_COUNT: usize = 125;
const DYN_OVERFLOW: usize = 126;
const DYN_FRAGMENTS: usize = 127;
const ARGS_OCC: u32 = 32;
const ARGS_NEED: u32 = 48;
const ARGS_ALL_NEEDED: u32 = 63;
const ARGS_FRAGMENTS: u32 = 64;
const ARGS_UNLINK: u32 = 65;
const ARGS_RESET: u32 = 66;
const ARGS_LAST_NEED: u32 = 67;
/// Deepest octree the dynamic part handles (1024^3: levels 0..9; ranges of 10 levels fit the
/// control block).
const MAX_DEPTH: u32 = 10;
/// Byte offset of `last` (the previous update's control block) in the parameter block.
const PARAMS_LAST: u64 = 48;
/// Bytes of one control block.
const CONTROL_BYTES: u64 = CONTROL_WORDS * 4;
/// Staging buffers of the counts readback: an update whose frame finds none free (the GPU is
/// more than this many updates behind) is not read back; a later one is.
pub const READBACK_SLOTS: usize = 4;

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

/// Mapping state of a readback slot.
const FREE: u8 = 0;
const WAITING: u8 = 1;
const MAPPED: u8 = 2;
const FAILED: u8 = 3;

/// One staging buffer of the counts readback: the control block after the update, then the
/// one it started from.
struct Readback {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
    /// The update it holds, and that update's triangle count (for the error message).
    update: u64,
    triangles: usize,
}

/// GPU state of the dynamic part, kept between updates.
pub(crate) struct SvoDynamic {
    reserve: DynamicReserve,
    node_capacity: u32,
    brick_capacity: u32,
    /// Per node: dynamic occupied / needed bits and the leaf's slot in `sums`.
    state: wgpu::Buffer,
    occupied: wgpu::Buffer,
    /// Needed lists of this and of the previous update (swapped every update).
    needed: [wgpu::Buffer; 2],
    /// Which of `needed` holds the previous update's list.
    last: usize,
    /// Per occupied dynamic leaf: fragment sums of its 8 voxels, as `Svo::leaf_sums`.
    pub(crate) sums: wgpu::Buffer,
    /// The dynamic fragments of the current update (reserve.fragments x 8 bytes).
    fragments: wgpu::Buffer,
    /// `DynParams` of `svo/dynamic.wgsl`: constants, then the previous control block.
    params: wgpu::Buffer,
    /// Per-level parameter slots of the dynamic kernels.
    level_params: wgpu::Buffer,
    /// The control block at the start of every update (static ranges and counts, empty
    /// dynamic ranges, zero counters), copied over `control` on the GPU.
    reset: wgpu::Buffer,
    readbacks: Vec<Readback>,
    /// Updates recorded so far.
    recorded: u64,
    /// The latest update whose counts `Svo` holds.
    applied: u64,
}

/// What [`SvoDynamic::new`] needs of the static part.
pub(crate) struct StaticPart {
    pub node_capacity: u32,
    pub brick_capacity: u32,
    pub depth: u32,
    pub pool_bricks: u32,
    pub first_leaf: u32,
    /// The build's control block (static level ranges and counts).
    pub control: Vec<u32>,
}

impl SvoDynamic {
    pub(crate) fn new(
        ctx: &GpuContext,
        reserve: DynamicReserve,
        part: StaticPart,
    ) -> Option<SvoDynamic> {
        if reserve.nodes == 0 {
            return None;
        }
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let buffer = |label: &str, words: u64| {
            ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: (words * 4).max(16),
                    usage,
                    mapped_at_creation: false,
                },
            )
        };
        let (s, b) = (part.control[0], part.control[BRICK_COUNTER]);
        let mut reset = part.control.clone();
        reset.resize(CONTROL_WORDS as usize, 0);
        reset[1] = 0;
        for w in &mut reset[DYN_NODES..] {
            *w = 0;
        }
        reset[DYN_NODES] = s;
        reset[DYN_NODES + 1] = s;
        // Constants, then `last`: the control block as the build left it (its node count is
        // the static one and its dynamic ranges are empty: nothing to undo).
        let mut params = vec![
            s,
            b,
            part.node_capacity,
            part.brick_capacity,
            reserve.fragments,
            0,
            reserve.occupied,
            reserve.needed,
            part.first_leaf,
            1,
            0,
            0,
        ];
        params.extend_from_slice(&reset);
        let params = ctx.create_buffer_init(
            OWNER,
            "dynamic params",
            bytemuck::cast_slice(&params),
            usage,
        );
        let reset = ctx.create_buffer_init(
            OWNER,
            "dynamic control reset",
            bytemuck::cast_slice(&reset),
            wgpu::BufferUsages::COPY_SRC,
        );
        let readbacks = (0..READBACK_SLOTS)
            .map(|k| Readback {
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
            })
            .collect();
        let sum_words = crate::voxel::svo::inject::LEAF_SUM_WORDS as u64 * 8;
        Some(SvoDynamic {
            reserve,
            node_capacity: part.node_capacity,
            brick_capacity: part.brick_capacity,
            state: buffer("dynamic state", part.node_capacity as u64),
            occupied: buffer("dynamic occupied list", reserve.occupied as u64),
            needed: [
                buffer("dynamic needed list 0", reserve.needed as u64),
                buffer("dynamic needed list 1", reserve.needed as u64),
            ],
            last: 1,
            sums: buffer("dynamic leaf sums", reserve.occupied as u64 * sum_words),
            fragments: buffer("dynamic fragments", reserve.fragments as u64 * 2),
            params,
            level_params: level_params(
                ctx,
                "dynamic level params",
                part.depth,
                0,
                part.node_capacity,
                part.pool_bricks,
            ),
            reset,
            readbacks,
            recorded: 0,
            applied: 0,
        })
    }

    /// The per-node state buffer (dynamic leaf slots), for injection.
    pub(crate) fn state(&self) -> &wgpu::Buffer {
        &self.state
    }
}

/// Group 2 of the dynamic kernels: parameters, state, lists, sums.
pub(crate) fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    use crate::voxel::svo::pipelines::storage;
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 1,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            // Read-only storage: "Parameter blocks" in voxel/mod.rs.
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }];
    entries.extend([
        storage(2, false),
        storage(3, false),
        storage(4, false),
        storage(5, true),
        storage(6, false),
        storage(7, true),
    ]);
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("svo dynamic"),
        entries: &entries,
    })
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
        let counts = svo.sync_dynamic(ctx)?;
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
        let depth = svo.levels.len() as u32;
        if svo.dynamic.is_none() {
            return Err(no_dynamic_part());
        }
        if !(2..=MAX_DEPTH).contains(&depth) {
            return Err(Error::InvalidArgument(format!(
                "the dynamic part needs an octree of 2 to {MAX_DEPTH} levels, this one has {depth}"
            )));
        }
        let earlier = svo.poll_dynamic(ctx);
        let Some(dynamic) = svo.dynamic.as_mut() else {
            return Err(no_dynamic_part());
        };
        let (s, cap) = (svo.static_nodes as u64, dynamic.node_capacity as u64);
        // The previous update's ranges go to the parameter block, then the counters restart:
        // nodes and bricks after the static part, empty dynamic ranges and lists.
        timer.untimed(|encoder| {
            encoder.copy_buffer_to_buffer(
                &svo.control,
                0,
                &dynamic.params,
                PARAMS_LAST,
                Some(CONTROL_BYTES),
            );
            encoder.copy_buffer_to_buffer(&dynamic.reset, 0, &svo.control, 0, Some(CONTROL_BYTES));
        });
        let owner = "svo dynamic";
        let triangles = self.voxelizer.append(
            ctx,
            timer,
            (owner, "svo dynamic voxelize"),
            &svo.grid,
            tris,
            (&dynamic.fragments, &svo.control, DYN_FRAGMENTS as u32),
        )?;
        ctx.ledger.forget(owner, "triangles");

        let (this, last) = (1 - dynamic.last, dynamic.last);
        let group0 = self.group0(
            ctx,
            &dynamic.level_params,
            [
                &dynamic.fragments,
                &triangles,
                &svo.child,
                &svo.neighbours,
                &svo.coord,
                &svo.brick_plus_one,
                &svo.control,
                &svo.bricks[0],
                &svo.bricks[1],
                &svo.bricks[2],
                &svo.bricks[3],
            ],
        );
        let group1 = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("svo dynamic"),
            layout: &self.dyn_layout,
            entries: &[
                (1, &dynamic.params),
                (2, &dynamic.state),
                (3, &dynamic.occupied),
                (4, &dynamic.needed[this]),
                (5, &dynamic.needed[last]),
                (6, &dynamic.sums),
                (7, &svo.leaf_sums),
            ]
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }),
        });
        let args_group = self.args_group(ctx, &svo.args);
        let groups = (&args_group, Some(&group1));
        let args = &svo.args;
        self.record(
            timer,
            "svo dynamic clear",
            &group0,
            groups,
            args,
            0,
            &[
                ("dyn_begin", 0, Dispatch::One),
                ("dyn_unlink", 0, Dispatch::Indirect(ARGS_UNLINK)),
                ("dyn_reset", 0, Dispatch::Indirect(ARGS_RESET)),
            ],
        );
        timer.untimed(|encoder| {
            let from = s * 4;
            encoder.clear_buffer(&svo.child, from, Some((cap - s) * 4));
            encoder.clear_buffer(&svo.neighbours, from * 3, Some((cap - s) * 12));
            encoder.clear_buffer(&svo.brick_plus_one, from, Some((cap - s) * 4));
            encoder.clear_buffer(&dynamic.state, from, Some((cap - s) * 4));
            encoder.clear_buffer(&dynamic.sums, 0, None);
        });

        let fragments = Dispatch::Indirect(ARGS_FRAGMENTS);
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
        self.record(
            timer,
            "svo dynamic structure",
            &group0,
            groups,
            args,
            0,
            &steps,
        );

        let leaf = depth - 1;
        let mut steps = vec![("dyn_accumulate", leaf, fragments)];
        for d in (0..depth).rev() {
            let entry = if d == leaf {
                "dyn_leaf_gather"
            } else {
                "dyn_mip_gather"
            };
            steps.push((entry, d, Dispatch::PerNode(ARGS_NEED + d)));
            // The previous update's needed nodes (parameter slot depth + d).
            steps.push((entry, depth + d, Dispatch::PerNode(ARGS_LAST_NEED + d)));
        }
        self.record(
            timer,
            "svo dynamic bricks",
            &group0,
            groups,
            args,
            0,
            &steps,
        );
        dynamic.last = this;
        dynamic.recorded += 1;
        let update = dynamic.recorded;

        // The counts go to a free staging buffer, mapped once the frame is submitted.
        if let Some(slot) = dynamic
            .readbacks
            .iter_mut()
            .find(|r| r.state.load(Ordering::Acquire) == FREE)
        {
            slot.state.store(WAITING, Ordering::Release);
            slot.update = update;
            slot.triangles = tris.len();
            let state = slot.state.clone();
            timer.untimed(|encoder| {
                encoder.copy_buffer_to_buffer(
                    &svo.control,
                    0,
                    &slot.buffer,
                    0,
                    Some(CONTROL_BYTES),
                );
                encoder.copy_buffer_to_buffer(
                    &dynamic.params,
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
        earlier.map(|_| update)
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
    pub fn sync_dynamic(&mut self, ctx: &GpuContext) -> Result<Option<DynamicCounts>> {
        if self.dynamic.is_none() {
            return Ok(None);
        }
        ctx.wait_idle()?;
        self.take_readbacks()
    }

    fn take_readbacks(&mut self) -> Result<Option<DynamicCounts>> {
        let depth = self.levels.len();
        let Some(dynamic) = self.dynamic.as_mut() else {
            return Ok(None);
        };
        let mut done: Vec<(u64, usize, std::result::Result<Vec<u32>, String>)> = Vec::new();
        for slot in &mut dynamic.readbacks {
            let words = match slot.state.load(Ordering::Acquire) {
                MAPPED => {
                    let words = slot
                        .buffer
                        .get_mapped_range(..)
                        .map(|bytes| bytemuck::cast_slice::<u8, u32>(&bytes).to_vec())
                        .map_err(|e| e.to_string());
                    slot.buffer.unmap();
                    words
                }
                FAILED => Err("mapping the readback failed".to_string()),
                _ => continue,
            };
            slot.state.store(FREE, Ordering::Release);
            done.push((slot.update, slot.triangles, words));
        }
        done.sort_by_key(|d| d.0);
        let reserve = dynamic.reserve;
        let mut latest = None;
        let mut error = None;
        for (update, triangles, words) in done {
            let words = match words {
                Ok(w) => w,
                Err(e) => {
                    error.get_or_insert(Error::Gpu(format!(
                        "reading back the counts of dynamic update {update}: {e}"
                    )));
                    continue;
                }
            };
            let (ctl, last) = words.split_at(CONTROL_WORDS as usize);
            let need = |c: &[u32]| c[NEED_RANGE + 2 * depth - 1].min(reserve.needed);
            let node_count = ctl[0].min(dynamic.node_capacity);
            let brick_count = ctl[BRICK_COUNTER].min(dynamic.brick_capacity);
            let counts = DynamicCounts {
                update,
                fragments: ctl[DYN_FRAGMENTS],
                nodes: node_count - self.static_nodes,
                bricks: brick_count - self.static_bricks,
                dirty: ctl[NEED_COUNT].min(reserve.needed) + need(last),
            };
            if update > dynamic.applied {
                dynamic.applied = update;
                self.node_count = node_count;
                self.brick_count = brick_count;
                self.fragment_count = counts.fragments;
                self.dynamic_levels = (0..depth)
                    .map(|d| (ctl[DYN_NODES + 2 * d], ctl[DYN_NODES + 2 * d + 1]))
                    .collect();
                latest = Some(counts);
            }
            let mut exhausted = Vec::new();
            if ctl[DYN_FRAGMENTS] > reserve.fragments {
                exhausted.push(format!(
                    "fragments ({} reserved, {} needed)",
                    reserve.fragments, ctl[DYN_FRAGMENTS]
                ));
            }
            if ctl[1] != 0 {
                exhausted.push(format!("nodes ({} reserved)", reserve.nodes));
            }
            match ctl[DYN_OVERFLOW] {
                0 => {}
                2 => exhausted.push(format!("bricks ({} reserved)", reserve.bricks)),
                _ => exhausted.push(format!(
                    "occupied or needed nodes ({} / {} reserved; {} occupied, {} needed)",
                    reserve.occupied, reserve.needed, ctl[OCC_COUNT], ctl[NEED_COUNT]
                )),
            }
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
