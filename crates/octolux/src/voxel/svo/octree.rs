//! The octree object: the GPU buffers a finished [`Svo`] keeps (nodes, brick pools, the
//! control block and dispatch arguments the later passes read), its accessors, and the
//! read-backs tests and tools use ([`Svo::read_back`] into an [`SvoCpu`], the radiance and
//! facing pools, the leaf voxels' radiance).

use crate::gpu::pack::{unpack_half4, unpack_unorm8};
use crate::gpu::{read_buffer, GpuContext};
use crate::voxel::svo::control::{args_offset, ARGS_DYN_NODES, NODE_ARGS};
use crate::voxel::svo::{BRICK_WORDS, BUILD_BRICK_WORDS, NODE_BYTES};
use crate::voxel::VoxelGrid;
use crate::Result;

/// A sparse voxel octree on the GPU.
pub struct Svo {
    /// The voxel grid the finest level resolves.
    pub(super) grid: VoxelGrid,
    /// Number of nodes (all levels). With a dynamic part, as of the latest dynamic update
    /// read back ([`Svo::poll_dynamic`], [`Svo::sync_dynamic`]).
    pub(super) node_count: u32,
    /// `array<u32>`: first child index, 0 = none.
    pub(super) child: wgpu::Buffer,
    /// `array<u32>`, a bit per static node (bit n % 32 of word n / 32): its cell holds a voxel
    /// of the static geometry. Nodes without one are subdivided where they border one (for
    /// the bricks' lattice); the visibility walk skips them whole.
    pub(super) static_occupied: wgpu::Buffer,
    /// `array<u32>`, 3 per node: +x, +y, +z neighbour, 0 = none.
    pub(super) neighbours: wgpu::Buffer,
    /// The brick pool, split over [`POOLS`] buffers (unused ones are 16-byte placeholders):
    /// brick `b` is slot `b % pool_bricks` of buffer `b / pool_bricks`, [`BRICK_WORDS`] words
    /// (27 texels as `pack4x8unorm`).
    pub(super) bricks: Vec<wgpu::Buffer>,
    /// Bricks per pool buffer.
    pub(super) pool_bricks: u32,
    /// `array<u32>`: per node, its brick index + 1 (0 = no brick, an all-zero lattice).
    pub(super) brick_plus_one: wgpu::Buffer,
    /// Number of bricks (with a dynamic part: as [`Svo::node_count`]).
    pub(super) brick_count: u32,
    /// Bricks the pools hold: the static part's and the dynamic reserve's.
    pub(super) brick_capacity: u32,
    /// Node index range of every level.
    pub(super) levels: Vec<(u32, u32)>,
    /// Voxel fragments the octree was built from; after a dynamic update, those of its
    /// dynamic triangles (as [`Svo::node_count`]).
    pub(super) fragment_count: u32,
    /// `array<u32>`: per node, its packed coordinates on its level (10 bits per axis).
    pub(super) coord: wgpu::Buffer,
    /// Counters and level ranges (`SvoControl` of `svo/control.wgsl`), kept for the passes
    /// that run per level after the build (injection) and for the dynamic updates.
    pub(super) control: wgpu::Buffer,
    /// Indirect dispatch sizes per level.
    pub(super) args: wgpu::Buffer,
    /// Per-level parameters (one 256-byte slot per level).
    pub(super) level_params: wgpu::Buffer,
    /// Fragment sums of albedo, emission and normal of the static part's occupied leaf voxels
    /// (`voxel/svo/leaf_sums.wgsl`: an index word per static leaf node, then
    /// [`crate::voxel::svo::inject::LEAF_SUM_WORDS`] words per occupied voxel).
    pub(super) leaf_sums: wgpu::Buffer,
    /// Radiance pool, split like [`Svo::bricks`]: [`BUILD_BRICK_WORDS`] words per brick,
    /// 27 texels of RGBA16F (radiance, opacity). Zero until [`SvoBuilder::inject`].
    pub(super) radiance: Vec<wgpu::Buffer>,
    /// Facing pool ([`SvoBuilder::with_facing`]), split and laid out like `radiance`: per
    /// texel the sum of the radiance's weight (r + g + b) times the direction its surface
    /// faces, filtered as the radiance (RGBA16F: xyz, 0). `None` without facing.
    pub(super) facing: Option<Vec<wgpu::Buffer>>,
    /// Injected radiance and opacity per leaf voxel (RGBA16F): static leaves in the order of
    /// `leaf_sums`, then the dynamic leaves in node order.
    pub(super) voxel_radiance: wgpu::Buffer,
    /// Nodes of the static part (`[0, static_nodes)`); dynamic nodes follow.
    pub(super) static_nodes: u32,
    /// Bricks of the static part; dynamic bricks follow.
    pub(super) static_bricks: u32,
    /// Node index range of every level's dynamic nodes (empty without a dynamic part; as
    /// [`Svo::node_count`]).
    pub(super) dynamic_levels: Vec<(u32, u32)>,
    /// Room for the dynamic part, `None` for an octree built without a reserve.
    pub(super) dynamic: Option<crate::voxel::svo::dynamic::SvoDynamic>,
}

/// The octree read back to the CPU (for tests and tools).
#[derive(Clone, Debug)]
pub struct SvoCpu {
    /// First child per node.
    pub child: Vec<u32>,
    /// +x, +y, +z neighbours per node.
    pub neighbours: Vec<[u32; 3]>,
    /// 27 RGBA texels per brick (texel `i + 3j + 9k`).
    pub bricks: Vec<[glam::Vec4; 27]>,
    /// Per node, its brick index + 1 (0 = none).
    pub brick_of: Vec<u32>,
    /// Static node range per level.
    pub levels: Vec<(u32, u32)>,
    /// Dynamic node range per level (empty without a dynamic part).
    pub dynamic_levels: Vec<(u32, u32)>,
}

impl SvoCpu {
    /// The texels of node `n` (zeros when it has no brick).
    pub fn node_brick(&self, n: u32) -> [glam::Vec4; 27] {
        match self.brick_of[n as usize] {
            0 => [glam::Vec4::ZERO; 27],
            b => self.bricks[b as usize - 1],
        }
    }

    /// Coordinates of every node on its level, found by walking down from the root.
    pub fn coordinates(&self) -> Vec<[u32; 3]> {
        let mut coords = vec![[0u32; 3]; self.child.len()];
        let none = (0, 0);
        for (d, &stat) in self.levels.iter().enumerate() {
            let dynamic = self.dynamic_levels.get(d).copied().unwrap_or(none);
            for n in (stat.0..stat.1).chain(dynamic.0..dynamic.1) {
                let first = self.child[n as usize];
                if first != 0 {
                    let c = coords[n as usize];
                    for o in 0..8u32 {
                        coords[(first + o) as usize] = [
                            c[0] * 2 + (o & 1),
                            c[1] * 2 + ((o >> 1) & 1),
                            c[2] * 2 + (o >> 2),
                        ];
                    }
                }
            }
        }
        coords
    }
}

impl Svo {
    /// The voxel grid the finest level resolves.
    pub fn grid(&self) -> &VoxelGrid {
        &self.grid
    }

    /// Number of nodes (all levels); with a dynamic part, as of the latest dynamic update
    /// read back ([`Svo::poll_dynamic`], [`Svo::sync_dynamic`]).
    pub fn node_count(&self) -> u32 {
        self.node_count
    }

    /// Number of bricks (with a dynamic part: as [`Svo::node_count`]).
    pub fn brick_count(&self) -> u32 {
        self.brick_count
    }

    /// Bricks per pool buffer ([`crate::voxel::svo::sample::SvoInfo::new`] takes it).
    pub fn pool_bricks(&self) -> u32 {
        self.pool_bricks
    }

    /// Node index range of every level.
    pub fn levels(&self) -> &[(u32, u32)] {
        &self.levels
    }

    /// Node index range of every level's dynamic nodes (empty without a dynamic part).
    pub fn dynamic_levels(&self) -> &[(u32, u32)] {
        &self.dynamic_levels
    }

    /// Nodes of the static part (`[0, static_nodes)`); dynamic nodes follow.
    pub fn static_nodes(&self) -> u32 {
        self.static_nodes
    }

    /// Bricks of the static part; dynamic bricks follow.
    pub fn static_bricks(&self) -> u32 {
        self.static_bricks
    }

    /// Voxel fragments the octree was built from; after a dynamic update, those of its
    /// dynamic triangles.
    pub fn fragment_count(&self) -> u32 {
        self.fragment_count
    }

    /// Whether the octree has room for a dynamic part (it was built with a reserve).
    pub fn has_dynamic(&self) -> bool {
        self.dynamic.is_some()
    }

    /// The octree's control block, counters and level ranges (`SvoControlValues` of
    /// `svo/control.wgsl` for a pass that reads it): the dynamic leaf range a pass over the
    /// dynamic leaves reads.
    pub fn control(&self) -> &wgpu::Buffer {
        &self.control
    }

    /// The indirect dispatch arguments (buffer, byte offset) of one workgroup per dynamic leaf
    /// node, as the latest dynamic update left them on the GPU.
    pub fn dynamic_leaf_dispatch(&self) -> (&wgpu::Buffer, u64) {
        let leaf = self.levels.len().saturating_sub(1) as u32;
        let slot = ARGS_DYN_NODES + leaf + NODE_ARGS;
        (&self.args, args_offset(slot))
    }

    /// Bytes the octree keeps on the GPU (nodes + bricks).
    pub fn bytes(&self) -> u64 {
        self.node_count as u64 * NODE_BYTES + self.brick_count as u64 * BRICK_WORDS as u64 * 4
    }

    /// Reads the octree back.
    pub fn read_back(&self, ctx: &GpuContext) -> Result<SvoCpu> {
        let n = self.node_count as u64;
        let child: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(ctx, &self.child, 0, n * 4)?).to_vec();
        let nbr: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(ctx, &self.neighbours, 0, n * 12)?).to_vec();
        let mut words: Vec<u32> = Vec::new();
        let mut left = self.brick_count as u64;
        for pool in &self.bricks {
            let bricks = left.min(self.pool_bricks as u64);
            if bricks == 0 {
                break;
            }
            let bytes = read_buffer(ctx, pool, 0, bricks * BRICK_WORDS as u64 * 4)?;
            words.extend_from_slice(bytemuck::cast_slice(&bytes));
            left -= bricks;
        }
        let brick_of: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(ctx, &self.brick_plus_one, 0, n * 4)?).to_vec();
        let bricks = words
            .chunks_exact(BRICK_WORDS as usize)
            .map(|b| std::array::from_fn(|t| unpack_unorm8(b[t])))
            .collect();
        Ok(SvoCpu {
            child,
            neighbours: nbr.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            bricks,
            brick_of,
            levels: self.levels.clone(),
            dynamic_levels: self.dynamic_levels.clone(),
        })
    }
}

impl Svo {
    /// Reads the radiance pool back: 27 (radiance, opacity) texels per brick, brick order as
    /// [`SvoCpu::bricks`] (so an [`SvoCpu`] with these bricks samples radiance).
    pub fn read_radiance(&self, ctx: &GpuContext) -> Result<Vec<[glam::Vec4; 27]>> {
        self.read_half_pools(ctx, &self.radiance)
    }

    /// Reads the facing pool back ([`SvoBuilder::with_facing`]): 27 (facing sum, 0) texels per
    /// brick, brick order as [`SvoCpu::bricks`]; `None` for an octree without facing.
    pub fn read_facing(&self, ctx: &GpuContext) -> Result<Option<Vec<[glam::Vec4; 27]>>> {
        self.facing
            .as_ref()
            .map(|pools| self.read_half_pools(ctx, pools))
            .transpose()
    }

    /// The bricks of a pool of 27 RGBA16F texels per brick, split like [`Svo::bricks`].
    fn read_half_pools(
        &self,
        ctx: &GpuContext,
        pools: &[wgpu::Buffer],
    ) -> Result<Vec<[glam::Vec4; 27]>> {
        let mut words: Vec<u32> = Vec::new();
        let mut left = self.brick_count as u64;
        for pool in pools {
            let bricks = left.min(self.pool_bricks as u64);
            if bricks == 0 {
                break;
            }
            let bytes = read_buffer(ctx, pool, 0, bricks * BUILD_BRICK_WORDS as u64 * 4)?;
            words.extend_from_slice(bytemuck::cast_slice(&bytes));
            left -= bricks;
        }
        Ok(words
            .chunks_exact(BUILD_BRICK_WORDS as usize)
            .map(|b| std::array::from_fn(|t| unpack_half4(b[2 * t], b[2 * t + 1])))
            .collect())
    }

    /// Reads the injected radiance of every leaf voxel back: index (leaf node - first leaf
    /// node) x 8 + octant (x + 2y + 4z), (radiance, opacity); the dynamic part's leaves follow
    /// the static ones ((static leaves + leaf node - first dynamic leaf node) x 8 + octant).
    pub fn read_voxel_radiance(&self, ctx: &GpuContext) -> Result<Vec<glam::Vec4>> {
        let (first, end) = self.levels.last().copied().unwrap_or((0, 0));
        let (d0, d1) = self.dynamic_levels.last().copied().unwrap_or((0, 0));
        let n = (end - first + d1 - d0) as u64 * 8;
        if n == 0 {
            return Ok(Vec::new());
        }
        let bytes = read_buffer(ctx, &self.voxel_radiance, 0, n * 8)?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        Ok(words
            .chunks_exact(2)
            .map(|w| unpack_half4(w[0], w[1]))
            .collect())
    }
}
