//! Scenes that multiply what they pull in, and files nested without end: each stops with an
//! error naming the budget or the depth it passed, within seconds and a few hundred MB, and a
//! model placed many times is read and stored once.

mod counting_alloc;

use counting_alloc::{peak_since, reset_peak};
use octolux::limits::Budget;
use octolux::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One measured load at a time: the peak is the process's.
static MEASURING: Mutex<()> = Mutex::new(());

/// Most memory a runaway scene may take before it stops.
const MEMORY_CAP: isize = 300 << 20;
/// Longest a runaway scene may run before it stops (a debug build on a slow machine).
const TIME_CAP: Duration = Duration::from_secs(20);

/// Loads `path` within `budget`, measuring the time and the peak memory above what was live.
fn measured_load(path: &Path, budget: Budget) -> (octolux::Result<Scene>, Duration, isize) {
    let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
    let base = reset_peak();
    let start = Instant::now();
    let result = Scene::load_within(path, budget);
    let took = start.elapsed();
    let peak = peak_since(base);
    (result, took, peak)
}

/// A runaway load: an error naming every needle, fast and small.
#[track_caller]
fn stops(path: &Path, needles: &[&str]) -> String {
    let (result, took, peak) = measured_load(path, Budget::default());
    let e = match result {
        Ok(scene) => panic!(
            "{}: loaded ({} triangles, {} objects); expected an error",
            path.display(),
            scene.triangle_count(),
            scene.objects.len()
        ),
        Err(e) => e.to_string(),
    };
    for needle in needles {
        assert!(e.contains(needle), "'{needle}' not in: {e}");
    }
    assert!(took < TIME_CAP, "{}: took {took:?}: {e}", path.display());
    assert!(
        peak < MEMORY_CAP,
        "{}: peaked at {} MiB: {e}",
        path.display(),
        peak >> 20
    );
    e
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("octolux-runaway-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An OBJ grid of `n` x `n` quads (2 n^2 triangles) in the xz plane.
fn grid_obj(path: &Path, n: usize) {
    let mut text = String::new();
    for z in 0..=n {
        for x in 0..=n {
            text.push_str(&format!(
                "v {} 0 {}\n",
                x as f32 / n as f32,
                z as f32 / n as f32
            ));
        }
    }
    text.push_str("vn 0 1 0\n");
    for z in 0..n {
        for x in 0..n {
            let i = z * (n + 1) + x + 1;
            let (a, b, c, d) = (i, i + 1, i + n + 2, i + n + 1);
            text.push_str(&format!("f {a}//1 {d}//1 {c}//1\nf {a}//1 {c}//1 {b}//1\n"));
        }
    }
    std::fs::write(path, text).unwrap();
}

/// A scene file that places `model` `count` times (in a row along x) under a point light.
fn placements(path: &Path, model: &str, count: usize) {
    let mut text =
        String::from("[[light]]\ntype = \"point\"\nposition = [0.5, 2.0, 0.5]\nintensity = 1.0\n");
    for i in 0..count {
        text.push_str(&format!(
            "[[model]]\npath = \"{model}\"\ntranslate = [{}.0, 0.0, 0.0]\n",
            i
        ));
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_model_listed_thousands_of_times_stops_with_the_triangle_budget() {
    let dir = temp_dir("listed");
    // 20,000 triangles placed 5,000 times: 100 million, five times the default budget.
    grid_obj(&dir.join("grid.obj"), 100);
    placements(&dir.join("scene.toml"), "grid.obj", 5000);
    let e = stops(
        &dir.join("scene.toml"),
        &[
            "scene.toml",
            "grid.obj",
            "triangles",
            "20,000,000",
            "--budget triangles=N",
        ],
    );
    eprintln!("{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_model_placed_many_times_is_read_and_stored_once() {
    let dir = temp_dir("shared");
    grid_obj(&dir.join("grid.obj"), 10);
    placements(&dir.join("scene.toml"), "grid.obj", 2000);
    let ((scene, files), took, peak) = {
        let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
        let base = reset_peak();
        let start = Instant::now();
        let (scene, files) = octolux::limits::recording_reads(|| {
            Scene::load(dir.join("scene.toml")).expect("a scene of 400,000 triangles loads")
        });
        ((scene, files), start.elapsed(), peak_since(base))
    };
    assert_eq!(scene.objects.len(), 2000);
    assert_eq!(scene.meshes.len(), 1, "every placement shares the one mesh");
    assert_eq!(scene.triangle_count(), 2000 * 200);
    // Reads are recorded from every thread: the other tests of this binary load their own
    // grid.obj meanwhile.
    let grid = dir.join("grid.obj");
    let grid_reads = files.iter().filter(|f| **f == grid).count();
    assert_eq!(grid_reads, 1, "the model is read once: {files:?}");
    assert!(took < TIME_CAP, "took {took:?}");
    assert!(peak < MEMORY_CAP, "peaked at {} MiB", peak >> 20);
    // The same scene under a budget that it passes is an error, and one that fits loads.
    let tight = Budget {
        instances: 1000,
        ..Budget::default()
    };
    let e = Scene::load_within(dir.join("scene.toml"), tight)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("instances") && e.contains("1,000") && e.contains("--budget instances=N"),
        "{e}"
    );
    let mut raised = tight;
    raised.apply("instances=2k").unwrap();
    Scene::load_within(dir.join("scene.toml"), raised).unwrap();
    std::fs::remove_dir_all(&dir).ok();
}

/// Mitsuba files `level0.xml` .. `level{depth}.xml`, each including the next `fan_out`
/// times; the last holds one rectangle.
fn include_fan_out(dir: &Path, fan_out: usize, depth: usize) -> PathBuf {
    for level in 0..=depth {
        let mut body = String::new();
        if level == depth {
            body.push_str("<shape type=\"rectangle\"/>");
        } else {
            for _ in 0..fan_out {
                body.push_str(&format!("<include filename=\"level{}.xml\"/>\n", level + 1));
            }
        }
        std::fs::write(
            dir.join(format!("level{level}.xml")),
            format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n"),
        )
        .unwrap();
    }
    dir.join("level0.xml")
}

#[test]
fn a_fan_out_of_includes_stops_with_the_include_budget() {
    let dir = temp_dir("includes");
    // 8 includes per file, 10 levels: a billion includes.
    let e = stops(
        &include_fan_out(&dir, 8, 10),
        &["includes", "1,000", "--budget includes=N", "<include"],
    );
    eprintln!("{e}");
    // A fan-out within the budget loads: 4 x 4 x 4 = 64 rectangles.
    let small = temp_dir("includes-small");
    let scene = Scene::load(include_fan_out(&small, 4, 3)).unwrap();
    assert_eq!(scene.objects.len(), 64);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&small).ok();
}

#[test]
fn a_mitsuba_shape_file_placed_many_times_is_read_once() {
    let dir = temp_dir("shapes");
    grid_obj(&dir.join("grid.obj"), 10);
    let mut body = String::new();
    for i in 0..500 {
        body.push_str(&format!(
            "<shape type=\"obj\"><string name=\"filename\" value=\"grid.obj\"/>\
             <transform name=\"to_world\"><translate x=\"{i}\"/></transform></shape>\n"
        ));
    }
    let path = dir.join("scene.xml");
    std::fs::write(
        &path,
        format!("<scene version=\"3.0.0\">\n{body}</scene>\n"),
    )
    .unwrap();
    let (scene, files) = {
        let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
        octolux::limits::recording_reads(|| Scene::load(&path).unwrap())
    };
    assert_eq!(scene.objects.len(), 500);
    assert_eq!(scene.meshes.len(), 1, "the shapes share the file's mesh");
    // Reads are recorded from every thread: the other tests of this binary load their own
    // grid.obj meanwhile.
    let grid = dir.join("grid.obj");
    let grid_reads = files.iter().filter(|f| **f == grid).count();
    assert_eq!(grid_reads, 1, "{files:?}");
    // Past the triangle budget, the shape that passes it is named.
    let tight = Budget {
        triangles: 10_000,
        ..Budget::default()
    };
    let e = Scene::load_within(&path, tight).unwrap_err().to_string();
    assert!(
        e.contains("shape 'shape50'") && e.contains("triangles") && e.contains("10,000"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Writes `text` to `name` in a fresh folder and loads it: it must fail naming every needle.
#[track_caller]
fn nested_fails(name: &str, text: &str, needles: &[&str]) {
    let dir = temp_dir(&name.replace('.', "-"));
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let e = stops(&path, needles);
    eprintln!("{name}: {e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn deep_nesting_is_an_error_in_every_nested_format() {
    const DEPTH: usize = 100_000;
    // Mitsuba XML: elements inside elements (this aborted the process on a stack overflow).
    let xml = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<bsdf type=\"twosided\">".repeat(DEPTH),
        "</bsdf>".repeat(DEPTH)
    );
    nested_fails("deep.xml", &xml, &["deep.xml"]);
    // Scene files: arrays inside arrays.
    let toml = format!("name = {}{}\n", "[".repeat(DEPTH), "]".repeat(DEPTH));
    nested_fails("deep.toml", &toml, &["deep.toml"]);
    // glTF: JSON arrays inside arrays, in a field the loader keeps as raw JSON.
    let gltf = format!(
        "{{\"asset\": {{\"version\": \"2.0\"}}, \"extensions\": {{\"X\": {}{}}}}}",
        "[".repeat(DEPTH),
        "]".repeat(DEPTH)
    );
    nested_fails("deep.gltf", &gltf, &["deep.gltf"]);
    // glTF: a chain of nodes each the child of the last (walked without recursion; the chain
    // holds no mesh, so the file is an error for that).
    let nodes: Vec<String> = (0..DEPTH)
        .map(|i| match i + 1 < DEPTH {
            true => format!("{{\"children\": [{}]}}", i + 1),
            false => "{}".to_string(),
        })
        .collect();
    let chain = format!(
        "{{\"asset\": {{\"version\": \"2.0\"}}, \"scene\": 0, \"scenes\": [{{\"nodes\": [0]}}], \
         \"nodes\": [{}]}}",
        nodes.join(",")
    );
    nested_fails("chain.gltf", &chain, &["chain.gltf"]);
}

#[test]
fn nesting_as_deep_as_real_scenes_loads() {
    // A bsdf four deep, as real scenes nest them (twosided > mask > bumpmap > diffuse).
    let dir = temp_dir("nesting-ok");
    let path = dir.join("ok.xml");
    std::fs::write(
        &path,
        "<scene version=\"3.0.0\"><shape type=\"rectangle\"><bsdf type=\"twosided\">\
         <bsdf type=\"mask\"><bsdf type=\"bumpmap\"><bsdf type=\"diffuse\"/></bsdf></bsdf>\
         </bsdf></shape></scene>",
    )
    .unwrap();
    Scene::load(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
}
