//! End-to-end tests of the LPV flags of `octolux render` and of a scene file's
//! `[settings.lpv]` table: valid values render, invalid ones are clear errors (exit code 1, an
//! `error:` line naming the setting or the file, no panic).

use crate::common::{assert_fails_with, assert_succeeds, render_small as render, temp_dir};
use std::path::{Path, PathBuf};

/// The MiB the `--stats` memory table lists for `owner`.
fn owner_mib(stdout: &str, owner: &str) -> f64 {
    stdout
        .lines()
        .find_map(|l| {
            let mut words = l.split_whitespace();
            (words.next() == Some(owner))
                .then(|| words.next()?.parse().ok())
                .flatten()
        })
        .unwrap_or_else(|| panic!("no '{owner}' row in: {stdout}"))
}

/// A scene file using the built-in Cornell box with `settings` appended.
fn scene_file(dir: &Path, settings: &str) -> PathBuf {
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        format!(
            "name = \"lpv-cli\"\n\n[[model]]\npath = \"builtin:cornell-box\"\n\n\
             [[light]]\ntype = \"spot\"\nname = \"spot\"\nposition = [0.278, 0.538, 0.2796]\n\
             direction = [0.0, -1.0, 0.0]\ncolor = [1.0, 1.0, 1.0]\nintensity = 1.0\n\
             inner_angle = 55.0\nouter_angle = 70.0\n\n{settings}"
        ),
    )
    .unwrap();
    path
}

#[test]
fn lpv_flags_render() {
    let tmp = temp_dir("lpv-cli-flags");
    let dir = tmp.path();
    for args in [
        &["--gi", "lpv", "--lpv-size", "16", "--lpv-iterations", "8"][..],
        &[
            "--gi",
            "lpv",
            "--lpv-size",
            "8",
            "--lpv-iterations",
            "0",
            "--rsm-size",
            "32",
            "--rsm-stride",
            "2",
            "--lpv-damping",
            "1",
            "--lpv-gain",
            "2",
            "--lpv-occlusion",
            "false",
        ][..],
        &[
            "--gi",
            "clpv",
            "--lpv-cascades",
            "2",
            "--clpv-size",
            "8",
            "--clpv-iterations",
            "4",
        ][..],
        &[
            "--gi",
            "olpv",
            "--olpv-size",
            "16",
            "--olpv-iterations",
            "2",
        ][..],
    ] {
        let output = render(dir, None, args);
        assert_succeeds(&output);
        assert!(dir.join("out.png").exists(), "{args:?}");
    }
}

#[test]
fn bad_lpv_values_are_clear_errors() {
    let tmp = temp_dir("lpv-cli-bad");
    let dir = tmp.path();
    let cases: [(&[&str], &[&str]); 8] = [
        (
            &["--gi", "lpv", "--lpv-size", "0"],
            &["lpv size", "2..=128"],
        ),
        (&["--gi", "lpv", "--lpv-size", "1"], &["lpv size"]),
        (
            &["--gi", "lpv", "--lpv-size", "100000"],
            &["lpv size", "2..=128"],
        ),
        (
            &["--gi", "lpv", "--lpv-iterations", "100000"],
            &["lpv iterations"],
        ),
        (&["--gi", "lpv", "--rsm-size", "0"], &["rsm_size"]),
        (&["--gi", "lpv", "--lpv-gain=-1"], &["gain"]),
        (
            &["--gi", "olpv", "--olpv-size", "24"],
            &["olpv size", "power of two"],
        ),
        (&["--gi", "clpv", "--lpv-cascades", "9"], &["clpv cascades"]),
    ];
    for (args, needles) in cases {
        assert_fails_with(&render(dir, None, args), needles);
    }
    // Not a number at all: the argument parser's own error (exit code 2 is clap's usage error).
    let output = render(dir, None, &["--gi", "lpv", "--lpv-size=-3"]);
    assert!(!output.status.success());
    assert!(!String::from_utf8_lossy(&output.stderr).contains("panicked"));
}

#[test]
fn scene_file_lpv_table_is_applied() {
    let tmp = temp_dir("lpv-cli-table");
    let dir = tmp.path();
    // Applied: a value the file sets shows in the technique's memory (the RSM dominates it),
    // and an invalid value from the file is refused like the same flag.
    let small = scene_file(dir, "[settings.lpv]\nrsm_size = 32\nsize = 8\n");
    let output = render(dir, Some(&small), &["--gi", "lpv", "--stats"]);
    assert_succeeds(&output);
    let small_mib = owner_mib(&String::from_utf8_lossy(&output.stdout), "lpv");
    let plain = scene_file(dir, "");
    let output = render(dir, Some(&plain), &["--gi", "lpv", "--stats"]);
    assert_succeeds(&output);
    let default_mib = owner_mib(&String::from_utf8_lossy(&output.stdout), "lpv");
    assert!(
        small_mib < default_mib / 4.0,
        "rsm_size 32 / size 8 from the file: {small_mib} MiB, defaults {default_mib} MiB"
    );
    let zero = scene_file(dir, "[settings.lpv]\nsize = 0\n");
    assert_fails_with(&render(dir, Some(&zero), &["--gi", "lpv"]), &["lpv size"]);
    // A flag overrides the file.
    let output = render(dir, Some(&zero), &["--gi", "lpv", "--lpv-size", "8"]);
    assert_succeeds(&output);
    // The cascaded and octree tables too.
    let octree = scene_file(dir, "[settings.olpv]\nsize = 12\n");
    assert_fails_with(
        &render(dir, Some(&octree), &["--gi", "olpv"]),
        &["olpv size"],
    );
}

#[test]
fn unknown_key_in_the_lpv_table_names_the_file() {
    let tmp = temp_dir("lpv-cli-unknown");
    let dir = tmp.path();
    let path = scene_file(dir, "[settings.lpv]\nsize = 16\niteratons = 8\n");
    let output = render(dir, Some(&path), &["--gi", "lpv"]);
    assert_fails_with(&output, &["scene.toml", "iteratons"]);
}
