//! Anisotropic (6-direction) voxels of the sparse voxel octree, on whatever adapter is present:
//! every node's values against the CPU twin (bit for bit), a red wall in front of a green one
//! seen from both sides, GPU directional samples against the CPU twin, the memory recorded in
//! the ledger, and the memory and pass time on the Cornell box.

use crate::common::{context, tri, Rng};
use glam::{Vec3, Vec4};
use octolux::gpu::{GpuContext, PassTimer};
use octolux::voxel::svo::aniso::{SvoAniso, SvoAnisoValues, LEDGER_LABEL};
use octolux::voxel::svo::sample::{svo_sample, svo_sample_aniso};
use octolux::voxel::svo::{Svo, SvoBuilder};
use octolux::voxel::{cpu, VoxelGrid, VoxelTriangle};

/// Random triangles of different colours, some large, some small.
fn scene(seed: u64, count: usize) -> Vec<VoxelTriangle> {
    let mut rng = Rng(seed);
    (0..count)
        .map(|i| {
            let c = rng.vec(0.15, 0.85);
            let s = if i % 3 == 0 { 0.3 } else { 0.1 };
            tri(
                c + rng.vec(-s, s),
                c + rng.vec(-s, s),
                c + rng.vec(-s, s),
                [(i * 20) as u8, 255 - (i * 13) as u8, (40 + i * 7) as u8],
            )
        })
        .collect()
}

fn unit_grid(res: u32) -> VoxelGrid {
    VoxelGrid::new(Vec3::ZERO, 1.0 / res as f32, res).unwrap()
}

fn build(
    ctx: &GpuContext,
    builder: &SvoBuilder,
    aniso: &SvoAniso,
    grid: &VoxelGrid,
    tris: &[VoxelTriangle],
) -> (Svo, SvoAnisoValues) {
    let (svo, _) = builder.build(ctx, grid, tris).unwrap();
    let mut timer = PassTimer::new(ctx);
    let values = aniso.build(ctx, &mut timer, &svo).unwrap();
    let timings = timer.finish_frame().unwrap();
    assert!(timings.iter().any(|t| t.name == "svo anisotropic"));
    (svo, values)
}

#[test]
fn node_values_equal_cpu_twin_and_bricks_cover_every_nonzero_node() {
    let ctx = context();
    let builder = SvoBuilder::new(&ctx);
    let aniso = SvoAniso::new(&ctx);
    // An empty octree has no bricks and no values.
    let (_, empty) = build(&ctx, &builder, &aniso, &unit_grid(8), &[]);
    assert_eq!(empty.brick_count, 0);
    assert!(empty.read_back(&ctx).unwrap().is_empty());
    // The same kernels over different octrees: rebuilding is one call.
    for (res, seed, count) in [(8u32, 1u64, 8usize), (32, 2, 20), (64, 3, 30)] {
        let grid = unit_grid(res);
        let tris = scene(seed, count);
        let (svo, values) = build(&ctx, &builder, &aniso, &grid, &tris);
        let gpu = values.read_back(&ctx).unwrap();
        assert_eq!(gpu.len() as u32, svo.brick_count());
        let tree = svo.read_back(&ctx).unwrap();
        let coords = tree.coordinates();
        let voxels = cpu::voxel_words(&cpu::voxelize(&grid, &tris), &tris);
        let reference = cpu::svo_aniso(grid.depth(), &voxels);
        let mut nonzero = 0;
        let mut directional = 0;
        for (d, &(start, end)) in svo.levels().iter().enumerate() {
            let mut seen = 0;
            for n in start..end {
                let c = coords[n as usize];
                let want = reference[d].get(&c);
                seen += want.is_some() as usize;
                match tree.brick_of[n as usize] {
                    // No brick: the node holds no occupied voxel, so it is zero.
                    0 => assert!(want.is_none(), "level {d} node {c:?} has no brick"),
                    b => {
                        let got = gpu[b as usize - 1];
                        let want = want.copied().unwrap_or([0; 6]);
                        assert_eq!(got, want, "level {d} node {c:?} at {res}^3");
                        nonzero += (got != [0; 6]) as usize;
                        directional += got.iter().any(|&w| w != got[0]) as usize;
                    }
                }
            }
            // Every node holding an occupied voxel exists in the octree.
            assert_eq!(seen, reference[d].len(), "level {d} at {res}^3");
        }
        assert!(nonzero > 10 && directional > 10, "{nonzero} {directional}");
        // 24 bytes per brick in the ledger.
        let entry = ctx
            .ledger
            .entries()
            .into_iter()
            .find(|e| e.owner == "svo" && e.name == LEDGER_LABEL)
            .expect("ledger entry");
        assert_eq!(entry.bytes, 24 * svo.brick_count() as u64);
        assert_eq!(values.bytes(), entry.bytes);
    }
}

/// A thin red wall in front of a green one, one voxel apart (x = 16.5 and 17.5 voxels of a
/// 32^3 grid), both inside one finest node (voxels 16..17) and one node of the level above.
fn walls() -> Vec<VoxelTriangle> {
    let v = 1.0 / 32.0;
    let wall = |x: f32, albedo: [u8; 3]| {
        let (lo, hi) = (0.3, 0.7);
        let a = Vec3::new(x, lo, lo);
        let b = Vec3::new(x, hi, lo);
        let c = Vec3::new(x, hi, hi);
        let d = Vec3::new(x, lo, hi);
        vec![tri(a, b, c, albedo), tri(a, c, d, albedo)]
    };
    let mut tris = wall(16.5 * v, [255, 0, 0]);
    tris.extend(wall(17.5 * v, [0, 255, 0]));
    tris
}

#[test]
fn red_wall_in_front_of_green_reads_the_front_colour() {
    let ctx = context();
    let grid = unit_grid(32);
    let tris = walls();
    let (svo, values) = build(
        &ctx,
        &SvoBuilder::new(&ctx),
        &SvoAniso::new(&ctx),
        &grid,
        &tris,
    );
    let tree = svo.read_back(&ctx).unwrap();
    let aniso = values.read_back(&ctx).unwrap();
    let red = Vec4::new(1.0, 0.0, 0.0, 1.0);
    let green = Vec4::new(0.0, 1.0, 0.0, 1.0);
    let half = Vec4::new(0.5, 0.5, 0.0, 1.0);
    let v = grid.voxel_size;
    // Centres of the finest node over voxels 16..17 and of its parent over 16..19, each with
    // its node size as footprint. Seen along y, the walls fill the finest node and half of its
    // parent.
    for (p, f, side) in [
        (Vec3::splat(17.0 * v), 2.0 * v, 1.0),
        (Vec3::splat(18.0 * v), 4.0 * v, 0.5),
    ] {
        let dirs = [Vec3::X, Vec3::NEG_X, Vec3::new(1.0, 0.3, -0.2), Vec3::Y];
        let cpu: Vec<Vec4> = dirs
            .iter()
            .map(|&d| svo_sample_aniso(&tree, &aniso, &grid, p, f, d))
            .collect();
        let gpu = SvoAniso::probe(&ctx, &svo, &values, &[p.extend(f); 4], Some(&dirs)).unwrap();
        for (g, c) in gpu.iter().zip(&cpu) {
            assert!((*g - *c).abs().max_element() < 1e-4, "GPU {g} CPU {c}");
        }
        let near = |a: Vec4, b: Vec4| (a - b).abs().max_element() < 0.01;
        assert!(near(cpu[0], red), "travelling +x at {p}: {}", cpu[0]);
        assert!(near(cpu[1], green), "travelling -x at {p}: {}", cpu[1]);
        assert!(
            cpu[2].x > 0.6 && cpu[2].y < 0.3,
            "oblique at {p}: {}",
            cpu[2]
        );
        // Along y the walls are side by side: half of each.
        assert!(
            near(cpu[3], half * side),
            "travelling +y at {p}: {}",
            cpu[3]
        );
        // The isotropic sample mixes the two, whichever way the cone travels.
        let iso = svo_sample(&tree, &grid, p, f);
        let gpu_iso = SvoAniso::probe(&ctx, &svo, &values, &[p.extend(f)], None).unwrap()[0];
        assert!((gpu_iso - iso).abs().max_element() < 1e-4);
        println!(
            "isotropic at {p}, footprint {f}: {iso}; +x {}, -x {}",
            cpu[0], cpu[1]
        );
        assert!(
            iso.x > 0.1 && iso.y > 0.1 && (iso.x - iso.y).abs() < 0.25 * iso.w,
            "isotropic at {p}: {iso}"
        );
    }
}

#[test]
fn gpu_directional_samples_match_cpu_twin() {
    let ctx = context();
    let grid = unit_grid(32);
    let tris = scene(7, 24);
    let aniso = SvoAniso::new(&ctx);
    // A brick pool split over four buffers, so that the isotropic fallback crosses buffers.
    let (whole, _) = SvoBuilder::new(&ctx).build(&ctx, &grid, &tris).unwrap();
    let builder = SvoBuilder::new(&ctx).with_pool_limit(whole.brick_count().div_ceil(4));
    let (svo, values) = build(&ctx, &builder, &aniso, &grid, &tris);
    assert!(svo.brick_count() > 3 * svo.pool_bricks());
    let tree = svo.read_back(&ctx).unwrap();
    let words = values.read_back(&ctx).unwrap();
    let mut rng = Rng(99);
    let v = grid.voxel_size;
    let footprints = [
        0.5 * v,
        v,
        1.5 * v,
        2.0 * v,
        3.0 * v,
        5.0 * v,
        11.0 * v,
        40.0 * v,
    ];
    let mut points = Vec::new();
    let mut dirs = Vec::new();
    for i in 0..480 {
        points.push(
            rng.vec(-0.05, 1.05)
                .extend(footprints[i % footprints.len()]),
        );
        let d = rng.vec(-1.0, 1.0);
        // Some axis-aligned directions and some with a zero component.
        dirs.push(match i % 7 {
            0 => Vec3::X,
            1 => Vec3::NEG_Z,
            2 => Vec3::new(d.x, 0.0, d.z),
            _ => d,
        });
    }
    let gpu = SvoAniso::probe(&ctx, &svo, &values, &points, Some(&dirs)).unwrap();
    let mut nonzero = 0;
    let mut worst = 0.0f32;
    for ((p, d), g) in points.iter().zip(&dirs).zip(&gpu) {
        let c = svo_sample_aniso(&tree, &words, &grid, p.truncate(), p.w, *d);
        let err = (*g - c).abs().max_element();
        worst = worst.max(err);
        assert!(err < 1e-4, "at {p} along {d}: GPU {g} CPU {c}");
        nonzero += (c.w > 0.0) as u32;
    }
    println!("worst GPU/CPU difference {worst:e}, {nonzero} non-zero samples");
    assert!(nonzero > 100, "only {nonzero} non-empty samples");
}

/// Memory and pass time of the anisotropic values on the Cornell box (64^3; 64^3 to 256^3
/// with `VOXEL_TABLE=full`), printed as the table in `docs/voxels.md`.
#[test]
fn measure_memory_and_pass_time() {
    let full = std::env::var("VOXEL_TABLE").is_ok_and(|v| v == "full");
    let ctx = context();
    println!("adapter: {}", ctx.describe());
    let builder = SvoBuilder::new(&ctx);
    let aniso = SvoAniso::new(&ctx);
    let scene = octolux::scene::cornell::scene();
    let tris = octolux::voxel::scene_triangles(&scene, &scene.frame(0.0, 0));
    let bounds = scene.bounds_at(0.0);
    // Warm up (shader compilation at the first dispatch).
    build(
        &ctx,
        &builder,
        &aniso,
        &VoxelGrid::enclosing(bounds, 32).unwrap(),
        &tris,
    );
    let resolutions: &[u32] = if full { &[64, 128, 256] } else { &[64] };
    println!("| N^3 | octree nodes | bricks | octree MB | anisotropic MB | anisotropic pass ms |");
    println!("|---|---|---|---|---|---|");
    for &res in resolutions {
        let grid = VoxelGrid::enclosing(bounds, res).unwrap();
        let svo = match builder.build(&ctx, &grid, &tris) {
            Ok((svo, _)) => svo,
            Err(e) => {
                println!(
                    "| {res} | octree build failed: {} |",
                    e.to_string().replace('\n', " ")
                );
                continue;
            }
        };
        let mut ms = Vec::new();
        let mut bytes = 0;
        for _ in 0..3 {
            let mut timer = PassTimer::new(&ctx);
            let values = aniso.build(&ctx, &mut timer, &svo).unwrap();
            let t = timer.finish_frame().unwrap();
            ms.push(t.iter().map(|t| t.ms).sum::<f64>());
            bytes = values.bytes();
        }
        assert_eq!(bytes, 24 * svo.brick_count() as u64);
        ms.sort_by(f64::total_cmp);
        println!(
            "| {res} | {} | {} | {:.1} | {:.2} | {:.1} |",
            svo.node_count(),
            svo.brick_count(),
            svo.bytes() as f64 / 1e6,
            bytes as f64 / 1e6,
            ms[1]
        );
    }
}
