//! Sampling the clipmap. `clip_sample(p, footprint)` (the WGSL module `voxel/clipmap/sample`,
//! CPU twin [`clip_sample`]) reads the finest level whose voxel is at least the footprint and
//! which holds `p`'s whole trilinear neighbourhood; `clip_radiance_sample`
//! (`voxel/clipmap/radiance_sample`, CPU twin [`clip_radiance_sample`]) reads the injected
//! radiance the same way; both read the parameter block [`ClipInfo`], bound with the voxels by
//! [`clip_bindings`]. A level that does not contain `p` is never read.
//!
//! Blending between levels by distance to a level's border and reading anisotropic voxels: the
//! WGSL module `voxel/clipmap/blend` (`clip_sample_blend`, `clip_sample_aniso`), its CPU twins
//! [`clip_sample_blend`] and [`clip_sample_aniso`], and [`probe_blend`], which evaluates the
//! WGSL at given points for tests.
//!
//! Level choice: the level `l` of `clip_sample` (the finest whose voxel is at least the
//! footprint and which holds the point's trilinear neighbourhood), mixed with level `l + 1` by
//! `1 - (1 - t)(1 - e)`, `t` the fractional footprint level and `e` a smoothstep that rises
//! from 0 at [`BLEND_CELLS`] voxels inside the border of level `l` to 1 on it. A level that
//! does not contain the point is never read.

use super::ClipmapSettings;
use crate::gpu::GpuContext;
use crate::voxel::clipmap::Clipmap;
use crate::voxel::sample::trilinear;
use crate::{Error, Result};
use glam::{IVec3, Vec3, Vec4};

/// First binding (group 0) of the clipmap's samplers (WGSL modules `voxel/clipmap/sample`,
/// `radiance_sample`, `blend`): `clip_info`, `clip_voxels` ([`clip_bindings`]).
pub const CLIP_BINDINGS: u32 = 64;
/// The radiance sampler's `clip_radiance`.
pub const CLIP_RADIANCE_BINDING: u32 = 66;
/// The anisotropic sampler's `clip_aniso` (`blend.wgsl`).
pub const CLIP_ANISO_BINDING: u32 = 67;

/// The entries every clipmap sampler reads: `info` (a [`ClipInfo`] block) and the voxels.
pub fn clip_bindings<'a>(
    info: &'a wgpu::Buffer,
    voxels: &'a wgpu::Buffer,
) -> [(u32, wgpu::BindingResource<'a>); 2] {
    [
        (CLIP_BINDINGS, info.as_entire_binding()),
        (CLIP_BINDINGS + 1, voxels.as_entire_binding()),
    ]
}

/// Parameter block `ClipInfo` of `voxel/clipmap/sample.wgsl` (a read-only storage buffer).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClipInfo {
    /// Voxel edge of the finest level.
    pub voxel_size: f32,
    /// Voxels per axis of every level.
    pub resolution: u32,
    /// Number of levels.
    pub levels: u32,
    pub _pad: u32,
    /// First voxel of each level (xyz; w unused).
    pub origins: [[i32; 4]; 8],
}

impl ClipInfo {
    /// The block for a clipmap with these settings and level origins (levels without an
    /// origin are treated as empty by placing them far away).
    pub fn new(settings: &ClipmapSettings, origins: &[Option<IVec3>]) -> ClipInfo {
        let mut o = [[i32::MIN / 2; 4]; 8];
        for (slot, origin) in o.iter_mut().zip(origins) {
            if let Some(origin) = origin {
                *slot = origin.extend(0).to_array();
            }
        }
        ClipInfo {
            voxel_size: settings.voxel_size,
            resolution: settings.resolution,
            levels: settings.levels,
            _pad: 0,
            origins: o,
        }
    }
}

fn clip_voxel(voxels: &[u32], res: u32, l: u32, g: IVec3) -> Vec4 {
    let r = res as i32;
    let m = g.rem_euclid(IVec3::splat(r)).as_uvec3();
    let w = voxels[(l * res * res * res + m.x + res * (m.y + res * m.z)) as usize];
    Vec4::new(
        (w & 255) as f32 / 255.0,
        ((w >> 8) & 255) as f32 / 255.0,
        ((w >> 16) & 255) as f32 / 255.0,
        (w >> 24) as f32 / 255.0,
    )
}

fn clip_contains(info: &ClipInfo, p: Vec3, l: u32) -> bool {
    let g = p / (info.voxel_size * (1u32 << l) as f32) - 0.5;
    let o = info.origins[l as usize];
    let lo = Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
    g.cmpge(lo).all()
        && g.cmplt(lo + Vec3::splat(info.resolution as f32 - 1.0))
            .all()
}

fn clip_sample_level(
    info: &ClipInfo,
    p: Vec3,
    l: u32,
    fetch: &impl Fn(u32, IVec3) -> Vec4,
) -> Vec4 {
    let g = p / (info.voxel_size * (1u32 << l) as f32) - 0.5;
    let i0 = g.floor().as_ivec3();
    let f = g - g.floor();
    trilinear(f, |o| fetch(l, i0 + o.as_ivec3()))
}

/// CPU twin of `clip_sample`, over voxels read back with
/// [`super::Clipmap::read_voxels`].
pub fn clip_sample(info: &ClipInfo, voxels: &[u32], p: Vec3, footprint: f32) -> Vec4 {
    clip_sample_with(info, p, footprint, &|l, g| {
        clip_voxel(voxels, info.resolution, l, g)
    })
}

/// CPU twin of `clip_radiance_sample`, over radiance read back with
/// [`super::Clipmap::read_radiance`].
pub fn clip_radiance_sample(info: &ClipInfo, radiance: &[Vec4], p: Vec3, footprint: f32) -> Vec4 {
    let res = info.resolution;
    clip_sample_with(info, p, footprint, &|l, g| {
        let m = g.rem_euclid(IVec3::splat(res as i32)).as_uvec3();
        radiance[(l * res * res * res + m.x + res * (m.y + res * m.z)) as usize]
    })
}

/// CPU twin of `clip_radiance_facing_level` (`voxel/clipmap/radiance_sample.wgsl`): level
/// `l`'s trilinear sample at `p` of the radiance and of its facing sum (each voxel's facing
/// times its radiance's r + g + b, [`crate::voxel::facing`]), over radiance and facing read
/// back with [`super::Clipmap::read_radiance`] and [`super::Clipmap::read_facing`].
pub fn clip_radiance_facing_level(
    info: &ClipInfo,
    radiance: &[Vec4],
    facing: &[Vec3],
    p: Vec3,
    l: u32,
) -> (Vec4, Vec3) {
    let res = info.resolution;
    let slot = |l: u32, g: IVec3| {
        let m = g.rem_euclid(IVec3::splat(res as i32)).as_uvec3();
        (l * res * res * res + m.x + res * (m.y + res * m.z)) as usize
    };
    let r = clip_sample_level(info, p, l, &|l, g| radiance[slot(l, g)]);
    let f = clip_sample_level(info, p, l, &|l, g| {
        let s = slot(l, g);
        (facing[s] * radiance[s].truncate().element_sum()).extend(0.0)
    });
    (r, f.truncate())
}

/// CPU twin of `clip_thicken` (`voxel/clipmap/radiance_sample.wgsl`): a sample of a level
/// `levels_above` levels coarser than the one its surfaces are voxelised on, its opacity a
/// (the occupied fraction of its volume) read as a medium's over the voxel's width,
/// 1 - (1 - a)^(2^levels_above); its radiance and facing sum scaled alike.
pub fn clip_thicken(radiance: Vec4, facing: Vec3, levels_above: u32) -> (Vec4, Vec3) {
    let a = radiance.w.clamp(0.0, 1.0);
    if levels_above == 0 || a <= 0.0 || a >= 1.0 {
        return (radiance, facing);
    }
    let thick = 1.0 - (1.0 - a).powf((1u32 << levels_above.min(30)) as f32);
    let k = thick / a;
    (radiance * k, facing * k)
}

fn clip_sample_with(
    info: &ClipInfo,
    p: Vec3,
    footprint: f32,
    fetch: &impl Fn(u32, IVec3) -> Vec4,
) -> Vec4 {
    let levels = info.levels;
    let lod = (footprint / info.voxel_size)
        .max(1.0)
        .log2()
        .clamp(0.0, (levels - 1) as f32);
    let mut l = lod.floor() as u32;
    while l < levels && !clip_contains(info, p, l) {
        l += 1;
    }
    if l >= levels {
        return Vec4::ZERO;
    }
    let a = clip_sample_level(info, p, l, fetch);
    let t = lod - lod.floor();
    if t <= 0.0 || l as f32 > lod.floor() || l + 1 >= levels || !clip_contains(info, p, l + 1) {
        return a;
    }
    a.lerp(clip_sample_level(info, p, l + 1, fetch), t)
}

/// Width (voxels of the finer level) of the band along a level's border over which samples
/// fade to the next coarser level (`CLIP_BLEND_CELLS` in WGSL).
pub const BLEND_CELLS: f32 = 2.0;

fn level_grid(info: &ClipInfo, p: Vec3, l: u32) -> Vec3 {
    p / (info.voxel_size * (1u32 << l) as f32) - 0.5
}

/// Whether level `l` holds the trilinear neighbourhood of `p`.
pub fn contains(info: &ClipInfo, p: Vec3, l: u32) -> bool {
    border_distance(info, p, l) >= 0.0 && {
        let g = level_grid(info, p, l);
        let o = info.origins[l as usize];
        let lo = Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
        g.cmplt(lo + Vec3::splat(info.resolution as f32 - 1.0))
            .all()
    }
}

/// Distance (voxels of level `l`) from `p` to the border of the region where level `l` holds
/// `p`'s trilinear neighbourhood (negative outside).
pub fn border_distance(info: &ClipInfo, p: Vec3, l: u32) -> f32 {
    let g = level_grid(info, p, l);
    let o = info.origins[l as usize];
    let lo = Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
    let hi = lo + Vec3::splat(info.resolution as f32 - 1.0);
    let d = (g - lo).min(hi - g);
    d.x.min(d.y.min(d.z))
}

/// The level `clip_sample_blend` reads at `p` (None when no level holds `p`) and the weight
/// of the next coarser level.
pub fn blend_choice(info: &ClipInfo, p: Vec3, footprint: f32) -> Option<(u32, f32)> {
    let levels = info.levels;
    let lod = (footprint / info.voxel_size)
        .max(1.0)
        .log2()
        .clamp(0.0, (levels - 1) as f32);
    let mut l = lod.floor() as u32;
    while l < levels && !contains(info, p, l) {
        l += 1;
    }
    if l >= levels {
        return None;
    }
    if l + 1 >= levels || !contains(info, p, l + 1) {
        return Some((l, 0.0));
    }
    let t = if l as f32 == lod.floor() {
        lod - lod.floor()
    } else {
        0.0
    };
    let x = (border_distance(info, p, l) / BLEND_CELLS).clamp(0.0, 1.0);
    let e = 1.0 - x * x * (3.0 - 2.0 * x);
    Some((l, 1.0 - (1.0 - t) * (1.0 - e)))
}

fn unorm8(w: u32) -> Vec4 {
    Vec4::new(
        (w & 255) as f32 / 255.0,
        ((w >> 8) & 255) as f32 / 255.0,
        ((w >> 16) & 255) as f32 / 255.0,
        (w >> 24) as f32 / 255.0,
    )
}

fn slot(res: u32, g: IVec3) -> usize {
    let m = g.rem_euclid(IVec3::splat(res as i32)).as_uvec3();
    (m.x + res * (m.y + res * m.z)) as usize
}

/// Trilinear sample of level `l` at `p` over `fetch(level, voxel)` (world-voxel coordinates).
pub fn sample_level(
    info: &ClipInfo,
    p: Vec3,
    l: u32,
    fetch: &mut impl FnMut(u32, IVec3) -> Vec4,
) -> Vec4 {
    let g = level_grid(info, p, l);
    let i0 = g.floor().as_ivec3();
    trilinear(g - g.floor(), |o| fetch(l, i0 + o.as_ivec3()))
}

/// CPU twin of `clip_sample_blend` over any voxel source `fetch(level, voxel)`.
pub fn clip_sample_blend_with(
    info: &ClipInfo,
    p: Vec3,
    footprint: f32,
    mut fetch: impl FnMut(u32, IVec3) -> Vec4,
) -> Vec4 {
    let Some((l, w)) = blend_choice(info, p, footprint) else {
        return Vec4::ZERO;
    };
    let a = sample_level(info, p, l, &mut fetch);
    if w <= 0.0 {
        return a;
    }
    a.lerp(sample_level(info, p, l + 1, &mut fetch), w)
}

/// CPU twin of `clip_sample_blend` over voxels read back with [`Clipmap::read_voxels`].
pub fn clip_sample_blend(info: &ClipInfo, voxels: &[u32], p: Vec3, footprint: f32) -> Vec4 {
    let res = info.resolution;
    clip_sample_blend_with(info, p, footprint, |l, g| {
        voxels
            .get((l * res * res * res) as usize + slot(res, g))
            .map_or(Vec4::ZERO, |&w| unorm8(w))
    })
}

/// CPU twin of `clip_sample_aniso` over voxels and directional values read back with
/// [`Clipmap::read_voxels`] and [`Clipmap::read_aniso`]; `dir` is the travel direction.
pub fn clip_sample_aniso(
    info: &ClipInfo,
    voxels: &[u32],
    aniso: &[u32],
    p: Vec3,
    footprint: f32,
    dir: Vec3,
) -> Vec4 {
    let res = info.resolution;
    let n = (res * res * res) as usize;
    let a = dir.abs();
    let w = a / (a.x + a.y + a.z).max(1e-20);
    let faces = [
        if dir.x >= 0.0 { 0 } else { 1 },
        if dir.y >= 0.0 { 2 } else { 3 },
        if dir.z >= 0.0 { 4 } else { 5 },
    ];
    let word = |i: usize| aniso.get(i).map_or(Vec4::ZERO, |&v| unorm8(v));
    let mut fetch = |l: u32, g: IVec3| {
        if l == 0 {
            return voxels.get(slot(res, g)).map_or(Vec4::ZERO, |&v| unorm8(v));
        }
        let s = (l as usize - 1) * n + slot(res, g);
        w.x * word(s * 6 + faces[0]) + w.y * word(s * 6 + faces[1]) + w.z * word(s * 6 + faces[2])
    };
    let Some((l, t)) = blend_choice(info, p, footprint) else {
        return Vec4::ZERO;
    };
    let a = sample_level(info, p, l, &mut fetch);
    if t <= 0.0 {
        return a;
    }
    a.lerp(sample_level(info, p, l + 1, &mut fetch), t)
}

/// Evaluates `clip_sample_blend` (without `dirs`) or `clip_sample_aniso` (with one travel
/// direction per point) on the GPU at `points` (xyz position, w footprint). Blocks.
pub fn probe_blend(
    ctx: &GpuContext,
    clipmap: &Clipmap,
    points: &[Vec4],
    dirs: Option<&[Vec3]>,
) -> Result<Vec<Vec4>> {
    let dir_words: Vec<Vec4> = match dirs {
        Some(d) if d.len() != points.len() => {
            return Err(Error::InvalidArgument(format!(
                "{} directions for {} points",
                d.len(),
                points.len()
            )))
        }
        Some(_) if clipmap.aniso.is_none() => {
            return Err(Error::InvalidArgument(
                "directional samples need a clipmap with anisotropic voxels".into(),
            ))
        }
        Some(d) => d.iter().map(|d| d.extend(1.0)).collect(),
        None => vec![Vec4::ZERO; points.len()],
    };
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let owner = "clipmap probe";
    let imports = "import octolux::voxel::clipmap::blend::{clip_sample_aniso, clip_sample_blend};";
    let sample =
        "select(clip_sample_blend(q.xyz, q.w), clip_sample_aniso(q.xyz, q.w, d.xyz), d.w > 0.5)";
    let info = ctx.create_buffer_init(
        owner,
        "info",
        bytemuck::bytes_of(&ClipInfo::new(&clipmap.settings, &clipmap.origins)),
        wgpu::BufferUsages::STORAGE,
    );
    let aniso = clipmap.aniso.as_ref().unwrap_or(&clipmap.voxels);
    let mut fixed = clip_bindings(&info, &clipmap.voxels).to_vec();
    fixed.push((CLIP_ANISO_BINDING, aniso.as_entire_binding()));
    crate::voxel::sample::run_directional_probe(
        ctx,
        owner,
        (imports, sample),
        &fixed,
        points,
        &dir_words,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn clip_info_mirrors_the_wgsl_block() {
        assert_mirrors_wgsl!(
            ClipInfo,
            "voxel/clipmap/sample",
            "ClipInfo",
            [voxel_size, resolution, levels, _pad, origins]
        );
    }
}
