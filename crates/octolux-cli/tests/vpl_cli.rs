//! End-to-end tests of the VPL flags of `octolux render` and of a scene file's
//! `[settings.vpl]` table: valid values render, invalid ones are clear errors (exit code 1, an
//! `error:` line naming the setting, no panic).

use std::process::{Command, Output};

fn render(extra: &[&str]) -> Output {
    let dir = std::env::temp_dir().join(format!("octolux-vpl-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out.png");
    let mut args = vec![
        "render",
        "--gi",
        "vpl",
        "--width",
        "16",
        "--height",
        "16",
        "--shadow-map-size",
        "64",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(&args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("run octolux")
}

#[test]
fn vpl_flags_render_and_bad_values_are_clear_errors() {
    let ok = render(&[
        "--vpl-count",
        "64",
        "--vpl-resolution",
        "32",
        "--vpl-rsm-size",
        "64",
        "--vpl-interleave",
        "2",
        "--vpl-filter",
        "false",
    ]);
    assert!(
        ok.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&ok.stderr)
    );
    for (flag, value, needle) in [
        ("--vpl-count", "0", "vpl count"),
        ("--vpl-resolution", "48", "vpl resolution"),
        ("--vpl-interleave", "9", "vpl interleave"),
        ("--vpl-end-offset", "9", "vpl end_offset"),
    ] {
        let out = render(&[flag, value]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {stderr}");
        assert!(!stderr.contains("panicked"), "panic: {stderr}");
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
}
