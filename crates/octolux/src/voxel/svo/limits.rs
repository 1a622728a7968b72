//! What a GPU can hold of an octree: every per-node array and every brick pool buffer is one
//! storage binding, so `max_storage_buffer_binding_size` bounds the nodes (the neighbour
//! array, 12 bytes per node, is the largest) and the bricks per pool buffer; the pool is
//! split over at most [`POOLS`] bindings. The errors say what ran out and what to change.

use crate::gpu::GpuContext;
use crate::voxel::svo::dynamic::DynamicReserve;
use crate::voxel::svo::{BUILD_BRICK_WORDS, POOLS};
use crate::{Error, Result};

/// Most nodes an octree may have on this GPU (also kept below `u32::MAX / 64`, so that
/// dispatch sizes and word indices stay in `u32`).
pub(super) fn max_nodes(ctx: &GpuContext) -> u32 {
    // The neighbour array (3 words per node) is the largest per-node array.
    (ctx.device.limits().max_storage_buffer_binding_size / 12).min(u32::MAX as u64 / 64) as u32
}

/// Most RGBA16F bricks one pool buffer may hold on this GPU.
pub(super) fn max_pool_bricks(ctx: &GpuContext) -> u32 {
    (ctx.device.limits().max_storage_buffer_binding_size / (BUILD_BRICK_WORDS as u64 * 4))
        .min(u32::MAX as u64 / 64) as u32
}

/// The octree's size in the GPU's terms: the structure pass found `nodes` and `bricks`, and
/// the dynamic reserve comes on top.
pub(super) struct Capacity {
    /// Nodes of the static part plus the reserve's.
    pub(super) nodes: u32,
    /// Bricks of the static part plus the reserve's.
    pub(super) bricks: u32,
}

impl Capacity {
    /// The capacity of an octree of `nodes` and `bricks` at `resolution` with `reserve`, or
    /// the error that says what does not fit in pools of `pool_bricks`.
    pub(super) fn check(
        ctx: &GpuContext,
        resolution: u32,
        (nodes, bricks): (u32, u32),
        reserve: DynamicReserve,
        pool_bricks: u32,
    ) -> Result<Capacity> {
        let brick_capacity = bricks as u64 + reserve.bricks as u64;
        if brick_capacity.div_ceil(pool_bricks as u64).max(1) > POOLS as u64 {
            return Err(Error::InvalidArgument(format!(
                "the octree at {resolution}^3 has {nodes} nodes and needs {bricks} bricks (+ \
                 {} reserved for dynamic geometry); this GPU can bind at most {} ({POOLS} \
                 storage bindings of {pool_bricks} RGBA16F bricks); use a lower resolution or \
                 a smaller reserve",
                reserve.bricks,
                POOLS * pool_bricks
            )));
        }
        let max_nodes = max_nodes(ctx) as u64;
        let node_capacity = nodes as u64 + reserve.nodes as u64;
        if node_capacity > max_nodes {
            return Err(Error::InvalidArgument(format!(
                "the octree at {resolution}^3 has {nodes} nodes; with {} reserved for dynamic \
                 geometry it needs more than this GPU can bind ({max_nodes}); reserve fewer",
                reserve.nodes
            )));
        }
        Ok(Capacity {
            nodes: node_capacity as u32,
            bricks: brick_capacity as u32,
        })
    }
}

/// The error for a structure that outgrew every node capacity this GPU can bind.
pub(super) fn too_many_nodes(resolution: u32, max_nodes: u32) -> Error {
    Error::InvalidArgument(format!(
        "the octree at {resolution}^3 needs more than {max_nodes} nodes, more than this GPU can \
         bind; use a lower resolution"
    ))
}
