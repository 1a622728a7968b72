//! Voxel structures against their CPU references, on whatever adapter is present (lavapipe in
//! CI): conservative voxelization (exact fragment lists, thin geometry), the sparse voxel octree
//! (structure, neighbour links, brick borders, mipmaps), the clipmap (incremental update equals
//! a rebuild) and the common sampling interface.

use crate::common::{context, tri, Rng};
use crate::lit_floor;
use glam::Vec3;
use octolux::gpu::GpuContext;
use octolux::voxel::voxelize::{read_fragments, Voxelizer};
use octolux::voxel::{cpu, VoxelGrid, VoxelTriangle};
use std::collections::BTreeSet;

/// A closed box with axis `a`-`b` and square cross-section of side `width` (12 triangles).
fn thin_box(a: Vec3, b: Vec3, width: f32, albedo: [u8; 3]) -> Vec<VoxelTriangle> {
    let axis = (b - a).normalize();
    let u = axis.any_orthonormal_vector() * width * 0.5;
    let v = axis.cross(u).normalize() * width * 0.5;
    let corners = |p: Vec3| [p - u - v, p + u - v, p + u + v, p - u + v];
    let (s, e) = (corners(a), corners(b));
    let mut out = Vec::new();
    for i in 0..4 {
        let j = (i + 1) % 4;
        out.push(tri(s[i], s[j], e[j], albedo));
        out.push(tri(s[i], e[j], e[i], albedo));
    }
    out.push(tri(s[0], s[1], s[2], albedo));
    out.push(tri(s[0], s[2], s[3], albedo));
    out.push(tri(e[0], e[2], e[1], albedo));
    out.push(tri(e[0], e[3], e[2], albedo));
    out
}

fn unit_grid(res: u32) -> VoxelGrid {
    VoxelGrid::new(Vec3::ZERO, 1.0 / res as f32, res).unwrap()
}

fn gpu_fragments(
    ctx: &GpuContext,
    grid: &VoxelGrid,
    tris: &[VoxelTriangle],
) -> Vec<([u32; 3], u32)> {
    let voxelizer = Voxelizer::new(ctx);
    let mut timings = Vec::new();
    let list = voxelizer
        .fragments(ctx, "voxelizer", grid, tris, &mut timings)
        .unwrap();
    assert_eq!(
        list.count as usize,
        read_fragments(ctx, &list).unwrap().len()
    );
    read_fragments(ctx, &list).unwrap()
}

/// Exact equality of two fragment lists, reporting only the differences.
fn assert_same(gpu: &[([u32; 3], u32)], cpu: &[([u32; 3], u32)], what: &str) {
    let a: BTreeSet<_> = gpu.iter().copied().collect();
    let b: BTreeSet<_> = cpu.iter().copied().collect();
    let only_gpu: Vec<_> = a.difference(&b).take(10).collect();
    let only_cpu: Vec<_> = b.difference(&a).take(10).collect();
    assert!(
        only_gpu.is_empty() && only_cpu.is_empty(),
        "{what}: only on the GPU {only_gpu:?}, only on the CPU {only_cpu:?}"
    );
    assert!(gpu == cpu, "{what}: same fragments in a different order");
}

/// Every point of a fine barycentric sampling of each triangle lies in a marked voxel: an
/// independent check that nothing the geometry touches is lost.
fn assert_covers(grid: &VoxelGrid, tris: &[VoxelTriangle], marked: &BTreeSet<[u32; 3]>) {
    let steps = 4 * grid.resolution;
    for t in tris {
        let [a, b, c] = t.positions.map(|p| cpu::to_grid(p, grid));
        for i in 0..=steps {
            for j in 0..=steps - i {
                let (u, v) = (i as f32 / steps as f32, j as f32 / steps as f32);
                let p = a + (b - a) * u + (c - a) * v;
                let cell = p
                    .floor()
                    .clamp(Vec3::ZERO, Vec3::splat(grid.resolution as f32 - 1.0));
                let cell = [cell.x as u32, cell.y as u32, cell.z as u32];
                assert!(
                    marked.contains(&cell),
                    "point {p} of the geometry is in unmarked voxel {cell:?}"
                );
            }
        }
    }
}

#[test]
fn voxelization_equals_cpu_conservative_rasteriser() {
    let ctx = context();
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let mut tris: Vec<VoxelTriangle> = (0..24)
        .map(|i| {
            let c = rng.vec(0.1, 0.9);
            let s = if i % 3 == 0 { 0.4 } else { 0.08 };
            tri(
                c + rng.vec(-s, s),
                c + rng.vec(-s, s),
                c + rng.vec(-s, s),
                [200, 100, 50],
            )
        })
        .collect();
    // A sliver, a degenerate (zero-area) triangle and one reaching outside the grid.
    tris.push(tri(
        Vec3::new(0.13, 0.2, 0.31),
        Vec3::new(0.87, 0.71, 0.33),
        Vec3::new(0.8701, 0.7102, 0.3301),
        [1, 2, 3],
    ));
    tris.push(tri(
        Vec3::new(0.21, 0.22, 0.23),
        Vec3::new(0.61, 0.52, 0.43),
        Vec3::new(0.41, 0.37, 0.33),
        [4, 5, 6],
    ));
    tris.push(tri(
        Vec3::new(-0.5, 0.37, 0.41),
        Vec3::new(1.3, 0.52, 0.45),
        Vec3::new(0.4, 1.2, 0.6),
        [7, 8, 9],
    ));
    for res in [16, 32] {
        let grid = unit_grid(res);
        let gpu = gpu_fragments(&ctx, &grid, &tris);
        let reference = cpu::voxelize(&grid, &tris);
        assert!(reference.len() > 100);
        assert_same(&gpu, &reference, &format!("{res}^3"));
    }
}

/// Triangles on voxel faces, edges and corners, and near them (see
/// [`boundary_configurations_equal_cpu_exactly`]); triangle 12 is much larger than the grid.
fn boundary_triangles() -> Vec<VoxelTriangle> {
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) / 16.0;
    let mut tris = vec![
        // In the face plane z = 4, corners on voxel corners and inside voxels.
        tri(
            v(2.0, 2.0, 4.0),
            v(6.0, 2.0, 4.0),
            v(2.0, 6.0, 4.0),
            [10, 20, 30],
        ),
        tri(
            v(2.5, 2.5, 4.0),
            v(5.5, 2.5, 4.0),
            v(2.5, 5.5, 4.0),
            [10, 20, 30],
        ),
        // An edge along a voxel edge line, and a plane through voxel corners (x + y = 8).
        tri(
            v(3.0, 3.0, 1.0),
            v(3.0, 3.0, 7.0),
            v(6.0, 5.0, 4.0),
            [40, 50, 60],
        ),
        tri(
            v(2.0, 6.0, 9.0),
            v(6.0, 2.0, 9.0),
            v(4.0, 4.0, 13.0),
            [40, 50, 60],
        ),
        // Vertices on corners only; a point on a corner; a segment along a voxel edge.
        tri(
            v(8.0, 8.0, 8.0),
            v(10.0, 9.0, 8.0),
            v(9.0, 10.0, 11.0),
            [70, 80, 90],
        ),
        tri(
            v(12.0, 12.0, 12.0),
            v(12.0, 12.0, 12.0),
            v(12.0, 12.0, 12.0),
            [1, 1, 1],
        ),
        tri(
            v(1.0, 13.0, 2.0),
            v(1.0, 13.0, 6.0),
            v(1.0, 13.0, 4.0),
            [2, 2, 2],
        ),
        // On the grid's outer faces.
        tri(
            v(0.0, 0.0, 0.0),
            v(16.0, 0.0, 0.0),
            v(0.0, 0.0, 16.0),
            [3, 3, 3],
        ),
        tri(
            v(16.0, 3.0, 3.0),
            v(16.0, 9.0, 3.0),
            v(16.0, 3.0, 9.0),
            [3, 3, 3],
        ),
        // Decimal coordinates close to (not on) lattice lines: the emissive triangle whose
        // hypotenuse x + z = 12.8 + 3.2 passes a hair from voxel edges, the degenerate
        // (collinear) triangle and the slanted triangle of the octree tests.
        tri(
            Vec3::new(0.2, 0.53, 0.2),
            Vec3::new(0.8, 0.53, 0.2),
            Vec3::new(0.2, 0.53, 0.8),
            [4, 4, 4],
        ),
        tri(
            Vec3::new(0.21, 0.22, 0.23),
            Vec3::new(0.61, 0.52, 0.43),
            Vec3::new(0.41, 0.37, 0.33),
            [5, 5, 5],
        ),
        tri(
            Vec3::new(0.3, 0.2, 0.4),
            Vec3::new(0.7, 0.8, 0.5),
            Vec3::new(0.4, 0.6, 0.8),
            [6, 6, 6],
        ),
        // A triangle much larger than the grid (split into pieces on the CPU).
        tri(
            Vec3::new(-30.0, 0.4, -20.0),
            Vec3::new(40.0, 0.45, -25.0),
            Vec3::new(5.0, 0.5, 60.0),
            [7, 7, 7],
        ),
    ];
    // Many tiny triangles around one voxel corner, offsets of 0, 1/128, 1/64 and 1/16 voxel.
    for (i, d) in [0.0f32, 1.0 / 128.0, 1.0 / 64.0, 1.0 / 16.0]
        .into_iter()
        .enumerate()
    {
        for s in [-1.0f32, 1.0] {
            let c = v(7.0 + s * d, 5.0 - s * d, 3.0 + d);
            tris.push(tri(
                c,
                c + v(0.01, 0.0, 0.0),
                c + v(0.0, 0.01, 0.02),
                [8, 8, i as u8],
            ));
        }
    }
    tris
}

/// Configurations that a float overlap test decides by rounding (and that a GPU compiler's
/// fused multiply-adds decided differently from the CPU): triangles in voxel face planes, edges
/// through voxel edges and corners, vertices on corners, degenerate triangles, planes touching
/// corners, and the same with world coordinates that are not exact in binary. The integer test
/// on the snapping lattice must give exactly the CPU's fragments on every adapter.
#[test]
fn boundary_configurations_equal_cpu_exactly() {
    let ctx = context();
    let tris = boundary_triangles();
    for res in [16, 32] {
        let grid = unit_grid(res);
        let gpu = gpu_fragments(&ctx, &grid, &tris);
        let reference = cpu::voxelize(&grid, &tris);
        assert_same(&gpu, &reference, &format!("{res}^3"));
        // Coverage of everything but the triangle larger than the grid (whose points outside the
        // grid `assert_covers` would clamp to the border).
        let marked: BTreeSet<[u32; 3]> = gpu.iter().filter(|f| f.1 != 12).map(|f| f.0).collect();
        let inside: Vec<VoxelTriangle> = [&tris[..12], &tris[13..]].concat();
        assert_covers(&grid, &inside, &marked);
        let of = |t: u32| -> BTreeSet<[u32; 3]> {
            gpu.iter().filter(|f| f.1 == t).map(|f| f.0).collect()
        };
        if res == 16 {
            // A triangle in a face plane marks both layers; a point on a corner its 8 voxels.
            assert!(of(0).iter().any(|c| c[2] == 3) && of(0).iter().any(|c| c[2] == 4));
            assert_eq!(of(5).len(), 8);
        }
    }
}

/// The clipmap's voxelization of the boundary configurations equals the CPU twin bit for bit
/// (albedo and emission) on every level, and a rebuild after a move equals an update.
#[test]
fn clipmap_boundary_configurations_equal_cpu_exactly() {
    use octolux::gpu::PassTimer;
    use octolux::voxel::clipmap::{Clipmap, ClipmapSettings};
    let ctx = context();
    let tris = with_emission(boundary_triangles());
    let settings = ClipmapSettings {
        resolution: 16,
        levels: 3,
        voxel_size: 1.0 / 32.0,
    };
    let mut clipmap = Clipmap::new(&ctx, settings).unwrap();
    let mut timer = PassTimer::new(&ctx);
    for centre in [Vec3::splat(0.5), Vec3::new(0.59, 0.43, 0.5)] {
        clipmap.update(&ctx, &mut timer, &tris, centre).unwrap();
        timer.finish_frame().unwrap();
        let origins: Vec<_> = clipmap.origins.iter().map(|o| o.unwrap()).collect();
        let voxels = clipmap.read_voxels(&ctx).unwrap();
        assert!(voxels.iter().filter(|&&v| v != 0).count() > 100);
        let reference = cpu::clipmap_voxels(&settings, &origins, &tris);
        let wrong = voxels
            .iter()
            .zip(&reference)
            .filter(|(x, y)| x != y)
            .count();
        assert_eq!(
            wrong, 0,
            "{wrong} clipmap voxels differ from the CPU reference"
        );
        assert_eq!(
            clipmap.read_emission(&ctx).unwrap(),
            cpu::clipmap_emission(&settings, &origins, &tris)
        );
    }
}

#[test]
fn thin_geometry_is_fully_covered() {
    let ctx = context();
    // A slanted pole a fifth of a (64^3) voxel thick, and a quad in a 45-degree plane.
    let mut tris = thin_box(
        Vec3::new(0.111, 0.093, 0.127),
        Vec3::new(0.873, 0.901, 0.689),
        0.2 / 64.0,
        [255, 0, 0],
    );
    let (p, q) = (Vec3::new(0.05, 0.06, 0.52), Vec3::new(0.93, 0.94, 0.52));
    let up = Vec3::new(0.0, 0.0, 0.4131);
    tris.push(tri(p - up, q - up, q + up, [0, 255, 0]));
    tris.push(tri(p - up, q + up, p + up, [0, 255, 0]));
    for res in [16, 32, 64] {
        let grid = unit_grid(res);
        let gpu = gpu_fragments(&ctx, &grid, &tris);
        assert_same(&gpu, &cpu::voxelize(&grid, &tris), &format!("{res}^3"));
        let pole: BTreeSet<[u32; 3]> = gpu.iter().filter(|f| f.1 < 12).map(|f| f.0).collect();
        let plane: BTreeSet<[u32; 3]> = gpu.iter().filter(|f| f.1 >= 12).map(|f| f.0).collect();
        assert_covers(&grid, &tris[..12], &pole);
        assert_covers(&grid, &tris[12..], &plane);
        // The pole is a connected line of voxels: at least one voxel per step along its
        // longest axis (the diagonal spans about 0.8 of the grid).
        let xs: BTreeSet<u32> = pole.iter().map(|v| v[1]).collect();
        assert!(
            xs.len() as f32 >= 0.8 * res as f32,
            "pole has gaps at {res}^3"
        );
    }
}

#[test]
fn absurd_resolutions_are_rejected() {
    for res in [0, 1, 3, 48, 2048, u32::MAX] {
        assert!(matches!(
            VoxelGrid::new(Vec3::ZERO, 1.0, res),
            Err(octolux::Error::InvalidArgument(_))
        ));
    }
    assert!(VoxelGrid::new(Vec3::ZERO, 0.0, 64).is_err());
}

/// A few random triangles, a thin pole and a 45-degree plane with different colours.
fn small_scene() -> Vec<VoxelTriangle> {
    let mut rng = Rng(12345);
    let mut tris: Vec<VoxelTriangle> = (0..12)
        .map(|i| {
            let c = rng.vec(0.15, 0.85);
            let albedo = [(i * 20) as u8, 255 - (i * 20) as u8, 77];
            tri(
                c + rng.vec(-0.2, 0.2),
                c + rng.vec(-0.2, 0.2),
                c + rng.vec(-0.2, 0.2),
                albedo,
            )
        })
        .collect();
    tris.extend(thin_box(
        Vec3::new(0.2, 0.11, 0.13),
        Vec3::new(0.81, 0.87, 0.71),
        0.01,
        [250, 10, 10],
    ));
    tris
}

#[test]
fn octree_equals_cpu_build_and_mip_filter() {
    use octolux::voxel::svo::SvoBuilder;
    let ctx = context();
    let tris = small_scene();
    // 4^3: the smallest octree, two levels (the root is the only level the coarse-level
    // dispatch filters); the last case splits the brick pool over three buffers.
    for (res, split) in [(4u32, false), (8, false), (32, false), (32, true)] {
        let grid = unit_grid(res);
        let mut builder = SvoBuilder::new(&ctx);
        if split {
            let (whole, _) = builder.build(&ctx, &grid, &tris).unwrap();
            builder = builder.with_pool_limit(whole.brick_count().div_ceil(3));
        }
        let (svo, timings) = builder.build(&ctx, &grid, &tris).unwrap();
        if split {
            assert!(svo.brick_count() > 2 * svo.pool_bricks(), "pool not split");
        }
        assert!(timings.iter().any(|t| t.name == "svo bricks"));
        let gpu = svo.read_back(&ctx).unwrap();
        let coords = gpu.coordinates();
        let fragments = cpu::voxelize(&grid, &tris);
        let voxels = cpu::voxel_values(&fragments, &tris);
        let occupied: BTreeSet<[u32; 3]> = voxels.keys().copied().collect();
        let depth = grid.depth();
        let reference = cpu::build_octree(depth, &occupied);
        let lattices = cpu::lattices(depth, &voxels);
        assert_eq!(gpu.levels.len(), depth as usize);
        let mut checked = 0;
        for (d, &(start, end)) in gpu.levels.iter().enumerate() {
            // Same nodes, same subdivision.
            let nodes: std::collections::BTreeMap<[u32; 3], bool> = (start..end)
                .map(|n| (coords[n as usize], gpu.child[n as usize] != 0))
                .collect();
            assert_eq!(
                nodes.len() as u32,
                end - start,
                "duplicate nodes on level {d}"
            );
            assert_eq!(nodes, reference[d].nodes, "level {d} at {res}^3");
            for n in start..end {
                let c = coords[n as usize];
                // Neighbour links: present exactly when the neighbour exists.
                for a in 0..3 {
                    let mut cc = c;
                    cc[a] += 1;
                    let m = gpu.neighbours[n as usize][a];
                    if m == 0 {
                        assert!(
                            !reference[d].nodes.contains_key(&cc),
                            "missing link {c:?} -> {cc:?}"
                        );
                    } else {
                        assert_eq!(coords[m as usize], cc, "wrong link on level {d}");
                        assert!((start..end).contains(&m));
                        // Consistent brick borders: the shared face is bit-identical.
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
                            assert_eq!(gpu.node_brick(n)[ti(hi)], gpu.node_brick(m)[ti(lo)]);
                        }
                    }
                }
                // Brick texels equal the CPU lattice (leaf box filter and mip filter).
                for t in 0..27u32 {
                    let p = glam::IVec3::new(
                        (2 * c[0] + t % 3) as i32,
                        (2 * c[1] + (t / 3) % 3) as i32,
                        (2 * c[2] + t / 9) as i32,
                    );
                    let want = lattices[d].get(p);
                    let got = gpu.node_brick(n)[t as usize];
                    let err = (got - want).abs().max_element();
                    assert!(
                        err <= 3e-3 + 2e-3 * want.abs().max_element(),
                        "level {d} node {c:?} texel {t}: GPU {got} CPU {want} ({res}^3)"
                    );
                    checked += 1;
                }
            }
        }
        // Every texel of the 9 nodes at 4^3.
        assert!(checked >= if res == 4 { 9 * 27 } else { 1000 });
        // Only needed nodes carry bricks (at 8^3 every node is needed).
        assert!(
            res < 32 || svo.brick_count() < svo.node_count(),
            "{} bricks for {} nodes",
            svo.brick_count(),
            svo.node_count()
        );
        assert!(ctx
            .ledger
            .by_owner()
            .iter()
            .any(|(o, b)| o == "svo" && *b >= svo.bytes()));
    }
}

/// `tris` with HDR emission on every other triangle (values that round in fixed point and in
/// the RGB9E5 storage, one above the 9-bit range of the finest step).
fn with_emission(mut tris: Vec<VoxelTriangle>) -> Vec<VoxelTriangle> {
    for (i, t) in tris.iter_mut().enumerate().filter(|(i, _)| i % 2 == 0) {
        t.emission = Vec3::new(
            0.37 * i as f32,
            3.3,
            0.0123 * i as f32 + 700.0 * (i % 4) as f32,
        );
    }
    tris
}

#[test]
fn clipmap_update_rewrites_only_exposed_slabs_and_equals_rebuild() {
    use octolux::gpu::PassTimer;
    use octolux::voxel::clipmap::{Clipmap, ClipmapSettings};
    let ctx = context();
    let tris = with_emission(small_scene());
    let settings = ClipmapSettings {
        resolution: 16,
        levels: 3,
        voxel_size: 1.0 / 32.0,
    };
    let res = settings.resolution as i64;
    let start = Vec3::new(0.51, 0.49, 0.5);
    let mut clipmap = Clipmap::new(&ctx, settings).unwrap();
    let mut timer = PassTimer::new(&ctx);
    let boxes = clipmap.update(&ctx, &mut timer, &tris, start).unwrap();
    timer.finish_frame().unwrap();
    let full = (settings.levels as i64 * res * res * res) as u32;
    assert_eq!(boxes.len(), settings.levels as usize);
    assert_eq!(clipmap.voxels_written(&ctx).unwrap(), full);
    // Move by k = (3, -2, 1) finest voxels: level l moves by the change of floor(p / v_l).
    let moved = start + Vec3::new(3.0, -2.0, 1.0) * settings.voxel_size;
    let before: Vec<_> = clipmap.origins.clone();
    let boxes = clipmap.update(&ctx, &mut timer, &tris, moved).unwrap();
    timer.finish_frame().unwrap();
    let mut expected = 0i64;
    for (now, was) in clipmap.origins.iter().zip(&before) {
        let d = (now.unwrap() - was.unwrap()).abs();
        expected += res * res * res - (res - d.x as i64) * (res - d.y as i64) * (res - d.z as i64);
    }
    let written = (clipmap.voxels_written(&ctx).unwrap() - full) as i64;
    assert_eq!(written, expected, "voxels rewritten");
    assert_eq!(
        boxes.iter().map(|b| b.volume() as i64).sum::<i64>(),
        expected
    );
    assert!(expected > 0 && expected < full as i64 / 2);
    // The same as a clipmap built from scratch at the new position, bit for bit.
    let mut fresh = Clipmap::new(&ctx, settings).unwrap();
    fresh.update(&ctx, &mut timer, &tris, moved).unwrap();
    timer.finish_frame().unwrap();
    let (a, b) = (
        clipmap.read_voxels(&ctx).unwrap(),
        fresh.read_voxels(&ctx).unwrap(),
    );
    assert!(a.iter().filter(|&&v| v != 0).count() > 500);
    assert_eq!(a, b, "incremental clipmap differs from a rebuild");
    // And both equal the CPU reference voxelization of every level.
    let origins: Vec<_> = clipmap.origins.iter().map(|o| o.unwrap()).collect();
    let reference = cpu::clipmap_voxels(&settings, &origins, &tris);
    let wrong = a.iter().zip(&reference).filter(|(x, y)| x != y).count();
    assert_eq!(
        wrong, 0,
        "{wrong} clipmap voxels differ from the CPU reference"
    );
    // Emission: the exposed slabs were cleared and rewritten too.
    let emission = clipmap.read_emission(&ctx).unwrap();
    assert!(emission.iter().filter(|&&e| e != 0).count() > 200);
    assert_eq!(emission, fresh.read_emission(&ctx).unwrap());
    assert_eq!(
        emission,
        cpu::clipmap_emission(&settings, &origins, &tris),
        "emission differs from the CPU reference"
    );
    // A large jump rebuilds whole levels and still matches.
    let far = moved + Vec3::new(0.9, 0.0, -0.7);
    clipmap.update(&ctx, &mut timer, &tris, far).unwrap();
    let mut fresh = Clipmap::new(&ctx, settings).unwrap();
    fresh.update(&ctx, &mut timer, &tris, far).unwrap();
    timer.finish_frame().unwrap();
    assert_eq!(
        clipmap.read_voxels(&ctx).unwrap(),
        fresh.read_voxels(&ctx).unwrap()
    );
    assert_eq!(
        clipmap.read_emission(&ctx).unwrap(),
        fresh.read_emission(&ctx).unwrap()
    );
}

#[test]
fn gpu_sampling_matches_cpu_twins() {
    use glam::Vec4;
    use octolux::gpu::PassTimer;
    use octolux::voxel::clipmap::sample::{clip_sample, ClipInfo};
    use octolux::voxel::clipmap::{Clipmap, ClipmapSettings};
    use octolux::voxel::debug::{probe, Structure};
    use octolux::voxel::svo::sample::svo_sample;
    use octolux::voxel::svo::SvoBuilder;
    let ctx = context();
    let tris = small_scene();
    let grid = unit_grid(32);
    // A brick pool split over several buffers, so that sampling crosses buffers.
    let (whole, _) = SvoBuilder::new(&ctx).build(&ctx, &grid, &tris).unwrap();
    let (svo, _) = SvoBuilder::new(&ctx)
        .with_pool_limit(whole.brick_count().div_ceil(4))
        .build(&ctx, &grid, &tris)
        .unwrap();
    assert!(svo.brick_count() > 3 * svo.pool_bricks());
    let settings = ClipmapSettings {
        resolution: 16,
        levels: 3,
        voxel_size: 1.0 / 32.0,
    };
    let mut clipmap = Clipmap::new(&ctx, settings).unwrap();
    let mut timer = PassTimer::new(&ctx);
    clipmap
        .update(&ctx, &mut timer, &tris, Vec3::splat(0.45))
        .unwrap();
    timer.finish_frame().unwrap();
    let mut rng = Rng(777);
    let points: Vec<Vec4> = (0..400)
        .map(|i| {
            rng.vec(-0.05, 1.05)
                .extend([0.01, 1.0 / 32.0, 0.05, 0.1, 0.3][i % 5])
        })
        .collect();
    let svo_cpu = svo.read_back(&ctx).unwrap();
    let gpu = probe(&ctx, Structure::Svo(&svo), &points).unwrap();
    let mut nonzero = 0;
    for (p, g) in points.iter().zip(&gpu) {
        let c = svo_sample(&svo_cpu, &grid, p.truncate(), p.w);
        assert!(
            (*g - c).abs().max_element() < 1e-4,
            "octree at {p}: GPU {g} CPU {c}"
        );
        nonzero += (c.w > 0.0) as u32;
    }
    assert!(nonzero > 20, "only {nonzero} non-empty octree samples");
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let gpu = probe(&ctx, Structure::Clipmap(&clipmap), &points).unwrap();
    let mut nonzero = 0;
    for (p, g) in points.iter().zip(&gpu) {
        let c = clip_sample(&info, &voxels, p.truncate(), p.w);
        assert!(
            (*g - c).abs().max_element() < 1e-4,
            "clipmap at {p}: GPU {g} CPU {c}"
        );
        nonzero += (c.w > 0.0) as u32;
    }
    assert!(nonzero > 20, "only {nonzero} non-empty clipmap samples");
}

/// Memory and build time of the octree and the matching clipmap, printed as the table in
/// `docs/voxels.md`. By default the Cornell box at 64^3 (fast); for the documented table run
/// `VOXEL_TABLE=full cargo test --release -p octolux --test integration voxel::measure --
/// --nocapture` (64^3..512^3, Crytek Sponza too). Every row holds the octree below a third of the thesis's figure
/// (Fig. 43: 11.3 / 58.4 / 287 / 1320 MB at 64^3..512^3).
#[test]
fn measure_memory_and_build_time() {
    let full = std::env::var("VOXEL_TABLE").is_ok_and(|v| v == "full");
    use octolux::gpu::PassTimer;
    use octolux::voxel::clipmap::Clipmap;
    use octolux::voxel::debug::matching_clipmap;
    use octolux::voxel::svo::SvoBuilder;
    let ctx = context();
    println!("adapter: {}", ctx.describe());
    let builder = SvoBuilder::new(&ctx);
    let mut scenes = vec![octolux::scene::cornell::scene()];
    let sponza = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/crytek-sponza.toml"
    );
    if full {
        match octolux::scene::Scene::load(sponza) {
            Ok(scene) => scenes.push(scene),
            Err(e) => println!("Crytek Sponza skipped: {e}"),
        }
    }
    let resolutions: &[u32] = if full { &[64, 128, 256, 512] } else { &[64] };
    // Warm up (shader compilation happens at the first dispatch on some drivers).
    let warm = octolux::scene::cornell::scene();
    let warm_tris = octolux::voxel::scene_triangles(&warm, &warm.frame(0.0, 0));
    let warm_grid = VoxelGrid::enclosing(warm.bounds_at(0.0), 32).unwrap();
    builder.build(&ctx, &warm_grid, &warm_tris).unwrap();
    let mut warm_clip = Clipmap::new(&ctx, matching_clipmap(&warm_grid)).unwrap();
    let mut timer = PassTimer::new(&ctx);
    warm_clip
        .update(&ctx, &mut timer, &warm_tris, Vec3::ZERO)
        .unwrap();
    timer.finish_frame().unwrap();
    println!("| scene | N^3 | triangles | fragments | octree nodes | octree MB | octree build ms | clipmap | clipmap MB | clipmap build ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for scene in &scenes {
        let frame = scene.frame(0.0, 0);
        let tris = octolux::voxel::scene_triangles(scene, &frame);
        let bounds = scene.bounds_at(0.0);
        for &res in resolutions {
            let grid = VoxelGrid::enclosing(bounds, res).unwrap();
            let start = std::time::Instant::now();
            let (svo_cols, svo_ms) = match builder.build(&ctx, &grid, &tris) {
                Ok((svo, timings)) => {
                    let thesis_mb = match res {
                        64 => 11.3,
                        128 => 58.4,
                        256 => 287.0,
                        _ => 1320.0,
                    };
                    let mb = svo.bytes() as f64 / 1e6;
                    assert!(mb < thesis_mb / 3.0, "{res}^3 octree: {mb:.1} MB");
                    let gpu_ms: f64 = timings.iter().map(|t| t.ms).sum();
                    if std::env::var_os(octolux::gpu::PROFILE_STEPS_ENV).is_some() {
                        println!(
                            "octree build of {} at {res}^3:\n{}",
                            scene.name,
                            octolux::gpu::slowest_first(&timings)
                        );
                    }
                    (
                        format!(
                            "{} | {} | {:.1}",
                            svo.fragment_count(),
                            svo.node_count(),
                            svo.bytes() as f64 / 1e6
                        ),
                        format!(
                            "{gpu_ms:.1} ({:.0} wall)",
                            start.elapsed().as_secs_f64() * 1e3
                        ),
                    )
                }
                Err(e) => (format!("- | - | {e}"), "-".into()),
            };
            let settings = matching_clipmap(&grid);
            let mut clipmap = Clipmap::new(&ctx, settings).unwrap();
            let mut timer = PassTimer::new(&ctx);
            let start = std::time::Instant::now();
            clipmap
                .update(&ctx, &mut timer, &tris, (bounds.0 + bounds.1) * 0.5)
                .unwrap();
            let clip_gpu: f64 = timer.finish_frame().unwrap().iter().map(|t| t.ms).sum();
            let clip_wall = start.elapsed().as_secs_f64() * 1e3;
            println!(
                "| {} | {res} | {} | {svo_cols} | {svo_ms} | {} x {}^3 | {:.2} | {clip_gpu:.1} ({clip_wall:.0} wall) |",
                scene.name,
                tris.len(),
                settings.levels,
                settings.resolution,
                clipmap.bytes() as f64 / 1e6
            );
        }
    }
}

#[test]
fn clipmap_revoxelises_only_around_a_moving_object() {
    use octolux::gpu::PassTimer;
    use octolux::voxel::clipmap::{Clipmap, ClipmapSettings};
    let ctx = context();
    let settings = ClipmapSettings {
        resolution: 16,
        levels: 3,
        voxel_size: 1.0 / 32.0,
    };
    let still = small_scene();
    let object = |at: Vec3| {
        let mut tris = thin_box(at, at + Vec3::new(0.05, 0.13, 0.04), 0.04, [9, 9, 250]);
        for t in &mut tris {
            t.emission = Vec3::new(4.0, 2.5, 0.3);
        }
        tris
    };
    let (a, b) = (Vec3::new(0.31, 0.42, 0.37), Vec3::new(0.36, 0.47, 0.41));
    let bounds = |at: Vec3| (at - Vec3::splat(0.03), at + Vec3::new(0.08, 0.16, 0.07));
    let before: Vec<VoxelTriangle> = still.iter().copied().chain(object(a)).collect();
    let after: Vec<VoxelTriangle> = still.iter().copied().chain(object(b)).collect();
    let camera = Vec3::splat(0.45);
    let mut clipmap = Clipmap::new(&ctx, settings).unwrap();
    let mut timer = PassTimer::new(&ctx);
    clipmap.update(&ctx, &mut timer, &before, camera).unwrap();
    timer.finish_frame().unwrap();
    let full = clipmap.voxels_written(&ctx).unwrap();
    // The camera stays: nothing is exposed; the object's old and new regions are revoxelised.
    assert!(clipmap
        .update(&ctx, &mut timer, &after, camera)
        .unwrap()
        .is_empty());
    let (old_lo, old_hi) = bounds(a);
    let (new_lo, new_hi) = bounds(b);
    let mut boxes = clipmap.boxes_touching(old_lo, old_hi);
    boxes.extend(clipmap.boxes_touching(new_lo, new_hi));
    clipmap
        .revoxelise(&ctx, &mut timer, &after, &boxes)
        .unwrap();
    timer.finish_frame().unwrap();
    let written = clipmap.voxels_written(&ctx).unwrap() - full;
    assert_eq!(
        written as u64,
        boxes.iter().map(|b| b.volume()).sum::<u64>()
    );
    assert!(written < full / 10, "{written} of {full} voxels rewritten");
    let mut fresh = Clipmap::new(&ctx, settings).unwrap();
    fresh.update(&ctx, &mut timer, &after, camera).unwrap();
    timer.finish_frame().unwrap();
    let got = clipmap.read_voxels(&ctx).unwrap();
    let got_emission = clipmap.read_emission(&ctx).unwrap();
    let mut stale = Clipmap::new(&ctx, settings).unwrap();
    stale.update(&ctx, &mut timer, &before, camera).unwrap();
    timer.finish_frame().unwrap();
    assert_ne!(got, stale.read_voxels(&ctx).unwrap());
    assert_ne!(got_emission, stale.read_emission(&ctx).unwrap());
    assert_eq!(
        got,
        fresh.read_voxels(&ctx).unwrap(),
        "differs from a rebuild after the move"
    );
    assert_eq!(
        got_emission,
        fresh.read_emission(&ctx).unwrap(),
        "emission differs from a rebuild after the move"
    );
    assert!(got_emission.iter().any(|&e| e != 0));
}

#[test]
fn empty_input_gives_empty_structures() {
    use octolux::gpu::PassTimer;
    use octolux::voxel::clipmap::{Clipmap, ClipmapSettings};
    use octolux::voxel::svo::SvoBuilder;
    let ctx = context();
    // Nothing, and a triangle entirely outside the grid.
    let outside = vec![tri(
        Vec3::splat(3.0),
        Vec3::new(3.5, 3.0, 3.0),
        Vec3::new(3.0, 3.5, 3.0),
        [1, 1, 1],
    )];
    for tris in [Vec::new(), outside] {
        let (svo, _) = SvoBuilder::new(&ctx)
            .build(&ctx, &unit_grid(16), &tris)
            .unwrap();
        assert_eq!(
            (svo.fragment_count(), svo.node_count(), svo.brick_count()),
            (0, 1, 0)
        );
        let settings = ClipmapSettings {
            resolution: 8,
            levels: 2,
            voxel_size: 0.1,
        };
        let mut clipmap = Clipmap::new(&ctx, settings).unwrap();
        let mut timer = PassTimer::new(&ctx);
        clipmap.update(&ctx, &mut timer, &tris, Vec3::ZERO).unwrap();
        timer.finish_frame().unwrap();
        assert!(clipmap.read_voxels(&ctx).unwrap().iter().all(|&v| v == 0));
        assert!(clipmap.read_emission(&ctx).unwrap().iter().all(|&v| v == 0));
    }
}

#[test]
fn clipmap_light_injection_matches_analytic_irradiance_and_shadows() {
    let ctx = context();
    // A floor facing +y under a point light, and a small occluder (facing the light) between.
    let mut tris = lit_floor::floor();
    tris.extend(lit_floor::quad(0.5503, 0.35, 0.5, [255, 255, 255]));
    let light = lit_floor::light();
    let clipmap = lit_floor::lit_clipmap(&ctx, &tris);
    let settings = clipmap.settings;
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let radiance = clipmap.read_radiance(&ctx).unwrap();
    let r = settings.resolution as i32;
    let origin = clipmap.origins[0].unwrap();
    let at = |x: f32, z: f32| {
        // The level-0 floor voxel under (x, z).
        let g = glam::IVec3::new(
            (x * 32.0) as i32,
            (0.3003f32 * 32.0) as i32,
            (z * 32.0) as i32,
        );
        assert!(g.cmpge(origin).all() && g.cmplt(origin + r).all());
        let m = g.rem_euclid(glam::IVec3::splat(r));
        let slot = (m.x + r * (m.y + r * m.z)) as usize;
        let p = (g.as_vec3() + 0.5) / 32.0;
        (voxels[slot], radiance[slot], p)
    };
    let mut lit = 0;
    for (x, z) in [(0.75, 0.75), (0.62, 0.8), (0.8, 0.3), (0.3, 0.8)] {
        let (word, got, p) = at(x, z);
        let albedo = Vec3::new(
            (word & 255) as f32,
            ((word >> 8) & 255) as f32,
            ((word >> 16) & 255) as f32,
        ) / 255.0;
        let d = light.position - p;
        let want = albedo / std::f32::consts::PI * (d.normalize().y / d.length_squared());
        let err = ((got.truncate() - want).abs() / want).max_element();
        assert!(err < 0.01, "lit voxel at {p}: {got} vs {want}");
        assert_eq!(got.w, 1.0);
        lit += 1;
    }
    assert_eq!(lit, 4);
    // Filtered radiance through the sampling interface: GPU equals the CPU twin.
    let info = octolux::voxel::clipmap::sample::ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let mut rng = Rng(4242);
    let points: Vec<glam::Vec4> = (0..200)
        .map(|i| {
            let p = rng.vec(0.1, 0.9);
            Vec3::new(p.x, 0.25 + 0.1 * p.y, p.z).extend([0.03, 0.05, 0.08][i % 3])
        })
        .collect();
    let gpu = octolux::voxel::debug::probe(
        &ctx,
        octolux::voxel::debug::Structure::ClipmapRadiance(&clipmap),
        &points,
    )
    .unwrap();
    let mut nonzero = 0;
    for (q, g) in points.iter().zip(&gpu) {
        let c = octolux::voxel::clipmap::sample::clip_radiance_sample(
            &info,
            &radiance,
            q.truncate(),
            q.w,
        );
        assert!(
            (*g - c).abs().max_element() < 1e-3,
            "radiance at {q}: GPU {g} CPU {c}"
        );
        nonzero += (c.x > 0.0) as u32;
    }
    assert!(nonzero > 20);
    // Under the occluder (its shadow on the floor spans about 0.2..0.5 in x and z).
    for (x, z) in [(0.3, 0.3), (0.4, 0.35), (0.33, 0.45)] {
        let (_, got, p) = at(x, z);
        let d = light.position - p;
        let open = 0.8 / std::f32::consts::PI * (d.normalize().y / d.length_squared());
        assert!(
            got.x < 0.1 * open,
            "shadowed voxel at {p}: {got} (unshadowed about {open})"
        );
    }
}

#[test]
fn split_leaves_out_clear_triangles_per_object() {
    // An animated scene in which a static object's material is clear: the split must skip
    // that object's triangles without shifting the others (it once panicked on Crytek
    // Sponza, whose clear triangles made the filtered list shorter than the objects').
    use octolux::scene::{AlphaMode, Scene};
    use octolux::voxel::{scene_triangles, scene_triangles_split};
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let mut scene = Scene::load(path).unwrap();
    let frame = scene.frame(0.5, 0);
    let (still, moving) = scene_triangles_split(&scene, &frame);
    let moving_count = moving.len();
    assert!(moving_count > 0 && !still.is_empty());
    let first_static = scene
        .objects
        .iter()
        .position(|o| o.animation.is_none())
        .unwrap();
    let mesh = scene.objects[first_static].meshes[0] as usize;
    let material = scene.meshes[mesh].material as usize;
    // Give that mesh a material of its own, made clear.
    let mut clear = scene.materials[material].clone();
    clear.alpha_mode = AlphaMode::Mask(0.5);
    clear.opacity = 0.0;
    scene.materials.push(clear);
    scene.meshes[mesh].material = (scene.materials.len() - 1) as u32;
    let gone = scene.meshes[mesh].indices.len() / 3;
    let (still2, moving2) = scene_triangles_split(&scene, &frame);
    assert_eq!(
        moving2.len(),
        moving_count,
        "the animated object keeps its triangles"
    );
    assert_eq!(still2.len(), still.len() - gone);
    assert_eq!(
        still2.len() + moving2.len(),
        scene_triangles(&scene, &frame).len()
    );
    assert_eq!(moving2, moving);
}

#[test]
fn voxel_normals_face_the_side_the_vertex_normals_face() {
    use glam::Mat4;
    use octolux::scene::{Material, Mesh, Object, Scene};
    // A unit quad in y = 0 wound counter-clockwise seen from above (face normal +y).
    let quad = |name: &str, normal: Vec3| Mesh {
        name: name.into(),
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 0.0),
        ],
        normals: vec![normal; 4],
        uvs: Vec::new(),
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    };
    let object = |name: &str, mesh: u32, transform: Mat4| Object {
        name: name.into(),
        meshes: vec![mesh],
        transform,
        animation: None,
    };
    let scene = Scene {
        name: "normals".into(),
        meshes: vec![quad("agrees", Vec3::Y), quad("disagrees", Vec3::NEG_Y)],
        materials: vec![Material::default()],
        objects: vec![
            object("as wound", 0, Mat4::IDENTITY),
            object("normals down", 1, Mat4::IDENTITY),
            // Mirrored: the transform reverses the winding, not the normals.
            object("mirrored", 0, Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))),
        ],
        ..Scene::default()
    };
    let tris = octolux::voxel::scene_triangles(&scene, &scene.frame(0.0, 0));
    let normals: Vec<Vec3> = tris.iter().map(|t| t.normal).collect();
    assert_eq!(normals.len(), 6);
    for (i, want) in [Vec3::Y, Vec3::NEG_Y, Vec3::Y].iter().enumerate() {
        for n in &normals[2 * i..2 * i + 2] {
            assert!(n.abs_diff_eq(*want, 1e-6), "object {i}: {n} against {want}");
        }
    }
}
