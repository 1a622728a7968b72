//! Mitsuba 3 XML import: one scene written at run time that uses every supported element,
//! checked against hand-computed positions, colours, lights, sky and cameras; errors that name
//! the file and position; the shipped example and the shared "cbox" scene; and a render of
//! the imported scene with the GPU renderer and the reference path tracer.

use glam::{Mat3, Vec3};
use octolux::image_io::HdrImage;
use octolux::scene::{srgb_to_linear, AlphaMode, LightKind, Scene, SkyRadiance};
use octolux::Error;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// A fresh, empty temporary folder for one test, removed when the returned guard drops.
fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-mitsuba-{name}-"))
        .tempdir()
        .unwrap()
}

fn write(path: &Path, bytes: impl AsRef<[u8]>) {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(path, bytes).unwrap();
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-4
}

fn assert_close(a: Vec3, b: Vec3) {
    assert!(close(a, b), "{a} != {b}");
}

const SCENE_XML: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<scene version="3.0.0">
    <default name="red" value="0.8, 0.1, 0.1"/>
    <default name="half" value="0.5"/>
    <default name="w" value="200"/>
    <default name="h" value="100"/>

    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <medium type="homogeneous" id="fog"/>

    <texture type="bitmap" id="wood"><string name="filename" value="tex.png"/></texture>
    <bsdf type="diffuse" id="red"><rgb name="reflectance" value="$red"/></bsdf>
    <bsdf type="twosided" id="white">
        <bsdf type="diffuse"><float name="reflectance" value="$half"/></bsdf>
    </bsdf>
    <bsdf type="roughplastic" id="plastic">
        <srgb name="diffuse_reflectance" value="0.5, 0.5, 0.5"/>
    </bsdf>
    <bsdf type="diffuse" id="textured"><ref name="reflectance" id="wood"/></bsdf>
    <bsdf type="roughconductor" id="gold"/>
    <bsdf type="dielectric" id="glass"/>

    <!-- A floor: the square scaled by 2, turned to face +y, lowered by 1. -->
    <shape type="rectangle" id="floor">
        <transform name="to_world">
            <scale value="2"/>
            <rotate x="1" angle="-90"/>
            <translate value="0 -1 0"/>
        </transform>
        <ref id="white"/>
    </shape>

    <shape type="cube" id="box">
        <transform name="to_world">
            <scale x="0.5" z="0.5"/>
            <translate x="1"/>
        </transform>
        <ref id="plastic"/>
    </shape>

    <shape type="sphere" id="ball">
        <point name="center" value="0, 1, 2"/>
        <float name="radius" value="0.25"/>
        <ref id="textured"/>
    </shape>

    <!-- An area light facing down at y = 3. -->
    <shape type="rectangle" id="lamp">
        <transform name="to_world">
            <rotate x="1" angle="90"/>
            <translate y="3"/>
        </transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="5, 4, 3"/></emitter>
    </shape>

    <shape type="obj" id="tri-obj">
        <string name="filename" value="tri.obj"/>
        <transform name="to_world">
            <matrix value="1 0 0 10  0 1 0 20  0 0 1 30  0 0 0 1"/>
        </transform>
        <ref id="gold"/>
    </shape>

    <!-- The emitter is declared after its use. -->
    <shape type="ply">
        <string name="filename" value="meshes/tri.ply"/>
        <ref id="red"/>
        <ref id="glow"/>
    </shape>

    <shape type="rectangle" id="pane">
        <ref id="glass"/>
    </shape>

    <shape type="serialized" id="unsupported-shape">
        <string name="filename" value="nothing.serialized"/>
    </shape>

    <emitter type="area" id="glow"><spectrum name="radiance" value="2"/></emitter>

    <emitter type="point" id="bulb">
        <point name="position" x="1" y="2" z="3"/>
        <rgb name="intensity" value="10"/>
    </emitter>
    <emitter type="spot" id="spot">
        <transform name="to_world">
            <lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/>
        </transform>
        <rgb name="intensity" value="1, 2, 3"/>
        <float name="cutoff_angle" value="30"/>
    </emitter>
    <emitter type="directional" id="sun">
        <vector name="direction" value="0, -2, 0"/>
        <spectrum name="irradiance" value="3"/>
    </emitter>
    <emitter type="envmap" id="sky">
        <string name="filename" value="sky.exr"/>
        <float name="scale" value="2"/>
        <transform name="to_world"><rotate y="1" angle="90"/></transform>
    </emitter>

    <sensor type="perspective" id="cam-x">
        <float name="fov" value="60"/>
        <float name="near_clip" value="0.1"/>
        <float name="far_clip" value="50"/>
        <transform name="to_world">
            <lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/>
        </transform>
        <film type="hdrfilm">
            <integer name="width" value="$w"/>
            <integer name="height" value="$h"/>
        </film>
    </sensor>
    <sensor type="perspective" id="cam-y">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="40"/>
        <transform name="to_world">
            <lookat origin="3, 0, 0" target="0, 0, 0" up="0, 0, 1"/>
        </transform>
    </sensor>
    <sensor type="perspective" id="cam-smaller">
        <string name="fov_axis" value="smaller"/>
        <float name="fov" value="30"/>
        <film type="hdrfilm">
            <integer name="width" value="100"/>
            <integer name="height" value="300"/>
        </film>
    </sensor>
</scene>
"#;

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

const TRI_PLY: &str = "ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 0
0 0 1
1 0 0
3 0 1 2
";

/// Colour texels of the 2x2 bitmap, top row first.
const TEX: [u8; 16] = [
    255, 0, 0, 255, 0, 255, 0, 255, //
    0, 0, 255, 255, 255, 255, 255, 255,
];

/// Writes the scene of [`SCENE_XML`] and its files into `dir`; returns the XML's path.
fn write_scene(dir: &Path) -> PathBuf {
    write(&dir.join("tri.obj"), TRI_OBJ);
    write(&dir.join("meshes/tri.ply"), TRI_PLY);
    image::RgbaImage::from_raw(2, 2, TEX.to_vec())
        .unwrap()
        .save(dir.join("tex.png"))
        .unwrap();
    let mut sky = HdrImage::new(8, 4);
    sky.pixels.fill(Vec3::new(0.5, 0.25, 1.0));
    sky.write_exr(&dir.join("sky.exr")).unwrap();
    let path = dir.join("scene.xml");
    write(&path, SCENE_XML);
    path
}

/// The world positions of object `name`'s vertices.
fn world_positions(scene: &Scene, name: &str) -> Vec<Vec3> {
    let object = scene
        .objects
        .iter()
        .find(|o| o.name == name)
        .unwrap_or_else(|| panic!("no object {name}"));
    object
        .meshes
        .iter()
        .flat_map(|&m| scene.meshes[m as usize].positions.iter())
        .map(|&p| object.transform.transform_point3(p))
        .collect()
}

/// The material of object `name` (its first mesh's).
fn material_of<'a>(scene: &'a Scene, name: &str) -> &'a octolux::scene::Material {
    let object = scene.objects.iter().find(|o| o.name == name).unwrap();
    &scene.materials[scene.meshes[object.meshes[0] as usize].material as usize]
}

#[test]
fn every_supported_element() {
    let tmp = temp_dir("all");
    let dir = tmp.path();
    let scene = Scene::load(write_scene(dir)).unwrap();
    assert_eq!(scene.name, "scene");
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(
        names,
        ["floor", "box", "ball", "lamp", "tri-obj", "shape5", "pane"]
    );

    // Shapes: transformed vertices.
    let floor = world_positions(&scene, "floor");
    let mut expected = vec![
        Vec3::new(-2.0, -1.0, 2.0),
        Vec3::new(2.0, -1.0, 2.0),
        Vec3::new(2.0, -1.0, -2.0),
        Vec3::new(-2.0, -1.0, -2.0),
    ];
    for p in &floor {
        let i = expected
            .iter()
            .position(|e| close(*e, *p))
            .unwrap_or_else(|| {
                panic!("floor vertex {p} is not one of {expected:?}");
            });
        expected.remove(i);
    }
    // The floor faces up (world normals, as renderers see them).
    let frame = scene.frame(0.0, 0);
    let triangles = scene.world_triangles(&frame);
    assert!(triangles[0].normals.iter().all(|n| close(*n, Vec3::Y)));

    let cube = world_positions(&scene, "box");
    assert_eq!(cube.len(), 24);
    let (lo, hi) = cube.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(l, h), p| (l.min(*p), h.max(*p)),
    );
    assert_close(lo, Vec3::new(0.5, -1.0, -0.5));
    assert_close(hi, Vec3::new(1.5, 1.0, 0.5));

    let ball = world_positions(&scene, "ball");
    assert!(ball.len() > 100);
    for p in &ball {
        assert!(
            ((*p - Vec3::new(0.0, 1.0, 2.0)).length() - 0.25).abs() < 1e-5,
            "{p}"
        );
    }

    let lamp = world_positions(&scene, "lamp");
    assert!(lamp.iter().all(|p| (p.y - 3.0).abs() < 1e-5));
    let lamp_object = scene.objects.iter().position(|o| o.name == "lamp").unwrap();
    let lamp_mesh = &scene.meshes[scene.objects[lamp_object].meshes[0] as usize];
    let normal = scene.objects[lamp_object]
        .transform
        .transform_vector3(lamp_mesh.normals[0]);
    assert_close(normal, Vec3::NEG_Y);

    let tri = world_positions(&scene, "tri-obj");
    assert_close(tri[1], Vec3::new(11.0, 20.0, 30.0));
    assert_close(tri[2], Vec3::new(10.0, 21.0, 30.0));
    let ply = world_positions(&scene, "shape5");
    assert_close(ply[2], Vec3::new(1.0, 0.0, 0.0));

    // Materials.
    let white = material_of(&scene, "floor");
    assert_eq!(white.name, "white");
    assert_close(white.base_color, Vec3::splat(0.5));
    let plastic = material_of(&scene, "box");
    assert_close(plastic.base_color, Vec3::splat(srgb_to_linear(0.5)));
    let textured = material_of(&scene, "ball");
    assert_close(textured.base_color, Vec3::ONE);
    let t = textured.base_color_texture.expect("a bitmap texture") as usize;
    assert_eq!(scene.textures[t].rgba, TEX);
    let lamp = material_of(&scene, "lamp");
    assert_close(lamp.base_color, Vec3::splat(0.2));
    assert_close(lamp.emission, Vec3::new(5.0, 4.0, 3.0));
    assert!(!lamp.emission_two_sided);
    let gold = material_of(&scene, "tri-obj");
    assert_close(gold.base_color, Vec3::splat(0.5));
    assert_eq!((gold.opacity, gold.alpha_mode), (1.0, AlphaMode::Opaque));
    let glowing = material_of(&scene, "shape5");
    assert_close(glowing.base_color, Vec3::new(0.8, 0.1, 0.1));
    assert_close(glowing.emission, Vec3::splat(2.0));
    let glass = material_of(&scene, "pane");
    assert_eq!(
        (glass.opacity, glass.alpha_mode),
        (0.0, AlphaMode::Mask(0.5))
    );
    // Only the lamp and the PLY triangle emit.
    let emissive = scene
        .materials
        .iter()
        .filter(|m| m.emission != Vec3::ZERO)
        .count();
    assert_eq!(emissive, 2);

    // Lights.
    assert_eq!(scene.lights.len(), 3);
    let bulb = &scene.lights[0];
    assert_eq!((bulb.name.as_str(), bulb.kind), ("bulb", LightKind::Point));
    assert_close(bulb.position, Vec3::new(1.0, 2.0, 3.0));
    assert_close(bulb.radiant(), Vec3::splat(10.0));
    let spot = &scene.lights[1];
    match spot.kind {
        LightKind::Spot {
            inner_angle,
            outer_angle,
        } => {
            assert!((outer_angle - 30f32.to_radians()).abs() < 1e-6);
            assert!((inner_angle - 22.5f32.to_radians()).abs() < 1e-6);
        }
        other => panic!("expected a spot, got {other:?}"),
    }
    assert_close(spot.position, Vec3::new(0.0, 5.0, 0.0));
    assert_close(spot.direction, Vec3::NEG_Y);
    assert_close(spot.radiant(), Vec3::new(1.0, 2.0, 3.0));
    let sun = &scene.lights[2];
    assert_eq!(sun.kind, LightKind::Directional);
    assert_close(sun.direction, Vec3::NEG_Y);
    assert_close(sun.radiant(), Vec3::splat(3.0));

    // Sky: the map, scaled, turned 90 degrees about y.
    let sky = scene.sky.as_ref().expect("the envmap");
    assert!(matches!(sky.radiance, SkyRadiance::Map(_)));
    assert_eq!(sky.intensity, 2.0);
    let r = Mat3::from_rotation_y(90f32.to_radians());
    for (a, b) in sky.to_world.to_cols_array().iter().zip(r.to_cols_array()) {
        assert!((a - b).abs() < 1e-6, "{} vs {r}", sky.to_world);
    }
    assert_close(sky.radiance(Vec3::X), Vec3::new(1.0, 0.5, 2.0));

    // Cameras: a look-at camera with the same origin, target and up, and Mitsuba's fov axis.
    assert_eq!(scene.cameras.len(), 3);
    let cam = &scene.cameras[0];
    assert_eq!(cam.name, "cam-x");
    assert_close(cam.position, Vec3::new(0.0, 1.0, 5.0));
    assert_close(cam.target, Vec3::new(0.0, 1.0, 4.0));
    assert_close(cam.up, Vec3::Y);
    assert!((cam.hfov.unwrap() - 60f32.to_radians()).abs() < 1e-6);
    // The 2:1 film gives the vertical angle.
    let vfov = 2.0 * (30f32.to_radians().tan() / 2.0).atan();
    assert!((cam.vfov - vfov).abs() < 1e-6);
    assert_eq!((cam.near, cam.far), (0.1, 50.0));
    // Mitsuba's image of this look-at has +x on the right and +y at the top.
    let view = cam.view(200, 100);
    assert!(view.ray_direction(199.5, 50.0).x > 0.4);
    assert!(view.ray_direction(100.0, 0.5).y > 0.2);
    let cam = &scene.cameras[1];
    assert_close(cam.position, Vec3::new(3.0, 0.0, 0.0));
    assert_close(cam.target, Vec3::new(2.0, 0.0, 0.0));
    assert_close(cam.up, Vec3::Z);
    assert_eq!(cam.hfov, None);
    assert!((cam.vfov - 40f32.to_radians()).abs() < 1e-6);
    assert_eq!((cam.near, cam.far), (0.01, 10000.0));
    // Looking along -x with +z up: image right is +y.
    assert!(cam.view(64, 64).ray_direction(63.5, 32.0).y > 0.2);
    // The smaller axis of a 100x300 film is x; the default pose looks along +z.
    let cam = &scene.cameras[2];
    assert!((cam.hfov.unwrap() - 30f32.to_radians()).abs() < 1e-6);
    assert_close(cam.position, Vec3::ZERO);
    assert_close(cam.target, Vec3::Z);
    // Mitsuba's identity camera has +x on the image's left.
    assert!(cam.view(64, 64).ray_direction(63.5, 32.0).x < -0.1);
}

#[test]
fn constant_sky_include_and_old_names() {
    let tmp = temp_dir("constant");
    let dir = tmp.path();
    write(&dir.join("tri.obj"), TRI_OBJ);
    write(
        &dir.join("parts/bsdfs.xml"),
        r#"<scene version="3.0.0">
            <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="$albedo"/></bsdf>
        </scene>"#,
    );
    // Version 0.6 names: toWorld, lookAt, fovAxis.
    write(
        &dir.join("old.xml"),
        r#"<scene version="0.6.0">
            <default name="albedo" value="0.25"/>
            <include filename="parts/bsdfs.xml"/>
            <shape type="obj">
                <string name="filename" value="tri.obj"/>
                <transform name="toWorld"><translate x="1"/></transform>
                <ref id="grey"/>
            </shape>
            <emitter type="constant"><rgb name="radiance" value="0.5, 0.6, 0.7"/></emitter>
            <sensor type="perspective">
                <string name="fovAxis" value="y"/>
                <float name="fov" value="50"/>
                <transform name="toWorld">
                    <lookAt origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/>
                </transform>
            </sensor>
        </scene>"#,
    );
    let scene = Scene::load(dir.join("old.xml")).unwrap();
    assert_close(
        world_positions(&scene, "shape0")[1],
        Vec3::new(2.0, 0.0, 0.0),
    );
    assert_close(material_of(&scene, "shape0").base_color, Vec3::splat(0.25));
    let sky = scene.sky.as_ref().unwrap();
    assert!(matches!(sky.radiance, SkyRadiance::Constant(c) if close(c, Vec3::new(0.5, 0.6, 0.7))));
    let cam = &scene.cameras[0];
    assert_eq!(cam.hfov, None);
    assert_close(cam.target, Vec3::new(0.0, 0.0, 3.0));
}

fn expect_parse_error(result: octolux::Result<Scene>, file: &str) -> String {
    match result {
        Err(e @ Error::Parse { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(file), "error does not name {file}: {msg}");
            msg
        }
        Err(e) => panic!("expected a parse error, got {e}"),
        Ok(_) => panic!("expected a parse error, got a scene"),
    }
}

#[test]
fn errors_name_the_file_and_position() {
    let tmp = temp_dir("errors");
    let dir = tmp.path();
    let load = |name: &str, text: &str| {
        let path = dir.join(name);
        write(&path, text);
        Scene::load(&path)
    };
    // Malformed XML.
    let msg = expect_parse_error(
        load(
            "broken.xml",
            "<scene version=\"3.0.0\">\n  <shape type=\"cube\">\n</scene>\n",
        ),
        "broken.xml",
    );
    assert!(msg.contains("line 3"), "{msg}");
    // Not a scene.
    let msg = expect_parse_error(load("other.xml", "<html/>"), "other.xml");
    assert!(msg.contains("<scene>"), "{msg}");
    // A missing mesh file: the XML file, the line and the mesh file are named.
    let msg = expect_parse_error(
        load(
            "missing.xml",
            "<scene version=\"3.0.0\">\n<shape type=\"obj\">\n\
             <string name=\"filename\" value=\"gone.obj\"/>\n</shape>\n</scene>",
        ),
        "missing.xml",
    );
    assert!(msg.contains("line 2") && msg.contains("gone.obj"), "{msg}");
    // A mesh file of the other format (an OBJ shape naming a PLY loaded as empty).
    write(
        &dir.join("tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    );
    let msg = expect_parse_error(
        load(
            "mixed.xml",
            "<scene version=\"3.0.0\">\n<shape type=\"obj\">\n\
             <string name=\"filename\" value=\"tri.ply\"/>\n</shape>\n</scene>",
        ),
        "mixed.xml",
    );
    assert!(msg.contains("tri.ply") && msg.contains(".obj"), "{msg}");
    // A bad number.
    let msg = expect_parse_error(
        load(
            "number.xml",
            "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n\
             <float name=\"radius\" value=\"big\"/>\n</shape>\n</scene>",
        ),
        "number.xml",
    );
    assert!(msg.contains("line 3") && msg.contains("big"), "{msg}");
    // An undefined parameter and a dangling reference.
    let msg = expect_parse_error(
        load(
            "param.xml",
            "<scene version=\"3.0.0\"><shape type=\"cube\">\
             <float name=\"x\" value=\"$nope\"/></shape></scene>",
        ),
        "param.xml",
    );
    assert!(msg.contains("$nope"), "{msg}");
    let msg = expect_parse_error(
        load(
            "ref.xml",
            "<scene version=\"3.0.0\"><shape type=\"cube\"><ref id=\"nope\"/></shape></scene>",
        ),
        "ref.xml",
    );
    assert!(msg.contains("'nope'"), "{msg}");
    // A broken mesh file: the XML file is named, and the mesh file in the message.
    write(
        &dir.join("bad.ply"),
        "ply\nformat ascii 1.0\nelement vertex x\n",
    );
    let msg = expect_parse_error(
        load(
            "badmesh.xml",
            "<scene version=\"3.0.0\"><shape type=\"ply\">\
             <string name=\"filename\" value=\"bad.ply\"/></shape></scene>",
        ),
        "badmesh.xml",
    );
    assert!(msg.contains("bad.ply"), "{msg}");
    // A bsdf that contains itself.
    let msg = expect_parse_error(
        load(
            "loop.xml",
            "<scene version=\"3.0.0\"><bsdf type=\"twosided\" id=\"a\"><ref id=\"a\"/></bsdf>\
             <shape type=\"cube\"><ref id=\"a\"/></shape></scene>",
        ),
        "loop.xml",
    );
    assert!(msg.contains("contains itself"), "{msg}");
    // A missing include.
    let msg = expect_parse_error(
        load(
            "include.xml",
            "<scene version=\"3.0.0\"><include filename=\"nowhere.xml\"/></scene>",
        ),
        "include.xml",
    );
    assert!(msg.contains("nowhere.xml"), "{msg}");
}

#[test]
fn shipped_example_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/mitsuba-example.xml");
    let scene = Scene::load(&path).unwrap();
    assert!(scene.triangle_count() > 0);
    assert!(scene.has_light());
    assert_eq!(scene.cameras.len(), 1);
    assert!(scene.sky.is_some());
}

#[test]
fn shared_cbox_scene() {
    let dir = octolux::scene::scenes_dir().join("cornell-box-mitsuba");
    if !dir.is_dir() {
        println!("{} not found (set OCTOLUX_SCENES); skipped", dir.display());
        return;
    }
    let scene = Scene::load(dir.join("cbox-rgb.xml")).unwrap();
    assert_eq!(scene.objects.len(), 8);
    assert_eq!(scene.triangle_count(), 38);
    let light = scene
        .materials
        .iter()
        .find(|m| m.emission != Vec3::ZERO)
        .unwrap();
    assert_close(light.emission, Vec3::new(18.387, 10.9873, 2.75357));
    assert_close(light.base_color, Vec3::new(0.936461, 0.740433, 0.705267));
    let cam = &scene.cameras[0];
    assert_close(cam.position, Vec3::new(278.0, 273.0, -800.0));
    assert_close(cam.target, Vec3::new(278.0, 273.0, -799.0));
    // "smaller" of a square film is x.
    assert!((cam.hfov.unwrap() - 39.3077f32.to_radians()).abs() < 1e-6);
    // The spectral variant: reflectances converted to RGB (red wall reddish).
    let spectral = Scene::load(dir.join("cbox.xml")).unwrap();
    let red = spectral.materials.iter().find(|m| m.name == "red").unwrap();
    assert!(
        red.base_color.x > 2.0 * red.base_color.y && red.base_color.x > 2.0 * red.base_color.z,
        "{}",
        red.base_color
    );
}

#[test]
fn imported_scene_renders_on_the_gpu_and_with_the_reference() {
    let tmp = temp_dir("render");
    let dir = tmp.path();
    let scene = Scene::load(write_scene(dir)).unwrap();
    let ctx = octolux::gpu::GpuContext::shared(&octolux::gpu::GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let settings = octolux::render::RenderSettings {
        width: 16,
        height: 12,
        ..Default::default()
    };
    let mut renderer = octolux::render::Renderer::new(&ctx, &scene, settings).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let image = renderer.read_hdr().unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
    assert!(image.pixels.iter().any(|p| p.max_element() > 0.0));

    let frame = scene.frame(0.0, 0);
    let reference = octolux::reference::render(
        &scene,
        &frame,
        16,
        12,
        &octolux::reference::ReferenceSettings {
            spp: 2,
            ..Default::default()
        },
        &|_, _| {},
    )
    .unwrap();
    assert!(reference.total.pixels.iter().all(|p| p.is_finite()));
    assert!(reference.total.pixels.iter().any(|p| p.max_element() > 0.0));
}
