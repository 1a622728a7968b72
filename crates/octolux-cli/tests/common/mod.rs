//! What the CLI test binaries share: running `octolux`, a scratch folder, a small render and
//! the checks of a clean success or failure.
#![allow(dead_code)] // each test binary uses a part

use std::path::Path;
use std::process::{Command, Output};
use tempfile::TempDir;

/// Runs the `octolux` binary with `args`.
pub fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("run octolux")
}

/// A fresh, empty scratch folder named after `name`, removed when the returned guard drops.
pub fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-{name}-"))
        .tempdir()
        .unwrap()
}

/// `octolux render` of `scene` (the built-in Cornell box for `None`) at 16 x 16 with 64^2
/// shadow maps into `dir`, with extra arguments; no warm-up frames (the tests that judge a
/// settled picture render on their own).
pub fn render_small(dir: &Path, scene: Option<&Path>, extra: &[&str]) -> Output {
    let out = dir.join("out.png");
    let mut args = vec!["render"];
    if let Some(scene) = scene {
        args.push(scene.to_str().unwrap());
    }
    args.extend([
        "--width",
        "16",
        "--height",
        "16",
        "--shadow-map-size",
        "64",
        "--out",
        out.to_str().unwrap(),
    ]);
    if !extra.contains(&"--warmup") {
        args.extend(["--warmup", "0"]);
    }
    args.extend(extra);
    octolux(&args)
}

/// Asserts that the command succeeded.
pub fn assert_succeeds(output: &Output) {
    assert!(
        output.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// Asserts a clean failure: exit code 1, every `needle` in stderr, no panic.
pub fn assert_fails_with(output: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    assert!(stderr.contains("error"), "no error line: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
}
