//! A uniform grid over triangle bounds, built once per scene, that finds the triangles whose
//! bounds meet a world-space box without visiting the others: the clipmap snaps only those for
//! an update box ([`crate::voxel::clipmap::Clipmap`]), so the CPU work of an update follows the
//! geometry near the exposed slabs, not the scene.
//!
//! Cells are cubes sized so that the grid has about one cell per triangle (at most 2^21 cells,
//! at most 1024 per axis). A triangle is listed in every cell its bounds touch; one touching
//! more than [`MAX_CELLS`] cells goes into a short list that every query scans. Triangles
//! replaced later ([`TriangleIndex::replace`], moving objects) leave the grid for a list of
//! moved triangles that every query scans too, until there are so many that the grid is
//! rebuilt. Queries return triangle indices in increasing order, each once.

use crate::voxel::VoxelTriangle;
use glam::{IVec3, Vec3};

/// Most cells a triangle is listed in; larger triangles are scanned by every query.
pub const MAX_CELLS: u64 = 64;
/// Most cells of the grid.
pub const MAX_GRID_CELLS: u64 = 1 << 21;

/// Bounds of a triangle; empty (`lo > hi`) when a position is not finite, so that it never
/// meets a box (the snapping skips such triangles too).
fn bounds(t: &VoxelTriangle) -> (Vec3, Vec3) {
    let [a, b, c] = t.positions;
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return (Vec3::INFINITY, Vec3::NEG_INFINITY);
    }
    (a.min(b).min(c), a.max(b).max(c))
}

/// The grid and the per-triangle bounds.
#[derive(Clone, Debug, Default)]
pub struct TriangleIndex {
    /// Bounds of every finite triangle (empty, `lo > hi`, when there is none).
    all: (Vec3, Vec3),
    lo: Vec3,
    inv_cell: Vec3,
    dims: IVec3,
    /// Per cell, the first entry of `ids` (CSR), one more than cells.
    starts: Vec<u32>,
    ids: Vec<u32>,
    large: Vec<u32>,
    bounds: Vec<(Vec3, Vec3)>,
    moved: Vec<bool>,
    moved_list: Vec<u32>,
}

impl TriangleIndex {
    /// Indexes `tris`.
    pub fn new(tris: &[VoxelTriangle]) -> TriangleIndex {
        Self::from_bounds(tris.iter().map(bounds).collect())
    }

    fn from_bounds(bounds: Vec<(Vec3, Vec3)>) -> TriangleIndex {
        let n = bounds.len();
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &(a, b) in bounds.iter().filter(|(a, b)| a.cmple(*b).all()) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let all = (lo, hi);
        if !lo.cmple(hi).all() {
            lo = Vec3::ZERO;
            hi = Vec3::ONE;
        }
        let extent = (hi - lo).max(Vec3::splat((hi - lo).max_element() / 1024.0 + 1e-6));
        let cells = (n as f64).clamp(1.0, MAX_GRID_CELLS as f64);
        let mut cell = ((extent.x as f64 * extent.y as f64 * extent.z as f64) / cells).cbrt();
        let dims = loop {
            let dims = (extent.as_dvec3() / cell)
                .ceil()
                .as_ivec3()
                .clamp(IVec3::ONE, IVec3::splat(1024));
            // Clamping an axis to 1024 cells can leave more cells than wanted.
            if dims.as_i64vec3().element_product() <= MAX_GRID_CELLS as i64 {
                break dims;
            }
            cell *= 1.25;
        };
        let mut index = TriangleIndex {
            all,
            lo,
            inv_cell: dims.as_vec3() / extent,
            dims,
            starts: Vec::new(),
            ids: Vec::new(),
            large: Vec::new(),
            bounds,
            moved: vec![false; n],
            moved_list: Vec::new(),
        };
        // Counting sort of (cell, triangle) pairs: triangles in increasing order per cell.
        let total = (dims.x * dims.y * dims.z) as usize;
        let mut counts = vec![0u32; total + 1];
        let mut listed = vec![false; n];
        for (t, &(a, b)) in index.bounds.iter().enumerate() {
            if !a.cmple(b).all() {
                continue;
            }
            let (first, last) = (index.cell(a), index.cell(b));
            let span = (last - first + IVec3::ONE).as_i64vec3();
            if (span.x * span.y * span.z) as u64 > MAX_CELLS {
                index.large.push(t as u32);
                continue;
            }
            listed[t] = true;
            index.for_cells(first, last, |c| counts[c + 1] += 1);
        }
        for c in 0..total {
            counts[c + 1] += counts[c];
        }
        let mut fill = counts.clone();
        index.ids = vec![0; counts[total] as usize];
        for (t, &(a, b)) in index.bounds.iter().enumerate() {
            if !listed[t] {
                continue;
            }
            let (first, last) = (index.cell(a), index.cell(b));
            let ids = &mut index.ids;
            let mut put = |c: usize| {
                ids[fill[c] as usize] = t as u32;
                fill[c] += 1;
            };
            let dims = index.dims;
            for z in first.z..=last.z {
                for y in first.y..=last.y {
                    for x in first.x..=last.x {
                        put((x + dims.x * (y + dims.y * z)) as usize);
                    }
                }
            }
        }
        index.starts = counts;
        index
    }

    /// Number of triangles indexed.
    pub fn len(&self) -> usize {
        self.bounds.len()
    }

    /// Whether no triangle is indexed.
    pub fn is_empty(&self) -> bool {
        self.bounds.is_empty()
    }

    /// The cell holding `p`, clamped to the grid (monotonic in every coordinate).
    fn cell(&self, p: Vec3) -> IVec3 {
        ((p - self.lo) * self.inv_cell)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, self.dims - IVec3::ONE)
    }

    fn for_cells(&self, first: IVec3, last: IVec3, mut f: impl FnMut(usize)) {
        for z in first.z..=last.z {
            for y in first.y..=last.y {
                for x in first.x..=last.x {
                    f((x + self.dims.x * (y + self.dims.y * z)) as usize);
                }
            }
        }
    }

    /// Bounds of triangle `t` (`lo > hi` when it has a non-finite position).
    pub fn triangle_bounds(&self, t: usize) -> (Vec3, Vec3) {
        self.bounds[t]
    }

    /// Sets `out` to the triangles whose bounds meet the closed box `[lo, hi]`, in increasing
    /// order, each once.
    pub fn query(&self, lo: Vec3, hi: Vec3, out: &mut Vec<u32>) {
        out.clear();
        if self.moved_list.is_empty() && lo.cmple(self.all.0).all() && hi.cmpge(self.all.1).all() {
            // The box holds the whole scene (a first build): every finite triangle.
            out.extend((0..self.len() as u32).filter(|&t| {
                let (a, b) = self.bounds[t as usize];
                a.cmple(b).all()
            }));
            return;
        }
        let meets = |t: u32| {
            let (a, b) = self.bounds[t as usize];
            a.cmple(hi).all() && b.cmpge(lo).all()
        };
        if !self.starts.is_empty() && lo.cmple(hi).all() {
            self.for_cells(self.cell(lo), self.cell(hi), |c| {
                let ids = &self.ids[self.starts[c] as usize..self.starts[c + 1] as usize];
                out.extend(
                    ids.iter()
                        .copied()
                        .filter(|&t| !self.moved[t as usize] && meets(t)),
                );
            });
        }
        out.extend(
            self.large
                .iter()
                .copied()
                .filter(|&t| !self.moved[t as usize] && meets(t)),
        );
        out.extend(self.moved_list.iter().copied().filter(|&t| meets(t)));
        out.sort_unstable();
        out.dedup();
    }

    /// Replaces the bounds of triangles `first..first + tris.len()` (which must exist) with
    /// those of `tris`. They are scanned by every query from then on; when more than a quarter
    /// of the scene (and over 4096 triangles) has moved, the grid is rebuilt.
    pub fn replace(&mut self, first: usize, tris: &[VoxelTriangle]) {
        for (i, t) in tris.iter().enumerate() {
            let k = first + i;
            self.bounds[k] = bounds(t);
            if !self.moved[k] {
                self.moved[k] = true;
                self.moved_list.push(k as u32);
            }
        }
        if self.moved_list.len() > (self.len() / 4).max(4096) {
            *self = Self::from_bounds(std::mem::take(&mut self.bounds));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> VoxelTriangle {
        VoxelTriangle {
            positions: [a, b, c],
            albedo: [1, 2, 3],
            normal: Vec3::Y,
            emission: Vec3::ZERO,
        }
    }

    /// A scene of one point (every extent zero) or of one long line still gets a small grid.
    #[test]
    fn degenerate_scenes_get_a_bounded_grid() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let point = vec![tri(p, p, p); 5000];
        let line: Vec<VoxelTriangle> = (0..5000)
            .map(|i| {
                let a = Vec3::new(i as f32 * 0.01, 0.0, 0.0);
                tri(a, a + Vec3::X * 0.001, a)
            })
            .collect();
        for tris in [point, line] {
            let index = TriangleIndex::new(&tris);
            assert!(index.starts.len() as u64 <= MAX_GRID_CELLS + 1);
            let mut out = Vec::new();
            index.query(Vec3::splat(-1.0), Vec3::splat(0.5), &mut out);
            let want = tris
                .iter()
                .enumerate()
                .filter(|(_, t)| t.positions[0].cmple(Vec3::splat(0.5)).all())
                .count();
            assert_eq!(out.len(), want);
        }
    }

    /// Every query returns exactly the triangles whose bounds meet the box, in order, also
    /// after triangles moved and after the rebuild that many moves cause.
    #[test]
    fn queries_equal_a_linear_scan() {
        let mut rng = 0x2545f4914f6cdd1du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut tris: Vec<VoxelTriangle> = (0..6000)
            .map(|i| {
                let c = Vec3::new(next(), next() * 0.3, next()) * 20.0;
                // Mostly small, some huge (listed as large), one non-finite.
                let s = if i % 97 == 0 { 15.0 } else { 0.3 };
                let mut d = || Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * s;
                let (a, b, e) = (c + d(), c + d(), c + d());
                if i == 17 {
                    tri(a, Vec3::NAN, e)
                } else {
                    tri(a, b, e)
                }
            })
            .collect();
        let mut index = TriangleIndex::new(&tris);
        assert!(!index.large.is_empty());
        let mut out = Vec::new();
        let mut check =
            |index: &TriangleIndex, tris: &[VoxelTriangle], next: &mut dyn FnMut() -> f32| {
                for _ in 0..200 {
                    let lo = Vec3::new(next(), next(), next()) * 24.0 - Vec3::splat(2.0);
                    let hi = lo + Vec3::new(next(), next() * 0.2, next()) * 8.0;
                    index.query(lo, hi, &mut out);
                    let want: Vec<u32> = (0..tris.len() as u32)
                        .filter(|&t| {
                            let (a, b) = bounds(&tris[t as usize]);
                            a.cmple(hi).all() && b.cmpge(lo).all()
                        })
                        .collect();
                    assert_eq!(out, want);
                }
            };
        check(&index, &tris, &mut next);
        for round in 0..3 {
            let first = 100 + round * 1700;
            let moved: Vec<VoxelTriangle> = tris[first..first + 1700]
                .iter()
                .map(|t| {
                    let mut t = *t;
                    for p in &mut t.positions {
                        *p += Vec3::new(3.0, 0.5, -2.0);
                    }
                    t
                })
                .collect();
            tris[first..first + 1700].copy_from_slice(&moved);
            index.replace(first, &moved);
            check(&index, &tris, &mut next);
        }
        // 5100 moved out of 6000: rebuilt.
        assert!(index.moved_list.is_empty());
    }
}
