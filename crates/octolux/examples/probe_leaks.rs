//! Light leaks through a thin wall (docs/probes.md, "Leaks"): on `scenes/two-rooms-leak.toml`
//! prints the mean indirect irradiance (W/m^2) over the pixels of the dark room and of the lit
//! room for the reference (one bounce) and for `probes-grid` and `probes-octree` with and
//! without depth-moment visibility.
//!
//! ```text
//! cargo run --release -p octolux --example probe_leaks -- width=160 height=90 spp=512
//! ```
//!
//! Keys: `scene` (scenes/two-rooms-leak.toml), `width`/`height` (160 x 90), `spp` (512),
//! `frames` (12: the octree grows a level per frame), `grid` (probes per axis, 21).

use octolux::gi::probes::{ProbeSettings, ProbesGrid, ProbesOctree, Visibility};
use octolux::gi::GiSettings;
use octolux::gpu::pack::f16_to_f32;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::reference::ReferenceSettings;
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::Scene;
use octolux::transport::Bounces;

/// The wall between the rooms spans x = 0.95 .. 0.97 m.
const WALL: (f32, f32) = (0.95, 0.97);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let mut path = format!("{root}/scenes/two-rooms-leak.toml");
    let (mut width, mut height, mut spp, mut frames) = (160u32, 90u32, 512u32, 12u32);
    let mut grid = ProbeSettings::default().grid;
    for arg in std::env::args().skip(1) {
        let (key, value) = arg
            .split_once('=')
            .ok_or(format!("'{arg}': expected key=value"))?;
        match key {
            "scene" => path = value.to_string(),
            "width" => width = value.parse()?,
            "height" => height = value.parse()?,
            "spp" => spp = value.parse()?,
            "frames" => frames = value.parse()?,
            "grid" => grid = [value.parse()?; 3],
            other => return Err(format!("unknown key '{other}'").into()),
        }
    }
    let scene = Scene::load(&path)?;
    let ctx = GpuContext::shared(&GpuOptions::default())?;
    println!("adapter: {}", ctx.describe());
    let mut rooms: Option<Vec<u8>> = None;
    let mut rows = Vec::new();
    for (gi, visibility) in [
        ("probes-grid", Visibility::None),
        ("probes-grid", Visibility::Moments),
        ("probes-octree", Visibility::None),
        ("probes-octree", Visibility::Moments),
    ] {
        let settings = RenderSettings {
            width,
            height,
            gi: gi.into(),
            gi_settings: GiSettings {
                probes: ProbeSettings {
                    visibility,
                    grid,
                    ..ProbeSettings::default()
                },
                ..GiSettings::default()
            },
            ..RenderSettings::default()
        };
        let mut r = Renderer::new(&ctx, &scene, settings)?;
        for _ in 0..frames {
            r.render(&scene, 0.0)?;
        }
        if rooms.is_none() {
            rooms = Some(room_of_pixels(&r)?);
        }
        let rooms = rooms.as_ref().ok_or("no rooms")?;
        let t = r.technique().as_any();
        let texture = match gi {
            "probes-grid" => t
                .and_then(|a| a.downcast_ref::<ProbesGrid>())
                .map(|g| g.indirect_texture()),
            _ => t
                .and_then(|a| a.downcast_ref::<ProbesOctree>())
                .map(|o| o.indirect_texture()),
        }
        .ok_or("not a probe technique")?;
        let bytes = octolux::gpu::read_texture(&ctx, texture, 0)?;
        let halves: &[u16] = bytemuck::cast_slice(&bytes);
        let e: Vec<f32> = (0..rooms.len())
            .map(|i| (0..3).map(|c| f16_to_f32(halves[4 * i + c])).sum::<f32>() / 3.0)
            .collect();
        rows.push((format!("{gi}, visibility {visibility:?}"), means(&e, rooms)));
    }
    let reference = octolux::reference::render(
        &scene,
        &scene.frame(0.0, 0),
        width,
        height,
        &ReferenceSettings {
            spp,
            bounces: Bounces::Indirect(1),
            ..ReferenceSettings::default()
        },
        &|_, _| {},
    )?;
    let e: Vec<f32> = reference
        .indirect_irradiance
        .pixels
        .iter()
        .map(|p| p.element_sum() / 3.0)
        .collect();
    rows.insert(
        0,
        (
            format!("reference, {spp} spp"),
            means(&e, rooms.as_ref().ok_or("no rooms")?),
        ),
    );
    println!("| configuration | dark room W/m^2 | lit room W/m^2 | dark / lit |");
    println!("| --- | --- | --- | --- |");
    for (name, (dark, lit)) in rows {
        println!("| {name} | {dark:.3e} | {lit:.3e} | {:.2e} |", dark / lit);
    }
    Ok(())
}

/// Per pixel: 1 lit room, 2 dark room, 0 background, the wall or its front edge.
fn room_of_pixels(r: &Renderer) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let g = r.read_gbuffer()?;
    let view = *r.last_view().ok_or("no frame rendered")?;
    Ok(view
        .world_points(&g.depth)
        .into_iter()
        .map(|p| match p {
            Some(p) if p.x < WALL.0 - 1e-3 => 1,
            Some(p) if p.x > WALL.1 + 1e-3 => 2,
            _ => 0,
        })
        .collect())
}

/// Mean of `e` over the dark room's pixels and over the lit room's.
fn means(e: &[f32], rooms: &[u8]) -> (f32, f32) {
    let mean = |room: u8| {
        let (s, n) = e
            .iter()
            .zip(rooms)
            .filter(|(_, &r)| r == room)
            .fold((0.0f64, 0u32), |(s, n), (&v, _)| (s + v as f64, n + 1));
        (s / n.max(1) as f64) as f32
    };
    (mean(2), mean(1))
}
