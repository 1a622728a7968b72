//! Puts PNG images side by side, top-aligned, with a gap between them (for the README's
//! pictures: `scripts/readme-images.sh`).
//!
//! ```sh
//! cargo run --release --example side_by_side -- left.png right.png out.png
//! ```

use image::{GenericImage, RgbImage};
use std::process::ExitCode;

/// Pixels between two images.
const GAP: u32 = 4;

fn run(args: &[String]) -> Result<(), String> {
    let [inputs @ .., out] = args else {
        return Err("usage: side_by_side IN.png IN.png... OUT.png".into());
    };
    if inputs.len() < 2 {
        return Err("usage: side_by_side IN.png IN.png... OUT.png".into());
    }
    let images = inputs
        .iter()
        .map(|p| {
            image::open(p)
                .map(|i| i.to_rgb8())
                .map_err(|e| format!("{p}: {e}"))
        })
        .collect::<Result<Vec<RgbImage>, String>>()?;
    let width = images.iter().map(|i| i.width()).sum::<u32>() + GAP * (images.len() as u32 - 1);
    let height = images.iter().map(|i| i.height()).max().unwrap_or(1);
    let mut combined = RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
    let mut x = 0;
    for image in &images {
        combined
            .copy_from(image, x, 0)
            .map_err(|e| format!("combining: {e}"))?;
        x += image.width() + GAP;
    }
    combined.save(out).map_err(|e| format!("{out}: {e}"))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
