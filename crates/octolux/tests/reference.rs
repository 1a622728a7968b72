//! Reference path tracer: physical invariants, analytic cases, convergence and determinism.
//! Images are small so the suite stays fast in the test profile.

use glam::{Mat4, Vec2, Vec3};
use octolux::image_io::HdrImage;
use octolux::reference::{render, ReferenceImages, ReferenceSettings};
use octolux::scene::{
    cornell, AlphaMode, Camera, Light, LightKind, Material, Mesh, Object, Scene, Texture,
};
use octolux::transport::{Bounces, EmissiveSurfaces, Transport};
use octolux::Error;
use std::f32::consts::PI;

fn settings(spp: u32, bounces: Bounces, seed: u64) -> ReferenceSettings {
    ReferenceSettings {
        spp,
        bounces,
        seed,
        ..ReferenceSettings::default()
    }
}

fn render_scene(scene: &Scene, size: u32, s: &ReferenceSettings) -> ReferenceImages {
    let frame = scene.frame(0.0, 0);
    render(scene, &frame, size, size, s, &|_, _| {}).unwrap()
}

/// Unit icosphere subdivided `levels` times, with flat (per-face) normals pointing inwards.
fn inward_icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from_array(*p).normalize())
    .collect();
    let mut faces: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut cache = std::collections::HashMap::new();
        let mut midpoint = |a: usize, b: usize, v: &mut Vec<Vec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut v);
                let bc = midpoint(b, c, &mut v);
                let ca = midpoint(c, a, &mut v);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let mut mesh = Mesh {
        name: "furnace".into(),
        material: 0,
        ..Mesh::default()
    };
    for [a, b, c] in faces {
        // Reverse the outward winding so the geometric normal points inwards.
        let (p0, p1, p2) = (v[a], v[c], v[b]);
        let n = (p1 - p0).cross(p2 - p0).normalize();
        assert!(n.dot(p0) < 0.0);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend([p0, p1, p2]);
        mesh.normals.extend([n; 3]);
        mesh.uvs.extend([Vec2::ZERO; 3]);
        mesh.indices.extend([base, base + 1, base + 2]);
    }
    mesh
}

/// A closed diffuse sphere (albedo `a`, emission `le`) seen from its centre.
fn furnace(a: f32, le: f32) -> Scene {
    Scene {
        name: "furnace".into(),
        meshes: vec![inward_icosphere(2)],
        materials: vec![Material {
            name: "grey".into(),
            base_color: Vec3::splat(a),
            emission: Vec3::splat(le),
            ..Material::default()
        }],
        objects: vec![Object {
            name: "sphere".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        cameras: vec![Camera {
            position: Vec3::ZERO,
            target: Vec3::new(0.3, 0.2, -1.0),
            vfov: 90f32.to_radians(),
            ..Camera::default()
        }],
        ..Scene::default()
    }
}

fn max_rel_error(image: &HdrImage, expected: f32) -> f32 {
    image
        .pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(|c| (c - expected).abs() / expected)
        .fold(0.0, f32::max)
}

#[test]
fn white_furnace_unlimited_converges_to_le_over_one_minus_a() {
    let (a, le) = (0.5, 1.0);
    // Only Russian roulette adds variance here (cosine sampling makes the path weight exactly
    // the albedo, and next-event estimation towards the sphere adds a weight of one in total):
    // per-sample standard deviation of the pixel is about 0.18, so 4096 spp give 0.003 =
    // 0.14 % of the expected 2, and the 1 % bound is seven standard deviations away.
    let images = render_scene(&furnace(a, le), 8, &settings(4096, Bounces::Unlimited, 1));
    let expected = le / (1.0 - a);
    let err = max_rel_error(&images.total, expected);
    assert!(err < 0.01, "furnace off by {err}");
    // The split is consistent: direct holds the emission seen and reflected once.
    assert!(max_rel_error(&images.direct, le + a * le) < 0.01);
    assert!(max_rel_error(&images.indirect, expected - le - a * le) < 0.02);
    assert!(max_rel_error(&images.emitter_irradiance, PI * le) < 0.01);
}

/// Mean of an image's red channel (the furnace is grey).
fn mean(image: &HdrImage) -> f32 {
    image.pixels.iter().map(|p| p.x).sum::<f32>() / image.pixels.len() as f32
}

/// Sum of le a^k for k = 0..=r: the furnace's radiance after at most r reflections.
fn furnace_radiance(a: f32, le: f32, reflections: u32) -> f32 {
    (0..=reflections).map(|k| le * a.powi(k as i32)).sum()
}

#[test]
fn white_furnace_exactly_n_bounces_for_every_way_of_counting_emissive_surfaces() {
    let (a, le) = (0.5, 1.0);
    for n in [0u32, 1, 2, 5] {
        let bounces = if n == 0 {
            Bounces::DirectOnly
        } else {
            Bounces::Indirect(n)
        };
        for emissive in [
            EmissiveSurfaces::LikeLights,
            EmissiveSurfaces::OneBounceFewer,
            EmissiveSurfaces::Unlit,
        ] {
            let transport = Transport { bounces, emissive };
            let s = settings(4096, bounces, 3).with_transport(transport);
            let images = render_scene(&furnace(a, le), 8, &s);
            // `direct` is light reflected once (n + 1 reflections with n bounces), as Mitsuba's
            // max_depth n + 2 counts it; emissive surfaces are the only emitters here.
            // Next-event estimation towards a sphere that surrounds the point is its worst case:
            // half the samples land behind the surface, and the per-sample standard deviation of
            // the once-reflected part is about 0.43 of the pixel. At 4096 spp that is 0.7 % per
            // pixel (3 % is over four standard deviations away) and 0.08 % for the mean of the
            // 64 pixels (0.5 % is six away).
            let r = transport.max_emissive_reflections();
            let expected = furnace_radiance(a, le, r);
            let err = max_rel_error(&images.total, expected);
            assert!(err < 0.03, "{transport:?}: off by {err}");
            let err = (mean(&images.total) - expected).abs() / expected;
            assert!(err < 0.005, "{transport:?}: mean off by {err}");
            let direct = furnace_radiance(a, le, r.min(1));
            assert!(
                max_rel_error(&images.direct, direct) < 0.03,
                "{transport:?}"
            );
            // E = pi L_in and indirect = a/pi E at every pixel.
            for (e, i) in images
                .indirect_irradiance
                .pixels
                .iter()
                .zip(&images.indirect.pixels)
            {
                assert!((*e * a / PI - *i).abs().max_element() < 1e-5);
            }
            // What a technique carrying emissive light in its indirect light outputs: every
            // reflection after the first at x1, the emission arriving there included.
            let gi = images.gi_irradiance(emissive);
            let want = if emissive == EmissiveSurfaces::OneBounceFewer {
                PI * furnace_radiance(a, le, r.saturating_sub(1)) * (r > 0) as u32 as f32
            } else {
                PI * (furnace_radiance(a, le, r.max(1) - 1) - le) * (r > 1) as u32 as f32
            };
            let got = mean(&gi);
            assert!(
                (got - want).abs() <= 0.005 * want.max(1e-3),
                "{transport:?}: irradiance {got} vs {want}"
            );
        }
    }
}

/// A 20 m x 20 m white floor at y = 0 seen from (0, 2, 0) looking straight down.
fn floor_scene(albedo: f32, light: Light) -> Scene {
    let mut mesh = Mesh {
        name: "floor".into(),
        positions: vec![
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::new(10.0, 0.0, 10.0),
            Vec3::new(10.0, 0.0, -10.0),
        ],
        uvs: vec![Vec2::ZERO; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
        ..Mesh::default()
    };
    mesh.compute_normals().unwrap();
    Scene {
        name: "floor".into(),
        meshes: vec![mesh],
        materials: vec![Material {
            base_color: Vec3::splat(albedo),
            ..Material::default()
        }],
        objects: vec![Object {
            name: "floor".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        lights: vec![light],
        cameras: vec![Camera {
            position: Vec3::new(0.0, 2.0, 0.0),
            target: Vec3::ZERO,
            vfov: 60f32.to_radians(),
            ..Camera::default()
        }],
        ..Scene::default()
    }
}

/// Checks every pixel of a direct-only render of `scene` against `expected(point on floor)`.
fn check_floor(scene: &Scene, expected: impl Fn(Vec3) -> f32) {
    let size = 32;
    let images = render_scene(scene, size, &settings(64, Bounces::DirectOnly, 5));
    let frame = scene.frame(0.0, 0);
    let view = frame.camera.view(size, size);
    // The expected pixel value is the mean of the analytic radiance over a 16 x 16 grid of
    // positions inside the pixel (the pixel integral, far more accurately than the 64 samples
    // it). The tolerance covers the 64-sample quadrature of that integral: 0.5 % of the value
    // plus 0.5 % of the brightest pixel for the spot-cone edge, where the
    // radiance rises from 0 to full within two pixels.
    let grid = 16;
    let mut want = vec![0.0f32; (size * size) as usize];
    for y in 0..size {
        for x in 0..size {
            let mut sum = 0.0;
            for j in 0..grid {
                for i in 0..grid {
                    let (sx, sy) = (
                        (i as f32 + 0.5) / grid as f32,
                        (j as f32 + 0.5) / grid as f32,
                    );
                    let d = view.ray_direction(x as f32 + sx, y as f32 + sy);
                    sum += expected(view.position + d * (-view.position.y / d.y));
                }
            }
            want[(y * size + x) as usize] = sum / (grid * grid) as f32;
        }
    }
    let peak = want.iter().copied().fold(0.0, f32::max);
    for y in 0..size {
        for x in 0..size {
            let want = want[(y * size + x) as usize];
            let got = images.direct.get(x, y);
            let tol = 5e-3 * want + 5e-3 * peak;
            assert!(
                (got - Vec3::splat(want)).abs().max_element() <= tol,
                "pixel {x},{y}: {got} vs {want}"
            );
        }
    }
    assert!(images.indirect.pixels.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn point_light_over_a_plane_matches_the_analytic_radiance() {
    let (albedo, intensity, h) = (0.8, 5.0, 1.0);
    let light = Light {
        name: "point".into(),
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity,
        position: Vec3::new(0.3, h, -0.2),
        direction: Vec3::NEG_Y,
        animation: None,
    };
    let scene = floor_scene(albedo, light.clone());
    check_floor(&scene, |p| {
        let to = light.position - p;
        let r = to.length();
        let cos = h / r;
        albedo / std::f32::consts::PI * intensity * cos / (r * r)
    });
}

#[test]
fn spot_and_directional_lights_match_the_analytic_radiance() {
    let albedo = 0.5;
    let spot = Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_angle: 20f32.to_radians(),
            outer_angle: 35f32.to_radians(),
        },
        color: Vec3::ONE,
        intensity: 3.0,
        position: Vec3::new(0.0, 1.5, 0.0),
        direction: Vec3::NEG_Y,
        animation: None,
    };
    let scene = floor_scene(albedo, spot.clone());
    check_floor(&scene, |p| {
        let to = spot.position - p;
        let r = to.length();
        let f = spot.spot_factor(-to / r);
        albedo / std::f32::consts::PI * spot.intensity * f * (spot.position.y / r) / (r * r)
    });
    let sun_dir = Vec3::new(0.3, -1.0, 0.2).normalize();
    let sun = Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: 2.0,
        position: Vec3::ZERO,
        direction: sun_dir,
        animation: None,
    };
    let scene = floor_scene(albedo, sun);
    check_floor(&scene, |_| {
        albedo / std::f32::consts::PI * 2.0 * (-sun_dir.y)
    });
}

fn rmse(a: &HdrImage, b: &HdrImage) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x - *y).length_squared() as f64)
        .sum();
    (sum / (3 * a.pixels.len()) as f64).sqrt()
}

#[test]
fn error_falls_as_one_over_sqrt_spp() {
    let scene = cornell::scene();
    let size = 32;
    let bounces = Bounces::Indirect(1);
    let reference = render_scene(&scene, size, &settings(2048, bounces, 99));
    let errors: Vec<f64> = [4u32, 16, 64]
        .iter()
        .map(|&spp| {
            rmse(
                &render_scene(&scene, size, &settings(spp, bounces, 7)).total,
                &reference.total,
            )
        })
        .collect();
    // Quadrupling the samples halves the error of a Monte Carlo estimate. The RMSE over 3072
    // values is itself a noisy estimate (seeds 7..10 gave step ratios 1.81..2.26), and the
    // 2048-spp reference adds its own noise (it inflates the 64-spp error by
    // sqrt(1 + 64/2048), 1.6 %), so accept 1.6..2.5 per step. Seeds are fixed, so the test is
    // deterministic.
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((1.6..2.5).contains(&ratio), "errors {errors:?}");
    }
}

#[test]
fn same_seed_same_image_on_any_thread_count() {
    let scene = cornell::scene();
    let s = settings(4, Bounces::Unlimited, 42);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| render_scene(&scene, 16, &s));
    let many = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| render_scene(&scene, 16, &s));
    assert_eq!(one.total, many.total);
    assert_eq!(one.indirect_irradiance, many.indirect_irradiance);
    let other = render_scene(&scene, 16, &settings(4, Bounces::Unlimited, 43));
    assert_ne!(one.total, other.total);
}

#[test]
fn cornell_box_is_finite_and_tinted_by_its_walls() {
    let scene = cornell::scene();
    let size = 24;
    let images = render_scene(&scene, size, &settings(16, Bounces::Unlimited, 11));
    for image in [
        &images.direct,
        &images.indirect,
        &images.total,
        &images.indirect_irradiance,
    ] {
        assert!(image
            .pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0));
    }
    for i in 0..images.total.pixels.len() {
        assert_eq!(
            images.total.pixels[i],
            images.direct.pixels[i] + images.indirect.pixels[i]
        );
    }
    // The red wall (+x) is on the left of the classic camera, the green one on the right:
    // compare red/green balance of the indirect light between the two halves.
    let half = |left: bool| {
        let mut sum = Vec3::ZERO;
        for y in 0..size {
            for x in 0..size / 2 {
                let x = if left { x } else { size - 1 - x };
                sum += images.indirect.get(x, y);
            }
        }
        sum
    };
    let (left, right) = (half(true), half(false));
    assert!(left.x / left.y > right.x / right.y, "{left} vs {right}");
    assert!(right.y / right.x > left.y / left.x);
    assert!(images.indirect.pixels.iter().any(|p| p.max_element() > 0.0));
    assert_eq!(images.spp_done, 16);
}

#[test]
fn time_budget_and_progress() {
    let scene = cornell::scene();
    let frame = scene.frame(0.0, 0);
    let calls = std::cell::RefCell::new(Vec::new());
    let s = ReferenceSettings {
        spp: 1000,
        time_budget: Some(std::time::Duration::ZERO),
        ..settings(1000, Bounces::DirectOnly, 0)
    };
    let images = render(&scene, &frame, 8, 8, &s, &|done, total| {
        calls.borrow_mut().push((done, total))
    })
    .unwrap();
    assert_eq!(images.spp_done, 1);
    assert_eq!(calls.into_inner(), vec![(1, 1000)]);
}

#[test]
fn absurd_sizes_are_rejected() {
    let scene = cornell::scene();
    let frame = scene.frame(0.0, 0);
    let s = settings(1, Bounces::DirectOnly, 0);
    for (w, h) in [(0, 8), (8, 0), (16385, 1), (8192, 8193)] {
        let result = render(&scene, &frame, w, h, &s, &|_, _| {});
        assert!(matches!(result, Err(Error::InvalidArgument(_))), "{w}x{h}");
    }
}

fn point_light() -> Light {
    Light {
        name: "point".into(),
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity: 5.0,
        position: Vec3::new(0.3, 1.0, -0.2),
        direction: Vec3::NEG_Y,
        animation: None,
    }
}

fn one_texel(rgba: [u8; 4]) -> Texture {
    Texture {
        name: "texel".into(),
        width: 1,
        height: 1,
        rgba: rgba.to_vec(),
    }
}

/// Adds a 20 m x 20 m quad at height `y` with material `material` to `scene`.
fn add_sheet(scene: &mut Scene, y: f32, material: Material) {
    let mut sheet = scene.meshes[0].clone();
    sheet.positions.iter_mut().for_each(|p| p.y = y);
    sheet.material = scene.materials.len() as u32;
    scene.materials.push(material);
    scene.meshes.push(sheet);
    scene.objects[0].meshes.push(scene.meshes.len() as u32 - 1);
}

#[test]
fn alpha_masked_texels_are_holes_for_every_ray() {
    let s = settings(4, Bounces::Indirect(2), 8);
    let open = floor_scene(0.8, point_light());
    let reference = render_scene(&open, 16, &s);
    // A fully transparent sheet between the light, the camera and the floor changes nothing.
    let mut holed = open.clone();
    holed.textures.push(one_texel([255, 255, 255, 0]));
    add_sheet(
        &mut holed,
        0.5,
        Material {
            base_color_texture: Some(0),
            alpha_mode: AlphaMode::Mask(0.5),
            ..Material::default()
        },
    );
    assert_eq!(render_scene(&holed, 16, &s).total, reference.total);
    // An opaque texel blocks: the camera sees the sheet instead, lit from 0.5 m above.
    let mut solid = holed.clone();
    solid.textures[0] = one_texel([255, 255, 255, 255]);
    let images = render_scene(&solid, 16, &settings(4, Bounces::DirectOnly, 8));
    let centre = images.direct.get(8, 8).x;
    let view = solid.frame(0.0, 0).camera.view(16, 16);
    let d = view.ray_direction(8.5, 8.5);
    let hit = view.position + d * ((0.5 - view.position.y) / d.y);
    let r2 = (point_light().position - hit).length_squared();
    let want = 0.8 / std::f32::consts::PI * 5.0 * (0.5 / r2.sqrt()) / r2;
    assert!((centre - want).abs() < 0.02 * want, "{centre} vs {want}");
    // Opacity multiplies the texel's alpha: a clear (transmissive) material is a hole too,
    // with or without a texture.
    let mut glass = solid.clone();
    glass.materials[1].opacity = 0.1;
    assert_eq!(render_scene(&glass, 16, &s).total, reference.total);
    glass.materials[1].base_color_texture = None;
    assert_eq!(render_scene(&glass, 16, &s).total, reference.total);
}

#[test]
fn base_colour_texture_multiplies_the_albedo() {
    let s = settings(4, Bounces::DirectOnly, 2);
    let plain = floor_scene(0.8, point_light());
    let mut textured = plain.clone();
    textured.textures.push(one_texel([128, 64, 255, 255]));
    textured.materials[0].base_color_texture = Some(0);
    let a = render_scene(&plain, 16, &s);
    let b = render_scene(&textured, 16, &s);
    let texel = textured.textures[0].sample(Vec2::splat(0.5)).truncate();
    for (p, q) in a.direct.pixels.iter().zip(&b.direct.pixels) {
        assert!((*p * texel - *q).abs().max_element() <= 1e-5 * p.max_element());
    }
    assert!((a.albedo.get(3, 3) - Vec3::splat(0.8)).abs().max_element() < 1e-6);
}

#[test]
fn pass_size_does_not_change_the_image() {
    let scene = cornell::scene();
    let a = render_scene(&scene, 8, &settings(12, Bounces::Unlimited, 5));
    let b = render_scene(
        &scene,
        8,
        &ReferenceSettings {
            max_pass_spp: 1,
            ..settings(12, Bounces::Unlimited, 5)
        },
    );
    assert_eq!(a.total, b.total);
}

/// A horizontal square of half-size `r` at height `y`; normals up or down.
fn square(r: f32, y: f32, up: bool, material: u32) -> Mesh {
    let mut mesh = Mesh {
        name: "square".into(),
        positions: vec![
            Vec3::new(-r, y, -r),
            Vec3::new(-r, y, r),
            Vec3::new(r, y, r),
            Vec3::new(r, y, -r),
        ],
        uvs: vec![Vec2::ZERO; 4],
        indices: if up {
            vec![0, 1, 2, 0, 2, 3]
        } else {
            vec![0, 2, 1, 0, 3, 2]
        },
        material,
        ..Mesh::default()
    };
    mesh.compute_normals().unwrap();
    mesh
}

/// Irradiance at `x` (surface normal `n`) from a polygon of uniform radiance `l` that it
/// sees whole: Lambert's closed form, l/2 x the sum over edges of the angle they subtend
/// times the cosine of their plane with `n`.
fn polygon_irradiance(x: Vec3, n: Vec3, polygon: &[Vec3], l: f32) -> f32 {
    let mut sum = 0.0f64;
    for i in 0..polygon.len() {
        let a = (polygon[i] - x).normalize().as_dvec3();
        let b = (polygon[(i + 1) % polygon.len()] - x)
            .normalize()
            .as_dvec3();
        let angle = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += angle * a.cross(b).normalize().dot(n.as_dvec3());
    }
    (l as f64 * 0.5 * sum.abs()) as f32
}

/// An emissive square lamp (1 m, radiance 10, facing down, albedo 0.7 underneath) 1 m over a
/// 4 m floor of albedo 0.8, seen from below the lamp.
const LAMP: (f32, f32, f32, f32, f32) = (0.5, 1.0, 10.0, 0.7, 0.8);

fn lamp_scene() -> Scene {
    let (r, h, l, lamp_albedo, floor_albedo) = LAMP;
    let object = |name: &str, mesh| Object {
        name: name.into(),
        meshes: vec![mesh],
        transform: Mat4::IDENTITY,
        animation: None,
    };
    Scene {
        name: "lamp".into(),
        meshes: vec![square(2.0, 0.0, true, 0), square(r, h, false, 1)],
        materials: vec![
            Material {
                base_color: Vec3::splat(floor_albedo),
                ..Material::default()
            },
            Material {
                base_color: Vec3::splat(lamp_albedo),
                emission: Vec3::splat(l),
                ..Material::default()
            },
        ],
        objects: vec![object("floor", 0), object("lamp", 1)],
        cameras: vec![Camera {
            position: Vec3::new(0.0, 0.5, 0.0),
            target: Vec3::ZERO,
            vfov: 60f32.to_radians(),
            ..Camera::default()
        }],
        ..Scene::default()
    }
}

/// The lamp's direct irradiance on the floor at `x` (closed form).
fn lamp_irradiance(x: Vec3) -> f32 {
    let (r, h, l, _, _) = LAMP;
    let lamp = [
        Vec3::new(-r, h, -r),
        Vec3::new(-r, h, r),
        Vec3::new(r, h, r),
        Vec3::new(r, h, -r),
    ];
    polygon_irradiance(x, Vec3::Y, &lamp, l)
}

/// Irradiance on the floor at each of `points` after the lamp's light was reflected by the
/// floor and then by the lamp's underside (three reflections to the eye with the floor's own):
/// midpoint quadrature over the floor (80 x 80) and the lamp (20 x 20) of the closed-form
/// first reflection. Between parallel planes at distance h the kernel cos cos / d^2 is
/// h^2 / d^4, smooth on the 5 cm cells, so the quadrature is far more accurate than the
/// tolerance.
fn lamp_two_bounce_irradiance(points: &[Vec3]) -> Vec<f32> {
    let (r, h, _, lamp_albedo, floor_albedo) = LAMP;
    let grid = |half: f32, y: f32, n: usize| -> Vec<Vec3> {
        let cell = 2.0 * half / n as f32;
        (0..n * n)
            .map(|i| {
                let (ix, iz) = ((i % n) as f32, (i / n) as f32);
                Vec3::new(-half + (ix + 0.5) * cell, y, -half + (iz + 0.5) * cell)
            })
            .collect()
    };
    let floor = grid(2.0, 0.0, 80);
    let floor_cell = (4.0f64 / 80.0).powi(2);
    let lamp = grid(r, h, 20);
    let lamp_cell = (2.0 * r as f64 / 20.0).powi(2);
    let kernel = |a: Vec3, b: Vec3| {
        let d2 = (a - b).length_squared() as f64;
        (h as f64 * h as f64) / (d2 * d2)
    };
    // Radiance leaving the floor after its first reflection.
    let floor_radiance: Vec<f64> = floor
        .iter()
        .map(|&z| floor_albedo as f64 / std::f64::consts::PI * lamp_irradiance(z) as f64)
        .collect();
    // Radiance leaving the lamp's underside after reflecting the floor's light.
    let lamp_radiance: Vec<f64> = lamp
        .iter()
        .map(|&y| {
            let e: f64 = floor
                .iter()
                .zip(&floor_radiance)
                .map(|(&z, &lz)| lz * kernel(y, z) * floor_cell)
                .sum();
            lamp_albedo as f64 / std::f64::consts::PI * e
        })
        .collect();
    points
        .iter()
        .map(|&x| {
            lamp.iter()
                .zip(&lamp_radiance)
                .map(|(&y, &ly)| ly * kernel(x, y) * lamp_cell)
                .sum::<f64>() as f32
        })
        .collect()
}

/// Floor points under each pixel of a `size` x `size` view of the lamp scene (4 x 4 per
/// pixel), to average an expected value over the pixel.
fn floor_points(scene: &Scene, size: u32) -> Vec<[Vec3; 16]> {
    let view = scene.frame(0.0, 0).camera.view(size, size);
    (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f32, (i / size) as f32);
            std::array::from_fn(|k| {
                let (sx, sy) = ((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5);
                let d = view.ray_direction(x + sx / 4.0, y + sy / 4.0);
                view.position + d * (-view.position.y / d.y)
            })
        })
        .collect()
}

#[test]
fn an_emissive_lamp_over_a_floor_matches_closed_form_and_quadrature_at_every_bounce_setting() {
    let scene = lamp_scene();
    let size = 16;
    let points = floor_points(&scene, size);
    let (_, _, _, _, floor_albedo) = LAMP;
    let direct_want: Vec<f32> = points
        .iter()
        .map(|p| p.iter().map(|&x| lamp_irradiance(x)).sum::<f32>() / 16.0)
        .collect();
    let flat: Vec<Vec3> = points.iter().flatten().copied().collect();
    let two_bounce: Vec<f32> = lamp_two_bounce_irradiance(&flat)
        .chunks(16)
        .map(|c| c.iter().sum::<f32>() / 16.0)
        .collect();
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    for bounces in [
        Bounces::DirectOnly,
        Bounces::Indirect(1),
        Bounces::Indirect(2),
    ] {
        let images = render_scene(&scene, size, &settings(1024, bounces, 11));
        // Direct light is the lamp's light reflected once by the floor, as Mitsuba's
        // max_depth 2 has it (the floor sees the lamp whole, so Lambert's formula is exact).
        // Next-event estimation makes it smooth: per-pixel standard deviation about 1 % at
        // 1024 spp (measured worst of 256 pixels: 3 %), the bound is 5 %; the mean over the
        // pixels, 0.06 %, must be within 0.5 %.
        let ratio = mean(
            &direct_want
                .iter()
                .zip(&images.direct.pixels)
                .map(|(w, g)| g.x / (floor_albedo / PI * w))
                .collect::<Vec<_>>(),
        );
        assert!(
            (ratio - 1.0).abs() < 0.005,
            "{bounces}: direct / closed form {ratio}"
        );
        for (i, want) in direct_want.iter().enumerate() {
            let want = floor_albedo / PI * want;
            let got = images.direct.pixels[i].x;
            assert!(
                (got - want).abs() <= 0.05 * want,
                "{bounces}: direct pixel {i}: {got} vs {want}"
            );
            let e = images.emitter_irradiance.pixels[i].x;
            assert!(
                (e - want * PI / floor_albedo).abs() <= 0.05 * e,
                "{bounces}: {e}"
            );
        }
        // Two reflections to the eye need the floor to see the floor: none. Three (two
        // bounces) go floor - lamp underside - floor. The image means are compared (per pixel
        // the three-reflection paths are noisy: about 7 % at 1024 spp, 0.45 % for the mean of
        // 256 pixels, the bound 2 % is over four away).
        let indirect = mean(
            &images
                .indirect_irradiance
                .pixels
                .iter()
                .map(|p| p.x)
                .collect::<Vec<_>>(),
        );
        match bounces {
            Bounces::Indirect(2) => {
                let want = mean(&two_bounce);
                assert!(
                    (indirect - want).abs() <= 0.02 * want,
                    "two bounces: {indirect} vs {want}"
                );
            }
            _ => assert_eq!(indirect, 0.0, "{bounces}"),
        }
    }
    // The noise next-event estimation removes: at 64 spp the direct image's relative RMS
    // error measures 2.9 %; with cosine sampling alone it measured 22 % (the same scene, the
    // previous build, docs/reference.md), so the 8 % bound fails without it.
    let images = render_scene(&scene, size, &settings(64, Bounces::DirectOnly, 12));
    let rms = (direct_want
        .iter()
        .zip(&images.direct.pixels)
        .map(|(w, g)| {
            let w = floor_albedo / PI * w;
            ((g.x - w) / w).powi(2)
        })
        .sum::<f32>()
        / direct_want.len() as f32)
        .sqrt();
    assert!(
        rms < 0.08,
        "direct light at 64 spp: relative RMS error {rms}"
    );
}
