//! Bad command lines and outputs: each is a clear error (exit status 1, no panic) found before
//! any rendering starts, and no input file is ever overwritten.

use crate::common::{octolux, temp_dir};
use octolux::image_io::HdrImage;
use std::path::Path;
use std::time::Instant;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Asserts a clean failure naming every needle, within a few seconds (nothing was rendered).
#[track_caller]
fn fails_fast(args: &[&str], needles: &[&str]) -> String {
    let start = Instant::now();
    let output = octolux(args);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "{args:?}: '{needle}' not in: {stderr}"
        );
    }
    assert!(
        start.elapsed().as_secs_f64() < 20.0,
        "{args:?}: took {:.1} s",
        start.elapsed().as_secs_f64()
    );
    stderr
}

/// `render SCENE --gi GI` at 32 x 32 pixels into `out`.
fn small_render<'a>(scene: &'a str, gi: &'a str, out: &'a str) -> [&'a str; 10] {
    [
        "render", scene, "--gi", gi, "--width", "32", "--height", "32", "--out", out,
    ]
}

fn write_exr(path: &Path, value: f32) {
    let mut image = HdrImage::new(4, 2);
    image.pixels.fill(glam::Vec3::splat(value));
    image.write_exr(path).unwrap();
}

#[test]
fn flags_out_of_range_are_errors_naming_the_flag() {
    let animated = "../../scenes/cornell-animated.toml";
    // A tiny frame rate made the animation time infinite (a panic).
    fails_fast(
        &["render", animated, "--frame", "1", "--fps", "1e-40"],
        &["--fps 1e-40", "0.001"],
    );
    // Four flags, four messages.
    fails_fast(&["render", "--frames", "0"], &["--frames 0"]);
    fails_fast(&["render", "--fps", "0"], &["--fps 0"]);
    fails_fast(&["render", "--time", "nan"], &["--time NaN"]);
    fails_fast(&["render", "--width", "0"], &["--width 0"]);
    // Frame counts that overflowed or allocated without bound.
    fails_fast(
        &["bench", "--frames", "4294967295"],
        &["--frames 4294967295"],
    );
    fails_fast(
        &["bench", "--warmup", "4294967295"],
        &["--warmup 4294967295"],
    );
    fails_fast(&["bench", "--fps", "1e-40"], &["--fps"]);
    // The window is range-checked like --size (it panicked in the window system).
    fails_fast(&["view", "--window", "70000x240"], &["--window 70000x240"]);
    fails_fast(&["view", "--window", "17000x240"], &["--window 17000x240"]);
}

#[test]
fn outputs_that_would_overwrite_an_input_are_refused() {
    let tmp = temp_dir("overwrite");
    let dir = tmp.path();
    let sky = dir.join("in.exr");
    write_exr(&sky, 1.0);
    let before = std::fs::read(&sky).unwrap();
    fails_fast(
        &["render", "--sky", s(&sky), "--out", s(&sky)],
        &["--out", "is the input"],
    );
    // The same file under another spelling.
    let dotted = dir.join(".").join("in.exr");
    fails_fast(
        &["render", "--sky", s(&sky), "--exr", s(&dotted)],
        &["--exr", "is the input"],
    );
    assert_eq!(std::fs::read(&sky).unwrap(), before);

    let a = dir.join("a.exr");
    let b = dir.join("b.exr");
    write_exr(&a, 1.0);
    write_exr(&b, 2.0);
    let a_png = dir.join("a.png");
    std::fs::write(&a_png, b"not replaced").unwrap();
    // `diff a b --out a` (a PNG of the error map over an input).
    fails_fast(
        &[
            "diff",
            s(&a),
            s(&b),
            "--mask",
            s(&a_png),
            "--out",
            s(&a_png),
        ],
        &["is the input"],
    );
    assert_eq!(std::fs::read(&a_png).unwrap(), b"not replaced");

    let scene = dir.join("scene.toml");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.toml"),
        &scene,
    )
    .unwrap();
    let text = std::fs::read(&scene).unwrap();
    fails_fast(
        &["bench", s(&scene), "--json", s(&scene), "--no-reference"],
        &["--json", ".json"],
    );
    assert_eq!(std::fs::read(&scene).unwrap(), text);
    // `bench --out-dir` writes `<technique>.exr`: a sky map of that name in that folder is
    // refused before anything is measured.
    let none = dir.join("none.exr");
    write_exr(&none, 1.0);
    let sky_before = std::fs::read(&none).unwrap();
    fails_fast(
        &[
            "bench",
            "--gi",
            "none",
            "--sky",
            s(&none),
            "--out-dir",
            s(dir),
            "--no-reference",
        ],
        &["--out-dir", "none.exr", "is the input"],
    );
    assert_eq!(std::fs::read(&none).unwrap(), sky_before);
}

#[test]
fn outputs_must_be_named_for_their_format_and_writable() {
    let tmp = temp_dir("formats");
    let dir = tmp.path();
    let a = dir.join("a.exr");
    let b = dir.join("b.exr");
    write_exr(&a, 1.0);
    write_exr(&b, 2.0);
    fails_fast(
        &["diff", s(&a), s(&b), "--out", s(&dir.join("err.exr"))],
        &["--out", "must end in .png"],
    );
    fails_fast(
        &[
            "render",
            "--gi",
            "reference",
            "--irradiance-exr",
            s(&dir.join("x.png")),
        ],
        &["--irradiance-exr", "must end in .exr"],
    );
    fails_fast(
        &["render", "--exr", s(&dir.join("x.png"))],
        &["--exr", "must end in .exr"],
    );
    // A folder that cannot be made fails before the render, not after it.
    let file = dir.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    fails_fast(
        &["render", "--out", s(&file.join("render.png"))],
        &["--out", "is not a folder"],
    );
    // A missing folder is made when the file is written, not by the check: a run that fails
    // after the check (an exposure out of range, found once the scene is loaded) leaves no
    // empty folder behind.
    let missing = dir.join("not-yet");
    fails_fast(
        &[
            "render",
            "--out",
            s(&missing.join("render.png")),
            "--exposure",
            "100",
        ],
        &["--exposure"],
    );
    assert!(!missing.exists(), "the check made {}", missing.display());
    fails_fast(
        &["bench", "--out-dir", s(&file), "--no-reference"],
        &["--out-dir", "is a file"],
    );
}

#[test]
fn outputs_a_technique_does_not_make_are_errors() {
    fails_fast(
        &["render", "--gi", "none", "--output", "ao"],
        &["--output ao", "cone tracers"],
    );
    fails_fast(
        &["render", "--gi", "lpv", "--output", "specular"],
        &["--output specular"],
    );
    fails_fast(
        &["render", "--gi", "vct-svo", "--output", "specular"],
        &["--output specular", "--vct-specular"],
    );
    fails_fast(
        &["render", "--gi", "none", "--direct-exr", "d.exr"],
        &["--direct-exr", "--gi reference"],
    );
    fails_fast(
        &["render", "--gi", "reference", "--output", "direct"],
        &["--output direct", "--direct-exr"],
    );
}

#[test]
fn diff_refuses_non_finite_images() {
    let tmp = temp_dir("diff-nan");
    let dir = tmp.path();
    let nan = dir.join("nan.exr");
    let inf = dir.join("inf.exr");
    let one = dir.join("one.exr");
    write_exr(&nan, f32::NAN);
    write_exr(&inf, f32::INFINITY);
    write_exr(&one, 1.0);
    fails_fast(&["diff", s(&nan), s(&one)], &["nan.exr", "pixel (0, 0)"]);
    fails_fast(&["diff", s(&one), s(&inf)], &["inf.exr", "finite"]);
    fails_fast(&["diff", s(&nan), s(&nan), "--json"], &["nan.exr"]);
}

#[test]
fn os_errors_are_printed_once() {
    let stderr = fails_fast(&["render", "no-such-scene.obj"], &["no-such-scene.obj"]);
    let line = stderr.lines().find(|l| l.starts_with("error:")).unwrap();
    let os = "No such file or directory";
    assert!(line.matches(os).count() <= 1, "{line}");
}

#[cfg(unix)]
#[test]
fn a_model_that_is_an_endless_stream_fails_at_once() {
    let tmp = temp_dir("endless");
    let dir = tmp.path();
    let link = dir.join("model.obj");
    std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
    fails_fast(&["render", s(&link)], &["model.obj", "not a regular file"]);
}

#[test]
fn huge_radiance_and_far_geometry_are_errors() {
    let tmp = temp_dir("huge");
    let dir = tmp.path();
    let scene = dir.join("far.toml");
    std::fs::write(
        dir.join("far.obj"),
        "v 1e30 0 0\nv 1e30 1 0\nv 1e30 0 1\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        &scene,
        "[[model]]\npath = \"builtin:cornell-box\"\n[[model]]\npath = \"far.obj\"\n",
    )
    .unwrap();
    fails_fast(&["render", s(&scene)], &["coordinate limit"]);
    let bright = dir.join("bright.exr");
    write_exr(&bright, 3e38);
    fails_fast(&["render", "--sky", s(&bright)], &["--sky", "at most"]);
    fails_fast(&["render", "--sky", "1e38,1e38,1e38"], &["sky", "at most"]);
}

#[test]
fn bench_checks_every_technique_before_measuring_any() {
    let stderr = fails_fast(
        &[
            "bench",
            "--gi",
            "none,vct-svo",
            "--vct-resolution",
            "7",
            "--no-reference",
        ],
        &["--gi vct-svo", "vct resolution"],
    );
    assert!(!stderr.contains("GI total"), "{stderr}");
    // The LPV family's settings too (checked when a volume is set up, before).
    let stderr = fails_fast(
        &[
            "bench",
            "--gi",
            "none,olpv",
            "--olpv-size",
            "12",
            "--no-reference",
        ],
        &["--gi olpv", "olpv size"],
    );
    assert!(!stderr.contains("GI total"), "{stderr}");
}

#[test]
fn more_lights_than_the_adapter_holds_is_one_clear_error() {
    let tmp = temp_dir("lights");
    let dir = tmp.path();
    let mut text = String::from("[[model]]\npath = \"builtin:cornell-box\"\n");
    for i in 0..3000 {
        let x = (i % 50) as f32 * 0.01;
        text += &format!(
            "[[light]]\ntype = \"point\"\nposition = [{x}, 0.5, 0.2]\nintensity = 0.001\n"
        );
    }
    let scene = dir.join("many.toml");
    std::fs::write(&scene, text).unwrap();
    let stderr = fails_fast(
        &[
            "render",
            s(&scene),
            "--gi",
            "none",
            "--width",
            "16",
            "--height",
            "16",
            "--out",
            s(&dir.join("many.png")),
        ],
        &["3000 point lights", "max_texture_array_layers", "at most"],
    );
    assert!(stderr.lines().count() < 10, "{stderr}");
}

/// One triangle far beside the Cornell box made every GPU technique render black (the spot
/// light's shadow map put its near plane past the box); now the direct light is unchanged.
#[test]
fn a_far_triangle_leaves_the_direct_light_unchanged() {
    let tmp = temp_dir("far");
    let dir = tmp.path();
    let camera_and_light = "[[light]]\ntype = \"spot\"\nposition = [0.278, 0.538, 0.2796]\n\
        direction = [0.0, -1.0, 0.0]\nintensity = 1.0\ninner_angle = 55.0\nouter_angle = 70.0\n\
        [[camera]]\nposition = [0.278, 0.273, -0.8]\ntarget = [0.278, 0.273, 0.0]\nfov = 39.3\n\
        near = 0.05\nfar = 5.0\n";
    std::fs::write(
        dir.join("far.obj"),
        "v 1e5 0 0\nv 1e5 1 0\nv 1e5 0 1\nf 1 2 3\n",
    )
    .unwrap();
    let render = |name: &str, extra: &str| {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(
            &scene,
            format!("[[model]]\npath = \"builtin:cornell-box\"\n{extra}{camera_and_light}"),
        )
        .unwrap();
        let out = dir.join(format!("{name}.exr"));
        let output = octolux(&small_render(s(&scene), "none", s(&out)));
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        HdrImage::read_exr(&out).unwrap()
    };
    let near = render("near", "");
    let far = render("far", "[[model]]\npath = \"far.obj\"\n");
    let mean = |i: &HdrImage| i.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>();
    assert!(mean(&near) > 0.0);
    assert!(
        (mean(&far) - mean(&near)).abs() < 1e-3 * mean(&near),
        "{} vs {}",
        mean(&far),
        mean(&near)
    );
}

/// Radiance within the scene limits that overflows the cone tracers' half-float voxels is an
/// error, not an OpenEXR file full of inf.
#[test]
fn a_frame_that_overflows_is_an_error() {
    let tmp = temp_dir("overflow");
    let dir = tmp.path();
    let scene = dir.join("bright.toml");
    std::fs::write(
        &scene,
        "[[model]]\npath = \"builtin:cornell-box\"\n[[light]]\ntype = \"spot\"\n\
         position = [0.278, 0.538, 0.2796]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1e6\n\
         outer_angle = 70.0\n",
    )
    .unwrap();
    let out = dir.join("bright.exr");
    let stderr = fails_fast(
        &small_render(s(&scene), "vct-clipmap", s(&out)),
        &["--gi vct-clipmap", "produced [", "half floats"],
    );
    // The overflowed value is inf or NaN (inf - inf, inf x 0) depending on the adapter's
    // arithmetic; the message names it either way.
    assert!(stderr.contains("inf") || stderr.contains("NaN"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn an_output_over_a_file_the_scene_reads_is_refused_before_rendering() {
    // The scene file names its sky map; `--exr` aimed at it is refused once the scene is
    // loaded, before any frame, and the map is left as it was.
    let tmp = temp_dir("scene-input");
    let dir = tmp.path();
    let mut sky = HdrImage::new(8, 4);
    for y in 0..4 {
        for x in 0..8 {
            sky.set(x, y, glam::Vec3::splat(0.5));
        }
    }
    let map = dir.join("sky.exr");
    sky.write_exr(&map).unwrap();
    let before = std::fs::read(&map).unwrap();
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        "[[model]]\npath = \"builtin:cornell-box\"\n\n[sky]\nmap = \"sky.exr\"\n",
    )
    .unwrap();
    fails_fast(
        &[
            "render",
            s(&scene),
            "--gi",
            "none",
            "--width",
            "32",
            "--height",
            "32",
            "--out",
            s(&dir.join("out.png")),
            "--exr",
            s(&map),
        ],
        &["--exr", "sky.exr"],
    );
    assert_eq!(std::fs::read(&map).unwrap(), before, "the sky map changed");
    assert!(!dir.join("out.png").exists(), "a frame was written");
    // `bench --json` aimed at a file the scene reads (an OBJ's material library, named
    // `.json` here so that only the input check can refuse it) likewise.
    std::fs::write(
        dir.join("box.obj"),
        "mtllib lib.json\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n",
    )
    .unwrap();
    let library = dir.join("lib.json");
    std::fs::write(&library, "newmtl m\nKd 0.5 0.5 0.5\n").unwrap();
    let scene = dir.join("obj.toml");
    std::fs::write(&scene, "[[model]]\npath = \"box.obj\"\n").unwrap();
    fails_fast(
        &[
            "bench",
            s(&scene),
            "--gi",
            "none",
            "--no-reference",
            "--json",
            s(&library),
        ],
        &["--json", "lib.json"],
    );
    assert_eq!(
        std::fs::read_to_string(&library).unwrap(),
        "newmtl m\nKd 0.5 0.5 0.5\n"
    );
}

/// Mean of an 8-bit PNG's channels, 0..255.
fn mean_png(path: &Path) -> f64 {
    let image = image::open(path).unwrap().to_rgb8();
    image.as_raw().iter().map(|&c| c as f64).sum::<f64>() / image.as_raw().len() as f64
}

#[test]
fn a_scene_without_a_camera_is_framed_so_that_it_renders_lit() {
    let dir = temp_dir("no-camera");
    // The Cornell box and its light, no camera: octolux used to look from +z, at the back of
    // the back wall, and write a black image without a word.
    let scene = dir.path().join("box.toml");
    std::fs::write(
        &scene,
        "[[model]]\npath = \"builtin:cornell-box\"\n\
         [[light]]\ntype = \"point\"\nposition = [0.278, 0.5, 0.28]\nintensity = 0.5\n",
    )
    .unwrap();
    for gi in ["none", "reference"] {
        let out = dir.path().join(format!("{gi}.png"));
        let output = octolux(&[
            "render",
            s(&scene),
            "--gi",
            gi,
            "--spp",
            "4",
            "--width",
            "48",
            "--height",
            "32",
            "--out",
            s(&out),
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{gi}: {stderr}");
        assert!(!stderr.contains("black"), "{gi}: {stderr}");
        let mean = mean_png(&out);
        assert!(mean > 20.0, "{gi}: mean {mean:.1} of 255");
    }
}

#[test]
fn a_black_image_is_explained_and_a_sky_counts_as_light() {
    let dir = temp_dir("black");
    // A camera behind the Cornell box's back wall, looking at its back.
    let behind = dir.path().join("behind.toml");
    std::fs::write(
        &behind,
        "[[model]]\npath = \"builtin:cornell-box\"\n\
         [[light]]\ntype = \"point\"\nposition = [0.278, 0.5, 0.28]\nintensity = 0.5\n\
         [[camera]]\nposition = [0.278, 0.273, 1.5]\ntarget = [0.278, 0.273, 0.0]\n",
    )
    .unwrap();
    let out = dir.path().join("behind.png");
    let output = octolux(&small_render(s(&behind), "none", s(&out)));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("the image is black although the scene has light")
            && stderr.contains("backs of surfaces"),
        "{stderr}"
    );
    // A model lit by --sky alone is lit: no warning that it will be black.
    let out = dir.path().join("sky.png");
    let mut args = small_render("../../scenes/models/uv-sphere.obj", "none", s(&out)).to_vec();
    args.extend(["--sky", "1,1,1"]);
    let output = octolux(&args);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(!stderr.contains("black"), "{stderr}");
    assert!(mean_png(&out) > 5.0);
    // Without the sky it has no light at all, and says so once.
    let output = octolux(&small_render(
        "../../scenes/models/uv-sphere.obj",
        "none",
        s(&out),
    ));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(stderr.matches("will be black").count(), 1, "{stderr}");
}

#[test]
fn budget_flags_are_checked_and_named() {
    fails_fast(
        &["render", "--budget", "polygons=3"],
        &["unknown budget 'polygons'", "triangles"],
    );
    fails_fast(
        &["render", "--budget", "triangles=lots"],
        &["--budget triangles=lots", "positive count"],
    );
    // A budget too small for the scene stops it, naming how to raise it.
    fails_fast(
        &[
            "render",
            "../../scenes/cornell-box.toml",
            "--budget",
            "triangles=10",
        ],
        &["triangles", "--budget triangles=N"],
    );
}
