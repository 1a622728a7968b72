//! The octree's dynamic part (Arnebäck 2017 §3.1.7): a static part built once and a dynamic
//! part replaced on every update must together equal an octree of static + dynamic geometry
//! built from scratch: the same nodes, subdivisions, neighbour links and bricks, shared brick
//! faces identical, every texel the exact CPU lattice within a stated tolerance; and the
//! update must not voxelize the static geometry again.

use crate::common::{context, tri};
use glam::Vec3;
use octolux::gpu::{GpuContext, GpuOptions, PassTimer};
use octolux::voxel::svo::dynamic::DynamicReserve;
use octolux::voxel::svo::{Svo, SvoBuilder, SvoCpu};
use octolux::voxel::{cpu, VoxelGrid, VoxelTriangle};
use std::collections::{BTreeMap, BTreeSet};

/// An axis-aligned box from `lo` to `hi` (12 triangles).
fn cube(lo: Vec3, hi: Vec3, albedo: [u8; 3]) -> Vec<VoxelTriangle> {
    let p = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let faces = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    faces
        .iter()
        .flat_map(|f| {
            [
                tri(p(f[0]), p(f[1]), p(f[2]), albedo),
                tri(p(f[0]), p(f[2]), p(f[3]), albedo),
            ]
        })
        .collect()
}

/// A floor, a back wall and a slanted triangle (static geometry of the unit cube).
fn static_scene() -> Vec<VoxelTriangle> {
    let mut tris = vec![
        tri(
            Vec3::new(0.05, 0.1, 0.05),
            Vec3::new(0.95, 0.1, 0.05),
            Vec3::new(0.95, 0.1, 0.95),
            [200, 200, 200],
        ),
        tri(
            Vec3::new(0.05, 0.1, 0.05),
            Vec3::new(0.95, 0.1, 0.95),
            Vec3::new(0.05, 0.1, 0.95),
            [200, 200, 200],
        ),
        tri(
            Vec3::new(0.3, 0.2, 0.4),
            Vec3::new(0.7, 0.8, 0.5),
            Vec3::new(0.4, 0.6, 0.8),
            [30, 220, 40],
        ),
    ];
    tris.extend(cube(
        Vec3::new(0.05, 0.1, 0.9),
        Vec3::new(0.95, 0.9, 0.93),
        [220, 30, 30],
    ));
    tris
}

/// Largest texel error of an updated octree against the exact lattice. Gathered texels are
/// filtered from 8-bit finer texels (the build filters 16-bit ones): every level adds at most
/// half an 8-bit step of rounding to an average of finer errors, so a level `k` above the
/// leaves is within (k + 1) / 2 steps, plus the f16 error the build already has.
fn tolerance(depth: u32, d: usize) -> f32 {
    (depth as usize - d) as f32 * 0.5 / 255.0 + 3e-3
}

/// Checks `gpu` against the octree of `tris` built on the CPU: the same nodes on every level
/// (static and dynamic ranges together), subdivision, links, bricks on exactly the needed
/// nodes, shared faces bit-identical, texels within [`tolerance`]. Returns the worst error.
fn check(gpu: &SvoCpu, grid: &VoxelGrid, tris: &[VoxelTriangle], label: &str) -> f32 {
    let depth = grid.depth();
    let fragments = cpu::voxelize(grid, tris);
    let voxels = cpu::voxel_values(&fragments, tris);
    let occupied: BTreeSet<[u32; 3]> = voxels.keys().copied().collect();
    let reference = cpu::build_octree(depth, &occupied);
    let lattices = cpu::lattices(depth, &voxels);
    let coords = gpu.coordinates();
    let mut worst = 0.0f32;
    for d in 0..depth as usize {
        let (s0, s1) = gpu.levels[d];
        let (d0, d1) = gpu.dynamic_levels.get(d).copied().unwrap_or((0, 0));
        let range: Vec<u32> = (s0..s1).chain(d0..d1).collect();
        let nodes: BTreeMap<[u32; 3], bool> = range
            .iter()
            .map(|&n| (coords[n as usize], gpu.child[n as usize] != 0))
            .collect();
        assert_eq!(
            nodes.len(),
            range.len(),
            "{label}: duplicate nodes on level {d}"
        );
        assert_eq!(nodes, reference[d].nodes, "{label}: nodes of level {d}");
        let in_level = |m: u32| (s0..s1).contains(&m) || (d0..d1).contains(&m);
        // Needed nodes: occupied ones and their 26 neighbours.
        let shift = depth - d as u32;
        let needed: BTreeSet<[u32; 3]> = occupied
            .iter()
            .map(|v| v.map(|c| c >> shift))
            .flat_map(|c| cpu::neighbourhood(c, 1 << d))
            .collect();
        for &n in &range {
            let c = coords[n as usize];
            assert_eq!(
                gpu.brick_of[n as usize] != 0,
                needed.contains(&c),
                "{label}: brick of level {d} node {c:?}"
            );
            for a in 0..3 {
                let mut cc = c;
                cc[a] += 1;
                let m = gpu.neighbours[n as usize][a];
                if m == 0 {
                    assert!(
                        !reference[d].nodes.contains_key(&cc),
                        "{label}: missing link {c:?} -> {cc:?} on level {d}"
                    );
                    continue;
                }
                assert!(in_level(m), "{label}: link to another level");
                assert_eq!(coords[m as usize], cc, "{label}: wrong link on level {d}");
                for k in 0..9 {
                    let (u, v) = (k % 3, k / 3);
                    let mut hi = [0usize; 3];
                    let mut lo = [0usize; 3];
                    hi[a] = 2;
                    hi[(a + 1) % 3] = u;
                    hi[(a + 2) % 3] = v;
                    lo[(a + 1) % 3] = u;
                    lo[(a + 2) % 3] = v;
                    let ti = |i: [usize; 3]| i[0] + 3 * i[1] + 9 * i[2];
                    assert_eq!(
                        gpu.node_brick(n)[ti(hi)],
                        gpu.node_brick(m)[ti(lo)],
                        "{label}: shared face of {c:?} and {cc:?} on level {d}"
                    );
                }
            }
            for t in 0..27u32 {
                let p = glam::IVec3::new(
                    (2 * c[0] + t % 3) as i32,
                    (2 * c[1] + (t / 3) % 3) as i32,
                    (2 * c[2] + t / 9) as i32,
                );
                let want = lattices[d].get(p);
                let got = gpu.node_brick(n)[t as usize];
                let err = (got - want).abs().max_element();
                worst = worst.max(err);
                assert!(
                    err <= tolerance(depth, d) + 2e-3 * want.abs().max_element(),
                    "{label}: level {d} node {c:?} texel {t}: GPU {got} CPU {want}"
                );
            }
        }
    }
    worst
}

fn unit_grid(res: u32) -> VoxelGrid {
    VoxelGrid::new(Vec3::ZERO, 1.0 / res as f32, res).unwrap()
}

fn with(a: &[VoxelTriangle], b: &[VoxelTriangle]) -> Vec<VoxelTriangle> {
    a.iter().chain(b).copied().collect()
}

/// The octree of [`static_scene`] in the unit grid of `res`^3 voxels, with room for a dynamic
/// part of `nodes` nodes: its builder, grid, static triangles and the octree.
fn static_octree(
    ctx: &GpuContext,
    res: u32,
    nodes: u32,
) -> (SvoBuilder, VoxelGrid, Vec<VoxelTriangle>, Svo) {
    let builder = SvoBuilder::new(ctx);
    let grid = unit_grid(res);
    let statics = static_scene();
    let (svo, _) = builder
        .build_with_reserve(ctx, &grid, &statics, DynamicReserve::new(nodes))
        .unwrap();
    (builder, grid, statics, svo)
}

#[test]
fn dynamic_updates_equal_rebuilds() {
    let ctx = context();
    let (builder, grid, statics, mut svo) = static_octree(&ctx, 32, 20_000);
    let (static_nodes, static_bricks) = (svo.node_count(), svo.brick_count());
    check(&svo.read_back(&ctx).unwrap(), &grid, &statics, "static");
    // A block resting on the floor (sharing voxels with it and with the slanted triangle),
    // moved away, moved into the wall, removed, back, and left there (an update of the same
    // triangles keeps the previous update's fragments).
    let positions = [
        Some(Vec3::new(0.35, 0.08, 0.35)),
        Some(Vec3::new(0.6, 0.5, 0.2)),
        Some(Vec3::new(0.12, 0.55, 0.85)),
        None,
        Some(Vec3::new(0.35, 0.08, 0.35)),
        Some(Vec3::new(0.35, 0.08, 0.35)),
    ];
    for (step, at) in positions.iter().enumerate() {
        let moving = at.map_or(Vec::new(), |p| {
            cube(p, p + Vec3::new(0.17, 0.13, 0.11), [40, 90, 250])
        });
        let update = builder.update_dynamic(&ctx, &mut svo, &moving).unwrap();
        let all = with(&statics, &moving);
        let label = format!("update {step}");
        let worst = check(&svo.read_back(&ctx).unwrap(), &grid, &all, &label);
        println!(
            "{label}: {} fragments, {} nodes and {} bricks added, {} dirty, worst texel error {worst:.2e}",
            update.fragments, update.nodes, update.bricks, update.dirty
        );
        // Only the dynamic triangles were voxelized.
        assert_eq!(
            update.fragments as usize,
            cpu::voxelize(&grid, &moving).len()
        );
        // A rebuild of everything has exactly as many nodes and bricks.
        let (rebuilt, _) = builder.build(&ctx, &grid, &all).unwrap();
        assert_eq!(svo.node_count(), rebuilt.node_count(), "{label}: nodes");
        assert_eq!(svo.brick_count(), rebuilt.brick_count(), "{label}: bricks");
        if at.is_none() {
            assert_eq!(
                (svo.node_count(), svo.brick_count()),
                (static_nodes, static_bricks)
            );
            assert_eq!((update.nodes, update.bricks), (0, 0));
        } else {
            assert!(
                update.nodes > 0 && update.bricks > 0,
                "{label}: nothing added"
            );
        }
    }
}

#[test]
fn updates_need_a_reserve_large_enough() {
    let ctx = context();
    let builder = SvoBuilder::new(&ctx);
    let grid = unit_grid(16);
    let statics = static_scene();
    let (mut plain, _) = builder.build(&ctx, &grid, &statics).unwrap();
    let err = builder.update_dynamic(&ctx, &mut plain, &[]).unwrap_err();
    assert!(err.to_string().contains("build_with_reserve"), "{err}");
    let (mut small, _) = builder
        .build_with_reserve(&ctx, &grid, &statics, DynamicReserve::new(16))
        .unwrap();
    let big = cube(Vec3::splat(0.2), Vec3::splat(0.8), [255, 0, 0]);
    let err = builder.update_dynamic(&ctx, &mut small, &big).unwrap_err();
    assert!(err.to_string().contains("reserve is too small"), "{err}");
    // After a failed update, the next one (here: nothing moving) restores the octree.
    let update = builder.update_dynamic(&ctx, &mut small, &[]).unwrap();
    assert_eq!((update.nodes, update.bricks), (0, 0));
    check(
        &small.read_back(&ctx).unwrap(),
        &grid,
        &statics,
        "after overflow",
    );
}

/// The per-frame form: every update is recorded into its frame's timer with no sync in
/// between (the GPU alone carries each update's ranges to the next), the last frame holding
/// two updates; one sync at the end gives the counts of the last update, and the octree
/// equals a rebuild of the final state.
#[test]
fn recorded_updates_without_waits_equal_a_rebuild() {
    // Without timestamps (lavapipe's default) every pass is its own submission; with them a
    // frame is one command buffer, so two updates in one frame must not overwrite each
    // other's uploads.
    recorded_updates(&context());
    recorded_updates(
        &GpuContext::shared(&GpuOptions {
            timestamps: octolux::gpu::Timestamps::Always,
            ..GpuOptions::default()
        })
        .unwrap(),
    );
}

fn recorded_updates(ctx: &GpuContext) {
    let ctx = ctx.clone();
    let (builder, grid, statics, mut svo) = static_octree(&ctx, 32, 20_000);
    let block = |x: f32, y: f32| {
        let p = Vec3::new(x, y, 0.35);
        cube(p, p + Vec3::new(0.17, 0.13, 0.11), [40, 90, 250])
    };
    // A block sliding over the floor and rising (one voxel is 1/32 = 0.031).
    let path: Vec<Vec<VoxelTriangle>> = (0..6)
        .map(|k| block(0.2 + 0.045 * k as f32, 0.08 + 0.07 * k as f32))
        .collect();
    let mut numbers = Vec::new();
    let (frames, last_frame) = path.split_at(path.len() - 2);
    for moving in frames {
        let mut timer = PassTimer::new(&ctx);
        numbers.push(
            builder
                .record_dynamic(&ctx, &mut timer, &mut svo, moving)
                .unwrap(),
        );
        timer.finish_frame().unwrap();
    }
    let mut timer = PassTimer::new(&ctx);
    for moving in last_frame {
        numbers.push(
            builder
                .record_dynamic(&ctx, &mut timer, &mut svo, moving)
                .unwrap(),
        );
    }
    timer.finish_frame().unwrap();
    assert_eq!(numbers, (1..=path.len() as u64).collect::<Vec<_>>());
    let counts = svo
        .sync_dynamic(&ctx)
        .unwrap()
        .expect("counts of the last update");
    let moving = path.last().unwrap();
    assert_eq!(counts.update, path.len() as u64);
    assert_eq!(
        counts.fragments as usize,
        cpu::voxelize(&grid, moving).len()
    );
    let all = with(&statics, moving);
    let worst = check(&svo.read_back(&ctx).unwrap(), &grid, &all, "recorded");
    let (rebuilt, _) = builder.build(&ctx, &grid, &all).unwrap();
    assert_eq!(svo.node_count(), rebuilt.node_count(), "nodes");
    assert_eq!(svo.brick_count(), rebuilt.brick_count(), "bricks");
    assert_eq!(svo.node_count() - svo.static_nodes(), counts.nodes);
    println!(
        "after {} recorded updates: {counts:?}, worst texel error {worst:.2e}",
        path.len()
    );
}

/// An update that exhausts the reserve is reported by a later update or by the sync, naming
/// the update and what ran out, and the octree recovers at the next update that fits.
#[test]
fn an_exhausted_reserve_is_reported_after_the_frame() {
    let ctx = context();
    let builder = SvoBuilder::new(&ctx);
    let grid = unit_grid(16);
    let statics = static_scene();
    let reserve = DynamicReserve::new(16);
    let (mut small, _) = builder
        .build_with_reserve(&ctx, &grid, &statics, reserve)
        .unwrap();
    let big = cube(Vec3::splat(0.2), Vec3::splat(0.8), [255, 0, 0]);
    assert!(cpu::voxelize(&grid, &big).len() > reserve.fragments as usize);
    let mut timer = PassTimer::new(&ctx);
    // Nothing is known yet when the overflowing update is recorded.
    assert_eq!(
        builder
            .record_dynamic(&ctx, &mut timer, &mut small, &big)
            .unwrap(),
        1
    );
    timer.finish_frame().unwrap();
    let mut timer = PassTimer::new(&ctx);
    let next = builder.record_dynamic(&ctx, &mut timer, &mut small, &[]);
    timer.finish_frame().unwrap();
    let err = match next {
        Err(e) => e,
        Ok(n) => {
            assert_eq!(n, 2);
            small.sync_dynamic(&ctx).unwrap_err()
        }
    };
    let text = err.to_string();
    assert!(text.contains("reserve is too small"), "{text}");
    assert!(text.contains("update 1"), "{text}");
    assert!(text.contains("ran out of fragments"), "{text}");
    println!("{text}");
    // The second update (nothing moving) restored the static octree.
    small.sync_dynamic(&ctx).unwrap();
    assert_eq!(
        (small.node_count(), small.brick_count()),
        (small.static_nodes(), small.static_bricks())
    );
    check(
        &small.read_back(&ctx).unwrap(),
        &grid,
        &statics,
        "after a reported overflow",
    );
}

/// Time of a dynamic update against a full rebuild of the same frame (figures for
/// docs/voxels.md; the assertion is only that both give the same octree size).
/// `VOXEL_TABLE=full cargo test --release -p octolux --test integration voxel_svo_dynamic::measure --
/// --nocapture` prints the whole table; by default one small row runs.
#[test]
fn measure_update_against_rebuild() {
    use octolux::scene::Scene;
    use octolux::voxel::scene_triangles_split;
    let full = std::env::var("VOXEL_TABLE").is_ok_and(|v| v == "full");
    let ctx = context();
    println!("adapter: {}", ctx.describe());
    let builder = SvoBuilder::new(&ctx);
    let scenes_dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/");
    let mut cases = Vec::new();
    // The animated Cornell box: its short block moves (t = 0 then t = 1 s).
    let animated = Scene::load(format!("{scenes_dir}cornell-animated.toml")).unwrap();
    let split = |t: f32| scene_triangles_split(&animated, &animated.frame(t, 0));
    let (still, before) = split(0.0);
    let (_, after) = split(1.0);
    assert!(!before.is_empty() && !still.is_empty());
    cases.push((
        "cornell-animated",
        animated.bounds_at(0.0),
        still,
        before,
        after,
    ));
    if full {
        match Scene::load(format!("{scenes_dir}crytek-sponza.toml")) {
            Ok(sponza) => {
                // A 1 m cube (the scene is in metres) moving 50 cm through the middle.
                let tris = octolux::voxel::scene_triangles(&sponza, &sponza.frame(0.0, 0));
                let bounds = sponza.bounds_at(0.0);
                let at = (bounds.0 + bounds.1) * 0.5
                    - Vec3::new(0.0, (bounds.1.y - bounds.0.y) * 0.3, 0.0);
                let block = |p: Vec3| cube(p, p + Vec3::ONE, [200, 60, 60]);
                let moved = at + Vec3::new(0.5, 0.0, 0.0);
                cases.push((
                    "crytek-sponza + moving cube",
                    bounds,
                    tris,
                    block(at),
                    block(moved),
                ));
            }
            Err(e) => println!("Crytek Sponza skipped: {e}"),
        }
    }
    let resolutions: &[u32] = if full { &[64, 128, 256] } else { &[32] };
    println!("| scene | N^3 | static / moving triangles | rebuild ms | update ms | update / rebuild | nodes, bricks added | dirty nodes |");
    println!("|---|---|---|---|---|---|---|---|");
    for (name, bounds, still, before, after) in &cases {
        for &res in resolutions {
            let grid = VoxelGrid::enclosing(*bounds, res).unwrap();
            let (mut svo, _) = builder
                .build_with_reserve(&ctx, &grid, still, DynamicReserve::new(1 << 17))
                .unwrap();
            // The first update also compiles nothing new but touches every buffer once.
            builder.update_dynamic(&ctx, &mut svo, before).unwrap();
            let start = std::time::Instant::now();
            let update = builder.update_dynamic(&ctx, &mut svo, after).unwrap();
            let update_wall = start.elapsed().as_secs_f64() * 1e3;
            let update_gpu: f64 = update.timings.iter().map(|t| t.ms).sum();
            let all = with(still, after);
            let start = std::time::Instant::now();
            let (rebuilt, timings) = builder.build(&ctx, &grid, &all).unwrap();
            let rebuild_wall = start.elapsed().as_secs_f64() * 1e3;
            let rebuild_gpu: f64 = timings.iter().map(|t| t.ms).sum();
            if std::env::var_os(octolux::gpu::PROFILE_STEPS_ENV).is_some() {
                println!(
                    "{name} at {res}^3, update:\n{}",
                    octolux::gpu::slowest_first(&update.timings)
                );
            }
            assert_eq!(svo.node_count(), rebuilt.node_count(), "{name} at {res}^3");
            assert_eq!(
                svo.brick_count(),
                rebuilt.brick_count(),
                "{name} at {res}^3"
            );
            println!(
                "| {name} | {res} | {} / {} | {rebuild_gpu:.1} ({rebuild_wall:.0} wall) | {update_gpu:.1} ({update_wall:.0} wall) | {:.2} | {}, {} | {} |",
                still.len(),
                after.len(),
                update_gpu / rebuild_gpu.max(1e-9),
                update.nodes,
                update.bricks,
                update.dirty
            );
        }
    }
}

/// Another thread polling the same device (as other renderers or tests sharing it do) may be
/// the one that sees a frame finish; the readback's callback then runs on that thread a moment
/// after this one's wait has returned. A blocking update still returns its own counts.
#[test]
fn blocking_updates_read_their_counts_while_another_thread_polls_the_device() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let ctx = context();
    let (builder, grid, _, mut svo) = static_octree(&ctx, 16, 4096);
    let moving = cube(Vec3::splat(0.3), Vec3::splat(0.45), [40, 90, 250]);
    let expected = cpu::voxelize(&grid, &moving).len() as u32;
    let done = AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            // Its own mappings' callbacks take a while, so a callback of the octree's that a
            // poll of this thread collects alongside one of them runs late.
            let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("another thread's readback"),
                size: 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            while !done.load(Ordering::Relaxed) {
                let mapped = std::sync::Arc::new(AtomicBool::new(false));
                let sink = mapped.clone();
                buffer.map_async(wgpu::MapMode::Read, .., move |_| {
                    std::thread::sleep(std::time::Duration::from_millis(3));
                    sink.store(true, Ordering::Release);
                });
                while !mapped.load(Ordering::Acquire) && !done.load(Ordering::Relaxed) {
                    let _ = ctx.device.poll(wgpu::PollType::Poll);
                }
                if mapped.load(Ordering::Acquire) {
                    buffer.unmap();
                }
            }
        });
        for step in 0..200 {
            let update = builder.update_dynamic(&ctx, &mut svo, &moving);
            let update = update.map_err(|e| format!("update {step}: {e}"));
            done.store(update.is_err(), Ordering::Relaxed);
            assert_eq!(update.unwrap().fragments, expected, "update {step}");
        }
        done.store(true, Ordering::Relaxed);
    });
}
