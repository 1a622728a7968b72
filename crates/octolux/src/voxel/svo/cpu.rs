//! The octree on the CPU: the node levels, the mipmapped lattices of the bricks and the
//! anisotropic values, written for clarity. The dynamic octree uses the lattices every frame;
//! the tests compare the GPU octree with all of them.

use super::SvoCpu;
use crate::voxel::pairs::{composite_pairs, pair_along, unpack_u8};
use glam::{IVec3, Vec4};
use std::collections::{BTreeMap, BTreeSet};

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

fn weight(o: i32) -> f32 {
    if o == 0 {
        0.5
    } else {
        0.25
    }
}

/// The anisotropic values of the octree's nodes (CPU twin of `svo/aniso.wgsl`) over a
/// `2^depth` grid with the occupied voxels `voxels` ([`crate::voxel::voxelize::cpu::voxel_words`]): entry `d` holds level
/// `d` (nodes of `2^(depth - d)` voxels) by node coordinates, 6 RGBA8 words per node for
/// travel along +x, -x, +y, -y, +z, -z. Only nodes containing an occupied voxel are listed;
/// every other node is zero. On the finest level the values composite the node's 2x2x2 voxels,
/// above that its 8 children's values for the same direction: the two met along the direction
/// front to back (rounded integer arithmetic), averaged over the 4 pairs, as
/// [`crate::voxel::clipmap::cpu::clipmap_aniso`] does.
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
