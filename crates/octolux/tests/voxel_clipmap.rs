//! Clipmap level filtering, blending between levels by distance and anisotropic voxels, on
//! whatever adapter is present, against their CPU twins.

use crate::common::{context, tri, Rng};
use glam::{IVec3, Vec3, Vec4};
use octolux::gpu::{GpuContext, GpuOptions, PassTimer};
use octolux::voxel::clipmap::sample::ClipInfo;
use octolux::voxel::clipmap::sample::{
    blend_choice, clip_sample_aniso, clip_sample_blend, clip_sample_blend_with, probe_blend,
};
use octolux::voxel::clipmap::{
    decode_emission, injected_radiance, Clipmap, ClipmapOptions, ClipmapSettings,
};
use octolux::voxel::{cpu, VoxelTriangle};

/// Random triangles, most of them emissive.
fn scene() -> Vec<VoxelTriangle> {
    let mut rng = Rng(4242);
    (0..24)
        .map(|i| {
            let c = rng.vec(0.1, 0.9);
            let mut t = tri(
                c + rng.vec(-0.15, 0.15),
                c + rng.vec(-0.15, 0.15),
                c + rng.vec(-0.15, 0.15),
                [(i * 10) as u8, 255 - (i * 9) as u8, (40 + i * 7) as u8],
            );
            // Small values (stored exactly, so the rounding of the mean shows) and, on every
            // fifth triangle, large ones; every fourth emits nothing.
            let scale = if i % 5 == 0 { 300.0 } else { 1.0 };
            if i % 4 != 1 {
                t.emission = Vec3::new(
                    0.0137 * i as f32,
                    0.21 + 0.0071 * i as f32,
                    0.4 - 0.011 * i as f32,
                ) * scale;
            }
            t
        })
        .collect()
}

const SETTINGS: ClipmapSettings = ClipmapSettings {
    resolution: 16,
    levels: 3,
    voxel_size: 1.0 / 32.0,
};

fn build(ctx: &GpuContext, options: ClipmapOptions, tris: &[VoxelTriangle], at: Vec3) -> Clipmap {
    let mut c = Clipmap::with_options(ctx, SETTINGS, options).unwrap();
    let mut timer = PassTimer::new(ctx);
    c.update(ctx, &mut timer, tris, at).unwrap();
    timer.finish_frame().unwrap();
    c
}

fn origins(c: &Clipmap) -> Vec<IVec3> {
    c.origins.iter().map(|o| o.unwrap()).collect()
}

#[test]
fn filtered_levels_equal_cpu_twin_and_incremental_equals_rebuild() {
    let ctx = context();
    let tris = scene();
    let options = ClipmapOptions {
        filtered: true,
        anisotropic: true,
    };
    // An odd finest origin, so that the coarse voxels on the finer level's edge are only
    // partly covered and keep their own voxelization.
    let start = Vec3::new(0.51, 0.49, 0.47);
    let mut clipmap = build(&ctx, options, &tris, start);
    let check = |c: &Clipmap| {
        let o = origins(c);
        let mut reference = cpu::clipmap_voxels(&SETTINGS, &o, &tris);
        let unfiltered = reference.clone();
        cpu::clipmap_filter(&SETTINGS, &o, &mut reference);
        let got = c.read_voxels(&ctx).unwrap();
        let wrong = got.iter().zip(&reference).filter(|(a, b)| a != b).count();
        assert_eq!(wrong, 0, "{wrong} filtered voxels differ from the CPU twin");
        // Filtering changed something: fractional opacity exists on coarse levels.
        assert_ne!(reference, unfiltered);
        let n = 16 * 16 * 16;
        let fractional = got[n..]
            .iter()
            .filter(|&&w| (w >> 24) != 0 && (w >> 24) != 255)
            .count();
        assert!(fractional > 50, "{fractional} partly covered coarse voxels");
        let aniso = cpu::clipmap_aniso(&SETTINGS, &o, &reference);
        let got_aniso = c.read_aniso(&ctx).unwrap();
        assert_eq!(got_aniso.len(), aniso.len());
        let wrong = got_aniso.iter().zip(&aniso).filter(|(a, b)| a != b).count();
        assert_eq!(
            wrong, 0,
            "{wrong} directional values differ from the CPU twin"
        );
        let mut emission = cpu::clipmap_emission(&SETTINGS, &o, &tris);
        let unfiltered = emission.clone();
        cpu::clipmap_filter_emission(&SETTINGS, &o, &mut emission);
        assert_ne!(emission, unfiltered);
        let got = c.read_emission(&ctx).unwrap();
        let wrong = got.iter().zip(&emission).filter(|(a, b)| a != b).count();
        assert_eq!(
            wrong, 0,
            "{wrong} filtered emission words differ from the CPU twin"
        );
        assert!(got.iter().filter(|&&e| e != 0).count() > 100);
    };
    check(&clipmap);
    let mut timer = PassTimer::new(&ctx);
    for step in [
        Vec3::new(3.0, -2.0, 1.0),
        Vec3::new(-1.0, 5.0, 2.0),
        Vec3::new(11.0, 0.0, -9.0),
    ] {
        let at = start + step * SETTINGS.voxel_size;
        clipmap.update(&ctx, &mut timer, &tris, at).unwrap();
        timer.finish_frame().unwrap();
        let fresh = build(&ctx, options, &tris, at);
        assert_eq!(
            clipmap.read_voxels(&ctx).unwrap(),
            fresh.read_voxels(&ctx).unwrap(),
            "incremental filtered clipmap differs from a rebuild"
        );
        assert_eq!(
            clipmap.read_aniso(&ctx).unwrap(),
            fresh.read_aniso(&ctx).unwrap(),
            "incremental directional values differ from a rebuild"
        );
        check(&clipmap);
    }
    // A moving object: revoxelising its boxes keeps the filtered levels consistent.
    let mut moved = tris.clone();
    for t in moved.iter_mut().take(3) {
        for p in t.positions.iter_mut() {
            *p += Vec3::new(0.04, 0.01, -0.03);
        }
    }
    let mut boxes = Vec::new();
    for t in tris.iter().take(3).chain(moved.iter().take(3)) {
        let lo = t.positions[0].min(t.positions[1]).min(t.positions[2]);
        let hi = t.positions[0].max(t.positions[1]).max(t.positions[2]);
        boxes.extend(clipmap.boxes_touching(lo, hi));
    }
    clipmap
        .revoxelise(&ctx, &mut timer, &moved, &boxes)
        .unwrap();
    timer.finish_frame().unwrap();
    let at = start + Vec3::new(11.0, 0.0, -9.0) * SETTINGS.voxel_size;
    let fresh = build(&ctx, options, &moved, at);
    assert_eq!(
        clipmap.read_voxels(&ctx).unwrap(),
        fresh.read_voxels(&ctx).unwrap()
    );
    assert_eq!(
        clipmap.read_aniso(&ctx).unwrap(),
        fresh.read_aniso(&ctx).unwrap()
    );
    assert_eq!(
        clipmap.read_emission(&ctx).unwrap(),
        fresh.read_emission(&ctx).unwrap()
    );
    // Injection without lights: the radiance is the (coverage-weighted) emission, to f16
    // rounding (relative 2^-11), with the filtered opacity.
    clipmap.inject(&ctx, &mut timer, &[], 64).unwrap();
    timer.finish_frame().unwrap();
    let radiance = clipmap.read_radiance(&ctx).unwrap();
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let emission = clipmap.read_emission(&ctx).unwrap();
    for ((r, &v), &e) in radiance.iter().zip(&voxels).zip(&emission) {
        let want = decode_emission(e);
        let err = (r.truncate() - want).abs().max_element();
        assert!(err <= want.max_element() / 2048.0, "{r} vs {want}");
        let alpha = (v >> 24) as f32 / 255.0;
        assert!(
            (r.w - alpha).abs() <= alpha / 2048.0,
            "{r} vs opacity {alpha}"
        );
    }
    // The directional values cost 24 bytes per voxel of levels 1 and up, in the ledger.
    let bytes = clipmap.aniso.as_ref().unwrap().size();
    assert_eq!(bytes, 2 * 16 * 16 * 16 * 24);
    let plain = Clipmap::new(&ctx, SETTINGS).unwrap();
    assert_eq!(
        clipmap.bytes() - plain.bytes() - radiance.len() as u64 * 12,
        bytes
    );
    assert!(plain.aniso.is_none() && plain.read_aniso(&ctx).unwrap().is_empty());
}

#[test]
fn distance_blend_is_smooth_matches_gpu_and_reads_only_containing_levels() {
    let ctx = context();
    let tris = scene();
    let clipmap = build(
        &ctx,
        ClipmapOptions {
            filtered: true,
            anisotropic: false,
        },
        &tris,
        Vec3::splat(0.45),
    );
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let mut rng = Rng(99);
    let points: Vec<Vec4> = (0..500)
        .map(|i| {
            rng.vec(-0.1, 1.1)
                .extend([0.01, 1.0 / 32.0, 0.05, 1.0 / 16.0, 0.2][i % 5])
        })
        .collect();
    let gpu = probe_blend(&ctx, &clipmap, &points, None).unwrap();
    let mut nonzero = 0;
    let mut partial = 0;
    let o = origins(&clipmap);
    for (p, g) in points.iter().zip(&gpu) {
        let c = clip_sample_blend(&info, &voxels, p.truncate(), p.w);
        assert!(
            (*g - c).abs().max_element() < 1e-4,
            "at {p}: GPU {g} CPU {c}"
        );
        nonzero += (c.w > 0.0) as u32;
        if let Some((_, w)) = blend_choice(&info, p.truncate(), p.w) {
            partial += (w > 0.0 && w < 1.0) as u32;
        }
        // Every voxel read lies inside its level.
        clip_sample_blend_with(&info, p.truncate(), p.w, |l, g| {
            let lo = o[l as usize];
            assert!(
                g.cmpge(lo).all() && g.cmplt(lo + IVec3::splat(16)).all(),
                "level {l} read outside its extent at {g} for {p}"
            );
            Vec4::ONE
        });
    }
    assert!(nonzero > 50, "only {nonzero} non-empty samples");
    assert!(partial > 10, "only {partial} samples in a blend band");
    // Walking out of level 0 with a fine footprint: the weight of level 1 rises smoothly from
    // 0 to 1 and reaches 1 on the border, so the value is continuous where level 0 ends.
    let hi0 = (o[0].x + 16) as f32 * SETTINGS.voxel_size - 0.5 * SETTINGS.voxel_size;
    let mut last = 0.0f32;
    let mut x = hi0 - 4.0 * SETTINGS.voxel_size;
    while x < hi0 - 1e-4 {
        let p = Vec3::new(x, 0.45, 0.45);
        let (l, w) = blend_choice(&info, p, 0.001).unwrap();
        assert_eq!(l, 0);
        assert!(
            w >= last - 1e-6 && w - last < 0.2,
            "weight jumps to {w} at {x}"
        );
        last = w;
        x += 0.05 * SETTINGS.voxel_size;
    }
    assert!(last > 0.98, "weight {last} at the border");
    let inside = Vec3::new(hi0 - 0.501 * SETTINGS.voxel_size, 0.45, 0.45);
    let outside = inside + Vec3::X * 0.002 * SETTINGS.voxel_size;
    let a = clip_sample_blend(&info, &voxels, inside, 0.001);
    let b = clip_sample_blend(&info, &voxels, outside, 0.001);
    assert!(
        (a - b).abs().max_element() < 0.02,
        "{a} vs {b} across the border"
    );
}

/// A thin red wall in front of a green one, one finest voxel apart, inside one level-1 voxel.
fn walls() -> Vec<VoxelTriangle> {
    let v = SETTINGS.voxel_size;
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
fn anisotropic_voxels_keep_the_front_colour() {
    let ctx = context();
    let tris = walls();
    let clipmap = build(
        &ctx,
        ClipmapOptions {
            filtered: false,
            anisotropic: true,
        },
        &tris,
        Vec3::splat(0.5),
    );
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let aniso = clipmap.read_aniso(&ctx).unwrap();
    // The centre of level-1 voxel (8, 8, 8), which holds both walls; footprint = its size.
    let p = Vec3::splat(8.5 / 16.0);
    let f = 1.0 / 16.0;
    let red = Vec4::new(1.0, 0.0, 0.0, 1.0);
    let green = Vec4::new(0.0, 1.0, 0.0, 1.0);
    let dirs = [Vec3::X, Vec3::NEG_X, Vec3::new(1.0, 0.3, -0.2), Vec3::Y];
    let cpu: Vec<Vec4> = dirs
        .iter()
        .map(|&d| clip_sample_aniso(&info, &voxels, &aniso, p, f, d))
        .collect();
    let gpu = probe_blend(&ctx, &clipmap, &[p.extend(f); 4], Some(&dirs)).unwrap();
    for (g, c) in gpu.iter().zip(&cpu) {
        assert!((*g - *c).abs().max_element() < 1e-4, "GPU {g} CPU {c}");
    }
    assert!(
        (cpu[0] - red).abs().max_element() < 0.01,
        "from -x: {}",
        cpu[0]
    );
    assert!(
        (cpu[1] - green).abs().max_element() < 0.01,
        "from +x: {}",
        cpu[1]
    );
    // Mostly along +x: mostly red; along y the walls are side by side: half coverage each.
    assert!(cpu[2].x > 0.6 && cpu[2].y < 0.3, "oblique: {}", cpu[2]);
    assert!((cpu[3] - Vec4::new(0.5, 0.5, 0.0, 1.0)).abs().max_element() < 0.01);
    // The isotropic average mixes the two whichever side it is seen from.
    let iso = clip_sample_blend(&info, &voxels, p, f);
    assert!(
        (iso - Vec4::new(0.5, 0.5, 0.0, 1.0)).abs().max_element() < 0.01,
        "{iso}"
    );
}

fn quad(y: f32, lo: f32, hi: f32, albedo: [u8; 3], emission: Vec3) -> Vec<VoxelTriangle> {
    let (a, b) = (Vec3::new(lo, y, lo), Vec3::new(lo, y, hi));
    let (c, d) = (Vec3::new(hi, y, hi), Vec3::new(hi, y, lo));
    let mut tris = vec![tri(a, b, c, albedo), tri(a, c, d, albedo)];
    for t in &mut tris {
        t.emission = emission;
    }
    tris
}

/// Slots of `tris`' voxels in the clipmap at `origins` (per-level voxelization).
fn touched(o: &[IVec3], tris: &[VoxelTriangle]) -> Vec<bool> {
    cpu::clipmap_voxels(&SETTINGS, o, tris)
        .iter()
        .map(|&w| w != 0)
        .collect()
}

#[test]
fn emission_is_injected_as_the_mean_of_the_voxel_fragments() {
    let ctx = context();
    // An emissive quad, a non-emissive one, and inside one finest voxel (whose level-1 and
    // level-2 voxels hold nothing else) two triangles of different emission. Every value is a
    // multiple of 1/1024 below 512/1024 x 2^s with few bits, so fixed point, RGB9E5 and f16
    // hold it exactly: the radiance must equal it exactly.
    let glow = Vec3::new(2.0, 0.5, 1.25);
    let mut emissive = quad(0.4003, 0.2, 0.45, [200, 100, 50], glow);
    emissive[1].emission = glow; // both halves
    let plain = quad(0.7003, 0.55, 0.8, [255, 255, 255], Vec3::ZERO);
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // The pair keeps more than 3/32 voxel (above the voxelizer's 3/128 snapping margin) from the faces of
    // its voxel on every level: x, z in [0.600, 0.609], y in [0.516, 0.527].
    let m = |x: f32, y: f32, z: f32| {
        v(
            0.6 + (x - 0.6) * 0.45,
            0.516 + (y - 0.51) * 0.7,
            0.6 + (z - 0.6) * 0.45,
        )
    };
    let mut mix = vec![
        tri(
            m(0.60, 0.51, 0.60),
            m(0.615, 0.51, 0.60),
            m(0.60, 0.52, 0.615),
            [10, 20, 30],
        ),
        tri(
            m(0.60, 0.515, 0.605),
            m(0.62, 0.52, 0.61),
            m(0.61, 0.525, 0.62),
            [90, 90, 90],
        ),
    ];
    mix[0].emission = Vec3::new(3.0, 0.0, 1.0);
    mix[1].emission = Vec3::new(1.0, 2.0, 0.0);
    let mean = Vec3::new(2.0, 1.0, 0.5);
    // 80 tiny triangles of emission 60000 in one voxel: the 64-bit sums pass 2^32 (32-bit sums
    // would wrap after 69 fragments).
    let hot: Vec<VoxelTriangle> = (0..80)
        .map(|i| {
            let p = v(0.3, 0.6, 0.6) + Vec3::splat(0.0001 * i as f32);
            let mut t = tri(
                p,
                p + v(0.004, 0.0, 0.0),
                p + v(0.0, 0.004, 0.002),
                [1, 2, 3],
            );
            t.emission = Vec3::new(60000.0, 1.0, 0.0);
            t
        })
        .collect();
    let tris: Vec<VoxelTriangle> =
        [emissive.clone(), plain.clone(), mix.clone(), hot.clone()].concat();
    let mut clipmap = build(&ctx, ClipmapOptions::default(), &tris, Vec3::splat(0.5));
    let mut timer = PassTimer::new(&ctx);
    clipmap.inject(&ctx, &mut timer, &[], 64).unwrap();
    timer.finish_frame().unwrap();
    let o = origins(&clipmap);
    let emission = clipmap.read_emission(&ctx).unwrap();
    assert_eq!(
        emission,
        cpu::clipmap_emission(&SETTINGS, &o, &tris),
        "GPU emission differs from the CPU twin"
    );
    let radiance = clipmap.read_radiance(&ctx).unwrap();
    let (e, p, m, h) = (
        touched(&o, &emissive),
        touched(&o, &plain),
        touched(&o, &mix),
        touched(&o, &hot),
    );
    let mut counts = [0; 4];
    for (i, r) in radiance.iter().enumerate() {
        assert!(
            !(e[i] && (p[i] || m[i] || h[i])) && !(m[i] && h[i]),
            "scene overlaps at {i}"
        );
        if e[i] {
            assert_eq!(*r, glow.extend(1.0), "emissive quad voxel {i}");
            counts[0] += 1;
        } else if m[i] {
            assert_eq!(*r, mean.extend(1.0), "mixed voxel {i}");
            counts[1] += 1;
        } else if h[i] {
            // RGB9E5 keeps 9 bits under the exponent of the largest channel: 60000 becomes
            // 469 x 128 = 60032 (also exact in f16), and the green 1.0 rounds to 0.
            let want = Vec3::new(60000.0, 1.0, 0.0);
            let err = (r.truncate() - want).abs().max_element();
            assert!(err <= 60000.0 / 512.0 && r.w == 1.0, "hot voxel {i}: {r}");
            counts[2] += 1;
        } else if p[i] {
            assert_eq!(*r, Vec4::new(0.0, 0.0, 0.0, 1.0), "non-emissive voxel {i}");
            counts[3] += 1;
        } else {
            assert_eq!(*r, Vec4::ZERO, "empty voxel {i}");
        }
    }
    // The mixed pair lies in one voxel of each level; the quads cover many.
    assert_eq!(counts[1], 3);
    assert!(
        counts[0] > 60 && counts[3] > 50 && counts[2] >= 3,
        "{counts:?}"
    );
    // Memory: the emission buffer is 4 bytes per voxel slot, in the ledger under "clipmap".
    let slots = (SETTINGS.levels * SETTINGS.resolution.pow(3)) as u64;
    assert!(ctx
        .ledger
        .entries()
        .iter()
        .any(|e| e.owner == "clipmap" && e.name == "emission" && e.bytes == slots * 4));
    // Voxels, normals and emission 12 bytes per slot, radiance and facing 12 more.
    assert_eq!(clipmap.bytes(), slots * (12 + 12));
}

/// Moving objects through the clipmap's own scene: `replace_triangles` uploads only the
/// object's triangles and queues the boxes around its old and new bounds, the next `follow`
/// revoxelises them with the slabs the camera exposes (queued boxes clipped to the levels' new
/// extents), and the result equals a clipmap built from scratch with the moved scene at the
/// final camera position, filtered levels and directional values included.
#[test]
fn replaced_triangles_are_revoxelised_by_the_next_follow() {
    let ctx = context();
    let options = ClipmapOptions {
        filtered: true,
        anisotropic: true,
    };
    let mut tris = scene();
    // The object: 4 small emissive triangles, after the rest of the scene.
    let first = tris.len();
    let c = Vec3::new(0.52, 0.47, 0.5);
    let d = 0.03;
    for (k, albedo) in [[250, 20, 20], [20, 250, 20], [20, 20, 250], [200, 200, 0]]
        .into_iter()
        .enumerate()
    {
        let o = c + Vec3::new(k as f32 * 0.011, 0.0, -(k as f32) * 0.007);
        let mut t = tri(
            o,
            o + Vec3::new(d, 0.0, 0.0),
            o + Vec3::new(0.0, d, d),
            albedo,
        );
        t.emission = Vec3::new(0.5, 0.25 * k as f32, 0.125);
        tris.push(t);
    }
    let object = first..first + 4;
    let start = Vec3::new(0.51, 0.49, 0.47);
    let mut clipmap = Clipmap::with_options(&ctx, SETTINGS, options).unwrap();
    clipmap.set_scene(&ctx, &tris);
    let mut timer = PassTimer::new(&ctx);
    clipmap.follow(&ctx, &mut timer, start).unwrap();
    timer.finish_frame().unwrap();
    let full = clipmap.voxels_written(&ctx).unwrap();
    let mut at = start;
    // The object moves with the camera still, then with the camera moving, then far (its
    // new region lies partly outside the finest level).
    for (offset, step) in [
        (Vec3::new(0.05, 0.02, -0.03), Vec3::ZERO),
        (Vec3::new(-0.1, 0.04, 0.02), Vec3::new(2.0, -1.0, 1.0)),
        (Vec3::new(0.2, -0.15, 0.2), Vec3::new(-1.0, 0.0, 3.0)),
    ] {
        let moved: Vec<VoxelTriangle> = tris[object.clone()]
            .iter()
            .map(|t| {
                let mut t = *t;
                for p in &mut t.positions {
                    *p += offset;
                }
                t
            })
            .collect();
        let written = clipmap.voxels_written(&ctx).unwrap();
        let queued = clipmap.replace_triangles(&ctx, first, &moved).unwrap();
        assert!(!queued.is_empty());
        tris[object.clone()].copy_from_slice(&moved);
        assert_eq!(clipmap.scene(), &tris[..]);
        at += step * SETTINGS.voxel_size;
        clipmap.follow(&ctx, &mut timer, at).unwrap();
        timer.finish_frame().unwrap();
        // Only the object's 4 triangles were uploaded (their surface data) besides the scratch.
        let stats = clipmap.last_update_stats();
        assert!(stats.parts > 0 && stats.triangles_snapped > 0);
        let triangle = std::mem::size_of::<octolux::voxel::GpuTriangle>() as u64;
        let scratch = stats.upload_bytes - 4 * triangle;
        assert_eq!(scratch % 256, 0, "{stats:?}");
        // Far fewer voxels rewritten than a rebuild.
        let rewritten = clipmap.voxels_written(&ctx).unwrap() - written;
        assert!(
            rewritten > 0 && rewritten < full / 2,
            "{rewritten} of {full}"
        );
        let fresh = build(&ctx, options, &tris, at);
        assert_eq!(clipmap.origins, fresh.origins);
        assert_eq!(
            clipmap.read_voxels(&ctx).unwrap(),
            fresh.read_voxels(&ctx).unwrap(),
            "voxels differ from a rebuild after the object moved by {offset}"
        );
        assert_eq!(
            clipmap.read_aniso(&ctx).unwrap(),
            fresh.read_aniso(&ctx).unwrap()
        );
        assert_eq!(
            clipmap.read_emission(&ctx).unwrap(),
            fresh.read_emission(&ctx).unwrap()
        );
    }
    // Triangles the scene does not have are rejected, and nothing is queued.
    assert!(matches!(
        clipmap.replace_triangles(&ctx, first + 2, &tris[..3]),
        Err(octolux::Error::InvalidArgument(_))
    ));
    let written = clipmap.voxels_written(&ctx).unwrap();
    clipmap.follow(&ctx, &mut timer, at).unwrap();
    timer.finish_frame().unwrap();
    assert_eq!(clipmap.voxels_written(&ctx).unwrap(), written);
    assert_eq!(clipmap.last_update_stats().parts, 0);
}

#[test]
fn several_updates_recorded_into_one_frame_equal_a_rebuild() {
    // With GPU timestamps every pass of a frame goes into one command buffer, submitted at the
    // end (lavapipe has the feature, so this runs everywhere): three camera moves and a moving
    // object recorded into the same frame must not overwrite each other's uploads.
    let ctx = GpuContext::shared(&GpuOptions {
        timestamps: octolux::gpu::Timestamps::Always,
        ..GpuOptions::default()
    })
    .unwrap();
    let options = ClipmapOptions::default();
    let tris = scene();
    let start = Vec3::new(0.5, 0.5, 0.5);
    let mut clipmap = build(&ctx, options, &tris, start);
    let mut moved = tris.clone();
    for t in moved.iter_mut().take(3) {
        for p in t.positions.iter_mut() {
            *p += Vec3::new(0.03, -0.02, 0.01);
        }
    }
    let mut timer = PassTimer::new(&ctx);
    let mut at = start;
    for step in [
        Vec3::new(2.0, -1.0, 1.0),
        Vec3::new(-3.0, 4.0, 2.0),
        Vec3::new(5.0, 1.0, -4.0),
    ] {
        at += step * SETTINGS.voxel_size;
        clipmap.update(&ctx, &mut timer, &tris, at).unwrap();
    }
    clipmap.replace_triangles(&ctx, 0, &moved[..3]).unwrap();
    clipmap.follow(&ctx, &mut timer, at).unwrap();
    timer.finish_frame().unwrap();
    let fresh = build(&ctx, options, &moved, at);
    let (got, want) = (
        clipmap.read_voxels(&ctx).unwrap(),
        fresh.read_voxels(&ctx).unwrap(),
    );
    assert_eq!(got.len(), want.len());
    let wrong = got.iter().zip(&want).filter(|(a, b)| a != b).count();
    assert!(
        want.iter().filter(|&&v| v != 0).count() > 100,
        "the scene is voxelized"
    );
    assert_eq!(
        wrong, 0,
        "{wrong} voxels differ from a rebuild after updates in one frame"
    );
}

/// The f16 bits of `x`, a normal f16 value or zero (exact).
fn half(x: f32) -> u16 {
    if x == 0.0 {
        return 0;
    }
    let bits = x.to_bits();
    let h = ((((bits >> 23) & 255) as i32 - 112) << 10) as u32 | ((bits >> 13) & 1023);
    assert_eq!(
        octolux::gpu::pack::f16_to_f32(h as u16),
        x,
        "{x} is not an f16"
    );
    h as u16
}

/// Multiple bounces: with a bounce buffer set, the injection adds each slot's indirect
/// irradiance to its direct irradiance. Without lights the injected radiance is emission +
/// albedo / pi x bounce, which the CPU twin `injected_radiance` computes from the read-back
/// voxel, emission and bounce words; without the buffer it is the emission alone.
#[test]
fn bounce_irradiance_is_added_to_the_injected_radiance() {
    let ctx = context();
    let tris = scene();
    let mut clipmap = build(&ctx, ClipmapOptions::default(), &tris, Vec3::splat(0.5));
    let slots = (SETTINGS.levels * SETTINGS.resolution.pow(3)) as usize;
    // Irradiance k / 64 (k < 1024) per channel: exact in f16.
    let mut rng = Rng(77);
    let bounce: Vec<Vec3> = (0..slots)
        .map(|_| (rng.vec(0.0, 1.0) * 1023.0).floor() / 64.0)
        .collect();
    let words: Vec<u32> = bounce
        .iter()
        .flat_map(|b| {
            [
                half(b.x) as u32 | (half(b.y) as u32) << 16,
                half(b.z) as u32,
            ]
        })
        .collect();
    let buffer = ctx.create_buffer_init(
        "test",
        "bounce",
        bytemuck::cast_slice(&words),
        wgpu::BufferUsages::STORAGE,
    );
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let emission = clipmap.read_emission(&ctx).unwrap();
    for with_bounce in [false, true] {
        clipmap
            .set_bounce(with_bounce.then(|| buffer.clone()))
            .unwrap();
        let mut timer = PassTimer::new(&ctx);
        clipmap.inject(&ctx, &mut timer, &[], 64).unwrap();
        timer.finish_frame().unwrap();
        let radiance = clipmap.read_radiance(&ctx).unwrap();
        let mut lit = 0;
        for i in 0..slots {
            let e = if with_bounce { bounce[i] } else { Vec3::ZERO };
            let want = injected_radiance(voxels[i], emission[i], e);
            let got = radiance[i].truncate();
            // f16 output: half an ulp, 2^-11 relative (plus the smallest normal).
            let tol = want.abs().max_element() * 1e-3 + 1e-4;
            assert!(
                (got - want).abs().max_element() <= tol,
                "slot {i} (bounce {with_bounce}): GPU {got}, CPU twin {want}"
            );
            if with_bounce && voxels[i] >> 24 != 0 && e.max_element() > 0.5 {
                lit += 1;
            }
        }
        if with_bounce {
            assert!(lit > 100, "{lit} slots with bounce light");
        }
    }
    // A buffer smaller than the clipmap's slots is refused.
    let small = ctx.create_buffer_init("test", "small", &[0u8; 64], wgpu::BufferUsages::STORAGE);
    assert!(clipmap.set_bounce(Some(small)).is_err());
}

/// A wall thinner than a voxel (two opposite quads 4 mm apart, inside one column of level 0's
/// voxels) standing on a floor, and a point light on the wall's +x side: what
/// `thin_wall_clipmap` voxelises and lights.
fn thin_wall() -> (Vec<VoxelTriangle>, octolux::scene::Light) {
    let mut tris = crate::lit_floor::floor();
    let white = [230, 230, 230];
    for (x, facing_plus_x) in [(0.514f32, false), (0.518, true)] {
        let (a, b) = (Vec3::new(x, 0.31, 0.3), Vec3::new(x, 0.7, 0.3));
        let (c, d) = (Vec3::new(x, 0.7, 0.7), Vec3::new(x, 0.31, 0.7));
        let (quad_a, quad_b) = if facing_plus_x {
            ([a, b, c], [a, c, d])
        } else {
            ([a, c, b], [a, d, c])
        };
        tris.push(tri(quad_a[0], quad_a[1], quad_a[2], white));
        tris.push(tri(quad_b[0], quad_b[1], quad_b[2], white));
    }
    let mut light = crate::lit_floor::light();
    light.position = Vec3::new(0.85, 0.5, 0.5);
    (tris, light)
}

/// The clipmap of `crate::lit_floor` (2 levels of 32^3) holding [`thin_wall`], lit by its
/// light through voxel shadow rays.
fn thin_wall_clipmap(ctx: &GpuContext) -> (Clipmap, Vec3) {
    let (tris, light) = thin_wall();
    let mut clipmap = Clipmap::new(ctx, crate::lit_floor::SETTINGS).unwrap();
    let mut timer = PassTimer::new(ctx);
    clipmap
        .update(ctx, &mut timer, &tris, Vec3::splat(0.5))
        .unwrap();
    clipmap
        .inject(ctx, &mut timer, std::slice::from_ref(&light), 512)
        .unwrap();
    timer.finish_frame().unwrap();
    (clipmap, light.position)
}

/// Every occupied slot's facing equals the CPU twin `injected_facing`: the floor's voxels face
/// along their normal, the thin wall's (whose faces' normals cancel) towards the light. The
/// GPU packs the facing it computes in f32 into snorm8: 1 / 127 bounds the difference (the
/// rounding of one store, and of a component on a rounding boundary either way).
#[test]
fn injected_facing_points_where_the_radiance_leaves() {
    use octolux::voxel::clipmap::{injected_facing, unpack_facing};
    let ctx = context();
    let (clipmap, light) = thin_wall_clipmap(&ctx);
    let s = clipmap.settings;
    let res = s.resolution as i32;
    let voxels = clipmap.read_voxels(&ctx).unwrap();
    let normals = clipmap.read_normals(&ctx).unwrap();
    let emission = clipmap.read_emission(&ctx).unwrap();
    let radiance = clipmap.read_radiance(&ctx).unwrap();
    let facing = clipmap.read_facing(&ctx).unwrap();
    assert_eq!(facing.len(), voxels.len());
    let (mut with_normal, mut without, mut worst) = (0, 0, 0.0f32);
    for (l, origin) in origins(&clipmap).into_iter().enumerate() {
        let size = s.voxel_size * (1 << l) as f32;
        for z in 0..res {
            for y in 0..res {
                for x in 0..res {
                    let g = origin + IVec3::new(x, y, z);
                    let m = g.rem_euclid(IVec3::splat(res));
                    let i =
                        l * (res * res * res) as usize + (m.x + res * (m.y + res * m.z)) as usize;
                    if voxels[i] >> 24 == 0 || radiance[i].truncate().element_sum() <= 0.0 {
                        continue;
                    }
                    let to_light = (light - (g.as_vec3() + 0.5) * size).normalize();
                    // One light: the facing does not depend on how much of it arrives.
                    let lit = [(to_light, Vec3::ONE)];
                    let out = octolux::voxel::clipmap::injected_radiance(
                        voxels[i],
                        emission[i],
                        Vec3::ONE,
                    );
                    let want = injected_facing(voxels[i], normals[i], &lit, out);
                    worst = worst.max((facing[i] - want).abs().max_element());
                    if unpack_facing(normals[i]).length_squared() > 0.01 {
                        with_normal += 1;
                    } else {
                        without += 1;
                    }
                }
            }
        }
    }
    println!(
        "lit voxels with a normal {with_normal}, without {without}; facing differs from the \
         CPU twin by {worst:.2e}"
    );
    assert!(
        with_normal > 300 && without > 100,
        "{with_normal}, {without}"
    );
    assert!(
        worst <= 1.0 / 127.0,
        "the facing differs from the CPU twin by {worst}"
    );
}

/// The radiance and facing samples of the trace's sampler (`clip_radiance_facing_level`)
/// equal the CPU twin, and what they say a cone sees of the thin wall: from its lit side all
/// its light, from its far side next to none (`facing_toward`).
#[test]
fn facing_samples_equal_the_cpu_twin_and_hide_a_thin_walls_far_face() {
    use octolux::voxel::clipmap::sample::{
        clip_radiance_facing_level, CLIP_BINDINGS, CLIP_RADIANCE_BINDING,
    };
    use octolux::voxel::facing::facing_toward;
    let ctx = context();
    let (clipmap, _) = thin_wall_clipmap(&ctx);
    let radiance = clipmap.read_radiance(&ctx).unwrap();
    let facing = clipmap.read_facing(&ctx).unwrap();
    let info = ClipInfo::new(&clipmap.settings, &clipmap.origins);
    let kernel = "import octolux::voxel::clipmap::radiance_sample::clip_radiance_facing_level;
@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points) {
        return;
    }
    let q = points[id.x];
    let s = clip_radiance_facing_level(q.xyz, u32(q.w));
    out[2u * id.x] = s.radiance;
    out[2u * id.x + 1u] = vec4<f32>(s.facing, 0.0);
}
";
    // Points around the wall (x = 0.516) and over the floor, on both levels.
    let mut rng = Rng(77);
    let points: Vec<Vec4> = (0..400)
        .map(|i| {
            let p = rng.vec(0.0, 1.0);
            Vec3::new(0.4 + 0.25 * p.x, 0.28 + 0.45 * p.y, 0.25 + 0.5 * p.z).extend((i % 2) as f32)
        })
        .collect();
    let info_buffer = ctx.create_buffer_init(
        "test",
        "clip info",
        bytemuck::bytes_of(&info),
        wgpu::BufferUsages::STORAGE,
    );
    let bindings = vec![
        (CLIP_BINDINGS, info_buffer.as_entire_binding()),
        (
            CLIP_RADIANCE_BINDING,
            clipmap.radiance.as_ref().unwrap().as_entire_binding(),
        ),
    ];
    let gpu = crate::common::run_probe(&ctx, kernel, bindings, &points, 2);
    let (mut worst, mut lit) = (0.0f32, 0);
    for (q, g) in points.iter().zip(gpu.chunks_exact(2)) {
        let (r, f) =
            clip_radiance_facing_level(&info, &radiance, &facing, q.truncate(), q.w as u32);
        let scale = r.abs().max_element().max(f.abs().max_element()).max(1.0);
        worst = worst.max(
            (r - g[0])
                .abs()
                .max_element()
                .max((f - g[1].truncate()).abs().max_element())
                / scale,
        );
        lit += (r.truncate().element_sum() > 1e-3) as u32;
    }
    println!("facing samples: {lit} of 400 lit; GPU and CPU differ by {worst:.2e}");
    assert!(lit > 100, "only {lit} samples lit");
    // f32 sums of the same f16 and snorm8 values in the same order.
    assert!(worst < 1e-4, "GPU and CPU samples differ by {worst}");
    // The wall's voxels on level 0, at their centres (x = 16.5 voxels): seen from the far
    // side by a cone travelling +x, from the lit side by one travelling -x.
    let v = clipmap.settings.voxel_size;
    let (mut far_side, mut near_side, mut samples) = (0.0f32, 1.0f32, 0);
    for y in 12..21 {
        for z in 12..20 {
            let p = Vec3::new(16.5, y as f32 + 0.5, z as f32 + 0.5) * v;
            let (r, f) = clip_radiance_facing_level(&info, &radiance, &facing, p, 0);
            if r.truncate().element_sum() <= 1e-3 {
                continue;
            }
            samples += 1;
            far_side = far_side.max(facing_toward(r, f, Vec3::X));
            near_side = near_side.min(facing_toward(r, f, Vec3::NEG_X));
        }
    }
    println!("wall samples {samples}: far side sees at most {far_side:.3}, lit side at least {near_side:.3}");
    assert!(samples >= 40, "only {samples} lit wall samples");
    assert!(
        far_side < 0.1,
        "the far side sees {far_side} of the wall's light"
    );
    assert!(
        near_side > 0.99,
        "the lit side sees only {near_side} of the wall's light"
    );
}

/// `clip_thicken` (a coarse level's occupied fraction read as a medium's opacity) on the GPU
/// equals its CPU twin for opacities 0 to 1 and 0 to 6 levels above the surfaces' level, within
/// 1e-5 of the opacity (WGSL's `pow` is exp2(y log2 x), whose error the adapter bounds, against
/// Rust's `powf`); and a plane (occupied fraction 2^-k, k levels up) keeps between 1 - 1/e and
/// 3/4 of its opacity, where the filtered level alone kept 2^-k.
#[test]
fn thickened_coarse_samples_equal_the_cpu_twin() {
    use octolux::voxel::clipmap::sample::clip_thicken;
    let ctx = context();
    let kernel =
        "import octolux::voxel::clipmap::radiance_sample::{ClipRadianceFacing, clip_thicken};
@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x / 2u;
    if i >= arrayLength(&points) / 2u || id.x % 2u != 0u {
        return;
    }
    let f = points[2u * i + 1u];
    let s = clip_thicken(ClipRadianceFacing(points[2u * i], f.xyz), u32(f.w) + 3u, 3u);
    out[2u * i] = s.radiance;
    out[2u * i + 1u] = vec4<f32>(s.facing, 0.0);
}
";
    let mut points = Vec::new();
    for levels in 0..=6u32 {
        for step in 0..=40 {
            let a = step as f32 / 40.0;
            points.push(Vec4::new(0.3 * a, 0.5 * a, 0.2 * a, a));
            points.push(Vec4::new(0.1 * a, -0.2 * a, 0.4 * a, levels as f32));
        }
    }
    let gpu = crate::common::run_probe(&ctx, kernel, Vec::new(), &points, 1);
    let mut worst = 0.0f32;
    for (q, g) in points.chunks_exact(2).zip(gpu.chunks_exact(2)) {
        let (r, f) = clip_thicken(q[0], q[1].truncate(), q[1].w as u32);
        let scale = r.abs().max_element().max(1.0);
        worst = worst
            .max((r - g[0]).abs().max_element() / scale)
            .max((f - g[1].truncate()).abs().max_element() / scale);
        // Never thinner than the stored sample, never past opaque; the colour keeps its ratio.
        assert!(r.w >= q[0].w - 1e-6 && r.w <= 1.0 + 1e-6, "{q:?} -> {r}");
        if q[0].w > 0.0 {
            assert!((r.x / r.w - 0.3).abs() < 1e-5, "{q:?} -> {r}");
        }
    }
    println!("clip_thicken: GPU and CPU differ by {worst:.2e}");
    assert!(worst < 1e-5, "GPU and CPU differ by {worst}");
    for k in 1..=6u32 {
        let plane = 0.5f32.powi(k as i32);
        let (r, _) = clip_thicken(Vec4::new(0.0, 0.0, 0.0, plane), Vec3::ZERO, k);
        assert!(
            r.w >= 1.0 - (-1.0f32).exp() - 1e-6 && r.w <= 0.75 + 1e-6,
            "a plane {k} levels up: {}",
            r.w
        );
    }
}
