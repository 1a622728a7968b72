//! Sparse voxel octree with a corner-sampled brick pool, built on the GPU level by level
//! (Arnebäck 2017 §3.1): flag occupied nodes from the voxel fragments, flag the 26 neighbours
//! of every occupied node, subdivide flagged nodes (8 children allocated with an atomic
//! counter), link neighbours; then fill the leaf bricks, transfer between neighbours and mipmap
//! bottom-up, transferring again on every level.
//!
//! Layout (struct-of-arrays, 5 words per node): `child` (first of 8 contiguous children),
//! `neighbours` (+x, +y, +z on the same level) and `brick_index` (brick + 1, 0 = none). Only
//! *needed* nodes (occupied or next to an occupied node) get a brick: the others exist because
//! a sibling is needed, and their lattice is provably all zero. A brick is 3x3x3 RGBA8 texels
//! (premultiplied albedo, opacity) on the node's corners, edge midpoints, face centres and
//! centre: 108 bytes. The build accumulates, transfers and filters in an RGBA16F pool (216
//! bytes per brick) that is converted and released at the end.
//!
//! The values define one corner-sampled lattice per level: on the finest level, each lattice
//! point (a voxel corner) holds the sum of the touching voxels' values / 8; each coarser
//! level applies the separable [1/4 1/2 1/4] filter ([`crate::voxel::svo::cpu::lattices`] is the reference).
//! A brick holds the lattice restricted to its node, so neighbouring bricks agree on their
//! shared faces, and trilinear interpolation inside a brick is continuous across nodes.
//!
//! Besides albedo and opacity the octree keeps, per leaf voxel, the sums of its fragments'
//! albedo, emission and normal, and an RGBA16F radiance pool (radiance, opacity) in the same
//! brick layout: [`SvoBuilder::inject`] fills it with emission + albedo/pi x direct irradiance
//! (visibility from the renderer's shadow maps) and filters it with the same transfer and mip
//! passes ([`crate::voxel::svo::inject`]). An octree built [`SvoBuilder::with_facing`] also
//! keeps a facing pool, the direction the radiance leaves in, filtered in the same dispatches.
//!
//! Moving geometry goes into a dynamic part ([`crate::voxel::svo::dynamic`], Arnebäck 2017 §3.1.7):
//! an octree built with [`SvoBuilder::build_with_reserve`] keeps room for dynamic nodes and
//! bricks after its static ones, and [`SvoBuilder::record_dynamic`] replaces the dynamic part
//! each frame without voxelizing or rebuilding the static one, and without waiting for the GPU.

pub mod aniso;
pub mod aniso_radiance;
mod bindings;
mod build;
mod control;
pub mod cpu;
pub mod dynamic;
pub mod inject;
mod limits;
#[cfg(test)]
mod mirrors;
mod octree;
mod pack;
mod pipelines;
pub mod sample;
mod steps;
pub mod walk;

pub use octree::{Svo, SvoCpu};
pub use pipelines::SvoBuilder;

/// Ledger owner of the octree's buffers.
pub const OWNER: &str = "svo";

/// A buffer of the octree of `words` 32-bit words (at least 16 bytes), under [`OWNER`]: the
/// build's kept buffers and the dynamic part's.
pub(crate) fn word_buffer(
    ctx: &crate::gpu::GpuContext,
    label: &str,
    words: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    ctx.create_buffer(
        OWNER,
        &wgpu::BufferDescriptor {
            label: Some(label),
            size: (words * 4).max(16),
            usage,
            mapped_at_creation: false,
        },
    )
}
/// Words per brick while building (27 texels x RGBA16F).
pub const BUILD_BRICK_WORDS: u32 = 54;
/// Words per brick of the finished pool (27 texels x RGBA8).
pub const BRICK_WORDS: u32 = 27;
/// Bytes per node: child, 3 neighbours, brick index.
pub const NODE_BYTES: u64 = 20;
/// Most buffers a brick pool is split over (one storage binding each).
pub const POOLS: u32 = 4;
