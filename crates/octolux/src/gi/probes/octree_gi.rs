//! `probes-octree`: `004`'s adaptive probe octree on the GPU. The octree (the encoding of
//! [`super::octree`], one `i32` buffer), its free lists and leaf ring live in GPU buffers; the
//! state machine runs in three compute passes per frame (octree.wgsl), driven by each probe's
//! surfel hit count inside its cube, and reaches the same buffers bit for bit as the CPU
//! specification [`super::octree::ProbeOctree`] from the same hit counts (tested).
//! Leaves whose cubes meet the old or new bounds of a moving object are re-placed (L1) or ask
//! for a probe (M1). Placement, surfel light, integration and the gather are the shared probe
//! passes over the octree's probe set (octree_set.wgsl, octree_sample.wgsl); a pixel reads the
//! probes of the few leaves around it ([`ProbeOctreeView::irradiance`] is the CPU twin).

use super::encoding::COEFFS;
use super::engine::{
    buf, facing_weight, module, run_pass, ProbeEngine, ProbeLayout, ProbeSetModules, SetPass,
    PROBE_VEC4,
};
use super::grid_gi::FORGETTING;
use super::history::{Changes, FrameChanges, RayPlan};
use super::moments::MomentMaps;
use super::octree::{OctreeRule, ProbeOctree};
use super::params::probe_storage;
use super::{OctreeGather, ProbeSettings, SurfelRange};
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::pass::KeptBindGroup;
use crate::gpu::shader::library_shader_with;
use crate::gpu::work::WorkRegion;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::Scene;
use crate::{Error, Result};
use glam::{UVec3, Vec3};

const OWNER: &str = "probes-octree";
/// Words before the free lists in the state buffer (`STATE_HEAD` in octree.wgsl): the tops of
/// the two free lists ([`STATE_PROBE_TOP`], [`STATE_CLUSTER_TOP`]), 2 spare.
const STATE_HEAD: usize = 4;
/// The state word holding the probes' free-list top (`STATE_PROBE_TOP` in octree.wgsl).
const STATE_PROBE_TOP: usize = 0;
/// The state word holding the clusters' free-list top (`STATE_CLUSTER_TOP` in octree.wgsl).
const STATE_CLUSTER_TOP: usize = 1;

/// `OctreeParams` in octree_params.wgsl (the same fields at the same offsets; tested).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct OctreeParams {
    /// Lower corner of the root cube.
    root_lo: [f32; 3],
    /// Edge of the root cube.
    root_size: f32,
    /// Words in the tree buffer.
    tree_words: u32,
    /// Probe slots.
    probe_slots: u32,
    /// Clusters.
    clusters: u32,
    /// Deepest level.
    max_depth: u32,
    /// Ring origin of this frame.
    ring_origin: u32,
    /// Moved boxes.
    moved_boxes: u32,
    /// Hits below which a probe is freed.
    free_below: u32,
    /// Hits from which a leaf splits.
    split_from: u32,
    /// 1: surfels beyond the probe's cube are kept (lit, not counted).
    keep_outside: u32,
    /// Gather 0 through the octree, 1 over all probes.
    gather_all: u32,
    /// 1: place every live probe this frame.
    place_all: u32,
    /// Levels complete down to this depth ([`OctreeRule::min_depth`]).
    min_depth: u32,
    /// Surfels per probe (of both sets with a history): the place and light passes'
    /// invocations per listed probe.
    surfels_per_probe: u32,
    /// Invocations per listed probe of the moment maps' pass (`MOMENT_LANES`).
    moment_lanes: u32,
    _pad: [u32; 2],
}

/// What the memory update counts (octree.wgsl): tree nodes it sweeps (every pass over the
/// tree; the dispatch size), live probes listed, probes allocated and freed.
const MEMORY_WORK: &[&str] = &["nodes", "live probes", "probes allocated", "probes freed"];
/// What the light select counts: nodes (one invocation each), nodes the leaf ring queued,
/// moved-box tests, probes asked to place their surfels.
const SELECT_WORK: &[&str] = &["nodes", "queued nodes", "box tests", "placements"];
/// What the light decide counts: nodes (one invocation each), leaves decided.
const DECIDE_WORK: &[&str] = &["nodes", "leaves decided"];

/// The probe octree in GPU buffers and the passes of its state machine.
pub struct GpuProbeOctree {
    rule: OctreeRule,
    params: OctreeParams,
    params_buffer: wgpu::Buffer,
    tree: wgpu::Buffer,
    probe_info: wgpu::Buffer,
    place_flags: wgpu::Buffer,
    hits: wgpu::Buffer,
    state: wgpu::Buffer,
    ring: wgpu::Buffer,
    boxes: wgpu::Buffer,
    box_room: usize,
    /// The live probes' count and slots, listed by the memory update.
    live: wgpu::Buffer,
    /// The shared passes' indirect dispatches over them.
    live_args: wgpu::Buffer,
    memory_update: wgpu::ComputePipeline,
    light_select: wgpu::ComputePipeline,
    light_decide: wgpu::ComputePipeline,
    origin: u32,
    /// The bind groups of memory update, light select and light decide, kept while their
    /// resources are.
    groups: [KeptBindGroup; 3],
    /// Their work regions, where the context counts work.
    work: [Option<WorkRegion>; 3],
}

/// Creates a storage buffer holding `data` under `owner`.
fn init(ctx: &GpuContext, label: &str, data: &[u8]) -> Result<wgpu::Buffer> {
    let b = probe_storage(ctx, OWNER, label, data.len() as u64)?;
    ctx.queue.write_buffer(&b, 0, data);
    Ok(b)
}

impl GpuProbeOctree {
    /// An octree over the cube at `lo` of edge `size` with room for the full tree of
    /// `rule.max_depth` levels, its levels above `rule.min_depth` built (as
    /// [`ProbeOctree::new`] with [`OctreeRule::full_capacity`]).
    pub fn new(ctx: &GpuContext, rule: OctreeRule, lo: Vec3, size: f32) -> Result<GpuProbeOctree> {
        let (len, capacity) = rule.full_capacity();
        Self::with_room(ctx, rule, lo, size, len, capacity)
    }

    /// [`GpuProbeOctree::new`] with a tree buffer of `len` words and `capacity` probe slots (a tree
    /// smaller than the full one, to exercise allocation failures and reuse).
    pub fn with_room(
        ctx: &GpuContext,
        rule: OctreeRule,
        lo: Vec3,
        size: f32,
        len: usize,
        capacity: u32,
    ) -> Result<GpuProbeOctree> {
        // The CPU specification builds the levels above `min_depth`; the GPU starts from its
        // state, word for word.
        let cpu = ProbeOctree::new(len, capacity, lo, size, rule);
        let clusters = (len - 1) / 9;
        let (free_probes, free_clusters) = cpu.free_lists();
        let mut state = vec![0u32; STATE_HEAD + capacity as usize + clusters + 3 * len];
        state[STATE_PROBE_TOP] = free_probes.len() as u32;
        state[STATE_CLUSTER_TOP] = free_clusters.len() as u32;
        state[STATE_HEAD..STATE_HEAD + free_probes.len()].copy_from_slice(free_probes);
        let c0 = STATE_HEAD + capacity as usize;
        state[c0..c0 + free_clusters.len()].copy_from_slice(free_clusters);
        let marks = c0 + clusters;
        for (word, &no_split) in state[marks..marks + len].iter_mut().zip(cpu.no_split()) {
            *word = no_split as u32;
        }
        let (ring, origin) = cpu.ring_codes();
        let info = cpu.probe_info();
        let params = OctreeParams {
            root_lo: lo.to_array(),
            root_size: size,
            tree_words: len as u32,
            probe_slots: capacity,
            clusters: clusters as u32,
            max_depth: rule.max_depth,
            ring_origin: 0,
            moved_boxes: 0,
            free_below: rule.free_below(),
            split_from: rule.split_from(),
            keep_outside: 0,
            gather_all: 0,
            place_all: 0,
            min_depth: rule.min_depth,
            surfels_per_probe: rule.surfels,
            moment_lanes: super::moments::MOMENT_LANES,
            _pad: [0; 2],
        };
        let source = library_shader_with(
            "gi/probes/octree",
            &[ctx.work_feature()],
            &[(
                "gi/probes/tree_bindings",
                module("gi/probes/octree_tree_write"),
            )],
        );
        let module = ctx.shader("probes octree", &source);
        let zeros = |n: usize| vec![0u8; 4 * n];
        let mut work = [None; 3];
        if let Some(counter) = ctx.work() {
            let passes = [
                ("memory update", MEMORY_WORK),
                ("light select", SELECT_WORK),
                ("light decide", DECIDE_WORK),
            ];
            for (slot, (pass, quantities)) in work.iter_mut().zip(passes) {
                *slot = Some(counter.region(&format!("{OWNER} {pass}"), quantities)?);
            }
        }
        Ok(GpuProbeOctree {
            rule,
            params,
            params_buffer: init(ctx, "octree params", bytemuck::bytes_of(&params))?,
            tree: init(ctx, "octree", bytemuck::cast_slice(&cpu.nodes))?,
            probe_info: init(ctx, "octree probe info", bytemuck::cast_slice(&info))?,
            place_flags: init(ctx, "octree place flags", &zeros(capacity as usize))?,
            hits: init(ctx, "octree hits", &zeros(capacity as usize))?,
            state: init(ctx, "octree free lists", bytemuck::cast_slice(&state))?,
            ring: init(ctx, "octree leaf ring", bytemuck::cast_slice(&ring))?,
            boxes: init(ctx, "octree moved boxes", &zeros(8))?,
            box_room: 1,
            live: init(ctx, "octree live probes", &zeros(1 + capacity as usize))?,
            live_args: ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some("octree live dispatch"),
                    size: crate::gpu::pass::indirect_offset(super::engine::LIVE_SLOTS),
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::INDIRECT
                        | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            ),
            memory_update: ctx.compute_pipeline("memory update", &module, "memory_update"),
            light_select: ctx.compute_pipeline("light select", &module, "light_select"),
            light_decide: ctx.compute_pipeline("light decide", &module, "light_decide"),
            origin: origin as u32,
            groups: Default::default(),
            work,
        })
    }

    /// The split/free rule.
    pub fn rule(&self) -> &OctreeRule {
        &self.rule
    }

    /// Probe slots.
    pub fn capacity(&self) -> u32 {
        self.params.probe_slots
    }

    /// The buffers a test reads back: the tree, the probe info, the state (free-list tops,
    /// free lists, per-node marks) and the ring.
    pub fn buffers(&self) -> [&wgpu::Buffer; 4] {
        [&self.tree, &self.probe_info, &self.state, &self.ring]
    }

    /// Probes allocated, read back from the GPU (for tools and tests; waits for the GPU).
    pub fn probe_count(&self, ctx: &GpuContext) -> Result<u32> {
        let words = crate::gpu::read_buffer(ctx, &self.state, 0, 4)?;
        Ok(self.capacity() - bytemuck::cast_slice::<u8, u32>(&words)[0])
    }

    /// The per-probe hit counts `light_decide` reads (the integration writes them).
    pub fn hits_buffer(&self) -> &wgpu::Buffer {
        &self.hits
    }

    /// Uploads this frame's parameters: the ring origin, the moved boxes, the modes
    /// (`keep_outside`, `gather_all`, `place_all` of `OctreeParams`).
    pub fn begin_frame(
        &mut self,
        ctx: &GpuContext,
        moved: &[(Vec3, Vec3)],
        modes: [u32; 3],
    ) -> Result<()> {
        if moved.len() > self.box_room {
            self.boxes = probe_storage(ctx, OWNER, "octree moved boxes", moved.len() as u64 * 32)?;
            self.box_room = moved.len();
        }
        let boxes: Vec<[f32; 4]> = moved
            .iter()
            .flat_map(|(lo, hi)| [lo.extend(0.0).to_array(), hi.extend(0.0).to_array()])
            .collect();
        if !boxes.is_empty() {
            ctx.queue
                .write_buffer(&self.boxes, 0, bytemuck::cast_slice(&boxes));
        }
        self.params.ring_origin = self.origin;
        self.params.moved_boxes = moved.len() as u32;
        let [keep_outside, gather_all, place_all] = modes;
        self.params.keep_outside = keep_outside;
        self.params.gather_all = gather_all;
        self.params.place_all = place_all;
        ctx.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        Ok(())
    }

    /// The memory update (M states).
    pub fn memory_update(&self, ctx: &GpuContext, timer: &mut PassTimer) {
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.tree)),
            (2, buf(&self.probe_info)),
            (5, buf(&self.state)),
            (6, buf(&self.ring)),
            (8, buf(&self.live)),
            (9, buf(&self.live_args)),
        ];
        entries.extend(self.count_nodes(ctx, 0));
        let group = self.groups[0].get(ctx, "memory update", &self.memory_update, &entries);
        run_pass(
            timer,
            "memory update",
            &self.memory_update,
            &[&group],
            (1, 1),
        );
    }

    /// Where `ctx` counts work: adds the tree's nodes to quantity 0 of pass `pass`'s region
    /// (its dispatch size: every pass sweeps or runs over every node) and gives the region's
    /// bind group entry.
    fn count_nodes<'a>(
        &self,
        ctx: &'a GpuContext,
        pass: usize,
    ) -> Option<(u32, wgpu::BindingResource<'a>)> {
        let (work, region) = ctx.work().zip(self.work[pass])?;
        work.add(region, 0, self.params.tree_words as u64);
        Some(work.entry(region))
    }

    fn node_groups(&self) -> (u32, u32) {
        (self.params.tree_words.div_ceil(64), 1)
    }

    /// The light update's first half: moved geometry, L1 leaves ask for surfels.
    pub fn light_select(&self, ctx: &GpuContext, timer: &mut PassTimer) {
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.tree)),
            (3, buf(&self.place_flags)),
            (5, buf(&self.state)),
            (6, buf(&self.ring)),
            (7, buf(&self.boxes)),
        ];
        entries.extend(self.count_nodes(ctx, 1));
        let group = self.groups[1].get(ctx, "light select", &self.light_select, &entries);
        let size = self.node_groups();
        run_pass(timer, "light select", &self.light_select, &[&group], size);
    }

    /// The light update's second half: the split/free rule from the hit counts.
    pub fn light_decide(&self, ctx: &GpuContext, timer: &mut PassTimer) {
        let mut entries = vec![
            (0, buf(&self.params_buffer)),
            (1, buf(&self.tree)),
            (2, buf(&self.probe_info)),
            (3, buf(&self.place_flags)),
            (4, buf(&self.hits)),
            (5, buf(&self.state)),
            (6, buf(&self.ring)),
        ];
        entries.extend(self.count_nodes(ctx, 2));
        let group = self.groups[2].get(ctx, "light decide", &self.light_decide, &entries);
        let size = self.node_groups();
        run_pass(timer, "light decide", &self.light_decide, &[&group], size);
    }

    /// Ends the frame: the next pull origin (`004`: p <- (p + 2) mod 3).
    pub fn end_frame(&mut self) {
        self.origin = (self.origin + 2) % 3;
    }

    /// The live probes the memory update listed: word 0 their count, then their slots in
    /// increasing order (for tests; the shared passes read it on the GPU).
    pub fn live_buffer(&self) -> &wgpu::Buffer {
        &self.live
    }

    /// The shared passes' indirect dispatches over the live probes (workgroups of 64): place
    /// and light (one invocation per surfel) at byte 0, the moments at 12, the integration at
    /// 24.
    pub fn live_args(&self) -> &wgpu::Buffer {
        &self.live_args
    }

    /// Bind group 1 (octree_set.wgsl) of a shared probe pass, with the bindings it uses:
    /// `uses` holds params, tree, probe info, place flags, hits, live probes.
    fn set_group(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        uses: [bool; 6],
    ) -> wgpu::BindGroup {
        let all = [
            &self.params_buffer,
            &self.tree,
            &self.probe_info,
            &self.place_flags,
            &self.hits,
            &self.live,
        ];
        let entries: Vec<(u32, wgpu::BindingResource)> = all
            .iter()
            .enumerate()
            .filter(|&(i, _)| uses[i])
            .map(|(i, b)| (i as u32, buf(b)))
            .collect();
        crate::gpu::pass::bind_group_at(ctx, Some("probes octree set"), pipeline, 1, &entries)
    }
}

/// `VISIBLE_SHARE` of octree_sample.wgsl: the octree gather widens its box while the probes
/// it found weigh less than this share of their weight without visibility.
const VISIBLE_SHARE: f32 = 0.1;

/// The octree as the gather reads it, on the CPU: the CPU twin of octree_sample.wgsl over
/// buffers read back from the GPU.
pub struct ProbeOctreeView<'a> {
    /// Lower corner of the root cube.
    pub lo: Vec3,
    /// Edge of the root cube.
    pub size: f32,
    /// Deepest level.
    pub max_depth: u32,
    /// Gather offset along the normal (m).
    pub bias: f32,
    /// The tree buffer.
    pub nodes: &'a [i32],
    /// Per probe slot: position and depth, or (0, 0, 0, -1).
    pub info: &'a [[f32; 4]],
    /// The moment maps and variance floor where the gather weighs by visibility.
    pub moments: Option<MomentMaps<'a>>,
}

impl ProbeOctreeView<'_> {
    /// The leaf holding `q` (inside the root cube) and its depth: `octree_leaf`.
    pub fn leaf(&self, q: Vec3) -> (u32, u32) {
        let (mut node, mut lo, mut size) = (0u32, self.lo, self.size);
        for d in 0..=self.max_depth {
            let v = self.nodes[node as usize];
            if v <= 0 {
                return (node, d);
            }
            let half = size * 0.5;
            let upper = q.cmpge(lo + Vec3::splat(half));
            lo += Vec3::select(upper, Vec3::splat(half), Vec3::ZERO);
            size = half;
            node = v as u32 + 1 + upper.bitmask();
        }
        (node, self.max_depth)
    }

    fn visibility(&self, probe: usize, x: Vec3, q: Vec3) -> f32 {
        self.moments.map_or(1.0, |m| m.visibility(probe, x, q))
    }

    fn edge(&self, probe: usize) -> f32 {
        self.size * 2f32.powi(-(self.info[probe][3] as i32))
    }

    /// Irradiance at `p` (unit normal `n`) from `probes` (the probe buffer's `vec4`s):
    /// `probes_irradiance` of octree_sample.wgsl.
    pub fn irradiance(
        &self,
        settings: &ProbeSettings,
        probes: &[[f32; 4]],
        p: Vec3,
        n: Vec3,
    ) -> Vec3 {
        let q = p + n * self.bias;
        let valid = |probe: usize| probes[probe * PROBE_VEC4 as usize + 8][2] >= 0.5;
        let value = |probe: usize| {
            let b = probe * PROBE_VEC4 as usize;
            let coeffs: [Vec3; COEFFS] = std::array::from_fn(|k| Vec3::from_slice(&probes[b + k]));
            settings.encoding.irradiance(&coeffs, n)
        };
        let (mut sum, mut total) = (Vec3::ZERO, 0.0f32);
        if settings.gather == OctreeGather::All {
            for (probe, info) in self.info.iter().enumerate() {
                if info[3] < 0.0 || !valid(probe) {
                    continue;
                }
                let x = Vec3::from_slice(info);
                let r = x - q;
                let e = self.edge(probe) * 0.5;
                let w = facing_weight(x - p, n)
                    * self.visibility(probe, x, q)
                    * 2f32.powi(-3 * info[3] as i32)
                    / r.dot(r).max(e * e);
                sum += value(probe) * w;
                total += w;
            }
        } else {
            let (lo, hi) = (self.lo, self.lo + Vec3::splat(self.size));
            let (_, depth) = self.leaf(q.clamp(lo, hi));
            let mut h = self.size * 2f32.powi(-(depth as i32)) * 0.5;
            for _ in 0..=self.max_depth + 1 {
                let mut seen = Vec::new();
                let mut open = 0.0f32;
                (sum, total) = (Vec3::ZERO, 0.0);
                for c in 0..8u32 {
                    let upper = glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0);
                    let corner =
                        (q + Vec3::select(upper, Vec3::splat(h), Vec3::splat(-h))).clamp(lo, hi);
                    let v = self.nodes[self.leaf(corner).0 as usize];
                    if v >= 0 || seen.contains(&(!v as usize)) {
                        continue;
                    }
                    let probe = !v as usize;
                    seen.push(probe);
                    if !valid(probe) {
                        continue;
                    }
                    let x = Vec3::from_slice(&self.info[probe]);
                    let tent =
                        (Vec3::ONE - (q - x).abs() / self.edge(probe).max(2.0 * h)).max(Vec3::ZERO);
                    let w0 = tent.x * tent.y * tent.z * facing_weight(x - p, n);
                    let w = w0 * self.visibility(probe, x, q);
                    sum += value(probe) * w;
                    total += w;
                    open += w0;
                }
                if total > 0.0 && total >= VISIBLE_SHARE * open {
                    break;
                }
                h *= 2.0;
            }
        }
        if total > 0.0 {
            sum / total
        } else {
            Vec3::ZERO
        }
    }
}

/// The root cube of the octree over `bounds`: centred on them, edge the largest extent plus
/// 2 %, so that walls on the bounds lie inside the cubes that touch them rather than on
/// their faces.
pub fn root_cube(bounds: (Vec3, Vec3)) -> Result<(Vec3, f32)> {
    let (lo, hi) = bounds;
    let size = (hi - lo).max_element() * 1.02;
    if !(size.is_finite() && size > 0.0) {
        return Err(Error::InvalidArgument(format!(
            "probes need a scene with extent; its bounds are {lo} to {hi}"
        )));
    }
    Ok(((lo + hi) * 0.5 - Vec3::splat(size * 0.5), size))
}

/// Probe + surfel GI on `004`'s adaptive octree.
pub struct ProbesOctree {
    passes: ProbeEngine,
    octree: GpuProbeOctree,
    root: (Vec3, f32),
    bias: f32,
    /// What changed from frame to frame.
    changes: FrameChanges,
    /// The rays of each frame (with a history).
    rays: RayPlan,
    /// Bind group 1 of place, light, integrate, gather and the moments.
    groups: [wgpu::BindGroup; 5],
    /// Boxes of the objects that moved in the last frame.
    moved: Vec<(Vec3, Vec3)>,
}

impl ProbesOctree {
    /// Probes the octree keeps now, read back from the GPU (for stats and tests; waits for the
    /// GPU, so never inside a frame).
    pub fn probe_count(&self, ctx: &GpuContext) -> Result<u32> {
        self.octree.probe_count(ctx)
    }

    /// The technique for `scene` at `width` x `height`.
    pub fn new(
        ctx: &GpuContext,
        settings: &ProbeSettings,
        scene: &Scene,
        width: u32,
        height: u32,
    ) -> Result<ProbesOctree> {
        let settings = &settings.for_technique(true)?;
        let (lo, size) = root_cube(scene.gi_bounds_at(0.0))?;
        let rule = settings.octree_rule();
        let (len, _) = rule.full_capacity();
        let mut octree =
            GpuProbeOctree::with_room(ctx, rule, lo, size, len, settings.octree_probe_slots())?;
        // The shared passes run over every surfel of both sets with a history.
        octree.params.surfels_per_probe = settings.surfel_count() * settings.surfel_sets();
        let bias = settings.normal_bias * size * 2f32.powi(-(rule.max_depth as i32));
        let layout = ProbeLayout {
            lo,
            spacing: Vec3::ZERO,
            dims: UVec3::ZERO,
            bias,
            cell: size * 2f32.powi(-(rule.max_depth as i32)),
            probes: octree.capacity(),
        };
        let set = ProbeSetModules {
            set: "gi/probes/octree_set",
            sample: "gi/probes/octree_sample",
            tree: Some("gi/probes/octree_tree_read"),
            sample_work: super::engine::OCTREE_SAMPLE_WORK,
        };
        let passes = ProbeEngine::new(ctx, OWNER, settings, scene, (width, height), &layout, &set)?;
        // Bind group 1 of each shared pass: params, tree, probe info, place flags, hits, live
        // probes (the place flags also say which probes restart their histories).
        let groups = [
            octree.set_group(ctx, &passes.place, [true, false, true, true, false, true]),
            octree.set_group(ctx, &passes.light, [true, true, true, true, false, true]),
            octree.set_group(
                ctx,
                &passes.integrate,
                [false, false, true, true, true, true],
            ),
            octree.set_group(ctx, &passes.gather, [true, true, true, false, false, false]),
            octree.set_group(
                ctx,
                &passes.moments_build,
                [true, false, true, true, false, true],
            ),
        ];
        Ok(ProbesOctree {
            passes,
            octree,
            root: (lo, size),
            bias,
            changes: FrameChanges::default(),
            rays: RayPlan::default(),
            groups,
            moved: Vec::new(),
        })
    }

    /// The indirect irradiance image.
    pub fn indirect_texture(&self) -> &wgpu::Texture {
        self.passes.texture()
    }

    /// The settings in use.
    pub fn settings(&self) -> &ProbeSettings {
        &self.passes.settings
    }

    /// The GPU octree.
    pub fn octree(&self) -> &GpuProbeOctree {
        &self.octree
    }

    /// The probe buffer (per probe slot 8 coefficients, then back-face share, hit share,
    /// valid).
    pub fn probe_buffer(&self) -> &wgpu::Buffer {
        self.passes.probe_buffer()
    }

    /// The boxes of the objects that moved in the last frame (old and new bounds).
    pub fn moved(&self) -> &[(Vec3, Vec3)] {
        &self.moved
    }

    /// The root cube: lower corner and edge.
    pub fn root(&self) -> (Vec3, f32) {
        self.root
    }

    /// The surfel buffer (per surfel position + state, normal + albedo, emission + distance)
    /// and the surfels' outgoing radiance.
    pub fn surfel_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer) {
        self.passes.surfel_buffers()
    }

    /// The probes' depth moment maps (see [`super::moments`]).
    pub fn moment_buffer(&self) -> &wgpu::Buffer {
        self.passes.moment_buffer()
    }

    /// The gather's view of the octree over read-back buffers (`moments`: the moment maps,
    /// read where the visibility is on).
    pub fn view<'a>(
        &self,
        nodes: &'a [i32],
        info: &'a [[f32; 4]],
        moments: Option<&'a [[f32; 2]]>,
    ) -> ProbeOctreeView<'a> {
        let cell = self.root.1 * 2f32.powi(-(self.octree.rule.max_depth as i32));
        ProbeOctreeView {
            lo: self.root.0,
            size: self.root.1,
            max_depth: self.octree.rule.max_depth,
            bias: self.bias,
            nodes,
            info,
            moments: moments.map(|maps| MomentMaps {
                maps,
                floor: super::moments::variance_floor(cell),
            }),
        }
    }
}

impl GiTechnique for ProbesOctree {
    fn name(&self) -> &str {
        OWNER
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        let Changes {
            moved,
            changed,
            bounce_scale,
        } = self.changes.observe(frame, Vec3::splat(self.root.1));
        self.moved = moved;
        self.passes.set_bounce_scale(bounce_scale);
        self.passes
            .set_forgetting(if changed { FORGETTING } else { 0.0 });
        self.rays
            .plan(&mut self.passes, changed, !self.moved.is_empty());
        self.passes.begin_frame(ctx, frame, timer)?;
        let settings = &self.passes.settings;
        let scene_range = settings.surfel_range == SurfelRange::Scene;
        // Surfels beyond the cube see objects the moved-leaf test does not reach: while
        // anything moves, every probe re-places them; with a history, every probe places a
        // new sample while the light changed in the last `history` frames.
        let place_all = (scene_range && !self.moved.is_empty()) || self.rays.sampled;
        let modes = [
            scene_range as u32,
            (settings.gather == OctreeGather::All) as u32,
            place_all as u32,
        ];
        self.octree.begin_frame(ctx, &self.moved, modes)?;
        let [place, light, integrate, gather, moments] = &self.groups;
        // 1. Memory update: free, collapse, allocate (M0-M4).
        self.octree.memory_update(ctx, timer);
        // 2. Light update, first half: moved geometry; L1 leaves ask for surfels.
        self.octree.light_select(ctx, timer);
        // 3. Surfels of those probes: rays along their lattices, hits inside the cube count;
        //    their depth moments.
        let set = |group| {
            Some(SetPass {
                group,
                listed: Some(self.octree.live_args()),
            })
        };
        self.passes.place(ctx, timer, set(place));
        self.passes.build_moments(ctx, timer, set(moments));
        // 4. Surfel light (+ last frame's probes).
        self.passes.light(ctx, frame, timer, set(light))?;
        // 5. Probes: each integrates its surfels and counts its hits inside its cube.
        self.passes.integrate(ctx, timer, set(integrate));
        // 6. Light update, second half: split, free or keep by the hit counts.
        self.octree.light_decide(ctx, timer);
        // 7. Pixels: the probes of the leaves around each (or all probes).
        self.passes.gather(ctx, frame, timer, Some(gather));
        self.octree.end_frame();
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        self.passes.view()
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        self.passes.reference_transport()
    }

    fn other_ledger_owners(&self) -> &[&'static str] {
        self.passes.other_ledger_owners()
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn settle_frames(&self) -> u32 {
        // Every probe's history full; the next frame stops tracing.
        self.passes.settings.history
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn octree_params_mirror_the_wgsl() {
        assert_mirrors_wgsl!(
            OctreeParams,
            "gi/probes/octree_params",
            "OctreeParams",
            [
                root_lo,
                root_size,
                tree_words,
                probe_slots,
                clusters,
                max_depth,
                ring_origin,
                moved_boxes,
                free_below,
                split_from,
                keep_outside,
                gather_all,
                place_all,
                min_depth,
                surfels_per_probe,
                moment_lanes,
                _pad,
            ]
        );
    }
}
