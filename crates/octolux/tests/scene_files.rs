//! The scene files shipped in `scenes/`: every one parses, the Cornell box file is the built-in
//! scene, and the animated one moves as its keys say.

use glam::{Quat, Vec3};
use octolux::scene::{cornell, file, LightKind, Scene};
use std::path::{Path, PathBuf};

fn scenes_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn scene_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(scenes_folder())
        .expect("the scenes/ folder ships with the repository")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

fn uses_shared_scenes(path: &Path) -> bool {
    std::fs::read_to_string(path)
        .map(|t| t.contains(&format!("\"{}", file::SCENES_PREFIX)))
        .unwrap_or(false)
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn every_shipped_scene_file_loads() {
    let files = scene_files();
    assert!(
        files.len() >= 7,
        "expected the shipped scene files, found {files:?}"
    );
    let shared = octolux::scene::scenes_dir().is_dir();
    for path in files {
        if uses_shared_scenes(&path) && !shared {
            println!(
                "skipping {}: the shared scenes folder ({}) is not there; set {} to check it",
                path.display(),
                octolux::scene::scenes_dir().display(),
                file::SCENES_ENV
            );
            continue;
        }
        // Every field is checked and every model file exists.
        file::model_files(&path).unwrap_or_else(|e| panic!("{e}"));
        match Scene::load(&path) {
            Ok(scene) => {
                assert!(scene.triangle_count() > 0, "{}", path.display());
                assert!(scene.has_light(), "{}", path.display());
                assert!(!scene.cameras.is_empty(), "{}", path.display());
                println!(
                    "{}: {} triangles, {} lights",
                    path.display(),
                    scene.triangle_count(),
                    scene.lights.len()
                );
            }
            Err(e) => panic!("{}: {e}", path.display()),
        }
    }
}

#[test]
fn cornell_box_file_is_the_builtin_scene() {
    let path = scenes_folder().join("cornell-box.toml");
    let scene = Scene::load(&path).unwrap();
    let expected = cornell::scene();
    assert_eq!(scene.name, expected.name);
    assert_eq!(scene.exposure, expected.exposure);
    assert_eq!(scene.meshes.len(), expected.meshes.len());
    for (a, b) in scene.meshes.iter().zip(&expected.meshes) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.normals, b.normals);
        assert_eq!(a.uvs, b.uvs);
        assert_eq!(a.indices, b.indices);
        assert_eq!(a.material, b.material);
    }
    assert_eq!(scene.materials.len(), expected.materials.len());
    for (a, b) in scene.materials.iter().zip(&expected.materials) {
        assert_eq!(
            (&a.name, a.base_color, a.emission, a.base_color_texture),
            (&b.name, b.base_color, b.emission, b.base_color_texture)
        );
    }
    assert_eq!(scene.objects.len(), expected.objects.len());
    for (a, b) in scene.objects.iter().zip(&expected.objects) {
        assert_eq!(
            (&a.name, &a.meshes, a.transform),
            (&b.name, &b.meshes, b.transform)
        );
        assert!(a.animation.is_none());
    }
    assert_eq!(scene.lights.len(), 1);
    let (a, b) = (&scene.lights[0], &expected.lights[0]);
    assert_eq!(a.name, b.name);
    assert_eq!(a.kind, b.kind);
    assert_eq!((a.color, a.intensity), (b.color, b.intensity));
    // Decimal metres in the file against millimetres x 0.001 in code: equal to float rounding.
    assert!(
        close(a.position, b.position),
        "{} vs {}",
        a.position,
        b.position
    );
    assert_eq!(a.direction, b.direction);
    assert!(a.animation.is_none());
    assert_eq!(scene.cameras.len(), 1);
    let (a, b) = (&scene.cameras[0], &expected.cameras[0]);
    assert_eq!(a.name, b.name);
    assert!(close(a.position, b.position) && close(a.target, b.target));
    assert_eq!((a.up, a.vfov, a.near, a.far), (b.up, b.vfov, b.near, b.far));
    assert!(a.animation.is_none());
}

#[test]
fn animated_cornell_box_moves_as_keyed() {
    let path = scenes_folder().join("cornell-animated.toml");
    let scene = Scene::load(&path).unwrap();
    assert!(scene.is_animated());
    let rest = Vec3::new(0.278, 0.538, 0.2796);
    let light = &scene.lights[0];
    assert_eq!(
        light.kind,
        LightKind::Spot {
            inner_angle: 45f32.to_radians(),
            outer_angle: 60f32.to_radians()
        }
    );
    // Keys: 0 s rest, 1 s 12 cm to -x turned -25 degrees about z, 3 s 12 cm to +x turned +25,
    // 4 s rest; looping every 4 s.
    let down = Vec3::NEG_Y;
    let tilted = |degrees: f32| {
        let r = degrees.to_radians();
        // -y turned about z by r: (sin r, -cos r, 0).
        Vec3::new(r.sin(), -r.cos(), 0.0)
    };
    let cases = [
        (0.0, rest, down),
        (0.5, rest + Vec3::new(-0.06, 0.0, 0.0), tilted(-12.5)),
        (1.0, rest + Vec3::new(-0.12, 0.0, 0.0), tilted(-25.0)),
        (2.0, rest, down),
        (2.5, rest + Vec3::new(0.06, 0.0, 0.0), tilted(12.5)),
        (4.0, rest, down),
        (4.5, rest + Vec3::new(-0.06, 0.0, 0.0), tilted(-12.5)),
        (-3.5, rest + Vec3::new(-0.06, 0.0, 0.0), tilted(-12.5)),
        (9.0, rest + Vec3::new(-0.12, 0.0, 0.0), tilted(-25.0)),
    ];
    for (t, position, direction) in cases {
        let l = light.at_time(t);
        assert!(
            close(l.position, position),
            "t = {t}: {} vs {position}",
            l.position
        );
        assert!(
            close(l.direction, direction),
            "t = {t}: {} vs {direction}",
            l.direction
        );
    }

    // Objects: the room and the tall block never move; the short block turns about the centre
    // of its footprint, 30 degrees about y and 5 cm to -x, 10 cm to +z at 2 s, back at 4 s.
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["room", "tall-block", "short-block"]);
    let corner = Vec3::new(0.130, 0.165, 0.065);
    let pivot = Vec3::new(0.186, 0.0, 0.1685);
    let moved = |degrees: f32, offset: Vec3| {
        Quat::from_rotation_y(degrees.to_radians()) * (corner - pivot) + pivot + offset
    };
    let cases = [
        (0.0, corner),
        (1.0, moved(15.0, Vec3::new(-0.025, 0.0, 0.05))),
        (2.0, moved(30.0, Vec3::new(-0.05, 0.0, 0.1))),
        (3.0, moved(15.0, Vec3::new(-0.025, 0.0, 0.05))),
        (4.0, corner),
        (6.0, moved(30.0, Vec3::new(-0.05, 0.0, 0.1))),
    ];
    for (t, expected) in cases {
        let frame = scene.frame(t, 0);
        let p = frame.object_transforms[2].transform_point3(corner);
        assert!(close(p, expected), "t = {t}: {p} vs {expected}");
        for still in &frame.object_transforms[..2] {
            assert!(still.abs_diff_eq(glam::Mat4::IDENTITY, 1e-6));
        }
    }
    // The moving block keeps clear of the tall block and the walls: sampled over the loop.
    for step in 0..=40 {
        let frame = scene.frame(step as f32 * 0.1, 0);
        let m = frame.object_transforms[2];
        for &p in &scene.meshes[scene.objects[2].meshes[0] as usize].positions {
            let w = m.transform_point3(p);
            assert!(w.x > 0.0 && w.z > 0.0 && w.x < 0.55 && w.z < 0.55, "{w}");
        }
    }
}

#[test]
fn scene_file_errors_name_the_file() {
    let tmp = tempfile::Builder::new()
        .prefix("octolux-scene-files-")
        .tempdir()
        .unwrap();
    let dir = tmp.path();
    let path = dir.join("broken.toml");
    std::fs::write(&path, "[[model]]\npath = \"meshes/missing.obj\"\n").unwrap();
    let err = Scene::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("broken.toml") && err.contains("meshes/missing.obj"),
        "{err}"
    );
    std::fs::write(
        &path,
        "[[model]]\npath = \"builtin:cornell-box\"\nspin = 3\n",
    )
    .unwrap();
    let err = Scene::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("broken.toml") && err.contains("spin") && err.contains("line 3"),
        "{err}"
    );
}

#[test]
fn camera_index_takes_an_index_or_a_name_and_rejects_others() {
    let mut scene = octolux::scene::cornell::scene();
    let first = scene.cameras[0].clone();
    scene.cameras.push(octolux::scene::Camera {
        name: "top".into(),
        ..first.clone()
    });
    assert_eq!(scene.camera_index("0").unwrap(), 0);
    assert_eq!(scene.camera_index("1").unwrap(), 1);
    assert_eq!(scene.camera_index(&first.name).unwrap(), 0);
    assert_eq!(scene.camera_index("top").unwrap(), 1);
    for bad in ["2", "side", "-1"] {
        let err = scene.camera_index(bad).unwrap_err().to_string();
        assert!(err.contains(&format!("no camera '{bad}'")), "{err}");
        assert!(err.contains("1 'top'"), "{err}");
    }
    // A scene without cameras is framed automatically: camera 0 only.
    scene.cameras.clear();
    assert_eq!(scene.camera_index("0").unwrap(), 0);
    assert!(scene.camera_index("1").is_err());
    // The renderer refuses a camera the scene does not have.
    let ctx = octolux::gpu::GpuContext::shared(&Default::default()).unwrap();
    let settings = octolux::render::RenderSettings {
        width: 8,
        height: 8,
        camera: 3,
        ..Default::default()
    };
    let err = octolux::render::Renderer::new(&ctx, &octolux::scene::cornell::scene(), settings)
        .err()
        .expect("camera 3 of a one-camera scene");
    assert!(err.to_string().contains("no camera '3'"), "{err}");
}

#[test]
fn a_material_override_can_take_a_texture() {
    let tmp = tempfile::Builder::new()
        .prefix("octolux-override-")
        .tempdir()
        .unwrap();
    let dir = tmp.path();
    let rgba = vec![
        255u8, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255,
    ];
    image::RgbaImage::from_raw(2, 2, rgba.clone())
        .unwrap()
        .save(dir.join("wood.png"))
        .unwrap();
    let write = |name: &str, material: &str| {
        let path = dir.join(name);
        std::fs::write(
            &path,
            format!("[[model]]\npath = \"builtin:cornell-box\"\nmaterial = {material}\n"),
        )
        .unwrap();
        path
    };
    let scene = Scene::load(write("t.toml", "{ texture = \"wood.png\" }")).unwrap();
    assert_eq!(scene.textures.len(), 1);
    assert_eq!(scene.textures[0].rgba, rgba);
    for m in &scene.materials {
        assert_eq!((m.base_color_texture, m.base_color), (Some(0), Vec3::ONE));
    }
    let tinted = Scene::load(write(
        "a.toml",
        "{ albedo = [0.5, 0.5, 0.5], texture = \"wood.png\" }",
    ))
    .unwrap();
    assert!(tinted
        .materials
        .iter()
        .all(|m| m.base_color == Vec3::splat(0.5) && m.base_color_texture == Some(0)));
    let err = Scene::load(write("m.toml", "{ texture = \"missing.png\" }"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("missing.png") && err.contains("not found"),
        "{err}"
    );
}

#[test]
fn obj_groups_and_materials_are_selectable_by_name() {
    let tmp = tempfile::Builder::new()
        .prefix("octolux-obj-select-")
        .tempdir()
        .unwrap();
    let dir = tmp.path();
    // A floor and a vase (glass body, clay foot) as OBJ groups, plus 25 small groups to show
    // that long name lists are cut short in errors.
    let mut obj = String::from(
        "mtllib parts.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n\
         v 0 0.1 0\nv 0.1 0.1 0\nv 0 0.5 0\nv 0.1 0.5 0\n\
         g floor\nusemtl clay\nf 1 4 3 2\n\
         g vase\nusemtl glass\nf 5 6 8 7\nusemtl clay\nf 5 6 7\n",
    );
    for i in 0..25 {
        obj.push_str(&format!("g pebble{i}\nusemtl clay\nf 5 7 6\n"));
    }
    std::fs::write(dir.join("parts.obj"), obj).unwrap();
    std::fs::write(
        dir.join("parts.mtl"),
        "newmtl clay\nKd 0.6 0.3 0.2\nnewmtl glass\nKd 0.9 0.9 0.9\nd 0.1\n",
    )
    .unwrap();
    let load = |name: &str, selection: &str| {
        let path = dir.join(name);
        std::fs::write(
            &path,
            format!(
                "[[model]]\nname = \"shop\"\npath = \"parts.obj\"\n{selection}\n\
                 [[light]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\nintensity = 1.0\n"
            ),
        )
        .unwrap();
        Scene::load(&path)
    };
    let names =
        |scene: &Scene| -> Vec<String> { scene.objects.iter().map(|o| o.name.clone()).collect() };
    let materials = |scene: &Scene| -> Vec<String> {
        scene
            .meshes
            .iter()
            .map(|m| scene.materials[m.material as usize].name.clone())
            .collect()
    };

    let all = load("all.toml", "").unwrap();
    assert_eq!(all.objects.len(), 27);
    assert_eq!(all.objects[0].name, "shop/floor");
    assert_eq!(all.objects[1].name, "shop/vase");

    // The vase only: one object named as the model.
    let vase = load("vase.toml", "objects = [\"vase\"]").unwrap();
    assert_eq!(names(&vase), ["shop"]);
    assert_eq!(materials(&vase), ["glass", "clay"]);

    // Drop the glass: the vase keeps its foot.
    let no_glass = load("no-glass.toml", "exclude_materials = [\"glass\"]").unwrap();
    assert_eq!(no_glass.objects.len(), 27);
    assert!(materials(&no_glass).iter().all(|m| m == "clay"));
    assert_eq!(no_glass.triangle_count(), all.triangle_count() - 2);

    // Only the glass: one object (the vase) with one mesh.
    let glass = load("glass.toml", "materials = [\"glass\"]").unwrap();
    assert_eq!(names(&glass), ["shop"]);
    assert_eq!(materials(&glass), ["glass"]);

    // Everything but the pebbles and the floor.
    let exclude: Vec<String> = (0..25).map(|i| format!("\"pebble{i}\"")).collect();
    let bare = load(
        "bare.toml",
        &format!("exclude_objects = [\"floor\", {}]", exclude.join(", ")),
    )
    .unwrap();
    assert_eq!(names(&bare), ["shop"]);
    assert_eq!(bare.triangle_count(), 3);

    // Unknown names: the error names the scene file and lists the model's names, cut short.
    let err = load("bad.toml", "objects = [\"chair\"]")
        .unwrap_err()
        .to_string();
    assert!(err.contains("bad.toml"), "{err}");
    assert!(
        err.contains("no object named 'chair'")
            && err.contains("'floor', 'vase', 'pebble0'")
            && err.contains("and 7 more"),
        "{err}"
    );
    let err = load("bad-material.toml", "exclude_materials = [\"steel\"]")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("no material named 'steel'") && err.contains("'clay', 'glass'"),
        "{err}"
    );
}

/// The scene-format document's example `[settings]` table is one the technique settings
/// accept (it once showed a key they reject).
#[test]
fn documented_settings_are_accepted() {
    let doc = include_str!("../../../docs/scene-format.md");
    let start = doc.find("```toml\n").unwrap() + "```toml\n".len();
    let end = start + doc[start..].find("```").unwrap();
    let table: toml::Table = toml::from_str(&doc[start..end]).unwrap();
    let settings = table["settings"].as_table().unwrap();
    let parsed = octolux::gi::GiSettings::from_table(settings, std::path::Path::new("doc"))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(parsed.lpv.size, 32);
}

/// `two-rooms-far-light` measures flicker on the premise that its circling light reaches
/// nothing the camera sees: the reference (same seed, so the same paths) is the same image,
/// bit for bit, wherever that light is, and the light itself moves.
#[test]
fn the_far_light_changes_nothing_the_camera_sees() {
    use octolux::reference::{self, ReferenceSettings};
    let scene = Scene::load(scenes_folder().join("two-rooms-far-light.toml")).unwrap();
    let far = scene
        .lights
        .iter()
        .position(|l| l.name == "far-light")
        .unwrap();
    let settings = ReferenceSettings {
        spp: 8,
        ..ReferenceSettings::default()
    };
    let render = |t: f32| {
        let frame = scene.frame(t, 0);
        let image = reference::render(&scene, &frame, 32, 24, &settings, &|_, _| {}).unwrap();
        (frame.lights[far].position, image.total.pixels)
    };
    let (p0, a) = render(0.0);
    assert!(
        a.iter().map(|p| p.element_sum()).sum::<f32>() > 0.0,
        "the left room is lit"
    );
    for t in [0.3, 0.77, 1.5] {
        let (p, b) = render(t);
        assert!(p.distance(p0) > 0.1, "the far light moves: {p} at {t} s");
        assert!(a == b, "the image changed with the far light at {t} s");
    }
}
