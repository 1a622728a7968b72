//! Visibility through the sparse voxel octree (VPL shadow segments, probe rays): the WGSL walk
//! (the module `voxel/svo/walk`, bound by [`walk_bindings`]), its CPU twin ([`SvoWalkCpu::occluded`]), an
//! independent CPU reference over a dense voxel set ([`segment_blocked_brute`]) and a GPU
//! harness that traces given segments ([`Tracer`]).
//!
//! Both ends of a shadow segment lie on voxelised surfaces. They are moved out of their own
//! voxels in two documented steps: each end moves `end_offset` voxels along its surface normal
//! (default 1.75, just over the voxel diagonal, so a plane's own voxel layer is left behind),
//! and the voxels holding the moved ends are never counted as occluders (they may still hold a
//! neighbouring surface in a corner, which would otherwise block every segment from there).

use crate::gpu::GpuContext;
use crate::voxel::svo::inject::LEAF_SUM_WORDS;
use crate::voxel::svo::Svo;
use crate::voxel::VoxelGrid;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::{IVec3, Vec3};
use std::collections::BTreeSet;

/// The first of the walk's six bindings in group 0 of every shader that imports
/// `voxel/svo/walk.wgsl` (parameters, child links, leaf sums, dynamic state, dynamic sums,
/// occupied static nodes), above every pass's own.
pub const WALK_BINDINGS: u32 = 44;

/// Bits of the fixed-point lattice per grid side: segment ends are points of a lattice of
/// 2^14 steps across the grid.
pub const FIXED_BITS: u32 = 14;

/// `SvoWalk` of `trace.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct SvoWalk {
    /// World position of the grid's corner.
    pub origin: [f32; 3],
    /// Voxel edge (m).
    pub voxel: f32,
    /// Octree levels (2^depth voxels per side).
    pub depth: u32,
    /// log2 of the lattice steps per voxel.
    pub shift: u32,
    /// First node of the finest level.
    pub first_leaf: u32,
    /// Static leaves (with an index word in the leaf sums).
    pub leaf_count: u32,
    /// Most cells one segment visits.
    pub cap: u32,
    /// Offset of the segment ends along their normals, in voxels.
    pub end_offset: f32,
    /// 1 when the octree has a dynamic part.
    pub dynamic: u32,
    /// Nodes of the static part: those the occupied-node bits cover.
    pub static_nodes: u32,
}

// `vpl_leaf_mask` reads a voxel's fragment count as word 3 of its dynamic sums.
const _: () = assert!(crate::voxel::svo::inject::LEAF_SUM_WORDS == 10);

/// The buffers the walk binds after its parameters: child links, leaf sums, the dynamic
/// part's node state and sums (16-byte placeholders without one), the occupied static nodes.
pub fn walk_buffers<'a>(svo: &'a Svo, placeholder: &'a wgpu::Buffer) -> [&'a wgpu::Buffer; 5] {
    let (state, sums) = match svo.dynamic.as_ref() {
        Some(d) => (d.state(), &d.sums),
        None => (placeholder, placeholder),
    };
    [
        &svo.child,
        &svo.leaf_sums,
        state,
        sums,
        &svo.static_occupied,
    ]
}

/// The bind-group entries of `walk.wgsl`'s bindings ([`WALK_BINDINGS`] on): `params` holds
/// the [`SvoWalk`] block, `placeholder` stands in for an absent dynamic part.
pub fn walk_bindings<'a>(
    params: &'a wgpu::Buffer,
    svo: &'a Svo,
    placeholder: &'a wgpu::Buffer,
) -> [(u32, wgpu::BindingResource<'a>); 6] {
    let [child, leaf, state, sums, occupied] = walk_buffers(svo, placeholder);
    let buffers = [params, child, leaf, state, sums, occupied];
    std::array::from_fn(|i| (WALK_BINDINGS + i as u32, buffers[i].as_entire_binding()))
}

impl SvoWalk {
    /// Parameters of the walk through `svo` with ends moved `end_offset` voxels.
    pub fn new(svo: &Svo, end_offset: f32) -> Result<SvoWalk> {
        let mut p = Self::from_parts(&svo.grid, svo.levels.last().copied(), end_offset)?;
        p.dynamic = svo.dynamic.is_some() as u32;
        p.static_nodes = svo.static_nodes;
        Ok(p)
    }

    fn from_parts(
        grid: &VoxelGrid,
        leaves: Option<(u32, u32)>,
        end_offset: f32,
    ) -> Result<SvoWalk> {
        let depth = grid.depth();
        if !(2..=10).contains(&depth) {
            return Err(Error::InvalidArgument(format!(
                "vpl: the octree must have 4 to 1024 voxels per side, not {}",
                grid.resolution
            )));
        }
        let (first_leaf, end) = leaves.unwrap_or((0, 0));
        Ok(SvoWalk {
            origin: grid.origin.to_array(),
            voxel: grid.voxel_size,
            depth,
            shift: FIXED_BITS - depth,
            first_leaf,
            leaf_count: end - first_leaf,
            cap: 3 * grid.resolution + depth + 2,
            end_offset,
            dynamic: 0,
            static_nodes: 0,
        })
    }

    /// The lattice point of world position `p` moved `end_offset` voxels along `n` (as
    /// `vpl_fixed_point` in `trace.wgsl`; float rounding may differ from a GPU by one step,
    /// 1/16 to 1/1024 voxel, which the tests avoid by handing both the same lattice points).
    pub fn fixed_point(&self, p: Vec3, n: Vec3) -> IVec3 {
        let g = (p + n * (self.end_offset * self.voxel) - Vec3::from(self.origin)) / self.voxel;
        let side = (1u32 << self.depth) as f32;
        let q = (g.clamp(Vec3::ZERO, Vec3::splat(side)) * (1u32 << self.shift) as f32).floor();
        q.as_ivec3()
            .clamp(IVec3::ONE, IVec3::splat((1 << FIXED_BITS) - 1))
    }
}

/// The octree's structure on the CPU, as the walk reads it.
#[derive(Clone, Debug)]
pub struct SvoWalkCpu {
    /// Walk parameters.
    pub params: SvoWalk,
    /// First child per node (0 = none).
    pub child: Vec<u32>,
    /// Per node, whether its cell holds a voxel (static or dynamic): the walk descends only
    /// into those.
    pub occupied: Vec<bool>,
    /// Per static leaf, the occupancy of its 2x2x2 voxels (bit x + 2y + 4z).
    pub leaf_masks: Vec<u32>,
    /// Per node, the occupancy its dynamic fragments add (empty without a dynamic part).
    pub dynamic_masks: Vec<u32>,
    /// The whole `leaf_sums` buffer: index words, then the static voxels' sums.
    pub leaf_sums: Vec<u32>,
    /// Per node, its dynamic sums slot + 1 (0 = none; empty without a dynamic part).
    pub dynamic_slots: Vec<u32>,
    /// The dynamic part's sums, [`LEAF_SUM_WORDS`] per voxel of each slot's 8.
    pub dynamic_sums: Vec<u32>,
}

impl SvoWalkCpu {
    /// Reads `svo`'s child links, leaf occupancy and fragment sums back.
    pub fn read(ctx: &GpuContext, svo: &Svo, params: SvoWalk) -> Result<SvoWalkCpu> {
        let words = |b: Vec<u8>| bytemuck::cast_slice::<u8, u32>(&b).to_vec();
        let child = words(crate::gpu::read_buffer(
            ctx,
            &svo.child,
            0,
            svo.node_count as u64 * 4,
        )?);
        let leaf_sums = words(crate::gpu::read_buffer(
            ctx,
            &svo.leaf_sums,
            0,
            svo.leaf_sums.size(),
        )?);
        let leaf_masks = leaf_sums
            .iter()
            .take(params.leaf_count as usize)
            .map(|w| w & 255)
            .collect();
        let (state, dynamic_sums) = match svo.dynamic.as_ref() {
            None => (Vec::new(), Vec::new()),
            Some(d) => (
                words(crate::gpu::read_buffer(
                    ctx,
                    d.state(),
                    0,
                    d.state().size(),
                )?),
                words(crate::gpu::read_buffer(ctx, &d.sums, 0, d.sums.size())?),
            ),
        };
        let static_bits = words(crate::gpu::read_buffer(
            ctx,
            &svo.static_occupied,
            0,
            svo.static_occupied.size(),
        )?);
        // As `svo_node_occupied` in `walk.wgsl`.
        let occupied = (0..child.len() as u32)
            .map(|n| {
                let static_bit = n < params.static_nodes
                    && static_bits
                        .get(n as usize / 32)
                        .is_some_and(|w| w & (1 << (n % 32)) != 0);
                let dynamic_bit =
                    params.dynamic != 0 && state.get(n as usize).is_some_and(|s| s & 1 != 0);
                static_bit || dynamic_bit
            })
            .collect();
        let dynamic_slots: Vec<u32> = state.iter().map(|s| s >> 2).collect();
        let words_per_voxel = LEAF_SUM_WORDS as usize;
        let dynamic_masks = dynamic_slots
            .iter()
            .map(|&slot| match slot {
                0 => 0,
                slot => (0..8)
                    .filter(|o| {
                        let at = ((slot - 1) * 8 + o) as usize * words_per_voxel + 3;
                        dynamic_sums.get(at).is_some_and(|&c| c != 0)
                    })
                    .fold(0, |m, o| m | 1 << o),
            })
            .collect();
        Ok(SvoWalkCpu {
            params,
            child,
            occupied,
            leaf_masks,
            dynamic_masks,
            leaf_sums,
            dynamic_slots,
            dynamic_sums,
        })
    }

    /// CPU twin of `svo_voxel_sums` (`trace.wgsl`): the fragment sums of voxel `v`, static
    /// and dynamic ([`LEAF_SUM_WORDS`] words; zero where `v` is empty).
    pub fn voxel_sums(&self, v: IVec3) -> [u32; LEAF_SUM_WORDS as usize] {
        let p = &self.params;
        let mut s = [0u32; LEAF_SUM_WORDS as usize];
        let mut node = 0u32;
        let mut k = p.depth;
        while k > 1 {
            let c = self.child.get(node as usize).copied().unwrap_or(0);
            if c == 0 {
                return s;
            }
            k -= 1;
            let o = (v >> k as i32) & IVec3::ONE;
            node = c + (o.x | (o.y << 1) | (o.z << 2)) as u32;
        }
        let o = ((v.x & 1) | ((v.y & 1) << 1) | ((v.z & 1) << 2)) as u32;
        let mut add = |words: &[u32], at: usize| {
            for (i, w) in s.iter_mut().enumerate() {
                *w = w.wrapping_add(words.get(at + i).copied().unwrap_or(0));
            }
        };
        let leaf = node.wrapping_sub(p.first_leaf);
        if leaf < p.leaf_count {
            let entry = self.leaf_sums[leaf as usize];
            let mask = entry & 255;
            if mask & (1 << o) != 0 {
                let slot = (entry >> 8) + (mask & ((1 << o) - 1)).count_ones();
                add(
                    &self.leaf_sums,
                    (p.leaf_count + slot * LEAF_SUM_WORDS) as usize,
                );
            }
        }
        match self.dynamic_slots.get(node as usize) {
            Some(&slot) if slot != 0 => add(
                &self.dynamic_sums,
                (((slot - 1) * 8 + o) * LEAF_SUM_WORDS) as usize,
            ),
            _ => {}
        }
        s
    }

    /// CPU twin of `svo_occluded` (`trace.wgsl`): the same integer steps.
    pub fn occluded(&self, a: IVec3, b: IVec3) -> bool {
        self.walk(a, b).0.is_some()
    }

    /// CPU twin of `svo_first_hit`: the first occupied voxel between the ends' voxels, and
    /// the number of cells the walk visited.
    pub fn walk(&self, a: IVec3, b: IVec3) -> (Option<IVec3>, u32) {
        let (hit, work) = self.walk_counted(a, b);
        (hit, work.cells)
    }

    /// [`SvoWalkCpu::walk`] with its work as the GPU walk counts it (`note_walk`).
    pub fn walk_counted(&self, a: IVec3, b: IVec3) -> (Option<IVec3>, WalkWork) {
        let p = &self.params;
        let d = b - a;
        let ad = d.abs();
        let mut work = WalkWork::default();
        if ad == IVec3::ZERO {
            return (None, work);
        }
        let first = voxel_at(a, d, 0, 1, p.shift);
        let mut v = first;
        // As `svo_first_hit`: the path of the last descent, valid from `reached` up.
        let mut path = [0u32; 16];
        let mut reached = p.depth;
        let mut prev = v;
        for it in 0..p.cap {
            let mut k = reached;
            while k < p.depth && (v >> k as i32) != (prev >> k as i32) {
                k += 1;
            }
            let mut node = path[k as usize];
            let mut occupied = false;
            work.cells = it + 1;
            loop {
                work.nodes += 1;
                if k == 1 {
                    let leaf = node.wrapping_sub(p.first_leaf);
                    let mask = self.leaf_masks.get(leaf as usize).copied().unwrap_or(0)
                        | self.dynamic_masks.get(node as usize).copied().unwrap_or(0);
                    if mask != 0 {
                        let bit = (v.x & 1) | ((v.y & 1) << 1) | ((v.z & 1) << 2);
                        occupied = mask & (1 << bit) != 0;
                        k = 0;
                    }
                    break;
                }
                let c = self.child.get(node as usize).copied().unwrap_or(0);
                if c == 0 || !self.occupied.get(node as usize).copied().unwrap_or(false) {
                    break;
                }
                k -= 1;
                let o = (v >> k as i32) & IVec3::ONE;
                node = c + (o.x | (o.y << 1) | (o.z << 2)) as u32;
                path[k as usize] = node;
            }
            reached = k.max(1);
            prev = v;
            let lo = (v >> k as i32) << k as i32;
            let mut dist = [0i32; 3];
            for i in 0..3 {
                let bound = if d[i] > 0 { lo[i] + (1 << k) } else { lo[i] } << p.shift;
                dist[i] = if d[i] > 0 { bound - a[i] } else { a[i] - bound };
            }
            let mut m = 3usize;
            for i in 0..3 {
                if ad[i] > 0 && (m == 3 || dist[i] * ad[m] < dist[m] * ad[i]) {
                    m = i;
                }
            }
            let (en, ed) = (dist[m], ad[m]);
            let holds_end = en >= ed;
            if occupied && !holds_end && v != first {
                return (Some(v), work);
            }
            if holds_end {
                return (None, work);
            }
            v = voxel_at(a, d, en, ed, p.shift);
        }
        (None, work)
    }
}

/// The work of one walk, as the GPU counts it (`note_walk` in `walk.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkWork {
    /// Cells visited (each a descent from the root and an exit face).
    pub cells: u32,
    /// Octree nodes the descents passed through.
    pub nodes: u32,
}

/// The voxel holding the point at time `tn / td` (+ an infinitesimal) of `a + t d` (as
/// `vpl_voxel_at` in `trace.wgsl`).
fn voxel_at(a: IVec3, d: IVec3, tn: i32, td: i32, shift: u32) -> IVec3 {
    let den = td << shift;
    IVec3::from_array(std::array::from_fn(|i| {
        let n = a[i] * td + d[i] * tn;
        if d[i] < 0 {
            (n + den - 1) / den - 1
        } else {
            n / den
        }
    }))
}

/// A time `num / den` (den > 0) on a segment, compared exactly.
#[derive(Clone, Copy)]
struct Time(i64, i64);

impl Time {
    fn lt(self, o: Time) -> bool {
        (self.0 as i128) * (o.1 as i128) < (o.0 as i128) * (self.1 as i128)
    }
}

/// Independent reference: whether the segment `a -> b` (lattice points, `2^shift` steps per
/// voxel) meets an occupied voxel of `voxels` in a piece of positive length, other than the
/// voxels holding its two ends. Voxels are half-open boxes `[v, v + 1)`, every voxel is tested
/// on its own with exact rational entry and exit times (no stepping).
pub fn segment_blocked_brute(voxels: &BTreeSet<[u32; 3]>, a: IVec3, b: IVec3, shift: u32) -> bool {
    first_blocker_brute(voxels, a, b, shift).is_some()
}

/// The blocking voxel of [`segment_blocked_brute`] the segment enters first.
pub fn first_blocker_brute(
    voxels: &BTreeSet<[u32; 3]>,
    a: IVec3,
    b: IVec3,
    shift: u32,
) -> Option<IVec3> {
    let d = b - a;
    if d == IVec3::ZERO {
        return None;
    }
    let step = 1i64 << shift;
    let entry = |v: &[u32; 3]| -> Option<Time> {
        // The times at which the segment is inside the slab of each axis: an interval whose
        // ends are included or not as the half-open box says; for positive-length pieces
        // only the interior matters, so the open interval (lo, hi) is enough.
        let mut lo = Time(0, 1);
        let mut hi = Time(1, 1);
        let mut lo_start = true;
        let mut hi_end = true;
        for i in 0..3 {
            let (a, d) = (a[i] as i64, d[i] as i64);
            let (b0, b1) = (v[i] as i64 * step, (v[i] as i64 + 1) * step);
            if d == 0 {
                if a < b0 || a >= b1 {
                    return None;
                }
                continue;
            }
            let (t0, t1) = if d > 0 {
                (Time(b0 - a, d), Time(b1 - a, d))
            } else {
                (Time(a - b1, -d), Time(a - b0, -d))
            };
            if lo.lt(t0) {
                lo = t0;
                lo_start = !Time(0, 1).lt(t0);
            }
            if t1.lt(hi) {
                hi = t1;
                hi_end = !t1.lt(Time(1, 1));
            }
        }
        // Crossed with positive length, and neither the first nor the last voxel crossed.
        (lo.lt(hi) && !lo_start && !hi_end).then_some(lo)
    };
    voxels
        .iter()
        .filter_map(|v| entry(v).map(|t| (t, v)))
        .reduce(|x, y| if y.0.lt(x.0) { y } else { x })
        .map(|(_, v)| IVec3::new(v[0] as i32, v[1] as i32, v[2] as i32))
}

/// What the test tracer counts: the walks' cells and nodes.
pub const TRACER_WORK: &[&str] = &["cells", "nodes"];

/// Traces segments on the GPU with `trace.wgsl` (for tests).
pub struct Tracer {
    pipeline: wgpu::ComputePipeline,
}

impl Tracer {
    /// Compiles the test kernel.
    /// On a counting context ([`GpuContext::with_work_counter`]) it counts the walks' cells
    /// and nodes as the pass `"walk test"` ([`TRACER_WORK`]).
    pub fn new(ctx: &GpuContext) -> Tracer {
        let source = crate::gpu::shader::compose_text(
            "walk test",
            include_str!("walk_test.wgsl"),
            &[ctx.work_feature()],
            &[],
        )
        .unwrap();
        let module = ctx.shader("walk test", &source);
        Tracer {
            pipeline: ctx.compute_pipeline("vpl trace test", &module, "main"),
        }
    }

    /// Per segment (pair of lattice points), the first voxel of `svo` that blocks it.
    pub fn trace(
        &self,
        ctx: &GpuContext,
        svo: &Svo,
        params: &SvoWalk,
        segments: &[(IVec3, IVec3)],
    ) -> Result<Vec<Option<IVec3>>> {
        let owner = "vpl trace test";
        let words: Vec<[i32; 8]> = segments
            .iter()
            .map(|(a, b)| [a.x, a.y, a.z, 0, b.x, b.y, b.z, 0])
            .collect();
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let params_buf = ctx.create_buffer_init(owner, "params", bytemuck::bytes_of(params), usage);
        let mut seg_bytes = bytemuck::cast_slice::<[i32; 8], u8>(&words).to_vec();
        seg_bytes.resize(seg_bytes.len().max(32), 0);
        let seg_buf = ctx.create_buffer_init(owner, "segments", &seg_bytes, usage);
        let out = ctx.create_buffer_init(
            owner,
            "results",
            &vec![0u8; segments.len().max(4) * 4],
            usage,
        );
        let placeholder = ctx.create_buffer_init(owner, "placeholder", &[0; 16], usage);
        let mut entries = vec![
            (3, seg_buf.as_entire_binding()),
            (4, out.as_entire_binding()),
        ];
        entries.extend(walk_bindings(&params_buf, svo, &placeholder));
        entries.extend(crate::gpu::work::entry(ctx, "walk test", TRACER_WORK)?);
        let group = crate::gpu::pass::bind(ctx, &self.pipeline, &entries);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups((segments.len() as u32).div_ceil(64), 1, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        let bytes = crate::gpu::read_buffer(ctx, &out, 0, segments.len() as u64 * 4)?;
        ctx.ledger.release_owner(owner);
        Ok(bytemuck::cast_slice::<u8, u32>(&bytes)
            .iter()
            .map(|&w| {
                let v = w.wrapping_sub(1);
                (w != 0).then(|| {
                    IVec3::new(
                        (v % 1024) as i32,
                        (v / 1024 % 1024) as i32,
                        (v >> 20) as i32,
                    )
                })
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(res: u32) -> SvoWalk {
        let grid = VoxelGrid::new(Vec3::ZERO, 1.0, res).unwrap();
        SvoWalk::from_parts(&grid, None, 1.75).unwrap()
    }

    #[test]
    fn an_empty_octree_blocks_nothing_and_the_walk_skips_empty_space() {
        // A root without children: one cell, one step, whatever the segment.
        let tree = SvoWalkCpu {
            params: params(64),
            child: vec![0],
            occupied: vec![false],
            leaf_masks: vec![],
            dynamic_masks: vec![],
            leaf_sums: vec![],
            dynamic_slots: vec![],
            dynamic_sums: vec![],
        };
        let f = 1 << tree.params.shift;
        let (hit, steps) = tree.walk(IVec3::splat(3), IVec3::new(60 * f, 61 * f, 2));
        assert!(hit.is_none());
        assert_eq!(steps, 1);
    }

    #[test]
    fn brute_reference_excludes_the_end_voxels_and_counts_the_ones_between() {
        let shift = 8;
        let f = 1 << shift;
        let wall: BTreeSet<[u32; 3]> = [[3, 1, 1]].into_iter().collect();
        let a = IVec3::new(f / 2, f + f / 2, f + f / 2);
        let b = IVec3::new(6 * f + f / 2, f + f / 2, f + f / 2);
        assert!(segment_blocked_brute(&wall, a, b, shift));
        // The same voxel at either end is not an occluder.
        let at_end: BTreeSet<[u32; 3]> = [[6, 1, 1]].into_iter().collect();
        assert!(!segment_blocked_brute(&at_end, a, b, shift));
        let at_start: BTreeSet<[u32; 3]> = [[0, 1, 1]].into_iter().collect();
        assert!(!segment_blocked_brute(&at_start, a, b, shift));
        // A segment along the face y = 2 belongs to the voxels above it (y = 2), not below.
        let below: BTreeSet<[u32; 3]> = [[3, 1, 1]].into_iter().collect();
        let above: BTreeSet<[u32; 3]> = [[3, 2, 1]].into_iter().collect();
        let (a2, b2) = (IVec3::new(a.x, 2 * f, a.z), IVec3::new(b.x, 2 * f, b.z));
        assert!(!segment_blocked_brute(&below, a2, b2, shift));
        assert!(segment_blocked_brute(&above, a2, b2, shift));
    }
}
