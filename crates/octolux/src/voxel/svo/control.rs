//! The blocks the octree's kernels share with the Rust that drives them, each a `#[repr(C)]`
//! struct mirroring the WGSL struct of the same name (`svo/control.wgsl`; a test compares
//! their field offsets): the control block ([`SvoControl`]: node and brick counters and the
//! node range of every level, counted on the GPU and read back once by the build and after
//! every dynamic update), the per-level parameter slots ([`LevelParams`]), and the indirect
//! dispatch argument slots the `finish` kernels write.

use crate::gpu::pass::SLOT;
use crate::gpu::GpuContext;
use crate::voxel::svo::OWNER;
use bytemuck::Zeroable;

/// Levels of the deepest octree ([`crate::voxel::MAX_RESOLUTION`]^3 voxels; `MAX_LEVELS` in
/// `svo/control.wgsl`).
pub(crate) const MAX_LEVELS: usize = crate::voxel::MAX_RESOLUTION.trailing_zeros() as usize;

/// The nodes `[first, end)` of one level (or the entries of a list).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct NodeRange {
    pub first: u32,
    pub end: u32,
}

impl NodeRange {
    pub(crate) fn pair(self) -> (u32, u32) {
        (self.first, self.end)
    }
}

/// The octree's control block (`SvoControl` in `svo/control.wgsl`, counted with atomics; read
/// as `SvoControlValues`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SvoControl {
    /// Nodes allocated so far: the next free node.
    pub node_count: u32,
    /// 1 when a subdivision found no room below the node capacity.
    pub node_overflow: u32,
    /// Bricks allocated so far.
    pub brick_count: u32,
    /// What the dynamic update ran out of: 1 a list, 2 the brick reserve.
    pub dynamic_overflow: u32,
    /// Dynamic fragments appended by the voxelization (may exceed the list's capacity).
    pub dynamic_fragments: u32,
    /// Entries appended to the dynamic occupied list.
    pub occupied_count: u32,
    /// Entries appended to the dynamic needed list.
    pub needed_count: u32,
    pub pad: u32,
    /// Static nodes of every level.
    pub levels: [NodeRange; MAX_LEVELS],
    /// Dynamic nodes of every level.
    pub dynamic_levels: [NodeRange; MAX_LEVELS],
    /// Entries of the dynamic occupied list, per level.
    pub occupied_ranges: [NodeRange; MAX_LEVELS],
    /// Entries of the dynamic needed list, per level.
    pub needed_ranges: [NodeRange; MAX_LEVELS],
}

/// Bytes of the control block.
pub(crate) const CONTROL_BYTES: u64 = std::mem::size_of::<SvoControl>() as u64;

/// `SvoControl::dynamic_overflow` when the brick reserve ran out (`BRICK_OVERFLOW` in
/// `svo/dynamic.wgsl`; any other nonzero value: a list ran out).
pub(crate) const BRICK_OVERFLOW: u32 = 2;

impl SvoControl {
    /// The block before the structure pass: the root alone on level 0, allocated.
    pub(crate) fn at_root() -> SvoControl {
        let mut control = SvoControl::zeroed();
        control.node_count = 1;
        control.levels[0] = NodeRange { first: 0, end: 1 };
        control
    }

    /// The block read back from `bytes` (a buffer's first [`CONTROL_BYTES`]).
    pub(crate) fn from_bytes(bytes: &[u8]) -> SvoControl {
        bytemuck::pod_read_unaligned(&bytes[..CONTROL_BYTES as usize])
    }

    /// The node ranges of the first `depth` levels.
    pub(crate) fn level_ranges(&self, depth: u32) -> Vec<(u32, u32)> {
        self.levels[..depth as usize]
            .iter()
            .map(|r| r.pair())
            .collect()
    }

    /// The dynamic node ranges of the first `depth` levels.
    pub(crate) fn dynamic_level_ranges(&self, depth: u32) -> Vec<(u32, u32)> {
        self.dynamic_levels[..depth as usize]
            .iter()
            .map(|r| r.pair())
            .collect()
    }
}

/// Byte offset of indirect dispatch slot `slot` in the arguments buffer (`args` of
/// `svo/build.wgsl`).
pub(crate) fn args_offset(slot: u32) -> u64 {
    crate::gpu::pass::indirect_offset(slot)
}

/// Indirect dispatch slots (`DispatchArgs` each): static levels, dynamic levels, dynamic lists and
/// the dynamic update's own sizes (`svo/dynamic.wgsl`); each slot again from `NODE_ARGS` on,
/// sized for one workgroup per entry.
pub(crate) const ARGS_SLOTS: u64 = 2 * NODE_ARGS as u64;
/// Slot `s + NODE_ARGS` holds slot `s`'s count as one workgroup per entry (`NODE_ARGS` in
/// `svo/build.wgsl`).
pub(crate) const NODE_ARGS: u32 = 96;
/// First indirect slot of the dynamic node ranges (`ARGS_DYN_NODES` in `svo/dynamic.wgsl`).
pub(crate) const ARGS_DYN_NODES: u32 = 16;

/// Parameters of one level of the octree kernels (`LevelParams` in `svo/common.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LevelParams {
    pub d: u32,
    pub depth: u32,
    pub fragments: u32,
    pub capacity: u32,
    pub pool_bricks: u32,
    /// 0: the level's static nodes; 1: its dynamic nodes (or, for the dynamic update's
    /// gather kernels, the previous update's dirty list).
    pub range: u32,
    pub pad: [u32; 2],
}

/// Read-only storage buffer of one [`LevelParams`] per slot ([`SLOT`] bytes apart):
/// slot `d` walks level `d`'s static nodes, slot `depth + d` its dynamic ones.
pub(crate) fn level_params(
    ctx: &GpuContext,
    label: &str,
    depth: u32,
    fragments: u32,
    capacity: u32,
    pool_bricks: u32,
) -> wgpu::Buffer {
    let mut params = vec![0u8; SLOT as usize * 2 * depth as usize];
    for slot in 0..2 * depth {
        let p = LevelParams {
            d: slot % depth,
            depth,
            fragments,
            capacity,
            pool_bricks,
            range: slot / depth,
            pad: [0; 2],
        };
        let at = slot as usize * SLOT as usize;
        params[at..at + 32].copy_from_slice(bytemuck::bytes_of(&p));
    }
    ctx.create_buffer_init(OWNER, label, &params, wgpu::BufferUsages::STORAGE)
}
