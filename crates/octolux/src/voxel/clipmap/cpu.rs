//! The clipmap's voxels on the CPU: per-level voxelization, emission, the level filter and
//! the anisotropic values, written for clarity; the tests compare the GPU clipmap with them.

use super::{covered_box, decode_emission_fixed, emission_fixed, encode_emission, ClipmapSettings};
use crate::voxel::pairs::{pack_u8, unpack_u8};
use crate::voxel::voxelize::snap::{piece_voxels, snap_triangles, SnapRegion};
use crate::voxel::VoxelTriangle;
use glam::{IVec3, Vec3};
use std::collections::BTreeMap;

/// Integer sums of one clipmap voxel: albedo r, g, b and fragment count, and the fixed-point
/// emission sums (64 bits, as the GPU's carry words).
#[derive(Clone, Copy, Default)]
struct ClipSums {
    albedo: [u32; 4],
    emission: [u64; 3],
}

/// Per level, the sums of every touched voxel of the level's extent (world-voxel coordinates).
fn clipmap_sums(
    settings: &ClipmapSettings,
    origins: &[IVec3],
    tris: &[VoxelTriangle],
) -> Vec<BTreeMap<[i32; 3], ClipSums>> {
    let res = settings.resolution as i32;
    let mut out = Vec::new();
    for (l, &origin) in origins.iter().enumerate() {
        let region = SnapRegion {
            origin: Vec3::ZERO,
            voxel_size: settings.level_voxel(l as u32),
            lo: origin,
            hi: origin + IVec3::splat(res),
        };
        let mut sums: BTreeMap<[i32; 3], ClipSums> = BTreeMap::new();
        for piece in snap_triangles(&region, tris) {
            let tri = &tris[piece.triangle as usize];
            for v in piece_voxels(&piece, region.size()) {
                let s = sums.entry((v + origin).to_array()).or_default();
                for (sum, a) in s.albedo.iter_mut().zip(tri.albedo) {
                    *sum += a as u32;
                }
                s.albedo[3] += 1;
                for (sum, e) in s.emission.iter_mut().zip(tri.emission.to_array()) {
                    *sum += emission_fixed(e) as u64;
                }
            }
        }
        out.push(sums);
    }
    out
}

/// The voxels of a clipmap whose levels start at `origins` (world-voxel coordinates), in the
/// GPU's layout (level after level, toroidal slots, RGBA8: albedo averaged with rounding,
/// alpha 255 where a triangle touches the voxel).
pub fn clipmap_voxels(
    settings: &ClipmapSettings,
    origins: &[IVec3],
    tris: &[VoxelTriangle],
) -> Vec<u32> {
    let res = settings.resolution as i32;
    let r = res as usize;
    let mut out = vec![0u32; origins.len() * r * r * r];
    for (l, sums) in clipmap_sums(settings, origins, tris)
        .into_iter()
        .enumerate()
    {
        for (g, s) in sums {
            let s = s.albedo;
            let half = s[3] / 2;
            let word = ((s[0] + half) / s[3])
                | (((s[1] + half) / s[3]) << 8)
                | (((s[2] + half) / s[3]) << 16)
                | (255 << 24);
            let m = IVec3::from(g).rem_euclid(IVec3::splat(res)).as_uvec3();
            out[l * r * r * r + m.x as usize + r * (m.y as usize + r * m.z as usize)] = word;
        }
    }
    out
}

/// The emission of a clipmap whose levels start at `origins`, in the GPU's layout (CPU twin of
/// `resolve` in `clipmap/update.wgsl`): per touched voxel the rounded integer mean of its fragments'
/// fixed-point emission ([`super::emission_fixed`]) as an RGB9E5 word
/// ([`super::encode_emission`]); 0 elsewhere.
pub fn clipmap_emission(
    settings: &ClipmapSettings,
    origins: &[IVec3],
    tris: &[VoxelTriangle],
) -> Vec<u32> {
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    let mut out = vec![0u32; origins.len() * n];
    for (l, sums) in clipmap_sums(settings, origins, tris)
        .into_iter()
        .enumerate()
    {
        for (g, s) in sums {
            let count = s.albedo[3] as u64;
            let mean = s.emission.map(|e| ((e + count / 2) / count) as u32);
            out[l * n + clip_slot(res, IVec3::from(g))] = encode_emission(mean);
        }
    }
    out
}

/// Level filtering of a clipmap's emission (CPU twin of the emission part of `filter_level`
/// in `clipmap/filter.wgsl`), in place over [`clipmap_emission`]'s layout: level by level from
/// level 1, the voxels wholly inside the finer level become the rounded integer mean of the
/// fixed-point emission of their 2x2x2 finer voxels (empty ones count as zero), re-encoded.
pub fn clipmap_filter_emission(
    settings: &ClipmapSettings,
    origins: &[IVec3],
    emission: &mut [u32],
) {
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    for l in 1..origins.len() {
        let b = covered_box(l as u32, origins[l - 1], res);
        for z in b.lo.z..b.hi.z {
            for y in b.lo.y..b.hi.y {
                for x in b.lo.x..b.hi.x {
                    let c = IVec3::new(x, y, z);
                    let mut sum = [0u32; 3];
                    for k in 0..8 {
                        let o = IVec3::new(k & 1, (k >> 1) & 1, (k >> 2) & 1);
                        let v = decode_emission_fixed(
                            emission[(l - 1) * n + clip_slot(res, 2 * c + o)],
                        );
                        for (s, v) in sum.iter_mut().zip(v) {
                            *s += v;
                        }
                    }
                    emission[l * n + clip_slot(res, c)] = encode_emission(sum.map(|s| (s + 4) / 8));
                }
            }
        }
    }
}

fn clip_slot(res: i32, g: IVec3) -> usize {
    let m = g.rem_euclid(IVec3::splat(res)).as_uvec3();
    let r = res as u32;
    (m.x + r * (m.y + r * m.z)) as usize
}

/// Level filtering of a clipmap (CPU twin of `filter_level` in `clipmap/filter.wgsl`), in
/// place over voxels in the GPU layout ([`clipmap_voxels`]): level by level from level 1, the
/// voxels wholly inside the finer level ([`super::covered_box`]) become the rounded
/// mean of their 2x2x2 finer voxels, per premultiplied channel and opacity.
pub fn clipmap_filter(settings: &ClipmapSettings, origins: &[IVec3], voxels: &mut [u32]) {
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    for l in 1..origins.len() {
        let b = covered_box(l as u32, origins[l - 1], res);
        for z in b.lo.z..b.hi.z {
            for y in b.lo.y..b.hi.y {
                for x in b.lo.x..b.hi.x {
                    let c = IVec3::new(x, y, z);
                    let mut sum = [0u32; 4];
                    for k in 0..8 {
                        let o = IVec3::new(k & 1, (k >> 1) & 1, (k >> 2) & 1);
                        let v = unpack_u8(voxels[(l - 1) * n + clip_slot(res, 2 * c + o)]);
                        for (s, v) in sum.iter_mut().zip(v) {
                            *s += v;
                        }
                    }
                    voxels[l * n + clip_slot(res, c)] = pack_u8(sum.map(|s| (s + 4) / 8));
                }
            }
        }
    }
}

/// The directional values of an anisotropic clipmap (CPU twin of `filter_level` and
/// `replicate` in `clipmap/filter.wgsl`) from its filtered voxels ([`clipmap_filter`]): per
/// voxel slot of levels 1 and up, 6 RGBA8 words for travel along +x, -x, +y, -y, +z, -z. Inside
/// the finer level, the two finer voxels met along the direction composited front to back
/// (rounded integer arithmetic), averaged over the 4 pairs; elsewhere the isotropic value.
pub fn clipmap_aniso(settings: &ClipmapSettings, origins: &[IVec3], voxels: &[u32]) -> Vec<u32> {
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    let levels = origins.len();
    let mut out = vec![0u32; levels.saturating_sub(1) * n * 6];
    for l in 1..levels {
        let covered = covered_box(l as u32, origins[l - 1], res);
        let o = origins[l];
        for z in o.z..o.z + res {
            for y in o.y..o.y + res {
                for x in o.x..o.x + res {
                    let c = IVec3::new(x, y, z);
                    let s = clip_slot(res, c);
                    let inside = c.cmpge(covered.lo).all() && c.cmplt(covered.hi).all();
                    for d in 0..6usize {
                        out[((l - 1) * n + s) * 6 + d] = if inside {
                            aniso_value(&out, voxels, n, res, l, c, d)
                        } else {
                            voxels[l * n + s]
                        };
                    }
                }
            }
        }
    }
    out
}

fn aniso_value(
    aniso: &[u32],
    voxels: &[u32],
    n: usize,
    res: i32,
    l: usize,
    c: IVec3,
    d: usize,
) -> u32 {
    let fine = |g: IVec3| {
        let s = clip_slot(res, g);
        unpack_u8(if l == 1 {
            voxels[s]
        } else {
            aniso[((l - 2) * n + s) * 6 + d]
        })
    };
    let axis = d / 2;
    let mut acc = [0u32; 4];
    for j in 0..4 {
        let mut o0 = IVec3::ZERO;
        let others: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
        o0[others[0]] = j & 1;
        o0[others[1]] = (j >> 1) & 1;
        let mut o1 = o0;
        o1[axis] = 1;
        let (front, back) = if d.is_multiple_of(2) {
            (o0, o1)
        } else {
            (o1, o0)
        };
        let f = fine(2 * c + front);
        let b = fine(2 * c + back);
        for i in 0..4 {
            acc[i] += f[i] + ((255 - f[3]) * b[i] + 127) / 255;
        }
    }
    pack_u8(acc.map(|a| (a + 2) / 4))
}
