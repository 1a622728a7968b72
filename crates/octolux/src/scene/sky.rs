//! Sky (environment) light: radiance arriving from infinitely far away in every direction,
//! either one constant colour or an equirectangular map (`.hdr` or `.exr`).
//!
//! Map convention (the same as Mitsuba 3's `envmap`, so imported scenes match): for a
//! direction `d` in the map's frame (y up), `u = atan2(d.x, -d.z) / 2pi` wrapped to [0, 1)
//! and `v = acos(d.y) / pi`; the top row is straight up, the centre column looks along -z
//! and a quarter of the width to the right looks along +x. [`Sky::to_world`] turns the map's
//! frame into the world's.
//!
//! Radiance is in W/(m^2 sr) like emission, scaled by [`Sky::intensity`].

use crate::image_io::HdrImage;
use crate::{Error, Result};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::{PI, TAU};
use std::path::Path;
use std::sync::Arc;

/// Where a sky's radiance comes from.
#[derive(Clone, Debug)]
pub enum SkyRadiance {
    /// The same radiance from every direction (linear RGB).
    Constant(Vec3),
    /// An equirectangular map of linear RGB radiance.
    Map(Arc<EnvironmentMap>),
}

/// A sky light.
#[derive(Clone, Debug)]
pub struct Sky {
    /// Constant colour or map.
    pub radiance: SkyRadiance,
    /// Multiplies the radiance.
    pub intensity: f32,
    /// Rotation from the map's frame to the world (orthonormal).
    pub to_world: Mat3,
    /// How many directional lights with shadow maps stand in for the sky in the GPU renderer
    /// (regions of equal light; see `frame/sky.rs`). More give softer, truer sky shadows at
    /// one shadow-map layer each. The reference path tracer ignores it.
    pub directions: u32,
}

impl Sky {
    /// Default of [`Sky::directions`].
    pub const DEFAULT_DIRECTIONS: u32 = 32;
    /// Largest accepted [`Sky::directions`].
    pub const MAX_DIRECTIONS: u32 = 64;
}

impl Sky {
    /// A constant sky of radiance `color`.
    pub fn constant(color: Vec3) -> Sky {
        Sky {
            radiance: SkyRadiance::Constant(color),
            intensity: 1.0,
            to_world: Mat3::IDENTITY,
            directions: Sky::DEFAULT_DIRECTIONS,
        }
    }

    /// A sky from an equirectangular map.
    pub fn map(map: EnvironmentMap) -> Sky {
        Sky {
            radiance: SkyRadiance::Map(Arc::new(map)),
            intensity: 1.0,
            to_world: Mat3::IDENTITY,
            directions: Sky::DEFAULT_DIRECTIONS,
        }
    }

    /// Radiance arriving from world direction `dir` (unit; the light travels along `-dir`).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        match &self.radiance {
            SkyRadiance::Constant(c) => *c * self.intensity,
            SkyRadiance::Map(map) => {
                let local = self.to_world.transpose() * dir;
                map.lookup(direction_to_uv(local)) * self.intensity
            }
        }
    }

    /// Whether the sky adds no light at all.
    pub fn is_black(&self) -> bool {
        let peak = match &self.radiance {
            SkyRadiance::Constant(c) => c.max_element(),
            SkyRadiance::Map(map) => map
                .image
                .pixels
                .iter()
                .fold(0.0f32, |m, p| m.max(p.max_element())),
        };
        peak * self.intensity <= 0.0
    }

    /// Total radiance x solid angle (W/m^2 per unit area facing all directions, i.e. the
    /// irradiance a sphere's point would get from the whole sphere with cosine = 1): used to
    /// bound the flux the sky can bring.
    pub fn power(&self) -> Vec3 {
        match &self.radiance {
            SkyRadiance::Constant(c) => *c * self.intensity * (4.0 * PI),
            SkyRadiance::Map(map) => map.power() * self.intensity,
        }
    }
}

/// Equirectangular map coordinates of a unit direction in the map's frame.
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    let u = d.x.atan2(-d.z) / TAU;
    let v = d.y.clamp(-1.0, 1.0).acos() / PI;
    Vec2::new(u - u.floor(), v)
}

/// The unit direction (map frame) at equirectangular coordinates `uv`.
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    let phi = uv.x * TAU;
    let theta = uv.y * PI;
    let s = theta.sin();
    Vec3::new(s * phi.sin(), theta.cos(), -s * phi.cos())
}

/// An equirectangular radiance map.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    /// File name for diagnostics.
    pub name: String,
    /// Linear RGB radiance, top row = straight up.
    pub image: HdrImage,
}

impl EnvironmentMap {
    /// Largest accepted edge, to turn absurd files into errors rather than allocations.
    pub const MAX_SIZE: u32 = 16384;

    /// Loads a Radiance `.hdr` or OpenEXR `.exr` map. Negative or non-finite texels and sizes
    /// that are not 2:1-ish are errors naming the file.
    pub fn load(path: &Path) -> Result<EnvironmentMap> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let image = match ext.as_str() {
            "exr" => HdrImage::read_exr(path)?,
            "hdr" => read_radiance_hdr(path)?,
            _ => {
                return Err(Error::parse(
                    path,
                    "environment map: expected an equirectangular .hdr or .exr file",
                ))
            }
        };
        let name = path
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        EnvironmentMap::from_image(name, image).map_err(|e| Error::parse(path, e))
    }

    /// Checks and wraps an image as a map (the message says what is wrong).
    pub fn from_image(name: String, image: HdrImage) -> std::result::Result<Self, String> {
        let (w, h) = (image.width, image.height);
        if w < 2 || h < 1 || w > Self::MAX_SIZE || h > Self::MAX_SIZE {
            return Err(format!(
                "environment map is {w}x{h}; expected between 2x1 and {0}x{0}",
                Self::MAX_SIZE
            ));
        }
        if let Some(i) = image
            .pixels
            .iter()
            .position(|p| !p.is_finite() || p.min_element() < 0.0)
        {
            return Err(format!(
                "environment map texel ({}, {}) is {:?}: radiance must be finite and not negative",
                i as u32 % w,
                i as u32 / w,
                image.pixels[i]
            ));
        }
        Ok(EnvironmentMap { name, image })
    }

    /// The map a Mitsuba scene means by this image, resampled to octolux's row placement.
    ///
    /// octolux, like Radiance, pbrt and Blender, puts the centre of row i at v = (i + 0.5) / H;
    /// Mitsuba 3's `envmap` puts row i at v = i / (H - 1), the first and last rows on the poles,
    /// and interpolates linearly between rows (the columns agree). On a coarse map this moves a
    /// small sun by up to half a row, which changes its power by the sine of its elevation
    /// (1.25 % on the 128 x 64 `afternoon.hdr`). The rows are resampled at
    /// [`EnvironmentMap::MITSUBA_ROW_FACTOR`] times the resolution (less where that would
    /// pass [`EnvironmentMap::MAX_SIZE`] or 2^24 texels) with the values of Mitsuba's
    /// interpolation at the new row centres, which leaves a difference second-order in the new
    /// row height.
    pub fn with_mitsuba_rows(self) -> EnvironmentMap {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        if h < 2 {
            return self;
        }
        let factor = Self::MITSUBA_ROW_FACTOR
            .min(Self::MAX_SIZE as usize / h)
            .min((1 << 24) / (w * h))
            .max(1);
        let rows = h * factor;
        let mut pixels = Vec::with_capacity(w * rows);
        for r in 0..rows {
            let v = (r as f64 + 0.5) / rows as f64;
            let at = v * (h - 1) as f64;
            let i = (at.floor() as usize).min(h - 2);
            let f = (at - i as f64) as f32;
            let (a, b) = (
                &self.image.pixels[i * w..(i + 1) * w],
                &self.image.pixels[(i + 1) * w..(i + 2) * w],
            );
            pixels.extend(a.iter().zip(b).map(|(p, q)| p.lerp(*q, f)));
        }
        EnvironmentMap {
            name: self.name,
            image: HdrImage {
                width: w as u32,
                height: rows as u32,
                pixels,
            },
        }
    }

    /// How much finer [`EnvironmentMap::with_mitsuba_rows`] makes the rows.
    pub const MITSUBA_ROW_FACTOR: usize = 8;

    /// Bilinear lookup at `uv` (u wraps around, v clamps at the poles).
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.image.width as i64, self.image.height as i64);
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |tx: i64, ty: i64| {
            let tx = tx.rem_euclid(w);
            let ty = ty.clamp(0, h - 1);
            self.image.pixels[(ty * w + tx) as usize]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Solid angle of a texel in row `y` (sr).
    pub fn texel_solid_angle(&self, y: u32) -> f32 {
        let h = self.image.height as f32;
        let w = self.image.width as f32;
        let t0 = y as f32 / h * PI;
        let t1 = (y + 1) as f32 / h * PI;
        (t0.cos() - t1.cos()) * TAU / w
    }

    /// Sum of radiance x texel solid angle over the map.
    pub fn power(&self) -> Vec3 {
        let w = self.image.width as usize;
        let mut sum = glam::DVec3::ZERO;
        for (y, row) in self.image.pixels.chunks_exact(w).enumerate() {
            let row_sum: glam::DVec3 = row.iter().map(|p| p.as_dvec3()).sum();
            sum += row_sum * self.texel_solid_angle(y as u32) as f64;
        }
        sum.as_vec3()
    }
}

/// Reads a Radiance RGBE (`.hdr`) file.
fn read_radiance_hdr(path: &Path) -> Result<HdrImage> {
    let bytes = crate::limits::read_file(path)?;
    let image = crate::limits::decode_image(path, &bytes, Some(image::ImageFormat::Hdr))?;
    if image.color() != image::ColorType::Rgb32F {
        return Err(Error::parse(path, "not a Radiance HDR file"));
    }
    let image = image.into_rgb32f();
    let (width, height) = image.dimensions();
    Ok(HdrImage {
        width,
        height,
        pixels: image
            .pixels()
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_and_direction_round_trip() {
        for &d in &[
            Vec3::new(0.3, 0.5, -0.8).normalize(),
            Vec3::new(-0.6, -0.2, 0.7).normalize(),
            Vec3::X,
            Vec3::NEG_Z,
        ] {
            let back = uv_to_direction(direction_to_uv(d));
            assert!((back - d).length() < 1e-5, "{d} -> {back}");
        }
        // Mitsuba's convention: -z at u = 0, +x at u = 1/4, up at v = 0.
        assert!(direction_to_uv(Vec3::NEG_Z).x.abs() < 1e-6);
        assert!((direction_to_uv(Vec3::X).x - 0.25).abs() < 1e-6);
        assert!(direction_to_uv(Vec3::Y).y.abs() < 1e-6);
    }

    #[test]
    fn map_power_of_a_constant_map_is_4_pi() {
        let mut image = HdrImage::new(64, 32);
        image.pixels.fill(Vec3::ONE);
        let map = EnvironmentMap::from_image("c".into(), image).unwrap();
        assert!((map.power() - Vec3::splat(4.0 * PI)).abs().max_element() < 1e-3);
        assert!(
            (map.lookup(Vec2::new(0.99, 0.01)) - Vec3::ONE)
                .abs()
                .max_element()
                < 1e-6
        );
    }

    #[test]
    fn bad_maps_are_errors() {
        let mut image = HdrImage::new(4, 2);
        image.pixels[5] = Vec3::new(f32::NAN, 0.0, 0.0);
        let e = EnvironmentMap::from_image("x".into(), image).unwrap_err();
        assert!(e.contains("(1, 1)"), "{e}");
        assert!(EnvironmentMap::from_image("x".into(), HdrImage::new(1, 1)).is_err());
    }

    /// A 32 x 16 map: a dim gradient sky and a bright 2 x 1-texel sun in the third row.
    fn sunny_map() -> EnvironmentMap {
        let (w, h) = (32u32, 16u32);
        let pixels = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let sky = Vec3::new(0.2, 0.3, 0.5) * (1.0 - y as f32 / h as f32);
                if y == 2 && (x == 10 || x == 11) {
                    sky + Vec3::splat(500.0)
                } else {
                    sky
                }
            })
            .collect();
        EnvironmentMap::from_image(
            "sunny".into(),
            HdrImage {
                width: w,
                height: h,
                pixels,
            },
        )
        .unwrap()
    }

    /// Mitsuba's reading of `map` at `uv`: rows at v = i / (H - 1), columns centred.
    fn mitsuba_lookup(map: &EnvironmentMap, uv: Vec2) -> Vec3 {
        let (w, h) = (map.image.width as i64, map.image.height as i64);
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * (h - 1) as f32;
        let (x0, y0) = (x.floor(), (y.floor() as i64).min(h - 2));
        let (fx, fy) = (x - x0, y - y0 as f32);
        let texel = |tx: i64, ty: i64| map.image.pixels[(ty * w + tx.rem_euclid(w)) as usize];
        let x0 = x0 as i64;
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Radiant power (channel sum) of a radiance function over the sphere, by a fine midpoint
    /// rule in (u, v).
    fn sphere_power(f: impl Fn(Vec2) -> Vec3) -> f64 {
        let (nu, nv) = (1024, 2048);
        let mut sum = 0.0f64;
        for j in 0..nv {
            let v = (j as f64 + 0.5) / nv as f64;
            let row: f64 = (0..nu)
                .map(|i| {
                    let u = (i as f64 + 0.5) / nu as f64;
                    f(Vec2::new(u as f32, v as f32)).element_sum() as f64
                })
                .sum();
            sum += row * (std::f64::consts::PI * v).sin();
        }
        sum * std::f64::consts::TAU / nu as f64 * std::f64::consts::PI / nv as f64
    }

    #[test]
    fn mitsuba_maps_are_resampled_to_the_power_mitsuba_sees() {
        let map = sunny_map();
        let mitsuba = sphere_power(|uv| mitsuba_lookup(&map, uv));
        let raw = sphere_power(|uv| map.lookup(uv));
        let resampled_map = map.clone().with_mitsuba_rows();
        assert_eq!(resampled_map.image.height, 16 * 8);
        let resampled = sphere_power(|uv| resampled_map.lookup(uv));
        let (raw_err, err) = (
            (raw / mitsuba - 1.0).abs(),
            (resampled / mitsuba - 1.0).abs(),
        );
        // Read as octolux reads it, the map's sun sits half a row lower: 7.7 % more power
        // here. Resampled, 0.2 % remains: the one-row sun is the worst case, a tent two rows
        // wide in Mitsuba's reading whose kinks the finer rows' interpolation rounds off.
        assert!(raw_err > 0.05, "raw map {raw_err}");
        assert!(err < 0.005, "resampled map {err} (raw {raw_err})");
        // One row: nothing to place.
        let one = EnvironmentMap::from_image("row".into(), HdrImage::new(4, 1)).unwrap();
        assert_eq!(one.clone().with_mitsuba_rows().image.height, 1);
    }
}
