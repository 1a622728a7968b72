//! End-to-end tests of the `octolux` command: outputs, `--stats`, and clear errors (non-zero
//! exit, no panic) for bad input.

use std::path::PathBuf;
use std::process::{Command, Output};

fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(args)
        .output()
        .expect("run octolux")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("octolux-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
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
    let dir = temp_dir("stats");
    let png = dir.join("cornell.png");
    let exr = dir.join("cornell.exr");
    let output = octolux(&[
        "render",
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
    let dir = temp_dir("frames");
    let out = dir.join("f.png");
    let output = octolux(&[
        "render",
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
fn missing_scene_file_is_an_error() {
    assert_fails_with(
        &octolux(&["render", "/nonexistent/scene.toml"]),
        &["/nonexistent/scene.toml", "not found"],
    );
}

#[test]
fn unknown_scene_extension_is_an_error() {
    let dir = temp_dir("ext");
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
