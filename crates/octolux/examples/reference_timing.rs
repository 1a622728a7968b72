//! Times the reference path tracer on the built-in Cornell box and writes the images.
//!
//! `cargo run --release -p octolux --example reference_timing -- [size] [spp] [out-dir]`

use octolux::reference::{render, Bounces, ReferenceSettings};
use octolux::scene::cornell;
use std::path::PathBuf;
use std::time::Instant;

fn main() -> octolux::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let size: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(256);
    let spp: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(64);
    let out = args.get(3).map(PathBuf::from);
    let scene = cornell::scene();
    let frame = scene.frame(0.0, 0);
    println!(
        "Cornell box {size}x{size}, {spp} spp, {} threads",
        rayon::current_num_threads()
    );
    for (name, bounces) in [
        ("direct", Bounces::DirectOnly),
        ("one-bounce", Bounces::Indirect(1)),
        ("unlimited", Bounces::Unlimited),
    ] {
        let settings = ReferenceSettings {
            spp,
            bounces,
            ..ReferenceSettings::default()
        };
        let start = Instant::now();
        let images = render(&scene, &frame, size, size, &settings, &|_, _| {})?;
        let seconds = start.elapsed().as_secs_f64();
        let paths = size as f64 * size as f64 * images.spp_done as f64;
        println!(
            "{name:<11} {seconds:8.3} s  {:8.2} M paths/s",
            paths / seconds / 1e6
        );
        if let Some(dir) = &out {
            images
                .total
                .write_exr(&dir.join(format!("{name}-total.exr")))?;
            images
                .total
                .write_png(&dir.join(format!("{name}-total.png")), 0.0)?;
            images
                .indirect_irradiance
                .write_exr(&dir.join(format!("{name}-irradiance.exr")))?;
        }
    }
    Ok(())
}
