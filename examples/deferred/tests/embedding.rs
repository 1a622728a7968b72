//! The embedding contract, checked through the example renderer: octolux's GI computed from the
//! example's own G-buffer (reversed-Z depth, octahedral normals) equals octolux's own renderer
//! on the same scene file, camera and technique; edits through the API between frames end where
//! a scene file of the final state does; the memory ledger stays flat while things move.

use glam::{Quat, Vec3};
use octolux::embed::GiEngine;
use octolux::gi::GiSettings;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::image_io::HdrImage;
use octolux::metrics;
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{Keyframe, Light, Scene, Track};
use octolux_example_deferred::{animate, create_device, model::Model, Example};
use std::path::PathBuf;

const SIZE: (u32, u32) = (64, 48);
/// Frames per comparison: enough for the techniques that accumulate over frames to settle the
/// same way on both sides.
const FRAMES: u32 = 3;

fn room() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/room.gltf")
}

fn device() -> (wgpu::Device, wgpu::Queue) {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let (_adapter, device, queue) = create_device(&instance).expect("device");
    (device, queue)
}

/// The room as octolux's importer reads it, with the block marked as moving (the example
/// declares it `Motion::Movable`) and placed as the example places it at time `t`, and the lamp
/// where the example puts it.
fn room_scene(t: f32) -> Scene {
    let mut scene = Scene::load(room()).expect("room.gltf");
    let model = Model::load(&room()).expect("room.gltf");
    let (block, lamp) = animate(&model, t);
    for object in scene.objects.iter_mut().filter(|o| o.name == "block") {
        object.transform = block * object.transform;
        object.animation = Some(Track {
            keys: vec![Keyframe {
                time: 0.0,
                translation: Vec3::ZERO,
                rotation: Quat::IDENTITY,
            }],
            looping: false,
        });
    }
    assert_eq!(scene.lights.len(), 1, "the room has one lamp");
    scene.lights[0].position = lamp;
    scene
}

/// Octolux's own renderer (what `octolux render` runs) on `scene` after `frames` frames at `t`.
fn octolux_indirect(
    scene: &Scene,
    technique: &str,
    gi_settings: &GiSettings,
    t: f32,
    frames: u32,
) -> HdrImage {
    let ctx = GpuContext::shared(&GpuOptions::default()).expect("context");
    let settings = RenderSettings {
        width: SIZE.0,
        height: SIZE.1,
        gi: technique.into(),
        gi_settings: gi_settings.clone(),
        ..RenderSettings::default()
    };
    let mut renderer = Renderer::new(&ctx, scene, settings).expect("renderer");
    for _ in 0..frames {
        renderer.render(scene, t).expect("frame");
    }
    renderer.engine().read_indirect().expect("indirect")
}

/// The example renderer on the room with `technique` and `settings`, `SIZE` pixels.
fn example(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    technique: &str,
    settings: &GiSettings,
) -> Example {
    let model = Model::load(&room()).expect("room.gltf");
    let format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let mut example =
        Example::new(device, queue, model, SIZE.0, SIZE.1, format, technique).expect("example");
    example
        .gi
        .set_technique(technique, settings)
        .expect("settings");
    example
}

fn example_indirect(gi: &GiEngine) -> HdrImage {
    gi.read_indirect().expect("indirect")
}

fn rel_mse(a: &HdrImage, b: &HdrImage) -> f64 {
    metrics::rel_mse(a, b, None).expect("same size")
}

/// A bound on relMSE between two images of one technique that differ only by the G-buffer's
/// encoding: the example stores normals octahedrally in 16-bit floats (11 significant bits: at most about 1e-3 rad) and
/// depth reversed (another projection's rounding), which moves sample positions and directions
/// by that much; 1e-3 relMSE is far below what any technique change shows (0.01-0.3).
const SAME_IMAGE: f64 = 1e-3;

fn check_close(what: &str, a: &HdrImage, b: &HdrImage) {
    let mean: f32 = b.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / b.pixels.len() as f32;
    let error = rel_mse(a, b);
    println!("{what}: relMSE {error:.2e}, mean irradiance {mean:.4}");
    assert!(
        mean > 0.0 || what.starts_with("none"),
        "{what}: no indirect light at all"
    );
    assert!(
        error <= SAME_IMAGE,
        "{what}: relMSE {error:.3e} between the example's G-buffer and octolux's own renderer"
    );
}

#[test]
fn every_technique_reads_the_example_gbuffer_as_octolux_reads_its_own() {
    let (device, queue) = device();
    let scene = room_scene(0.0);
    // Defaults, with the two largest structures smaller to keep the test short (the contract
    // does not depend on their size).
    let mut settings = GiSettings::default();
    settings.vct.octree_resolution = 64;
    settings.clpv.cascades = 2;
    for &technique in octolux::gi::TECHNIQUES {
        let mut example = example(&device, &queue, technique, &settings);
        example.render_at(0.0, FRAMES).expect("frames");
        let ours = example_indirect(&example.gi);
        let theirs = octolux_indirect(&scene, technique, &settings, 0.0, FRAMES);
        check_close(technique, &ours, &theirs);
    }
}

/// Settings of the drift test: the cone tracers and probes without their multiple bounces,
/// which converge over frames (an image after edits would differ from a fresh one by their
/// convergence, not by drift), and a smaller octree to keep the test short.
fn drift_settings() -> GiSettings {
    let mut settings = GiSettings::default();
    settings.vct.multi_bounce = false;
    settings.vct.octree_resolution = 64;
    settings.probes.multi_bounce = Some(false);
    // The probes' history too: a fresh renderer has none.
    settings.probes.history = 0;
    settings
}

#[test]
fn edits_between_frames_end_where_a_scene_file_of_that_state_does_with_a_flat_ledger() {
    let (device, queue) = device();
    let settings = drift_settings();
    for technique in ["lpv", "vct-svo", "vpl", "probes-grid"] {
        let mut example = example(&device, &queue, technique, &settings);
        example.render_at(0.0, 1).expect("frame");
        let start = example_indirect(&example.gi);

        // Moving: block and lamp move every frame; the ledger must not change.
        let mut ledger = Vec::new();
        let mut ledger_after = Vec::new();
        for i in 1..6 {
            example.render_at(i as f32 * 0.3, 1).expect("frame");
            ledger.push(example.gi.memory().total());
        }
        // A light added, frames later removed: rebuilds (whose structures are sized for the
        // scene as it stands then, the moving block's voxels included).
        let extra = example
            .gi
            .add_light(Light::spot(
                Vec3::new(1.0, 1.9, 1.8),
                Vec3::new(0.0, -1.0, -0.5),
                Vec3::ONE,
                2.0,
                0.4,
                0.6,
            ))
            .expect("add light");
        for i in 6..8 {
            example.render_at(i as f32 * 0.3, 1).expect("frame");
        }
        example.gi.remove_light(extra).expect("remove light");
        for i in 8..13 {
            example.render_at(i as f32 * 0.3, 1).expect("frame");
            ledger_after.push(example.gi.memory().total());
        }
        for ledger in [ledger, ledger_after] {
            assert!(
                ledger.iter().all(|&b| b == ledger[0]),
                "{technique}: the ledger changed while things moved: {ledger:?}"
            );
        }
        // The last state, against a fresh renderer of that state from the file.
        let t = 12.0 * 0.3;
        example.render_at(t, 1).expect("frame");
        let ours = example_indirect(&example.gi);
        let theirs = octolux_indirect(&room_scene(t), technique, &settings, t, 2);
        check_close(&format!("{technique} after edits"), &ours, &theirs);
        assert!(
            rel_mse(&ours, &start) > 10.0 * SAME_IMAGE,
            "{technique}: the moved state looks like the start; the test would not see drift"
        );
    }
}

/// The example as a user runs it without a window: frames, a screenshot, the GI's memory.
#[test]
fn the_example_runs_headless_and_writes_its_screenshot() {
    let dir = tempfile_dir();
    let shot = dir.join("frame.png");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_deferred"))
        .args([
            "--frames",
            "3",
            "--width",
            "96",
            "--height",
            "64",
            "--technique",
            "lpv",
        ])
        .arg("--screenshot")
        .arg(&shot)
        .output()
        .expect("run the example");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("octolux GPU memory"), "{stdout}");
    let image = image::open(&shot).expect("screenshot").to_rgba8();
    assert_eq!(image.dimensions(), (96, 64));
    let lit = image
        .pixels()
        .filter(|p| p.0[..3].iter().any(|&c| c > 40))
        .count();
    assert!(
        lit > 96 * 64 / 2,
        "the screenshot is mostly dark: {lit} lit pixels"
    );
    // A bad technique name is an error naming it, not a panic.
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_deferred"))
        .args(["--frames", "1", "--technique", "lpx"])
        .output()
        .expect("run the example");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("lpx"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

fn tempfile_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("octolux-example-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
