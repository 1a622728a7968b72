//! The dynamic part's GPU state, kept between updates ([`SvoDynamic`]): the per-node state,
//! the occupied and needed lists, the dynamic leaf sums and fragments, the parameter block
//! ([`DynParams`]) and the control block every update starts from; and what an update records
//! around its kernels: the restart of the counters and the clearing of the dynamic section.

use super::ring::{Readback, READBACK_SLOTS};
use super::DynamicReserve;
use crate::gpu::pass::KeptBindGroup;
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::svo::control::{level_params, NodeRange, SvoControl, CONTROL_BYTES, MAX_LEVELS};
use crate::voxel::svo::{word_buffer, Svo, OWNER};
use crate::voxel::VoxelTriangle;

/// Byte offset of `last` (the previous update's control block) in the parameter block.
pub(super) const PARAMS_LAST: u64 = std::mem::offset_of!(DynParams, last) as u64;

/// `DynParams` of `svo/dynamic.wgsl`: the dynamic update's constants, then the previous
/// update's control block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct DynParams {
    /// Nodes and bricks of the static part (the dynamic ones follow).
    pub static_nodes: u32,
    pub static_bricks: u32,
    /// Nodes and bricks the pools hold: the static part and the reserve.
    pub node_capacity: u32,
    pub brick_capacity: u32,
    /// Capacities of the fragment list and of the occupied and needed lists.
    pub fragment_capacity: u32,
    pub occupied_capacity: u32,
    pub needed_capacity: u32,
    pub first_static_leaf: u32,
    /// The control block as the previous update left it, copied there on the GPU.
    pub last: SvoControl,
}

/// GPU state of the dynamic part, kept between updates.
pub(crate) struct SvoDynamic {
    pub(in crate::voxel::svo) reserve: DynamicReserve,
    pub(in crate::voxel::svo) node_capacity: u32,
    pub(in crate::voxel::svo) brick_capacity: u32,
    /// Per node: dynamic occupied / needed bits and the leaf's slot in `sums`.
    pub(in crate::voxel::svo) state: wgpu::Buffer,
    pub(in crate::voxel::svo) occupied: wgpu::Buffer,
    /// Needed lists of this and of the previous update (swapped every update).
    pub(in crate::voxel::svo) needed: [wgpu::Buffer; 2],
    /// Which of `needed` holds the previous update's list.
    pub(in crate::voxel::svo) last: usize,
    /// Per occupied dynamic leaf: fragment sums of its 8 voxels, as `Svo::leaf_sums`.
    pub(in crate::voxel::svo) sums: wgpu::Buffer,
    /// The dynamic fragments of the current update (reserve.fragments x 8 bytes).
    pub(in crate::voxel::svo) fragments: wgpu::Buffer,
    /// [`DynParams`].
    pub(in crate::voxel::svo) params: wgpu::Buffer,
    /// Per-level parameter slots of the dynamic kernels.
    pub(in crate::voxel::svo) level_params: wgpu::Buffer,
    /// The control block at the start of every update (static ranges and counts, empty
    /// dynamic ranges, zero counters), copied over `control` on the GPU.
    pub(in crate::voxel::svo) reset: wgpu::Buffer,
    pub(super) readbacks: Vec<Readback>,
    /// Updates recorded so far.
    pub(in crate::voxel::svo) recorded: u64,
    /// The latest update whose counts `Svo` holds.
    pub(in crate::voxel::svo) applied: u64,
    /// The triangles the latest update voxelized and their upload, which the fragment list
    /// still holds the fragments of: an update of the same triangles keeps both.
    pub(in crate::voxel::svo) triangles: Option<(Vec<VoxelTriangle>, wgpu::Buffer)>,
    /// The update's bind groups, kept while the buffers they bind are.
    pub(in crate::voxel::svo) groups: DynamicGroups,
}

/// The bind groups of the dynamic kernels: group 0 (made again when the triangles are
/// uploaded again), group 1 and group 2 per needed list written.
#[derive(Default)]
pub(crate) struct DynamicGroups {
    pub(in crate::voxel::svo) group0: KeptBindGroup,
    pub(in crate::voxel::svo) args: KeptBindGroup,
    pub(in crate::voxel::svo) group2: [KeptBindGroup; 2],
}

/// What [`SvoDynamic::new`] needs of the static part.
pub(crate) struct StaticPart {
    pub node_capacity: u32,
    pub brick_capacity: u32,
    pub depth: u32,
    pub pool_bricks: u32,
    pub first_leaf: u32,
    /// The build's control block (static level ranges and counts).
    pub control: SvoControl,
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
        let buffer = |label: &str, words: u64| word_buffer(ctx, label, words, usage);
        let reset = reset_control(&part.control);
        // `last`: the control block as the build left it (its node count is the static one and
        // its dynamic ranges are empty: nothing to undo).
        let params = DynParams {
            static_nodes: part.control.node_count,
            static_bricks: part.control.brick_count,
            node_capacity: part.node_capacity,
            brick_capacity: part.brick_capacity,
            fragment_capacity: reserve.fragments,
            occupied_capacity: reserve.occupied,
            needed_capacity: reserve.needed,
            first_static_leaf: part.first_leaf,
            last: reset,
        };
        let params =
            ctx.create_buffer_init(OWNER, "dynamic params", bytemuck::bytes_of(&params), usage);
        let reset = ctx.create_buffer_init(
            OWNER,
            "dynamic control reset",
            bytemuck::bytes_of(&reset),
            wgpu::BufferUsages::COPY_SRC,
        );
        let readbacks = (0..READBACK_SLOTS).map(|k| Readback::new(ctx, k)).collect();
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
            triangles: None,
            groups: DynamicGroups::default(),
        })
    }

    /// The per-node state buffer (dynamic leaf slots), for injection.
    pub(crate) fn state(&self) -> &wgpu::Buffer {
        &self.state
    }
}

/// The control block at the start of every update: the static part's counts and level
/// ranges, no overflow, empty dynamic ranges and lists (the dynamic nodes of level 0, below
/// which the first are allocated, start and end after the static nodes).
fn reset_control(built: &SvoControl) -> SvoControl {
    let s = built.node_count;
    let empty = [NodeRange::default(); MAX_LEVELS];
    let mut dynamic_levels = empty;
    dynamic_levels[0] = NodeRange { first: s, end: s };
    SvoControl {
        node_count: s,
        node_overflow: 0,
        brick_count: built.brick_count,
        dynamic_overflow: 0,
        dynamic_fragments: 0,
        occupied_count: 0,
        needed_count: 0,
        pad: 0,
        levels: built.levels,
        dynamic_levels,
        occupied_ranges: empty,
        needed_ranges: empty,
    }
}

/// Group 2 of the dynamic kernels: parameters, state, lists, sums.
pub(crate) fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    use crate::gpu::storage_entry;
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
        storage_entry(2, false),
        storage_entry(3, false),
        storage_entry(4, false),
        storage_entry(5, true),
        storage_entry(6, false),
        storage_entry(7, true),
    ]);
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("svo dynamic"),
        entries: &entries,
    })
}

impl SvoDynamic {
    /// Records the copy of the previous update's control block into the parameter block and
    /// the reset of the control block.
    pub(super) fn restart(&self, timer: &mut PassTimer, control: &wgpu::Buffer) {
        timer.untimed(|encoder| {
            encoder.copy_buffer_to_buffer(
                control,
                0,
                &self.params,
                PARAMS_LAST,
                Some(CONTROL_BYTES),
            );
            encoder.copy_buffer_to_buffer(&self.reset, 0, control, 0, Some(CONTROL_BYTES));
        });
    }

    /// Records, for an update of the previous update's triangles, the restoring of its
    /// fragment count into the control block (after [`SvoDynamic::restart`]): the fragment
    /// list still holds its fragments, so they need no new voxelization.
    pub(super) fn keep_fragments(&self, timer: &mut PassTimer, control: &wgpu::Buffer) {
        let count = std::mem::offset_of!(SvoControl, dynamic_fragments) as u64;
        timer.untimed(|encoder| {
            encoder.copy_buffer_to_buffer(
                &self.params,
                PARAMS_LAST + count,
                control,
                count,
                Some(4),
            );
        });
    }

    /// Records the clearing of the dynamic section: the nodes after the static part (links,
    /// bricks, state) and the dynamic leaf sums.
    pub(super) fn clear_section(&self, timer: &mut PassTimer, svo: &Svo) {
        let (s, cap) = (svo.static_nodes as u64, self.node_capacity as u64);
        timer.untimed(|encoder| {
            let from = s * 4;
            encoder.clear_buffer(&svo.child, from, Some((cap - s) * 4));
            encoder.clear_buffer(&svo.neighbours, from * 3, Some((cap - s) * 12));
            encoder.clear_buffer(&svo.brick_plus_one, from, Some((cap - s) * 4));
            encoder.clear_buffer(&self.state, from, Some((cap - s) * 4));
            encoder.clear_buffer(&self.sums, 0, None);
        });
    }
}
