//! CPU reference implementations of the voxel kernels, written for clarity; the tests compare
//! the GPU structures with them.

use super::svo::SvoCpu;
use super::voxelize::snap::{piece_voxels, snap_triangles, SnapRegion};
use super::{VoxelGrid, VoxelTriangle};
use glam::{IVec3, Vec3, Vec4};
use std::collections::{BTreeMap, BTreeSet};

/// Grid coordinates of `p` in `f32` (for tests that sample the geometry; the voxelizer snaps in
/// `f64`, [`super::voxelize::snap`]).
pub fn to_grid(p: Vec3, grid: &VoxelGrid) -> Vec3 {
    let inv = 1.0 / grid.voxel_size;
    Vec3::new(
        (p.x - grid.origin.x) * inv,
        (p.y - grid.origin.y) * inv,
        (p.z - grid.origin.z) * inv,
    )
}

/// The voxel fragment list the GPU voxelizer produces, in the same order: per snapped piece
/// of each triangle ([`snap_triangles`]), the touched voxels of its cell range in z, y, x loop
/// order, by the same integer test ([`super::voxelize::snap::PieceTest`]).
pub fn voxelize(grid: &VoxelGrid, tris: &[VoxelTriangle]) -> Vec<([u32; 3], u32)> {
    let region = SnapRegion {
        origin: grid.origin,
        voxel_size: grid.voxel_size,
        lo: IVec3::ZERO,
        hi: IVec3::splat(grid.resolution as i32),
    };
    snap_triangles(&region, tris)
        .iter()
        .flat_map(|p| {
            piece_voxels(p, region.size())
                .into_iter()
                .map(move |v| (v.as_uvec3().to_array(), p.triangle))
        })
        .collect()
}

/// Premultiplied albedo and opacity of every occupied voxel: the mean of the albedo of the
/// fragments in it (as the GPU computes it: integer sums, then one division), opacity 1.
pub fn voxel_values(
    fragments: &[([u32; 3], u32)],
    tris: &[VoxelTriangle],
) -> BTreeMap<[u32; 3], Vec4> {
    let mut sums: BTreeMap<[u32; 3], [u32; 4]> = BTreeMap::new();
    for &(v, t) in fragments {
        let s = sums.entry(v).or_default();
        let albedo = tris[t as usize].albedo;
        for (i, a) in albedo.iter().enumerate() {
            s[i] += *a as u32;
        }
        s[3] += 1;
    }
    sums.into_iter().map(|(v, s)| (v, voxel_value(s))).collect()
}

/// One voxel's value from its integer sums (r, g, b, count), as the GPU computes it.
pub fn voxel_value(s: [u32; 4]) -> Vec4 {
    if s[3] == 0 {
        return Vec4::ZERO;
    }
    let n = s[3] as f32;
    Vec4::new(
        s[0] as f32 / n / 255.0,
        s[1] as f32 / n / 255.0,
        s[2] as f32 / n / 255.0,
        1.0,
    )
}

/// One level of the reference octree: nodes by coordinates, each with whether it was
/// subdivided (has 8 children on the next level).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CpuLevel {
    /// Node coordinates (level `d` has `2^d` nodes per axis) -> subdivided.
    pub nodes: BTreeMap<[u32; 3], bool>,
}

/// The reference octree over a `2^depth` voxel grid: level `d` holds nodes of `2^(depth-d)`
/// voxels; a node is subdivided when it holds a voxel or is one of the 26 neighbours of a node
/// that does, and a subdivided node gets all 8 children.
pub fn build_octree(depth: u32, voxels: &BTreeSet<[u32; 3]>) -> Vec<CpuLevel> {
    let mut levels: Vec<CpuLevel> = Vec::new();
    let mut existing: BTreeSet<[u32; 3]> = BTreeSet::from([[0, 0, 0]]);
    for d in 0..depth {
        let shift = depth - d;
        let occupied: BTreeSet<[u32; 3]> = voxels.iter().map(|v| v.map(|c| c >> shift)).collect();
        let mut needed = BTreeSet::new();
        for o in &occupied {
            for n in neighbourhood(*o, 1 << d) {
                if existing.contains(&n) {
                    needed.insert(n);
                }
            }
        }
        let leaf = d + 1 == depth;
        let level = CpuLevel {
            nodes: existing
                .iter()
                .map(|&c| (c, !leaf && needed.contains(&c)))
                .collect(),
        };
        let mut next = BTreeSet::new();
        for (c, &sub) in &level.nodes {
            if sub {
                for o in 0..8u32 {
                    next.insert([
                        c[0] * 2 + (o & 1),
                        c[1] * 2 + ((o >> 1) & 1),
                        c[2] * 2 + ((o >> 2) & 1),
                    ]);
                }
            }
        }
        levels.push(level);
        existing = next;
    }
    levels
}

/// `c` and its up to 26 neighbours inside `[0, n)^3`.
pub fn neighbourhood(c: [u32; 3], n: u32) -> Vec<[u32; 3]> {
    let mut out = Vec::with_capacity(27);
    for dz in -1i64..=1 {
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                let p = [c[0] as i64 + dx, c[1] as i64 + dy, c[2] as i64 + dz];
                if p.iter().all(|&v| v >= 0 && v < n as i64) {
                    out.push(p.map(|v| v as u32));
                }
            }
        }
    }
    out
}

/// A dense corner-sampled lattice of `size`^3 RGBA values.
#[derive(Clone, Debug)]
pub struct Lattice {
    /// Points per axis.
    pub size: u32,
    /// Values, x fastest.
    pub values: Vec<Vec4>,
}

impl Lattice {
    /// The value at integer point `p` (zero outside).
    pub fn get(&self, p: IVec3) -> Vec4 {
        let s = self.size as i32;
        if p.cmplt(IVec3::ZERO).any() || p.cmpge(IVec3::splat(s)).any() {
            return Vec4::ZERO;
        }
        self.values[(p.x + s * (p.y + s * p.z)) as usize]
    }
}

/// The corner-sampled lattices of every octree level, finest last. Level `depth - 1` has its
/// points on voxel corners, each the sum of the touching voxels' values / 8 (empty voxels count
/// as zero: a box filter of the voxels evaluated at the corners); level `d` has `2^(d+1) + 1`
/// points per axis, each the separable [1/4 1/2 1/4] filter of the 27 finer points around the
/// same position.
pub fn lattices(depth: u32, voxels: &BTreeMap<[u32; 3], Vec4>) -> Vec<Lattice> {
    let n = 1u32 << depth;
    let size = n + 1;
    let mut finest = Lattice {
        size,
        values: vec![Vec4::ZERO; (size * size * size) as usize],
    };
    for (v, value) in voxels {
        for o in 0..8u32 {
            let p = [v[0] + (o & 1), v[1] + ((o >> 1) & 1), v[2] + ((o >> 2) & 1)];
            finest.values[(p[0] + size * (p[1] + size * p[2])) as usize] += *value / 8.0;
        }
    }
    let mut out = vec![finest];
    for d in (0..depth - 1).rev() {
        let fine = &out[0];
        let size = (1u32 << (d + 1)) + 1;
        let mut values = vec![Vec4::ZERO; (size * size * size) as usize];
        for z in 0..size as i32 {
            for y in 0..size as i32 {
                for x in 0..size as i32 {
                    let mut sum = Vec4::ZERO;
                    for oz in -1..=1 {
                        for oy in -1..=1 {
                            for ox in -1..=1 {
                                let w = weight(ox) * weight(oy) * weight(oz);
                                sum += fine.get(IVec3::new(2 * x + ox, 2 * y + oy, 2 * z + oz)) * w;
                            }
                        }
                    }
                    values[(x + size as i32 * (y + size as i32 * z)) as usize] = sum;
                }
            }
        }
        out.insert(0, Lattice { size, values });
    }
    out
}

/// Integer sums of one clipmap voxel: albedo r, g, b and fragment count, and the fixed-point
/// emission sums (64 bits, as the GPU's carry words).
#[derive(Clone, Copy, Default)]
struct ClipSums {
    albedo: [u32; 4],
    emission: [u64; 3],
}

/// Per level, the sums of every touched voxel of the level's extent (world-voxel coordinates).
fn clipmap_sums(
    settings: &super::clipmap::ClipmapSettings,
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
                    *sum += super::clipmap::emission_fixed(e) as u64;
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
    settings: &super::clipmap::ClipmapSettings,
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
/// fixed-point emission ([`super::clipmap::emission_fixed`]) as an RGB9E5 word
/// ([`super::clipmap::encode_emission`]); 0 elsewhere.
pub fn clipmap_emission(
    settings: &super::clipmap::ClipmapSettings,
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
            out[l * n + clip_slot(res, IVec3::from(g))] = super::clipmap::encode_emission(mean);
        }
    }
    out
}

/// Level filtering of a clipmap's emission (CPU twin of the emission part of `filter_level`
/// in `clipmap/filter.wgsl`), in place over [`clipmap_emission`]'s layout: level by level from
/// level 1, the voxels wholly inside the finer level become the rounded integer mean of the
/// fixed-point emission of their 2x2x2 finer voxels (empty ones count as zero), re-encoded.
pub fn clipmap_filter_emission(
    settings: &super::clipmap::ClipmapSettings,
    origins: &[IVec3],
    emission: &mut [u32],
) {
    use super::clipmap::{decode_emission_fixed, encode_emission};
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    for l in 1..origins.len() {
        let b = super::clipmap::covered_box(l as u32, origins[l - 1], res);
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

fn unpack_u8(w: u32) -> [u32; 4] {
    [w & 255, (w >> 8) & 255, (w >> 16) & 255, w >> 24]
}

fn pack_u8(v: [u32; 4]) -> u32 {
    v[0] | (v[1] << 8) | (v[2] << 16) | (v[3] << 24)
}

fn clip_slot(res: i32, g: IVec3) -> usize {
    let m = g.rem_euclid(IVec3::splat(res)).as_uvec3();
    let r = res as u32;
    (m.x + r * (m.y + r * m.z)) as usize
}

/// Level filtering of a clipmap (CPU twin of `filter_level` in `clipmap/filter.wgsl`), in
/// place over voxels in the GPU layout ([`clipmap_voxels`]): level by level from level 1, the
/// voxels wholly inside the finer level ([`super::clipmap::covered_box`]) become the rounded
/// mean of their 2x2x2 finer voxels, per premultiplied channel and opacity.
pub fn clipmap_filter(
    settings: &super::clipmap::ClipmapSettings,
    origins: &[IVec3],
    voxels: &mut [u32],
) {
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    for l in 1..origins.len() {
        let b = super::clipmap::covered_box(l as u32, origins[l - 1], res);
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
pub fn clipmap_aniso(
    settings: &super::clipmap::ClipmapSettings,
    origins: &[IVec3],
    voxels: &[u32],
) -> Vec<u32> {
    let res = settings.resolution as i32;
    let n = (res * res * res) as usize;
    let levels = origins.len();
    let mut out = vec![0u32; levels.saturating_sub(1) * n * 6];
    for l in 1..levels {
        let covered = super::clipmap::covered_box(l as u32, origins[l - 1], res);
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

/// Per occupied voxel, its RGBA8 word: the rounded integer mean of its fragments' albedo,
/// alpha 255 (`leaf_voxel` in `svo/aniso.wgsl`, which reads the octree's leaf sums).
pub fn voxel_words(
    fragments: &[([u32; 3], u32)],
    tris: &[VoxelTriangle],
) -> BTreeMap<[u32; 3], u32> {
    let mut sums: BTreeMap<[u32; 3], [u32; 4]> = BTreeMap::new();
    for &(v, t) in fragments {
        let s = sums.entry(v).or_default();
        for (sum, a) in s.iter_mut().zip(tris[t as usize].albedo) {
            *sum += a as u32;
        }
        s[3] += 1;
    }
    sums.into_iter()
        .map(|(v, s)| {
            let half = s[3] / 2;
            let rgb = [0, 1, 2].map(|i| (s[i] + half) / s[3]);
            (v, pack_u8([rgb[0], rgb[1], rgb[2], 255]))
        })
        .collect()
}

/// The anisotropic values of the octree's nodes (CPU twin of `svo/aniso.wgsl`) over a
/// `2^depth` grid with the occupied voxels `voxels` ([`voxel_words`]): entry `d` holds level
/// `d` (nodes of `2^(depth - d)` voxels) by node coordinates, 6 RGBA8 words per node for
/// travel along +x, -x, +y, -y, +z, -z. Only nodes containing an occupied voxel are listed;
/// every other node is zero. On the finest level the values composite the node's 2x2x2 voxels,
/// above that its 8 children's values for the same direction: the two met along the direction
/// front to back (rounded integer arithmetic), averaged over the 4 pairs, as
/// [`clipmap_aniso`] does.
pub fn svo_aniso(
    depth: u32,
    voxels: &BTreeMap<[u32; 3], u32>,
) -> Vec<BTreeMap<[u32; 3], [u32; 6]>> {
    let octant = |c: [u32; 3], o: usize| {
        [
            c[0] * 2 + (o as u32 & 1),
            c[1] * 2 + ((o as u32 >> 1) & 1),
            c[2] * 2 + (o as u32 >> 2),
        ]
    };
    let mut levels: Vec<BTreeMap<[u32; 3], [u32; 6]>> = Vec::new();
    let leaves: BTreeSet<[u32; 3]> = voxels.keys().map(|v| v.map(|c| c >> 1)).collect();
    let finest = leaves
        .into_iter()
        .map(|c| {
            let fine = |o: usize| unpack_u8(voxels.get(&octant(c, o)).copied().unwrap_or(0));
            (c, std::array::from_fn(|d| composite_pairs(d, fine)))
        })
        .collect();
    levels.push(finest);
    for _ in 1..depth {
        let below = &levels[0];
        let parents: BTreeSet<[u32; 3]> = below.keys().map(|v| v.map(|c| c >> 1)).collect();
        let level = parents
            .into_iter()
            .map(|c| {
                let values: [u32; 6] = std::array::from_fn(|d| {
                    composite_pairs(d, |o| {
                        unpack_u8(below.get(&octant(c, o)).map_or(0, |v| v[d]))
                    })
                });
                (c, values)
            })
            .collect();
        levels.insert(0, level);
    }
    levels
}

/// Direction `d` (+x, -x, +y, -y, +z, -z) of a 2x2x2 block of RGBA8 values `fine(octant)`:
/// the two met along the direction composited front to back, averaged over the 4 pairs.
fn composite_pairs(d: usize, fine: impl Fn(usize) -> [u32; 4]) -> u32 {
    let mut acc = [0u32; 4];
    for (front, back) in (0..4).map(|j| pair_along(d, j)) {
        let f = fine(front);
        let b = fine(back);
        for i in 0..4 {
            acc[i] += f[i] + ((255 - f[3]) * b[i] + 127) / 255;
        }
    }
    pack_u8(acc.map(|a| (a + 2) / 4))
}

/// Pair `j` (0..4) of octants (x + 2y + 4z) met one after the other travelling along
/// direction `d` (+x, -x, +y, -y, +z, -z): (front, back).
fn pair_along(d: usize, j: usize) -> (usize, usize) {
    let axis = d / 2;
    let bit = 1usize << axis;
    let k0 = ((j >> axis) << (axis + 1)) | (j & (bit - 1));
    if d.is_multiple_of(2) {
        (k0, k0 | bit)
    } else {
        (k0 | bit, k0)
    }
}

/// CPU twin of `svo/aniso_radiance.wgsl`: the anisotropic radiance of every brick of `svo`
/// (order of its bricks), from the injected radiance of its leaf voxels (`voxel_radiance`,
/// [`crate::voxel::svo::Svo::read_voxel_radiance`]): per direction (+x, -x, +y, -y, +z, -z),
/// the 4 pairs of finer values met along it composited front to back (premultiplied,
/// `front + (1 - front.a) back`) and averaged; the finer values are the leaf's voxels, or the
/// children's values for the same direction. In f32: the GPU rounds every level to f16.
pub fn svo_aniso_radiance(svo: &SvoCpu, voxel_radiance: &[Vec4]) -> Vec<[Vec4; 6]> {
    let depth = svo.levels.len();
    let mut values = vec![[Vec4::ZERO; 6]; svo.bricks.len()];
    let Some(&(first_leaf, end_leaf)) = svo.levels.last() else {
        return values;
    };
    let static_leaves = (end_leaf - first_leaf) as usize;
    let dynamic_leaf = svo.dynamic_levels.last().map_or(0, |r| r.0);
    let composite = |fine: &dyn Fn(usize) -> Vec4, d: usize| {
        (0..4)
            .map(|j| {
                let (front, back) = pair_along(d, j);
                let f = fine(front);
                f + (1.0 - f.w) * fine(back)
            })
            .sum::<Vec4>()
            * 0.25
    };
    for d in (0..depth).rev() {
        let ranges = [Some(svo.levels[d]), svo.dynamic_levels.get(d).copied()];
        for n in ranges.into_iter().flatten().flat_map(|(a, b)| a..b) {
            let b = svo.brick_of[n as usize];
            if b == 0 {
                continue;
            }
            let node: [Vec4; 6] = if d + 1 == depth {
                let slot = if n >= first_leaf && n < end_leaf {
                    (n - first_leaf) as usize
                } else {
                    static_leaves + (n - dynamic_leaf) as usize
                };
                let voxel = |o: usize| voxel_radiance[slot * 8 + o];
                std::array::from_fn(|dir| composite(&voxel, dir))
            } else {
                let first = svo.child[n as usize];
                std::array::from_fn(|dir| {
                    let child = |o: usize| match (first, svo.brick_of.get(first as usize + o)) {
                        (0, _) | (_, None | Some(0)) => Vec4::ZERO,
                        (_, Some(&cb)) => values[cb as usize - 1][dir],
                    };
                    composite(&child, dir)
                })
            };
            values[b as usize - 1] = node;
        }
    }
    values
}

fn weight(o: i32) -> f32 {
    if o == 0 {
        0.5
    } else {
        0.25
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_filter_preserves_a_full_lattice() {
        let mut voxels = BTreeMap::new();
        for z in 0..8 {
            for y in 0..8 {
                for x in 0..8 {
                    voxels.insert([x, y, z], Vec4::ONE);
                }
            }
        }
        let l = lattices(3, &voxels);
        // Interior points of every level see a full neighbourhood: value 1.
        assert!((l[2].get(IVec3::splat(4)) - Vec4::ONE).abs().max_element() < 1e-6);
        assert!((l[1].get(IVec3::splat(2)) - Vec4::ONE).abs().max_element() < 1e-6);
        assert!((l[0].get(IVec3::splat(1)) - Vec4::ONE).abs().max_element() < 1e-6);
        // A corner of the grid touches one voxel of eight.
        assert!((l[2].get(IVec3::ZERO).w - 0.125).abs() < 1e-6);
    }
}
