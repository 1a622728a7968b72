//! The static build (`svo/build.wgsl`): voxelize the triangles into fragments, then
//! [`SvoBuilder::build_with`] runs its passes in order: the structure, level by level; the
//! counts, read back once (the only wait of the build); the bricks, filled and filtered in
//! RGBA16F; their packing to RGBA8; the leaf sums injection reads; and exact-sized copies of
//! the node arrays, after which the scratch is released. A structure that outgrows its node
//! scratch is built again with twice as much ([`SvoBuilder::build_with_reserve`]). The
//! buffers the passes run over are in `build/buffers.rs`.

mod buffers;

use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::voxel::svo::control::{level_params, SvoControl, ARGS_SLOTS, CONTROL_BYTES, NODE_ARGS};
use crate::voxel::svo::dynamic::{DynamicReserve, StaticPart, SvoDynamic};
use crate::voxel::svo::limits::{self, Capacity};
use crate::voxel::svo::steps::{filter_steps, Dispatch};
use crate::voxel::svo::word_buffer;
use crate::voxel::svo::{Svo, SvoBuilder, BRICK_WORDS, BUILD_BRICK_WORDS, OWNER};
use crate::voxel::voxelize::FragmentList;
use crate::voxel::{VoxelGrid, VoxelTriangle};
use crate::{Error, Result};
use buffers::{pools, BuildNodes, KeptNodes, Scratch, USAGE};

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
        check_grid(grid)?;
        let mut timings = Vec::new();
        let list = self
            .voxelizer
            .fragments(ctx, OWNER, grid, tris, &mut timings)?;
        let max_nodes = limits::max_nodes(ctx);
        let mut capacity = (list.count as u64 * 4 + 4096).min(max_nodes as u64) as u32;
        let pool_bricks = self.pool_bricks(ctx);
        loop {
            let sizes = (grid.depth(), capacity, pool_bricks);
            match self.build_with(ctx, grid, &list, sizes, reserve, &mut timings)? {
                Some(svo) => {
                    forget_fragments(ctx);
                    return Ok((svo, timings));
                }
                None if capacity >= max_nodes => {
                    return Err(limits::too_many_nodes(grid.resolution, max_nodes))
                }
                None => capacity = (capacity as u64 * 2).min(max_nodes as u64) as u32,
            }
        }
    }

    /// Bricks per pool buffer: what the device can bind, capped by
    /// [`SvoBuilder::with_pool_limit`].
    fn pool_bricks(&self, ctx: &GpuContext) -> u32 {
        let device_pool = limits::max_pool_bricks(ctx);
        self.pool_limit
            .unwrap_or(device_pool)
            .min(device_pool)
            .max(1)
    }

    /// One build attempt with `capacity` nodes of scratch; `None` when they did not suffice.
    fn build_with(
        &self,
        ctx: &GpuContext,
        grid: &VoxelGrid,
        list: &FragmentList,
        sizes: (u32, u32, u32),
        reserve: DynamicReserve,
        timings: &mut Vec<PassTiming>,
    ) -> Result<Option<Svo>> {
        let mut scratch = Scratch::new(ctx);
        let attempt = self.attempt(ctx, &mut scratch, list, sizes);
        let mut timer = PassTimer::new(ctx);

        // 1. Structure: flag the occupied nodes and their 26-neighbourhoods, subdivide and
        //    link level by level, then mark the occupied nodes and give needed ones a brick.
        self.record_structure(ctx, &mut timer, &attempt);
        timings.extend(timer.finish_frame()?);

        // 2. Counts: the one read-back of the build. Too few nodes: try again with more;
        //    more than the GPU can bind: fail.
        let Some((counts, capacity)) = check_counts(ctx, grid, &attempt, reserve)? else {
            return Ok(None);
        };

        // 3. Bricks: fill the leaf bricks from the fragments, then transfer between
        //    neighbours and mip up the levels, in RGBA16F.
        let wide = self.record_bricks(ctx, &mut timer, &mut scratch, &attempt, &counts);

        // 4. Pack the bricks into the finished RGBA8 pool (with the reserve's room).
        let bricks = self.pack_bricks(ctx, &mut timer, &attempt, &wide, (&counts, &capacity));

        // 5. Sum the leaf voxels' fragments (albedo, emission, normal) for injection.
        let leaves = counts.level_ranges(attempt.depth).last().copied();
        let child = &attempt.nodes.child;
        let (leaf_sums, sum_timings) = self.light.accumulate(
            ctx,
            &mut timer,
            list,
            child,
            attempt.depth,
            leaves.unwrap_or((0, 0)),
        )?;
        timings.extend(sum_timings);

        // 6. Keep the node arrays at their exact size (plus the dynamic reserve, zeroed) and
        //    release the scratch.
        let nodes = (counts.node_count, capacity.nodes);
        let kept = attempt.nodes.keep(ctx, &mut timer, nodes.0, nodes.1);
        timings.extend(timer.finish_frame()?);
        scratch.release();

        // 7. The octree, with empty radiance (and facing) pools for injection to fill.
        let built = Built {
            counts,
            capacity,
            kept,
            bricks,
            leaf_sums,
        };
        Ok(Some(self.octree(ctx, grid, attempt, built, reserve)))
    }

    /// The buffers of one attempt of `(depth, capacity, pool_bricks)`: its scratch node
    /// arrays, and the control block, dispatch arguments (the root's written) and per-level
    /// parameters the octree keeps.
    fn attempt<'a>(
        &self,
        ctx: &GpuContext,
        scratch: &mut Scratch,
        list: &'a FragmentList,
        (depth, capacity, pool_bricks): (u32, u32, u32),
    ) -> Attempt<'a> {
        let nodes = BuildNodes::new(scratch, capacity);
        let control = word_buffer(ctx, "control", CONTROL_BYTES / 4, USAGE);
        let indirect = USAGE | wgpu::BufferUsages::INDIRECT;
        let args = word_buffer(ctx, "dispatch args", 3 * ARGS_SLOTS, indirect);
        start_at_root(ctx, &control, &args);
        let params = level_params(
            ctx,
            "level params",
            depth,
            list.count,
            capacity,
            pool_bricks,
        );
        let args_group = self.args_group(ctx, &args);
        Attempt {
            list,
            depth,
            capacity,
            pool_bricks,
            nodes,
            control,
            args,
            params,
            args_group,
        }
    }

    /// Group 0 of the attempt's kernels, with `pools` at the brick pool bindings.
    fn attempt_group(
        &self,
        ctx: &GpuContext,
        a: &Attempt,
        pools: [&wgpu::Buffer; 4],
    ) -> wgpu::BindGroup {
        let n = &a.nodes;
        self.group0(
            ctx,
            &a.params,
            [
                &a.list.buffer,
                &a.list.triangles,
                &n.child,
                &n.neighbours,
                &n.coord,
                &n.brick_plus_one,
                &a.control,
                pools[0],
                pools[1],
                pools[2],
                pools[3],
            ],
        )
    }

    /// Records the structure pass ([`structure_steps`]). No brick exists yet: pool 0's
    /// binding holds the occupied-node bits `mark_occupied` writes (a binding of its own would
    /// take the dynamic update's kernels past the 20 storage buffers per stage octolux asks
    /// of a device).
    fn record_structure(&self, ctx: &GpuContext, timer: &mut PassTimer, a: &Attempt) {
        let n = &a.nodes;
        let pools = [&n.occupied, &n.placeholder, &n.placeholder, &n.placeholder];
        let structure = self.attempt_group(ctx, a, pools);
        let steps = structure_steps(a.depth, a.capacity);
        let groups = (&a.args_group, None);
        let count = a.list.count;
        self.record(
            timer,
            "svo structure",
            &structure,
            groups,
            &a.args,
            count,
            &steps,
        );
    }

    /// Records the brick pass into a scratch RGBA16F pool for the `counts`' bricks, which it
    /// returns: the leaf bricks accumulated and filled from the fragments, then filtered up
    /// the levels ([`filter_steps`]).
    fn record_bricks(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        scratch: &mut Scratch,
        a: &Attempt,
        counts: &SvoControl,
    ) -> Vec<wgpu::Buffer> {
        let label = "brick pool (build, RGBA16F)";
        let wide = scratch.pools(label, counts.brick_count, a.pool_bricks);
        let filling = self.attempt_group(ctx, a, [&wide[0], &wide[1], &wide[2], &wide[3]]);
        let leaf = a.depth - 1;
        let mut steps = vec![
            ("leaf_accumulate", leaf, Dispatch::Fragments),
            ("leaf_fill", leaf, Dispatch::PerNode(leaf)),
        ];
        steps.extend(filter_steps(a.depth, false, self.fuse_coarse));
        let groups = (&a.args_group, None);
        let count = a.list.count;
        self.record(
            timer,
            "svo bricks",
            &filling,
            groups,
            &a.args,
            count,
            &steps,
        );
        wide
    }

    /// Records the packing of the RGBA16F pool `wide` into the finished RGBA8 pool, made for
    /// the octree's brick capacity, which it returns.
    fn pack_bricks(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        a: &Attempt,
        wide: &[wgpu::Buffer],
        (counts, capacity): (&SvoControl, &Capacity),
    ) -> Vec<wgpu::Buffer> {
        let bricks = pools(
            ctx,
            "brick pool",
            BRICK_WORDS,
            capacity.bricks,
            a.pool_bricks,
        );
        let wide_and_narrow = (wide, bricks.as_slice());
        self.pack.record(
            ctx,
            timer,
            wide_and_narrow,
            counts.brick_count,
            a.pool_bricks,
        );
        bricks
    }

    /// The octree of a finished attempt, with empty radiance (and facing) pools and, with a
    /// reserve, its dynamic part.
    fn octree(
        &self,
        ctx: &GpuContext,
        grid: &VoxelGrid,
        attempt: Attempt,
        built: Built,
        reserve: DynamicReserve,
    ) -> Svo {
        let Built {
            counts,
            capacity,
            kept,
            bricks,
            leaf_sums,
        } = built;
        let (depth, pool_bricks) = (attempt.depth, attempt.pool_bricks);
        let levels = counts.level_ranges(depth);
        let leaves = levels.last().copied().unwrap_or((0, 0));
        let pool = |label: &str, words: u32| pools(ctx, label, words, capacity.bricks, pool_bricks);
        let leaf_voxels = (leaves.1 - leaves.0 + reserve.nodes) as u64 * 8;
        let (node_count, brick_count) = (counts.node_count, counts.brick_count);
        Svo {
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
            fragment_count: attempt.list.count,
            coord: kept.coord,
            control: attempt.control,
            args: attempt.args,
            level_params: attempt.params,
            leaf_sums,
            radiance: pool("radiance pool", BUILD_BRICK_WORDS),
            facing: self.facing.then(|| pool("facing pool", BUILD_BRICK_WORDS)),
            // RGBA16F: two words per voxel.
            voxel_radiance: word_buffer(ctx, "voxel radiance", leaf_voxels * 2, USAGE),
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
        }
    }
}

/// The buffers one build attempt records its passes over.
struct Attempt<'a> {
    list: &'a FragmentList,
    /// Levels, node capacity of the scratch, bricks per pool buffer.
    depth: u32,
    capacity: u32,
    pool_bricks: u32,
    /// Scratch node arrays, sized for the attempt's node capacity.
    nodes: BuildNodes,
    /// The control block, dispatch arguments and per-level parameters the octree keeps.
    control: wgpu::Buffer,
    args: wgpu::Buffer,
    params: wgpu::Buffer,
    /// Group 1 over `args`.
    args_group: wgpu::BindGroup,
}

/// What the passes of a successful attempt made, for [`SvoBuilder::octree`].
struct Built {
    counts: SvoControl,
    capacity: Capacity,
    kept: KeptNodes,
    bricks: Vec<wgpu::Buffer>,
    leaf_sums: wgpu::Buffer,
}

/// The octree needs a supported grid of at least 4^3 voxels.
fn check_grid(grid: &VoxelGrid) -> Result<()> {
    crate::voxel::check_resolution(grid.resolution)?;
    if grid.resolution < 4 {
        return Err(Error::InvalidArgument(
            "octree resolution must be at least 4".into(),
        ));
    }
    Ok(())
}

/// The attempt's counts (the build's one read-back) and the octree's capacity: `None` when
/// the structure outgrew the node scratch, an error when the octree (with `reserve`) is more
/// than the GPU can bind.
fn check_counts(
    ctx: &GpuContext,
    grid: &VoxelGrid,
    attempt: &Attempt,
    reserve: DynamicReserve,
) -> Result<Option<(SvoControl, Capacity)>> {
    let counts = SvoControl::from_bytes(&read_buffer(ctx, &attempt.control, 0, CONTROL_BYTES)?);
    if counts.node_overflow != 0 {
        return Ok(None);
    }
    let sizes = (counts.node_count, counts.brick_count);
    let capacity = Capacity::check(ctx, grid.resolution, sizes, reserve, attempt.pool_bricks)?;
    Ok(Some((counts, capacity)))
}

/// The ledger no longer counts the build's fragment list and triangles (the GPU frees them
/// after their last use).
fn forget_fragments(ctx: &GpuContext) {
    ctx.ledger.forget(OWNER, "fragments");
    ctx.ledger.forget(OWNER, "triangles");
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
