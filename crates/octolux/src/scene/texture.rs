//! RGBA8 textures: sRGB-encoded colour, linear alpha (coverage). The GPU samples them as
//! `Rgba8UnormSrgb` with bilinear filtering and repeat addressing; [`Texture::sample`] does the
//! same on the CPU for the path tracer.

use crate::{Error, Result};
use glam::{Vec2, Vec4};
use std::path::Path;

/// An RGBA8 texture.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Name (usually the file name).
    pub name: String,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major RGBA8 texels, top row first; colour is sRGB-encoded, alpha linear.
    pub rgba: Vec<u8>,
}

/// sRGB transfer function, decoding one 8-bit value to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// Largest texture edge accepted, to turn absurd files into errors rather than allocations.
    pub const MAX_SIZE: u32 = 16384;

    /// Loads an image file (PNG, JPEG, TGA, BMP) as an RGBA8 texture. The format comes from
    /// the file extension first (TGA has no signature to recognise it by), then from the
    /// content.
    pub fn load(path: &Path) -> Result<Texture> {
        Self::load_within(path, &crate::limits::Account::default())
    }

    /// [`Texture::load`], charging the file to `account`.
    pub fn load_within(path: &Path, account: &crate::limits::Account) -> Result<Texture> {
        let bytes = account.read_file(path)?;
        let image =
            crate::limits::decode_image(path, &bytes, image::ImageFormat::from_path(path).ok())?;
        if image.width() > Self::MAX_SIZE || image.height() > Self::MAX_SIZE {
            return Err(Error::parse(
                path,
                format!(
                    "image is {}x{}, larger than {}",
                    image.width(),
                    image.height(),
                    Self::MAX_SIZE
                ),
            ));
        }
        let rgba = image.to_rgba8();
        Ok(Texture {
            name: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            width: rgba.width(),
            height: rgba.height(),
            rgba: rgba.into_raw(),
        })
    }

    /// Checks that the texels fill the size: `width` x `height` RGBA8 texels, neither side 0
    /// nor above [`Texture::MAX_SIZE`]. [`crate::scene::validate`] checks every texture so.
    pub fn check(&self) -> Result<()> {
        let expected = self.width as u64 * self.height as u64 * 4;
        if self.width == 0
            || self.height == 0
            || self.width > Self::MAX_SIZE
            || self.height > Self::MAX_SIZE
            || self.rgba.len() as u64 != expected
        {
            return Err(Error::InvalidArgument(format!(
                "texture '{}': {} bytes do not make {}x{} RGBA8 texels (1 to {} per side)",
                self.name,
                self.rgba.len(),
                self.width,
                self.height,
                Self::MAX_SIZE
            )));
        }
        Ok(())
    }

    /// One texel as linear RGB + alpha, with repeat addressing (opaque white for a texture
    /// that fails [`Texture::check`]).
    pub fn texel(&self, x: i64, y: i64) -> Vec4 {
        if self.width == 0 || self.height == 0 {
            return Vec4::ONE;
        }
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.rem_euclid(self.height as i64) as usize;
        let i = (y * self.width as usize + x) * 4;
        let Some(t) = self.rgba.get(i..i + 4) else {
            return Vec4::ONE;
        };
        Vec4::new(
            SRGB_LUT[t[0] as usize],
            SRGB_LUT[t[1] as usize],
            SRGB_LUT[t[2] as usize],
            t[3] as f32 / 255.0,
        )
    }

    /// Bilinear sample at `uv` (repeat addressing, v = 0 at the top row as in glTF and wgpu),
    /// filtering in linear space like an sRGB texture on the GPU.
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let bottom = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

static SRGB_LUT: std::sync::LazyLock<[f32; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)));
