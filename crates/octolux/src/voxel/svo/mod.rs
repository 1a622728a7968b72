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
pub mod cpu;
pub mod dynamic;
pub mod inject;
pub mod sample;
pub mod walk;

use crate::gpu::pack::{unpack_half4, unpack_unorm8};
use crate::gpu::pass::dispatch_size;
use crate::gpu::shader::library_shader;
use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::voxel::svo::dynamic::DynamicReserve;
use crate::voxel::voxelize::{FragmentList, Voxelizer};
use crate::voxel::{VoxelGrid, VoxelTriangle};
use crate::{Error, Result};

/// Ledger owner of the octree's buffers.
pub const OWNER: &str = "svo";
/// Words per brick while building (27 texels x RGBA16F).
pub const BUILD_BRICK_WORDS: u32 = 54;
/// Words per brick of the finished pool (27 texels x RGBA8).
pub const BRICK_WORDS: u32 = 27;
/// Bytes per node: child, 3 neighbours, brick index.
pub const NODE_BYTES: u64 = 20;
/// Bytes between parameter slots bound at offsets (a multiple of any adapter's
/// `min_storage_buffer_offset_alignment`).
pub(crate) const PARAM_STRIDE: u64 = 256;

/// Converts the RGBA16F build pool into the RGBA8 pool (values are in 0..1).
const PACK_WGSL: &str = "
// Storage, not uniform: see \"Parameter blocks\" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> count: vec4<u32>;
@group(0) @binding(1) var<storage, read> wide0: array<u32>;
@group(0) @binding(2) var<storage, read> wide1: array<u32>;
@group(0) @binding(3) var<storage, read> wide2: array<u32>;
@group(0) @binding(4) var<storage, read> wide3: array<u32>;
@group(0) @binding(5) var<storage, read_write> narrow0: array<u32>;
@group(0) @binding(6) var<storage, read_write> narrow1: array<u32>;
@group(0) @binding(7) var<storage, read_write> narrow2: array<u32>;
@group(0) @binding(8) var<storage, read_write> narrow3: array<u32>;
@compute @workgroup_size(64)
fn pack(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    if i >= count.x {
        return;
    }
    let b = i / 27u;
    let t = i % 27u;
    let slot = b % count.y;
    let w = slot * 54u + 2u * t;
    var lo = 0u;
    var hi = 0u;
    switch b / count.y {
        case 0u: { lo = wide0[w]; hi = wide0[w + 1u]; }
        case 1u: { lo = wide1[w]; hi = wide1[w + 1u]; }
        case 2u: { lo = wide2[w]; hi = wide2[w + 1u]; }
        default: { lo = wide3[w]; hi = wide3[w + 1u]; }
    }
    let v = clamp(vec4<f32>(unpack2x16float(lo), unpack2x16float(hi)), vec4<f32>(0.0), vec4<f32>(1.0));
    let n = slot * 27u + t;
    switch b / count.y {
        case 0u: { narrow0[n] = pack4x8unorm(v); }
        case 1u: { narrow1[n] = pack4x8unorm(v); }
        case 2u: { narrow2[n] = pack4x8unorm(v); }
        default: { narrow3[n] = pack4x8unorm(v); }
    }
}
";
pub(crate) const CONTROL_WORDS: u64 = 128;
/// Word of `control` counting bricks (`BRICK_COUNTER` in `svo/build.wgsl`).
pub(crate) const BRICK_COUNTER: usize = 60;
/// Indirect dispatch slots (3 words each): static levels, dynamic levels, dynamic lists and
/// the dynamic update's own sizes (`svo/dynamic.wgsl`); each slot again from `NODE_ARGS` on,
/// sized for one workgroup per entry.
pub(crate) const ARGS_SLOTS: u64 = 2 * NODE_ARGS as u64;
/// Slot `s + NODE_ARGS` holds slot `s`'s count as one workgroup per entry (`NODE_ARGS` in
/// `svo/build.wgsl`).
pub(crate) const NODE_ARGS: u32 = 96;
/// First indirect slot of the dynamic node ranges (`ARGS_DYN_NODES` in `svo/dynamic.wgsl`).
pub(crate) const ARGS_DYN_NODES: u32 = 16;

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

/// Read-only storage buffer of one [`LevelParams`] per slot ([`PARAM_STRIDE`] bytes apart):
/// slot `d` walks level `d`'s static nodes, slot `depth + d` its dynamic ones.
pub(crate) fn level_params(
    ctx: &GpuContext,
    label: &str,
    depth: u32,
    fragments: u32,
    capacity: u32,
    pool_bricks: u32,
) -> wgpu::Buffer {
    let mut params = vec![0u8; PARAM_STRIDE as usize * 2 * depth as usize];
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
        let at = slot as usize * PARAM_STRIDE as usize;
        params[at..at + 32].copy_from_slice(bytemuck::bytes_of(&p));
    }
    ctx.create_buffer_init(OWNER, label, &params, wgpu::BufferUsages::STORAGE)
}

/// Most buffers a brick pool is split over (one storage binding each).
pub const POOLS: u32 = 4;

/// A sparse voxel octree on the GPU.
pub struct Svo {
    /// The voxel grid the finest level resolves.
    grid: VoxelGrid,
    /// Number of nodes (all levels). With a dynamic part, as of the latest dynamic update
    /// read back ([`Svo::poll_dynamic`], [`Svo::sync_dynamic`]).
    node_count: u32,
    /// `array<u32>`: first child index, 0 = none.
    child: wgpu::Buffer,
    /// `array<u32>`, a bit per static node (bit n % 32 of word n / 32): its cell holds a voxel
    /// of the static geometry. Nodes without one are subdivided where they border one (for
    /// the bricks' lattice); the visibility walk skips them whole.
    static_occupied: wgpu::Buffer,
    /// `array<u32>`, 3 per node: +x, +y, +z neighbour, 0 = none.
    neighbours: wgpu::Buffer,
    /// The brick pool, split over [`POOLS`] buffers (unused ones are 16-byte placeholders):
    /// brick `b` is slot `b % pool_bricks` of buffer `b / pool_bricks`, [`BRICK_WORDS`] words
    /// (27 texels as `pack4x8unorm`).
    bricks: Vec<wgpu::Buffer>,
    /// Bricks per pool buffer.
    pool_bricks: u32,
    /// `array<u32>`: per node, its brick index + 1 (0 = no brick, an all-zero lattice).
    brick_index: wgpu::Buffer,
    /// Number of bricks (with a dynamic part: as [`Svo::node_count`]).
    brick_count: u32,
    /// Bricks the pools hold: the static part's and the dynamic reserve's.
    brick_capacity: u32,
    /// Node index range of every level.
    levels: Vec<(u32, u32)>,
    /// Voxel fragments the octree was built from; after a dynamic update, those of its
    /// dynamic triangles (as [`Svo::node_count`]).
    fragment_count: u32,
    /// `array<u32>`: per node, its packed coordinates on its level (10 bits per axis).
    coord: wgpu::Buffer,
    /// Level ranges and counters of the build (`control` in `svo/build.wgsl`), kept for the passes
    /// that run per level after the build (injection).
    control: wgpu::Buffer,
    /// Indirect dispatch sizes per level.
    args: wgpu::Buffer,
    /// Per-level parameters (one 256-byte slot per level).
    level_params: wgpu::Buffer,
    /// Fragment sums of albedo, emission and normal of the static part's occupied leaf voxels
    /// (`voxel/svo/leaf_sums.wgsl`: an index word per static leaf node, then
    /// [`crate::voxel::svo::inject::LEAF_SUM_WORDS`] words per occupied voxel).
    leaf_sums: wgpu::Buffer,
    /// Radiance pool, split like [`Svo::bricks`]: [`BUILD_BRICK_WORDS`] words per brick,
    /// 27 texels of RGBA16F (radiance, opacity). Zero until [`SvoBuilder::inject`].
    radiance: Vec<wgpu::Buffer>,
    /// Facing pool ([`SvoBuilder::with_facing`]), split and laid out like `radiance`: per
    /// texel the sum of the radiance's weight (r + g + b) times the direction its surface
    /// faces, filtered as the radiance (RGBA16F: xyz, 0). `None` without facing.
    facing: Option<Vec<wgpu::Buffer>>,
    /// Injected radiance and opacity per leaf voxel (RGBA16F): static leaves in the order of
    /// `leaf_sums`, then the dynamic leaves in node order.
    voxel_radiance: wgpu::Buffer,
    /// Nodes of the static part (`[0, static_nodes)`); dynamic nodes follow.
    static_nodes: u32,
    /// Bricks of the static part; dynamic bricks follow.
    static_bricks: u32,
    /// Node index range of every level's dynamic nodes (empty without a dynamic part; as
    /// [`Svo::node_count`]).
    dynamic_levels: Vec<(u32, u32)>,
    /// Room for the dynamic part, `None` for an octree built without a reserve.
    dynamic: Option<crate::voxel::svo::dynamic::SvoDynamic>,
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

/// The octree build pipelines.
pub struct SvoBuilder {
    pub(super) voxelizer: Voxelizer,
    pub(super) layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    /// Group 2 of the dynamic update's kernels (`svo/dynamic.wgsl`).
    pub(super) dyn_layout: wgpu::BindGroupLayout,
    /// Kernels by entry point, with the groups they bind beyond group 0.
    pipelines: Pipelines,
    pack: wgpu::ComputePipeline,
    pool_limit: Option<u32>,
    /// Filter the coarsest levels in one dispatch (`mip_coarse`).
    fuse_coarse: bool,
    /// Octrees keep the facing of their radiance ([`SvoBuilder::with_facing`]).
    facing: bool,
    /// The radiance mip's kernels that also filter the facing pool, compiled when first
    /// needed.
    facing_filter: std::cell::OnceCell<FacingFilter>,
    pub(super) light: crate::voxel::svo::inject::SvoLight,
    /// Stands in for the fragments and triangles the transfer and mip kernels do not read.
    mip_placeholder: wgpu::Buffer,
}

pub(super) fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    crate::gpu::storage_entry(binding, read_only)
}

/// Which bind groups beyond group 0 a kernel uses: group 1 (the dispatch arguments, which a
/// kernel dispatched indirectly must not bind) and group 2 (the dynamic part).
/// The mip and transfer kernels compiled with the feature `facing` (`svo/build.wgsl`): group 0
/// of the build layout plus the facing pool's four buffers (bindings 12..15).
struct FacingFilter {
    layout0: wgpu::BindGroupLayout,
    pipelines: Pipelines,
}

/// Kernels by entry point, with the groups they bind beyond group 0.
type Pipelines = std::collections::HashMap<&'static str, (wgpu::ComputePipeline, Groups)>;

/// The entry points that filter a brick pool up the levels (`filter_steps`).
const FILTER_ENTRIES: [&str; 5] = [
    "mip",
    "mip_coarse",
    "transfer_x",
    "transfer_y",
    "transfer_z",
];

#[derive(Clone, Copy)]
struct Groups {
    args: bool,
    dynamic: bool,
}

pub(super) enum Dispatch {
    /// One invocation per fragment.
    Fragments,
    /// `n` invocations.
    Capacity(u32),
    /// Indirect, from this slot of the dispatch arguments: one invocation per entry.
    Indirect(u32),
    /// Indirect, one workgroup per entry of this slot (kernels that spread a node over a
    /// workgroup).
    PerNode(u32),
    /// One workgroup.
    One,
}

/// Work counts of the radiance mip (`gpu/work.rs`): its dispatches, one after another.
const RADIANCE_MIP_WORK: &[&str] = &["dispatches"];

/// Levels `0..=COARSE_LEVEL` (at most 8^2 = 64 nodes on the last) are filtered by one
/// dispatch of one workgroup, `mip_coarse` in `svo/build.wgsl`, instead of four dispatches
/// each.
const COARSE_LEVEL: u32 = 2;

/// The neighbour transfers and mips after the leaves are filled, from the leaf level up: each
/// level's static nodes, then (with `dynamic`) its dynamic ones (parameter slot depth + d;
/// their ranges are read on the GPU, empty before the first update). The coarsest levels in
/// one step unless `fuse` is false.
fn filter_steps(depth: u32, dynamic: bool, fuse: bool) -> Vec<(&'static str, u32, Dispatch)> {
    let ranges = |d: u32| {
        [(d, d)]
            .into_iter()
            .chain(dynamic.then_some((depth + d, ARGS_DYN_NODES + d)))
    };
    let leaf = depth.saturating_sub(1);
    // The leaf level has no mip, so it is never fused.
    let coarse = (fuse && depth >= 2).then(|| COARSE_LEVEL.min(depth - 2));
    let mut steps = Vec::new();
    for d in (0..depth).rev() {
        if Some(d) == coarse {
            steps.push(("mip_coarse", d, Dispatch::One));
            break;
        }
        if d != leaf {
            steps.extend(ranges(d).map(|(slot, args)| ("mip", slot, Dispatch::PerNode(args))));
        }
        for t in ["transfer_x", "transfer_y", "transfer_z"] {
            steps.extend(ranges(d).map(|(slot, args)| (t, slot, Dispatch::Indirect(args))));
        }
    }
    steps
}

impl SvoBuilder {
    /// Compiles the build kernels.
    pub fn new(ctx: &GpuContext) -> SvoBuilder {
        let device = &ctx.device;
        let layout0 = layout0_with(device, "svo", 11);
        let layout1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("svo args"),
            entries: &[storage(0, false)],
        });
        let dyn_layout = crate::voxel::svo::dynamic::bind_group_layout(device);
        // The build and the dynamic update: `dynamic` imports `build`, so it holds both.
        let module = ctx.shader(
            "svo",
            &library_shader("voxel/svo/dynamic", &[("facing", false)]),
        );
        let accumulate = ctx.shader(
            "svo accumulate",
            &library_shader("voxel/svo/accumulate", &[]),
        );
        let plain = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo"),
            bind_group_layouts: &[Some(&layout0)],
            immediate_size: 0,
        });
        let with_args = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo finish level"),
            bind_group_layouts: &[Some(&layout0), Some(&layout1)],
            immediate_size: 0,
        });
        let dynamic = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo dynamic"),
            bind_group_layouts: &[Some(&layout0), None, Some(&dyn_layout)],
            immediate_size: 0,
        });
        let dynamic_args = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("svo dynamic finish"),
            bind_group_layouts: &[Some(&layout0), Some(&layout1), Some(&dyn_layout)],
            immediate_size: 0,
        });
        let mut pipelines = std::collections::HashMap::new();
        for entry in crate::voxel::svo::dynamic::ENTRY_POINTS
            .iter()
            .copied()
            .chain([
                "flag_occupied",
                "flag_needed",
                "subdivide",
                "mark_occupied",
                "assign_bricks",
                "finish_level",
                "leaf_fill",
                "transfer_x",
                "transfer_y",
                "transfer_z",
                "mip",
                "mip_coarse",
            ])
        {
            let groups = Groups {
                args: entry.contains("finish") || entry == "dyn_begin",
                dynamic: entry.starts_with("dyn_"),
            };
            let layout = match (groups.args, groups.dynamic) {
                (true, true) => &dynamic_args,
                (true, false) => &with_args,
                (false, true) => &dynamic,
                (false, false) => &plain,
            };
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
            pipelines.insert(entry, (pipeline, groups));
        }
        let leaf_accumulate = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("leaf_accumulate"),
            layout: Some(&plain),
            module: &accumulate,
            entry_point: Some("leaf_accumulate"),
            compilation_options: Default::default(),
            cache: None,
        });
        let no_groups = Groups {
            args: false,
            dynamic: false,
        };
        pipelines.insert("leaf_accumulate", (leaf_accumulate, no_groups));
        let pack_module = ctx.shader("svo pack", PACK_WGSL);
        SvoBuilder {
            pack: ctx.compute_pipeline("svo pack bricks", &pack_module, "pack"),
            pool_limit: None,
            fuse_coarse: true,
            facing: false,
            facing_filter: std::cell::OnceCell::new(),
            light: crate::voxel::svo::inject::SvoLight::new(ctx),
            mip_placeholder: ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some("mip placeholder"),
                    size: 64,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                },
            ),
            voxelizer: Voxelizer::new(ctx),
            layout0,
            layout1,
            dyn_layout,
            pipelines,
        }
    }

    /// Caps the bricks per pool buffer below what the device can bind (tests use this to
    /// exercise pools split over several buffers).
    pub fn with_pool_limit(mut self, bricks: u32) -> SvoBuilder {
        self.pool_limit = Some(bricks.max(1));
        self
    }

    /// Filters levels `0..=2` of the bricks and the radiance in one dispatch (`fused`, the
    /// default) or each level in its own four dispatches, as the finer levels are: the bricks
    /// are the same either way (tests compare the two).
    pub fn with_fused_coarse_levels(mut self, fused: bool) -> SvoBuilder {
        self.fuse_coarse = fused;
        self
    }

    /// Octrees built by this builder also keep, per radiance texel, the direction the radiance
    /// leaves in (the radiance-weighted mean facing of its surfaces; a wall thinner than a
    /// voxel faces the light that lights it): the facing pool, filtered like the radiance,
    /// 216 bytes per brick (default false; [`crate::gi::vct::VctSettings::facing`]).
    pub fn with_facing(mut self, facing: bool) -> SvoBuilder {
        self.facing = facing;
        self
    }

    /// Voxelizes `tris` into `grid` and builds the octree. Returns the octree and the pass
    /// times (voxelization, structure, bricks); scratch buffers are released at the end.
    /// The octree has no dynamic part: see [`SvoBuilder::build_with_reserve`].
    pub fn build(
        &self,
        ctx: &GpuContext,
        grid: &VoxelGrid,
        tris: &[VoxelTriangle],
    ) -> Result<(Svo, Vec<PassTiming>)> {
        self.build_with_reserve(ctx, grid, tris, DynamicReserve::NONE)
    }

    /// Builds the static part of an octree from `tris` (as [`SvoBuilder::build`]) with room
    /// for a dynamic part of up to `reserve` nodes and bricks, which
    /// [`SvoBuilder::record_dynamic`] fills each frame.
    pub fn build_with_reserve(
        &self,
        ctx: &GpuContext,
        grid: &VoxelGrid,
        tris: &[VoxelTriangle],
        reserve: DynamicReserve,
    ) -> Result<(Svo, Vec<PassTiming>)> {
        crate::voxel::check_resolution(grid.resolution)?;
        if grid.resolution < 4 {
            return Err(Error::InvalidArgument(
                "octree resolution must be at least 4".into(),
            ));
        }
        let mut timings = Vec::new();
        let list = self
            .voxelizer
            .fragments(ctx, OWNER, grid, tris, &mut timings)?;
        let depth = grid.depth();
        // The neighbour array (3 words per node) is the largest per-node array.
        let max_nodes = (ctx.device.limits().max_storage_buffer_binding_size / 12)
            .min(u32::MAX as u64 / 64) as u32;
        let mut capacity = (list.count as u64 * 4 + 4096).min(max_nodes as u64) as u32;
        let device_pool = (ctx.device.limits().max_storage_buffer_binding_size
            / (BUILD_BRICK_WORDS as u64 * 4))
            .min(u32::MAX as u64 / 64) as u32;
        let pool_bricks = self
            .pool_limit
            .unwrap_or(device_pool)
            .min(device_pool)
            .max(1);
        loop {
            let attempt = self.build_with(
                ctx,
                grid,
                &list,
                (depth, capacity, pool_bricks),
                reserve,
                &mut timings,
            )?;
            match attempt {
                Some(svo) => {
                    ctx.ledger.forget(OWNER, "fragments");
                    ctx.ledger.forget(OWNER, "triangles");
                    return Ok((svo, timings));
                }
                None if capacity >= max_nodes => {
                    return Err(Error::InvalidArgument(format!(
                        "the octree at {}^3 needs more than {max_nodes} nodes, more than this \
                         GPU can bind; use a lower resolution",
                        grid.resolution
                    )))
                }
                None => capacity = (capacity as u64 * 2).min(max_nodes as u64) as u32,
            }
        }
    }

    /// One build attempt with `capacity` nodes of scratch; `None` when they did not suffice.
    fn build_with(
        &self,
        ctx: &GpuContext,
        grid: &VoxelGrid,
        list: &FragmentList,
        (depth, capacity, pool_bricks): (u32, u32, u32),
        reserve: DynamicReserve,
        timings: &mut Vec<PassTiming>,
    ) -> Result<Option<Svo>> {
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let scratch = |label: &str, words: u64, usage: wgpu::BufferUsages| {
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
        let cap = capacity as u64;
        let child = scratch("child (build)", cap, usage);
        let nbr = scratch("neighbours (build)", cap * 3, usage);
        let coord = scratch("coordinates (build)", cap, usage);
        let flags = scratch("flags (build)", cap, usage);
        let occupied = scratch("occupied nodes (build)", cap.div_ceil(32), usage);
        let control = scratch("control", CONTROL_WORDS, usage);
        let args = scratch(
            "dispatch args",
            3 * ARGS_SLOTS,
            usage | wgpu::BufferUsages::INDIRECT,
        );
        let mut init = vec![0u32; CONTROL_WORDS as usize];
        init[0] = 1; // the root is allocated
        init[2] = 0;
        init[3] = 1;
        ctx.queue
            .write_buffer(&control, 0, bytemuck::cast_slice(&init));
        // Level 0 is the root alone, in both forms of its slot.
        for slot in [0, NODE_ARGS as u64] {
            ctx.queue
                .write_buffer(&args, slot * 12, bytemuck::cast_slice(&[1u32, 1, 1]));
        }
        let params = level_params(
            ctx,
            "level params",
            depth,
            list.count,
            capacity,
            pool_bricks,
        );
        // The brick pool is bound in the structure phase too (the layout is shared), so it gets
        // a placeholder there and its exact size afterwards.
        let placeholder = scratch("placeholder", 4, usage);
        let group = |pools: [&wgpu::Buffer; 4]| {
            self.group0(
                ctx,
                &params,
                [
                    &list.buffer,
                    &list.triangles,
                    &child,
                    &nbr,
                    &coord,
                    &flags,
                    &control,
                    pools[0],
                    pools[1],
                    pools[2],
                    pools[3],
                ],
            )
        };
        let args_group = self.args_group(ctx, &args);
        let mut timer = PassTimer::new(ctx);
        // No brick exists yet: pool 0's binding holds the occupied-node bits `mark_occupied`
        // writes (a binding of its own would take the dynamic update's kernels past the 20
        // storage buffers per stage octolux asks of a device).
        let structure = group([&occupied, &placeholder, &placeholder, &placeholder]);
        let mut steps = Vec::new();
        for d in 0..depth {
            steps.push(("flag_occupied", d, Dispatch::Fragments));
            steps.push(("flag_needed", d, Dispatch::Indirect(d)));
            if d + 1 < depth {
                steps.push(("subdivide", d, Dispatch::Indirect(d)));
                steps.push(("finish_level", d, Dispatch::One));
            }
        }
        steps.push((
            "mark_occupied",
            0,
            Dispatch::Capacity(capacity.div_ceil(32)),
        ));
        steps.push(("assign_bricks", 0, Dispatch::Capacity(capacity)));
        self.record(
            &mut timer,
            "svo structure",
            &structure,
            (&args_group, None),
            &args,
            list.count,
            &steps,
        );
        timings.extend(timer.finish_frame()?);
        let control_cpu: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(ctx, &control, 0, CONTROL_WORDS * 4)?).to_vec();
        if control_cpu[1] != 0 {
            return Ok(None);
        }
        let node_count = control_cpu[0];
        let brick_count = control_cpu[BRICK_COUNTER];
        let brick_capacity = brick_count as u64 + reserve.bricks as u64;
        if brick_capacity.div_ceil(pool_bricks as u64).max(1) > POOLS as u64 {
            return Err(Error::InvalidArgument(format!(
                "the octree at {}^3 has {node_count} nodes and needs {brick_count} bricks (+ \
                 {} reserved for dynamic geometry); this GPU can bind at most {} ({POOLS} \
                 storage bindings of {pool_bricks} RGBA16F bricks); use a lower resolution or \
                 a smaller reserve",
                grid.resolution,
                reserve.bricks,
                POOLS * pool_bricks
            )));
        }
        let max_nodes =
            (ctx.device.limits().max_storage_buffer_binding_size / 12).min(u32::MAX as u64 / 64);
        let node_capacity = node_count as u64 + reserve.nodes as u64;
        if node_capacity > max_nodes {
            return Err(Error::InvalidArgument(format!(
                "the octree at {}^3 has {node_count} nodes; with {} reserved for dynamic \
                 geometry it needs more than this GPU can bind ({max_nodes}); reserve fewer",
                grid.resolution, reserve.nodes
            )));
        }
        let levels: Vec<(u32, u32)> = (0..depth as usize)
            .map(|d| (control_cpu[2 + 2 * d], control_cpu[3 + 2 * d]))
            .collect();
        // Pool k holds bricks [k * pool_bricks, (k + 1) * pool_bricks).
        let make_pools = |label: &str, words: u64, total: u64| -> Vec<wgpu::Buffer> {
            (0..POOLS as u64)
                .map(|k| {
                    let bricks = total
                        .saturating_sub(k * pool_bricks as u64)
                        .min(pool_bricks as u64);
                    ctx.create_buffer(
                        OWNER,
                        &wgpu::BufferDescriptor {
                            label: Some(&format!("{label} {k}")),
                            size: (bricks * words * 4).max(16),
                            usage,
                            mapped_at_creation: false,
                        },
                    )
                })
                .collect()
        };
        let wide = make_pools(
            "brick pool (build, RGBA16F)",
            BUILD_BRICK_WORDS as u64,
            brick_count as u64,
        );
        let filling = group([&wide[0], &wide[1], &wide[2], &wide[3]]);
        let leaf = depth - 1;
        let mut steps = vec![
            ("leaf_accumulate", leaf, Dispatch::Fragments),
            ("leaf_fill", leaf, Dispatch::PerNode(leaf)),
        ];
        steps.extend(filter_steps(depth, false, self.fuse_coarse));
        self.record(
            &mut timer,
            "svo bricks",
            &filling,
            (&args_group, None),
            &args,
            list.count,
            &steps,
        );
        // The finished pool: RGBA8, half the size of the build pool.
        let packed = make_pools("brick pool", BRICK_WORDS as u64, brick_capacity);
        let count = ctx.create_buffer_init(
            OWNER,
            "pack params",
            bytemuck::cast_slice(&[brick_count * 27, pool_bricks, 0, 0]),
            wgpu::BufferUsages::STORAGE,
        );
        let pack_group = crate::gpu::pass::bind_buffers(
            ctx,
            &self.pack,
            &[
                (0, &count),
                (1, &wide[0]),
                (2, &wide[1]),
                (3, &wide[2]),
                (4, &wide[3]),
                (5, &packed[0]),
                (6, &packed[1]),
                (7, &packed[2]),
                (8, &packed[3]),
            ],
        );
        crate::gpu::pass::dispatch_1d(
            &mut timer,
            "svo pack bricks",
            &self.pack,
            &pack_group,
            brick_count * 27,
        );
        let leaves = levels.last().copied().unwrap_or((0, 0));
        let (leaf_sums, sum_timings) = self
            .light
            .accumulate(ctx, &mut timer, list, &child, depth, leaves)?;
        timings.extend(sum_timings);
        let radiance = make_pools("radiance pool", BUILD_BRICK_WORDS as u64, brick_capacity);
        let facing = self
            .facing
            .then(|| make_pools("facing pool", BUILD_BRICK_WORDS as u64, brick_capacity));
        let voxel_radiance = scratch(
            "voxel radiance",
            (leaves.1 - leaves.0 + reserve.nodes) as u64 * 16,
            usage,
        );
        // Keep only what the octree needs, at its exact size (plus the dynamic reserve, which
        // starts zeroed).
        let mut exact = |label: &str, per_node: u64, from: &wgpu::Buffer| {
            let buffer = ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: (node_capacity * per_node * 4).max(16),
                    usage,
                    mapped_at_creation: false,
                },
            );
            let words = node_count as u64 * per_node;
            timer.untimed(|encoder| {
                encoder.copy_buffer_to_buffer(from, 0, &buffer, 0, Some(words * 4))
            });
            buffer
        };
        let child_exact = exact("child", 1, &child);
        let nbr_exact = exact("neighbours", 3, &nbr);
        let brick_index = exact("brick index", 1, &flags);
        let coord_exact = exact("coordinates", 1, &coord);
        // Static nodes only: the walk reads the dynamic ones' state instead.
        let occupied_words = (node_count as u64).div_ceil(32);
        let static_occupied = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("occupied nodes"),
                size: (occupied_words * 4).max(16),
                usage,
                mapped_at_creation: false,
            },
        );
        timer.untimed(|encoder| {
            encoder.copy_buffer_to_buffer(
                &occupied,
                0,
                &static_occupied,
                0,
                Some(occupied_words * 4),
            )
        });
        timings.extend(timer.finish_frame()?);
        for label in [
            "child (build)",
            "neighbours (build)",
            "coordinates (build)",
            "flags (build)",
            "occupied nodes (build)",
            "placeholder",
            "pack params",
        ] {
            ctx.ledger.forget(OWNER, label);
        }
        for k in 0..POOLS {
            ctx.ledger
                .forget(OWNER, &format!("brick pool (build, RGBA16F) {k}"));
        }
        Ok(Some(Svo {
            grid: *grid,
            node_count,
            child: child_exact,
            static_occupied,
            neighbours: nbr_exact,
            bricks: packed,
            pool_bricks,
            brick_index,
            brick_count,
            brick_capacity: brick_capacity as u32,
            levels,
            fragment_count: list.count,
            coord: coord_exact,
            control,
            args,
            level_params: params,
            leaf_sums,
            radiance,
            facing,
            voxel_radiance,
            static_nodes: node_count,
            static_bricks: brick_count,
            dynamic_levels: Vec::new(),
            dynamic: crate::voxel::svo::dynamic::SvoDynamic::new(
                ctx,
                reserve,
                crate::voxel::svo::dynamic::StaticPart {
                    node_capacity: node_capacity as u32,
                    brick_capacity: brick_capacity as u32,
                    depth,
                    pool_bricks,
                    first_leaf: leaves.0,
                    control: control_cpu,
                },
            ),
        }))
    }

    /// Injects direct light into `svo`'s radiance pool: per leaf voxel, emission + albedo/pi x
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
            &svo.brick_index,
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
        crate::gpu::work::add(
            ctx,
            "svo radiance mip",
            RADIANCE_MIP_WORK,
            0,
            steps.len() as u64,
        )?;
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

    /// Group 0 of the octree kernels: `params` (per-level slots) and the 11 storage buffers
    /// of `svo/build.wgsl` (fragments, triangles, child, neighbours, coordinates, flags / brick
    /// index, control, the 4 brick pool buffers).
    /// Group 1: the dispatch arguments, written by the `finish` kernels.
    pub(super) fn args_group(&self, ctx: &GpuContext, args: &wgpu::Buffer) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("svo args"),
            layout: &self.layout1,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: args.as_entire_binding(),
            }],
        })
    }

    pub(super) fn group0(
        &self,
        ctx: &GpuContext,
        params: &wgpu::Buffer,
        buffers: [&wgpu::Buffer; 11],
    ) -> wgpu::BindGroup {
        group0_with(ctx, &self.layout0, params, &buffers)
    }

    /// The facing kernels, compiled on first use.
    fn facing_filter(&self, ctx: &GpuContext) -> &FacingFilter {
        self.facing_filter.get_or_init(|| {
            let device = &ctx.device;
            // The facing pool's four buffers after the build's eleven.
            let layout0 = layout0_with(device, "svo (facing)", 15);
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("svo (facing)"),
                bind_group_layouts: &[Some(&layout0)],
                immediate_size: 0,
            });
            let source = library_shader("voxel/svo/build", &[("facing", true)]);
            let module = ctx.shader("svo radiance mip (facing)", &source);
            let pipelines = FILTER_ENTRIES
                .iter()
                .map(|&entry| {
                    let pipeline =
                        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                            label: Some(entry),
                            layout: Some(&layout),
                            module: &module,
                            entry_point: Some(entry),
                            compilation_options: Default::default(),
                            cache: None,
                        });
                    let groups = Groups {
                        args: false,
                        dynamic: false,
                    };
                    (entry, (pipeline, groups))
                })
                .collect();
            FacingFilter { layout0, pipelines }
        })
    }

    /// Records `steps` (entry point, parameter slot, dispatch) as one timed pass; kernels that
    /// write dispatch arguments get `args_group` (group 1, over `args`), those of the dynamic
    /// part `dynamic` (group 2).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn record(
        &self,
        timer: &mut PassTimer,
        name: &str,
        group: &wgpu::BindGroup,
        groups: (&wgpu::BindGroup, Option<&wgpu::BindGroup>),
        args: &wgpu::Buffer,
        fragments: u32,
        steps: &[(&'static str, u32, Dispatch)],
    ) {
        let pipelines = &self.pipelines;
        record_steps(
            pipelines, timer, name, group, groups, args, fragments, steps,
        );
    }
}

/// [`SvoBuilder::record`] with the kernels of `pipelines`.
#[allow(clippy::too_many_arguments)]
fn record_steps(
    pipelines: &Pipelines,
    timer: &mut PassTimer,
    name: &str,
    group: &wgpu::BindGroup,
    (args_group, dynamic): (&wgpu::BindGroup, Option<&wgpu::BindGroup>),
    args: &wgpu::Buffer,
    fragments: u32,
    steps: &[(&'static str, u32, Dispatch)],
) {
    let record_step = |encoder: &mut wgpu::CommandEncoder,
                       timestamps: Option<wgpu::ComputePassTimestampWrites>,
                       (entry, d, dispatch): &(&'static str, u32, Dispatch)| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(entry),
            timestamp_writes: timestamps,
        });
        let (pipeline, groups) = &pipelines[entry];
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[*d * PARAM_STRIDE as u32]);
        if groups.args {
            pass.set_bind_group(1, args_group, &[]);
        }
        if let (true, Some(dynamic)) = (groups.dynamic, dynamic) {
            pass.set_bind_group(2, dynamic, &[]);
        }
        match dispatch {
            Dispatch::Fragments => {
                let (x, y) = dispatch_size(fragments);
                pass.dispatch_workgroups(x, y, 1);
            }
            Dispatch::Capacity(n) => {
                let (x, y) = dispatch_size(*n);
                pass.dispatch_workgroups(x, y, 1);
            }
            Dispatch::Indirect(slot) => {
                pass.dispatch_workgroups_indirect(args, *slot as u64 * 12);
            }
            Dispatch::PerNode(slot) => {
                pass.dispatch_workgroups_indirect(args, (*slot + NODE_ARGS) as u64 * 12);
            }
            Dispatch::One => {
                pass.dispatch_workgroups(1, 1, 1);
            }
        }
    };
    if timer.profile_steps() {
        for step in steps {
            let label = format!("{name}: {} {}", step.0, step.1);
            timer.pass(&label, |encoder, stamps| {
                record_step(encoder, stamps.compute(), step)
            });
        }
        return;
    }
    timer.pass(name, |encoder, stamps| {
        let last = steps.len().saturating_sub(1);
        for (i, step) in steps.iter().enumerate() {
            record_step(encoder, stamps.compute_part(i == 0, i == last), step);
        }
    });
}

/// Group 0's layout of the octree kernels: the per-level parameter slots (read-only storage
/// with a dynamic offset, "Parameter blocks" in voxel/mod.rs), fragments and triangles
/// (read-only), and read-write storage buffers up to binding `last`.
fn layout0_with(device: &wgpu::Device, label: &str, last: u32) -> wgpu::BindGroupLayout {
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: true,
            min_binding_size: wgpu::BufferSize::new(32),
        },
        count: None,
    }];
    entries.push(storage(1, true));
    entries.push(storage(2, true));
    entries.extend((3..=last).map(|b| storage(b, false)));
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// Group 0 of the octree kernels over `layout`: `params` (per-level slots) and `buffers` at
/// bindings 1...
fn group0_with(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let mut entries = vec![wgpu::BindGroupEntry {
        binding: 0,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: params,
            offset: 0,
            size: wgpu::BufferSize::new(32),
        }),
    }];
    for (i, b) in buffers.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: i as u32 + 1,
            resource: b.as_entire_binding(),
        });
    }
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("svo"),
        layout,
        entries: &entries,
    })
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

    /// The build's level ranges and counters (`control` in `svo/build.wgsl`): the dynamic
    /// leaf range a pass over the dynamic leaves reads.
    pub fn control(&self) -> &wgpu::Buffer {
        &self.control
    }

    /// The indirect dispatch arguments (buffer, byte offset) of one workgroup per dynamic leaf
    /// node, as the latest dynamic update left them on the GPU.
    pub fn dynamic_leaf_dispatch(&self) -> (&wgpu::Buffer, u64) {
        let leaf = self.levels.len().saturating_sub(1) as u32;
        let slot = ARGS_DYN_NODES + leaf + NODE_ARGS;
        (&self.args, slot as u64 * 12)
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
            bytemuck::cast_slice(&read_buffer(ctx, &self.brick_index, 0, n * 4)?).to_vec();
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
