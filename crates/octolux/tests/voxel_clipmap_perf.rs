//! Cost of the clipmap's per-frame update on Crytek Sponza (230k triangles) for a camera moving
//! one finest voxel per frame along the diagonal (so level 0 exposes a slab on each axis every
//! frame and level `l` every `2^l` frames): the CPU time of each update split into finding and
//! snapping triangles, uploads and recording, and the GPU pass times. Printed as the table in
//! `docs/voxels.md` (clipmap section); run `cargo test --release -p octolux --test integration
//! voxel_clipmap_perf -- --nocapture`. The incrementally updated clipmap must equal one built
//! from scratch at the final position.
//!
//! Skipped (with a message) when the shared scenes folder is absent.

use glam::Vec3;
use octolux::gpu::{GpuContext, GpuOptions, PassTimer, PassTiming, TimingSource};
use octolux::scene::{scenes_dir, Scene};
use octolux::voxel::clipmap::{Clipmap, ClipmapSettings, UpdateStats};
use std::collections::BTreeMap;

/// Frames measured after the first (full) build.
const FRAMES: usize = 32;

const SETTINGS: ClipmapSettings = ClipmapSettings {
    resolution: 64,
    levels: 6,
    voxel_size: 1.0 / 16.0,
};

fn gpu_ms(timings: &[PassTiming]) -> f64 {
    timings.iter().map(|t| t.ms).sum()
}

fn row(label: &str, s: &UpdateStats, wall: f64, gpu: f64) {
    println!(
        "| {label} | {} | {} | {} | {:.1} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
        s.parts,
        s.triangles_snapped,
        s.pieces,
        s.upload_bytes as f64 / 1e6,
        s.snap_ms,
        s.upload_ms,
        s.record_ms,
        s.cpu_ms(),
        wall,
        gpu
    );
}

#[test]
fn sponza_update_cost_for_a_moving_camera() {
    if !scenes_dir().is_dir() {
        println!(
            "skipped: the shared scenes folder {} is absent",
            scenes_dir().display()
        );
        return;
    }
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/crytek-sponza.toml"
    );
    let scene = Scene::load(path).expect("Crytek Sponza");
    let tris = octolux::voxel::scene_triangles(&scene, &scene.frame(0.0, 0));
    let ctx = GpuContext::shared(&GpuOptions::default())
        .expect("a GPU adapter (install mesa-vulkan-drivers)");
    println!("adapter: {}", ctx.describe());
    println!(
        "Crytek Sponza: {} triangles; clipmap {} levels of {}^3, finest voxel {} m",
        tris.len(),
        SETTINGS.levels,
        SETTINGS.resolution,
        SETTINGS.voxel_size
    );
    let mut clipmap = Clipmap::new(&ctx, SETTINGS).unwrap();
    let mut timer = PassTimer::new(&ctx);
    // In the atrium, off the voxel lattice.
    let start = Vec3::new(0.013, 2.021, -0.377);
    println!("| update | parts | triangles snapped | pieces | upload MB | snap ms | upload ms | record ms | CPU ms | wall ms | GPU ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let clock = std::time::Instant::now();
    clipmap.update(&ctx, &mut timer, &tris, start).unwrap();
    let wall = clock.elapsed().as_secs_f64() * 1e3;
    let gpu = gpu_ms(&timer.finish_frame().unwrap());
    row(
        "first (full build)",
        &clipmap.last_update_stats(),
        wall,
        gpu,
    );
    let mut sum = UpdateStats::default();
    let mut max = UpdateStats::default();
    let (mut wall_sum, mut gpu_sum, mut gpu_max, mut wall_max) = (0.0, 0.0, 0.0f64, 0.0f64);
    let mut passes: BTreeMap<String, f64> = BTreeMap::new();
    // `update` made `tris` the clipmap's scene; `follow` moves the camera over it.
    let mut at = start;
    for _ in 0..FRAMES {
        at += Vec3::ONE * SETTINGS.voxel_size;
        let clock = std::time::Instant::now();
        clipmap.follow(&ctx, &mut timer, at).unwrap();
        let wall = clock.elapsed().as_secs_f64() * 1e3;
        let timings = timer.finish_frame().unwrap();
        let s = clipmap.last_update_stats();
        sum.parts += s.parts;
        sum.triangles_snapped += s.triangles_snapped;
        sum.pieces += s.pieces;
        sum.work_items += s.work_items;
        sum.upload_bytes += s.upload_bytes;
        sum.snap_ms += s.snap_ms;
        sum.upload_ms += s.upload_ms;
        sum.record_ms += s.record_ms;
        if s.cpu_ms() > max.cpu_ms() {
            max = s;
        }
        wall_sum += wall;
        wall_max = wall_max.max(wall);
        let g = gpu_ms(&timings);
        gpu_sum += g;
        gpu_max = gpu_max.max(g);
        for t in &timings {
            // "clipmap L3 voxelize" -> "voxelize", summed over levels.
            let kind = t.name.rsplit(' ').next().unwrap_or(&t.name).to_string();
            *passes.entry(kind).or_default() += t.ms;
        }
    }
    let n = FRAMES as f64;
    let mean = UpdateStats {
        parts: (sum.parts as f64 / n).round() as u32,
        triangles_snapped: (sum.triangles_snapped as f64 / n).round() as u64,
        pieces: (sum.pieces as f64 / n).round() as u64,
        work_items: (sum.work_items as f64 / n).round() as u64,
        upload_bytes: (sum.upload_bytes as f64 / n).round() as u64,
        snap_ms: sum.snap_ms / n,
        upload_ms: sum.upload_ms / n,
        record_ms: sum.record_ms / n,
    };
    row(
        &format!("mean of {FRAMES} one-voxel moves"),
        &mean,
        wall_sum / n,
        gpu_sum / n,
    );
    row("slowest move (CPU)", &max, wall_max, gpu_max);
    // The work follows the geometry near the exposed slabs: a few percent of the scene.
    assert!(
        mean.triangles_snapped < tris.len() as u64 / 10,
        "{} triangles snapped per move",
        mean.triangles_snapped
    );
    let per_pass: Vec<String> = passes
        .iter()
        .map(|(k, ms)| format!("{k} {:.2} ms", ms / n))
        .collect();
    println!(
        "GPU passes per move (mean, all levels; timing source {:?}): {}",
        timer.source(),
        per_pass.join(", ")
    );
    if timer.source() == TimingSource::CpuSubmitWait {
        println!(
            "(without GPU timestamps every pass is submitted and waited for while it is \
             recorded: record ms includes the GPU ms; CPU ms without them: {:.2} per move)",
            mean.cpu_ms() - gpu_sum / n
        );
    }
    // Memory the updates keep: the resident triangles and the scratch (the first build's
    // one-off buffers are gone from the ledger).
    let kept: Vec<String> = ctx
        .ledger
        .entries()
        .iter()
        .filter(|e| e.owner == "clipmap" && e.bytes > 0)
        .filter(|e| {
            ["triangles", "triangle pieces", "work items", "box params"].contains(&e.name.as_str())
                || e.name.ends_with("(one update)")
        })
        .map(|e| {
            assert!(!e.name.ends_with("(one update)"), "{} kept", e.name);
            format!("{} {:.2} MB", e.name, e.bytes as f64 / 1e6)
        })
        .collect();
    println!("kept between updates: {}", kept.join(", "));
    // The incremental clipmap equals a fresh build at the final position.
    let mut fresh = Clipmap::new(&ctx, SETTINGS).unwrap();
    fresh.set_scene(&ctx, &tris);
    fresh.follow(&ctx, &mut timer, at).unwrap();
    timer.finish_frame().unwrap();
    assert_eq!(clipmap.origins, fresh.origins);
    let (a, b) = (
        clipmap.read_voxels(&ctx).unwrap(),
        fresh.read_voxels(&ctx).unwrap(),
    );
    let wrong = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert_eq!(wrong, 0, "{wrong} voxels differ from a rebuild");
    assert!(a.iter().filter(|&&v| v != 0).count() > 10_000);
    assert_eq!(
        clipmap.read_emission(&ctx).unwrap(),
        fresh.read_emission(&ctx).unwrap()
    );
}
