//! Sky light and one-sided emission in the reference path tracer: closed-form and
//! independently integrated values.

use glam::{Mat3, Mat4, Vec2, Vec3};
use octolux::image_io::HdrImage;
use octolux::reference::{render, Bounces, ReferenceImages, ReferenceSettings};
use octolux::scene::{
    cornell, uv_to_direction, Camera, EnvironmentMap, Material, Mesh, Object, Scene, Sky,
};
use std::f32::consts::PI;

fn settings(spp: u32, bounces: Bounces) -> ReferenceSettings {
    ReferenceSettings {
        spp,
        bounces,
        seed: 11,
        ..ReferenceSettings::default()
    }
}

fn reference(scene: &Scene, w: u32, h: u32, s: &ReferenceSettings) -> ReferenceImages {
    let frame = scene.frame(0.0, 0);
    render(scene, &frame, w, h, s, &|_, _| {}).unwrap()
}

fn mean(image: &HdrImage) -> Vec3 {
    image.pixels.iter().copied().sum::<Vec3>() / image.pixels.len() as f32
}

fn quad(name: &str, corners: [Vec3; 4], material: u32) -> Mesh {
    let mut mesh = Mesh {
        name: name.into(),
        positions: corners.to_vec(),
        uvs: vec![Vec2::ZERO; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        ..Mesh::default()
    };
    mesh.compute_normals();
    mesh
}

/// A 40 m square floor facing up, seen from 2 m above looking straight down.
fn floor(albedo: f32) -> Scene {
    let s = 20.0;
    Scene {
        name: "floor".into(),
        meshes: vec![quad(
            "floor",
            [
                Vec3::new(-s, 0.0, -s),
                Vec3::new(-s, 0.0, s),
                Vec3::new(s, 0.0, s),
                Vec3::new(s, 0.0, -s),
            ],
            0,
        )],
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
        cameras: vec![Camera {
            position: Vec3::new(0.0, 2.0, 0.0),
            target: Vec3::ZERO,
            up: Vec3::Z,
            vfov: 40f32.to_radians(),
            ..Camera::default()
        }],
        ..Scene::default()
    }
}

/// Under a constant sky of radiance L an open plane of albedo a reflects exactly a L (it sees
/// the sky over its whole hemisphere). Next-event estimation alone (direct only) and combined
/// with the escaping cosine rays (one bounce) both give it; nothing is indirect.
#[test]
fn constant_sky_over_a_plane_reflects_albedo_times_radiance() {
    let radiance = Vec3::new(0.5, 1.0, 2.0);
    let a = 0.6;
    let mut scene = floor(a);
    scene.sky = Some(Sky::constant(radiance));
    let want = radiance * a;
    // Direct only: uniform sphere sampling, per-sample deviation about 1.3 a L; 16x16 pixels x
    // 256 samples put the image mean's deviation at 0.2 %, five times below the bound.
    let direct = reference(&scene, 16, 16, &settings(256, Bounces::DirectOnly));
    let got = mean(&direct.direct);
    assert!(((got - want) / want).abs().max_element() < 0.01, "{got}");
    // With both strategies every sample is close to a L (cosine samples all escape).
    let both = reference(&scene, 16, 16, &settings(64, Bounces::Indirect(1)));
    let got = mean(&both.direct);
    assert!(((got - want) / want).abs().max_element() < 0.01, "{got}");
    for p in &both.direct.pixels {
        assert!(((*p - want) / want).abs().max_element() < 0.1, "{p}");
    }
    assert!(both.indirect.pixels.iter().all(|p| *p == Vec3::ZERO));
}

/// A white furnace open to the sky: the Cornell box (open at the front) with every surface of
/// albedo 1 under a constant sky L. Light is never absorbed, so with unlimited bounces every
/// pixel, surface or sky, is exactly L.
#[test]
fn open_white_cornell_box_under_a_constant_sky_is_a_furnace() {
    let mut scene = cornell::geometry();
    for m in &mut scene.materials {
        m.base_color = Vec3::ONE;
    }
    scene.cameras = vec![cornell::camera()];
    let radiance = Vec3::splat(1.5);
    scene.sky = Some(Sky::constant(radiance));
    // Paths bounce about twenty times before they leave, and Russian roulette (survival 0.95,
    // weight 1/0.95) makes single pixels noisy: at 256 samples they scatter by up to 17 % in
    // trials, while the image mean stays within 0.3 %.
    let images = reference(&scene, 16, 16, &settings(256, Bounces::Unlimited));
    let got = mean(&images.total);
    assert!(
        ((got - radiance) / radiance).abs().max_element() < 0.01,
        "{got}"
    );
    for p in &images.total.pixels {
        assert!(
            ((*p - radiance) / radiance).abs().max_element() < 0.3,
            "{p}"
        );
    }
    // One bounce less than everything: strictly darker inside the box.
    let one = reference(&scene, 16, 16, &settings(64, Bounces::Indirect(1)));
    assert!(mean(&one.total).x < 0.97 * radiance.x);
}

/// A sky map with a bright patch and a dim gradient, turned about y.
fn patchy_map_sky() -> Sky {
    let (w, h) = (64u32, 32u32);
    let mut image = HdrImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = if (20..26).contains(&x) && (6..10).contains(&y) {
                Vec3::new(30.0, 24.0, 16.0)
            } else {
                Vec3::new(0.2, 0.3, 0.6) * (1.0 - y as f32 / h as f32)
            };
            image.set(x, y, v);
        }
    }
    let mut sky = Sky::map(EnvironmentMap::from_image("patchy".into(), image).unwrap());
    sky.intensity = 0.5;
    sky.to_world = Mat3::from_rotation_y(1.1);
    sky
}

/// Irradiance on an upward-facing plane from `sky`, integrated on a fine grid over the
/// upper hemisphere through `Sky::radiance` (independent of the tracer's sampling).
fn upward_irradiance(sky: &Sky) -> Vec3 {
    let (nu, nv) = (1024, 512);
    let mut sum = glam::DVec3::ZERO;
    for j in 0..nv / 2 {
        for i in 0..nu {
            let uv = Vec2::new((i as f32 + 0.5) / nu as f32, (j as f32 + 0.5) / nv as f32);
            let d = uv_to_direction(uv);
            let d_omega = 2.0 * PI * PI * (uv.y * PI).sin() / (nu * nv) as f32;
            sum += (sky.radiance(d) * d.y * d_omega).as_dvec3();
        }
    }
    sum.as_vec3()
}

#[test]
fn sky_map_over_a_plane_matches_the_integrated_irradiance() {
    let sky = patchy_map_sky();
    let a = 0.5;
    let mut scene = floor(a);
    let want = upward_irradiance(&sky) * (a / PI);
    scene.sky = Some(sky);
    for bounces in [Bounces::DirectOnly, Bounces::Indirect(1)] {
        let images = reference(&scene, 16, 16, &settings(256, bounces));
        let got = mean(&images.direct);
        assert!(
            ((got - want) / want).abs().max_element() < 0.02,
            "{bounces}: {got} vs {want}"
        );
    }
}

/// A lamp quad 0.5 m over the floor: its front face (the side its normals point to) lights
/// the floor; turned over, the floor gets nothing, unless the material emits from both faces.
#[test]
fn emission_leaves_the_front_face_only_unless_two_sided() {
    let lamp = |facing_down: bool, two_sided: bool| {
        let mut scene = floor(0.5);
        scene.cameras[0].position = Vec3::new(0.0, 0.4, 0.0);
        let (y, h) = (0.5, 0.3);
        let mut corners = [
            Vec3::new(-h, y, -h),
            Vec3::new(-h, y, h),
            Vec3::new(h, y, h),
            Vec3::new(h, y, -h),
        ];
        if facing_down {
            corners.reverse();
        }
        scene.meshes.push(quad("lamp", corners, 1));
        scene.materials.push(Material {
            base_color: Vec3::ZERO,
            emission: Vec3::splat(4.0),
            emission_two_sided: two_sided,
            ..Material::default()
        });
        scene.objects[0].meshes.push(1);
        let images = reference(&scene, 8, 8, &settings(64, Bounces::Indirect(1)));
        mean(&images.indirect_irradiance).x
    };
    let down = lamp(true, false);
    let up = lamp(false, false);
    let up_two_sided = lamp(false, true);
    assert!(down > 1.0, "{down}");
    assert_eq!(up, 0.0);
    assert!(
        (up_two_sided - down).abs() < 0.05 * down,
        "{up_two_sided} vs {down}"
    );
}
