//! Image error metrics: a test image against a reference, both linear HDR of the same size,
//! optionally restricted to a mask (`true` = pixel counts).
//!
//! Definitions (means are over the pixels in the mask and the three colour channels):
//! - **MSE**: mean of (a - b)^2 on linear values;
//! - **relMSE**: mean of (a - b)^2 / (b^2 + 0.01), b = reference ([`REL_MSE_EPSILON`] keeps
//!   black reference pixels from dominating);
//! - **PSNR**: 10 log10(1 / MSE) on the *display* images, i.e. tone-mapped exactly as the PNG
//!   output ([`display`]: scale by 2^exposure, filmic curve, sRGB encoding; values in 0..1,
//!   peak 1, not quantised). Identical images give [`PSNR_CAP_DB`] rather than infinity so the
//!   value stays a JSON number;
//! - **SSIM**: Wang et al. 2004 on the luma (Rec. 709 weights on the sRGB-encoded display
//!   values) with an 11 x 11 Gaussian window (sigma 1.5, truncated and renormalised at the
//!   borders), C1 = 0.01^2, C2 = 0.03^2; the mean of the SSIM map over the mask;
//! - **FLIP**: NVIDIA's LDR-FLIP (the `nv-flip` crate has no HDR-FLIP) on the display images
//!   quantised to 8-bit sRGB, at [`MetricOptions::pixels_per_degree`]; the mean of the FLIP
//!   map over the mask.
//!
//! Use [`compare`] for all of them, [`flip_map`] for a per-pixel error image.

use crate::image_io::{filmic, linear_to_srgb, write_rgb8_png, HdrImage};
use crate::scene::srgb_to_linear;
use crate::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The epsilon of relMSE's denominator b^2 + eps.
pub const REL_MSE_EPSILON: f64 = 0.01;
/// PSNR reported for identical images.
pub const PSNR_CAP_DB: f64 = 100.0;

/// The error of a test image against a reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Mean squared error, linear values.
    pub mse: f64,
    /// Relative mean squared error, linear values.
    pub rel_mse: f64,
    /// Peak signal-to-noise ratio of the display images, dB (higher is better).
    pub psnr: f64,
    /// Structural similarity of the display luma, 1 = identical.
    pub ssim: f64,
    /// Mean LDR-FLIP error of the display images, 0 = identical.
    pub flip: f64,
}

/// How images are turned into display images for PSNR, SSIM and FLIP.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetricOptions {
    /// Exposure in stops applied before tone mapping (use the scene's).
    pub exposure: f32,
    /// FLIP's observer model: pixels per degree of visual angle.
    pub pixels_per_degree: f32,
}

impl Default for MetricOptions {
    fn default() -> Self {
        MetricOptions {
            exposure: 0.0,
            pixels_per_degree: nv_flip::DEFAULT_PIXELS_PER_DEGREE,
        }
    }
}

/// Checks sizes and mask, and returns the indices of the pixels that count.
fn selected(test: &HdrImage, reference: &HdrImage, mask: Option<&[bool]>) -> Result<Vec<usize>> {
    if test.width != reference.width || test.height != reference.height {
        return Err(Error::InvalidArgument(format!(
            "image sizes differ: {}x{} (test) vs {}x{} (reference)",
            test.width, test.height, reference.width, reference.height
        )));
    }
    let n = test.width as usize * test.height as usize;
    if test.pixels.len() != n || reference.pixels.len() != n {
        return Err(Error::InvalidArgument(
            "image pixel count does not match its size".into(),
        ));
    }
    let indices: Vec<usize> = match mask {
        Some(mask) if mask.len() != n => {
            return Err(Error::InvalidArgument(format!(
                "mask has {} entries for a {}x{} image",
                mask.len(),
                test.width,
                test.height
            )))
        }
        Some(mask) => (0..n).filter(|&i| mask[i]).collect(),
        None => (0..n).collect(),
    };
    if indices.is_empty() {
        return Err(Error::InvalidArgument(
            "no pixel to compare (empty image or empty mask)".into(),
        ));
    }
    Ok(indices)
}

/// Mean over the selected pixels and channels of `f(test, reference)`.
fn channel_mean(
    test: &HdrImage,
    reference: &HdrImage,
    indices: &[usize],
    f: impl Fn(f64, f64) -> f64,
) -> f64 {
    let sum: f64 = indices
        .iter()
        .map(|&i| {
            let (a, b) = (test.pixels[i], reference.pixels[i]);
            (0..3).map(|c| f(a[c] as f64, b[c] as f64)).sum::<f64>()
        })
        .sum();
    sum / (3 * indices.len()) as f64
}

/// A linear value as displayed: exposure, filmic tone curve, sRGB encoding (0..1).
pub fn display(p: Vec3, exposure: f32) -> Vec3 {
    let scale = exposure.exp2();
    (p * scale)
        .to_array()
        .map(|c| linear_to_srgb(filmic(c)))
        .into()
}

fn display_image(image: &HdrImage, exposure: f32) -> Vec<Vec3> {
    image.pixels.iter().map(|&p| display(p, exposure)).collect()
}

/// Mean squared error on linear values.
pub fn mse(test: &HdrImage, reference: &HdrImage, mask: Option<&[bool]>) -> Result<f64> {
    let idx = selected(test, reference, mask)?;
    Ok(channel_mean(test, reference, &idx, |a, b| {
        (a - b) * (a - b)
    }))
}

/// Relative mean squared error: mean of (a - b)^2 / (b^2 + 0.01), b = reference.
pub fn rel_mse(test: &HdrImage, reference: &HdrImage, mask: Option<&[bool]>) -> Result<f64> {
    let idx = selected(test, reference, mask)?;
    Ok(channel_mean(test, reference, &idx, |a, b| {
        (a - b) * (a - b) / (b * b + REL_MSE_EPSILON)
    }))
}

/// How relMSE is spread over the pixels: whether an image's error is a little everywhere or
/// a few pixels far off (noise, fireflies, singular light), which the mean alone cannot tell.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorDistribution {
    /// Per-pixel relMSE (mean over the channels) at the median, 90th and 99th percentile
    /// (nearest rank).
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Share of the relMSE sum from the worst 1 % of the pixels (at least one pixel): 0.01
    /// for an error spread evenly, near 1 for a few outliers.
    pub worst_1_percent: f64,
    /// Share from the worst 0.1 % (at least one pixel).
    pub worst_0_1_percent: f64,
}

/// The spread of relMSE over the selected pixels ([`ErrorDistribution`]).
pub fn rel_mse_distribution(
    test: &HdrImage,
    reference: &HdrImage,
    mask: Option<&[bool]>,
) -> Result<ErrorDistribution> {
    let idx = selected(test, reference, mask)?;
    let mut errors: Vec<f64> = idx
        .iter()
        .map(|&i| {
            let (a, b) = (test.pixels[i], reference.pixels[i]);
            (0..3)
                .map(|c| {
                    let (a, b) = (a[c] as f64, b[c] as f64);
                    (a - b) * (a - b) / (b * b + REL_MSE_EPSILON)
                })
                .sum::<f64>()
                / 3.0
        })
        .collect();
    errors.sort_by(|a, b| b.total_cmp(a));
    let n = errors.len();
    let total: f64 = errors.iter().sum();
    // Nearest rank, counted from the worst pixel.
    let percentile = |q: f64| errors[((1.0 - q) * n as f64).floor().min((n - 1) as f64) as usize];
    let share = |fraction: f64| {
        let k = ((n as f64 * fraction).ceil() as usize).clamp(1, n);
        if total > 0.0 {
            errors[..k].iter().sum::<f64>() / total
        } else {
            0.0
        }
    };
    Ok(ErrorDistribution {
        p50: percentile(0.5),
        p90: percentile(0.9),
        p99: percentile(0.99),
        worst_1_percent: share(0.01),
        worst_0_1_percent: share(0.001),
    })
}

/// PSNR (dB) of the display images with peak 1, capped at [`PSNR_CAP_DB`].
pub fn psnr(
    test: &HdrImage,
    reference: &HdrImage,
    mask: Option<&[bool]>,
    options: &MetricOptions,
) -> Result<f64> {
    let idx = selected(test, reference, mask)?;
    let display_of = |image: &HdrImage| HdrImage {
        width: image.width,
        height: image.height,
        pixels: display_image(image, options.exposure),
    };
    let (a, b) = (display_of(test), display_of(reference));
    let mse = channel_mean(&a, &b, &idx, |a, b| (a - b) * (a - b));
    Ok(if mse <= 0.0 {
        PSNR_CAP_DB
    } else {
        (-10.0 * mse.log10()).min(PSNR_CAP_DB)
    })
}

/// Rec. 709 luma of display (sRGB-encoded) values.
fn luma(p: Vec3) -> f64 {
    (0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z) as f64
}

/// Separable Gaussian blur with a window truncated and renormalised at the borders.
fn blur(values: &[f64], width: usize, height: usize, kernel: &[f64]) -> Vec<f64> {
    let r = (kernel.len() / 2) as isize;
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        let mut out = vec![0.0; src.len()];
        for y in 0..height {
            for x in 0..width {
                let (mut sum, mut weight) = (0.0, 0.0);
                for (k, w) in kernel.iter().enumerate() {
                    let o = k as isize - r;
                    let (sx, sy) = if horizontal {
                        (x as isize + o, y as isize)
                    } else {
                        (x as isize, y as isize + o)
                    };
                    if sx >= 0 && sy >= 0 && (sx as usize) < width && (sy as usize) < height {
                        sum += w * src[sy as usize * width + sx as usize];
                        weight += w;
                    }
                }
                out[y * width + x] = sum / weight;
            }
        }
        out
    };
    pass(&pass(values, true), false)
}

/// The per-pixel SSIM map of the display luma.
pub fn ssim_map(
    test: &HdrImage,
    reference: &HdrImage,
    options: &MetricOptions,
) -> Result<Vec<f64>> {
    selected(test, reference, None)?;
    let (w, h) = (test.width as usize, test.height as usize);
    let x: Vec<f64> = display_image(test, options.exposure)
        .into_iter()
        .map(luma)
        .collect();
    let y: Vec<f64> = display_image(reference, options.exposure)
        .into_iter()
        .map(luma)
        .collect();
    let sigma = 1.5f64;
    let kernel: Vec<f64> = (-5..=5)
        .map(|i: i32| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let product = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).collect::<Vec<_>>();
    let mx = blur(&x, w, h, &kernel);
    let my = blur(&y, w, h, &kernel);
    let mxx = blur(&product(&x, &x), w, h, &kernel);
    let myy = blur(&product(&y, &y), w, h, &kernel);
    let mxy = blur(&product(&x, &y), w, h, &kernel);
    let (c1, c2) = (0.01f64 * 0.01, 0.03f64 * 0.03);
    Ok((0..w * h)
        .map(|i| {
            let (ux, uy) = (mx[i], my[i]);
            let vx = mxx[i] - ux * ux;
            let vy = myy[i] - uy * uy;
            let cov = mxy[i] - ux * uy;
            ((2.0 * ux * uy + c1) * (2.0 * cov + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2))
        })
        .collect())
}

/// Mean SSIM of the display luma over the mask.
pub fn ssim(
    test: &HdrImage,
    reference: &HdrImage,
    mask: Option<&[bool]>,
    options: &MetricOptions,
) -> Result<f64> {
    let idx = selected(test, reference, mask)?;
    let map = ssim_map(test, reference, options)?;
    Ok(idx.iter().map(|&i| map[i]).sum::<f64>() / idx.len() as f64)
}

/// A per-pixel error image (values 0..1).
#[derive(Clone, Debug)]
pub struct ErrorMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major error values, top row first.
    pub values: Vec<f32>,
}

impl ErrorMap {
    /// The map coloured with FLIP's magma colour map; pixels outside `mask` are black.
    pub fn to_magma_rgb8(&self, mask: Option<&[bool]>) -> Vec<u8> {
        let data = nv_flip::FlipImageFloat::with_data(self.width, self.height, &self.values);
        let mut rgb = data.apply_color_lut(&nv_flip::magma_lut()).to_vec();
        if let Some(mask) = mask {
            for (i, keep) in mask.iter().enumerate() {
                if !keep {
                    rgb[3 * i..3 * i + 3].fill(0);
                }
            }
        }
        rgb
    }

    /// Writes the magma-coloured map as a PNG file.
    pub fn write_png(&self, path: &Path, mask: Option<&[bool]>) -> Result<()> {
        write_rgb8_png(path, self.width, self.height, self.to_magma_rgb8(mask))
    }
}

fn display_rgb8(image: &HdrImage, exposure: f32) -> Vec<u8> {
    display_image(image, exposure)
        .into_iter()
        .flat_map(|p| {
            p.to_array()
                .map(|c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
        })
        .collect()
}

/// The per-pixel LDR-FLIP error of the display images.
pub fn flip_map(
    test: &HdrImage,
    reference: &HdrImage,
    options: &MetricOptions,
) -> Result<ErrorMap> {
    selected(test, reference, None)?;
    let (w, h) = (test.width, test.height);
    let a = nv_flip::FlipImageRgb8::with_data(w, h, &display_rgb8(test, options.exposure));
    let b = nv_flip::FlipImageRgb8::with_data(w, h, &display_rgb8(reference, options.exposure));
    let map = nv_flip::flip(b, a, options.pixels_per_degree);
    Ok(ErrorMap {
        width: w,
        height: h,
        values: map.to_vec(),
    })
}

/// Mean LDR-FLIP error over the mask.
pub fn flip(
    test: &HdrImage,
    reference: &HdrImage,
    mask: Option<&[bool]>,
    options: &MetricOptions,
) -> Result<f64> {
    let idx = selected(test, reference, mask)?;
    let map = flip_map(test, reference, options)?;
    Ok(idx.iter().map(|&i| map.values[i] as f64).sum::<f64>() / idx.len() as f64)
}

/// All metrics with default options (exposure 0, FLIP's default observer).
pub fn compare(test: &HdrImage, reference: &HdrImage, mask: Option<&[bool]>) -> Result<Metrics> {
    compare_with(test, reference, mask, &MetricOptions::default())
}

/// All metrics.
pub fn compare_with(
    test: &HdrImage,
    reference: &HdrImage,
    mask: Option<&[bool]>,
    options: &MetricOptions,
) -> Result<Metrics> {
    Ok(Metrics {
        mse: mse(test, reference, mask)?,
        rel_mse: rel_mse(test, reference, mask)?,
        psnr: psnr(test, reference, mask, options)?,
        ssim: ssim(test, reference, mask, options)?,
        flip: flip(test, reference, mask, options)?,
    })
}

/// Loads an image for comparison: OpenEXR as linear HDR, PNG/JPEG decoded from sRGB to linear
/// (only meaningful for images that were not tone-mapped).
pub fn load_image(path: &Path) -> Result<HdrImage> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        return HdrImage::read_exr(path);
    }
    let image = decode(path)?.to_rgb8();
    Ok(HdrImage {
        width: image.width(),
        height: image.height(),
        pixels: image
            .pixels()
            .map(|p| Vec3::from_array(p.0.map(|c| srgb_to_linear(c as f32 / 255.0))))
            .collect(),
    })
}

/// Loads a mask image: a pixel counts where its (8-bit) luminance is at least one half
/// (white = include). It must have the given size.
pub fn load_mask(path: &Path, width: u32, height: u32) -> Result<Vec<bool>> {
    let image = decode(path)?.to_luma8();
    if image.width() != width || image.height() != height {
        return Err(Error::InvalidArgument(format!(
            "mask {} is {}x{}, images are {width}x{height}",
            path.display(),
            image.width(),
            image.height()
        )));
    }
    Ok(image.pixels().map(|p| p.0[0] >= 128).collect())
}

fn decode(path: &Path) -> Result<image::DynamicImage> {
    let bytes = crate::limits::read_file(path)?;
    crate::limits::decode_image(path, &bytes, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(width: u32, height: u32, v: f32) -> HdrImage {
        let mut image = HdrImage::new(width, height);
        image.pixels.fill(Vec3::splat(v));
        image
    }

    #[test]
    fn the_error_distribution_tells_outliers_from_an_even_error() {
        let reference = grey(100, 10, 1.0);
        // Every pixel 10 % off: each pixel's relMSE is the mean, the worst 1 % hold 1 %.
        let even = grey(100, 10, 1.1);
        let d = rel_mse_distribution(&even, &reference, None).unwrap();
        let off = 1.1f32 as f64 - 1.0;
        let each = off * off / (1.0 + REL_MSE_EPSILON);
        for v in [d.p50, d.p90, d.p99] {
            assert!((v - each).abs() < 1e-9, "{d:?}");
        }
        assert!((d.worst_1_percent - 0.01).abs() < 1e-9, "{d:?}");
        assert!((d.worst_0_1_percent - 0.001).abs() < 1e-9, "{d:?}");
        // One firefly in 1000 pixels: all the error, the median none.
        let mut firefly = grey(100, 10, 1.0);
        firefly.pixels[517] = Vec3::splat(50.0);
        let d = rel_mse_distribution(&firefly, &reference, None).unwrap();
        assert_eq!((d.p50, d.p90, d.p99), (0.0, 0.0, 0.0), "{d:?}");
        assert_eq!(d.worst_0_1_percent, 1.0);
        assert_eq!(d.worst_1_percent, 1.0);
        // Eleven equal fireflies: the worst 1 % (10 pixels) hold 10 of them, the 99th
        // percentile (the 11th worst pixel) is one.
        for i in 0..10 {
            firefly.pixels[i * 97] = Vec3::splat(50.0);
        }
        let d = rel_mse_distribution(&firefly, &reference, None).unwrap();
        assert!(d.p99 > 0.0 && d.p90 == 0.0, "{d:?}");
        assert!((d.worst_1_percent - 10.0 / 11.0).abs() < 1e-9, "{d:?}");
        assert!((d.worst_0_1_percent - 1.0 / 11.0).abs() < 1e-9, "{d:?}");
        // Identical images: no error anywhere, no share.
        let same = rel_mse_distribution(&reference, &reference, None).unwrap();
        assert_eq!(same, ErrorDistribution::default());
    }
}
