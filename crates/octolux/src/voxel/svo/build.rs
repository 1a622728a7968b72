//! The static build (`svo/build.wgsl`): voxelize the triangles into fragments, then
//! [`SvoBuilder::build_with`] runs its passes in order: the structure, level by level; the
//! counts, read back once (the only wait of the build); the bricks, filled and filtered in
//! RGBA16F; their packing to RGBA8; the leaf sums injection reads; and exact-sized copies of
//! the node arrays, after which the scratch is released. A structure that outgrows its node
//! scratch is built again with twice as much ([`SvoBuilder::build_with_reserve`]).

use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::voxel::svo::control::{level_params, SvoControl, ARGS_SLOTS, CONTROL_BYTES, NODE_ARGS};
use crate::voxel::svo::dynamic::{DynamicReserve, StaticPart, SvoDynamic};
use crate::voxel::svo::limits::{self, Capacity};
use crate::voxel::svo::steps::{filter_steps, Dispatch};
use crate::voxel::svo::{Svo, SvoBuilder, BRICK_WORDS, BUILD_BRICK_WORDS, OWNER, POOLS};
use crate::voxel::voxelize::FragmentList;
use crate::voxel::{VoxelGrid, VoxelTriangle};
use crate::{Error, Result};

/// Usage of every buffer the build makes: bound as storage, copied and read back.
const USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

impl SvoBuilder {
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
        let max_nodes = limits::max_nodes(ctx);
        let mut capacity = (list.count as u64 * 4 + 4096).min(max_nodes as u64) as u32;
        let device_pool = limits::max_pool_bricks(ctx);
        let pool_bricks = self
            .pool_limit
            .unwrap_or(device_pool)
            .min(device_pool)
            .max(1);
        loop {
            let sizes = (grid.depth(), capacity, pool_bricks);
            match self.build_with(ctx, grid, &list, sizes, reserve, &mut timings)? {
                Some(svo) => {
                    ctx.ledger.forget(OWNER, "fragments");
                    ctx.ledger.forget(OWNER, "triangles");
                    return Ok((svo, timings));
                }
                None if capacity >= max_nodes => {
                    return Err(limits::too_many_nodes(grid.resolution, max_nodes))
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
        let mut scratch = Scratch::new(ctx);
        let nodes = BuildNodes::new(&mut scratch, capacity);
        let control = kept_buffer(ctx, "control", CONTROL_BYTES / 4, USAGE);
        let args = kept_buffer(
            ctx,
            "dispatch args",
            3 * ARGS_SLOTS,
            USAGE | wgpu::BufferUsages::INDIRECT,
        );
        start_at_root(ctx, &control, &args);
        let params = level_params(
            ctx,
            "level params",
            depth,
            list.count,
            capacity,
            pool_bricks,
        );
        let group = |pools: [&wgpu::Buffer; 4]| {
            let n = &nodes;
            self.group0(
                ctx,
                &params,
                [
                    &list.buffer,
                    &list.triangles,
                    &n.child,
                    &n.neighbours,
                    &n.coord,
                    &n.flags,
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

        // 1. Structure: flag the occupied nodes and their 26-neighbourhoods, subdivide and
        //    link level by level, then mark the occupied nodes and give needed ones a brick.
        //    No brick exists yet: pool 0's binding holds the occupied-node bits
        //    `mark_occupied` writes (a binding of its own would take the dynamic update's
        //    kernels past the 20 storage buffers per stage octolux asks of a device).
        let n = &nodes;
        let structure = group([&n.occupied, &n.placeholder, &n.placeholder, &n.placeholder]);
        let steps = structure_steps(depth, capacity);
        let groups = (&args_group, None);
        self.record(
            &mut timer,
            "svo structure",
            &structure,
            groups,
            &args,
            list.count,
            &steps,
        );
        timings.extend(timer.finish_frame()?);

        // 2. Counts: the one read-back of the build. Too few nodes: try again with more;
        //    more than the GPU can bind: fail.
        let counts = SvoControl::from_bytes(&read_buffer(ctx, &control, 0, CONTROL_BYTES)?);
        if counts.node_overflow != 0 {
            return Ok(None);
        }
        let (node_count, brick_count) = (counts.node_count, counts.brick_count);
        let capacity = Capacity::check(
            ctx,
            grid.resolution,
            (node_count, brick_count),
            reserve,
            pool_bricks,
        )?;
        let levels = counts.level_ranges(depth);
        let leaves = levels.last().copied().unwrap_or((0, 0));

        // 3. Bricks: fill the leaf bricks from the fragments, then transfer between
        //    neighbours and mip up the levels, in RGBA16F.
        let wide = scratch.pools("brick pool (build, RGBA16F)", brick_count, pool_bricks);
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
            groups,
            &args,
            list.count,
            &steps,
        );

        // 4. Pack the bricks into the finished RGBA8 pool (with the reserve's room).
        let pool = |label: &str, words: u32| pools(ctx, label, words, capacity.bricks, pool_bricks);
        let bricks = pool("brick pool", BRICK_WORDS);
        let wide_and_narrow = (wide.as_slice(), bricks.as_slice());
        self.pack
            .record(ctx, &mut timer, wide_and_narrow, brick_count, pool_bricks);

        // 5. Sum the leaf voxels' fragments (albedo, emission, normal) for injection.
        let (leaf_sums, sum_timings) =
            self.light
                .accumulate(ctx, &mut timer, list, &nodes.child, depth, leaves)?;
        timings.extend(sum_timings);

        // 6. Keep the node arrays at their exact size (plus the dynamic reserve, zeroed) and
        //    release the scratch.
        let kept = nodes.keep(ctx, &mut timer, node_count, capacity.nodes);
        timings.extend(timer.finish_frame()?);
        scratch.release();

        // 7. The octree, with empty radiance (and facing) pools for injection to fill.
        let leaf_voxels = (leaves.1 - leaves.0 + reserve.nodes) as u64 * 8;
        Ok(Some(Svo {
            grid: *grid,
            node_count,
            child: kept.child,
            static_occupied: kept.static_occupied,
            neighbours: kept.neighbours,
            bricks,
            pool_bricks,
            brick_plus_one: kept.brick_plus_one,
            brick_count,
            brick_capacity: capacity.bricks,
            levels,
            fragment_count: list.count,
            coord: kept.coord,
            control,
            args,
            level_params: params,
            leaf_sums,
            radiance: pool("radiance pool", BUILD_BRICK_WORDS),
            facing: self.facing.then(|| pool("facing pool", BUILD_BRICK_WORDS)),
            // RGBA16F: two words per voxel.
            voxel_radiance: kept_buffer(ctx, "voxel radiance", leaf_voxels * 2, USAGE),
            static_nodes: node_count,
            static_bricks: brick_count,
            dynamic_levels: Vec::new(),
            dynamic: SvoDynamic::new(
                ctx,
                reserve,
                StaticPart {
                    node_capacity: capacity.nodes,
                    brick_capacity: capacity.bricks,
                    depth,
                    pool_bricks,
                    first_leaf: leaves.0,
                    control: counts,
                },
            ),
        }))
    }
}

/// The structure pass: per level, flag the occupied nodes (one invocation per fragment) and
/// the needed ones (with the neighbour links), then subdivide the needed ones and record the
/// next level's range; finally the occupied-node bits and the brick indices.
fn structure_steps(depth: u32, capacity: u32) -> Vec<(&'static str, u32, Dispatch)> {
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
    steps
}

/// The control block and dispatch arguments before the structure pass: level 0 is the root
/// alone, allocated (node 0), in both forms of its argument slot.
fn start_at_root(ctx: &GpuContext, control: &wgpu::Buffer, args: &wgpu::Buffer) {
    ctx.queue
        .write_buffer(control, 0, bytemuck::bytes_of(&SvoControl::at_root()));
    let one = wgpu::util::DispatchIndirectArgs { x: 1, y: 1, z: 1 };
    let stride = size_of::<wgpu::util::DispatchIndirectArgs>() as u64;
    for slot in [0, NODE_ARGS as u64] {
        ctx.queue.write_buffer(args, slot * stride, one.as_bytes());
    }
}

/// A buffer of `words` words (at least 16 bytes) that outlives the build.
fn kept_buffer(
    ctx: &GpuContext,
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

/// A brick pool of `bricks` bricks of `words` words, split over [`POOLS`] buffers of
/// `pool_bricks`: buffer k holds bricks `[k * pool_bricks, (k + 1) * pool_bricks)` (unused
/// ones are 16-byte placeholders).
fn pools(
    ctx: &GpuContext,
    label: &str,
    words: u32,
    bricks: u32,
    pool_bricks: u32,
) -> Vec<wgpu::Buffer> {
    (0..POOLS as u64)
        .map(|k| {
            let here = (bricks as u64)
                .saturating_sub(k * pool_bricks as u64)
                .min(pool_bricks as u64);
            kept_buffer(ctx, &format!("{label} {k}"), here * words as u64, USAGE)
        })
        .collect()
}

/// The buffers of one build attempt: made through it, and forgotten by the ledger together
/// when the attempt ends (the GPU frees each when its last use has run).
struct Scratch<'a> {
    ctx: &'a GpuContext,
    labels: Vec<String>,
}

impl<'a> Scratch<'a> {
    fn new(ctx: &'a GpuContext) -> Scratch<'a> {
        Scratch {
            ctx,
            labels: Vec::new(),
        }
    }

    fn buffer(&mut self, label: &str, words: u64) -> wgpu::Buffer {
        self.labels.push(label.to_string());
        kept_buffer(self.ctx, label, words, USAGE)
    }

    /// An RGBA16F brick pool of `bricks` (as [`pools`]).
    fn pools(&mut self, label: &str, bricks: u32, pool_bricks: u32) -> Vec<wgpu::Buffer> {
        self.labels
            .extend((0..POOLS).map(|k| format!("{label} {k}")));
        pools(self.ctx, label, BUILD_BRICK_WORDS, bricks, pool_bricks)
    }

    fn release(self) {
        for label in &self.labels {
            self.ctx.ledger.forget(OWNER, label);
        }
    }
}

/// The node arrays of one build attempt, sized for its node capacity.
struct BuildNodes {
    /// First child per node (0 = none).
    child: wgpu::Buffer,
    /// +x, +y, +z neighbour per node.
    neighbours: wgpu::Buffer,
    /// Packed coordinates per node on its level.
    coord: wgpu::Buffer,
    /// Per node its occupied / needed flags, which `assign_bricks` turns into its brick
    /// index + 1.
    flags: wgpu::Buffer,
    /// A bit per node: its cell holds a voxel ([`Svo`]'s `static_occupied`).
    occupied: wgpu::Buffer,
    /// Stands in for the brick pool buffers in the structure pass.
    placeholder: wgpu::Buffer,
}

/// The node arrays the octree keeps, at their exact size.
struct KeptNodes {
    child: wgpu::Buffer,
    neighbours: wgpu::Buffer,
    coord: wgpu::Buffer,
    brick_plus_one: wgpu::Buffer,
    static_occupied: wgpu::Buffer,
}

impl BuildNodes {
    fn new(scratch: &mut Scratch, capacity: u32) -> BuildNodes {
        let cap = capacity as u64;
        BuildNodes {
            child: scratch.buffer("child (build)", cap),
            neighbours: scratch.buffer("neighbours (build)", cap * 3),
            coord: scratch.buffer("coordinates (build)", cap),
            flags: scratch.buffer("flags (build)", cap),
            occupied: scratch.buffer("occupied nodes (build)", cap.div_ceil(32)),
            placeholder: scratch.buffer("placeholder", 4),
        }
    }

    /// Copies of the first `nodes` nodes into arrays of `capacity` (the static part and
    /// the dynamic reserve); the occupied bits of the static nodes only (the walk reads the
    /// dynamic ones' state instead).
    fn keep(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        nodes: u32,
        capacity: u32,
    ) -> KeptNodes {
        let mut copy = |label: &str, from: &wgpu::Buffer, words: u64, capacity_words: u64| {
            let buffer = kept_buffer(ctx, label, capacity_words, USAGE);
            timer.untimed(|encoder| {
                encoder.copy_buffer_to_buffer(from, 0, &buffer, 0, Some(words * 4))
            });
            buffer
        };
        let (n, cap) = (nodes as u64, capacity as u64);
        KeptNodes {
            child: copy("child", &self.child, n, cap),
            neighbours: copy("neighbours", &self.neighbours, n * 3, cap * 3),
            brick_plus_one: copy("brick index", &self.flags, n, cap),
            coord: copy("coordinates", &self.coord, n, cap),
            static_occupied: copy(
                "occupied nodes",
                &self.occupied,
                n.div_ceil(32),
                n.div_ceil(32),
            ),
        }
    }
}
