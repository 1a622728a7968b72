//! The GPU octree against its CPU specification: the same frames from the same hit counts
//! give the same buffers word for word (tree, probe records, free lists, marks, ring).

use crate::common::context;
use glam::Vec3;
use octolux::gi::probes::octree::{OctreeProbe, OctreeRule, ProbeOctree};
use octolux::gi::probes::octree_gi::GpuProbeOctree;
use octolux::gpu::{read_buffer, GpuContext, PassTimer};

fn read<T: bytemuck::Pod>(ctx: &GpuContext, b: &wgpu::Buffer) -> Vec<T> {
    bytemuck::cast_slice(&read_buffer(ctx, b, 0, b.size()).unwrap()).to_vec()
}

/// Compares every buffer of `gpu` with `cpu`; returns the probe count.
fn assert_same(ctx: &GpuContext, gpu: &GpuProbeOctree, cpu: &ProbeOctree, what: &str) -> usize {
    let [tree, info, state, ring] = gpu.buffers();
    let len = cpu.nodes.len();
    let tree: Vec<i32> = read(ctx, tree);
    assert_eq!(tree[..len], cpu.nodes[..], "{what}: tree");
    let info: Vec<[u32; 4]> = read(ctx, info);
    let want: Vec<[u32; 4]> = cpu
        .probe_info()
        .iter()
        .map(|v| v.map(f32::to_bits))
        .collect();
    assert_eq!(info[..want.len()], want[..], "{what}: probe records");
    let state: Vec<u32> = read(ctx, state);
    let (probes, clusters) = cpu.free_lists();
    let capacity = want.len();
    let cluster_room = (len - 1) / 9;
    assert_eq!(state[0] as usize, probes.len(), "{what}: free probes");
    assert_eq!(state[1] as usize, clusters.len(), "{what}: free clusters");
    assert_eq!(state[4..4 + probes.len()], probes[..], "{what}: probe list");
    let c0 = 4 + capacity;
    assert_eq!(
        state[c0..c0 + clusters.len()],
        clusters[..],
        "{what}: cluster list"
    );
    let marks = c0 + cluster_room;
    let no_split: Vec<bool> = state[marks..marks + len].iter().map(|&w| w != 0).collect();
    assert_eq!(no_split, cpu.no_split(), "{what}: no-split marks");
    assert!(
        state[marks + len..marks + 3 * len].iter().all(|&w| w == 0),
        "{what}: scratch marks left"
    );
    let ring: Vec<u32> = read(ctx, ring);
    let (codes, _) = cpu.ring_codes();
    assert_eq!(ring[..3 * len], codes[..], "{what}: ring");
    cpu.probe_count()
}

/// The live probes the memory update listed for the shared passes: the CPU tree's allocated
/// slots in increasing order, and dispatches that cover them.
fn assert_live_list(ctx: &GpuContext, gpu: &GpuProbeOctree, cpu: &ProbeOctree, what: &str) {
    let live: Vec<u32> = read(ctx, gpu.live_buffer());
    let want: Vec<u32> = (0..gpu.capacity())
        .filter(|&p| cpu.probe(p).is_some())
        .collect();
    assert_eq!(live[0] as usize, want.len(), "{what}: live count");
    assert_eq!(live[1..1 + want.len()], want[..], "{what}: live slots");
    let args: Vec<u32> = read(ctx, gpu.live_args());
    let surfels = gpu.rule().surfels;
    let moment_lanes = octolux::gi::probes::moments::MOMENT_LANES;
    for (k, per_probe) in [surfels, moment_lanes, 1].into_iter().enumerate() {
        let [x, y, z] = [args[3 * k], args[3 * k + 1], args[3 * k + 2]];
        let launched = 64 * x as u64 * y as u64 * z as u64;
        let needed = want.len() as u64 * per_probe as u64;
        assert!(
            launched >= needed && launched < needed + 64 * x as u64 + 64 && x <= 65535,
            "{what}: dispatch {k}: {x} x {y} x {z} groups for {needed} invocations"
        );
    }
}

/// One frame on both: the GPU's memory update and light selection, then its hit counts are
/// set from `hits` for its live probes, then the decision.
fn frame(
    ctx: &GpuContext,
    gpu: &mut GpuProbeOctree,
    cpu: &mut ProbeOctree,
    moved: &[(Vec3, Vec3)],
    hits: &dyn Fn(&OctreeProbe) -> u32,
) {
    gpu.begin_frame(ctx, moved, [0; 3]).unwrap();
    let mut timer = PassTimer::new(ctx);
    gpu.memory_update(ctx, &mut timer);
    gpu.light_select(ctx, &mut timer);
    timer.finish_frame().unwrap();
    let info: Vec<[f32; 4]> = read(ctx, gpu.buffers()[1]);
    let counts: Vec<u32> = info
        .iter()
        .map(|i| {
            let probe = OctreeProbe {
                position: Vec3::from_slice(i),
                depth: i[3].max(0.0) as u32,
            };
            if i[3] < 0.0 {
                0
            } else {
                hits(&probe)
            }
        })
        .collect();
    ctx.queue
        .write_buffer(gpu.hits_buffer(), 0, bytemuck::cast_slice(&counts));
    gpu.light_decide(ctx, &mut timer);
    timer.finish_frame().unwrap();
    ctx.check_errors().unwrap();
    gpu.end_frame();
    cpu.frame(moved, |_, p| hits(p));
}

/// A hash of a probe's position, depth and the frame's epoch: hit counts that change every
/// few frames, so the tree splits, frees and collapses over and over.
fn scripted(p: &OctreeProbe, epoch: u32, surfels: u32) -> u32 {
    let mut h = p
        .position
        .to_array()
        .iter()
        .fold(epoch.wrapping_mul(0x9e37_79b9), |h, v| {
            (h ^ v.to_bits()).wrapping_mul(0x85eb_ca6b).rotate_left(13)
        });
    h ^= p.depth.wrapping_mul(0xc2b2_ae35);
    h = h.wrapping_mul(0x27d4_eb2f) ^ (h >> 15);
    // The root always splits; deeper probes hit less, as their lattices are confined to
    // smaller cubes.
    let u = (h % 1000) as f32 / 1000.0;
    let f = if p.depth == 0 {
        0.9
    } else {
        0.1 + 0.8 * u * (1.0 - 0.15 * p.depth as f32)
    };
    ((f * surfels as f32) as u32).min(surfels)
}

#[test]
fn gpu_octree_equals_the_cpu_octree_on_scripted_hit_counts() {
    let ctx = context();
    // Full room at depths 2 and 3, and a small room where splits fail for want of probes and
    // clusters; `004`'s rule (min_depth 0) and levels kept down to depth 1 and 2.
    for (depth, min_depth, room) in [
        (2, 0, None),
        (3, 0, None),
        (3, 0, Some((1 + 9 * 6, 40))),
        (3, 1, None),
        (3, 2, None),
        (3, 2, Some((1 + 9 * 12, 80))),
    ] {
        let rule = OctreeRule {
            max_depth: depth,
            min_depth,
            ..Default::default()
        };
        let (len, capacity) = room.unwrap_or(rule.full_capacity());
        let (lo, size) = (Vec3::new(-1.0, -0.5, -2.0), 4.0);
        let mut gpu = GpuProbeOctree::with_room(&ctx, rule, lo, size, len, capacity).unwrap();
        let mut cpu = ProbeOctree::new(len, capacity, lo, size, rule);
        let mut counts = Vec::new();
        for f in 0..40u32 {
            // A box sweeps through the cube from frame 20 to 30.
            let moved = if (20..30).contains(&f) {
                let c = lo + Vec3::splat(0.4 * (f - 20) as f32);
                vec![(c, c + Vec3::splat(0.5))]
            } else {
                vec![]
            };
            frame(&ctx, &mut gpu, &mut cpu, &moved, &|p| {
                scripted(p, f / 4, rule.surfels)
            });
            let what = format!("depth {depth}, min {min_depth}, room {room:?}, frame {f}");
            counts.push(assert_same(&ctx, &gpu, &cpu, &what));
            assert_live_list(&ctx, &gpu, &cpu, &what);
        }
        println!("depth {depth}, min {min_depth}, room {room:?}: probes per frame {counts:?}");
        let distinct: std::collections::BTreeSet<_> = counts.iter().collect();
        assert!(distinct.len() > 5, "the tree changes: {counts:?}");
    }
}

/// A renderer with `probes-octree` and `probes` at `size` x `size`.
fn octree_renderer(
    ctx: &GpuContext,
    scene: &octolux::scene::Scene,
    probes: &octolux::gi::probes::ProbeSettings,
    size: u32,
) -> octolux::render::Renderer {
    let settings = octolux::render::RenderSettings {
        width: size,
        height: size,
        gi: "probes-octree".into(),
        gi_settings: octolux::gi::GiSettings {
            probes: probes.clone(),
            ..Default::default()
        },
        ..Default::default()
    };
    octolux::render::Renderer::new(ctx, scene, settings).unwrap()
}

/// The renderer's `probes-octree`.
fn technique(r: &octolux::render::Renderer) -> &octolux::gi::probes::ProbesOctree {
    r.technique()
        .as_any()
        .and_then(|a| a.downcast_ref::<octolux::gi::probes::ProbesOctree>())
        .unwrap()
}

#[test]
fn gpu_octree_equals_the_cpu_octree_on_the_animated_cornell_box() {
    // `probes-octree` on the shipped animated Cornell box, 30 frames through the block's
    // motion: after every frame the CPU octree, fed the same boxes of moved objects and the
    // GPU's hit counts (surfels inside each probe's cube), holds the same buffers.
    let ctx = context();
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let scene = octolux::scene::Scene::load(path).unwrap();
    // Depth 3, complete down to depth 2 only, and `004`'s split and free rule, so that
    // probes are freed as well as allocated. The tree is the subject: one fixed lattice and one
    // bounce (the probes' values do not steer it) keep the frames cheap.
    let probes = octolux::gi::probes::ProbeSettings {
        max_depth: 3,
        min_depth: 2,
        split_fraction: 0.5,
        free_fraction: 0.25,
        history: 0,
        multi_bounce: Some(false),
        ..Default::default()
    };
    let mut r = octree_renderer(&ctx, &scene, &probes, 24);
    let rule = probes.octree_rule();
    let (len, capacity) = rule.full_capacity();
    let (lo, size) = octolux::gi::probes::octree_gi::root_cube(scene.bounds_at(0.0)).unwrap();
    let mut cpu = ProbeOctree::new(len, capacity, lo, size, rule);
    let (mut counts, mut moving) = (Vec::new(), 0);
    for f in 0..30 {
        r.render(&scene, 0.9 + 0.05 * f as f32).unwrap();
        let technique = technique(&r);
        let hits: Vec<u32> = read(&ctx, technique.octree().hits_buffer());
        cpu.frame(technique.moved(), |slot, _| hits[slot as usize]);
        moving += !technique.moved().is_empty() as u32;
        let what = format!("frame {f}");
        counts.push(assert_same(&ctx, technique.octree(), &cpu, &what));
        assert_live_list(&ctx, technique.octree(), &cpu, &what);
    }
    println!("probes per frame {counts:?}, {moving} frames with moving objects");
    assert!(moving > 10, "the block moves");
    assert!(counts[29] > 8 && counts[29] < 512, "{counts:?}");
}

#[test]
fn octree_gather_equals_its_cpu_twin() {
    // `probes-octree` on the Cornell box after 8 frames (the tree has grown), both gathers
    // with depth-moment visibility and the octree gather without: every pixel's indirect
    // irradiance equals the CPU twin's (`ProbeOctreeView::irradiance`) from the GPU's tree, probes
    // and moment maps at the pixel's position and normal.
    //
    // Tolerance: the output is f16 (2^-11 relative) of a sum the CPU forms in the same
    // order, from a world position rebuilt from the depth buffer on both sides; a point within
    // rounding of a cube face may pick another leaf on either side, which must be rare.
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    use octolux::gi::probes::Visibility;
    for (gather, visibility) in [
        (
            octolux::gi::probes::OctreeGather::Octree,
            Visibility::Moments,
        ),
        (octolux::gi::probes::OctreeGather::All, Visibility::Moments),
        (octolux::gi::probes::OctreeGather::Octree, Visibility::None),
    ] {
        // The gathers are the subject: whatever the probes hold, both sides read the same;
        // one fixed lattice and one bounce keep the frames cheap.
        let probes = octolux::gi::probes::ProbeSettings {
            gather,
            visibility,
            history: 0,
            multi_bounce: Some(false),
            ..Default::default()
        };
        let mut r = octree_renderer(&ctx, &scene, &probes, 40);
        for _ in 0..8 {
            r.render(&scene, 0.0).unwrap();
        }
        let technique = technique(&r);
        let [tree, info, _, _] = technique.octree().buffers();
        let (nodes, info): (Vec<i32>, Vec<[f32; 4]>) = (read(&ctx, tree), read(&ctx, info));
        let probe_data: Vec<[f32; 4]> = read(&ctx, technique.probe_buffer());
        let live = info.iter().filter(|i| i[3] >= 0.0).count();
        let maps: Vec<[f32; 2]> = read(&ctx, technique.moment_buffer());
        let view = technique.view(
            &nodes,
            &info,
            (visibility == Visibility::Moments).then_some(&maps[..]),
        );
        let g = r.read_gbuffer().unwrap();
        let camera = *r.last_view().unwrap();
        let bytes = octolux::gpu::read_texture(&ctx, technique.indirect_texture(), 0).unwrap();
        let indirect: &[u16] = bytemuck::cast_slice(&bytes);
        let (mut lit, mut off) = (0, 0);
        let points = camera.world_points(&g.depth);
        for (i, (point, normal)) in points.iter().zip(&g.normal).enumerate() {
            let Some(p) = *point else {
                continue;
            };
            let want = view.irradiance(&probes, &probe_data, p, normal.normalize());
            let got = Vec3::from_array(std::array::from_fn(|c| {
                octolux::gpu::pack::f16_to_f32(indirect[4 * i + c])
            }));
            if (got - want).abs().max_element() > 2e-3 * want.max_element() + 1e-5 {
                off += 1;
                assert!(
                    off <= 2,
                    "{gather:?} {visibility:?} pixel {i}: gpu {got}, cpu {want}"
                );
            }
            lit += (want.max_element() > 0.0) as u32;
        }
        println!("{gather:?} {visibility:?}: {live} probes, {lit} pixels lit, {off} differ");
        assert!(lit > 1000, "{lit} pixels lit");
        // The complete depth-3 level's 512 at least; at most about a third of the full
        // depth-4 tree's 4096 leaves in a closed box (splitting from a quarter of the surfels:
        // 1296 measured).
        assert!((512..=1500).contains(&live), "{live} probes");
    }
}
