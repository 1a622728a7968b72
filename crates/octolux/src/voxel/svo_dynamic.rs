//! The octree's dynamic part (Arnebäck 2017 §3.1.7): static geometry is voxelized and built
//! once, moving geometry is rebuilt every frame in a section of the node and brick pools
//! reserved after the static part, so a moving object never forces a full rebuild.
//!
//! An octree built with [`SvoBuilder::build_with_reserve`] keeps room for
//! [`DynamicReserve::nodes`] nodes and [`DynamicReserve::bricks`] bricks after its static
//! ones. [`SvoBuilder::update_dynamic`] then, on the GPU (`svo_dynamic.wgsl`):
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
//! All of this is proportional to the dynamic geometry, not to the scene. The work per level
//! is sized on the GPU (indirect dispatches); the CPU reads back 512 bytes of counters at the
//! end to detect an exhausted reserve and to know the dynamic ranges.
//!
//! Gathered texels are filtered from the finer level's 8-bit texels where the build filters
//! 16-bit ones, so they can differ from a full rebuild by a few 8-bit steps; both agree with
//! the exact lattice ([`super::cpu::lattices`]) within the tolerance the tests state.

use super::svo::{
    level_params, Dispatch, Svo, SvoBuilder, ARGS_DYN_NODES, BRICK_COUNTER, CONTROL_WORDS, OWNER,
};
use super::VoxelTriangle;
use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::{Error, Result};

/// The dynamic update's kernels (`svo_dynamic.wgsl`).
pub(crate) const ENTRY_POINTS: &[&str] = &[
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

// Words of `control` and indirect slots, as in `svo_dynamic.wgsl`.
const DYN_NODES: usize = 64;
const NEED_RANGE: usize = 104;
const OCC_COUNT: usize = 124;
const NEED_COUNT: usize = 125;
const DYN_OVERFLOW: usize = 126;
const ARGS_OCC: u32 = 32;
const ARGS_NEED: u32 = 48;
const ARGS_ALL_NEEDED: u32 = 63;
/// Deepest octree the dynamic part handles (1024^3: levels 0..9; ranges of 10 levels fit the
/// control block).
const MAX_DEPTH: u32 = 10;

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
}

impl DynamicReserve {
    /// No dynamic part.
    pub const NONE: DynamicReserve = DynamicReserve {
        nodes: 0,
        bricks: 0,
        occupied: 0,
        needed: 0,
    };

    /// Room for `nodes` dynamic nodes, as many bricks and needed nodes, and a quarter as
    /// many occupied nodes (an occupied node is needed with its 26 neighbours).
    pub fn new(nodes: u32) -> DynamicReserve {
        DynamicReserve {
            nodes,
            bricks: nodes,
            occupied: (nodes / 4).max(64),
            needed: nodes,
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
    /// Pass times: voxelization, clear, structure, bricks.
    pub timings: Vec<PassTiming>,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DynParams {
    sizes: [u32; 4],
    lists: [u32; 4],
    leaves: [u32; 4],
    last_need: [[u32; 4]; 16],
    last_nodes: [[u32; 4]; 16],
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
    /// Node count after the previous update.
    last_nodes: u32,
    /// The previous update's needed-list range per level.
    last_need: Vec<(u32, u32)>,
}

impl SvoDynamic {
    pub(crate) fn new(
        ctx: &GpuContext,
        reserve: DynamicReserve,
        node_capacity: u32,
        brick_capacity: u32,
    ) -> Option<SvoDynamic> {
        if reserve.nodes == 0 {
            return None;
        }
        let buffer = |label: &str, words: u64| {
            ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: (words * 4).max(16),
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_DST
                        | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            )
        };
        let sum_words = super::svo_inject::LEAF_SUM_WORDS as u64 * 8;
        Some(SvoDynamic {
            reserve,
            node_capacity,
            brick_capacity,
            state: buffer("dynamic state", node_capacity as u64),
            occupied: buffer("dynamic occupied list", reserve.occupied as u64),
            needed: [
                buffer("dynamic needed list 0", reserve.needed as u64),
                buffer("dynamic needed list 1", reserve.needed as u64),
            ],
            last: 1,
            sums: buffer("dynamic leaf sums", reserve.occupied as u64 * sum_words),
            last_nodes: node_capacity - reserve.nodes,
            last_need: Vec::new(),
        })
    }

    /// The per-node state buffer (dynamic leaf slots), for injection.
    pub(crate) fn state(&self) -> &wgpu::Buffer {
        &self.state
    }
}

/// Group 2 of the dynamic kernels: parameters, state, lists, sums.
pub(crate) fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    use super::svo::storage;
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

impl SvoBuilder {
    /// Replaces the dynamic part of `svo` (built with [`SvoBuilder::build_with_reserve`]) by
    /// the voxels of `tris`, leaving the static part as built. Call it every frame with the
    /// moving geometry at its current position; an empty `tris` removes the dynamic part.
    /// Afterwards the octree's structure, bricks and leaf sums are those of static + dynamic
    /// geometry together; [`SvoBuilder::inject`] lights both.
    ///
    /// Fails when the octree has no reserve, or when the dynamic geometry needs more nodes,
    /// bricks or list entries than reserved (the octree then holds a partial dynamic part
    /// until the next successful update).
    pub fn update_dynamic(
        &self,
        ctx: &GpuContext,
        svo: &mut Svo,
        tris: &[VoxelTriangle],
    ) -> Result<DynamicUpdate> {
        let depth = svo.levels.len() as u32;
        let Some(dynamic) = svo.dynamic.as_mut() else {
            return Err(Error::InvalidArgument(
                "this octree has no dynamic part: build it with SvoBuilder::build_with_reserve"
                    .into(),
            ));
        };
        if !(2..=MAX_DEPTH).contains(&depth) {
            return Err(Error::InvalidArgument(format!(
                "the dynamic part needs an octree of 2 to {MAX_DEPTH} levels, this one has {depth}"
            )));
        }
        let mut timings = Vec::new();
        let list = self
            .voxelizer
            .fragments(ctx, "svo dynamic", &svo.grid, tris, &mut timings)?;
        let (s, b) = (svo.static_nodes, svo.static_bricks);
        let mut params = DynParams {
            sizes: [s, b, dynamic.node_capacity, dynamic.brick_capacity],
            lists: [
                dynamic.last_nodes,
                dynamic.last_need.last().map_or(0, |r| r.1),
                dynamic.reserve.occupied,
                dynamic.reserve.needed,
            ],
            leaves: [svo.levels[depth as usize - 1].0, 1, 0, 0],
            last_need: [[0; 4]; 16],
            last_nodes: [[0; 4]; 16],
        };
        for (d, &(start, end)) in dynamic.last_need.iter().enumerate() {
            params.last_need[d] = [start, end, 0, 0];
        }
        for (d, &(start, end)) in svo.dynamic_levels.iter().enumerate() {
            params.last_nodes[d] = [start, end, 0, 0];
        }
        let params_buffer = ctx.create_buffer_init(
            OWNER,
            "dynamic params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let level_params_buffer = level_params(
            ctx,
            "dynamic level params",
            depth,
            list.count,
            dynamic.node_capacity,
            svo.pool_bricks,
        );
        // Counters: nodes and bricks restart after the static part; level 0 has no dynamic
        // nodes; lists are empty. The static level ranges (words 2..) stay.
        let q = &ctx.queue;
        q.write_buffer(&svo.control, 0, bytemuck::cast_slice(&[s, 0u32]));
        q.write_buffer(
            &svo.control,
            BRICK_COUNTER as u64 * 4,
            bytemuck::bytes_of(&b),
        );
        let mut tail = vec![0u32; CONTROL_WORDS as usize - DYN_NODES];
        tail[0] = s;
        tail[1] = s;
        q.write_buffer(
            &svo.control,
            DYN_NODES as u64 * 4,
            bytemuck::cast_slice(&tail),
        );

        let (this, last) = (1 - dynamic.last, dynamic.last);
        let group0 = self.group0(
            ctx,
            &level_params_buffer,
            [
                &list.buffer,
                &list.triangles,
                &svo.child,
                &svo.neighbours,
                &svo.coord,
                &svo.brick_index,
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
                (1, &params_buffer),
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
        let mut timer = PassTimer::new(ctx);
        let last_count = params.lists[1];
        self.record(
            &mut timer,
            "svo dynamic clear",
            &group0,
            (&args_group, Some(&group1)),
            &svo.args,
            0,
            &[
                ("dyn_unlink", 0, Dispatch::Capacity(dynamic.last_nodes - s)),
                ("dyn_reset", 0, Dispatch::Capacity(last_count)),
            ],
        );
        let cap = dynamic.node_capacity as u64;
        timer.untimed(|encoder| {
            let from = s as u64 * 4;
            encoder.clear_buffer(&svo.child, from, Some((cap - s as u64) * 4));
            encoder.clear_buffer(&svo.neighbours, from * 3, Some((cap - s as u64) * 12));
            encoder.clear_buffer(&svo.brick_index, from, Some((cap - s as u64) * 4));
            encoder.clear_buffer(&dynamic.state, from, Some((cap - s as u64) * 4));
            encoder.clear_buffer(&dynamic.sums, 0, None);
        });

        let mut steps = Vec::new();
        for d in 0..depth {
            steps.push(("dyn_flag_occupied", d, Dispatch::Fragments));
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
        let args = &svo.args;
        self.record(
            &mut timer,
            "svo dynamic structure",
            &group0,
            (&args_group, Some(&group1)),
            args,
            list.count,
            &steps,
        );

        let leaf = depth - 1;
        let mut steps = vec![("dyn_accumulate", leaf, Dispatch::Fragments)];
        let mut dirty_last = 0;
        for d in (0..depth).rev() {
            let entry = if d == leaf {
                "dyn_leaf_gather"
            } else {
                "dyn_mip_gather"
            };
            steps.push((entry, d, Dispatch::Indirect(ARGS_NEED + d)));
            if let Some(&(start, end)) = dynamic.last_need.get(d as usize) {
                if end > start {
                    steps.push((entry, depth + d, Dispatch::Capacity(end - start)));
                    dirty_last += end - start;
                }
            }
        }
        self.record(
            &mut timer,
            "svo dynamic bricks",
            &group0,
            (&args_group, Some(&group1)),
            args,
            list.count,
            &steps,
        );
        timings.extend(timer.finish_frame()?);

        let control: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(ctx, &svo.control, 0, CONTROL_WORDS * 4)?).to_vec();
        let node_count = control[0].min(dynamic.node_capacity);
        let brick_count = control[BRICK_COUNTER].min(dynamic.brick_capacity);
        let need_count = control[NEED_COUNT].min(dynamic.reserve.needed);
        svo.node_count = node_count;
        svo.brick_count = brick_count;
        svo.fragment_count = list.count;
        svo.dynamic_levels = (0..depth as usize)
            .map(|d| (control[DYN_NODES + 2 * d], control[DYN_NODES + 2 * d + 1]))
            .collect();
        dynamic.last_nodes = node_count;
        dynamic.last_need = (0..depth as usize)
            .map(|d| (control[NEED_RANGE + 2 * d], control[NEED_RANGE + 2 * d + 1]))
            .collect();
        dynamic.last = this;
        for label in ["fragments", "triangles"] {
            ctx.ledger.record("svo dynamic", label, 0);
        }
        for label in ["dynamic params", "dynamic level params"] {
            ctx.ledger.record(OWNER, label, 0);
        }
        let reserve = dynamic.reserve;
        let exhausted = if control[1] != 0 {
            Some(format!("nodes ({} reserved)", reserve.nodes))
        } else if control[DYN_OVERFLOW] == 2 {
            Some(format!("bricks ({} reserved)", reserve.bricks))
        } else if control[DYN_OVERFLOW] != 0 {
            Some(format!(
                "occupied or needed nodes ({} / {} reserved; {} occupied, {} needed)",
                reserve.occupied, reserve.needed, control[OCC_COUNT], control[NEED_COUNT]
            ))
        } else {
            None
        };
        if let Some(what) = exhausted {
            return Err(Error::InvalidArgument(format!(
                "the octree's dynamic reserve is too small for {} dynamic triangles: it ran out \
                 of {what}; build it with a larger DynamicReserve",
                tris.len()
            )));
        }
        Ok(DynamicUpdate {
            fragments: list.count,
            nodes: node_count - s,
            bricks: brick_count - b,
            dirty: need_count + dirty_last,
            timings,
        })
    }
}
