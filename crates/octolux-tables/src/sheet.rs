//! Image sheets: a scene's images (every technique and the reference, as `bench --out-dir`
//! writes them) side by side in one image, in a fixed order, for the docs.
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

/// Writes the PNGs (or JPEGs) of `dir` named after [`SHEET_ORDER`] (`reference*` for the
/// reference)
/// into one sheet of `columns` columns at `out`; names with no image are left out. Returns
/// the names placed, in order. `out` ending in `.jpg` is written as JPEG at quality
/// [`JPEG_QUALITY`] (a 640 x 360 sheet of ten images: about a fifth of the PNG's bytes, which
/// the repository carries to every machine it runs on); any other name as PNG.
pub fn sheet(dir: &Path, out: &Path, columns: u32) -> Result<Vec<String>> {
    let mut images = Vec::new();
    for name in SHEET_ORDER {
        let path = if name == "reference" {
            std::fs::read_dir(dir)
                .with_context(|| format!("listing {}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .find(|p| {
                    let f = p.file_name().unwrap_or_default().to_string_lossy();
                    f.starts_with("reference") && (f.ends_with(".png") || f.ends_with(".jpg"))
                })
        } else {
            ["png", "jpg"]
                .iter()
                .map(|ext| dir.join(format!("{name}.{ext}")))
                .find(|p| p.exists())
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
    write(&sheet, out).with_context(|| format!("writing {}", out.display()))?;
    Ok(images.into_iter().map(|(n, _)| n).collect())
}

/// The inverse of [`sheet`] for a sheet of all ten images of [`SHEET_ORDER`] in `columns`
/// columns: writes each tile as `dir/<name>.png` (`reference.png` for the reference), leaving
/// every name that already has an image in `dir` as it is. So a technique re-run alone (its
/// fresh images in `dir`) makes a whole sheet again with the other techniques' tiles taken
/// from the committed one, whose other images are not kept. Returns the names written.
pub fn unsheet(sheet: &Path, dir: &Path, columns: u32) -> Result<Vec<String>> {
    let image = image::open(sheet)
        .with_context(|| format!("reading {}", sheet.display()))?
        .to_rgb8();
    let n = SHEET_ORDER.len() as u32;
    let columns = columns.clamp(1, n);
    let rows = n.div_ceil(columns);
    let gap = 2;
    let (sw, sh) = image.dimensions();
    if (sw + gap) % columns != 0 || (sh + gap) % rows != 0 {
        bail!(
            "{}: {sw}x{sh} is not a sheet of {n} images in {columns} columns",
            sheet.display()
        );
    }
    let (w, h) = ((sw + gap) / columns - gap, (sh + gap) / rows - gap);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let present: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect();
    let mut written = Vec::new();
    for (i, name) in SHEET_ORDER.iter().enumerate() {
        let has = |f: &String| {
            let stem = f.rsplit_once('.').map_or(f.as_str(), |(s, _)| s);
            let image = f.ends_with(".png") || f.ends_with(".jpg");
            image && (stem == *name || (*name == "reference" && stem.starts_with("reference")))
        };
        if present.iter().any(has) {
            continue;
        }
        let (x, y) = (i as u32 % columns, i as u32 / columns);
        let tile = image::imageops::crop_imm(&image, x * (w + gap), y * (h + gap), w, h);
        let path = dir.join(format!("{name}.png"));
        tile.to_image()
            .save(&path)
            .with_context(|| format!("writing {}", path.display()))?;
        written.push(name.to_string());
    }
    Ok(written)
}

/// JPEG quality of `.jpg` sheets: high enough that the blotches, grain and edges the sheets are
/// looked at for are not the encoder's.
pub const JPEG_QUALITY: u8 = 90;

fn write(sheet: &RgbImage, out: &Path) -> Result<()> {
    let jpeg = out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"));
    if !jpeg {
        sheet.save(out)?;
        return Ok(());
    }
    let file = std::io::BufWriter::new(std::fs::File::create(out)?);
    image::codecs::jpeg::JpegEncoder::new_with_quality(file, JPEG_QUALITY).encode_image(sheet)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    /// Two images of flat colours, as `bench --out-dir` names them, made into a sheet of two
    /// columns as PNG (exact) and as JPEG (within the encoder's error on flat colour).
    #[test]
    fn a_sheet_places_the_images_in_order_as_png_or_jpeg() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (32, 16);
        RgbImage::from_pixel(w, h, Rgb([200, 40, 40]))
            .save(dir.path().join("none.png"))
            .unwrap();
        RgbImage::from_pixel(w, h, Rgb([40, 40, 200]))
            .save(dir.path().join("reference-unlimited.png"))
            .unwrap();
        for (name, tolerance) in [("sheet.png", 0i32), ("sheet.jpg", 6)] {
            let out = dir.path().join(name);
            let placed = sheet(dir.path(), &out, 2).unwrap();
            assert_eq!(placed, ["none", "reference"]);
            let read = image::open(&out).unwrap().to_rgb8();
            assert_eq!(read.dimensions(), (2 * w + 2, h), "{name}");
            let near = |p: &Rgb<u8>, q: [u8; 3]| {
                (0..3).all(|c| (i32::from(p[c]) - i32::from(q[c])).abs() <= tolerance)
            };
            assert!(near(read.get_pixel(w / 2, h / 2), [200, 40, 40]), "{name}");
            assert!(
                near(read.get_pixel(w + 2 + w / 2, h / 2), [40, 40, 200]),
                "{name}"
            );
        }
        let jpeg = std::fs::read(dir.path().join("sheet.jpg")).unwrap();
        assert_eq!(jpeg[..2], [0xFF, 0xD8], "a JPEG stream");
    }

    /// A full sheet taken apart gives back every tile exactly, and a name with a fresh image
    /// keeps it.
    #[test]
    fn unsheet_gives_back_the_tiles_a_sheet_was_made_of() {
        let made = tempfile::tempdir().unwrap();
        let (w, h) = (12, 8);
        let colour = |i: usize| Rgb([20 * i as u8, 255 - 20 * i as u8, (i as u8) * 7]);
        for (i, name) in SHEET_ORDER.iter().enumerate() {
            let file = if *name == "reference" {
                "reference-unlimited.png".to_string()
            } else {
                format!("{name}.png")
            };
            RgbImage::from_pixel(w, h, colour(i))
                .save(made.path().join(file))
                .unwrap();
        }
        let out = made.path().join("sheet.png");
        sheet(made.path(), &out, 5).unwrap();
        let apart = tempfile::tempdir().unwrap();
        RgbImage::from_pixel(w, h, Rgb([1, 2, 3]))
            .save(apart.path().join("vpl.png"))
            .unwrap();
        let written = unsheet(&out, apart.path(), 5).unwrap();
        assert_eq!(written.len(), SHEET_ORDER.len() - 1);
        assert!(!written.contains(&"vpl".to_string()));
        for (i, name) in SHEET_ORDER.iter().enumerate() {
            let tile = image::open(apart.path().join(format!("{name}.png")))
                .unwrap()
                .to_rgb8();
            let want = if *name == "vpl" {
                Rgb([1, 2, 3])
            } else {
                colour(i)
            };
            assert_eq!(tile.dimensions(), (w, h), "{name}");
            assert!(tile.pixels().all(|p| *p == want), "{name}");
        }
        // A sheet of another shape is refused, naming it.
        let err = unsheet(&made.path().join("none.png"), apart.path(), 5).unwrap_err();
        assert!(err.to_string().contains("none.png"), "{err}");
    }
}
