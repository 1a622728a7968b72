//! Image sheets: a scene's images (every technique and the reference, as `bench --out-dir`
//! writes them) side by side in one PNG, in a fixed order, for the docs.
use anyhow::{bail, Context, Result};
use image::{GenericImage, RgbImage};
use std::path::Path;

/// The order of a sheet, left to right then top to bottom: GI off, the techniques as the
/// README lists them, then the reference (whichever transport it was rendered for).
pub const SHEET_ORDER: [&str; 10] = [
    "none",
    "probes-grid",
    "probes-octree",
    "vct-svo",
    "vct-clipmap",
    "vpl",
    "lpv",
    "clpv",
    "olpv",
    "reference",
];

/// Writes the PNGs of `dir` named after [`SHEET_ORDER`] (`reference*.png` for the reference)
/// into one sheet of `columns` columns at `out`; names with no image are left out. Returns
/// the names placed, in order.
pub fn sheet(dir: &Path, out: &Path, columns: u32) -> Result<Vec<String>> {
    let mut images = Vec::new();
    for name in SHEET_ORDER {
        let path = if name == "reference" {
            std::fs::read_dir(dir)
                .with_context(|| format!("listing {}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .find(|p| {
                    let f = p.file_name().unwrap_or_default().to_string_lossy();
                    f.starts_with("reference") && f.ends_with(".png")
                })
        } else {
            Some(dir.join(format!("{name}.png"))).filter(|p| p.exists())
        };
        if let Some(path) = path {
            let image = image::open(&path)
                .with_context(|| format!("reading {}", path.display()))?
                .to_rgb8();
            images.push((name.to_string(), image));
        }
    }
    let Some((_, first)) = images.first() else {
        bail!("no technique or reference PNG in {}", dir.display());
    };
    let (w, h) = first.dimensions();
    let columns = columns.clamp(1, images.len() as u32);
    let rows = (images.len() as u32).div_ceil(columns);
    let gap = 2;
    let mut sheet = RgbImage::from_pixel(
        columns * (w + gap) - gap,
        rows * (h + gap) - gap,
        image::Rgb([255, 255, 255]),
    );
    for (i, (name, image)) in images.iter().enumerate() {
        if image.dimensions() != (w, h) {
            bail!("{name}: {:?}, the others {w}x{h}", image.dimensions());
        }
        let (x, y) = (i as u32 % columns, i as u32 / columns);
        sheet.copy_from(image, x * (w + gap), y * (h + gap))?;
    }
    sheet
        .save(out)
        .with_context(|| format!("writing {}", out.display()))?;
    Ok(images.into_iter().map(|(n, _)| n).collect())
}
