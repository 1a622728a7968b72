//! Opacity and transmission, treated alike by every pass: MTL `d`/`Tr` become opacity, and a
//! clear sheet changes nothing for the GPU renderer (camera, shadows), the voxelizer or the
//! reference, while an opaque one blocks.

use glam::{Mat4, Vec2, Vec3};
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::reference::{self, ReferenceSettings};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{
    AlphaMode, Camera, Light, LightKind, Material, Mesh, Object, Scene, SceneFrame,
};
use octolux::transport::Bounces;
use octolux::voxel::scene_triangles;
use tempfile::TempDir;

/// A fresh, empty temporary folder for one test, removed when the returned guard drops.
fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-materials-{name}-"))
        .tempdir()
        .unwrap()
}

#[test]
fn mtl_dissolve_and_transparency_become_opacity() {
    let tmp = temp_dir("mtl");
    let dir = tmp.path();
    std::fs::write(
        dir.join("glass.obj"),
        "mtllib glass.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl window\nf 1 2 3\n\
         usemtl tinted\nf 1 3 2\nusemtl wall\nf 2 1 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("glass.mtl"),
        "newmtl window\nKd 1 1 1\nd 0.1\nnewmtl tinted\nKd 1 1 1\nTr 0.25\nnewmtl wall\nKd 0.5 0.5 0.5\n",
    )
    .unwrap();
    let scene = Scene::load_model(dir.join("glass.obj")).unwrap();
    let material = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    let window = material("window");
    assert_eq!(
        (window.opacity, window.alpha_mode),
        (0.1, AlphaMode::Mask(0.5))
    );
    assert!(window.is_clear());
    let tinted = material("tinted");
    assert_eq!(tinted.opacity, 0.75);
    assert!(!tinted.is_clear(), "lets through less than half: opaque");
    let wall = material("wall");
    assert_eq!((wall.opacity, wall.alpha_mode), (1.0, AlphaMode::Opaque));
}

fn quad(y: f32, half: f32, material: u32) -> Mesh {
    Mesh {
        name: format!("quad-{y}"),
        positions: vec![
            Vec3::new(-half, y, -half),
            Vec3::new(-half, y, half),
            Vec3::new(half, y, half),
            Vec3::new(half, y, -half),
        ],
        normals: vec![Vec3::Y; 4],
        uvs: vec![Vec2::ZERO; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// A floor lit by a point light above it, seen from above, with a sheet of opacity `opacity`
/// (masked at 0.5) halfway between.
fn sheet_scene(opacity: Option<f32>) -> Scene {
    let mut scene = Scene {
        name: "sheet".into(),
        meshes: vec![quad(0.0, 2.0, 0)],
        materials: vec![Material {
            base_color: Vec3::splat(0.7),
            ..Material::default()
        }],
        objects: vec![Object {
            name: "all".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        lights: vec![Light {
            name: "bulb".into(),
            kind: LightKind::Point,
            color: Vec3::ONE,
            intensity: 2.0,
            position: Vec3::new(0.0, 1.0, 0.0),
            direction: Vec3::NEG_Y,
            animation: None,
        }],
        cameras: vec![Camera {
            position: Vec3::new(0.0, 1.5, 0.01),
            target: Vec3::ZERO,
            vfov: 50f32.to_radians(),
            ..Camera::default()
        }],
        ..Scene::default()
    };
    if let Some(opacity) = opacity {
        scene.meshes.push(quad(0.5, 0.3, 1));
        scene.materials.push(Material {
            base_color: Vec3::splat(0.9),
            opacity,
            alpha_mode: AlphaMode::Mask(0.5),
            ..Material::default()
        });
        scene.objects[0].meshes.push(1);
    }
    scene
}

fn gpu_image(scene: &Scene) -> Vec<Vec3> {
    let ctx = GpuContext::shared(&GpuOptions::default()).expect("a GPU adapter");
    let mut renderer = Renderer::new(
        &ctx,
        scene,
        RenderSettings {
            width: 24,
            height: 24,
            shadow_map_size: 256,
            ..RenderSettings::default()
        },
    )
    .unwrap();
    renderer.render(scene, 0.0).unwrap();
    renderer.read_hdr().unwrap().pixels
}

#[test]
fn a_clear_sheet_is_invisible_to_every_pass_and_an_opaque_one_blocks() {
    let open = sheet_scene(None);
    let clear = sheet_scene(Some(0.1));
    let solid = sheet_scene(Some(0.9));
    // GPU: camera and shadow map.
    let (a, b, c) = (gpu_image(&open), gpu_image(&clear), gpu_image(&solid));
    assert_eq!(a, b, "a clear sheet changes nothing on the GPU");
    assert_ne!(a, c, "an opaque sheet shows and casts a shadow");
    // Voxels: the clear sheet's triangles are left out.
    let frame: SceneFrame = clear.frame(0.0, 0);
    assert_eq!(scene_triangles(&clear, &frame).len(), 2);
    assert_eq!(scene_triangles(&solid, &solid.frame(0.0, 0)).len(), 4);
    // Reference.
    let settings = ReferenceSettings {
        spp: 4,
        bounces: Bounces::Indirect(1),
        ..ReferenceSettings::default()
    };
    let trace = |scene: &Scene| {
        reference::render(scene, &scene.frame(0.0, 0), 12, 12, &settings, &|_, _| {})
            .unwrap()
            .total
    };
    assert_eq!(trace(&open), trace(&clear));
    assert_ne!(trace(&open), trace(&solid));
}
