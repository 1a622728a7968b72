//! Linear HDR images, OpenEXR and PNG output, and the filmic tone map shared with the GPU
//! (`render/compose.wgsl` implements the same curve; a test keeps them in step).

use crate::{Error, Result};
use glam::Vec3;
use std::path::Path;

/// Largest accepted image side.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest accepted pixel count (64 Mpixel).
pub const MAX_PIXELS: u64 = 1 << 26;

/// Checks an output size, with an error a person can act on.
pub fn check_image_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidArgument(format!(
            "image size {width}x{height}: width and height must be at least 1"
        )));
    }
    if width > MAX_IMAGE_SIDE
        || height > MAX_IMAGE_SIDE
        || width as u64 * height as u64 > MAX_PIXELS
    {
        return Err(Error::InvalidArgument(format!(
            "image size {width}x{height} is too large (at most {MAX_IMAGE_SIDE} per side and {} Mpixel)",
            MAX_PIXELS >> 20
        )));
    }
    Ok(())
}

/// A linear-light RGB image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` linear RGB values.
    pub pixels: Vec<Vec3>,
}

impl HdrImage {
    /// A black image.
    pub fn new(width: u32, height: u32) -> HdrImage {
        HdrImage {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// Pixel at (`x`, `y`).
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Sets the pixel at (`x`, `y`).
    pub fn set(&mut self, x: u32, y: u32, v: Vec3) {
        self.pixels[(y * self.width + x) as usize] = v;
    }

    /// The first pixel (x, y, value) that is NaN or infinite, if any.
    pub fn first_non_finite(&self) -> Option<(u32, u32, Vec3)> {
        let w = self.width.max(1);
        self.pixels
            .iter()
            .position(|p| !p.is_finite())
            .map(|i| (i as u32 % w, i as u32 / w, self.pixels[i]))
    }

    /// Writes a linear 32-bit float RGB OpenEXR file, atomically (see [`write_atomically`]).
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        let w = self.width as usize;
        write_atomically(path, |file| {
            exr::prelude::write_rgb_file(file, w, self.height as usize, |x, y| {
                let p = self.pixels[y * w + x];
                (p.x, p.y, p.z)
            })
            .map_err(|e| Error::parse(path, format!("cannot write OpenEXR: {e}")))
        })
    }

    /// Reads the RGB channels of an OpenEXR file (alpha ignored). The file is read with the
    /// size limit of [`crate::limits::read_file`] and every layer's size is checked against
    /// [`crate::limits::check_image_dimensions`] before pixels are allocated.
    pub fn read_exr(path: &Path) -> Result<HdrImage> {
        use exr::image::read::image::ReadLayers;
        use exr::image::read::layers::ReadChannels;
        let bytes = crate::limits::read_file(path)?;
        let bad = |e: exr::error::Error| Error::parse(path, format!("cannot read OpenEXR: {e}"));
        let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&bytes), false)
            .map_err(bad)?;
        for header in &meta.headers {
            let size = header.layer_size;
            let side = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
            let (w, h) = (side(size.width()), side(size.height()));
            crate::limits::check_image_dimensions(w, h)
                .and_then(|()| crate::limits::check_image_data(w, h, bytes.len()))
                .map_err(|e| Error::parse(path, e))?;
        }
        let image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |resolution: exr::math::Vec2<usize>, _: &exr::image::RgbaChannels| {
                    HdrImage::new(resolution.width() as u32, resolution.height() as u32)
                },
                |image: &mut HdrImage, position, (r, g, b, _a): (f32, f32, f32, f32)| {
                    image.set(position.x() as u32, position.y() as u32, Vec3::new(r, g, b));
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(&bytes))
            .map_err(bad)?;
        Ok(image.layer_data.channel_data.pixels)
    }

    /// Writes the image tone-mapped for display: scaled by 2^`exposure`, filmic curve, sRGB.
    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<()> {
        let scale = exposure.exp2();
        let bytes: Vec<u8> = self
            .pixels
            .iter()
            .flat_map(|&p| tone_map_to_srgb8(p * scale))
            .collect();
        write_rgb8_png(path, self.width, self.height, bytes)
    }
}

/// Writes 8-bit RGB data as a PNG file, atomically (see [`write_atomically`]).
pub fn write_rgb8_png(path: &Path, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
    let image = image::RgbImage::from_raw(width, height, rgb)
        .ok_or_else(|| Error::InvalidArgument("image buffer size does not match".into()))?;
    write_atomically(path, |file| {
        image
            .save_with_format(file, image::ImageFormat::Png)
            .map_err(|e| Error::parse(path, format!("cannot write PNG: {e}")))
    })
}

/// Writes a file atomically: `write` fills a temporary file in the same folder (created if
/// missing), which then replaces `path` by a rename. A failure leaves `path` as it was and no
/// temporary file behind.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
            dir
        }
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".octolux-").suffix(".part");
    // Like a file made by `File::create`: readable by others as the umask allows.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let temp = builder.tempfile_in(dir).map_err(|e| Error::io(dir, e))?;
    write(temp.path())?;
    temp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Filmic tone curve (Narkowicz's fit of the ACES reference rendering transform), applied per
/// channel to exposed linear values; output in 0..1, linear.
///
/// ```
/// use octolux::image_io::filmic;
/// assert_eq!(filmic(0.0), 0.0);
/// assert!(filmic(0.18) > 0.2 && filmic(0.18) < 0.3); // mid grey stays mid
/// assert_eq!(filmic(1e6), 1.0);
/// ```
pub fn filmic(x: f32) -> f32 {
    // At 8 the curve is above 1 already; the bound keeps x * x finite for any radiance.
    let x = if x > 0.0 { x.min(8.0) } else { 0.0 };
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// sRGB opto-electronic transfer function (linear 0..1 to encoded 0..1).
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Exposed linear radiance to display sRGB bytes.
pub fn tone_map_to_srgb8(p: Vec3) -> [u8; 3] {
    [p.x, p.y, p.z].map(|c| (linear_to_srgb(filmic(c)) * 255.0 + 0.5) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip() {
        let dir = tempfile::Builder::new()
            .prefix("octolux-exr-")
            .tempdir()
            .unwrap();
        let path = dir.path().join("a.exr");
        let mut image = HdrImage::new(3, 2);
        image.set(2, 1, Vec3::new(1.5, 0.25, 100.0));
        image.set(0, 0, Vec3::new(0.001, 2.0, 3.0));
        image.write_exr(&path).unwrap();
        assert_eq!(HdrImage::read_exr(&path).unwrap(), image);
    }

    #[test]
    fn failed_writes_leave_the_file_and_no_temporary() {
        let dir = tempfile::Builder::new()
            .prefix("octolux-atomic-")
            .tempdir()
            .unwrap();
        let path = dir.path().join("keep.png");
        std::fs::write(&path, b"old").unwrap();
        let e = write_atomically(&path, |tmp| {
            std::fs::write(tmp, b"half").unwrap();
            Err(Error::InvalidArgument("failed".into()))
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn tone_map_is_monotonic_and_bounded() {
        assert_eq!(tone_map_to_srgb8(Vec3::ZERO), [0, 0, 0]);
        assert_eq!(tone_map_to_srgb8(Vec3::splat(1e6)), [255, 255, 255]);
        let mut last = 0.0;
        for i in 0..1000 {
            let v = linear_to_srgb(filmic(i as f32 * 0.01));
            assert!(v >= last);
            last = v;
        }
    }
}
