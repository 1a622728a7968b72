//! The octree-against-clipmap comparisons of docs/vct.md ("`003`'s comparisons"): the scene
//! files they use load and bench with both cone tracers, the fixed-work specular cone shows up
//! as its own pass, moving spheres show up as voxel-update passes of both structures, the
//! ledger's resources are in the JSON, and `scripts/vct-compare.sh` runs end to end and
//! prints its tables, all at tiny sizes.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tempfile::TempDir;

fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("run octolux")
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fresh, empty scratch folder named after `name`, removed when the returned guard drops.
fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-vct-compare-{name}-"))
        .tempdir()
        .unwrap()
}

/// Whether the shared scenes (Crytek Sponza) are here; says so when not.
fn shared_scenes() -> bool {
    let here = octolux::scene::scenes_dir().join("crytek-sponza").is_dir();
    if !here {
        println!(
            "not run: the shared scenes folder {} is absent (set OCTOLUX_SCENES)",
            octolux::scene::scenes_dir().display()
        );
    }
    here
}

/// `octolux bench FILE --gi vct-svo,vct-clipmap` at 24 x 16, small structures, JSON on stdout.
fn bench_both(file: &str, extra: &[&str]) -> Value {
    let mut args = vec![
        "bench",
        file,
        "--gi",
        "vct-svo,vct-clipmap",
        "--no-reference",
        "--width",
        "24",
        "--height",
        "16",
        "--shadow-map-size",
        "256",
        "--warmup",
        "1",
        "--frames",
        "1",
        "--vct-octree-resolution",
        "16",
        "--vct-resolution",
        "8",
        "--vct-levels",
        "3",
        "--vct-multi-bounce",
        "false",
        "--json",
        "-",
    ];
    args.extend(extra);
    let output = octolux(&args);
    assert!(
        output.status.success(),
        "{file}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("JSON on stdout")
}

/// The names of the technique's own passes.
fn gi_passes(report: &Value, technique: &str) -> Vec<String> {
    let techniques = report["scenes"][0]["techniques"].as_array().unwrap();
    let t = techniques
        .iter()
        .find(|t| t["technique"] == technique)
        .unwrap();
    t["passes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["gi"] == true)
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn the_flight_and_the_moving_sun_bench_with_a_fixed_work_specular_cone() {
    if !shared_scenes() {
        return;
    }
    for name in ["sponza-flythrough.toml", "sponza-moving-sun.toml"] {
        let file = repo().join("scenes").join(name);
        let report = bench_both(
            file.to_str().unwrap(),
            &[
                "--vct-specular",
                "--vct-roughness",
                "0",
                "--vct-specular-steps",
                "4",
            ],
        );
        assert_eq!(report["scenes"][0]["animated"], true, "{name}");
        for technique in ["vct-svo", "vct-clipmap"] {
            let passes = gi_passes(&report, technique);
            assert!(
                passes.iter().any(|p| *p == format!("{technique} specular")),
                "{name}, {technique}: {passes:?}"
            );
        }
        // The ledger's resources: the octree's under "svo", the clipmap's radiance grid.
        let entries = |technique: &str| {
            report["scenes"][0]["techniques"]
                .as_array()
                .unwrap()
                .iter()
                .find(|t| t["technique"] == technique)
                .unwrap()["memory_entries"]
                .as_array()
                .unwrap()
                .clone()
        };
        assert!(entries("vct-svo")
            .iter()
            .any(|e| e["owner"] == "svo" && e["mib"].as_f64().unwrap() > 0.0));
        assert!(entries("vct-clipmap")
            .iter()
            .any(|e| e["owner"] == "vct-clipmap" && e["name"] == "radiance"));
    }
}

#[test]
fn moving_spheres_update_both_structures_every_frame() {
    // Two spheres of scenes/models/uv-sphere.obj moving over a ground plane: the octree
    // rebuilds its dynamic part and the clipmap revoxelises where they were and are.
    let tmp = temp_dir("spheres");
    let dir = tmp.path();
    let sphere = repo().join("scenes/models/uv-sphere.obj");
    let mut text = String::from(
        "[[model]]\npath = \"builtin:ground-plane\"\nsize = 8.0\n\
         [[light]]\ntype = \"directional\"\ndirection = [0.3, -1.0, 0.1]\nintensity = 3.0\n\
         [[camera]]\nposition = [0.0, 2.0, 5.0]\ntarget = [0.0, 0.5, 0.0]\n",
    );
    for x in [-1.0, 1.0] {
        text += &format!(
            "[[model]]\npath = {:?}\nscale = 0.5\ntranslate = [{x}, 0.5, 0.0]\nloop = true\n\
             [[model.animation]]\ntime = 0.0\n[[model.animation]]\ntime = 1.0\n\
             translate = [0.0, 0.0, 1.0]\n[[model.animation]]\ntime = 2.0\n",
            sphere.to_str().unwrap()
        );
    }
    let file = dir.join("spheres.toml");
    std::fs::write(&file, text).unwrap();
    let report = bench_both(file.to_str().unwrap(), &["--fps", "4"]);
    assert_eq!(report["scenes"][0]["triangles"], 2 + 2 * 528);
    let svo = gi_passes(&report, "vct-svo");
    assert!(
        svo.iter().any(|p| p.starts_with("vct-svo svo dynamic")),
        "{svo:?}"
    );
    let clipmap = gi_passes(&report, "vct-clipmap");
    assert!(
        clipmap.iter().any(|p| p.ends_with(" voxelize")),
        "{clipmap:?}"
    );
}

#[test]
fn a_fixed_work_specular_cone_needs_the_specular_cone() {
    let output = octolux(&[
        "bench",
        "--no-reference",
        "--gi",
        "vct-clipmap",
        "--width",
        "16",
        "--height",
        "16",
        "--frames",
        "1",
        "--vct-specular-steps",
        "8",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("vct specular_steps"), "{stderr}");
}

#[test]
fn the_comparison_script_runs_every_case_and_prints_its_ratios() {
    if !shared_scenes() {
        return;
    }
    let tmp = temp_dir("script");
    let out = tmp.path();
    let output = Command::new("bash")
        .arg(repo().join("scripts/vct-compare.sh"))
        .args(["24", "16", "1"])
        .arg(out)
        .env("OCTOLUX", env!("CARGO_BIN_EXE_octolux"))
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env("RESOLUTIONS", "16")
        .env("FLIGHT_RESOLUTIONS", "16")
        .env("SPHERE_RESOLUTIONS", "16")
        .env("SPHERES", "1")
        .env("WARMUP", "1")
        .output()
        .expect("run scripts/vct-compare.sh");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for table in [
        "thin cone",
        "flight",
        "memory",
        "moving light",
        "moving spheres at 16^3",
    ] {
        assert!(stdout.contains(table), "no '{table}' table in:\n{stdout}");
    }
    // One row per case and resolution (one sphere count: each count is another bench of
    // Sponza, the suite's time), each with a ratio.
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("| 16^3") || l.starts_with("| 1 |"))
        .collect();
    assert_eq!(rows.len(), 5, "{stdout}");
}
