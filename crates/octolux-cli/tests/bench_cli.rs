//! End-to-end tests of `octolux bench` as a performance run: `--no-reference`, several scenes,
//! frame-time statistics, the adapter and the JSON layout (`--json`, `--json -`, `--json-dir`),
//! and clear errors (exit code 1, an `error:` line naming the problem, no panic).

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};
use tempfile::TempDir;

fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("run octolux")
}

/// A fresh, empty scratch folder named after `name`, removed when the returned guard drops.
fn temp_dir(name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("octolux-bench-cli-{name}-"))
        .tempdir()
        .unwrap()
}

/// A scene file that ships with the project.
fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
        .to_str()
        .unwrap()
        .to_string()
}

/// `octolux bench --no-reference` at 24 x 16 with 1 warm-up + 2 measured frames and a small
/// LPV, on `scenes` (none: the built-in Cornell box), with extra arguments.
fn bench(scenes: &[&str], extra: &[&str]) -> Output {
    bench_with_warmup(scenes, "1", extra)
}

/// [`bench`] with `warmup` warm-up frames.
fn bench_with_warmup(scenes: &[&str], warmup: &str, extra: &[&str]) -> Output {
    let mut args = vec!["bench"];
    args.extend(scenes);
    args.extend(["--no-reference", "--gi", "none,lpv", "--warmup", warmup]);
    args.extend(["--frames", "2"]);
    args.extend(SMALL);
    args.extend(extra);
    octolux(&args)
}

/// A 24 x 16 image, small shadow maps, a small LPV and RSM.
const SMALL: [&str; 12] = [
    "--width",
    "24",
    "--height",
    "16",
    "--shadow-map-size",
    "64",
    "--lpv-size",
    "8",
    "--lpv-iterations",
    "2",
    "--rsm-size",
    "64",
];

fn assert_succeeds(output: &Output) {
    assert!(
        output.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// Asserts a clean failure: exit code 1, every `needle` in stderr, no panic.
fn assert_fails_with(output: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    assert!(stderr.contains("error:"), "no error line: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
    }
}

fn f(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("'{key}' is not a number in {v}"))
}

/// Mean, median, min and max of one statistic are consistent and non-negative.
fn check_stats(v: &Value, what: &str) {
    let (mean, median, min, max) = (
        f(v, "mean_ms"),
        f(v, "median_ms"),
        f(v, "min_ms"),
        f(v, "max_ms"),
    );
    assert!(min >= 0.0, "{what}: {v}");
    assert!(
        min <= mean && mean <= max,
        "{what}: mean outside min..max: {v}"
    );
    assert!(
        min <= median && median <= max,
        "{what}: median outside min..max: {v}"
    );
}

/// The run header: adapter, size and frame counts.
fn check_run(report: &Value) {
    assert_eq!(report["width"], 24);
    assert_eq!(report["height"], 16);
    assert_eq!(report["warmup"], 1);
    assert_eq!(report["frames"], 2);
    assert_eq!(report["reference"], false);
    let adapter = &report["adapter"];
    assert!(!adapter["name"].as_str().unwrap().is_empty(), "{adapter}");
    assert!(
        !adapter["backend"].as_str().unwrap().is_empty(),
        "{adapter}"
    );
    assert!(!adapter["device_type"].as_str().unwrap().is_empty());
    assert!(adapter["driver"].is_string() && adapter["driver_info"].is_string());
    let source = adapter["timing_source"].as_str().unwrap();
    assert!(
        source == "GPU timestamps" || source == "CPU submit+wait",
        "{source}"
    );
    // Provenance: the commit of this checkout (the tests run inside one), the date and the
    // command line that made the figures.
    let provenance = &report["provenance"];
    let commit = provenance["commit"].as_str().unwrap();
    let hash = commit.trim_end_matches("+dirty");
    let in_git = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .is_ok_and(|o| o.status.success());
    if in_git {
        assert!(
            hash.len() == 40 && hash.chars().all(|c| c.is_ascii_hexdigit()),
            "{provenance}"
        );
    } else {
        assert_eq!(commit, "unknown", "{provenance}");
    }
    let date = provenance["date"].as_str().unwrap();
    assert!(
        date.len() == 20 && date.starts_with("20") && date.ends_with('Z'),
        "{date}"
    );
    let args = provenance["command_line"].as_array().unwrap();
    assert_eq!(args[1], "bench", "{provenance}");
}

/// Whether the scene's report says it moves.
fn animated(scene: &Value) -> bool {
    scene["animated"].as_bool().unwrap()
}

/// One scene's results for `--gi none,lpv` without a reference.
fn check_scene(scene: &Value, name: &str) {
    assert_eq!(scene["scene"], name);
    assert!(scene["triangles"].as_u64().unwrap() > 0);
    assert_eq!(scene["references"].as_array().unwrap().len(), 0);
    let techniques = scene["techniques"].as_array().unwrap();
    let names: Vec<&str> = techniques
        .iter()
        .map(|t| t["technique"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["none", "lpv"]);
    for t in techniques {
        let technique = t["technique"].as_str().unwrap();
        assert_eq!(t["scene"], name);
        assert!(t["metrics"].is_null() && t["reference"].is_null(), "{t}");
        check_stats(&t["gi_total"], "gi_total");
        check_stats(&t["frame_total"], "frame_total");
        check_stats(&t["frame_wall"], "frame_wall");
        assert!(f(&t["frame_total"], "mean_ms") > 0.0);
        assert!(f(&t["frame_total"], "mean_ms") >= f(&t["gi_total"], "mean_ms"));
        let passes = t["passes"].as_array().unwrap();
        let mut gi_sum = 0.0;
        let mut frame_sum = 0.0;
        for p in passes {
            let pass = p["name"].as_str().unwrap();
            check_stats(p, pass);
            // The renderer's own passes are outside the GI total; the technique's inside.
            let own = pass.starts_with(&format!("{technique} "));
            assert_eq!(p["gi"], own, "{technique}: {p}");
            if own {
                gi_sum += f(p, "mean_ms");
            }
            frame_sum += f(p, "mean_ms");
        }
        let pass_names: Vec<&str> = passes.iter().map(|p| p["name"].as_str().unwrap()).collect();
        for frame_pass in ["shadow maps", "gbuffer", "direct light", "compose"] {
            assert!(pass_names.contains(&frame_pass), "{pass_names:?}");
        }
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.max(1.0);
        assert!(close(gi_sum, f(&t["gi_total"], "mean_ms")), "{t}");
        assert!(close(frame_sum, f(&t["frame_total"], "mean_ms")), "{t}");
        // Held still, GI off is the same image every frame on every adapter; `lpv` recomputes
        // everything from the unchanged scene (exactly 0 on lavapipe; the bound leaves room
        // for a GPU that sums its injection in another order from frame to frame).
        let flicker = f(t, "flicker");
        assert_eq!(t["motion_flicker"].is_null(), !animated(scene), "{t}");
        match technique {
            "none" => assert_eq!(flicker, 0.0, "{t}"),
            _ => assert!((0.0..1e-3).contains(&flicker), "{t}"),
        }
        let total_mib = f(t, "total_mib");
        let technique_mib = f(t, "technique_mib");
        assert!(total_mib > 0.0 && technique_mib > 0.0 && technique_mib < total_mib);
        let objects = t["objects"].as_array().expect("wgpu object counts");
        assert_eq!(objects.len(), 2);
        assert!(objects[0]["buffers"].as_u64().unwrap() > 0);
        assert_eq!(objects[0], objects[1], "no objects created per frame: {t}");
        let owners: Vec<&str> = t["memory"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["owner"].as_str().unwrap())
            .collect();
        assert!(owners.contains(&technique), "{owners:?}");
        if technique == "lpv" {
            // A static scene keeps the RSM its warm-up frame drew (nothing it sees moves); the
            // animated box's spot light moves, so its RSM is drawn every frame.
            let mut expected = vec!["lpv rsm", "lpv inject", "lpv propagate", "lpv lookup"];
            if scene["animated"] == false {
                expected.remove(0);
            }
            let lpv: Vec<&str> = pass_names
                .iter()
                .copied()
                .filter(|n| n.starts_with("lpv "))
                .collect();
            assert_eq!(lpv, expected, "{pass_names:?}");
            assert!(f(&t["gi_total"], "min_ms") > 0.0);
        } else {
            assert_eq!(f(&t["gi_total"], "max_ms"), 0.0);
        }
    }
}

#[test]
fn no_reference_on_the_built_in_cornell_box() {
    let tmp = temp_dir("builtin");
    let dir = tmp.path();
    let json = dir.join("perf.json");
    let output = bench(&[], &["--json", json.to_str().unwrap()]);
    assert_succeeds(&output);
    let stdout = String::from_utf8_lossy(&output.stdout);
    for needle in [
        "'cornell-box' (built-in",
        "at 24x16; 1 warm-up + 2 measured frames",
        "adapter: ",
        "pass times from ",
        "GI total ms",
        "frame ms",
        "* lpv propagate",
        "per-pass ms (2 frames",
    ] {
        assert!(stdout.contains(needle), "'{needle}' missing:\n{stdout}");
    }
    assert!(!stdout.contains("reference ("), "{stdout}");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    check_run(&report);
    let scenes = report["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    assert!(scenes[0]["file"].is_null());
    assert_eq!(scenes[0]["animated"], false);
    check_scene(&scenes[0], "cornell-box");
}

/// The work counts of pass `pass` of technique `t` in a bench report, by quantity.
fn work_of(report: &Value, t: usize, pass: &str) -> Vec<(String, u64)> {
    let passes = report["scenes"][0]["techniques"][t]["passes"]
        .as_array()
        .unwrap();
    let p = passes
        .iter()
        .find(|p| p["name"] == pass)
        .unwrap_or_else(|| panic!("no pass '{pass}' in {passes:?}"));
    p["work"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| {
            (
                w["quantity"].as_str().unwrap().to_string(),
                w["count"].as_u64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn work_counts_per_pass_in_the_table_and_the_json() {
    // VPL shading with 256 VPLs, 4 x 4 interleaving: each shaded pixel pairs with its
    // sub-image's 256 / 16 VPLs, whatever the adapter; the LPV's RSM is one 64^2 layer of the
    // Cornell box's 30 triangles (none culled: the spot sees the whole room).
    let tmp = temp_dir("work");
    let dir = tmp.path();
    let json = dir.join("work.json");
    let run = |extra: &[&str]| {
        // The first measured frame is the first frame (no warm-up), so it draws the RSMs
        // (a static scene keeps them after that). `bench` measures none and lpv; vpl
        // follows them (technique 2).
        let mut args = vec![
            "--gi",
            "vpl",
            "--vpl-count",
            "256",
            "--no-flicker",
            "--json",
        ];
        args.push(json.to_str().unwrap());
        args.extend(extra);
        let output = bench_with_warmup(&[], "0", &args);
        assert_succeeds(&output);
        let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (String::from_utf8_lossy(&output.stdout).to_string(), report)
    };
    let (stdout, report) = run(&[]);
    assert!(
        stdout.contains("work in the first measured frame"),
        "{stdout}"
    );
    assert!(stdout.contains("VPL pairs"), "{stdout}");
    let rsm = work_of(&report, 1, "lpv rsm");
    let count = |w: &[(String, u64)], q: &str| {
        w.iter()
            .find(|(name, _)| name == q)
            .unwrap_or_else(|| panic!("no '{q}' in {w:?}"))
            .1
    };
    assert_eq!(count(&rsm, "layers"), 1, "{rsm:?}");
    assert_eq!(count(&rsm, "texels"), 64 * 64, "{rsm:?}");
    assert_eq!(count(&rsm, "triangles drawn"), 30, "{rsm:?}");
    // The frame's own passes count what they draw too: the box's 30 triangles, all in view.
    let shadow = work_of(&report, 1, "shadow maps");
    assert_eq!(count(&shadow, "layers"), 1, "{shadow:?}");
    assert_eq!(count(&shadow, "triangles drawn"), 30, "{shadow:?}");
    let gbuffer = work_of(&report, 0, "gbuffer");
    assert_eq!(count(&gbuffer, "triangles drawn"), 30, "{gbuffer:?}");
    let inject = work_of(&report, 1, "lpv inject");
    assert_eq!(count(&inject, "RSM texels"), 2 * 64 * 64, "{inject:?}");
    let shade = work_of(&report, 2, "vpl shade");
    let pixels = count(&shade, "pixels");
    assert!(pixels > 0 && pixels <= 24 * 16, "{shade:?}");
    assert_eq!(count(&shade, "VPL pairs"), pixels * 16, "{shade:?}");
    let rays = count(&shade, "shadow rays");
    assert!(0 < rays && rays <= pixels * 16, "{shade:?}");
    assert!(count(&shade, "ray cells") >= rays, "{shade:?}");
    assert!(
        count(&shade, "octree nodes") >= count(&shade, "ray cells"),
        "{shade:?}"
    );
    // Propagation counts what its settings say (8^3 cells x 2 steps); a pass that counts
    // nothing has an empty list; the same run again counts the same.
    let propagate = work_of(&report, 1, "lpv propagate");
    assert_eq!(count(&propagate, "steps"), 2, "{propagate:?}");
    assert_eq!(
        count(&propagate, "cell updates"),
        8 * 8 * 8 * 2,
        "{propagate:?}"
    );
    let lookup = work_of(&report, 1, "lpv lookup");
    assert_eq!(count(&lookup, "pixels"), 24 * 16, "{lookup:?}");
    assert!(work_of(&report, 1, "compose").is_empty());
    let (_, again) = run(&[]);
    assert_eq!(work_of(&again, 2, "vpl shade"), shade);
    // Without counting: no work anywhere, nothing in the table.
    let (stdout, report) = run(&["--no-work-counts"]);
    assert!(work_of(&report, 2, "vpl shade").is_empty());
    assert!(report["scenes"][0]["techniques"][2]["flicker"].is_null());
    assert!(!stdout.contains("VPL pairs"), "{stdout}");
}

#[test]
fn bounce_gathers_launch_lanes_for_the_cones_of_each_listed_voxel() {
    // The cone tracers' bounce gathers visit the listed voxels only, their cones spread over
    // lanes: the lanes launched are the voxels that gathered times their cones rounded up to
    // a power of two (at most 16), rounded up to whole workgroups of 64, whatever the
    // structure and its size (small ones here: at the defaults the two gathers alone took
    // minutes of the suite on a CPU driver).
    let tmp = temp_dir("lanes");
    let dir = tmp.path();
    let json = dir.join("lanes.json");
    let output = bench(
        &[],
        &[
            "--gi",
            "vct-clipmap,vct-svo",
            "--vct-resolution",
            "32",
            "--vct-levels",
            "3",
            "--vct-octree-resolution",
            "64",
            "--no-flicker",
            "--json",
            json.to_str().unwrap(),
        ],
    );
    assert_succeeds(&output);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for (t, pass) in [(2, "vct-clipmap bounce"), (3, "vct-svo bounce")] {
        let work = work_of(&report, t, pass);
        let count = |q: &str| work.iter().find(|(name, _)| name == q).unwrap().1;
        let voxels = count("voxels");
        assert!(voxels > 100, "{pass}: {work:?}");
        let cones = count("cones") / voxels;
        assert_eq!(cones * voxels, count("cones"), "{pass}: {work:?}");
        let lanes = voxels * cones.next_power_of_two().min(16);
        assert_eq!(count("lanes"), lanes.div_ceil(64) * 64, "{pass}: {work:?}");
    }
}

#[test]
fn two_scene_files_in_one_run() {
    let tmp = temp_dir("two");
    let dir = tmp.path();
    let json_dir = dir.join("per-scene");
    let (a, b) = (scene("cornell-box.toml"), scene("cornell-animated.toml"));
    let output = bench(
        &[&a, &b],
        &["--json", "-", "--json-dir", json_dir.to_str().unwrap()],
    );
    assert_succeeds(&output);
    // With `--json -` standard output is the JSON document alone; the tables go to stderr.
    let report: Value = serde_json::from_slice(&output.stdout).expect("stdout is JSON");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("'cornell-box'") && stderr.contains("'cornell-animated'"),
        "{stderr}"
    );
    check_run(&report);
    let scenes = report["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    check_scene(&scenes[0], "cornell-box");
    check_scene(&scenes[1], "cornell-animated");
    assert_eq!(scenes[0]["file"], a.as_str());
    assert_eq!(scenes[0]["animated"], false);
    assert_eq!(scenes[0]["last_time"], 0.0);
    // Animated: 1 warm-up + 2 measured frames at 30 fps, the last at 2/30 s.
    assert_eq!(scenes[1]["animated"], true);
    let last = f(&scenes[1], "last_time");
    assert!((last - 2.0 / 30.0).abs() < 1e-6, "{last}");
    // --json-dir: one file per scene in the same layout, with that scene alone.
    for name in ["cornell-box", "cornell-animated"] {
        let path = json_dir.join(format!("{name}.json"));
        let one: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        check_run(&one);
        assert_eq!(one["scenes"].as_array().unwrap().len(), 1);
        check_scene(&one["scenes"][0], name);
    }
}

#[test]
fn missing_scene_file_is_an_error_before_any_work() {
    let output = bench(&[&scene("cornell-box.toml"), "no-such-scene.toml"], &[]);
    assert_fails_with(&output, &["no-such-scene.toml", "no such file"]);
    assert!(
        output.stdout.is_empty(),
        "measured before failing: {}",
        String::from_utf8_lossy(&output.stdout)
    );
}

#[test]
fn zero_frames_is_an_error() {
    assert_fails_with(
        &octolux(&["bench", "--no-reference", "--frames", "0"]),
        &["--frames", "at least 1"],
    );
}

#[test]
fn unknown_technique_is_an_error() {
    assert_fails_with(
        &octolux(&["bench", "--no-reference", "--gi", "none,lpvv"]),
        &["lpvv", "unknown GI technique", "olpv"],
    );
}

#[test]
fn bad_fps_and_json_folder_are_errors() {
    assert_fails_with(&bench(&[], &["--fps", "0"]), &["--fps"]);
    let tmp = temp_dir("json");
    let missing = tmp.path().join("no-such-folder").join("perf.json");
    assert_fails_with(
        &bench(&[], &["--json", missing.to_str().unwrap()]),
        &["no-such-folder", "does not exist"],
    );
}

/// `--lag` and motion flicker on `cornell-crossing` (a sphere flies through the spot's beam):
/// GI off follows every change at once and has no indirect light to flicker; `lpv` recomputes
/// everything from the scene each frame, so it has no lag either; `vct-svo`'s voxels keep the
/// bounce light of the frames before, so after the light switches off its image takes frames
/// to go dark, which the lag must show.
#[test]
fn lag_after_a_light_switches_or_an_object_jumps_and_flicker_while_the_scene_moves() {
    let crossing = scene("cornell-crossing.toml");
    let mut args = vec!["bench", &crossing, "--gi", "none,lpv,vct-svo", "--spp", "4"];
    args.extend(["--warmup", "1", "--frames", "1"]);
    args.extend(SMALL);
    args.extend([
        "--vct-octree-resolution",
        "32",
        "--no-work-counts",
        "--lag",
        "off:ceiling-spot",
        "--lag",
        "jump:0..1",
        "--json",
        "-",
    ]);
    let output = octolux(&args);
    assert_succeeds(&output);
    let report: Value = serde_json::from_slice(&output.stdout).expect("JSON on stdout");
    for t in report["scenes"][0]["techniques"].as_array().unwrap() {
        let technique = t["technique"].as_str().unwrap();
        let lag = t["lag"].as_array().unwrap();
        assert_eq!(lag.len(), 2, "{t}");
        assert_eq!(lag[0]["event"], "off:ceiling-spot");
        assert_eq!(lag[1]["event"], "jump:0..1");
        for event in lag {
            let curve: Vec<f64> = event["rel_mse"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            assert_eq!(curve.len(), 24, "{event}");
            assert_eq!(f(event, "settled_rel_mse"), *curve.last().unwrap());
            assert!(curve.iter().all(|e| e.is_finite() && *e >= 0.0), "{event}");
        }
        let frames = |i: usize| lag[i]["frames"].as_u64().unwrap();
        match technique {
            "none" | "lpv" => assert_eq!((frames(0), frames(1)), (0, 0), "{technique}: {t}"),
            _ => {
                // Dark after the switch: the first frame still holds the voxels' bounce light.
                let first = lag[0]["rel_mse"][0].as_f64().unwrap();
                assert!(frames(0) >= 2 && first > 1e-2, "{technique}: {}", lag[0]);
            }
        }
        // The sphere moves: flicker while it does is measured (and is the light it moves).
        let motion = f(t, "motion_flicker");
        match technique {
            "none" => assert_eq!((motion, f(t, "flicker")), (0.0, 0.0)),
            _ => assert!(motion > 0.0 && motion.is_finite(), "{technique}: {t}"),
        }
    }
}

#[test]
fn bad_lag_events_are_errors() {
    assert_fails_with(
        &octolux(&["bench", "--gi", "none", "--lag", "on:lamp"]),
        &["--lag on:lamp", "no light 'lamp'", "0 'ceiling-spot'"],
    );
    let output = octolux(&["bench", "--gi", "none", "--lag", "flash:1"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && !stderr.contains("panicked"));
    assert!(stderr.contains("expected `jump:A..B`"), "{stderr}");
    let output = octolux(&["bench", "--gi", "none", "--lag", "on:0", "--no-reference"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("--no-reference"),
        "{stderr}"
    );
}

/// `--settle` warms each technique up to its settled picture (`probes-grid` with a 5-frame
/// history: 5 frames; the others `--warmup`), `--early N` judges frame N beside it: the same
/// error for GI off, which computes every frame afresh, another for the probes, whose history
/// was not full at frame 2. On an animated scene the warm-up is held still, so every
/// technique's measured frames show the same scene times.
#[test]
fn settled_and_early_frames_are_judged_per_technique() {
    let cornell = scene("cornell-box.toml");
    let crossing = scene("cornell-crossing.toml");
    let mut args = vec!["bench", &cornell, &crossing, "--gi", "none,lpv,probes-grid"];
    args.extend(["--spp", "4", "--warmup", "1", "--frames", "2", "--settle"]);
    args.extend(["--early", "2", "--probes-history", "5", "--no-work-counts"]);
    args.extend(["--no-flicker", "--json", "-"]);
    args.extend(SMALL);
    let output = octolux(&args);
    assert_succeeds(&output);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("settled picture: probes-grid 5 frames"),
        "{stderr}"
    );
    let report: Value = serde_json::from_slice(&output.stdout).expect("JSON on stdout");
    assert_eq!(report["settle"], true);
    for scene in report["scenes"].as_array().unwrap() {
        let techniques = scene["techniques"].as_array().unwrap();
        for t in techniques {
            let technique = t["technique"].as_str().unwrap();
            let warmup = if technique == "probes-grid" { 5 } else { 1 };
            assert_eq!(t["warmup"], warmup, "{t}");
            assert_eq!(t["early"]["frame"], 2, "{t}");
            let early = f(&t["early"]["metrics"], "rel_mse");
            let measured = f(&t["metrics"], "rel_mse");
            assert!(early.is_finite() && measured.is_finite(), "{t}");
            if scene["animated"] == false && technique == "none" {
                assert_eq!(early, measured, "{t}");
            }
            if technique == "probes-grid" {
                assert_ne!(early, measured, "{t}");
            }
        }
        if scene["animated"] == true {
            // Measured frames at 0 and 1/30 s, whatever each technique's warm-up.
            assert!((f(scene, "last_time") - 1.0 / 30.0).abs() < 1e-6, "{scene}");
        }
    }
    for early in ["0", "4"] {
        let output = octolux(&[
            "bench", "--gi", "none", "--warmup", "1", "--frames", "2", "--early", early,
        ]);
        assert_fails_with(&output, &[&format!("--early {early}"), "1..=3"]);
    }
}
