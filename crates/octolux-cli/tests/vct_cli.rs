//! The cone tracers' flags on the command line: `--vct-anisotropic` and `--vct-facing` render
//! both ways, and a value that is not a boolean is a usage error naming the flag.

use crate::common;

#[test]
fn the_anisotropic_flag_renders_and_a_bad_value_is_refused() {
    let tmp = common::temp_dir("vct-cli");
    let dir = tmp.path();
    for flag in ["--vct-anisotropic", "--vct-facing"] {
        for value in ["true", "false"] {
            let output = common::render_small(
                dir,
                None,
                &[
                    "--gi",
                    "vct-svo",
                    "--vct-octree-resolution",
                    "32",
                    flag,
                    value,
                ],
            );
            common::assert_succeeds(&output);
        }
    }
    let output = common::render_small(
        dir,
        None,
        &["--gi", "vct-svo", "--vct-anisotropic", "maybe"],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    // clap's usage errors exit with 2.
    assert_eq!(output.status.code(), Some(2), "stderr: {stderr}");
    assert!(stderr.contains("--vct-anisotropic"), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "stderr: {stderr}");
}
