//! No per-frame growth: every technique renders many frames of an animated scene with three
//! lights of every kind (spot, point, directional), and after the first frames the process's
//! resident memory, wgpu's own count of live objects and the memory ledger stay flat: the
//! counts and the ledger do not change at all, and resident memory stops growing (a leak grows
//! in every window of frames, a driver's warm-up does not).
//!
//! This binary holds one test on purpose: resident memory is a property of the process, so no
//! other test may run beside it.

mod growth;
use glam::Vec3;
use growth::snapshot;
use octolux::gi::GiSettings;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{LightKind, Scene};

/// Frames rendered before the first measurement (pipelines, caches and allocator pools fill).
const WARMUP: usize = 5;
/// Frames per measured window.
const WINDOW: usize = 10;
/// Measured windows after the warm-up.
const WINDOWS: usize = 3;
/// Allowed growth of resident memory in the quietest window. A leak grows in every window;
/// a driver that fills its pools for a while after the first frames (NVIDIA's grew by 4 MiB
/// over frames 3 to 13 of the first renderer, then stopped) grows in the first ones only. The
/// leaks this guards against (Mesa's lavapipe recompiling and keeping a shader variant whenever
/// a pipeline whose branches depend on a small uniform block was bound) grew by 0.1 to 20 MiB
/// per frame on this scene, 1 to 200 MiB per window, and by ~80 MiB per frame on Sponza; with
/// them gone, resident memory here does not move by a single page on lavapipe.
const RSS_SLACK_MIB: f64 = 1.0;

/// The animated Cornell box (moving spot, moving block) plus a point and a directional light.
fn scene() -> Scene {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-animated.toml"
    );
    let mut scene = Scene::load(path).expect("scenes/cornell-animated.toml");
    let spot = scene.lights[0].clone();
    let mut point = spot.clone();
    point.name = "point".into();
    point.kind = LightKind::Point;
    point.intensity = 0.3;
    point.position = Vec3::new(0.4, 0.4, 0.3);
    point.animation = None;
    let mut sun = spot.clone();
    sun.name = "sun".into();
    sun.kind = LightKind::Directional;
    sun.intensity = 0.5;
    sun.direction = Vec3::new(0.2, -1.0, 0.4).normalize();
    sun.animation = None;
    scene.lights.push(point);
    scene.lights.push(sun);
    scene
}

/// Small volumes and few iterations: what leaks does not depend on their size, and lavapipe
/// runs them on the CPU.
fn small_settings() -> GiSettings {
    let mut s = GiSettings::default();
    s.lpv.size = 16;
    s.lpv.iterations = 8;
    s.lpv.rsm_size = 64;
    s.clpv.size = 16;
    s.clpv.iterations = 8;
    s.vct.resolution = 16;
    s.vct.levels = 2;
    s.vct.inject_steps = 32;
    s.vct.octree_resolution = 32;
    s.olpv.size = 16;
    s.olpv.iterations = 4;
    s.probes.grid = [8; 3];
    // `probes-octree`: at most 512 leaves instead of 4096 (it took half of this test's time).
    s.probes.max_depth = 3;
    s.probes.min_depth = 2;
    s.vpl.count = 64;
    s.vpl.resolution = 32;
    s.vpl.rsm_size = 64;
    s
}

#[test]
fn no_technique_grows_from_frame_to_frame() {
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = scene();
    assert!(
        ctx.resource_counts().is_some(),
        "wgpu reports its live objects"
    );
    let mut frame = 0usize;
    let mut next_time = || {
        frame += 1;
        frame as f32 * 0.13
    };
    for &name in octolux::gi::TECHNIQUES {
        let settings = RenderSettings {
            width: 48,
            height: 48,
            shadow_map_size: 256,
            gi: name.to_string(),
            gi_settings: small_settings(),
            ..Default::default()
        };
        let mut renderer = Renderer::new(&ctx, &scene, settings).unwrap();
        for _ in 0..WARMUP {
            renderer.render(&scene, next_time()).unwrap();
        }
        let mut snapshots = vec![snapshot(&ctx)];
        for _ in 0..WINDOWS {
            for _ in 0..WINDOW {
                renderer.render(&scene, next_time()).unwrap();
            }
            snapshots.push(snapshot(&ctx));
        }
        let (first, last) = (&snapshots[0], &snapshots[WINDOWS]);
        assert_eq!(
            first.counts,
            last.counts,
            "{name}: wgpu objects alive before and after {} frames",
            WINDOW * WINDOWS
        );
        assert_eq!(first.ledger, last.ledger, "{name}: ledger");
        let rss: Option<Vec<f64>> = snapshots.iter().map(|s| s.rss).collect();
        if let Some(rss) = rss {
            let growth: Vec<f64> = rss.windows(2).map(|w| w[1] - w[0]).collect();
            println!(
                "{name}: resident {:.1} MiB after {WARMUP} frames, growth per {WINDOW} frames {growth:.1?} MiB; {:?}",
                rss[0], last.counts
            );
            let quietest = growth.iter().copied().fold(f64::INFINITY, f64::min);
            assert!(
                quietest <= RSS_SLACK_MIB,
                "{name}: resident memory grew in every window of {WINDOW} frames: {growth:.1?} MiB"
            );
        }
        drop(renderer);
    }
}
