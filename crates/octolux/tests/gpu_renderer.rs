//! GPU renderer tests on simple geometry with known answers, run on whatever adapter is present
//! (lavapipe in CI): G-buffer contents, direct lighting against the analytic irradiance, shadows
//! of every light type, the GPU tone map against the CPU one, timers and the memory ledger.

use crate::common::context;
use glam::{Mat4, Vec2, Vec3};
use octolux::gpu::{GpuContext, GpuOptions, Timestamps, TimingSource};
use octolux::image_io::tone_map_to_srgb8;
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{Camera, Light, LightKind, Material, Mesh, Object, Scene};

/// A square of side `2 * half` centred at `centre`, facing `normal`.
fn quad(centre: Vec3, normal: Vec3, half: f32, material: u32) -> Mesh {
    let n = normal.normalize();
    let t = n.any_orthonormal_vector();
    let b = n.cross(t);
    let corners = [-t - b, t - b, t + b, -t + b].map(|c| centre + c * half);
    Mesh {
        name: "quad".into(),
        positions: corners.to_vec(),
        normals: vec![n; 4],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// An axis-aligned box mesh.
fn cuboid(lo: Vec3, hi: Vec3, material: u32) -> Mesh {
    let c = (lo + hi) * 0.5;
    let e = (hi - lo) * 0.5;
    let mut mesh = Mesh {
        name: "box".into(),
        material,
        ..Mesh::default()
    };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut du = Vec3::ZERO;
            du[u] = e[u];
            let mut dv = Vec3::ZERO;
            dv[v] = e[v];
            let f = c + n * e[axis];
            let base = mesh.positions.len() as u32;
            mesh.positions
                .extend([f - du - dv, f + du - dv, f + du + dv, f - du + dv]);
            mesh.normals.extend([n; 4]);
            mesh.uvs.extend([Vec2::ZERO; 4]);
            let ccw = (du * 2.0).cross(dv * 2.0).dot(n) > 0.0;
            let tris = if ccw {
                [0, 1, 2, 0, 2, 3]
            } else {
                [0, 2, 1, 0, 3, 2]
            };
            mesh.indices.extend(tris.map(|i| base + i));
        }
    }
    mesh
}

fn scene_of(meshes: Vec<Mesh>, albedo: Vec3, lights: Vec<Light>, camera: Camera) -> Scene {
    let objects = vec![Object {
        name: "all".into(),
        meshes: (0..meshes.len() as u32).collect(),
        transform: Mat4::IDENTITY,
        animation: None,
    }];
    Scene {
        name: "test".into(),
        meshes,
        materials: vec![Material {
            base_color: albedo,
            ..Material::default()
        }],
        textures: vec![],
        objects,
        lights,
        cameras: vec![camera],
        exposure: 0.0,
        sky: None,
        requests: vec![],
    }
}

fn settings(width: u32, height: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        shadow_map_size: 1024,
        ..RenderSettings::default()
    }
}

fn point_light(position: Vec3, intensity: f32) -> Light {
    Light {
        name: "point".into(),
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity,
        position,
        direction: Vec3::NEG_Y,
        animation: None,
    }
}

#[test]
fn gbuffer_of_a_plane_matches_cpu_values() {
    let ctx = context();
    let d = 2.0;
    let albedo = Vec3::new(0.25, 0.5, 0.75); // exact in f16
    let camera = Camera {
        position: Vec3::ZERO,
        target: Vec3::NEG_Z,
        up: Vec3::Y,
        vfov: 60f32.to_radians(),
        near: 0.1,
        far: 10.0,
        ..Camera::default()
    };
    let scene = scene_of(
        vec![quad(Vec3::new(0.0, 0.0, -d), Vec3::Z, 10.0, 0)],
        albedo,
        vec![point_light(Vec3::new(0.0, 0.0, -1.0), 1.0)],
        camera.clone(),
    );
    let mut renderer = Renderer::new(&ctx, &scene, settings(32, 24)).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let g = renderer.read_gbuffer().unwrap();
    let (n, f) = (camera.near, camera.far);
    // Perspective depth (wgpu 0..1 range) of a point at view distance z along the axis.
    let expected_depth = |z: f32| f * (z - n) / (z * (f - n));
    let view = camera.view(32, 24);
    for y in 0..24 {
        for x in 0..32 {
            let i = y * 32 + x;
            assert_eq!(g.albedo[i], albedo, "albedo at {x},{y}");
            assert_eq!(g.normal[i], Vec3::Z, "normal at {x},{y}");
            // The plane is at view depth d for every pixel (it faces the camera squarely).
            let depth = g.depth[i];
            assert!(
                (depth - expected_depth(d)).abs() < 1e-6,
                "depth {depth} at {x},{y}"
            );
            let dir = view.ray_direction(x as f32 + 0.5, y as f32 + 0.5);
            assert!(dir.z < 0.0);
        }
    }
}

/// Camera looking down at the plane y = 0 from above and to the side.
fn overhead_camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 3.0, 3.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 50f32.to_radians(),
        near: 0.1,
        far: 20.0,
        ..Camera::default()
    }
}

/// World point seen at pixel centre (x, y) on the plane y = 0, intersected on the CPU.
fn floor_point(view: &octolux::scene::CameraView, x: u32, y: u32) -> Option<Vec3> {
    let dir = view.ray_direction(x as f32 + 0.5, y as f32 + 0.5);
    (dir.y < -1e-4).then(|| view.position + dir * (-view.position.y / dir.y))
}

#[test]
fn point_light_irradiance_matches_inverse_square_law() {
    let ctx = context();
    let albedo = Vec3::splat(0.5);
    let light = point_light(Vec3::new(0.3, 1.5, -0.2), 4.0);
    let scene = scene_of(
        vec![quad(Vec3::ZERO, Vec3::Y, 3.0, 0)],
        albedo,
        vec![light.clone()],
        overhead_camera(),
    );
    let (w, h) = (48, 32);
    let mut renderer = Renderer::new(&ctx, &scene, settings(w, h)).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let direct = renderer.read_direct().unwrap();
    let view = *renderer.last_view().unwrap();
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let Some(p) = floor_point(&view, x, y) else {
                continue;
            };
            if p.x.abs() > 2.9 || p.z.abs() > 2.9 {
                continue;
            }
            let d = light.position - p;
            let r2 = d.length_squared();
            let cos = d.normalize().y;
            let expected = albedo / std::f32::consts::PI * light.intensity * cos / r2;
            let got = direct.get(x, y);
            let rel = ((got - expected).abs() / expected).max_element();
            assert!(
                rel < 0.01,
                "pixel {x},{y}: got {got}, expected {expected} ({rel:.4})"
            );
            checked += 1;
        }
    }
    assert!(checked > 500, "only {checked} pixels on the plane");
}

/// Whether the segment from `p` to `light` passes through the box [lo, hi].
fn segment_hits_box(p: Vec3, to: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let d = to - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for a in 0..3 {
        if d[a].abs() < 1e-9 {
            if p[a] < lo[a] || p[a] > hi[a] {
                return false;
            }
            continue;
        }
        let (mut ta, mut tb) = ((lo[a] - p[a]) / d[a], (hi[a] - p[a]) / d[a]);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
    }
    t0 <= t1
}

fn check_shadows(light: Light) {
    let ctx = context();
    let (lo, hi) = (Vec3::new(-0.4, 0.6, -0.4), Vec3::new(0.4, 0.9, 0.4));
    let scene = scene_of(
        vec![quad(Vec3::ZERO, Vec3::Y, 3.0, 0), cuboid(lo, hi, 0)],
        Vec3::splat(0.5),
        vec![light.clone()],
        overhead_camera(),
    );
    let (w, h) = (64, 48);
    let mut renderer = Renderer::new(&ctx, &scene, settings(w, h)).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let direct = renderer.read_direct().unwrap();
    let view = *renderer.last_view().unwrap();
    let margin = Vec3::splat(0.08);
    let (mut shadowed, mut lit) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let Some(p) = floor_point(&view, x, y) else {
                continue;
            };
            if p.x.abs() > 2.8 || p.z.abs() > 2.8 {
                continue;
            }
            // The box itself hides some floor pixels from the camera.
            if segment_hits_box(view.position, p, lo, hi) {
                continue;
            }
            let towards = match light.kind {
                LightKind::Directional => p - light.direction * 100.0,
                _ => light.position,
            };
            let (to_light, e) = match light.kind {
                LightKind::Directional => (-light.direction, light.intensity),
                _ => {
                    let d = light.position - p;
                    let dir = d.normalize();
                    (
                        dir,
                        light.intensity * light.spot_factor(-dir) / d.length_squared(),
                    )
                }
            };
            let unshadowed = 0.5 / std::f32::consts::PI * e * to_light.y.max(0.0);
            if unshadowed < 1e-3 {
                continue;
            }
            let got = direct.get(x, y).x;
            if segment_hits_box(p, towards, lo + margin, hi - margin) {
                assert!(
                    got < 0.05 * unshadowed,
                    "{:?}: pixel {x},{y} ({p}) should be in shadow: {got} vs {unshadowed}",
                    light.kind
                );
                shadowed += 1;
            } else if !segment_hits_box(p, towards, lo - margin, hi + margin) {
                assert!(
                    got > 0.95 * unshadowed,
                    "{:?}: pixel {x},{y} ({p}) should be lit: {got} vs {unshadowed}",
                    light.kind
                );
                lit += 1;
            }
        }
    }
    assert!(
        shadowed > 40 && lit > 200,
        "{:?}: {shadowed} shadowed, {lit} lit pixels checked",
        light.kind
    );
}

#[test]
fn point_light_casts_shadows() {
    check_shadows(point_light(Vec3::new(0.2, 2.0, 0.1), 4.0));
}

#[test]
fn spot_light_casts_shadows() {
    check_shadows(Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_angle: 50f32.to_radians(),
            outer_angle: 60f32.to_radians(),
        },
        position: Vec3::new(-0.3, 2.2, 0.2),
        direction: Vec3::new(0.1, -1.0, -0.05).normalize(),
        ..point_light(Vec3::ZERO, 4.0)
    });
}

#[test]
fn directional_light_casts_shadows() {
    check_shadows(Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        direction: Vec3::new(0.4, -1.0, 0.3).normalize(),
        ..point_light(Vec3::ZERO, 2.0)
    });
}

#[test]
fn gpu_tone_map_matches_cpu() {
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    let mut renderer = Renderer::new(&ctx, &scene, settings(40, 40)).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let hdr = renderer.read_hdr().unwrap();
    let display = renderer.read_display().unwrap();
    let scale = scene.exposure.exp2();
    let mut nonzero = 0;
    for (i, p) in hdr.pixels.iter().enumerate() {
        let cpu = tone_map_to_srgb8(*p * scale);
        for c in 0..3 {
            let gpu = display[i * 3 + c];
            assert!(
                (gpu as i32 - cpu[c] as i32).abs() <= 1,
                "pixel {i}: gpu {gpu} cpu {}",
                cpu[c]
            );
        }
        nonzero += (cpu[0] > 0) as usize;
    }
    assert!(nonzero > 400, "the Cornell box is lit");
}

#[test]
fn timings_cover_every_pass_in_both_modes_and_memory_is_stable() {
    // `Always` exercises the timestamp path even on lavapipe (values unchecked there).
    for timestamps in [Timestamps::Always, Timestamps::Off, Timestamps::Auto] {
        let ctx = GpuContext::shared(&GpuOptions {
            timestamps,
            ..GpuOptions::default()
        })
        .unwrap();
        let scene = octolux::scene::cornell::scene();
        let mut renderer = Renderer::new(&ctx, &scene, settings(32, 32)).unwrap();
        let first = renderer.render(&scene, 0.0).unwrap();
        let memory = ctx.ledger.total();
        let second = renderer.render(&scene, 0.5).unwrap();
        assert_eq!(ctx.ledger.total(), memory, "no per-frame allocation");
        for timings in [&first, &second] {
            let names: Vec<&str> = timings.iter().map(|t| t.name.as_str()).collect();
            assert_eq!(names, ["shadow maps", "gbuffer", "direct light", "compose"]);
            assert!(timings.iter().all(|t| t.ms.is_finite() && t.ms >= 0.0));
        }
        if !ctx.timestamps {
            assert!(first
                .iter()
                .all(|t| t.source == TimingSource::CpuSubmitWait));
        }
        let owners: Vec<String> = ctx.ledger.by_owner().into_iter().map(|(o, _)| o).collect();
        for owner in ["gbuffer", "shadow-maps", "scene", "compose", "direct"] {
            assert!(
                owners.iter().any(|o| o == owner),
                "{owner} missing from the ledger"
            );
        }
        // 32x32 G-buffer: three Rgba16Float targets (8 B) and Depth32Float (4 B).
        let gbuffer = ctx
            .ledger
            .by_owner()
            .into_iter()
            .find(|(o, _)| o == "gbuffer")
            .unwrap()
            .1;
        assert_eq!(gbuffer, 32 * 32 * (3 * 8 + 4));
    }
}

#[test]
fn absurd_sizes_are_errors() {
    let ctx = context();
    let scene = octolux::scene::cornell::scene();
    for (w, h) in [(0, 10), (10, 0), (100_000, 100_000), (20_000, 1)] {
        let err = Renderer::new(&ctx, &scene, settings(w, h))
            .err()
            .expect("must fail");
        assert!(err.to_string().contains(&format!("{w}x{h}")), "{err}");
    }
}

#[test]
fn renderers_on_threads_share_one_device_and_agree() {
    // Several threads render at once on the process's shared device (what parallel tests do);
    // each gets its own ledger, and all images are identical.
    let images: Vec<Vec<u8>> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..4)
            .map(|_| {
                s.spawn(|| {
                    let ctx = context();
                    let scene = octolux::scene::cornell::scene();
                    let mut renderer = Renderer::new(&ctx, &scene, settings(24, 24)).unwrap();
                    renderer.render(&scene, 0.0).unwrap();
                    assert!(ctx.ledger.total() > 0, "each context has its own ledger");
                    renderer.read_display().unwrap()
                })
            })
            .collect();
        workers.into_iter().map(|w| w.join().unwrap()).collect()
    });
    assert!(images.windows(2).all(|w| w[0] == w[1]));
    let a = context();
    let b = context();
    assert_eq!(a.device, b.device, "one device per process and options");
}

#[test]
fn pipelined_frames_report_earlier_frames_without_waiting() {
    // With timestamps (lavapipe has the feature; its values are not checked here) the
    // pipelined path returns nothing until a frame's timestamps are back, then the latest
    // finished frame with every pass; at most 3 frames are in flight, so no more than 3 calls
    // in a row return nothing (a GPU slower than the recording CPU, as an H100 drawing 2048^2
    // shadow maps is next to a 32x32 frame, lets frames pile up and finish together; their
    // times then arrive as one report). Without timestamps every call returns this frame's
    // CPU times. The image is the same either way.
    let scene = octolux::scene::cornell::scene();
    for timestamps in [Timestamps::Always, Timestamps::Off] {
        let ctx = GpuContext::shared(&GpuOptions {
            timestamps,
            ..GpuOptions::default()
        })
        .unwrap();
        let mut renderer = Renderer::new(&ctx, &scene, settings(32, 32)).unwrap();
        let (mut reported, mut silent, mut longest_silence) = (0, 0, 0);
        for frame in 0..8 {
            if let Some(times) = renderer.render_pipelined(&scene, 0.0).unwrap() {
                let names: Vec<&str> = times.iter().map(|t| t.name.as_str()).collect();
                assert_eq!(names, ["shadow maps", "gbuffer", "direct light", "compose"]);
                reported += 1;
                silent = 0;
            } else {
                assert!(
                    ctx.timestamps,
                    "frame {frame}: CPU timing reports every frame"
                );
                silent += 1;
                longest_silence = usize::max(longest_silence, silent);
            }
        }
        assert!(
            longest_silence <= 3,
            "{timestamps:?}: {longest_silence} calls in a row reported nothing"
        );
        if !ctx.timestamps {
            assert_eq!(reported, 8, "{timestamps:?}: every frame reported");
        }
        let pipelined = renderer.read_display().unwrap();
        renderer.render(&scene, 0.0).unwrap();
        assert_eq!(pipelined, renderer.read_display().unwrap());
    }
}

/// One triangle a kilometre beside the Cornell box: the GI structures fit the box, not the
/// whole extent (`Scene::gi_bounds_at`), so every technique renders the box as it does without
/// the triangle (before, each lost most of its indirect light: relMSE 0.12-0.36 at 64x64).
#[test]
fn a_far_triangle_leaves_every_technique_image_unchanged() {
    let ctx = context();
    let near = octolux::scene::cornell::scene();
    let mut far = near.clone();
    far.meshes.push(Mesh {
        name: "far".into(),
        positions: vec![
            Vec3::new(1000.0, 0.0, 0.0),
            Vec3::new(1000.0, 1.0, 0.0),
            Vec3::new(1000.0, 0.0, 1.0),
        ],
        normals: vec![Vec3::NEG_X; 3],
        uvs: vec![Vec2::ZERO; 3],
        indices: vec![0, 1, 2],
        material: 0,
    });
    far.objects.push(Object {
        name: "far".into(),
        meshes: vec![far.meshes.len() as u32 - 1],
        transform: Mat4::IDENTITY,
        animation: None,
    });
    assert_eq!(near.gi_bounds_at(0.0), near.bounds_at(0.0));
    assert_eq!(far.gi_bounds_at(0.0), near.bounds_at(0.0));
    assert!(far.bounds_at(0.0).1.x >= 1000.0);
    // Each technique's structures at a small size: what is compared is where they are
    // placed (the GI bounds), not how fine they are.
    let mut small = octolux::gi::GiSettings::default();
    small.vct.octree_resolution = 32;
    small.vct.resolution = 16;
    small.clpv.cascades = 2;
    small.lpv.rsm_size = 64;
    small.vpl.rsm_size = 64;
    for gi in octolux::gi::TECHNIQUES.iter().filter(|t| **t != "none") {
        let image = |scene: &Scene| {
            let mut r = Renderer::new(
                &ctx,
                scene,
                RenderSettings {
                    gi: gi.to_string(),
                    gi_settings: small.clone(),
                    shadow_map_size: 256,
                    ..settings(16, 16)
                },
            )
            .unwrap();
            for _ in 0..2 {
                r.render(scene, 0.0).unwrap();
            }
            r.read_hdr().unwrap()
        };
        let (a, b) = (image(&near), image(&far));
        let rel = octolux::metrics::rel_mse(&b, &a, None).unwrap();
        assert!(rel < 1e-6, "{gi}: relMSE {rel} with the far triangle");
    }
}
