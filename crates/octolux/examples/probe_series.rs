//! `004`'s probe-count protocol (ch. 4.1.3): renders a scene frame by frame at 60 frames per
//! second with a probe technique and prints, per frame, the probe count and the time of each
//! probe pass as CSV (`frame,probes,<pass> ms,...`).
//!
//! ```text
//! cargo run --release -p octolux --example probe_series -- scenes/cornell-bunny-turn.toml \
//!     frames=600 gi=probes-octree max_depth=3 surfels=64 lattice=fibonacci
//! ```
//!
//! Keys: `frames` (600), `start` (first frame, 0), `gi` (`probes-octree` or `probes-grid`), `width`/`height` (160 x 90),
//! and the `[settings.probes]` keys `max_depth`, `min_depth`, `surfels`, `lattice`, `split_fraction`,
//! `free_fraction`, `grid` (per axis).

use octolux::gi::probes::{Lattice, ProbesOctree};
use octolux::gi::GiSettings;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: probe_series SCENE [key=value ...]")?;
    let (mut frames, mut start, mut gi) = (600u32, 0u32, "probes-octree".to_string());
    let (mut width, mut height) = (160, 90);
    let mut settings = GiSettings::default();
    for arg in args {
        let (key, value) = arg
            .split_once('=')
            .ok_or(format!("'{arg}': expected key=value"))?;
        let probes = &mut settings.probes;
        match key {
            "frames" => frames = value.parse()?,
            "start" => start = value.parse()?,
            "gi" => gi = value.to_string(),
            "width" => width = value.parse()?,
            "height" => height = value.parse()?,
            "max_depth" => probes.max_depth = value.parse()?,
            "min_depth" => probes.min_depth = value.parse()?,
            "surfels" => probes.surfels = Some(value.parse()?),
            "split_fraction" => probes.split_fraction = value.parse()?,
            "free_fraction" => probes.free_fraction = value.parse()?,
            "grid" => probes.grid = [value.parse()?; 3],
            "lattice" => {
                probes.lattice = Lattice::from_name(value).ok_or(format!("lattice '{value}'"))?
            }
            _ => return Err(format!("unknown key '{key}'").into()),
        }
    }
    let scene = Scene::load(&path)?;
    let ctx = GpuContext::shared(&GpuOptions::default())?;
    let mut r = Renderer::new(
        &ctx,
        &scene,
        RenderSettings {
            width,
            height,
            gi,
            gi_settings: settings.clone(),
            ..RenderSettings::default()
        },
    )?;
    let mut header = false;
    for frame in start..start + frames {
        let timings = r.render(&scene, frame as f32 / 60.0)?;
        let probes = match r
            .technique()
            .as_any()
            .and_then(|a| a.downcast_ref::<ProbesOctree>())
        {
            Some(octree) => octree.octree().probe_count(&ctx)?,
            None => settings.probes.probe_count(),
        };
        let passes: Vec<_> = timings
            .iter()
            .filter(|t| t.name.starts_with("probes"))
            .collect();
        if !header {
            let names: Vec<String> = passes.iter().map(|t| format!("{} ms", t.name)).collect();
            println!("frame,probes,{}", names.join(","));
            header = true;
        }
        let ms: Vec<String> = passes.iter().map(|t| format!("{:.3}", t.ms)).collect();
        println!("{frame},{probes},{}", ms.join(","));
    }
    Ok(())
}
