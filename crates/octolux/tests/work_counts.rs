//! The work counters `bench` reports: 64-bit sums from 32-bit atomics, one region per pass,
//! counts added on the CPU, and zero again after each read; the counts of the probe
//! techniques' passes (the BVH walk's against its CPU twin) and of the LPV propagation; and
//! counted renderers drawing the same images as plain ones.

use crate::common;

use crate::common::context;
use glam::{UVec3, Vec3};
use octolux::gi::lpv::{ClpvSettings, LpvSettings, OlpvSettings};
use octolux::gi::probes::bvh::{BvhWork, SceneBvh};
use octolux::gi::probes::lattice::Lattice;
use octolux::gi::probes::moments::MOMENT_TEXELS;
use octolux::gi::probes::{ProbeSettings, ProbesGrid, ProbesOctree, RayBackend};
use octolux::gi::GiSettings;
use octolux::gpu::work::{entry, WorkCounter};
use octolux::gpu::{GpuContext, WorkCount};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::Scene;

const KERNEL: &str = "
import octolux::gpu::work::count_work;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    count_work(0u, 0xffffffffu);
    count_work(1u, id.x);
    count_work(2u, 0u);
}
";

fn run(ctx: &GpuContext, pass: &str, invocations: u32) {
    let source =
        octolux::gpu::shader::compose_text("work count test", KERNEL, &[ctx.work_feature()], &[])
            .unwrap();
    let module = ctx.shader("work count test", &source);
    let pipeline = ctx.compute_pipeline("work count test", &module, "main");
    let quantities = &["big", "index", "nothing"];
    let entries: Vec<_> = entry(ctx, pass, quantities).unwrap().into_iter().collect();
    let group = octolux::gpu::pass::bind(ctx, &pipeline, &entries);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut p = encoder.begin_compute_pass(&Default::default());
        p.set_pipeline(&pipeline);
        p.set_bind_group(0, &group, &[]);
        p.dispatch_workgroups(invocations / 64, 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
}

fn count(counts: &[WorkCount], pass: &str, quantity: &str) -> u64 {
    counts
        .iter()
        .find(|c| c.pass == pass && c.quantity == quantity)
        .unwrap_or_else(|| panic!("no count {pass}/{quantity} in {counts:?}"))
        .count
}

#[test]
fn work_counts_are_exact_64_bit_sums_per_pass() {
    let ctx = context().with_work_counter();
    let work: &WorkCounter = ctx.work().unwrap();
    // 256 invocations each adding 2^32 - 1: the low word wraps 255 times.
    run(&ctx, "first", 256);
    run(&ctx, "second", 128);
    run(&ctx, "first", 64);
    let cpu = work.region("cpu", &["draws"]).unwrap();
    work.add(cpu, 0, 5);
    work.add(cpu, 0, 1 << 40);
    let counts = work.take(&ctx).unwrap();
    let sum = |n: u64| n * (n - 1) / 2;
    assert_eq!(count(&counts, "first", "big"), 320 * 0xffff_ffff);
    assert_eq!(count(&counts, "first", "index"), sum(256) + sum(64));
    assert_eq!(count(&counts, "first", "nothing"), 0);
    assert_eq!(count(&counts, "second", "big"), 128 * 0xffff_ffff);
    assert_eq!(count(&counts, "second", "index"), sum(128));
    assert_eq!(count(&counts, "cpu", "draws"), 5 + (1 << 40));
    // Read again: every count back at zero, the regions kept.
    let again = work.take(&ctx).unwrap();
    assert_eq!(again.len(), counts.len());
    assert!(again.iter().all(|c| c.count == 0), "{again:?}");
    // A pass registered again with other quantities is an error, not a silent mix-up.
    assert!(work.region("first", &["big"]).is_err());
}

#[test]
fn a_context_without_counters_counts_nothing() {
    let ctx = context();
    assert!(ctx.work().is_none());
    assert_eq!(ctx.work_feature(), ("count_work", false));
    // The kernel composes without the binding and runs.
    run(&ctx, "first", 64);
    ctx.check_errors().unwrap();
}

// The probe techniques' and the LPV propagation's counts.

/// BVH traversals counted, and the lattice as the GPU computes it.
const BVH_KERNEL: &str = "
import octolux::gi::probes::lattice::lattice_dir;
import octolux::gi::probes::bvh::{bvh_closest, BVH_MISS, count_bvh_work};
import octolux::gpu::work::count_work;

struct TestParams {
    // x: lattice kind, y: directions, z: rays
    misc: vec4<u32>,
    // x: static BVH root, y: animated objects
    roots: vec4<u32>,
};

@group(0) @binding(0) var<storage, read> T: TestParams;
// Per ray: (origin, t_max), (direction, 0).
@group(0) @binding(6) var<storage, read> rays: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn dirs(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < T.misc.y {
        out[id.x] = lattice_dir(T.misc.x, id.x, T.misc.y);
    }
}

// Counts: nodes visited, triangles tested, hits.
@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= T.misc.z {
        return;
    }
    let o = rays[2u * id.x];
    let hit = bvh_closest(T.roots.xy, o.xyz, rays[2u * id.x + 1u].xyz, o.w);
    count_bvh_work(0u, 1u);
    count_work(2u, u32(hit.tri != BVH_MISS));
}
";

fn storage(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    ctx.create_buffer_init(
        "work counts test",
        label,
        bytes,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    )
}

/// Runs entry `entry` of [`BVH_KERNEL`] over `count` invocations with `buffers` bound (and the
/// work counts of pass `entry` where `ctx` counts).
fn run_bvh_kernel(ctx: &GpuContext, entry: &str, buffers: &[(u32, &wgpu::Buffer)], count: u32) {
    let source =
        octolux::gpu::shader::compose_text("bvh kernel", BVH_KERNEL, &[ctx.work_feature()], &[])
            .unwrap();
    let module = ctx.shader("bvh kernel", &source);
    let pipeline = ctx.compute_pipeline(entry, &module, entry);
    let mut entries: Vec<_> = buffers
        .iter()
        .map(|&(i, b)| (i, b.as_entire_binding()))
        .collect();
    if entry == "trace" {
        entries.extend(entry_of(
            ctx,
            entry,
            &["BVH nodes", "triangles tested", "hits"],
        ));
    }
    let group = octolux::gpu::pass::bind(ctx, &pipeline, &entries);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut p = encoder.begin_compute_pass(&Default::default());
        p.set_pipeline(&pipeline);
        p.set_bind_group(0, &group, &[]);
        p.dispatch_workgroups(count.div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    ctx.check_errors().unwrap();
}

fn entry_of<'a>(
    ctx: &'a GpuContext,
    pass: &str,
    quantities: &[&'static str],
) -> Option<(u32, wgpu::BindingResource<'a>)> {
    entry(ctx, pass, quantities).unwrap()
}

/// The lattice directions of `n` rays as the GPU computes them.
fn gpu_lattice(ctx: &GpuContext, lattice: Lattice, n: u32) -> Vec<Vec3> {
    let params: [u32; 8] = [lattice.gpu_kind(), n, 0, 0, 0, 0, 0, 0];
    let p = storage(ctx, "params", bytemuck::cast_slice(&params));
    let out = storage(ctx, "out", &vec![0u8; n as usize * 16]);
    run_bvh_kernel(ctx, "dirs", &[(0, &p), (7, &out)], n);
    let bytes = octolux::gpu::read_buffer(ctx, &out, 0, n as u64 * 16).unwrap();
    bytemuck::cast_slice::<u8, [f32; 4]>(&bytes)
        .iter()
        .map(|d| Vec3::from_slice(d))
        .collect()
}

#[test]
fn the_bvh_walk_counts_the_nodes_and_triangles_of_its_cpu_twin() {
    // The animated Cornell box at t = 1.3 s (the short block moved and turned: a two-level
    // BVH); 4096 random rays from inside the box, every fourth with a short reach. The GPU's
    // counts of nodes visited and triangles tested equal the CPU traversal's exactly: the
    // slab tests, the order of the children and the triangle tests are the same step for step
    // (the probe twins' test shows the hits agree; a ray through a shared edge may go either
    // way, which the sums would show).
    let ctx = context().with_work_counter();
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let scene = Scene::load(path).unwrap();
    let frame = scene.frame(1.3, 0);
    let bvh = SceneBvh::build(&scene);
    let (nodes, tris, roots) = bvh.flatten();
    let instances = bvh.instances(&scene, &frame, &roots).unwrap();
    let (lo, hi) = scene.bounds_at(1.3);
    let mut rnd = common::Rng(99);
    let n = 4096u32;
    let (mut rays, mut cpu, mut hits) = (Vec::new(), BvhWork::default(), 0u64);
    for i in 0..n {
        let o = lo + (hi - lo) * (rnd.vec(0.0, 1.0) * 0.98 + 0.01);
        let d = rnd.unit();
        let t_max = if i % 4 == 0 { 0.2 } else { 1e30 };
        rays.push([o.x, o.y, o.z, t_max]);
        rays.push([d.x, d.y, d.z, 0.0]);
        hits += bvh
            .closest_counted(&instances, o, d, t_max, &mut cpu)
            .is_some() as u64;
    }
    let params: [u32; 8] = [0, 0, n, 0, 0, instances.len() as u32, 0, 0];
    let buffers = [
        (0, storage(&ctx, "params", bytemuck::cast_slice(&params))),
        (2, storage(&ctx, "nodes", bytemuck::cast_slice(&nodes))),
        (3, storage(&ctx, "tris", bytemuck::cast_slice(&tris))),
        (
            4,
            storage(&ctx, "instances", bytemuck::cast_slice(&instances)),
        ),
        (6, storage(&ctx, "rays", bytemuck::cast_slice(&rays))),
    ];
    let bound: Vec<(u32, &wgpu::Buffer)> = buffers.iter().map(|(i, b)| (*i, b)).collect();
    run_bvh_kernel(&ctx, "trace", &bound, n);
    let counts = ctx.work().unwrap().take(&ctx).unwrap();
    println!("CPU {cpu:?}, {hits} hits");
    assert!(cpu.nodes > n as u64 && cpu.triangles > n as u64, "{cpu:?}");
    assert_eq!(count(&counts, "trace", "hits"), hits);
    assert_eq!(count(&counts, "trace", "BVH nodes"), cpu.nodes);
    assert_eq!(count(&counts, "trace", "triangles tested"), cpu.triangles);
}

const SIZE: u32 = 32;

/// Small settings of every technique under test: a 4^3 probe grid of 32 rays without a
/// history, a depth-3 probe octree, small light volumes.
fn small(gi: &str) -> RenderSettings {
    let s = GiSettings {
        probes: ProbeSettings {
            grid: [4, 4, 4],
            surfels: Some(32),
            history: 0,
            // Adaptive below depth 2, so that the octree's first frames decide leaves.
            max_depth: 3,
            min_depth: 2,
            ..Default::default()
        },
        lpv: LpvSettings {
            size: 8,
            iterations: 4,
            rsm_size: 64,
            rsm_stride: 2,
            ..Default::default()
        },
        clpv: ClpvSettings {
            cascades: 2,
            size: 6,
            iterations: 3,
            ..Default::default()
        },
        olpv: OlpvSettings {
            size: 8,
            iterations: 2,
        },
        ..Default::default()
    };
    RenderSettings {
        width: SIZE,
        height: SIZE,
        shadow_map_size: 256,
        gi: gi.into(),
        gi_settings: s,
        ..RenderSettings::default()
    }
}

/// The work counts of the next frame of `r` (what earlier frames counted is dropped).
fn next_frame(ctx: &GpuContext, r: &mut Renderer, scene: &Scene) -> Vec<WorkCount> {
    ctx.work().unwrap().take(ctx).unwrap();
    r.render(scene, 0.0).unwrap();
    ctx.work().unwrap().take(ctx).unwrap()
}

/// The `vec4`s of `buffer`.
fn read_vec4(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Vec<[f32; 4]> {
    let bytes = octolux::gpu::read_buffer(ctx, buffer, 0, buffer.size()).unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}

#[test]
fn probes_grid_counts_its_rays_surfels_probes_and_pixels() {
    // The first frame traces every probe's lattice: its BVH work equals the CPU twin's over
    // the same rays (the lattice as the GPU computes it, from the probes' centres), its lit
    // surfels are the front-facing hits it stored; a static second frame traces nothing.
    let ctx = context().with_work_counter();
    let scene = octolux::scene::cornell::scene();
    let mut r = Renderer::new(&ctx, &scene, small("probes-grid")).unwrap();
    let first = next_frame(&ctx, &mut r, &scene);
    let g = r
        .technique()
        .as_any()
        .and_then(|a| a.downcast_ref::<ProbesGrid>())
        .unwrap();
    let c = |counts: &[WorkCount], pass: &str, q: &str| {
        count(counts, &format!("probes-grid {pass}"), q)
    };
    let settings = g.settings();
    let n = settings.surfel_count() as u64;
    let grid = *g.grid();
    let probes = grid.count() as u64;
    assert_eq!(c(&first, "place", "probes"), probes);
    assert_eq!(c(&first, "place", "rays"), probes * n);
    let bvh = SceneBvh::build(&scene);
    let dirs = gpu_lattice(&ctx, settings.lattice, n as u32);
    let (lo, hi) = scene.gi_bounds_at(0.0);
    let t_max = (hi - lo).length() * 1.01;
    let mut cpu = BvhWork::default();
    for p in 0..grid.count() {
        let d = grid.dims;
        let o = grid.position(UVec3::new(p % d.x, (p / d.x) % d.y, p / (d.x * d.y)));
        for &dir in &dirs {
            bvh.closest_counted(&[], o, dir, t_max, &mut cpu);
        }
    }
    println!("CPU twin of the placement: {cpu:?}");
    assert_eq!(c(&first, "place", "BVH nodes"), cpu.nodes);
    assert_eq!(c(&first, "place", "triangles tested"), cpu.triangles);
    let texels = probes * MOMENT_TEXELS as u64;
    assert_eq!(c(&first, "moments", "texels"), texels);
    assert_eq!(c(&first, "moments", "kernel terms"), texels * n);
    // Surfel states: 0 miss, 1 front, 2 back; only front faces are lit.
    let surfels = read_vec4(&ctx, g.surfel_buffers().0);
    let front = surfels.iter().step_by(3).filter(|s| s[3] == 1.0).count() as u64;
    assert!(front > probes * n / 4, "{front} front hits");
    assert_eq!(c(&first, "light", "surfels"), front);
    let lights = scene.lights.len() as u64;
    let shadow = c(&first, "light", "shadow lookups");
    assert!(
        shadow > 0 && shadow <= front * lights,
        "{shadow} shadow lookups"
    );
    // With multiple bounces every lit surfel reads the probes around it (last frame's).
    let read = c(&first, "light", "probes read");
    assert!(read <= 8 * front, "{read} probes read by {front} surfels");
    assert_eq!(c(&first, "integrate", "probes"), probes);
    assert_eq!(c(&first, "integrate", "surfels"), probes * n);
    let pixels = c(&first, "gather", "pixels");
    assert!(
        pixels > 0 && pixels <= (SIZE * SIZE) as u64,
        "{pixels} pixels"
    );
    let read = c(&first, "gather", "probes read");
    assert!(read >= pixels && read <= 8 * pixels, "{read} probes read");

    let second = next_frame(&ctx, &mut r, &scene);
    assert_eq!(
        c(&second, "place", "rays"),
        0,
        "a static frame traces nothing"
    );
    assert_eq!(c(&second, "light", "surfels"), front);
    assert_eq!(c(&second, "gather", "pixels"), pixels);
}

#[test]
fn probe_rays_through_voxels_count_their_walks() {
    // With `rays = "voxels"` the placement counts the octree walks' cells and nodes instead
    // of the BVH's: every ray visits at least one cell (or misses the grid), every cell's
    // walk descends through nodes.
    let ctx = context().with_work_counter();
    let scene = octolux::scene::cornell::scene();
    let mut settings = small("probes-grid");
    settings.gi_settings.probes.rays = RayBackend::Voxels;
    settings.gi_settings.probes.voxel_resolution = 32;
    let mut r = Renderer::new(&ctx, &scene, settings).unwrap();
    let counts = next_frame(&ctx, &mut r, &scene);
    let c = |q: &str| count(&counts, "probes-grid place", q);
    assert_eq!(c("rays"), 64 * 32);
    let (cells, nodes) = (c("ray cells"), c("octree nodes"));
    assert!(
        cells >= c("rays") / 2 && nodes >= cells,
        "{cells} cells, {nodes} nodes"
    );
    assert!(!counts
        .iter()
        .any(|w| w.pass == "probes-grid place" && w.quantity == "BVH nodes"));
}

#[test]
fn probes_octree_counts_its_tree_walks_and_live_probes() {
    // The first frame: every leaf the state machine asks for places its lattice (placements
    // asked = probes placed = leaves decided), over the live probes the memory update listed
    // (= the probes allocated after the frame); every pixel descends the tree at least 9
    // times (its leaf, then 8 corners). Over the next frames the probes allocated less those
    // freed is the change in the probe count.
    let ctx = context().with_work_counter();
    let scene = octolux::scene::cornell::scene();
    let mut r = Renderer::new(&ctx, &scene, small("probes-octree")).unwrap();
    let first = next_frame(&ctx, &mut r, &scene);
    let o = r
        .technique()
        .as_any()
        .and_then(|a| a.downcast_ref::<ProbesOctree>())
        .unwrap();
    let c = |counts: &[WorkCount], pass: &str, q: &str| {
        count(counts, &format!("probes-octree {pass}"), q)
    };
    let settings = o.settings();
    let n = settings.surfel_count() as u64;
    let (nodes, _) = settings.octree_rule().full_capacity();
    let nodes = nodes as u64;
    let live = o.probe_count(&ctx).unwrap() as u64;
    assert!(live >= 64, "{live} probes");
    for pass in ["memory update", "light select", "light decide"] {
        assert_eq!(c(&first, pass, "nodes"), nodes, "{pass}");
    }
    assert_eq!(c(&first, "memory update", "live probes"), live);
    let placed = c(&first, "place", "probes");
    assert!(
        placed > 0 && placed <= live,
        "{placed} of {live} probes placed"
    );
    assert_eq!(c(&first, "light select", "placements"), placed);
    assert_eq!(c(&first, "light decide", "leaves decided"), placed);
    assert_eq!(c(&first, "place", "rays"), placed * n);
    let tested = c(&first, "place", "triangles tested");
    assert!(c(&first, "place", "BVH nodes") >= placed * n && tested > 0);
    assert_eq!(
        c(&first, "moments", "texels"),
        placed * MOMENT_TEXELS as u64
    );
    assert_eq!(c(&first, "integrate", "probes"), live);
    assert_eq!(c(&first, "integrate", "surfels"), live * n);
    let lit = c(&first, "light", "surfels");
    assert!(lit > 0 && lit <= live * n, "{lit} surfels lit");
    // Multiple bounces (the default): every lit surfel reads the probes as a pixel does,
    // descending to its leaf and to the 8 corners' at least.
    let surfel_lookups = c(&first, "light", "octree lookups");
    assert!(
        surfel_lookups >= 9 * lit,
        "{surfel_lookups} lookups for {lit} surfels"
    );
    let pixels = c(&first, "gather", "pixels");
    assert!(
        pixels > 0 && pixels <= (SIZE * SIZE) as u64,
        "{pixels} pixels"
    );
    let lookups = c(&first, "gather", "octree lookups");
    let visited = c(&first, "gather", "octree nodes");
    assert!(
        lookups >= 9 * pixels,
        "{lookups} lookups for {pixels} pixels"
    );
    let depth = settings.max_depth as u64;
    assert!(
        visited >= lookups && visited <= lookups * (depth + 1),
        "{visited} nodes in {lookups} lookups"
    );
    let read = c(&first, "gather", "probes read");
    assert!(read >= pixels && read <= 8 * lookups, "{read} probes read");

    let (mut allocated, mut freed) = (0, 0);
    for _ in 0..3 {
        let counts = next_frame(&ctx, &mut r, &scene);
        allocated += c(&counts, "memory update", "probes allocated");
        freed += c(&counts, "memory update", "probes freed");
    }
    let o = r
        .technique()
        .as_any()
        .and_then(|a| a.downcast_ref::<ProbesOctree>())
        .unwrap();
    let now = o.probe_count(&ctx).unwrap() as u64;
    println!("probes: {live} after the first frame, {now} after 3 more (+{allocated} -{freed})");
    assert_eq!(live + allocated - freed, now);
}

#[test]
fn lpv_propagation_counts_cells_times_iterations_on_every_grid() {
    // Worked out from the settings of `small`: lpv one 8^3 grid (8 bricks of 4^3) x 4 steps;
    // clpv two 6^3 cascades (8 bricks each, 64 lanes a brick) x 3; olpv levels 8, 4, 2, 1
    // (8 + 1 + 1 + 1 bricks) x 2.
    let ctx = context().with_work_counter();
    let scene = octolux::scene::cornell::scene();
    for (gi, steps, lanes, cells) in [
        ("lpv", 4, 4 * 8 * 64, 4 * 512),
        ("clpv", 3, 3 * 16 * 64, 3 * 2 * 216),
        ("olpv", 2, 2 * 11 * 64, 2 * (512 + 64 + 8 + 1)),
    ] {
        let mut r = Renderer::new(&ctx, &scene, small(gi)).unwrap();
        let counts = next_frame(&ctx, &mut r, &scene);
        let pass = format!("{gi} propagate");
        assert_eq!(count(&counts, &pass, "steps"), steps, "{gi}");
        assert_eq!(count(&counts, &pass, "lanes"), lanes, "{gi}");
        assert_eq!(count(&counts, &pass, "cell updates"), cells, "{gi}");
        // The lookup reads the volume at every pixel.
        let lookup = format!("{gi} lookup");
        assert_eq!(
            count(&counts, &lookup, "pixels"),
            (SIZE * SIZE) as u64,
            "{gi}"
        );
    }
}

#[test]
fn counting_does_not_change_the_images() {
    // The counted shaders of the probe techniques and the LPVs render the same pixels as the
    // uncounted ones, frame after frame.
    let plain = context();
    let counted = context().with_work_counter();
    let scene = octolux::scene::cornell::scene();
    for gi in ["probes-grid", "probes-octree", "lpv", "clpv", "olpv"] {
        let mut a = Renderer::new(&plain, &scene, small(gi)).unwrap();
        let mut b = Renderer::new(&counted, &scene, small(gi)).unwrap();
        for frame in 0..3 {
            a.render(&scene, 0.0).unwrap();
            b.render(&scene, 0.0).unwrap();
            assert_eq!(
                a.read_hdr().unwrap().pixels,
                b.read_hdr().unwrap().pixels,
                "{gi} frame {frame}"
            );
        }
        counted.work().unwrap().take(&counted).unwrap();
    }
}

#[test]
fn shadow_layers_are_drawn_again_only_where_their_content_moved() {
    // A point light (six layers) over the Cornell box whose short block slides along the floor
    // (inside the box: the scene bounds, to which the views are fitted, stay the same):
    // the first frame draws every layer, a frame with nothing moved none, a frame where the
    // block moved only the faces that see it (not the ceiling's), and a frame where the light
    // moved all six. Each running renderer's picture equals a fresh renderer's at that time.
    use octolux::scene::{Keyframe, Light, Track};
    let ctx = context().with_work_counter();
    let mut scene = octolux::scene::cornell::geometry();
    scene.cameras = vec![octolux::scene::cornell::camera()];
    let centre = octolux::scene::cornell::room_centre();
    scene.lights = vec![Light::point(centre + Vec3::Y * 0.2, Vec3::ONE, 0.5)];
    let slide = |to: Vec3| {
        Track::new(
            [(0.0, Vec3::ZERO), (1.0, to)]
                .into_iter()
                .map(|(time, translation)| Keyframe {
                    time,
                    translation,
                    rotation: glam::Quat::IDENTITY,
                })
                .collect(),
            false,
        )
    };
    let block = scene.objects.iter_mut().find(|o| o.name == "short-block");
    block.unwrap().animation = slide(Vec3::new(0.1, 0.0, 0.0));
    let settings = RenderSettings {
        width: 24,
        height: 24,
        shadow_map_size: 64,
        gi: "none".into(),
        ..RenderSettings::default()
    };
    let mut running = Renderer::new(&ctx, &scene, settings.clone()).unwrap();
    let mut layers_drawn = |scene: &Scene, t: f32| {
        ctx.work().unwrap().take(&ctx).unwrap();
        running.render(scene, t).unwrap();
        let counts = ctx.work().unwrap().take(&ctx).unwrap();
        let image = running.read_direct().unwrap();
        let mut fresh = Renderer::new(&ctx, scene, settings.clone()).unwrap();
        fresh.render(scene, t).unwrap();
        assert_eq!(image, fresh.read_direct().unwrap(), "t = {t}");
        count(&counts, "shadow maps", "layers")
    };
    assert_eq!(layers_drawn(&scene, 0.0), 6);
    assert_eq!(layers_drawn(&scene, 0.0), 0, "nothing moved");
    let moved = layers_drawn(&scene, 1.0);
    assert!(
        (1..6).contains(&moved),
        "the block moved: {moved} layers drawn"
    );
    scene.lights[0].animation = slide(Vec3::new(0.05, 0.0, 0.0));
    assert_eq!(layers_drawn(&scene, 0.5), 6, "the light moved");
}
