//! End-to-end tests of the `octolux` command: outputs, `--stats`, and clear errors (non-zero
//! exit, no panic) for bad input.

use std::path::PathBuf;
use std::process::{Command, Output};
use tempfile::TempDir;

fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(args)
        .output()
        .expect("run octolux")
}

/// A fresh, empty scratch folder named after `name`, removed when the returned guard drops.
fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-cli-{name}-"))
        .tempdir()
        .unwrap()
}

/// Asserts a clean failure: exit code 1, an `error:` line containing every `needle`, no panic.
fn assert_fails_with(output: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
}

#[test]
fn renders_the_default_scene_with_stats() {
    let tmp = temp_dir("stats");
    let dir = tmp.path();
    let png = dir.join("cornell.png");
    let exr = dir.join("cornell.exr");
    // The default technique without its warm-up frames: what is checked is the report.
    let output = octolux(&[
        "render",
        "--warmup",
        "0",
        "--width",
        "64",
        "--height",
        "64",
        "--stats",
        "--out",
        png.to_str().unwrap(),
        "--exr",
        exr.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for needle in [
        "pass times",
        "shadow maps",
        "gbuffer",
        "direct light",
        "compose",
        "GPU memory by owner",
        "shadow-maps",
        "total",
    ] {
        assert!(
            stdout.contains(needle),
            "'{needle}' missing from:\n{stdout}"
        );
    }
    let image = octolux::image_io::HdrImage::read_exr(&exr).unwrap();
    assert_eq!((image.width, image.height), (64, 64));
    assert!(std::fs::metadata(&png).unwrap().len() > 100);
}

#[test]
fn animated_frames_are_numbered() {
    let tmp = temp_dir("frames");
    let dir = tmp.path();
    let out = dir.join("f.png");
    let output = octolux(&[
        "render",
        "--gi",
        "none",
        "--width",
        "16",
        "--height",
        "16",
        "--frames",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for i in 0..3 {
        assert!(dir.join(format!("f_{i:04}.png")).exists());
    }
}

#[test]
fn zero_width_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "--width", "0"]),
        &["0x360", "at least 1"],
    );
}

#[test]
fn absurd_size_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "--width", "100000", "--height", "100000"]),
        &["100000x100000", "too large"],
    );
}

#[test]
fn cameras_are_chosen_by_index_or_name_and_others_are_errors() {
    let tmp = temp_dir("camera");
    let dir = tmp.path();
    let out = dir.join("c.png");
    let out = out.to_str().unwrap();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    for camera in ["0", "front"] {
        let output = octolux(&[
            "render", scene, "--camera", camera, "--gi", "none", "--width", "8", "--height", "8",
            "--out", out,
        ]);
        assert!(output.status.success(), "--camera {camera}: {output:?}");
    }
    for camera in ["1", "top"] {
        assert_fails_with(
            &octolux(&["render", scene, "--camera", camera, "--out", out]),
            &[&format!("no camera '{camera}'"), "0 'front'"],
        );
    }
    assert_fails_with(
        &octolux(&["bench", "--camera", "3", "--no-reference"]),
        &["--camera 3", "no camera '3'"],
    );
}

#[test]
fn exposure_flag_replaces_the_scene_exposure() {
    // +2 EV makes the display image brighter, -2 EV darker; a non-finite EV is an error.
    let tmp = temp_dir("exposure");
    let dir = tmp.path();
    let mean = |ev: &str| {
        let out = dir.join(format!("e{ev}.png"));
        let output = octolux(&[
            "render",
            "--gi",
            "none",
            "--exposure",
            ev,
            "--width",
            "24",
            "--height",
            "24",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(output.status.success(), "{output:?}");
        let image = octolux::metrics::load_image(&out).unwrap();
        image.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>()
    };
    let (dark, normal, bright) = (mean("-2"), mean("0"), mean("2"));
    assert!(dark < normal && normal < bright, "{dark} {normal} {bright}");
    assert_fails_with(
        &octolux(&["render", "--exposure", "inf", "--out", "x.png"]),
        &["--exposure", "finite"],
    );
}

#[test]
fn missing_scene_file_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "/nonexistent/scene.toml"]),
        &["/nonexistent/scene.toml", "not found"],
    );
}

#[test]
fn unknown_scene_extension_is_an_error() {
    let tmp = temp_dir("ext");
    let dir = tmp.path();
    let path = dir.join("model.xyz");
    std::fs::write(&path, "hello").unwrap();
    assert_fails_with(
        &octolux(&["render", path.to_str().unwrap()]),
        &["model.xyz", "unknown scene format"],
    );
}

#[test]
fn unknown_output_format_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "--out", "image.bmp"]),
        &["image.bmp", ".png or .exr"],
    );
}

#[test]
fn unknown_technique_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "--width", "8", "--height", "8", "--gi", "magic"]),
        &["magic", "none"],
    );
}

#[test]
fn unknown_adapter_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "--adapter", "no-such-gpu-anywhere"]),
        &["no-such-gpu-anywhere", "available"],
    );
}

#[test]
fn reference_writes_direct_indirect_and_total() {
    let tmp = temp_dir("reference");
    let dir = tmp.path();
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let output = octolux(&[
        "render",
        "--gi",
        "reference",
        "--bounces",
        "1",
        "--spp",
        "4",
        "--width",
        "24",
        "--height",
        "24",
        "--out",
        &p("total.png"),
        "--exr",
        &p("total.exr"),
        "--direct-exr",
        &p("direct.exr"),
        "--indirect-exr",
        &p("indirect.exr"),
        "--irradiance-exr",
        &p("irradiance.exr"),
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let read = |n: &str| octolux::image_io::HdrImage::read_exr(&dir.join(n)).unwrap();
    let (total, direct, indirect) = (read("total.exr"), read("direct.exr"), read("indirect.exr"));
    assert!(indirect.pixels.iter().any(|p| p.max_element() > 0.0));
    for i in 0..total.pixels.len() {
        let sum = direct.pixels[i] + indirect.pixels[i];
        assert!((total.pixels[i] - sum).abs().max_element() <= 1e-5 * sum.max_element().max(1.0));
    }
    assert_eq!(read("irradiance.exr").width, 24);
    assert!(dir.join("total.png").exists());
}

#[test]
fn bad_bounces_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "--gi", "reference", "--bounces", "lots"]),
        &["lots", "unlimited"],
    );
}

#[test]
fn bench_prints_a_table_and_json() {
    let tmp = temp_dir("bench");
    let dir = tmp.path();
    let json = dir.join("bench.json");
    let output = octolux(&[
        "bench",
        "--gi",
        "none",
        "--width",
        "24",
        "--height",
        "16",
        "--spp",
        "4",
        "--warmup",
        "0",
        "--frames",
        "2",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for needle in [
        "technique",
        "GI total ms",
        "frame ms",
        "FLIP",
        "relMSE",
        "none",
        "reference (direct)",
        "per-pass ms",
    ] {
        assert!(
            stdout.contains(needle),
            "'{needle}' missing from:\n{stdout}"
        );
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let technique = &report["scenes"][0]["techniques"][0];
    assert_eq!(technique["technique"], "none");
    assert_eq!(technique["reference"], "direct");
    assert!(technique["metrics"]["flip"].as_f64().unwrap() >= 0.0);
    assert!(technique["total_mib"].as_f64().unwrap() > 0.0);
    let passes: Vec<&str> = technique["passes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        passes,
        ["shadow maps", "gbuffer", "direct light", "compose"]
    );
}

#[test]
fn diff_of_mismatched_sizes_is_an_error() {
    let tmp = temp_dir("diff");
    let dir = tmp.path();
    let a = dir.join("a.exr");
    let b = dir.join("b.exr");
    octolux::image_io::HdrImage::new(4, 4)
        .write_exr(&a)
        .unwrap();
    octolux::image_io::HdrImage::new(5, 4)
        .write_exr(&b)
        .unwrap();
    assert_fails_with(
        &octolux(&["diff", a.to_str().unwrap(), b.to_str().unwrap()]),
        &["4x4", "5x4"],
    );
    assert_fails_with(
        &octolux(&["diff", a.to_str().unwrap(), "/nonexistent.exr"]),
        &["/nonexistent.exr"],
    );
}

#[test]
fn diff_prints_metrics_as_a_table_and_json() {
    let tmp = temp_dir("diff-ok");
    let dir = tmp.path();
    let a = dir.join("a.exr");
    let mut image = octolux::image_io::HdrImage::new(8, 8);
    image.set(3, 3, glam::Vec3::ONE);
    image.write_exr(&a).unwrap();
    let output = octolux(&["diff", a.to_str().unwrap(), a.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success() && stdout.contains("FLIP") && stdout.contains("relMSE"),
        "{stdout}"
    );
    let output = octolux(&["diff", a.to_str().unwrap(), a.to_str().unwrap(), "--json"]);
    let value: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(value["flip"].as_f64(), Some(0.0));
    // One pixel of 64 off: it holds all of relMSE, the median pixel none.
    let b = dir.join("b.exr");
    image.set(5, 1, glam::Vec3::splat(3.0));
    image.write_exr(&b).unwrap();
    let output = octolux(&["diff", b.to_str().unwrap(), a.to_str().unwrap(), "--json"]);
    let value: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let spread = &value["rel_mse_distribution"];
    assert_eq!(spread["p50"].as_f64(), Some(0.0), "{value}");
    assert_eq!(spread["worst_1_percent"].as_f64(), Some(1.0), "{value}");
    let output = octolux(&["diff", b.to_str().unwrap(), a.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("worst 1 % of pixels 100.0 %"), "{stdout}");
}

/// Writes `files` into a fresh folder and renders the first one at a tiny size without GI (the
/// loaders are the subject): the output, the image's path and the folder, which is removed when
/// dropped.
fn render_files(name: &str, files: &[(&str, &str)]) -> (Output, PathBuf, TempDir) {
    let tmp = temp_dir(name);
    let dir = tmp.path();
    for (file, text) in files {
        std::fs::write(dir.join(file), text).unwrap();
    }
    let scene = dir.join(files[0].0);
    let out = dir.join("out.exr");
    let output = octolux(&[
        "render",
        scene.to_str().unwrap(),
        "--gi",
        "none",
        "--width",
        "16",
        "--height",
        "16",
        "--out",
        out.to_str().unwrap(),
    ]);
    (output, out, tmp)
}

#[test]
fn malformed_toml_is_an_error() {
    let (output, ..) = render_files(
        "bad-toml",
        &[("scene.toml", "name = \"x\"\n[[light]\ntype = \"point\"\n")],
    );
    assert_fails_with(&output, &["scene.toml", "line"]);
}

#[test]
fn malformed_obj_is_an_error() {
    let (output, ..) = render_files(
        "bad-obj",
        &[("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")],
    );
    assert_fails_with(&output, &["m.obj"]);
}

#[test]
fn malformed_gltf_is_an_error() {
    let (output, ..) = render_files("bad-gltf", &[("m.gltf", "{ \"asset\": { \"version\": ")]);
    assert_fails_with(&output, &["m.gltf"]);
}

#[test]
fn nan_vertex_is_an_error() {
    let (output, ..) = render_files(
        "nan",
        &[("m.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")],
    );
    assert_fails_with(&output, &["non-finite"]);
}

#[test]
fn scene_without_geometry_is_an_error() {
    let (output, ..) = render_files("empty", &[("m.obj", "# nothing here\n")]);
    assert_fails_with(&output, &["no geometry"]);
}

#[test]
fn unlit_scene_renders_black_with_a_warning() {
    let (output, out, _dir) = render_files(
        "unlit",
        &[("m.obj", "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n")],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("no lights"), "{stderr}");
    let image = octolux::image_io::HdrImage::read_exr(&out).unwrap();
    assert!(image.pixels.iter().all(|p| *p == glam::Vec3::ZERO));
}

#[test]
fn missing_texture_falls_back_to_the_factor_with_a_warning() {
    let (output, ..) = render_files(
        "missing-texture",
        &[
            (
                "m.obj",
                "mtllib m.mtl\nusemtl red\nv -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n",
            ),
            (
                "m.mtl",
                "newmtl red\nKd 0.8 0.1 0.1\nKe 1 1 1\nmap_Kd nowhere.png\n",
            ),
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("nowhere.png"), "{stderr}");
}

#[test]
fn no_adapter_says_how_to_install_a_driver() {
    // Restricting wgpu to GL leaves no Vulkan/Metal/DX12 adapter, as on a machine without a
    // driver.
    let output = Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(["render", "--width", "8", "--height", "8"])
        .env("WGPU_BACKEND", "gl")
        .output()
        .unwrap();
    assert_fails_with(&output, &["no GPU adapter", "mesa-vulkan-drivers"]);
}

#[test]
fn frame_n_of_an_animation_matches_its_time() {
    let tmp = temp_dir("frame-n");
    let dir = tmp.path();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let by_frame = dir.join("a.exr");
    let by_time = dir.join("b.exr");
    let first = dir.join("c.exr");
    for (extra, out) in [
        (["--frame", "45"], &by_frame),
        (["--time", "1.5"], &by_time),
        (["--frame", "0"], &first),
    ] {
        let mut args = vec![
            "render",
            scene,
            "--gi",
            "none",
            "--width",
            "32",
            "--height",
            "32",
            "--fps",
            "30",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let output = octolux(&args);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let read = |p: &PathBuf| octolux::image_io::HdrImage::read_exr(p).unwrap();
    assert_eq!(read(&by_frame), read(&by_time));
    assert_ne!(read(&by_frame), read(&first), "the scene moves");
}

#[test]
fn voxel_debug_view_renders_and_rejects_bad_input() {
    let tmp = temp_dir("voxels");
    let dir = tmp.path();
    let out = dir.join("voxels.png");
    let output = octolux(&[
        "render",
        "--gi",
        "none",
        "--view",
        "voxels",
        "--voxel-res",
        "32",
        "--width",
        "32",
        "--height",
        "32",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(String::from_utf8_lossy(&output.stdout).contains("octree 32^3"));
    assert!(std::fs::metadata(&out).unwrap().len() > 100);
    assert_fails_with(
        &octolux(&["render", "--view", "voxels", "--out", "v.exr"]),
        &["v.exr", ".png"],
    );
    assert_fails_with(
        &octolux(&[
            "render",
            "--view",
            "voxels",
            "--voxel-res",
            "100000",
            "--out",
            out.to_str().unwrap(),
        ]),
        &["100000"],
    );
}

/// `--view probes` draws a probe technique's state over the frame: the counts it prints match
/// the settings, each layer changes the image, and misuse is a clear error.
#[test]
fn probe_debug_view_renders_and_rejects_bad_input() {
    let tmp = temp_dir("probe-view");
    let dir = tmp.path();
    let run = |gi: &str, layers: &str, name: &str| {
        let out = dir.join(name);
        let output = octolux(&[
            "render",
            "--gi",
            gi,
            "--probes-grid",
            "4",
            "--view",
            "probes",
            "--probe-layers",
            layers,
            "--probe-frames",
            "6",
            "--width",
            "48",
            "--height",
            "32",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
        let image = image::open(&out).unwrap().to_rgb8();
        assert_eq!(image.dimensions(), (48, 32));
        (stdout, image)
    };
    // The grid: 4^3 probes, no cells.
    let (stdout, _) = run("probes-grid", "all", "grid.png");
    assert!(stdout.contains("probes-grid: 64 probes"), "{stdout}");
    assert!(stdout.contains(" 0 octree cells"), "{stdout}");
    // The octree: some probes and cells; each layer draws something of its own.
    let (stdout, cells) = run("probes-octree", "cells", "cells.png");
    assert!(
        !stdout.contains(" 0 probes") && !stdout.contains(" 0 octree cells"),
        "{stdout}"
    );
    let (_, probes) = run("probes-octree", "probes", "probes.png");
    let (_, surfels) = run("probes-octree", "surfels", "surfels.png");
    assert_ne!(cells, probes);
    assert_ne!(probes, surfels);
    let out = dir.join("p.png");
    let out = out.to_str().unwrap();
    assert_fails_with(
        &octolux(&["render", "--gi", "vpl", "--view", "probes", "--out", out]),
        &["--view probes", "vpl"],
    );
    assert_fails_with(
        &octolux(&[
            "render",
            "--gi",
            "probes-grid",
            "--view",
            "probes",
            "--out",
            "p.exr",
        ]),
        &["p.exr", ".png"],
    );
    assert_fails_with(
        &octolux(&[
            "render",
            "--gi",
            "probes-grid",
            "--view",
            "probes",
            "--probe-layers",
            "probes,voxels",
            "--out",
            out,
        ]),
        &["voxels"],
    );
    assert_fails_with(
        &octolux(&[
            "render",
            "--gi",
            "probes-grid",
            "--view",
            "probes",
            "--probe-frames",
            "0",
            "--out",
            out,
        ]),
        &["--probe-frames 0"],
    );
}

/// `--sky` lights any scene without a scene file: the camera sees it where nothing is drawn,
/// on the GPU and in the reference; a bad value is an error naming it.
#[test]
fn sky_flags_light_a_scene_and_bad_ones_are_errors() {
    let tmp = temp_dir("sky");
    let dir = tmp.path();
    for gi in ["none", "reference"] {
        let exr = dir.join(format!("{gi}.exr"));
        let output = octolux(&[
            "render",
            "--gi",
            gi,
            "--spp",
            "1",
            "--width",
            "24",
            "--height",
            "16",
            "--sky",
            "0.25,0.5,1",
            "--sky-intensity",
            "2",
            "--out",
            exr.to_str().unwrap(),
        ]);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        // The top-left corner looks past the box's open front at the sky.
        let image = octolux::image_io::HdrImage::read_exr(&exr).unwrap();
        let corner = image.get(0, 0);
        let want = glam::Vec3::new(0.5, 1.0, 2.0);
        assert!((corner - want).abs().max_element() < 2e-3, "{gi}: {corner}");
    }
    let output = octolux(&["render", "--sky", "missing-sky.hdr"]);
    assert_fails_with(&output, &["missing-sky.hdr"]);
    let output = octolux(&["render", "--sky-intensity", "2"]);
    assert_fails_with(&output, &["--sky-intensity", "need a sky"]);
}

/// A Mitsuba scene whose integrator and sampler ask for settings: the reference warns where
/// it does otherwise, naming what it uses and the flag that matches the file.
#[test]
fn mitsuba_depth_and_sample_count_are_warned_about_when_not_followed() {
    let tmp = temp_dir("mitsuba-requests");
    let dir = tmp.path();
    let scene = dir.join("lamp.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="32"/></sampler>
    </sensor>
    <shape type="rectangle">
        <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
</scene>"#,
    )
    .unwrap();
    let render = |extra: &[&str]| {
        let out = dir.join("out.exr");
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--gi",
            "reference",
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let output = octolux(&args);
        assert!(output.status.success(), "{output:?}");
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let stderr = render(&["--spp", "4"]);
    for needle in [
        "lamp.xml:2",
        "max_depth 4 asks for 2 bounces (--bounces 2); the reference follows unlimited",
        "lamp.xml:6",
        "asks for 32 samples per pixel (--spp 32); this render takes 4",
    ] {
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
    // Following the file: no warning.
    let stderr = render(&["--spp", "32", "--bounces", "2"]);
    assert!(!stderr.contains("warning"), "{stderr}");
}

/// `--stats` says how many probes `probes-octree` keeps: a tree that kept none would turn GI
/// off without a word.
#[test]
fn stats_report_the_probes_the_octree_keeps() {
    let tmp = temp_dir("probe-stats");
    let dir = tmp.path();
    let out = dir.join("probes.png");
    let output = octolux(&[
        "render",
        "--gi",
        "probes-octree",
        "--width",
        "32",
        "--height",
        "18",
        "--frames",
        "4",
        "--stats",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let kept: u32 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("probes kept: "))
        .unwrap_or_else(|| panic!("no probe count in:\n{stdout}"))
        .trim()
        .parse()
        .unwrap();
    assert!(kept > 1, "{kept} probes kept on the Cornell box");
}
