//! End-to-end tests of the probe octree's and ray flags of `octolux render`: valid values render,
//! invalid ones are clear errors (an `error:` line naming the setting, no panic).

use crate::common;

use std::process::Output;

/// A small render with `--gi probes-octree` and `extra`.
fn render(extra: &[&str]) -> Output {
    let mut args = vec!["--gi", "probes-octree"];
    args.extend(extra);
    common::render_small(common::temp_dir("probes-cli").path(), None, &args)
}

#[test]
fn octree_flags_render_and_bad_values_are_clear_errors() {
    let ok = render(&[
        "--probes-max-depth",
        "2",
        "--probes-min-depth",
        "0",
        "--probes-surfels",
        "32",
        "--probes-rays",
        "voxels",
        "--probes-voxel-resolution",
        "32",
    ]);
    assert!(
        ok.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&ok.stderr)
    );
    for (flags, needle, code) in [
        (&["--probes-min-depth", "5"][..], "probes min_depth", 1),
        (
            &["--probes-max-depth", "2", "--probes-min-depth", "3"][..],
            "probes min_depth",
            1,
        ),
        (&["--probes-max-depth", "9"][..], "probes max_depth", 1),
        (&["--probes-normal-bias", "2"][..], "probes normal_bias", 1),
        (
            &["--probes-backface-limit", "NaN"][..],
            "probes backface_limit",
            1,
        ),
        (&["--probes-max-probes", "8"][..], "probes max_probes", 1),
        (&["--probes-history", "5000"][..], "probes history", 1),
        (&["--probes-history=-1"][..], "--probes-history", 2),
        (&["--probes-min-depth=-1"][..], "--probes-min-depth", 2),
        (&["--probes-min-depth", "two"][..], "--probes-min-depth", 2),
        (&["--probes-rays", "cones"][..], "--probes-rays", 2),
        (
            &["--probes-rays", "voxels", "--probes-voxel-resolution", "48"][..],
            "probes voxel_resolution",
            1,
        ),
    ] {
        let out = render(flags);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{flags:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "panic: {stderr}");
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
}
