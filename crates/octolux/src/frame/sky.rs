//! The sky on the GPU: what the direct pass needs to light with it and to show it.
//!
//! Rasterised shadowing cannot integrate a whole sphere of light, so the sky is split into
//! [`Sky::directions`] regions of equal light by median cut (Debevec's light-probe sampling):
//! each region becomes a directional light with the region's irradiance, arriving from its
//! light-weighted centre, with an orthographic shadow map like any sun. Every technique sees
//! these lights (the LPV family injects their reflective shadow maps, so sky light bounces).
//!
//! The direct pass does not sum those few lights as they are, which would turn the sky's smooth
//! light into a handful of cosine lobes. It takes the unshadowed irradiance for the surface
//! normal from the sky's order-2 spherical-harmonic projection (exact for a constant sky,
//! within a few percent for smooth maps; Ramamoorthi and Hanrahan 2001) and scales it by the
//! visible fraction of the region lights: E = E_sh(n) x sum(E_k cos_k V_k) / sum(E_k cos_k).
//! Unshadowed surfaces get E_sh exactly; shadows come from the region lights.

use crate::gpu::GpuContext;
use crate::scene::{uv_to_direction, Light, LightKind, Sky, SkyRadiance};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};
use std::f32::consts::PI;

const OWNER: &str = "sky";

/// Largest map the GPU keeps, in texels; bigger maps are box-filtered down by halves.
const MAX_GPU_TEXELS: usize = 2048 * 1024;

/// Size of the grid a constant sky is cut on (any grid gives equal solid angles).
const CONSTANT_GRID: (usize, usize) = (256, 128);

/// The sky as a grid of radiance x solid angle (the light each texel brings), in map space.
struct LightGrid {
    width: usize,
    height: usize,
    /// Radiance x solid angle per texel (W/m^2 on a surface facing it).
    power: Vec<Vec3>,
}

impl LightGrid {
    fn new(sky: &Sky) -> LightGrid {
        let (width, height, radiance): (usize, usize, TexelRadiance) = match &sky.radiance {
            SkyRadiance::Constant(c) => {
                let c = *c * sky.intensity;
                (CONSTANT_GRID.0, CONSTANT_GRID.1, Box::new(move |_, _| c))
            }
            SkyRadiance::Map(map) => {
                let w = map.image.width as usize;
                let s = sky.intensity;
                (
                    w,
                    map.image.height as usize,
                    Box::new(move |x, y| map.image.pixels[y * w + x] * s),
                )
            }
        };
        let mut power = Vec::with_capacity(width * height);
        for y in 0..height {
            let t0 = y as f32 / height as f32 * PI;
            let t1 = (y + 1) as f32 / height as f32 * PI;
            let solid_angle = (t0.cos() - t1.cos()) * 2.0 * PI / width as f32;
            power.extend((0..width).map(|x| radiance(x, y) * solid_angle));
        }
        LightGrid {
            width,
            height,
            power,
        }
    }

    fn direction(&self, x: usize, y: usize) -> Vec3 {
        uv_to_direction(glam::Vec2::new(
            (x as f32 + 0.5) / self.width as f32,
            (y as f32 + 0.5) / self.height as f32,
        ))
    }
}

/// Radiance of texel (x, y).
type TexelRadiance<'a> = Box<dyn Fn(usize, usize) -> Vec3 + 'a>;

/// A rectangle of texels [x0, x1) x [y0, y1).
#[derive(Clone, Copy, Debug)]
struct Region {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// Scalar weight of a texel's light for cutting (mean of the channels).
fn weight(p: Vec3) -> f64 {
    (p.x as f64 + p.y as f64 + p.z as f64) / 3.0
}

impl Region {
    fn energy(&self, grid: &LightGrid) -> f64 {
        (self.y0..self.y1)
            .flat_map(|y| (self.x0..self.x1).map(move |x| (x, y)))
            .map(|(x, y)| weight(grid.power[y * grid.width + x]))
            .sum()
    }

    /// Splits across its angularly longer side at the light median; None for single texels.
    fn split(&self, grid: &LightGrid) -> Option<(Region, Region)> {
        let (w, h) = (self.x1 - self.x0, self.y1 - self.y0);
        if w * h <= 1 {
            return None;
        }
        let mid_theta = ((self.y0 + self.y1) as f32 * 0.5 / grid.height as f32 * PI).sin();
        let angular_w = w as f32 / grid.width as f32 * 2.0 * PI * mid_theta;
        let angular_h = h as f32 / grid.height as f32 * PI;
        let along_x = (angular_w >= angular_h && w > 1) || h == 1;
        let (n, line): (usize, Box<dyn Fn(usize) -> f64>) = if along_x {
            (
                w,
                Box::new(|i| {
                    (self.y0..self.y1)
                        .map(|y| weight(grid.power[y * grid.width + self.x0 + i]))
                        .sum()
                }),
            )
        } else {
            (
                h,
                Box::new(|i| {
                    (self.x0..self.x1)
                        .map(|x| weight(grid.power[(self.y0 + i) * grid.width + x]))
                        .sum()
                }),
            )
        };
        let lines: Vec<f64> = (0..n).map(line).collect();
        let total: f64 = lines.iter().sum();
        // The cut after which the running sum first reaches half (at least one line a side).
        let mut running = 0.0;
        let mut cut = n / 2;
        if total > 0.0 {
            for (i, l) in lines.iter().enumerate() {
                running += l;
                if running >= total * 0.5 {
                    cut = i + 1;
                    break;
                }
            }
        }
        let cut = cut.clamp(1, n - 1);
        Some(if along_x {
            (
                Region {
                    x1: self.x0 + cut,
                    ..*self
                },
                Region {
                    x0: self.x0 + cut,
                    ..*self
                },
            )
        } else {
            (
                Region {
                    y1: self.y0 + cut,
                    ..*self
                },
                Region {
                    y0: self.y0 + cut,
                    ..*self
                },
            )
        })
    }
}

/// How many lights [`sky_lights`] gives: [`Sky::directions`], unless the sky has fewer texels
/// (median cut stops at single texels).
pub fn sky_light_count(sky: &Sky) -> usize {
    let texels = match &sky.radiance {
        SkyRadiance::Constant(_) => CONSTANT_GRID.0 * CONSTANT_GRID.1,
        SkyRadiance::Map(map) => map.image.width as usize * map.image.height as usize,
    };
    (sky.directions.max(1) as usize).min(texels)
}

/// The directional lights that stand in for `sky` in shadowing: [`Sky::directions`] regions
/// of about equal light (the brightest region is split next, so any count works), each with
/// its total irradiance arriving from its light-weighted mean direction (world space).
pub fn sky_lights(sky: &Sky) -> Vec<Light> {
    sky_regions(sky)
        .into_iter()
        .map(|(light, _)| light)
        .collect()
}

/// [`sky_lights`] with the tangent of each light's angular radius: the half-angle of a cap
/// with the same mean cosine about the mean direction as the region's light (a cap of
/// half-angle a has mean cosine (1 + cos a) / 2), so a region whose light is one small sun
/// casts hard shadows and an evenly lit one soft shadows.
pub(crate) fn sky_regions(sky: &Sky) -> Vec<(Light, f32)> {
    let grid = LightGrid::new(sky);
    let whole = Region {
        x0: 0,
        x1: grid.width,
        y0: 0,
        y1: grid.height,
    };
    let mut regions = vec![(whole.energy(&grid), whole)];
    while regions.len() < sky_light_count(sky) {
        // Split the region with the most light that can still be split.
        let Some((i, _)) = regions
            .iter()
            .enumerate()
            .filter(|(_, (_, r))| (r.x1 - r.x0) * (r.y1 - r.y0) > 1)
            .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
        else {
            break;
        };
        let (energy, region) = regions.swap_remove(i);
        let Some((a, b)) = region.split(&grid) else {
            regions.push((energy, region));
            break;
        };
        regions.push((a.energy(&grid), a));
        regions.push((b.energy(&grid), b));
    }
    regions
        .iter()
        .enumerate()
        .map(|(k, (_, r))| {
            let mut sum = Vec3::ZERO;
            let mut centre = DVec3::ZERO;
            let mut total = 0.0f64;
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    let p = grid.power[y * grid.width + x];
                    let w = weight(p).max(1e-12);
                    sum += p;
                    centre += grid.direction(x, y).as_dvec3() * w;
                    total += w;
                }
            }
            let direction = sky.to_world * centre.as_vec3().normalize_or(Vec3::Y);
            let mean_cos = (centre.length() / total).clamp(0.0, 1.0);
            let cos_a = (2.0 * mean_cos - 1.0).clamp(-1.0, 1.0);
            let tan_a = ((1.0 - cos_a * cos_a).sqrt() / cos_a.max(1e-3)).min(10.0) as f32;
            let light = Light {
                name: format!("sky-{k}"),
                kind: LightKind::Directional,
                color: sum,
                intensity: 1.0,
                position: Vec3::ZERO,
                direction: -direction,
                animation: None,
            };
            (light, tan_a)
        })
        .collect()
}

/// The nine real spherical-harmonic basis functions (bands 0-2) at unit direction `d`.
fn sh9(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// Irradiance coefficients of `sky` in world space: the radiance's projection on the nine
/// basis functions, convolved with the clamped cosine (pi, 2pi/3, pi/4 per band), so that
/// [`sh_irradiance`] evaluates irradiance directly.
pub fn sh_irradiance_coefficients(sky: &Sky) -> [Vec3; 9] {
    let mut c = [Vec3::ZERO; 9];
    match &sky.radiance {
        // Exact: only band 0 is non-zero.
        SkyRadiance::Constant(l) => c[0] = *l * sky.intensity * (4.0 * PI * 0.282_095),
        SkyRadiance::Map(_) => {
            let grid = LightGrid::new(sky);
            let mut sum = [DVec3::ZERO; 9];
            for y in 0..grid.height {
                for x in 0..grid.width {
                    let p = grid.power[y * grid.width + x].as_dvec3();
                    let basis = sh9(sky.to_world * grid.direction(x, y));
                    for (s, b) in sum.iter_mut().zip(basis) {
                        *s += p * b as f64;
                    }
                }
            }
            for (out, s) in c.iter_mut().zip(sum) {
                *out = s.as_vec3();
            }
        }
    }
    let band = [PI, 2.0 * PI / 3.0, PI / 4.0];
    for (i, coefficient) in c.iter_mut().enumerate() {
        let l = match i {
            0 => 0,
            1..=3 => 1,
            _ => 2,
        };
        *coefficient *= band[l];
    }
    c
}

/// Unshadowed irradiance for a surface with unit normal `n` (the same sum `direct.wgsl`
/// evaluates), clamped at zero against ringing.
pub fn sh_irradiance(coefficients: &[Vec3; 9], n: Vec3) -> Vec3 {
    sh9(n)
        .iter()
        .zip(coefficients)
        .map(|(b, c)| *c * *b)
        .sum::<Vec3>()
        .max(Vec3::ZERO)
}

/// `SkyParams` of `direct.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SkyParams {
    /// Irradiance coefficients (rgb; the fourth unused).
    sh: [[f32; 4]; 9],
    /// Rows of the world-to-map rotation (xyz; the fourth unused).
    to_map: [[f32; 4]; 3],
    /// A constant sky's radiance (x intensity).
    constant: [f32; 3],
    /// [`SKY_NONE`], [`SKY_CONSTANT`] or [`SKY_MAP`].
    kind: u32,
    /// The map's texels per row.
    map_width: u32,
    /// The map's rows.
    map_height: u32,
    /// Scale of the map's texels.
    intensity: f32,
    _pad: u32,
}

/// [`SkyParams::kind`] without a sky.
const SKY_NONE: u32 = 0;
/// [`SkyParams::kind`] of a constant sky.
const SKY_CONSTANT: u32 = 1;
/// [`SkyParams::kind`] of an environment map.
const SKY_MAP: u32 = 2;

/// The sky's GPU data: parameters and the map (linear RGB texels in a storage buffer, so
/// 32-bit values need no filterable float format; the shader filters like the CPU does).
pub(crate) struct SkyGpu {
    pub params: wgpu::Buffer,
    pub map: wgpu::Buffer,
}

impl SkyGpu {
    pub fn new(ctx: &GpuContext, sky: Option<&Sky>) -> SkyGpu {
        let mut params = SkyParams {
            kind: SKY_NONE,
            ..SkyParams::zeroed()
        };
        let mut texels: Vec<[f32; 4]> = vec![[0.0; 4]];
        if let Some(sky) = sky {
            for (dst, c) in params.sh.iter_mut().zip(sh_irradiance_coefficients(sky)) {
                *dst = c.extend(0.0).to_array();
            }
            let to_map = sky.to_world.transpose();
            params.to_map = [
                to_map.row(0).extend(0.0).to_array(),
                to_map.row(1).extend(0.0).to_array(),
                to_map.row(2).extend(0.0).to_array(),
            ];
            match &sky.radiance {
                SkyRadiance::Constant(c) => {
                    params.constant = (*c * sky.intensity).to_array();
                    params.kind = SKY_CONSTANT;
                }
                SkyRadiance::Map(map) => {
                    let (w, h, pixels) = fit_map(
                        map.image.width as usize,
                        map.image.height as usize,
                        map.image.pixels.clone(),
                    );
                    params.kind = SKY_MAP;
                    params.map_width = w as u32;
                    params.map_height = h as u32;
                    params.intensity = sky.intensity;
                    texels = pixels.iter().map(|p| p.extend(0.0).to_array()).collect();
                }
            }
        }
        let usage = wgpu::BufferUsages::STORAGE;
        SkyGpu {
            params: ctx.create_buffer_init(OWNER, "sky params", bytemuck::bytes_of(&params), usage),
            map: ctx.create_buffer_init(OWNER, "sky map", bytemuck::cast_slice(&texels), usage),
        }
    }
}

/// Halves a map (2x2 box filter) until it has at most [`MAX_GPU_TEXELS`] texels.
fn fit_map(mut w: usize, mut h: usize, mut pixels: Vec<Vec3>) -> (usize, usize, Vec<Vec3>) {
    while w * h > MAX_GPU_TEXELS && w >= 2 && h >= 2 {
        let (nw, nh) = (w / 2, h / 2);
        let mut out = Vec::with_capacity(nw * nh);
        for y in 0..nh {
            for x in 0..nw {
                let p = |dx: usize, dy: usize| pixels[(2 * y + dy) * w + 2 * x + dx];
                out.push((p(0, 0) + p(1, 0) + p(0, 1) + p(1, 1)) * 0.25);
            }
        }
        log::info!("sky map {w}x{h} reduced to {nw}x{nh} for the GPU");
        (w, h, pixels) = (nw, nh, out);
    }
    (w, h, pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sky_params_mirror_the_wgsl_block() {
        crate::gpu::layout::assert_mirrors_wgsl!(
            SkyParams,
            "render/direct",
            "SkyParams",
            [sh, to_map, constant, kind, map_width, map_height, intensity, _pad]
        );
    }
    use crate::image_io::HdrImage;
    use crate::scene::EnvironmentMap;

    fn map_sky() -> Sky {
        let (w, h) = (64u32, 32u32);
        let mut image = HdrImage::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let v = if (20..26).contains(&x) && (6..10).contains(&y) {
                    Vec3::new(30.0, 24.0, 16.0)
                } else {
                    Vec3::new(0.2, 0.3, 0.6) * (1.0 - y as f32 / h as f32)
                };
                image.set(x, y, v);
            }
        }
        let mut sky = Sky::map(EnvironmentMap::from_image("m".into(), image).unwrap());
        sky.to_world = glam::Mat3::from_rotation_y(0.4);
        sky.directions = 12;
        sky
    }

    /// Irradiance for normal `n` by fine quadrature of `Sky::radiance`.
    fn irradiance(sky: &Sky, n: Vec3) -> Vec3 {
        let (nu, nv) = (512, 256);
        let mut sum = DVec3::ZERO;
        for j in 0..nv {
            for i in 0..nu {
                let uv =
                    glam::Vec2::new((i as f32 + 0.5) / nu as f32, (j as f32 + 0.5) / nv as f32);
                let d = uv_to_direction(uv);
                let d_omega = 2.0 * PI * PI * (uv.y * PI).sin() / (nu * nv) as f32;
                sum += (sky.radiance(d) * d.dot(n).max(0.0) * d_omega).as_dvec3();
            }
        }
        sum.as_vec3()
    }

    /// A map with fewer texels than directions gives one light per texel, as counted.
    #[test]
    fn tiny_maps_give_the_counted_lights() {
        let mut image = HdrImage::new(2, 1);
        image.pixels.fill(Vec3::ONE);
        let sky = Sky::map(EnvironmentMap::from_image("tiny".into(), image).unwrap());
        assert_eq!(sky_light_count(&sky), 2);
        assert_eq!(sky_lights(&sky).len(), 2);
        assert_eq!(sky_light_count(&map_sky()), 12);
    }

    /// The region lights carry all of the sky's light, each about an equal share.
    #[test]
    fn median_cut_conserves_the_light() {
        for sky in [map_sky(), Sky::constant(Vec3::new(1.0, 0.5, 0.25))] {
            let lights = sky_lights(&sky);
            assert_eq!(lights.len(), sky.directions as usize);
            let total: Vec3 = lights.iter().map(|l| l.radiant()).sum();
            let power = sky.power();
            assert!(
                ((total - power) / power).abs().max_element() < 1e-4,
                "{total} {power}"
            );
            for l in &lights {
                assert!((l.direction.length() - 1.0).abs() < 1e-5);
            }
        }
        // A constant sky cuts into equal solid angles: equal shares.
        let lights = sky_lights(&Sky::constant(Vec3::ONE));
        let share = 4.0 * PI / lights.len() as f32;
        for l in &lights {
            assert!(
                (l.radiant().x - share).abs() < 0.05 * share,
                "{}",
                l.radiant()
            );
        }
    }

    #[test]
    fn sh_irradiance_is_exact_for_a_constant_sky_and_close_for_a_map() {
        let constant = Sky::constant(Vec3::new(0.5, 1.0, 2.0));
        let c = sh_irradiance_coefficients(&constant);
        for n in [Vec3::Y, Vec3::NEG_X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let e = sh_irradiance(&c, n);
            assert!(
                (e - constant.radiance(n) * PI).abs().max_element() < 1e-4,
                "{e}"
            );
        }
        // A smooth map (the patch blurred out by the cosine): within 10 % of the peak.
        let sky = map_sky();
        let c = sh_irradiance_coefficients(&sky);
        let peak = irradiance(&sky, Vec3::Y).max_element();
        for n in [
            Vec3::Y,
            Vec3::X,
            Vec3::NEG_Z,
            Vec3::new(0.5, 0.5, 0.7).normalize(),
        ] {
            let (got, want) = (sh_irradiance(&c, n), irradiance(&sky, n));
            assert!(
                (got - want).abs().max_element() < 0.1 * peak,
                "{n}: {got} vs {want}"
            );
        }
    }
}
