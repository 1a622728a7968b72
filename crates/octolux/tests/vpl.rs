//! `vpl`: the octree walk against an independent voxel reference and its CPU twin, the VPLs'
//! flux against closed forms, the shading of one VPL against the closed-form geometry term,
//! and the Cornell box against the one-bounce reference. Bad settings are clear errors.

use crate::common::context;
use crate::floor_flux;

use glam::{IVec3, Vec3};
use octolux::gi::vpl::generate::{sample_cpu, Vpl};
use octolux::gi::vpl::{geometry_term, vpl_clamp, VplGi, VplSettings};
use octolux::gi::GiSettings;
use octolux::gpu::GpuContext;
use octolux::render::{RenderSettings, Renderer};
use octolux::voxel::svo::dynamic::DynamicReserve;
use octolux::voxel::svo::walk::{
    first_blocker_brute, segment_blocked_brute, SvoWalk, SvoWalkCpu, Tracer,
};
use octolux::voxel::svo::SvoBuilder;
use octolux::voxel::{VoxelGrid, VoxelTriangle};
use std::collections::BTreeSet;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) as u32
    }
}

/// Two triangles of the axis-aligned rectangle `lo..hi` (one extent zero).
fn quad(lo: Vec3, hi: Vec3) -> Vec<VoxelTriangle> {
    let d = hi - lo;
    let (u, v) = if d.x == 0.0 {
        (Vec3::new(0.0, d.y, 0.0), Vec3::new(0.0, 0.0, d.z))
    } else if d.y == 0.0 {
        (Vec3::new(d.x, 0.0, 0.0), Vec3::new(0.0, 0.0, d.z))
    } else {
        (Vec3::new(d.x, 0.0, 0.0), Vec3::new(0.0, d.y, 0.0))
    };
    let normal = u.cross(v).normalize();
    let tri = |positions| VoxelTriangle {
        positions,
        albedo: [200; 3],
        normal,
        emission: Vec3::ZERO,
    };
    vec![tri([lo, lo + u, lo + u + v]), tri([lo, lo + u + v, lo + v])]
}

#[test]
fn octree_walk_equals_the_voxel_reference_and_its_cpu_twin() {
    // A counting context: the GPU walks' work counts must equal the twin's, walk by walk
    // summed (integers, exact on every adapter).
    let ctx = context().with_work_counter();
    let builder = SvoBuilder::new(&ctx);
    let res = 32;
    let grid = VoxelGrid::new(Vec3::ZERO, 1.0, res).unwrap();
    let wall = |x: f32| quad(Vec3::new(x, 2.0, 2.0), Vec3::new(x, 30.0, 30.0));
    let mut holed = Vec::new();
    for (lo, hi) in [
        ((2.0, 2.0), (30.0, 12.0)),
        ((2.0, 20.0), (30.0, 30.0)),
        ((2.0, 12.0), (12.0, 20.0)),
        ((20.0, 12.0), (30.0, 20.0)),
    ] {
        holed.extend(quad(
            Vec3::new(15.5, lo.0, lo.1),
            Vec3::new(15.5, hi.0, hi.1),
        ));
    }
    let speck = cases_speck();
    let cases = [
        ("nearly empty", speck),
        ("one wall", wall(15.5)),
        ("wall on a voxel face", wall(16.0)),
        ("wall with a hole", holed),
    ];
    let tracer = Tracer::new(&ctx);
    let mut rng = Rng(7);
    for (name, tris) in cases {
        let (svo, _) = builder.build(&ctx, &grid, &tris).unwrap();
        let hits = compare_walks(&ctx, &tracer, &svo, &grid, &tris, &mut rng, name);
        if name == "nearly empty" {
            assert!(hits < 10, "{name}: {hits}");
        } else {
            assert!(hits > 100 && hits < 900, "{name}: {hits}");
        }
    }
    // The dynamic part: a wall moved through two poses is walked where it is now, together
    // with the static speck.
    let (mut svo, _) = builder
        .build_with_reserve(&ctx, &grid, &cases_speck(), DynamicReserve::new(20_000))
        .unwrap();
    for x in [9.5, 21.5] {
        builder.update_dynamic(&ctx, &mut svo, &wall(x)).unwrap();
    }
    svo.sync_dynamic(&ctx).unwrap();
    let mut all = cases_speck();
    all.extend(wall(21.5));
    let hits = compare_walks(&ctx, &tracer, &svo, &grid, &all, &mut rng, "moved wall");
    assert!(hits > 100 && hits < 900, "moved wall: {hits}");
    // Beside the speck the dynamic wall lies in static nodes that hold no static voxel but are
    // subdivided for the speck's bricks: the walk must descend into them by their dynamic
    // occupancy.
    builder.update_dynamic(&ctx, &mut svo, &wall(5.5)).unwrap();
    svo.sync_dynamic(&ctx).unwrap();
    let mut all = cases_speck();
    all.extend(wall(5.5));
    let hits = compare_walks(
        &ctx,
        &tracer,
        &svo,
        &grid,
        &all,
        &mut rng,
        "wall by the speck",
    );
    assert!(hits > 100 && hits < 900, "wall by the speck: {hits}");
}

#[test]
fn the_walk_skips_nodes_subdivided_only_for_their_neighbours_bricks() {
    // The octree subdivides the empty neighbours of occupied nodes (their bricks' lattice
    // needs them); the walk skips such a node's cell whole. Against a twin that descends into
    // every node with children (the walk before), every segment finds the same first voxel,
    // in fewer cells and nodes.
    let ctx = context();
    let builder = SvoBuilder::new(&ctx);
    let grid = VoxelGrid::new(Vec3::ZERO, 1.0, 32).unwrap();
    let mut tris = quad(Vec3::new(15.5, 2.0, 2.0), Vec3::new(15.5, 30.0, 30.0));
    tris.extend(quad(Vec3::new(2.0, 4.5, 2.0), Vec3::new(30.0, 4.5, 30.0)));
    let (svo, _) = builder.build(&ctx, &grid, &tris).unwrap();
    let params = SvoWalk::new(&svo, 1.75).unwrap();
    let walk = SvoWalkCpu::read(&ctx, &svo, params).unwrap();
    let subdivided_empty = (0..walk.child.len())
        .filter(|&n| walk.child[n] != 0 && !walk.occupied[n])
        .count();
    assert!(subdivided_empty > 0, "no empty node is subdivided");
    let mut every_node = walk.clone();
    every_node.occupied.iter_mut().for_each(|o| *o = true);
    let mut rng = Rng(11);
    let top = (1u32 << 14) - 1;
    let (mut before, mut after) = ([0u64; 2], [0u64; 2]);
    for _ in 0..2000 {
        let mut p = || {
            IVec3::new(
                (rng.next() % top) as i32 + 1,
                (rng.next() % top) as i32 + 1,
                (rng.next() % top) as i32 + 1,
            )
        };
        let (a, b) = (p(), p());
        let (hit, work) = walk.walk_counted(a, b);
        let (hit_before, work_before) = every_node.walk_counted(a, b);
        assert_eq!(hit, hit_before, "segment {a} -> {b}");
        assert!(work.cells <= work_before.cells, "segment {a} -> {b}");
        after[0] += work.cells as u64;
        after[1] += work.nodes as u64;
        before[0] += work_before.cells as u64;
        before[1] += work_before.nodes as u64;
    }
    println!("{subdivided_empty} empty nodes subdivided; cells {before:?} -> {after:?}");
    assert!(
        after[0] < before[0] && after[1] < before[1],
        "{before:?} -> {after:?}"
    );
}

fn cases_speck() -> Vec<VoxelTriangle> {
    vec![VoxelTriangle {
        positions: [
            Vec3::splat(1.2),
            Vec3::new(1.4, 1.2, 1.2),
            Vec3::new(1.2, 1.4, 1.2),
        ],
        albedo: [200; 3],
        normal: Vec3::Z,
        emission: Vec3::ZERO,
    }]
}

/// Traces 1000 segments (600 random, 400 grazing voxel faces, edges and corners) through
/// `svo` on the GPU and with the CPU twin, and checks both against the voxel reference over
/// `tris` voxelised on the CPU; returns how many are occluded.
fn compare_walks(
    ctx: &GpuContext,
    tracer: &Tracer,
    svo: &octolux::voxel::svo::Svo,
    grid: &VoxelGrid,
    tris: &[VoxelTriangle],
    rng: &mut Rng,
    name: &str,
) -> usize {
    let res = grid.resolution;
    let params = SvoWalk::new(svo, 1.75).unwrap();
    let cpu = SvoWalkCpu::read(ctx, svo, params).unwrap();
    let voxels: BTreeSet<[u32; 3]> = octolux::voxel::cpu::voxelize(grid, tris)
        .into_iter()
        .map(|(v, _)| v)
        .collect();
    let f = 1i32 << params.shift;
    let top = (1 << 14) - 1;
    let mut segments = Vec::new();
    for _ in 0..600 {
        let mut p = || {
            IVec3::new(
                (rng.next() % top as u32) as i32 + 1,
                (rng.next() % top as u32) as i32 + 1,
                (rng.next() % top as u32) as i32 + 1,
            )
        };
        segments.push((p(), p()));
    }
    // Grazing segments: ends on voxel faces, edges and corners, along faces, through
    // corners diagonally, and axis-parallel across the wall.
    for _ in 0..400 {
        let r: Vec<u32> = (0..10).map(|_| rng.next()).collect();
        let c = |k: usize, lo: u32| (lo + r[k] % (res - lo - 1)) as i32 * f;
        let (a, b) = match r[9] % 4 {
            0 => (
                IVec3::new(c(0, 1), c(1, 1), c(2, 1)),
                IVec3::new(c(3, 1), c(4, 1), c(5, 1)),
            ),
            1 => {
                let (y, z) = (c(0, 1), c(1, 1));
                (IVec3::new(c(2, 1), y, z), IVec3::new(c(3, 1), y, z))
            }
            2 => {
                let (x, y, z, k) = (c(0, 2), c(1, 2), c(2, 2), (r[3] % 12) as i32 * f);
                (
                    IVec3::new(x, y, z),
                    IVec3::new((x + k).min(top), (y + k).min(top), (z - k).max(f)),
                )
            }
            _ => {
                let (y, z) = (c(0, 1) + (r[1] % 3) as i32 * f / 2, c(2, 1));
                (IVec3::new(f, y, z), IVec3::new(30 * f, y, z))
            }
        };
        segments.push((a, b));
    }
    let gpu = tracer.trace(ctx, svo, &params, &segments).unwrap();
    let counted = ctx.work().expect("a counting context").take(ctx).unwrap();
    let mut work = [0u64; 2];
    let mut hits = 0;
    for (i, &(a, b)) in segments.iter().enumerate() {
        // The first blocking voxel (what a bounce ray hits), and so whether it is blocked.
        let (twin, steps) = cpu.walk_counted(a, b);
        work[0] += steps.cells as u64;
        work[1] += steps.nodes as u64;
        let reference = first_blocker_brute(&voxels, a, b, params.shift);
        assert_eq!(
            twin, reference,
            "{name}: segment {a} -> {b}: walk {twin:?}, voxel reference {reference:?}"
        );
        assert_eq!(
            cpu.occluded(a, b),
            segment_blocked_brute(&voxels, a, b, params.shift)
        );
        assert_eq!(gpu[i], twin, "{name}: segment {a} -> {b}: GPU differs");
        hits += twin.is_some() as usize;
    }
    let gpu_work: Vec<(String, u64)> = counted
        .into_iter()
        .filter(|c| c.pass == "walk test")
        .map(|c| (c.quantity, c.count))
        .collect();
    let twin_work = [
        ("cells".to_string(), work[0]),
        ("nodes".to_string(), work[1]),
    ];
    assert_eq!(gpu_work, twin_work, "{name}: work counts");
    println!(
        "{name}: {hits} of {} segments occluded; {} cells, {} nodes",
        segments.len(),
        work[0],
        work[1]
    );
    hits
}

fn vpl_of(r: &Renderer) -> &VplGi {
    r.technique()
        .as_any()
        .and_then(|a| a.downcast_ref::<VplGi>())
        .expect("the vpl technique")
}

fn settings(w: u32, h: u32, vpl: VplSettings) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        shadow_map_size: 256,
        gi: "vpl".into(),
        gi_settings: GiSettings {
            vpl,
            ..GiSettings::default()
        },
        ..RenderSettings::default()
    }
}

fn scene_of(
    quads: &[([Vec3; 4], Vec3)],
    light: octolux::scene::Light,
    camera: octolux::scene::Camera,
) -> octolux::scene::Scene {
    use octolux::scene::{Material, Mesh, Object, Scene};
    let meshes: Vec<Mesh> = quads
        .iter()
        .map(|(corners, n)| Mesh {
            name: "quad".into(),
            positions: corners.to_vec(),
            normals: vec![*n; 4],
            uvs: vec![glam::Vec2::ZERO; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
            material: 0,
        })
        .collect();
    Scene {
        name: "test".into(),
        objects: vec![Object {
            name: "quads".into(),
            meshes: (0..meshes.len() as u32).collect(),
            transform: glam::Mat4::IDENTITY,
            animation: None,
        }],
        meshes,
        materials: vec![Material {
            base_color: Vec3::splat(0.5),
            ..Material::default()
        }],
        textures: vec![],
        lights: vec![light],
        cameras: vec![camera],
        exposure: 0.0,
        sky: None,
        requests: vec![],
    }
}

fn floor(a: f32) -> ([Vec3; 4], Vec3) {
    (
        [
            Vec3::new(-a, 0.0, -a),
            Vec3::new(-a, 0.0, a),
            Vec3::new(a, 0.0, a),
            Vec3::new(a, 0.0, -a),
        ],
        Vec3::Y,
    )
}

fn floor_camera() -> octolux::scene::Camera {
    octolux::scene::Camera {
        position: Vec3::new(0.0, 2.0, 2.0),
        target: Vec3::ZERO,
        near: 0.05,
        far: 10.0,
        ..octolux::scene::Camera::default()
    }
}

#[test]
fn vpl_flux_sums_to_the_reflected_flux_for_every_light_type_and_count() {
    // Reflected flux off a Lambertian floor in closed form (`floor_flux`).
    // RSMs of 128^2 texels approximate the floor's outline to about a texel: within 1%.
    // The VPLs' mean flux is W / N each (exact up to f32 rounding: 1e-4), and they equal
    // the CPU twin's drawn from the same RSMs (same texels: positions within 1e-5 m).
    let ctx = context();
    let a = floor_flux::A;
    let cases = floor_flux::cases();
    for (name, light, expected) in cases {
        let scene = scene_of(&[floor(a)], light, floor_camera());
        for count in [1u32, 37, 512, 2048] {
            let vpl = VplSettings {
                count,
                rsm_size: 128,
                resolution: 32,
                ..VplSettings::default()
            };
            let mut r = Renderer::new(&ctx, &scene, settings(16, 16, vpl)).unwrap();
            r.render(&scene, 0.0).unwrap();
            let t = vpl_of(&r);
            let vpls = t.read_vpls(&ctx).unwrap();
            assert_eq!(vpls.len(), count as usize);
            let sum: Vec3 = vpls.iter().map(|v| v.flux).sum();
            println!("{name}, {count} VPLs: {sum} W, expected {expected:.5} W");
            for f in sum.to_array() {
                let rel = (f - expected).abs() / expected;
                assert!(rel < 0.01, "{name} {count}: {f} W, expected {expected} W");
            }
            let mean = sum.element_sum() / 3.0 / count as f32;
            for v in &vpls {
                let m = v.flux.element_sum() / 3.0;
                assert!(
                    (m - mean).abs() <= 1e-4 * mean,
                    "{name}: VPL mean flux {m} vs {mean}"
                );
            }
            let rsm = t.read_rsm(&ctx).unwrap();
            let twin: Vec<Vpl> = sample_cpu(&rsm, &t.half_layers(), count);
            // Same texel, same area (the texel's, times the same scale as the flux).
            let same = vpls
                .iter()
                .zip(&twin)
                .filter(|(g, c)| {
                    g.position.distance(c.position) < 1e-5
                        && (g.area - c.area).abs() <= 1e-4 * c.area
                })
                .count();
            assert!(
                same * 100 >= 99 * count as usize,
                "{name} {count}: only {same} VPLs equal the CPU twin's"
            );
            let twin_sum: Vec3 = twin.iter().map(|v| v.flux).sum();
            assert!((twin_sum - sum).abs().max_element() <= 1e-3 * expected);
            // The VPLs' areas sum to the lit area the RSMs see, as their fluxes to its flux:
            // in expectation, and closely where the texels' weights vary little (within 2 %
            // from 512 VPLs on). Not under the spot: its smooth edge's texels weigh little,
            // and the few VPLs drawn there stand for large areas (512 VPLs: 10 % short).
            let seen: f32 = rsm
                .iter()
                .flat_map(|i| i.position.iter().zip(&i.normal).zip(&i.flux))
                .filter(|(_, f)| f[0] + f[1] + f[2] > 0.0)
                .map(|((p, n), _)| p[3].max(0.0) * n[3].max(0.0))
                .sum();
            let areas: f32 = vpls.iter().map(|v| v.area).sum();
            println!("{name}, {count} VPLs: areas {areas} m^2, the RSMs see {seen} m^2");
            if count >= 512 && name != "spot" {
                assert!(
                    (areas - seen).abs() <= 0.02 * seen,
                    "{name} {count}: areas {areas} m^2, the RSMs see {seen} m^2"
                );
            }
        }
        // The light moving (by 0.1 mm, which changes the flux by about 1e-4): its layers are
        // drawn at half the side in their targets' corner, the rest holding the first frame's
        // whole-side texels, which must weigh nothing: the same 1 % and the same VPLs as the
        // twin's. At the default 256^2, so that the half side is 128^2 as above (at 64^2 the
        // point light's face seams cost 2.3 %, as in the LPV's injection test).
        use octolux::scene::{Keyframe, Track};
        let mut moving = scene.clone();
        let nudge = |time: f32, x: f32| Keyframe {
            time,
            translation: Vec3::new(x, 0.0, 0.0),
            rotation: glam::Quat::IDENTITY,
        };
        moving.lights[0].animation = Track::new(vec![nudge(0.0, 0.0), nudge(1.0, 1e-4)], false);
        let count = 512;
        let vpl = VplSettings {
            count,
            rsm_size: 256,
            resolution: 32,
            ..VplSettings::default()
        };
        let mut r = Renderer::new(&ctx, &moving, settings(16, 16, vpl)).unwrap();
        r.render(&moving, 0.0).unwrap();
        r.render(&moving, 1.0).unwrap();
        let t = vpl_of(&r);
        let half = t.half_layers();
        assert!(
            half.iter().all(|&h| h),
            "{name}: the moved light's layers at half: {half:?}"
        );
        let vpls = t.read_vpls(&ctx).unwrap();
        let sum: Vec3 = vpls.iter().map(|v| v.flux).sum();
        println!("{name}, moving: {sum} W, expected {expected:.5} W");
        for f in sum.to_array() {
            let rel = (f - expected).abs() / expected;
            assert!(rel < 0.01, "{name} moving: {f} W, expected {expected} W");
        }
        let twin = sample_cpu(&t.read_rsm(&ctx).unwrap(), &half, count);
        let same = vpls
            .iter()
            .zip(&twin)
            .filter(|(g, c)| g.position.distance(c.position) < 1e-5)
            .count();
        assert!(
            same * 100 >= 99 * count as usize,
            "{name} moving: only {same} VPLs equal the CPU twin's"
        );
    }
}

#[test]
fn one_vpl_over_a_plane_gives_the_closed_form_geometry_term() {
    // A 0.2 m tile 1 m above a floor, facing down, lit from below by a narrow spot light that
    // does not see the floor: with one VPL, no interleave and no merge, every floor pixel's
    // irradiance is Phi / pi x G (eq. 1-4, G with the clamp B or the VPL's disk) of that VPL, nothing occludes
    // the segments, and the tolerance is the f16 image's rounding (2^-10) plus the depth
    // buffer's position error (1e-3 relative).
    use octolux::scene::{Light, LightKind};
    let ctx = context();
    let s = 0.1;
    let tile = (
        [
            Vec3::new(-s, 1.0, -s),
            Vec3::new(s, 1.0, -s),
            Vec3::new(s, 1.0, s),
            Vec3::new(-s, 1.0, s),
        ],
        Vec3::NEG_Y,
    );
    let light = Light {
        name: "up".into(),
        kind: LightKind::Spot {
            inner_angle: 10f32.to_radians(),
            outer_angle: 15f32.to_radians(),
        },
        color: Vec3::ONE,
        intensity: 5.0,
        position: Vec3::new(0.0, 0.5, 0.0),
        direction: Vec3::Y,
        animation: None,
    };
    let scene = scene_of(&[floor(1.0), tile], light, floor_camera());
    // Sparse shading: the shaded pixels (one per f x f block) are the closed form as above;
    // every pixel is then a convex combination of the 2 x 2 shaded blocks around it, so it
    // lies between their closed-form values (the same tolerance).
    for sparse in [1, 2, 4] {
        let (w, h) = (32, 32);
        let OneVplFrame { v, b, g, view, e } = one_vpl_frame(&ctx, &scene, (w, h), sparse);
        assert!(v.flux.x > 0.0 && (v.position.y - 1.0).abs() < 1e-3, "{v:?}");
        // The closed form at pixel (x, y) where it sees the floor.
        let closed = |x: u32, y: u32| {
            let p = up_facing_point(&g, &view, (w, h), (x, y))?;
            (p.y.abs() <= 1e-2).then(|| {
                v.flux / std::f32::consts::PI
                    * geometry_term(p, Vec3::Y, v.position, v.normal, vpl_clamp(b * b, v.area))
            })
        };
        // The shaded pixel of block (bx, by), as `block_pixel` in frame/sparse.wgsl.
        let shaded = |bx: u32, by: u32| {
            let (bw, bh) = (w.div_ceil(sparse), h.div_ceil(sparse));
            let (bx, by) = (bx.min(bw - 1), by.min(bh - 1));
            (
                (bx * sparse + sparse / 2).min(w - 1),
                (by * sparse + sparse / 2).min(h - 1),
            )
        };
        let mut checked = 0;
        let mut error = 0.0;
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let Some(expected) = closed(x, y) else {
                    continue;
                };
                let g0 = |c: u32| ((c as f32 + 0.5) / sparse as f32 - 0.5).floor().max(0.0) as u32;
                let around: Vec<Vec3> = (0..4)
                    .filter_map(|k| {
                        let (sx, sy) = shaded(g0(x) + (k & 1), g0(y) + (k >> 1));
                        closed(sx, sy)
                    })
                    .collect();
                if around.len() < 4 {
                    continue; // near the floor's edge: a neighbour block sees the tile
                }
                let lo = around.iter().fold(Vec3::INFINITY, |a, &b| a.min(b));
                let hi = around.iter().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
                let tol = 2e-3 * hi.max_element() + 1e-6;
                assert!(
                    (e[i] - lo).min_element() >= -tol && (hi - e[i]).min_element() >= -tol,
                    "sparse {sparse}, pixel ({x}, {y}): {} outside the shaded blocks' {lo}..{hi}",
                    e[i]
                );
                error += ((e[i] - expected).abs() / expected.max(Vec3::splat(1e-9))).max_element();
                checked += 1;
            }
        }
        let mean = error / checked as f32;
        println!("sparse {sparse}: {checked} floor pixels, mean relative error {mean:.4}");
        assert!(checked > 150, "sparse {sparse}: {checked} floor pixels");
        // Every pixel shaded: the closed form. Reconstructed: between shaded blocks 2 and 4
        // pixels apart on a 32 x 32 image where the field falls by a few percent per pixel
        // (measured 0.05 and 0.06); a wrong weight or block would be far off.
        let bound = if sparse == 1 { 2e-3 } else { 0.1 };
        assert!(mean < bound, "sparse {sparse}: mean relative error {mean}");
    }
}

#[test]
fn a_vpl_next_to_a_receiver_lights_it_as_a_disk_of_its_area() {
    // A 0.4 m tile 0.1 m above the floor, facing down, lit from 4 cm below by a wide spot that
    // does not see the floor: one VPL stands for the whole lit tile. Its area is the tile's in
    // expectation over draws; this one draw, from a texel lit more weakly than the mean,
    // stands for 0.99 m^2, a disk of radius 0.56 m, far above the voxel clamp (6 cm). So on
    // the floor beneath it the squared distance is bounded by area / pi: those pixels must be
    // Phi / pi x G with that bound, which a point VPL would light several times brighter; the
    // tolerance is the closed-form test's.
    use octolux::scene::{Light, LightKind};
    let ctx = context();
    let (s, height) = (0.2, 0.1);
    let tile = (
        [
            Vec3::new(-s, height, -s),
            Vec3::new(s, height, -s),
            Vec3::new(s, height, s),
            Vec3::new(-s, height, s),
        ],
        Vec3::NEG_Y,
    );
    let light = Light {
        name: "up".into(),
        kind: LightKind::Spot {
            inner_angle: 82f32.to_radians(),
            outer_angle: 84f32.to_radians(),
        },
        color: Vec3::ONE,
        intensity: 5.0,
        position: Vec3::new(0.0, 0.06, 0.0),
        direction: Vec3::Y,
        animation: None,
    };
    let camera = octolux::scene::Camera {
        position: Vec3::new(0.0, 0.05, 0.9),
        target: Vec3::new(0.0, 0.0, 0.0),
        near: 0.02,
        far: 10.0,
        ..octolux::scene::Camera::default()
    };
    let scene = scene_of(&[floor(1.0), tile], light, camera);
    let (w, h) = (48, 32);
    let OneVplFrame { v, b, g, view, e } = one_vpl_frame(&ctx, &scene, (w, h), 1);
    assert!((v.position.y - height).abs() < 1e-3, "{v:?}");
    let disk = v.area / std::f32::consts::PI;
    assert!(disk > 4.0 * b * b, "area {} m^2, clamp {b} m", v.area);
    let (mut checked, mut bounded) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let Some(p) = up_facing_point(&g, &view, (w, h), (x, y)) else {
                continue;
            };
            if p.y.abs() > 1e-2 {
                continue;
            }
            let expected = v.flux / std::f32::consts::PI
                * geometry_term(p, Vec3::Y, v.position, v.normal, vpl_clamp(b * b, v.area));
            let tol = 2e-3 * expected.max_element() + 1e-6;
            assert!(
                (e[i] - expected).abs().max_element() <= tol,
                "pixel ({x}, {y}) at {p}: {} against {expected}",
                e[i]
            );
            checked += 1;
            bounded += (p.distance_squared(v.position) < disk) as usize;
        }
    }
    println!(
        "{checked} floor pixels, {bounded} within the VPL's disk (area {} m^2)",
        v.area
    );
    assert!(
        bounded >= 20 && checked > bounded,
        "{checked} pixels, {bounded} bounded"
    );
}

/// A frame shaded by one VPL alone (every pixel with it, no merge), for the closed-form tests.
struct OneVplFrame {
    /// The VPL.
    v: Vpl,
    /// The voxel clamp's distance (m).
    b: f32,
    g: octolux::render::GBufferImages,
    view: octolux::scene::CameraView,
    /// The indirect irradiance per pixel.
    e: Vec<Vec3>,
}

fn one_vpl_frame(
    ctx: &GpuContext,
    scene: &octolux::scene::Scene,
    (w, h): (u32, u32),
    sparse: u32,
) -> OneVplFrame {
    // Every ray traced: these frames check the geometry term, not the roulette.
    let vpl = VplSettings {
        count: 1,
        interleave: 1,
        roulette: 0.0,
        filter: false,
        rsm_size: 64,
        resolution: 64,
        sparse,
        ..VplSettings::default()
    };
    let mut r = Renderer::new(ctx, scene, settings(w, h, vpl.clone())).unwrap();
    r.render(scene, 0.0).unwrap();
    let t = vpl_of(&r);
    OneVplFrame {
        v: t.read_vpls(ctx).unwrap()[0],
        b: vpl.clamp * t.svo().grid().voxel_size,
        g: r.read_gbuffer().unwrap(),
        view: *r.last_view().unwrap(),
        e: irradiance(ctx, t.indirect_texture()),
    }
}

/// The world point pixel (x, y) of a w x h G-buffer sees where it sees a surface facing up
/// (the floors these tests shade), `None` elsewhere.
fn up_facing_point(
    g: &octolux::render::GBufferImages,
    view: &octolux::scene::CameraView,
    (w, h): (u32, u32),
    (x, y): (u32, u32),
) -> Option<Vec3> {
    let i = (y * w + x) as usize;
    if g.depth[i] >= 1.0 || g.normal[i].y < 0.9 {
        return None;
    }
    let ndc = Vec3::new(
        (x as f32 + 0.5) / w as f32 * 2.0 - 1.0,
        1.0 - (y as f32 + 0.5) / h as f32 * 2.0,
        g.depth[i],
    );
    Some(view.inv_view_proj.project_point3(ndc))
}

fn irradiance(ctx: &GpuContext, texture: &wgpu::Texture) -> Vec<Vec3> {
    let bytes = octolux::gpu::read_texture(ctx, texture, 0).unwrap();
    bytes
        .chunks_exact(8)
        .map(|c| {
            let f = |k: usize| octolux::gpu::pack::f16_to_f32(u16::from_le_bytes([c[k], c[k + 1]]));
            Vec3::new(f(0), f(2), f(4))
        })
        .collect()
}

#[test]
fn bad_settings_are_clear_errors() {
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    for (vpl, what) in [
        (
            VplSettings {
                count: 0,
                ..VplSettings::default()
            },
            "count",
        ),
        (
            VplSettings {
                resolution: 100,
                ..VplSettings::default()
            },
            "resolution",
        ),
        (
            VplSettings {
                rsm_size: 300,
                ..VplSettings::default()
            },
            "rsm_size",
        ),
        (
            VplSettings {
                clamp: f32::NAN,
                ..VplSettings::default()
            },
            "clamp",
        ),
        (
            VplSettings {
                bounces: 4,
                ..VplSettings::default()
            },
            "bounces",
        ),
        (
            VplSettings {
                roulette: f32::NAN,
                ..VplSettings::default()
            },
            "roulette",
        ),
    ] {
        let err = Renderer::new(&ctx, &scene, settings(8, 8, vpl))
            .err()
            .expect("an error")
            .to_string();
        assert!(err.contains(what), "{err}");
    }
    let table: toml::Table = toml::from_str("[vpl]\ncount = 512\nbogus = 1\n").unwrap();
    let err = GiSettings::from_table(&table, std::path::Path::new("x.toml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("bogus"), "{err}");
    let table: toml::Table = toml::from_str("[vpl]\ncount = 512\ninterleave = 2\n").unwrap();
    let s = GiSettings::from_table(&table, std::path::Path::new("x.toml")).unwrap();
    assert_eq!((s.vpl.count, s.vpl.interleave), (512, 2));
}

/// The reference path tracer's image of `scene` with `bounces` indirect bounces (256 spp).
fn reference(
    scene: &octolux::scene::Scene,
    size: u32,
    bounces: u32,
) -> octolux::image_io::HdrImage {
    let settings = octolux::reference::ReferenceSettings {
        spp: 256,
        bounces: octolux::transport::Bounces::Indirect(bounces),
        ..octolux::reference::ReferenceSettings::default()
    };
    octolux::reference::render(
        scene,
        &scene.frame(0.0, 0),
        size,
        size,
        &settings,
        &|_, _| {},
    )
    .unwrap()
    .total
}

fn mean_over(image: &octolux::image_io::HdrImage, mask: &[bool]) -> f32 {
    let (sum, n) = image
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .fold((0.0, 0), |(s, n), (p, _)| {
            (s + p.element_sum() / 3.0, n + 1)
        });
    sum / n.max(1) as f32
}

#[test]
fn cornell_box_against_the_one_bounce_reference() {
    // The ceiling, which the spot light does not reach, is lit within 25% of the reference,
    // and the image is closer to the one-bounce reference than no GI at all: relMSE under
    // 0.3 x and FLIP under 0.4 x GI off's (48 x 48, 256 spp; docs/vpl.md has the 160 x 90
    // table).
    use octolux::metrics::{flip, rel_mse, MetricOptions};
    use octolux::transport::Bounces;
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let size = 48;
    let mut images = Vec::new();
    let mut mask = Vec::new();
    for technique in ["none", "vpl"] {
        let mut s = settings(size, size, VplSettings::default());
        s.gi = technique.into();
        let mut r = Renderer::new(&ctx, &scene, s).unwrap();
        r.render(&scene, 0.0).unwrap();
        if technique == "vpl" {
            assert_eq!(
                r.technique().reference_transport().bounces,
                Bounces::Indirect(1)
            );
        }
        let g = r.read_gbuffer().unwrap();
        mask = g
            .normal
            .iter()
            .zip(&g.depth)
            .map(|(n, &d)| d < 1.0 && n.dot(Vec3::NEG_Y) > 0.9)
            .collect();
        images.push(r.read_hdr().unwrap());
    }
    let reference = reference(&scene, size, 1);
    let expected = mean_over(&reference, &mask);
    let got = mean_over(&images[1], &mask);
    println!("ceiling radiance: vpl {got}, reference {expected}");
    assert_eq!(
        mean_over(&images[0], &mask),
        0.0,
        "no direct light on the ceiling"
    );
    assert!(
        (0.75..1.25).contains(&(got / expected)),
        "ceiling: vpl {got}, reference {expected}"
    );
    let options = MetricOptions::default();
    let rel: Vec<f64> = images
        .iter()
        .map(|i| rel_mse(i, &reference, None).unwrap())
        .collect();
    let fl: Vec<f64> = images
        .iter()
        .map(|i| flip(i, &reference, None, &options).unwrap())
        .collect();
    println!(
        "relMSE none {:.4} vpl {:.4}; FLIP none {:.4} vpl {:.4}",
        rel[0], rel[1], fl[0], fl[1]
    );
    assert!(rel[1] < 0.3 * rel[0], "relMSE {rel:?}");
    assert!(fl[1] < 0.4 * fl[0], "FLIP {fl:?}");
}

#[test]
fn animated_scene_updates_the_octree_keeps_memory_constant_and_follows_the_light() {
    // A moving block (the octree's dynamic part, rebuilt every frame) and a moving light
    // (new VPLs every frame): after the first frame nothing is allocated, the octree update
    // runs as timed passes, and the indirect light changes.
    use octolux::scene::{Keyframe, Track};
    let ctx = context();
    let mut scene = octolux::scene::cornell::scene();
    let key = |time: f32, x: f32| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: glam::Quat::IDENTITY,
    };
    scene.lights[0].animation = Track::new(vec![key(0.0, -0.15), key(1.0, 0.15)], false);
    scene.objects[1].animation = Track::new(vec![key(0.0, 0.0), key(1.0, 0.1)], false);
    let vpl = VplSettings {
        count: 256,
        resolution: 64,
        ..VplSettings::default()
    };
    let mut r = Renderer::new(&ctx, &scene, settings(32, 32, vpl)).unwrap();
    let first = r.render(&scene, 0.0).unwrap();
    for pass in ["vpl rsm", "vpl generate", "vpl shade", "vpl merge"] {
        assert!(first.iter().any(|t| t.name == pass), "{pass} missing");
    }
    assert!(
        first.iter().any(|t| t.name.starts_with("vpl svo dyn")),
        "no octree update pass: {:?}",
        first.iter().map(|t| &t.name).collect::<Vec<_>>()
    );
    let memory = ctx.ledger.total();
    let e0 = irradiance(&ctx, vpl_of(&r).indirect_texture());
    let mut last = e0.clone();
    for t in [0.5, 1.0] {
        r.render(&scene, t).unwrap();
        assert_eq!(ctx.ledger.total(), memory, "allocation at t = {t}");
        last = irradiance(&ctx, vpl_of(&r).indirect_texture());
    }
    let change: f32 = e0
        .iter()
        .zip(&last)
        .map(|(a, b)| (*a - *b).abs().element_sum())
        .sum();
    let total: f32 = e0.iter().map(|p| p.element_sum()).sum();
    println!("indirect changed by {change} of {total}");
    assert!(change > 0.05 * total, "{change} of {total}");
}

#[test]
fn thin_wall_between_a_lit_and_a_dark_room_leaks_no_light() {
    // Two rooms side by side on a 2 x 1 m floor, parted at x = 0 by a wall of one quad (no
    // thickness). A spot light in the left room lights its far wall (x = -1), whose VPLs light
    // both floors in G; only the walk through the octree keeps them off the right floor. The
    // conservative voxelisation marks the wall in every voxel it touches and the walk steps
    // voxel by voxel in exact arithmetic, so no segment crosses it: the right floor's mean
    // irradiance, measured at 128^3 and 256^3 without the merge, must stay under 0.1% of the
    // left floor's. The camera sees the wall edge-on, so the floors meet in the image and the
    // merge (which sees one plane) carries light across over its 4 x 4 window: printed.
    use octolux::scene::{Light, LightKind};
    let ctx = context();
    let q = |a: Vec3, b: Vec3, c: Vec3, d: Vec3, n: Vec3| ([a, b, c, d], n);
    let quads = [
        q(
            Vec3::new(-1.0, 0.0, -0.5),
            Vec3::new(-1.0, 0.0, 0.5),
            Vec3::new(1.0, 0.0, 0.5),
            Vec3::new(1.0, 0.0, -0.5),
            Vec3::Y,
        ),
        q(
            Vec3::new(0.0, 0.0, -0.5),
            Vec3::new(0.0, 2.0, -0.5),
            Vec3::new(0.0, 2.0, 0.5),
            Vec3::new(0.0, 0.0, 0.5),
            Vec3::X,
        ),
        q(
            Vec3::new(-1.0, 0.0, -0.5),
            Vec3::new(-1.0, 2.0, -0.5),
            Vec3::new(-1.0, 2.0, 0.5),
            Vec3::new(-1.0, 0.0, 0.5),
            Vec3::X,
        ),
    ];
    let light = Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_angle: 20f32.to_radians(),
            outer_angle: 25f32.to_radians(),
        },
        color: Vec3::ONE,
        intensity: 10.0,
        position: Vec3::new(-0.3, 1.0, 0.0),
        direction: Vec3::new(-1.0, 0.0, 0.0),
        animation: None,
    };
    let camera = octolux::scene::Camera {
        position: Vec3::new(0.0, 3.0, 1.2),
        target: Vec3::ZERO,
        near: 0.05,
        far: 10.0,
        ..octolux::scene::Camera::default()
    };
    let scene = scene_of(&quads, light, camera);
    let (w, h) = (48, 48);
    for (resolution, filter) in [(128, false), (256, false), (128, true)] {
        let vpl = VplSettings {
            count: 512,
            resolution,
            filter,
            ..VplSettings::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings(w, h, vpl)).unwrap();
        r.render(&scene, 0.0).unwrap();
        let g = r.read_gbuffer().unwrap();
        let view = *r.last_view().unwrap();
        let e = irradiance(&ctx, vpl_of(&r).indirect_texture());
        let (mut lit, mut dark) = ((0.0f32, 0), (0.0f32, 0));
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let Some(p) = up_facing_point(&g, &view, (w, h), (x, y)) else {
                    continue;
                };
                let side = if p.x < -0.05 {
                    &mut lit
                } else if p.x > 0.05 {
                    &mut dark
                } else {
                    continue;
                };
                side.0 += e[i].element_sum() / 3.0;
                side.1 += 1;
            }
        }
        let (lit, dark) = (lit.0 / lit.1.max(1) as f32, dark.0 / dark.1.max(1) as f32);
        println!("{resolution}^3, merge {filter}: lit floor {lit} W/m^2, dark floor {dark} W/m^2");
        assert!(lit > 0.1, "{resolution}: the lit floor gets {lit} W/m^2");
        if !filter {
            assert!(dark <= 1e-3 * lit, "{resolution}: {dark} leaked of {lit}");
        }
    }
}

#[test]
fn second_bounce_vpls_bring_the_image_closer_to_the_two_bounce_reference() {
    // With `bounces` 2 every first-bounce VPL spawns one through the octree. Against the
    // two-bounce reference the image must be closer than with one bounce (relMSE and FLIP),
    // and the second bounce's VPLs must carry between 10% and 100% of the first's flux (the
    // walls' albedos are below 1, and most rays hit the box: energy shrinks but stays).
    use octolux::metrics::{flip, rel_mse, MetricOptions};
    use octolux::transport::Bounces;
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let size = 48;
    let reference = reference(&scene, size, 2);
    let mut errors = Vec::new();
    for bounces in [1, 2] {
        let vpl = VplSettings {
            bounces,
            ..VplSettings::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings(size, size, vpl)).unwrap();
        r.render(&scene, 0.0).unwrap();
        assert_eq!(
            r.technique().reference_transport().bounces,
            Bounces::Indirect(bounces)
        );
        let image = r.read_hdr().unwrap();
        let rel = rel_mse(&image, &reference, None).unwrap();
        let fl = flip(&image, &reference, None, &MetricOptions::default()).unwrap();
        println!("bounces {bounces}: relMSE {rel:.4} FLIP {fl:.4}");
        errors.push((rel, fl));
        if bounces == 2 {
            let vpls = vpl_of(&r).read_vpls(&ctx).unwrap();
            let (first, second) = vpls.split_at(1024);
            let sum = |v: &[Vpl]| v.iter().map(|v| v.flux.element_sum()).sum::<f32>();
            let hits = second.iter().filter(|v| v.flux.max_element() > 0.0).count();
            println!(
                "first bounce {} W, second {} W ({hits} of 1024 rays hit)",
                sum(first),
                sum(second)
            );
            // The box is open towards the camera: 889 of 1024 rays hit (measured).
            assert!(hits > 800, "{hits} of 1024 bounce rays hit the box");
            assert!(sum(second) > 0.1 * sum(first) && sum(second) < sum(first));
        }
    }
    assert!(errors[1].0 < errors[0].0, "relMSE {errors:?}");
    assert!(errors[1].1 < errors[0].1, "FLIP {errors:?}");
}

#[test]
fn russian_roulette_traces_fewer_rays_and_keeps_the_expected_irradiance() {
    // The Cornell box, every pixel shaded, no merge (each pixel its own estimate): with the
    // default roulette the pass traces fewer shadow rays, pixels change, and the mean difference
    // to the image without it is zero within 4 standard errors of the per-pixel differences
    // (the hash draws an independent number per pixel and VPL). Without the 1 / p weight of
    // the survivors the mean would fall by the share of the rouletted contributions, many
    // standard errors.
    let ctx = context().with_work_counter();
    let scene = octolux::scene::cornell::scene();
    let (w, h) = (64, 48);
    let frame = |roulette: f32| {
        let vpl = VplSettings {
            filter: false,
            sparse: 1,
            roulette,
            ..VplSettings::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings(w, h, vpl)).unwrap();
        ctx.work().unwrap().take(&ctx).unwrap();
        r.render(&scene, 0.0).unwrap();
        let rays = ctx
            .work()
            .unwrap()
            .take(&ctx)
            .unwrap()
            .iter()
            .find(|c| c.pass == "vpl shade" && c.quantity == "shadow rays")
            .map(|c| c.count)
            .expect("shadow rays counted");
        (rays, irradiance(&ctx, vpl_of(&r).indirect_texture()))
    };
    let (rays_all, all) = frame(0.0);
    let (rays, rouletted) = frame(VplSettings::default().roulette);
    println!("shadow rays {rays_all} -> {rays}");
    assert!(rays * 3 < rays_all * 2, "shadow rays {rays_all} -> {rays}");
    let d: Vec<f64> = all
        .iter()
        .zip(&rouletted)
        .map(|(a, b)| ((b.x + b.y + b.z) - (a.x + a.y + a.z)) as f64 / 3.0)
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let level = all
        .iter()
        .map(|a| (a.x + a.y + a.z) as f64 / 3.0)
        .sum::<f64>()
        / n;
    let changed = d.iter().filter(|x| x.abs() > 1e-3 * level).count();
    println!(
        "mean irradiance {level:.5}, difference {mean:.3e} (standard error {:.3e}), {changed} pixels changed",
        sd / n.sqrt()
    );
    assert!(
        changed * 4 > d.len(),
        "{changed} of {} pixels changed",
        d.len()
    );
    assert!(
        mean.abs() < 4.0 * sd / n.sqrt(),
        "mean difference {mean:.3e} against a standard error of {:.3e}",
        sd / n.sqrt()
    );
}
