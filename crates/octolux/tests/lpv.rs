//! Light Propagation Volume tests on lavapipe-sized inputs: GPU kernels against the CPU
//! reference (`octolux::gi::lpv::sh`), energy conservation of propagation, the Cornell box
//! (colour bleeding, plausibility), animation (no per-frame allocation, light follows), and
//! printed measurements (octree error per iteration, pass-time ratios).

use crate::common::{context, Rng};
use crate::floor_flux;

use glam::{Quat, Vec3};
use octolux::gi::lpv::{kernels, sh};
use octolux::gi::GiSettings;
use octolux::gpu::{GpuContext, GpuOptions, PassTiming};
use octolux::image_io::HdrImage;
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{Keyframe, Track};

/// The LPV technique of a renderer set up with `lpv`, `clpv` or `olpv`.
fn lpv_of(r: &Renderer) -> &octolux::gi::LpvGi {
    r.technique()
        .as_any()
        .and_then(|t| t.downcast_ref::<octolux::gi::LpvGi>())
        .expect("an LPV-family renderer")
}

/// A volume with Lambertian emitters of positive flux in a fraction of the cells.
fn random_volume(n: usize, rng: &mut Rng, fill: f32) -> Vec<sh::Cell> {
    (0..n * n * n)
        .map(|_| {
            if rng.next() < fill {
                let normal = rng.unit();
                [0, 1, 2].map(|_| sh::lambertian_emitter(rng.next() + 0.1, normal))
            } else {
                [[0.0; 4]; 3]
            }
        })
        .collect()
}

fn max_abs(v: &[sh::Cell]) -> f32 {
    v.iter()
        .flatten()
        .flatten()
        .fold(0.0f32, |m, x| m.max(x.abs()))
}

/// Largest element-wise difference relative to the largest magnitude of `b`.
fn rel_diff(a: &[sh::Cell], b: &[sh::Cell]) -> f32 {
    assert_eq!(a.len(), b.len());
    let d = a
        .iter()
        .flatten()
        .flatten()
        .zip(b.iter().flatten().flatten())
        .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    d / max_abs(b).max(1e-30)
}

#[test]
fn gpu_propagation_step_matches_cpu() {
    // f32 sums of ~30 terms in a different order: agreement to 1e-5 of the largest value.
    let ctx = context();
    let n = 8;
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let input = random_volume(n, &mut rng, 0.3);
    let m = n + 1;
    let gv: Vec<sh::Sh> = (0..m * m * m)
        .map(|_| {
            if rng.next() < 0.3 {
                sh::lobe(rng.unit()).map(|c| c * rng.next())
            } else {
                [0.0; 4]
            }
        })
        .collect();
    let default = GiSettings::default().lpv.directional;
    for (occluded, directional) in [(false, 0.0), (true, 0.0), (false, 1.0), (true, default)] {
        let g = occluded.then_some(gv.as_slice());
        let one = kernels::propagate(&ctx, n as u32, &input, g, 1, directional).unwrap();
        let cpu = sh::propagate_step(&input, n, g, directional);
        let err = rel_diff(&one.last, &cpu);
        assert!(
            err < 1e-5,
            "occluded {occluded}, directional {directional}: step differs by {err}"
        );
        // Two steps and the accumulation buffer (input + step 1 + step 2).
        let two = kernels::propagate(&ctx, n as u32, &input, g, 2, directional).unwrap();
        let cpu2 = sh::propagate_step(&cpu, n, g, directional);
        assert!(rel_diff(&two.last, &cpu2) < 1e-5);
        let acc: Vec<sh::Cell> = (0..input.len())
            .map(|i| {
                let mut c = input[i];
                for ch in 0..3 {
                    for k in 0..4 {
                        c[ch][k] += cpu[i][ch][k] + cpu2[i][ch][k];
                    }
                }
                c
            })
            .collect();
        assert!(rel_diff(&two.accumulated, &acc) < 1e-5);
    }
}

#[test]
fn open_volume_propagation_conserves_energy() {
    // The 30 face solid angles of the six neighbours sum to 4 pi (6 x 2 pi / 3), band 1
    // cancels by symmetry and the re-emitted lobe carries exactly the face flux, so
    //   flux(remaining after t steps) + sum of boundary outflow(before each step) = injected
    // holds exactly up to f32 rounding (the constants' 1e-10 relative error is far below it).
    // Tolerance: 1e-5 relative.
    // Checked for both re-emissions (Lambertian about the face, beam along the crossing
    // direction) and the default mix: all carry the face flux in band 0.
    let ctx = context();
    let n = 8;
    let default = GiSettings::default().lpv.directional;
    for directional in [0.0, 1.0, default] {
        conserves_energy(&ctx, n, directional);
    }
}

fn conserves_energy(ctx: &GpuContext, n: usize, directional: f32) {
    let mut rng = Rng(12345);
    let input = random_volume(n, &mut rng, 0.2);
    let injected = sh::total_flux(&input);
    let mut outflow = [0.0f64; 3];
    let mut previous = input.clone();
    for steps in 1..=10 {
        let run = kernels::propagate(ctx, n as u32, &input, None, steps, directional).unwrap();
        let out = sh::boundary_outflow(&previous, n);
        for ch in 0..3 {
            outflow[ch] += out[ch];
        }
        let remaining = sh::total_flux(&run.last);
        for ch in 0..3 {
            let balance = remaining[ch] + outflow[ch];
            assert!(
                (balance - injected[ch]).abs() < 1e-5 * injected[ch],
                "directional {directional}, step {steps} channel {ch}: remaining {} + left {} != injected {}",
                remaining[ch],
                outflow[ch],
                injected[ch]
            );
        }
        previous = run.last;
    }
    assert!(
        outflow[0] > 0.5 * injected[0],
        "most light has left after 10 steps"
    );
}

fn occupancy_of(gv: &[sh::Sh], n: usize) -> Vec<bool> {
    let m = n + 1;
    let mut occ = vec![false; n * n * n];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                occ[sh::index(n, x, y, z)] = (0..8).any(|k| {
                    let (a, b, c) = (x + (k & 1), y + ((k >> 1) & 1), z + (k >> 2));
                    gv[a + m * (b + m * c)][0] > 1e-6
                });
            }
        }
    }
    occ
}

#[test]
fn octree_downsample_index_and_merge_match_cpu() {
    let ctx = context();
    let n = 8usize;
    let mut rng = Rng(777);
    let level0 = random_volume(n, &mut rng, 0.15);
    let m = n + 1;
    let mut gv = vec![[0.0f32; 4]; m * m * m];
    // A wall at corner plane x = 2 and a few scattered surfels.
    for z in 0..m {
        for y in 0..m {
            gv[2 + m * (y + m * z)] = sh::lobe(Vec3::X);
        }
    }
    gv[7 + m * (7 + m * 8)] = sh::lobe(Vec3::Y).map(|c| c * 0.5);
    let directional = GiSettings::default().lpv.directional;
    let run = kernels::octree(&ctx, n as u32, &level0, &gv, 3, directional).unwrap();
    // Downsample (eq. 2).
    let mut cpu_levels = vec![level0.clone()];
    for i in 1..4 {
        let next = sh::downsample(&cpu_levels[i - 1], n >> (i - 1));
        cpu_levels.push(next);
    }
    for (i, (gpu, cpu)) in run.injected.iter().zip(&cpu_levels).enumerate() {
        assert!(rel_diff(gpu, cpu) < 1e-6, "level {i} downsample");
    }
    // Index volume levels (exact integers).
    let cpu_index = sh::index_levels(&occupancy_of(&gv, n), n);
    assert_eq!(run.index, cpu_index);
    assert!(run.index[0].contains(&0) && run.index[0].contains(&3));
    // Per-level propagation (3 steps, unoccluded) and merge.
    let mut cpu_acc = Vec::new();
    for (i, level) in cpu_levels.iter().enumerate() {
        let side = n >> i;
        let mut state = level.clone();
        let mut acc = level.clone();
        for _ in 0..3 {
            state = sh::propagate_step(&state, side, None, directional);
            for (a, s) in acc.iter_mut().zip(&state) {
                for ch in 0..3 {
                    for k in 0..4 {
                        a[ch][k] += s[ch][k];
                    }
                }
            }
        }
        assert!(rel_diff(&run.accumulated[i], &acc) < 1e-5, "level {i}");
        cpu_acc.push(acc);
    }
    let merged = sh::merge(&run.accumulated, &cpu_index, n);
    assert!(rel_diff(&run.merged, &merged) < 1e-6);
}

fn lpv_settings(technique: &str, w: u32, h: u32) -> RenderSettings {
    let mut gi = GiSettings::default();
    gi.lpv.size = 16;
    gi.lpv.iterations = 12;
    gi.lpv.rsm_size = 64;
    gi.lpv.rsm_stride = 2;
    gi.clpv.size = 16;
    gi.clpv.iterations = 8;
    gi.olpv.size = 16;
    RenderSettings {
        width: w,
        height: h,
        shadow_map_size: 256,
        gi: technique.into(),
        gi_settings: gi,
        ..RenderSettings::default()
    }
}

/// Indirect irradiance recovered from the composed image: hdr = direct + albedo/pi E.
fn indirect(renderer: &Renderer) -> (HdrImage, Vec<Vec3>, Vec<Vec3>) {
    let hdr = renderer.read_hdr().unwrap();
    let direct = renderer.read_direct().unwrap();
    let g = renderer.read_gbuffer().unwrap();
    let mut e = hdr.clone();
    for (i, p) in e.pixels.iter_mut().enumerate() {
        let a = g.albedo[i];
        let d = hdr.pixels[i] - direct.pixels[i];
        *p = Vec3::new(
            if a.x > 0.02 {
                d.x * std::f32::consts::PI / a.x
            } else {
                0.0
            },
            if a.y > 0.02 {
                d.y * std::f32::consts::PI / a.y
            } else {
                0.0
            },
            if a.z > 0.02 {
                d.z * std::f32::consts::PI / a.z
            } else {
                0.0
            },
        );
    }
    (e, g.albedo, g.normal)
}

#[test]
fn cornell_box_lpv_family_bleeds_colour_and_changes_the_image() {
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let (w, h) = (32, 32);
    let mut none = Renderer::new(&ctx, &scene, lpv_settings("none", w, h)).unwrap();
    none.render(&scene, 0.0).unwrap();
    let base = none.read_hdr().unwrap();
    for technique in ["lpv", "clpv", "olpv"] {
        let mut r = Renderer::new(&ctx, &scene, lpv_settings(technique, w, h)).unwrap();
        r.render(&scene, 0.0).unwrap();
        let (e, albedo, normal) = indirect(&r);
        // The whole image differs from no GI, by more than f16 noise.
        let changed = e.pixels.iter().filter(|p| p.max_element() > 1e-3).count();
        assert!(
            changed > 300,
            "{technique}: only {changed} pixels got indirect light"
        );
        let hdr = r.read_hdr().unwrap();
        let diff: f32 = hdr
            .pixels
            .iter()
            .zip(&base.pixels)
            .map(|(a, b)| (*a - *b).abs().element_sum())
            .sum();
        assert!(
            diff > 20.0,
            "{technique}: image barely differs from none ({diff})"
        );
        println!("{technique}: {changed} of 1024 pixels lit indirectly, |hdr - none| = {diff}");
        let (mut floor, mut red, mut green) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        let (mut white_left, mut white_right) = (Vec3::ZERO, Vec3::ZERO);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let p = e.pixels[i];
                // f16 storage of small differences: allow a hair below zero.
                assert!(
                    p.is_finite() && p.min_element() > -1e-3,
                    "{technique}: {p} at {x},{y}"
                );
                let (a, n) = (albedo[i], normal[i]);
                let white = a.min_element() > 0.5;
                if white && n.y > 0.9 {
                    floor += p;
                }
                if a.x > 2.0 * a.y {
                    red += p;
                }
                if a.y > 2.0 * a.x {
                    green += p;
                }
                // White surfaces (floor, back wall, blocks) near the red (left) and green
                // (right) walls.
                if white && x < w / 4 {
                    white_left += p;
                }
                if white && x >= w - w / 4 {
                    white_right += p;
                }
            }
        }
        for (name, v) in [("floor", floor), ("red wall", red), ("green wall", green)] {
            assert!(
                v.min_element() > 0.0,
                "{technique}: no indirect light on the {name}"
            );
        }
        assert!(
            white_left.x > white_left.y,
            "{technique}: the red wall tints its neighbourhood: {white_left}"
        );
        assert!(
            white_right.y > white_right.x,
            "{technique}: the green wall tints its neighbourhood: {white_right}"
        );
        println!("{technique}: floor {floor}, near red {white_left}, near green {white_right}");
    }
}

fn technique_ms(timings: &[PassTiming], prefixes: &[&str]) -> f64 {
    timings
        .iter()
        .filter(|t| prefixes.iter().any(|p| t.name.starts_with(p)))
        .map(|t| t.ms)
        .sum()
}

#[test]
fn animated_scene_keeps_memory_constant_and_follows_the_light() {
    let ctx = context();
    let mut scene = octolux::scene::cornell::scene();
    let key = |time: f32, x: f32| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: Quat::IDENTITY,
    };
    scene.lights[0].animation = Track::new(vec![key(0.0, -0.15), key(1.0, 0.15)], false);
    scene.objects[1].animation = Track::new(vec![key(0.0, 0.0), key(1.0, 0.1)], false);
    for technique in ["lpv", "clpv", "olpv"] {
        let mut r = Renderer::new(&ctx, &scene, lpv_settings(technique, 32, 32)).unwrap();
        let first = r.render(&scene, 0.0).unwrap();
        assert!(first
            .iter()
            .any(|t| t.name == format!("{technique} propagate")));
        let memory = ctx.ledger.total();
        let (e0, _, _) = indirect(&r);
        let mut last = e0.clone();
        for t in [0.5, 1.0] {
            r.render(&scene, t).unwrap();
            assert_eq!(
                ctx.ledger.total(),
                memory,
                "{technique}: allocation at t = {t}"
            );
            last = indirect(&r).0;
        }
        let change: f32 = e0
            .pixels
            .iter()
            .zip(&last.pixels)
            .map(|(a, b)| (*a - *b).abs().element_sum())
            .sum();
        let total: f32 = e0.pixels.iter().map(|p| p.element_sum()).sum();
        println!("{technique}: indirect changed by {change} of {total}");
        assert!(
            change > 0.05 * total,
            "{technique}: moving the light changed the indirect light by only {change} of {total}"
        );
        assert!(ctx
            .ledger
            .by_owner()
            .iter()
            .any(|(o, b)| o == technique && *b > 0));
    }
}

#[test]
fn settings_come_from_scene_tables_and_reject_unknown_keys() {
    let table: toml::Table = toml::from_str(
        "[lpv]\nsize = 24\ngain = 2.0\n[clpv]\ncascades = 4\n[olpv]\niterations = 6\n",
    )
    .unwrap();
    let s = GiSettings::from_table(&table, std::path::Path::new("x.toml")).unwrap();
    assert_eq!((s.lpv.size, s.lpv.gain, s.lpv.iterations), (24, 2.0, 32));
    assert_eq!(
        (s.clpv.cascades, s.olpv.iterations, s.olpv.size),
        (4, 6, 32)
    );
    let bad: toml::Table = toml::from_str("[lpv]\nsizes = 3\n").unwrap();
    assert!(GiSettings::from_table(&bad, std::path::Path::new("x.toml")).is_err());
    let bad: toml::Table = toml::from_str("[lpvv]\nsize = 3\n").unwrap();
    assert!(GiSettings::from_table(&bad, std::path::Path::new("x.toml")).is_err());
    // Invalid values are errors at creation, not panics.
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let mut settings = lpv_settings("olpv", 8, 8);
    settings.gi_settings.olpv.size = 12;
    assert!(Renderer::new(&ctx, &scene, settings).is_err());
    for directional in [-0.1, 1.5, f32::NAN] {
        let mut settings = lpv_settings("lpv", 8, 8);
        settings.gi_settings.lpv.directional = directional;
        let err = Renderer::new(&ctx, &scene, settings).err();
        assert!(
            err.is_some_and(|e| e.to_string().contains("directional")),
            "directional {directional}"
        );
    }
    // A scene without lights: every technique runs and outputs zero indirect light.
    let dark = octolux::scene::cornell::geometry();
    for technique in ["lpv", "clpv", "olpv"] {
        let mut r = Renderer::new(&ctx, &dark, lpv_settings(technique, 8, 8)).unwrap();
        r.render(&dark, 0.0).unwrap();
        let (e, _, _) = indirect(&r);
        assert!(e.pixels.iter().all(|p| *p == Vec3::ZERO), "{technique}");
    }
}

#[test]
fn measurements_octree_error_per_iteration_and_pass_time_ratio() {
    // 000 §4.1, Fig. 8: e_abs / e_rel of the accumulated octree levels against the downsample
    // of the level below, after k iterations, for light injected near one wall of a 32^3
    // volume. Printed, not asserted beyond sanity: the paper reports a simulation.
    let ctx = context();
    let n = 32usize;
    let mut level0 = vec![[[0.0f32; 4]; 3]; n * n * n];
    let mut rng = Rng(4242);
    for z in 4..28 {
        for y in 4..28 {
            let normal = Vec3::X;
            let phi = 0.5 + rng.next();
            level0[sh::index(n, 1, y, z)] = [0, 1, 2].map(|_| sh::lambertian_emitter(phi, normal));
        }
    }
    let m = n + 1;
    let mut gv = vec![[0.0f32; 4]; m * m * m];
    for z in 0..m {
        for y in 0..m {
            gv[1 + m * (y + m * z)] = sh::lobe(Vec3::X);
        }
    }
    println!("k  e_abs        e_rel");
    let mut previous = 0.0;
    for k in [0u32, 1, 2, 4, 8, 16] {
        let run = kernels::octree(&ctx, n as u32, &level0, &gv, k, 0.0).unwrap();
        let (abs, rel) = sh::octree_errors(&run.accumulated, n);
        println!("{k:<2} {abs:.6e} {rel:.6e}");
        assert!(abs.is_finite() && rel.is_finite());
        if k == 0 {
            assert!(abs < 1e-6, "no propagation: levels are exact downsamples");
        }
        assert!(abs >= previous * 0.5);
        previous = abs;
    }

    // Table 1 as ratios: per-pass times of olpv (n = 32, k = 4) against lpv (n = 32, k = 16)
    // on the Cornell box, best of 3 frames each. Passes are timed on their own (CPU submit +
    // wait): lavapipe's timestamps around multi-dispatch passes are not trustworthy.
    let ctx = GpuContext::shared(&GpuOptions {
        timestamps: octolux::gpu::Timestamps::Off,
        ..GpuOptions::default()
    })
    .unwrap();
    let scene = octolux::scene::cornell::scene();
    let mut times = Vec::new();
    for (technique, k) in [("lpv", 16), ("olpv", 4)] {
        let mut s = lpv_settings(technique, 64, 64);
        s.gi_settings.lpv.size = 32;
        s.gi_settings.lpv.iterations = k;
        s.gi_settings.olpv.size = 32;
        s.gi_settings.olpv.iterations = k;
        s.gi_settings.lpv.rsm_size = 128;
        s.gi_settings.lpv.rsm_stride = 4;
        let mut r = Renderer::new(&ctx, &scene, s).unwrap();
        let mut best: Option<Vec<PassTiming>> = None;
        for f in 0..3 {
            let t = r.render(&scene, f as f32).unwrap();
            let total = technique_ms(&t, &[technique]);
            if best
                .as_ref()
                .is_none_or(|b| technique_ms(b, &[technique]) > total)
            {
                best = Some(t);
            }
        }
        let best = best.unwrap();
        for t in best.iter().filter(|t| t.name.starts_with(technique)) {
            println!("{:<18} {:8.3} ms ({:?})", t.name, t.ms, t.source);
        }
        times.push((
            technique_ms(&best, &[&format!("{technique} propagate")]),
            technique_ms(&best, &[technique]),
        ));
    }
    println!(
        "olpv(k=4) / lpv(k=16): propagate {:.3}, technique total {:.3}",
        times[1].0 / times[0].0,
        times[1].1 / times[0].1
    );
}

/// A grey square floor of half-size `a` at y = 0 (normal +y), lit by `light`.
fn floor_scene(a: f32, light: octolux::scene::Light) -> octolux::scene::Scene {
    use octolux::scene::{Camera, Material, Mesh, Object, Scene};
    let mesh = Mesh {
        name: "floor".into(),
        positions: vec![
            Vec3::new(-a, 0.0, -a),
            Vec3::new(-a, 0.0, a),
            Vec3::new(a, 0.0, a),
            Vec3::new(a, 0.0, -a),
        ],
        normals: vec![Vec3::Y; 4],
        uvs: vec![glam::Vec2::ZERO; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    };
    Scene {
        name: "floor".into(),
        meshes: vec![mesh],
        materials: vec![Material {
            base_color: Vec3::splat(0.5),
            ..Material::default()
        }],
        textures: vec![],
        objects: vec![Object {
            name: "floor".into(),
            meshes: vec![0],
            transform: glam::Mat4::IDENTITY,
            animation: None,
        }],
        lights: vec![light],
        cameras: vec![Camera {
            position: Vec3::new(0.0, 2.0, 2.0),
            target: Vec3::ZERO,
            near: 0.05,
            far: 10.0,
            ..Camera::default()
        }],
        exposure: 0.0,
        sky: None,
        requests: vec![],
    }
}

#[test]
fn injected_vpl_flux_is_the_reflected_flux_for_every_light_type() {
    // Reflected flux off a Lambertian floor in closed form (`floor_flux`).
    // RSM 256^2 with 4x4 blocks: only the floor's outline (about a texel wide) and the point
    // light's face seams are approximated, so the sums must agree within 1% (measured: 0.05%
    // point, 0.01% spot, 0.01% directional); moving, at 128^2 with 2x2 blocks: 0.3% point,
    // 0.01% spot, 0.03% directional (at 64^2 the point light's seams cost 2.3%).
    let ctx = context();
    let a = floor_flux::A;
    let cases = floor_flux::cases();
    for (name, light, expected) in cases {
        let scene = floor_scene(a, light);
        let mut s = lpv_settings("lpv", 16, 16);
        s.gi_settings.lpv.iterations = 0;
        s.gi_settings.lpv.rsm_size = 256;
        s.gi_settings.lpv.rsm_stride = 4;
        let mut r = Renderer::new(&ctx, &scene, s.clone()).unwrap();
        r.render(&scene, 0.0).unwrap();
        let lpv = lpv_of(&r);
        let flux = sh::total_flux(&lpv.read_accumulated(&ctx).unwrap());
        println!(
            "{name}: injected {:.5} W, expected {expected:.5} W",
            flux[0]
        );
        for f in flux {
            let rel = (f as f32 - expected).abs() / expected;
            assert!(rel < 0.01, "{name}: injected {f} W, expected {expected} W");
        }
        // The light moving (by 0.1 mm, which changes the flux by about 1e-4): its layers are
        // drawn at half the side, its outline twice as coarse: the same 1 %.
        let mut moving = scene.clone();
        let nudge = |time: f32, x: f32| Keyframe {
            time,
            translation: Vec3::new(x, 0.0, 0.0),
            rotation: Quat::IDENTITY,
        };
        moving.lights[0].animation = Track::new(vec![nudge(0.0, 0.0), nudge(1.0, 1e-4)], false);
        let mut r = Renderer::new(&ctx, &moving, s).unwrap();
        r.render(&moving, 0.0).unwrap();
        r.render(&moving, 1.0).unwrap();
        let lpv = lpv_of(&r);
        let half = lpv.last_grids().unwrap().half_layers;
        let layers = lpv.read_rsm(&ctx).unwrap().len();
        assert_eq!(
            half[0],
            (1 << layers) - 1,
            "{name}: the moved light's layers at half"
        );
        let flux = sh::total_flux(&lpv.read_accumulated(&ctx).unwrap());
        println!("{name}, moving: injected {:.5} W", flux[0]);
        for f in flux {
            let rel = (f as f32 - expected).abs() / expected;
            assert!(
                rel < 0.01,
                "{name} moving: injected {f} W, expected {expected} W"
            );
        }
    }
}

#[test]
fn thin_wall_leak_with_and_without_damping() {
    // A spot lights the floor on the +x side of a thin wall at x = 0. Nothing on the -x side
    // is lit, directly or by a bounce, so any indirect light on the wall's dark face is a leak
    // of the LPV's coarse cells through the wall. Measures its mean on the dark face for
    // damping 0, 1, 2 (001 §3.3.1: derivative along the normal).
    use octolux::scene::{Light, LightKind, Mesh};
    let ctx = context();
    let light = Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_angle: 25f32.to_radians(),
            outer_angle: 35f32.to_radians(),
        },
        color: Vec3::ONE,
        intensity: 4.0,
        position: Vec3::new(0.5, 1.0, 0.0),
        direction: Vec3::NEG_Y,
        animation: None,
    };
    let mut scene = floor_scene(1.0, light);
    scene.meshes.push(Mesh {
        name: "wall".into(),
        positions: vec![
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 1.2, -1.0),
            Vec3::new(0.0, 1.2, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ],
        normals: vec![Vec3::X; 4],
        uvs: vec![glam::Vec2::ZERO; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    });
    scene.objects[0].meshes.push(1);
    scene.cameras[0].position = Vec3::new(-1.5, 0.6, 0.0);
    scene.cameras[0].target = Vec3::new(0.0, 0.4, 0.0);
    let (w, h) = (48, 48);
    let mut leaks = Vec::new();
    for damping in [0.0, 1.0, 2.0] {
        let mut s = lpv_settings("lpv", w, h);
        s.gi_settings.lpv.damping = damping;
        let mut r = Renderer::new(&ctx, &scene, s).unwrap();
        r.render(&scene, 0.0).unwrap();
        let (e, _, normal) = indirect(&r);
        let (mut leak, mut count) = (0.0f32, 0);
        for (p, n) in e.pixels.iter().zip(&normal) {
            if n.x < -0.9 {
                leak += p.x;
                count += 1;
            }
        }
        assert!(count > 200, "{count} pixels of the wall's dark face");
        let leak = leak / count as f32;
        println!("damping {damping}: leak on the dark face {leak:.5} W/m^2");
        leaks.push(leak);
    }
    // Measured (docs/lpv.md): 0.0039, 0.0042, 0.0047 W/m^2 with the defaults (blocking from
    // both sides, sampled a cell in front), against 0.0488, 0.0024, 0.0000 with 001's one-sided
    // blocking and half-cell lookup. Damping no longer helps; the bound holds every setting to
    // a fifth of the former undamped leak, about 3% of the lit floor's 0.3 W/m^2.
    for (damping, leak) in [0.0, 1.0, 2.0].iter().zip(&leaks) {
        assert!(
            (0.0..0.01).contains(leak),
            "damping {damping}: leak {leak}, all: {leaks:?}"
        );
    }
}

#[test]
fn gpu_lookup_matches_cpu_lookup_of_the_accumulated_volume() {
    // E = max(0, <c(p + n s LOOKUP_OFFSET), lobe(-n)>) / s^2 with c trilinear in the accumulated volume,
    // computed on the CPU from the GPU's volume and G-buffer, against the GPU lookup. The output
    // is f16: agreement within 0.2% of the largest value.
    use octolux::scene::{Light, LightKind};
    let ctx = context();
    let light = Light {
        name: "point".into(),
        kind: LightKind::Point,
        color: Vec3::new(1.0, 0.6, 0.3),
        intensity: 2.0,
        position: Vec3::new(0.2, 0.5, -0.1),
        direction: Vec3::NEG_Y,
        animation: None,
    };
    let scene = floor_scene(1.0, light);
    let (w, h) = (24, 24);
    let mut s = lpv_settings("lpv", w, h);
    s.gi_settings.lpv.iterations = 3;
    let mut r = Renderer::new(&ctx, &scene, s).unwrap();
    r.render(&scene, 0.0).unwrap();
    let lpv = lpv_of(&r);
    let volume = lpv.read_accumulated(&ctx).unwrap();
    let bytes = octolux::gpu::read_texture(&ctx, lpv.indirect_texture(), 0).unwrap();
    let gpu: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|c| octolux::gpu::pack::f16_to_f32(u16::from_le_bytes([c[0], c[1]])))
        .collect();
    let g = r.read_gbuffer().unwrap();
    let view = *r.last_view().unwrap();
    let n = 16usize;
    let (origin, cell) = octolux::gi::lpv::cascades::fit(scene.bounds_at(0.0), n as u32);
    let mut largest = 0.0f32;
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if g.depth[i] >= 1.0 {
                continue;
            }
            let ndc = Vec3::new(
                (x as f32 + 0.5) / w as f32 * 2.0 - 1.0,
                1.0 - (y as f32 + 0.5) / h as f32 * 2.0,
                g.depth[i],
            );
            let p = view.inv_view_proj.project_point3(ndc);
            let normal = g.normal[i].normalize();
            let at = p + normal * (sh::LOOKUP_OFFSET * cell);
            let c = sh::sample_trilinear(&volume, n, origin, cell, at);
            for ch in 0..3 {
                let cpu = sh::irradiance(&c[ch], normal, cell);
                let got = gpu[i * 4 + ch];
                largest = largest.max(cpu);
                worst = worst.max((cpu - got).abs());
            }
        }
    }
    println!("lookup: largest E {largest}, worst difference {worst}");
    assert!(largest > 0.0);
    assert!(worst <= 2e-3 * largest, "worst {worst} of {largest}");
}

/// Indirect irradiance E of the technique's output texture (f16 RGBA), per pixel.
fn technique_irradiance(ctx: &GpuContext, r: &Renderer) -> Vec<Vec3> {
    let lpv = lpv_of(r);
    let bytes = octolux::gpu::read_texture(ctx, lpv.indirect_texture(), 0).unwrap();
    bytes
        .chunks_exact(8)
        .map(|c| {
            let f = |k: usize| octolux::gpu::pack::f16_to_f32(u16::from_le_bytes([c[k], c[k + 1]]));
            Vec3::new(f(0), f(2), f(4))
        })
        .collect()
}

/// Cornell box regions by G-buffer normal, albedo and world position.
fn cornell_region(p: Vec3, n: Vec3, a: Vec3) -> Option<&'static str> {
    let white = a.min_element() > 0.5;
    if a.x > 2.0 * a.y {
        Some("red wall")
    } else if a.y > 2.0 * a.x {
        Some("green wall")
    } else if !white {
        None
    } else if n.y > 0.9 && p.y < 0.02 {
        Some("floor")
    } else if n.y > 0.9 {
        Some("block tops")
    } else if n.y < -0.9 {
        Some("ceiling")
    } else if n.z < -0.9 && p.z > 0.54 {
        Some("back wall")
    } else if n.y.abs() < 0.5 {
        Some("block sides")
    } else {
        None
    }
}

/// Cornell box irradiance per region against the one-bounce reference (`indirect_irradiance`).
/// Prints the table of docs/lpv.md (SPP=4096 in release for the documented figures) and holds
/// every default technique to the right order of magnitude on every region: within a factor 6
/// of the reference. The block tops (32 pixels, facing up just above the brightly lit floor)
/// are the documented exception (ratio < 0.1): with 2 bands, the floor's strong up-going
/// light reads as negative irradiance on an up-facing surface (<basis(y), lobe(-y)> = -0.25
/// per unit of flux) and cancels the weaker light coming down from the walls. Also `olpv`'s
/// ceiling (ratio < 0.2): the merge reads level 0 next to geometry, and level 0's light moves
/// one cell per step, 16 of the 32 the ceiling lies above the floor.
#[test]
fn cornell_irradiance_per_region_against_the_reference() {
    use octolux::reference::ReferenceSettings;
    use octolux::transport::Bounces;
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let (w, h) = (64u32, 64u32);
    let spp = std::env::var("SPP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(64);
    let reference = octolux::reference::render(
        &scene,
        &scene.frame(0.0, 0),
        w,
        h,
        &ReferenceSettings {
            spp,
            bounces: Bounces::Indirect(1),
            ..ReferenceSettings::default()
        },
        &|_, _| {},
    )
    .unwrap();
    let configs: Vec<(&str, GiSettings)> = {
        let mut v = Vec::new();
        // Defaults (0 = keep), then lpv with more iterations and without occlusion, then the
        // 001 transfer (directional 0) for comparison.
        for (name, it, occ, dir) in [
            ("lpv", 0, true, 1.0),
            ("lpv", 64, true, 1.0),
            ("lpv", 64, false, 1.0),
            ("clpv", 0, true, 1.0),
            ("olpv", 0, true, 1.0),
            ("lpv", 0, true, 0.0),
            ("clpv", 0, true, 0.0),
            ("olpv", 0, true, 0.0),
        ] {
            let mut gi = GiSettings::default();
            if it > 0 {
                gi.lpv.iterations = it;
            }
            gi.lpv.occlusion = occ;
            gi.lpv.directional = dir;
            v.push((name, gi));
        }
        v
    };
    let mut failures = Vec::new();
    for (technique, gi) in configs {
        let (n, k) = match technique {
            "clpv" => (gi.clpv.size, gi.clpv.iterations),
            "olpv" => (gi.olpv.size, gi.olpv.iterations),
            _ => (gi.lpv.size, gi.lpv.iterations),
        };
        let label = format!(
            "{technique} n={n} k={k} occlusion={} directional={}",
            gi.lpv.occlusion, gi.lpv.directional
        );
        let is_default = gi.lpv.occlusion
            && gi.lpv.directional == GiSettings::default().lpv.directional
            && (technique != "lpv" || k == GiSettings::default().lpv.iterations);
        let settings = RenderSettings {
            width: w,
            height: h,
            gi: technique.into(),
            gi_settings: gi,
            ..RenderSettings::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings).unwrap();
        r.render(&scene, 0.0).unwrap();
        let e = technique_irradiance(&ctx, &r);
        let g = r.read_gbuffer().unwrap();
        let view = *r.last_view().unwrap();
        let mut sums: std::collections::BTreeMap<&str, (f64, f64, usize)> = Default::default();
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                if g.depth[i] >= 1.0 {
                    continue;
                }
                let ndc = Vec3::new(
                    (x as f32 + 0.5) / w as f32 * 2.0 - 1.0,
                    1.0 - (y as f32 + 0.5) / h as f32 * 2.0,
                    g.depth[i],
                );
                let p = view.inv_view_proj.project_point3(ndc);
                if let Some(region) = cornell_region(p, g.normal[i], g.albedo[i]) {
                    let s = sums.entry(region).or_default();
                    s.0 += e[i].element_sum() as f64 / 3.0;
                    s.1 += reference.indirect_irradiance.pixels[i].element_sum() as f64 / 3.0;
                    s.2 += 1;
                }
            }
        }
        println!("{label}");
        for (region, (t, rf, count)) in sums {
            let (t, rf) = (t / count as f64, rf / count as f64);
            let ratio = t / rf;
            println!("  {region:12} pixels {count:5} E {t:.4} reference {rf:.4} ratio {ratio:.3}");
            if is_default && region == "block tops" {
                if ratio >= 0.1 {
                    failures.push(format!("{label}: block tops lit ({ratio}), update docs"));
                }
            } else if is_default && technique == "olpv" && region == "ceiling" {
                if !(0.01..0.2).contains(&ratio) {
                    failures.push(format!("{label}: ceiling ratio {ratio}, update docs"));
                }
            } else if is_default && !(1.0 / 6.0..6.0).contains(&ratio) {
                failures.push(format!("{label}: {region} ratio {ratio}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// E of one Lambertian VPL (flux 1, normal +x) propagated in an open `n`^3 volume without
/// occlusion (CPU reference, which the GPU kernel equals), looked up as the renderer does:
/// VPL in the cell half a cell in front of the emitting point, sample `offset` cells in front
/// of the receiver, E = <c, lobe(-n)>/s^2. Returns (distance in cells, off-axis, LPV E, exact E)
/// for receivers facing -x at distances 1..=8 on the lobe axis and on the 45 degree line.
fn single_vpl_irradiance(
    n: usize,
    iterations: usize,
    directional: f32,
    offset: f32,
) -> Vec<(u32, bool, f32, f32)> {
    let s = 1.0f32;
    let emitter = Vec3::new(3.0, n as f32 / 2.0 + 0.5, n as f32 / 2.0 + 0.5);
    let normal = Vec3::X;
    let mut volume = vec![[[0.0f32; 4]; 3]; n * n * n];
    let vpl = ((emitter + normal * 0.5 * s) / s).floor();
    volume[sh::index(n, vpl.x as usize, vpl.y as usize, vpl.z as usize)] =
        [sh::lambertian_emitter(1.0, normal); 3];
    let mut acc = volume.clone();
    for _ in 0..iterations {
        volume = sh::propagate_step(&volume, n, None, directional);
        for (a, c) in acc.iter_mut().zip(&volume) {
            for k in 0..4 {
                a[0][k] += c[0][k];
            }
        }
    }
    let mut out = Vec::new();
    for off_axis in [false, true] {
        for d in 1..=8u32 {
            let along = d as f32 * s;
            let receiver = emitter + Vec3::new(along, if off_axis { along } else { 0.0 }, 0.0);
            let rn = -Vec3::X;
            let c = sh::sample_trilinear(&acc, n, Vec3::ZERO, s, receiver + rn * offset * s);
            let lpv = sh::irradiance(&c[0], rn, s);
            let to = receiver - emitter;
            let r = to.length();
            let exact = to.normalize().dot(normal) * (-to.normalize()).dot(rn)
                / (std::f32::consts::PI * r * r);
            out.push((d, off_axis, lpv, exact));
        }
    }
    out
}

#[test]
fn single_vpl_irradiance_against_the_analytic_answer() {
    // A Lambertian VPL of flux Phi gives E = Phi/pi cos_emit cos_recv / d^2. The LPV departs
    // from it in documented, deterministic ways (docs/lpv.md, "Physical check"):
    // - the VPL sits half a cell in front of the emitter and the lookup samples half a cell in
    //   front of the receiver, so transport is computed over d - 1 cells: too bright near;
    // - re-emitting the light that crosses a face as a Lambertian lobe about the face
    //   (directional 0, 001): per step a lobe sends 47% of its flux on, 67% sideways and -14%
    //   back, so light diffuses instead of travelling straight: too dark far, and more so off
    //   the axis;
    // - re-emitting it as a beam along the direction it crossed the face (directional 1, the
    //   default, sampled one cell in front of the receiver): light keeps its direction, but
    //   only the six axis and 24 side directions exist, so the light of a single VPL gathers
    //   along the grid axes (a ray effect: on the axis up to 15 x, 45 degrees off it 0.4-1.2
    //   x). Extended sources average it out (the lit-plane tests).
    // The ratios below are the measured curves (f32 CPU arithmetic, exact up to rounding); the
    // test pins them to 5% so that any change of normalisation (a constant factor such as
    // pi, 4 pi, 2 or 8), of an offset, of the transfer or of the lookup shows.
    let curves: [(f32, f32, [f32; 8], [f32; 8]); 2] = [
        (
            0.0,
            0.5,
            [2.030, 2.644, 2.098, 1.583, 1.223, 0.922, 0.701, 0.489],
            [1.270, 1.679, 1.521, 1.187, 0.814, 0.490, 0.258, 0.116],
        ),
        (
            GiSettings::default().lpv.directional,
            sh::LOOKUP_OFFSET,
            [1.471, 7.689, 11.34, 13.59, 14.58, 14.66, 14.13, 13.25],
            [0.823, 0.956, 0.599, 0.431, 0.497, 0.707, 0.972, 1.215],
        ),
    ];
    let mut failures = Vec::new();
    for (directional, offset, expected_on, expected_off) in curves {
        let rows = single_vpl_irradiance(20, 40, directional, offset);
        println!(
            "directional {directional}, lookup offset {offset}\nd  axis  E_lpv     E_exact   ratio"
        );
        for &(d, off, lpv, exact) in &rows {
            let ratio = lpv / exact;
            println!(
                "{d}  {}  {lpv:.5}  {exact:.5}  {ratio:.3}",
                if off { "45" } else { " 0" }
            );
            let want = if off { expected_off } else { expected_on }[d as usize - 1];
            if (ratio / want - 1.0).abs() >= 0.05 {
                failures.push(format!(
                    "directional {directional}, d {d} off-axis {off}: ratio {ratio}, documented {want}"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A square Lambertian emitter filling the bottom row of an open `n`^3 volume (one VPL of flux
/// 1 per cell: exitance 1 W/m^2), propagated `iterations` times without occlusion. Returns, for
/// receivers above its centre facing down at heights `h` (cells), (h, LPV E, exact E), and the
/// LPV E on the emitter itself facing up (exactly 0: a plane does not see itself).
fn lit_plane_irradiance(
    n: usize,
    iterations: usize,
    directional: f32,
    offset: f32,
    heights: &[u32],
) -> (Vec<(u32, f32, f32)>, f32) {
    let mut volume = vec![[[0.0f32; 4]; 3]; n * n * n];
    for z in 0..n {
        for x in 0..n {
            volume[sh::index(n, x, 0, z)] = [sh::lambertian_emitter(1.0, Vec3::Y); 3];
        }
    }
    let mut acc = volume.clone();
    for _ in 0..iterations {
        volume = sh::propagate_step(&volume, n, None, directional);
        for (a, c) in acc.iter_mut().zip(&volume) {
            for k in 0..4 {
                a[0][k] += c[0][k];
            }
        }
    }
    let centre = n as f32 / 2.0;
    let lookup = |p: Vec3, normal: Vec3| {
        let c = sh::sample_trilinear(&acc, n, Vec3::ZERO, 1.0, p + normal * offset);
        sh::irradiance(&c[0], normal, 1.0)
    };
    // Exact: E = M integral of h^2 / (pi r^4) over the square, midpoint rule.
    let exact = |h: f32| {
        let m = 400;
        let step = n as f32 / m as f32;
        let mut e = 0.0f64;
        for j in 0..m {
            for i in 0..m {
                let x = (i as f32 + 0.5) * step - centre;
                let z = (j as f32 + 0.5) * step - centre;
                let r2 = (x * x + z * z + h * h) as f64;
                e += (h * h) as f64 / (std::f64::consts::PI * r2 * r2) * (step * step) as f64;
            }
        }
        e as f32
    };
    let rows = heights
        .iter()
        .map(|&h| {
            let p = Vec3::new(centre, h as f32, centre);
            (h, lookup(p, -Vec3::Y), exact(h as f32))
        })
        .collect();
    (rows, lookup(Vec3::new(centre, 0.0, centre), Vec3::Y))
}

#[test]
fn lit_plane_lights_itself_and_fades_with_height() {
    // The Cornell box's missing ceiling light and too bright floor, isolated: a lit square
    // (exitance M = 1 W/m^2, 16 x 16 cells) at the bottom of an open 16^3 volume, 32 iterations.
    // Exact: a plane receives nothing from itself; a point h cells above its centre facing down
    // receives M x the form factor of the square. The 2-band SH lobe of an upward emitter
    // sends a quarter of its peak sideways; in a plane of emitters the sideways lobes of
    // neighbours add up to an isotropic term, which lights the plane itself and sends half of
    // the light back down, so the light that climbs fades within a few cells. Measured ratios,
    // pinned to 5% (deterministic CPU arithmetic); the 32^3 / 64-iteration values are in
    // docs/lpv.md.
    let (rows, own) = lit_plane_irradiance(16, 32, 0.0, 0.5, &[2, 4, 8, 12]);
    println!("own E on the plane: {own:.3} W/m^2 (exact 0)");
    for &(h, lpv, exact) in &rows {
        println!(
            "h {h}: E_lpv {lpv:.4} E_exact {exact:.4} ratio {:.3}",
            lpv / exact
        );
    }
    assert!((own / 0.988 - 1.0).abs() < 0.05, "own {own}");
    let expected = [1.473f32, 0.841, 0.166, 0.013];
    for (&(h, lpv, exact), want) in rows.iter().zip(expected) {
        let ratio = lpv / exact;
        assert!(
            (ratio / want - 1.0).abs() < 0.05,
            "h {h}: ratio {ratio}, documented {want}"
        );
    }
}

#[test]
fn lit_plane_does_not_light_itself_when_light_keeps_its_direction() {
    // The lit square of the test above with the default transfer (light crossing a face is
    // re-emitted as a beam along the direction it crossed it). An upward Lambertian lobe sends
    // its sideways quarter along the plane as beams that stay horizontal: the down-going light
    // the plane would receive cancels between neighbours, and the up-going light keeps
    // climbing instead of diffusing back. Pinned: E on the plane itself below 0.5% of the
    // exitance (exact 0), ratios above it within 5% of the measured ones.
    let directional = GiSettings::default().lpv.directional;
    for (n, iterations, expected) in [
        (16, 32, [1.027f32, 1.046, 1.194, 1.326, 0.0]),
        (32, 64, [1.027, 1.005, 1.029, 1.091, 1.139]),
    ] {
        let heights: &[u32] = if n == 16 {
            &[2, 4, 8, 12]
        } else {
            &[2, 4, 8, 12, 15]
        };
        let (rows, own) =
            lit_plane_irradiance(n, iterations, directional, sh::LOOKUP_OFFSET, heights);
        println!("{n}^3, {iterations} iterations: own E on the plane {own:.4} W/m^2 (exact 0)");
        for &(h, lpv, exact) in &rows {
            println!(
                "h {h}: E_lpv {lpv:.4} E_exact {exact:.4} ratio {:.3}",
                lpv / exact
            );
        }
        assert!(own.abs() < 0.005, "own {own}");
        for (&(h, lpv, exact), want) in rows.iter().zip(expected) {
            let ratio = lpv / exact;
            assert!(
                (ratio / want - 1.0).abs() < 0.05,
                "{n}^3, h {h}: ratio {ratio}, measured {want}"
            );
        }
    }
}

/// The Cornell box with its spot light, plus a point light (six RSM layers) and a sun.
fn cornell_three_lights() -> octolux::scene::Scene {
    use octolux::scene::LightKind;
    let mut scene = octolux::scene::cornell::scene();
    let spot = scene.lights[0].clone();
    scene.lights.push(octolux::scene::Light {
        name: "point".into(),
        kind: LightKind::Point,
        intensity: 0.3,
        position: Vec3::new(0.35, 0.42, 0.25),
        ..spot.clone()
    });
    scene.lights.push(octolux::scene::Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        intensity: 0.4,
        direction: Vec3::new(0.3, -1.0, 0.5).normalize(),
        ..spot
    });
    scene
}

#[test]
fn injection_equals_the_cpu_twin_for_every_variant() {
    // The fixed-point GPU injection against `inject_cpu` (the maths of the earlier
    // float-atomic kernel, summed in f64) for every variant, with the camera geometry taken from
    // every pixel (40x40) and from 3x3 blocks (600x200 > 256 samples per side).
    // Tolerances: each light term is a handful of f32 operations whose rounding another compiler
    // may change (< 1e-6 of its magnitude) plus one fixed-point rounding of 2^-58 of the light's
    // flux; 2e-5 of the summed magnitudes bounds both with a margin. Camera surfels take their
    // footprint from differences of neighbouring pixels' world positions, which cancels about
    // three of f32's seven digits: 1e-3. Terms whose cell decision lies within 1e-3 cells of a
    // boundary may land in a neighbour on another adapter: their magnitude is allowed on top.
    // The point light and the sun move (the second frame): their seven layers are drawn at
    // half the side and read with half the stride, the spot's whole.
    use octolux::gi::lpv::inject_cpu::{self, CameraInput, GBufferInput};
    let ctx = context();
    let mut scene = cornell_three_lights();
    let nudge = |time: f32, x: f32| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: Quat::IDENTITY,
    };
    for light in &mut scene.lights[1..] {
        light.animation = Track::new(vec![nudge(0.0, 0.0), nudge(1.0, 0.02)], false);
    }
    for (w, h) in [(40, 40), (600, 200)] {
        for technique in ["lpv", "clpv", "olpv"] {
            let mut s = lpv_settings(technique, w, h);
            s.gi_settings.lpv.iterations = 0;
            s.gi_settings.clpv.iterations = 0;
            s.gi_settings.olpv.iterations = 0;
            s.gi_settings.lpv.rsm_stride = 4;
            let mut r = Renderer::new(&ctx, &scene, s).unwrap();
            r.render(&scene, 0.0).unwrap();
            r.render(&scene, 0.5).unwrap();
            let lpv = lpv_of(&r);
            let grids = *lpv.last_grids().unwrap();
            assert_eq!(
                grids.half_layers[0], 0b1111_1110,
                "point and sun moved, not the spot"
            );
            let gpu_light = lpv.read_accumulated(&ctx).unwrap();
            let gpu_gv = lpv.read_geometry(&ctx).unwrap();
            let rsm = lpv.read_rsm(&ctx).unwrap();
            assert_eq!(rsm.len(), 8, "spot + 6 point faces + sun");
            let gb = r.read_gbuffer().unwrap();
            let view = r.last_view().unwrap();
            let camera = CameraInput {
                inv_view_proj: view.inv_view_proj,
                position: view.position,
                width: w,
                height: h,
            };
            let cpu = inject_cpu::inject(
                &grids,
                gpu_light.len(),
                &rsm,
                &camera,
                &GBufferInput {
                    depth: &gb.depth,
                    normal: &gb.normal,
                },
            );
            let label = format!("{technique} at {w}x{h}");
            let floor = |sums: &[f64]| sums.iter().fold(0.0f64, |a, &b| a.max(b)) * 1e-9;
            let light_floor = floor(
                &cpu.light
                    .iter()
                    .flat_map(|c| c.map(|s| s.magnitude))
                    .collect::<Vec<_>>(),
            );
            let (mut lit, mut magnitude, mut slack) = (0, 0.0, 0.0);
            // Only grids that receive light (olpv's coarser levels are downsampled from level 0
            // before this buffer is read; `octree_downsample_index_and_merge_match_cpu` covers
            // them).
            let injected_cells = lpv
                .layouts()
                .iter()
                .filter(|l| l.flags & octolux::gi::lpv::FLAG_INJECT != 0)
                .map(|l| l.offset as usize..(l.offset + l.n * l.n * l.n) as usize)
                .collect::<Vec<_>>();
            for (i, (g, c)) in gpu_light.iter().zip(&cpu.light).enumerate() {
                if !injected_cells.iter().any(|r| r.contains(&i)) {
                    continue;
                }
                lit += (c[0].magnitude > 0.0) as usize;
                magnitude += c[0].magnitude;
                slack += c[0].slack;
                for ch in 0..3 {
                    for k in 0..4 {
                        let s = c[ch * 4 + k];
                        let tol = 2e-5 * s.magnitude + s.slack + light_floor;
                        let diff = (g[ch][k] as f64 - s.value).abs();
                        assert!(
                            diff <= tol,
                            "{label}: light cell {i} channel {ch} coefficient {k}: GPU {} CPU {} \
                             (tolerance {tol:e})",
                            g[ch][k],
                            s.value
                        );
                    }
                }
            }
            let gv_floor = 1e-9;
            let mut blocked = 0;
            for (i, g) in gpu_gv.iter().enumerate() {
                let (a, b) = (&cpu.gv_rsm[i], &cpu.gv_camera[i]);
                let close = |sums: &[inject_cpu::Sum; 4], rel: f64| {
                    (0..4).all(|k| {
                        let s = sums[k];
                        (g[k] as f64 - s.value).abs() <= rel * s.magnitude + s.slack + gv_floor
                    })
                };
                let ta = 2e-5 * a[0].magnitude + a[0].slack + gv_floor;
                let tb = 1e-3 * b[0].magnitude + b[0].slack + gv_floor;
                let ok = if (a[0].value - b[0].value).abs() > ta + tb {
                    // The CPU's max-combination choice is clear: the GPU must agree.
                    if b[0].value > a[0].value {
                        close(b, 1e-3)
                    } else {
                        close(a, 2e-5)
                    }
                } else {
                    close(a, 2e-5) || close(b, 1e-3)
                };
                blocked += (g[0] > 0.0) as usize;
                assert!(
                    ok,
                    "{label}: geometry cell {i}: GPU {g:?} RSM {a:?} camera {b:?}"
                );
            }
            let loose = slack / magnitude.max(1e-30);
            println!(
                "{label}: {lit} lit cells ({:.2}% of the light allowed to move by ambiguous \
                 decisions), {blocked} blocking geometry cells, camera stride {}",
                100.0 * loose,
                grids.camera_stride
            );
            assert!(
                lit >= 20 && blocked >= 50,
                "{label}: the test sees real injection"
            );
            assert!(loose < 0.05, "{label}: almost all light is checked tightly");
        }
    }
}

#[test]
fn volume_bounds_can_be_set_instead_of_fitted() {
    // `[settings.lpv] bounds` places the uniform and octree volumes (and the cascades' focus and
    // size) on the given box instead of the scene's bounds; bad boxes are errors.
    use octolux::gi::lpv::cascades;
    let table: toml::Table =
        toml::from_str("[lpv]\nbounds = [[0.1, 0.0, 0.1], [0.4, 0.3, 0.5]]\n").unwrap();
    let s = GiSettings::from_table(&table, std::path::Path::new("x.toml")).unwrap();
    assert_eq!(s.lpv.bounds, Some([[0.1, 0.0, 0.1], [0.4, 0.3, 0.5]]));
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let (lo, hi) = (Vec3::new(0.1, 0.0, 0.1), Vec3::new(0.4, 0.3, 0.5));
    for technique in ["lpv", "olpv", "clpv"] {
        let mut settings = lpv_settings(technique, 8, 8);
        settings.gi_settings.lpv.bounds = Some([lo.to_array(), hi.to_array()]);
        let mut r = Renderer::new(&ctx, &scene, settings).unwrap();
        r.render(&scene, 0.0).unwrap();
        let lpv = lpv_of(&r);
        let g = lpv.last_grids().unwrap().grids[0];
        if technique == "clpv" {
            // The finest cascade is 1.25 x the box's largest side wide.
            let width = g.cell * g.n as f32;
            assert!((width - 1.25 * 0.4).abs() < 1e-5, "{technique}: {width}");
        } else {
            let (origin, cell) = cascades::fit((lo, hi), g.n);
            assert_eq!(
                (Vec3::from(g.origin), g.cell),
                (origin, cell),
                "{technique}"
            );
            let fitted = cascades::fit(scene.bounds_at(0.0), g.n);
            assert!(
                cell < fitted.1 * 0.8,
                "{technique}: the box is smaller than the scene"
            );
        }
    }
    for bad in [
        [[0.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
        [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
        [[f32::NAN, 0.0, 0.0], [1.0, 1.0, 1.0]],
    ] {
        let mut settings = lpv_settings("lpv", 8, 8);
        settings.gi_settings.lpv.bounds = Some(bad);
        let err = Renderer::new(&ctx, &scene, settings)
            .err()
            .expect("bad bounds");
        assert!(err.to_string().contains("lpv bounds"), "{err}");
    }
}

/// Adds the quad `corners` (counter-clockwise seen from the side `normal` points to) to mesh 0.
fn add_quad(scene: &mut octolux::scene::Scene, corners: [Vec3; 4], normal: Vec3) {
    let mesh = &mut scene.meshes[0];
    let base = mesh.positions.len() as u32;
    mesh.positions.extend(corners);
    mesh.normals.extend([normal; 4]);
    mesh.uvs.extend([glam::Vec2::ZERO; 4]);
    mesh.indices
        .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// A closed room (1.2 x 1 x 1.2 m, walls, floor and roof 1 cm thick: far thinner than an LPV
/// cell of 13 cm) on a 4 x 4 m sunlit ground, the camera inside. Nothing inside is lit,
/// directly or by any bounce: the reference's indirect irradiance there is exactly 0.
fn leak_room_scene() -> octolux::scene::Scene {
    use octolux::scene::{Light, LightKind};
    let sun = Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: 3.0,
        position: Vec3::ZERO,
        direction: Vec3::new(-0.5, -1.0, -0.3).normalize(),
        animation: None,
    };
    let mut scene = floor_scene(2.0, sun);
    let (lo, hi) = (Vec3::new(-0.6, 0.02, -0.6), Vec3::new(0.6, 1.0, 0.6));
    let t = 0.01;
    // Each slab: an outer face facing out and an inner face facing in, `t` apart.
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = side;
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let plane = if side > 0.0 { hi[axis] } else { lo[axis] };
            for (offset, facing) in [(t, n), (0.0, -n)] {
                let at = plane + side * offset;
                let corner = |a: f32, b: f32| {
                    let mut p = Vec3::ZERO;
                    p[axis] = at;
                    p[u] = a;
                    p[v] = b;
                    p
                };
                let mut q = [
                    corner(lo[u], lo[v]),
                    corner(hi[u], lo[v]),
                    corner(hi[u], hi[v]),
                    corner(lo[u], hi[v]),
                ];
                let winding = (q[1] - q[0]).cross(q[2] - q[0]);
                if winding.dot(facing) < 0.0 {
                    q.reverse();
                }
                add_quad(&mut scene, q, facing);
            }
        }
    }
    scene.cameras[0].position = Vec3::new(0.45, 0.75, 0.45);
    scene.cameras[0].target = Vec3::new(-0.6, 0.2, -0.6);
    scene.cameras[0].near = 0.01;
    scene
}

#[test]
fn leak_into_a_closed_room_beside_a_sunlit_exterior() {
    // Mean indirect irradiance on the inside of a closed room next to a sunlit exterior, whose
    // walls are far thinner than a cell; exactly 0 in reality (the reference's value: no path
    // from the sun reaches the inside). Default settings (32^3, 32 iterations), and with the
    // 001 re-emission (directional 0) for comparison.
    let ctx = context();
    let scene = leak_room_scene();
    let (w, h) = (48, 48);
    let mut results = Vec::new();
    for technique in ["lpv", "clpv", "olpv"] {
        for directional in [0.0, GiSettings::default().lpv.directional] {
            let mut s = RenderSettings {
                width: w,
                height: h,
                gi: technique.into(),
                ..RenderSettings::default()
            };
            s.gi_settings.lpv.directional = directional;
            let mut r = Renderer::new(&ctx, &scene, s).unwrap();
            r.render(&scene, 0.0).unwrap();
            let direct = r.read_direct().unwrap();
            let lit = direct.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
            assert_eq!(
                lit, 0.0,
                "the camera sees direct light: not inside the room"
            );
            let e = technique_irradiance(&ctx, &r);
            let mean = e.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / e.len() as f32;
            println!("{technique} directional {directional}: leak inside {mean:.4} W/m^2");
            results.push((technique, directional, mean));
        }
    }
    // For scale: the sunlit ground outside receives 3 x 0.85 = 2.55 W/m^2 directly. Measured
    // with the defaults (docs/lpv.md): lpv 0.110, clpv 0.059, olpv 0.010 W/m^2; with the
    // blocking read from one side only (before) and directional 0: 0.075, 0.116, 0.005.
    // Bound: the leak stays below 5% of the exterior's direct irradiance.
    for (technique, directional, leak) in results {
        assert!(
            (0.0..0.05 * 2.55).contains(&leak),
            "{technique} directional {directional}: leak {leak}"
        );
    }
}

#[test]
fn rsms_are_drawn_again_only_when_something_they_see_moves() {
    // A static scene keeps its RSMs after the first frame (no `rsm` pass), with the same image
    // as drawing them again; a light that moves or an object that moves draws them again.
    let ctx = context();
    let mut scene = octolux::scene::cornell::scene();
    let has_rsm = |timings: &[PassTiming]| timings.iter().any(|t| t.name == "lpv rsm");
    let mut r = Renderer::new(&ctx, &scene, lpv_settings("lpv", 32, 32)).unwrap();
    assert!(has_rsm(&r.render(&scene, 0.0).unwrap()), "first frame");
    let drawn = r.read_hdr().unwrap();
    assert!(!has_rsm(&r.render(&scene, 0.0).unwrap()), "static frame");
    let kept = r.read_hdr().unwrap();
    assert_eq!(drawn.pixels, kept.pixels, "kept RSMs give another image");
    // A fresh renderer at the same frame draws them and gets the same image.
    let mut fresh = Renderer::new(&ctx, &scene, lpv_settings("lpv", 32, 32)).unwrap();
    fresh.render(&scene, 0.0).unwrap();
    assert_eq!(fresh.read_hdr().unwrap().pixels, kept.pixels);
    // Something the RSMs see moves: the light, then (the light still) an object.
    let key = |time: f32, x: f32| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: Quat::IDENTITY,
    };
    scene.lights[0].animation = Track::new(vec![key(0.0, 0.0), key(1.0, 0.2)], false);
    assert!(has_rsm(&r.render(&scene, 0.5).unwrap()), "moved light");
    // At rest again, its layer is drawn once more at the whole side (it moved at half).
    assert!(has_rsm(&r.render(&scene, 0.5).unwrap()), "light at rest");
    assert!(
        !has_rsm(&r.render(&scene, 0.5).unwrap()),
        "light at rest again"
    );
    scene.lights[0].animation = None;
    scene.objects[1].animation = Track::new(vec![key(0.0, 0.0), key(1.0, 0.1)], false);
    let mut r = Renderer::new(&ctx, &scene, lpv_settings("lpv", 32, 32)).unwrap();
    assert!(has_rsm(&r.render(&scene, 0.0).unwrap()));
    assert!(has_rsm(&r.render(&scene, 0.5).unwrap()), "moved object");
}

#[test]
fn each_rsm_layer_is_drawn_again_only_when_something_it_sees_moves() {
    // Two spots: the box's own, which sees everything, and a narrow one aimed at the floor's
    // corner farthest from the short block. Moving the narrow spot draws its layer alone;
    // moving the short block draws the big spot's layer alone (the block is outside the narrow
    // spot's view). A layer whose content moves is drawn at half the side, and at the whole
    // once it rests; the kept layers give the image a fresh renderer draws.
    let ctx = context().with_work_counter();
    let mut scene = octolux::scene::cornell::scene();
    let short = scene
        .objects
        .iter()
        .position(|o| o.name == "short-block")
        .unwrap();
    let corners = &scene.meshes[scene.objects[short].meshes[0] as usize].positions;
    let block = corners.iter().fold(Vec3::ZERO, |s, &p| s + p) / corners.len() as f32;
    let (lo, hi) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.556, 0.0, 0.56));
    let corner = Vec3::new(
        if block.x > 0.278 { lo.x } else { hi.x },
        0.0,
        if block.z > 0.28 { lo.z } else { hi.z },
    );
    let target = corner * 0.8 + Vec3::new(0.278, 0.0, 0.28) * 0.2;
    let mut narrow = octolux::scene::Light::spot(
        Vec3::new(target.x, 0.5, target.z),
        Vec3::NEG_Y,
        Vec3::ONE,
        0.5,
        4f32.to_radians(),
        6f32.to_radians(),
    );
    narrow.name = "narrow".into();
    scene.lights.push(narrow);
    let key = |time: f32, x: f32| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: Quat::IDENTITY,
    };
    // Layers and texels drawn in a frame.
    let drawn = |r: &mut Renderer, scene: &octolux::scene::Scene, t: f32| {
        // Counts of other renderers on this context are dropped first.
        ctx.work().unwrap().take(&ctx).unwrap();
        r.render(scene, t).unwrap();
        let counts = ctx.work().unwrap().take(&ctx).unwrap();
        let count = |quantity: &str| {
            counts
                .iter()
                .find(|c| c.pass == "lpv rsm" && c.quantity == quantity)
                .map_or(0, |c| c.count)
        };
        (count("layers"), count("texels"))
    };
    let layers_drawn =
        |r: &mut Renderer, scene: &octolux::scene::Scene, t: f32| drawn(r, scene, t).0;
    let side = lpv_settings("lpv", 32, 32).gi_settings.lpv.rsm_size as u64;
    let fresh_image = |scene: &octolux::scene::Scene, t: f32| {
        let mut fresh = Renderer::new(&ctx, scene, lpv_settings("lpv", 32, 32)).unwrap();
        fresh.render(scene, t).unwrap();
        fresh.read_hdr().unwrap().pixels
    };

    scene.lights[1].animation = Track::new(vec![key(0.0, 0.0), key(1.0, 0.02)], false);
    let mut r = Renderer::new(&ctx, &scene, lpv_settings("lpv", 32, 32)).unwrap();
    assert_eq!(layers_drawn(&mut r, &scene, 0.0), 2, "first frame");
    assert_eq!(layers_drawn(&mut r, &scene, 0.0), 0, "static frame");
    assert_eq!(
        drawn(&mut r, &scene, 0.5),
        (1, side * side / 4),
        "the narrow spot moved: its layer at half the side"
    );
    assert_ne!(r.read_hdr().unwrap().pixels, fresh_image(&scene, 0.5));
    // At rest: drawn once more at the whole side, then kept; the image a fresh renderer draws.
    assert_eq!(drawn(&mut r, &scene, 0.5), (1, side * side), "at rest");
    assert_eq!(layers_drawn(&mut r, &scene, 0.5), 0, "kept");
    assert_eq!(r.read_hdr().unwrap().pixels, fresh_image(&scene, 0.5));

    scene.lights[1].animation = None;
    scene.objects[short].animation = Track::new(vec![key(0.0, 0.0), key(1.0, 0.01)], false);
    let mut r = Renderer::new(&ctx, &scene, lpv_settings("lpv", 32, 32)).unwrap();
    assert_eq!(layers_drawn(&mut r, &scene, 0.0), 2, "first frame");
    assert_eq!(
        drawn(&mut r, &scene, 0.5),
        (1, side * side / 4),
        "the block moved: the big spot's layer at half the side"
    );
    assert_eq!(drawn(&mut r, &scene, 0.5), (1, side * side), "at rest");
    assert_eq!(r.read_hdr().unwrap().pixels, fresh_image(&scene, 0.5));
}

#[test]
fn a_layer_at_half_the_side_is_cleared_over_its_corner() {
    // A layer drawn at half the side keeps its targets' contents outside its corner and clears
    // the corner itself with a triangle (a load-op clear would cover the whole layer). Two
    // renderers whose point light comes from different places to the same one draw the same
    // corners, bit for bit, whatever the whole-side drawing before left there: texels the
    // light does not reach are zero again, and no stale depth hides a surface.
    let ctx = context();
    let key = |time: f32, x: f32| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: Quat::IDENTITY,
    };
    let rsm_after = |from: f32| {
        let mut scene = cornell_three_lights();
        scene.lights[1].animation = Track::new(vec![key(0.0, from), key(0.5, 0.01)], false);
        let mut r = Renderer::new(&ctx, &scene, lpv_settings("lpv", 24, 24)).unwrap();
        r.render(&scene, 0.0).unwrap();
        r.render(&scene, 0.5).unwrap();
        let lpv = lpv_of(&r);
        (
            lpv.last_grids().unwrap().half_layers[0],
            lpv.read_rsm(&ctx).unwrap(),
        )
    };
    let (half, near) = rsm_after(0.0);
    let (half_far, far) = rsm_after(-0.15);
    assert_eq!(
        half, 0b0111_1110,
        "the point light's six faces at half the side"
    );
    assert_eq!(half_far, half);
    let (mut uncovered, mut stale_differs) = (0, false);
    for layer in (1..7).filter(|l| half & (1 << l) != 0) {
        let (a, b) = (&near[layer], &far[layer]);
        let n = a.size as usize;
        for y in 0..n {
            for x in 0..n {
                let t = y * n + x;
                let texel = |img: &octolux::frame::rsm::RsmImage| {
                    [img.position[t], img.normal[t], img.flux[t]].map(|v| v.map(f32::to_bits))
                };
                if x < n / 2 && y < n / 2 {
                    assert_eq!(texel(a), texel(b), "layer {layer} texel ({x}, {y})");
                    uncovered += usize::from(a.position[t][3] == 0.0);
                } else {
                    stale_differs |= texel(a) != texel(b);
                }
            }
        }
    }
    // Otherwise the comparison could not see a texel left uncleared.
    assert!(uncovered > 0, "some corner texels see no surface");
    assert!(stale_differs, "the whole-side drawings before differ");
}
