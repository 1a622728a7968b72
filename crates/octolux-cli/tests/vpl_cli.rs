//! End-to-end tests of the VPL flags of `octolux render` and of a scene file's
//! `[settings.vpl]` table: valid values render, invalid ones are clear errors (exit code 1, an
//! `error:` line naming the setting, no panic).

use crate::common;

use std::process::Output;

/// A small render with `--gi vpl` and `extra`.
fn render(extra: &[&str]) -> Output {
    let mut args = vec!["--gi", "vpl"];
    args.extend(extra);
    common::render_small(common::temp_dir("vpl-cli").path(), None, &args)
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
        "--vpl-roulette",
        "0.5",
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
        ("--vpl-roulette", "17", "vpl roulette"),
    ] {
        let out = render(&[flag, value]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {stderr}");
        assert!(!stderr.contains("panicked"), "panic: {stderr}");
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
}
