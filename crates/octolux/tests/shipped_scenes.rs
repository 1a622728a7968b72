//! Every shipped scene file renders on the GPU: loads, uploads, lights something and reports
//! no GPU error. Scenes that use the shared real-world models need the scenes folder; where it
//! is absent the test says so plainly.

use octolux::gpu::{GpuContext, GpuOptions};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::{scenes_dir, Scene};
use std::path::PathBuf;

fn scene_files() -> Vec<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_shipped_scene_renders_lit() {
    let ctx = GpuContext::shared(&GpuOptions::default()).unwrap();
    let shared = scenes_dir().is_dir();
    let mut rendered = 0;
    for path in scene_files() {
        let text = std::fs::read_to_string(&path).unwrap();
        if text.contains("\"scenes:") && !shared {
            println!(
                "not rendering {}: the shared scenes folder {} is absent (set OCTOLUX_SCENES)",
                path.display(),
                scenes_dir().display()
            );
            continue;
        }
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        // No shipped scene has far outliers: GI structures fit the whole scene, as before.
        assert_eq!(
            scene.gi_bounds_at(0.0),
            scene.bounds_at(0.0),
            "{}",
            path.display()
        );
        let mut renderer = Renderer::new(
            &ctx,
            &scene,
            RenderSettings {
                width: 96,
                height: 54,
                shadow_map_size: 1024,
                ..RenderSettings::default()
            },
        )
        .unwrap();
        for t in [0.0, 1.0] {
            renderer
                .render(&scene, t)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        let image = renderer.read_hdr().unwrap();
        let lit = image
            .pixels
            .iter()
            .filter(|p| p.max_element() > 1e-3)
            .count();
        assert!(
            image.pixels.iter().all(|p| p.is_finite()),
            "{}",
            path.display()
        );
        // A well-framed scene shows lit surfaces over a good part of the image.
        assert!(
            lit * 10 > image.pixels.len(),
            "{}: only {lit} lit pixels",
            path.display()
        );
        println!(
            "{}: {} triangles, {lit} of {} pixels lit",
            path.display(),
            scene.triangle_count(),
            image.pixels.len()
        );
        rendered += 1;
    }
    assert!(rendered >= 2);
}
