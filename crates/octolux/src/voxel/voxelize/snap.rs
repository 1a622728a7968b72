//! Exact, conservative triangle/voxel overlap on a fixed-point lattice, shared bit for bit by
//! the GPU kernels (`voxelize/overlap.wgsl`) and the CPU references ([`crate::voxel::cpu`]).
//!
//! A float separating-axis test decides touching and near-touching configurations (a triangle
//! edge passing through a voxel edge, a vertex on a voxel face) by rounding, and a GPU compiler
//! may fuse multiplies and adds or reorder sums where the CPU does not, so the GPU and the CPU
//! twin disagree on exactly those voxels. Here the only rounding happens once, on the CPU,
//! before upload; everything the GPU computes is integer arithmetic whose every intermediate
//! fits in `i32`, so every adapter and the CPU decide every case identically:
//!
//! 1. **Snap.** Vertices are converted to grid space in `f64` and rounded to the nearest point
//!    of a lattice of [`SNAP`] steps per voxel edge (1/64 voxel), in coordinates absolute to
//!    the grid (so the result does not depend on which box of the grid is voxelized), then
//!    made relative to the first voxel of the box by an exact integer subtraction.
//! 2. **Split.** A triangle whose snapped extent exceeds [`MAX_EXTENT`] steps (32 voxels) on
//!    some axis is bisected at the midpoint of its longest edge (in `f64`, before snapping),
//!    recursively; pieces whose bounding box is clear of the box are dropped, so even a
//!    triangle far larger than the grid costs a bounded number of pieces. The bound keeps the
//!    products of the test within `i32` (see [`PieceTest`]).
//! 3. **Test.** Each voxel box is dilated by [`DILATE`] step on every side and tested against
//!    the snapped piece, closed (touching counts), with the 13 axes of the separating axis
//!    theorem, in integers. Snapping moves a vertex by at most half a step per axis, so every
//!    point of the original triangle is within half a step of the snapped one (same
//!    barycentric coordinates): a voxel the original triangle touches is always marked
//!    (conservative), and a marked voxel is at most 1.5 steps (3/128 voxel) from the original
//!    triangle along each axis.
//!
//! A voxel on the seam between two pieces of a split triangle gets one fragment from each
//! piece (the triangle counts twice in that voxel's averages). Only triangles longer than 32
//! voxels are split.

use crate::voxel::VoxelTriangle;
use glam::{DVec3, IVec3, Vec3, Vec3Swizzles};

/// Lattice steps per voxel edge: vertices are snapped to multiples of 1/`SNAP` voxel.
pub const SNAP: i32 = 64;
/// log2 of [`SNAP`].
const SNAP_SHIFT: i32 = 6;
/// Dilation of every voxel box, in lattice steps, on every side: covers the half-step
/// snapping error with half a step to spare for the `f64` rounding before it.
pub const DILATE: i32 = 1;
/// Largest extent of a piece along any axis, in lattice steps (32 voxels). Vertices then lie
/// within `MAX_EXTENT + 2 * SNAP + DILATE` < 2^12 steps of the first voxel of their cell range,
/// edges are below 2^11, the triangle normal below 2^23 per component, and every intermediate
/// of [`PieceTest`] below 1.7 x 10^9 in magnitude (see [`PieceTest::new`]).
pub const MAX_EXTENT: i32 = 2048;
/// The normal's projection `n . v` (up to 2^36) is summed in two parts, `n = nh 2^NORMAL_SPLIT
/// + nl` with `0 <= nl < 2^NORMAL_SPLIT`, so that both partial sums fit `i32`.
const NORMAL_SPLIT: i32 = 12;

/// A triangle, or a piece of one, snapped to the lattice of a box of voxels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    /// Vertices in lattice steps relative to the corner of the box's first voxel.
    pub q: [IVec3; 3],
    /// Index of the triangle the piece belongs to.
    pub triangle: u32,
}

/// GPU layout of a [`Piece`] (`Piece` in `voxelize/overlap.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuPiece {
    /// Vertex 0.
    pub a: [i32; 3],
    /// Index of the triangle the piece belongs to.
    pub triangle: u32,
    /// Vertex 1.
    pub b: [i32; 3],
    /// Padding (WGSL aligns a `vec3<i32>` to 16 bytes).
    pub _pad_b: u32,
    /// Vertex 2.
    pub c: [i32; 3],
    /// Padding to the struct's 16-byte alignment.
    pub _pad_c: u32,
}

impl Piece {
    /// The GPU layout.
    pub fn to_gpu(&self) -> GpuPiece {
        let [a, b, c] = self.q;
        GpuPiece {
            a: a.to_array(),
            triangle: self.triangle,
            b: b.to_array(),
            _pad_b: 0,
            c: c.to_array(),
            _pad_c: 0,
        }
    }
}

/// A box of voxels `[lo, hi)` of the grid whose voxel `(0, 0, 0)` starts at `origin` and whose
/// voxels have edge `voxel_size`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SnapRegion {
    /// World position of the corner of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Voxel edge.
    pub voxel_size: f32,
    /// First voxel of the box.
    pub lo: IVec3,
    /// One past the last voxel of the box.
    pub hi: IVec3,
}

impl SnapRegion {
    /// Voxels per axis of the box.
    pub fn size(&self) -> IVec3 {
        self.hi - self.lo
    }

    /// Grid position of `p` in lattice steps, absolute to the grid (not to the box).
    fn lattice(&self, p: Vec3) -> DVec3 {
        (p.as_dvec3() - self.origin.as_dvec3()) / self.voxel_size as f64 * SNAP as f64
    }
}

/// Appends the pieces of triangle `positions` (index `triangle`) that can touch a voxel of
/// `region`, in a fixed order. Triangles with a non-finite grid position are skipped.
pub fn snap_triangle(
    region: &SnapRegion,
    positions: [Vec3; 3],
    triangle: u32,
    out: &mut Vec<Piece>,
) {
    let v = positions.map(|p| region.lattice(p));
    if !v.iter().all(|p| p.is_finite()) {
        return;
    }
    // Pieces whose bounding box keeps more than DILATE + 1/2 steps away from the box cannot
    // touch a dilated voxel of it once snapped.
    let reach = DILATE as f64 + 1.0;
    let offset = region.lo.as_i64vec3() * SNAP as i64;
    let box_lo = offset.as_dvec3() - DVec3::splat(reach);
    let box_hi = (region.hi.as_i64vec3() * SNAP as i64).as_dvec3() + DVec3::splat(reach);
    // Depth first, first half first; most triangles need no split (and no allocation).
    let mut stack = Vec::new();
    let mut next = Some(v);
    while let Some(t) = next.take().or_else(|| stack.pop()) {
        let mn = t[0].min(t[1]).min(t[2]);
        let mx = t[0].max(t[1]).max(t[2]);
        if mx.cmplt(box_lo).any() || mn.cmpgt(box_hi).any() {
            continue;
        }
        let r = t.map(|p| p.round());
        let extent = r[0].max(r[1]).max(r[2]) - r[0].min(r[1]).min(r[2]);
        if extent.max_element() <= MAX_EXTENT as f64 {
            // Bounded by the box and the extent: the i64 -> i32 conversion is exact.
            let q = r.map(|p| (p.as_i64vec3() - offset).as_ivec3());
            out.push(Piece { q, triangle });
            continue;
        }
        // Bisect the longest edge.
        let edges = [(0, 1, 2), (1, 2, 0), (2, 0, 1)];
        let (i, j, k) = edges.into_iter().fold((0, 1, 2), |best, e| {
            let len = |(a, b, _): (usize, usize, usize)| (t[a] - t[b]).length_squared();
            if len(e) > len(best) {
                e
            } else {
                best
            }
        });
        let m = (t[i] + t[j]) * 0.5;
        stack.push([m, t[j], t[k]]);
        next = Some([t[i], m, t[k]]);
    }
}

/// The pieces of every triangle of `tris` that can touch a voxel of `region`, triangle after
/// triangle.
pub fn snap_triangles(region: &SnapRegion, tris: &[VoxelTriangle]) -> Vec<Piece> {
    let mut out = Vec::with_capacity(tris.len());
    for (t, tri) in tris.iter().enumerate() {
        snap_triangle(region, tri.positions, t as u32, &mut out);
    }
    out
}

fn ceil_snap(x: i32) -> i32 {
    -((-x) >> SNAP_SHIFT)
}

fn floor_snap(x: i32) -> i32 {
    x >> SNAP_SHIFT
}

fn ceil_snap3(x: IVec3) -> IVec3 {
    -((-x) >> SNAP_SHIFT)
}

fn floor_snap3(x: IVec3) -> IVec3 {
    x >> SNAP_SHIFT
}

/// The voxels `[first, last]` (inclusive, relative to the box's first voxel) whose dilated
/// boxes the piece's bounding box touches, clipped to `[0, size)`: empty when `last < first`
/// on some axis (`piece_cells` in WGSL).
pub fn piece_cells(p: &Piece, size: IVec3) -> (IVec3, IVec3) {
    let mn = p.q[0].min(p.q[1]).min(p.q[2]);
    let mx = p.q[0].max(p.q[1]).max(p.q[2]);
    // Voxel c spans [c SNAP - DILATE, (c + 1) SNAP + DILATE] on each axis.
    let first = ceil_snap3(mn - IVec3::splat(SNAP + DILATE)).max(IVec3::ZERO);
    let last = floor_snap3(mx + IVec3::splat(DILATE)).min(size - IVec3::ONE);
    (first, last)
}

/// Number of voxels of a range from [`piece_cells`].
pub fn cell_count((first, last): (IVec3, IVec3)) -> u64 {
    let size = last - first + IVec3::ONE;
    if size.cmple(IVec3::ZERO).any() {
        return 0;
    }
    size.x as u64 * size.y as u64 * size.z as u64
}

fn cross(a: IVec3, b: IVec3) -> IVec3 {
    a.yzx() * b.zxy() - a.zxy() * b.yzx()
}

fn dot(a: IVec3, b: IVec3) -> i32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// The separating-axis test of one piece against the dilated voxels of its cell range, set up
/// once per piece (`PieceTest` in WGSL).
///
/// For an axis `a`, a voxel at offset `l` from the range's first voxel projects to
/// `SNAP (a . l) + [bmin, bmax]` (its dilated box relative to that voxel's corner), the piece to
/// `[tmin, tmax]`; they overlap exactly when
/// `ceil((tmin - bmax) / SNAP) <= a . l <= floor((tmax - bmin) / SNAP)`. The bounds are
/// computed here; per voxel only `a . l` remains: one dot product for the triangle normal and
/// one integer cross product per edge, whose components are the projections on the three
/// axes `edge x (unit axis)`. The box normals are the cell range itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PieceTest {
    n: IVec3,
    n_range: (i32, i32),
    e: [IVec3; 3],
    lo: [IVec3; 3],
    hi: [IVec3; 3],
}

impl PieceTest {
    /// The test of `p` for the voxels at offsets from `first`.
    pub fn new(p: &Piece, first: IVec3) -> PieceTest {
        let o = first * SNAP;
        let v = p.q.map(|q| q - o);
        let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
        let n = cross(e[0], e[1]);
        // Every vertex projects to the same value t = n . v0 on the normal, up to 2^36 in
        // magnitude: t = a 2^NORMAL_SPLIT + b with a = (n >> NORMAL_SPLIT) . v0 (below 2^24)
        // and b = (n & (2^NORMAL_SPLIT - 1)) . v0 (below 2^27), and since 2^NORMAL_SPLIT is a
        // multiple of SNAP, ceil((t - x) / SNAP) = a 2^(NORMAL_SPLIT - SNAP_SHIFT) +
        // ceil((b - x) / SNAP), every term within i32 (the box terms x are below 1.7 x 10^9).
        let nh = n >> NORMAL_SPLIT;
        let nl = n & ((1 << NORMAL_SPLIT) - 1);
        let a = dot(nh, v[0]) << (NORMAL_SPLIT - SNAP_SHIFT);
        let b = dot(nl, v[0]);
        let pos = n.max(IVec3::ZERO).element_sum();
        let neg = (-n).max(IVec3::ZERO).element_sum();
        let n_range = (
            a + ceil_snap(b - (SNAP + DILATE) * pos - DILATE * neg),
            a + floor_snap(b + DILATE * pos + (SNAP + DILATE) * neg),
        );
        let mut lo = [IVec3::ZERO; 3];
        let mut hi = [IVec3::ZERO; 3];
        for j in 0..3 {
            let p = v.map(|v| cross(e[j], v));
            let (tmin, tmax) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            // Sums of the positive and of the negative components of the three axes
            // (0, -e.z, e.y), (e.z, 0, -e.x), (-e.y, e.x, 0).
            let ep = e[j].max(IVec3::ZERO);
            let en = (-e[j]).max(IVec3::ZERO);
            let pos = en.zxy() + ep.yzx();
            let neg = ep.zxy() + en.yzx();
            lo[j] = ceil_snap3(tmin - (SNAP + DILATE) * pos - DILATE * neg);
            hi[j] = floor_snap3(tmax + DILATE * pos + (SNAP + DILATE) * neg);
        }
        PieceTest {
            n,
            n_range,
            e,
            lo,
            hi,
        }
    }

    /// Whether the piece touches the dilated voxel at offset `l` from the range's first voxel
    /// (`piece_touches` in WGSL).
    pub fn touches(&self, l: IVec3) -> bool {
        let d = dot(self.n, l);
        if d < self.n_range.0 || d > self.n_range.1 {
            return false;
        }
        (0..3).all(|j| {
            let c = cross(self.e[j], l);
            c.cmpge(self.lo[j]).all() && c.cmple(self.hi[j]).all()
        })
    }
}

/// The voxels (relative to the box's first voxel) that piece `p` marks in a box of `size`
/// voxels, in the GPU's loop order (x fastest).
pub fn piece_voxels(p: &Piece, size: IVec3) -> Vec<IVec3> {
    let (first, last) = piece_cells(p, size);
    let mut out = Vec::new();
    if cell_count((first, last)) == 0 {
        return out;
    }
    let test = PieceTest::new(p, first);
    for z in first.z..=last.z {
        for y in first.y..=last.y {
            for x in first.x..=last.x {
                let c = IVec3::new(x, y, z);
                if test.touches(c - first) {
                    out.push(c);
                }
            }
        }
    }
    out
}

/// Bounding-box voxels one work item visits (`CHUNK` in `voxelize/overlap.wgsl`). Small, because the
/// slowest invocation sets the pass time on a GPU: a floor triangle of Crytek Sponza spans
/// thousands of voxels next to the few of a typical triangle (4096 took 0.7 ms per pass on an
/// H100, most of it waiting for the longest items).
pub const CHUNK: u32 = 256;

/// Work items (piece, chunk) covering the cell range of every piece in a box of `size` voxels:
/// exactly the chunks the GPU visits (no piece's range is empty or larger than `u32`).
pub fn work_items(pieces: &[Piece], size: IVec3) -> Vec<[u32; 2]> {
    let mut items = Vec::with_capacity(pieces.len());
    for (i, p) in pieces.iter().enumerate() {
        let cells = cell_count(piece_cells(p, size));
        for chunk in 0..cells.div_ceil(CHUNK as u64) {
            items.push([i as u32, chunk as u32]);
        }
    }
    items
}

/// Exact references for the tests: the separating-axis test in wide integers (no division,
/// no bound on magnitudes) and in `f64` on unsnapped triangles.
#[cfg(test)]
mod tests {
    use super::*;
    use glam::I64Vec3;

    /// Exact SAT of the snapped triangle `q` against the dilated voxel `c`, in doubled
    /// coordinates (box centre and half-size are integers) and i128.
    fn exact(q: [IVec3; 3], c: IVec3) -> bool {
        let q = q.map(|q| q.as_i64vec3() * 2);
        let centre = c.as_i64vec3() * (2 * SNAP as i64) + I64Vec3::splat(SNAP as i64);
        let half = (SNAP + 2 * DILATE) as i128;
        let v = q.map(|q| q - centre);
        let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
        let mut axes = vec![I64Vec3::X, I64Vec3::Y, I64Vec3::Z, e[0].cross(e[1])];
        for e in e {
            axes.push(I64Vec3::new(0, -e.z, e.y));
            axes.push(I64Vec3::new(e.z, 0, -e.x));
            axes.push(I64Vec3::new(-e.y, e.x, 0));
        }
        let d = |a: I64Vec3, b: I64Vec3| {
            a.x as i128 * b.x as i128 + a.y as i128 * b.y as i128 + a.z as i128 * b.z as i128
        };
        axes.iter().all(|&a| {
            let p = v.map(|v| d(a, v));
            let r = half * (a.x.abs() as i128 + a.y.abs() as i128 + a.z.abs() as i128);
            !(p.iter().min().unwrap() > &r || p.iter().max().unwrap() < &-r)
        })
    }

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn range(&mut self, lo: i32, hi: i32) -> i32 {
            lo + (self.next() % (hi - lo + 1) as u64) as i32
        }
        fn unit(&mut self) -> f64 {
            (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Every voxel of a box around the piece, integer test against the exact one.
    fn check_piece(p: &Piece, size: IVec3) {
        let (first, last) = piece_cells(p, size);
        let marked: std::collections::HashSet<IVec3> = piece_voxels(p, size).into_iter().collect();
        let mn = p.q[0].min(p.q[1]).min(p.q[2]);
        let mx = p.q[0].max(p.q[1]).max(p.q[2]);
        let lo = ((mn >> SNAP_SHIFT) - IVec3::splat(2)).max(IVec3::ZERO);
        let hi = ((mx >> SNAP_SHIFT) + IVec3::splat(2)).min(size - IVec3::ONE);
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let c = IVec3::new(x, y, z);
                    let want = exact(p.q, c);
                    let got = marked.contains(&c);
                    assert_eq!(got, want, "piece {p:?} voxel {c} (range {first}..{last})");
                }
            }
        }
    }

    #[test]
    fn integer_test_equals_exact_sat_on_random_pieces() {
        let mut rng = Rng(0x2545f4914f6cdd1d);
        let size = IVec3::splat(64);
        for i in 0..1500 {
            // Small, lattice-aligned, degenerate and maximal pieces, partly outside the box.
            let extent = [4, 16, 64, 400, MAX_EXTENT][i % 5];
            let base = IVec3::new(
                rng.range(-40, 64 * SNAP - 40),
                rng.range(-40, 64 * SNAP - 40),
                rng.range(-40, 64 * SNAP - 40),
            );
            let mut q = [IVec3::ZERO; 3];
            for v in &mut q {
                *v = base
                    + IVec3::new(
                        rng.range(0, extent),
                        rng.range(0, extent),
                        rng.range(0, extent),
                    );
                if i % 7 == 0 {
                    // On voxel faces, edges and corners.
                    *v = (*v >> SNAP_SHIFT) << SNAP_SHIFT;
                }
            }
            if i % 11 == 0 {
                q[2] = q[0] + (q[1] - q[0]) * 2; // collinear
            }
            let ext = q[0].max(q[1]).max(q[2]) - q[0].min(q[1]).min(q[2]);
            if ext.max_element() > MAX_EXTENT {
                continue;
            }
            check_piece(&Piece { q, triangle: 0 }, size);
        }
    }

    #[test]
    fn extreme_pieces_stay_within_i32() {
        // The largest extents in every direction and sign, inside and at both ends of a
        // 1024^3 box (debug builds panic on any i32 overflow).
        let size = IVec3::splat(1024);
        let e = MAX_EXTENT;
        let far = 1024 * SNAP;
        for base in [
            IVec3::splat(-e + 8),
            IVec3::splat(far / 2),
            IVec3::splat(far - 8),
        ] {
            for s in 0..8 {
                let sign = IVec3::new(1 - 2 * (s & 1), 1 - (s & 2), 1 - (s & 4) / 2);
                for q in [
                    [
                        base,
                        base + sign * IVec3::new(e, 0, e),
                        base + sign * IVec3::new(0, e, 0),
                    ],
                    [
                        base,
                        base + sign * IVec3::new(e, e, 0),
                        base + sign * IVec3::new(e, 0, e),
                    ],
                    [
                        base,
                        base + sign * IVec3::new(e, e, e),
                        base + sign * IVec3::new(e, 1, 0),
                    ],
                ] {
                    let p = Piece { q, triangle: 0 };
                    for c in piece_voxels(&p, size).iter().step_by(97) {
                        assert!(exact(q, *c));
                    }
                }
            }
        }
    }

    /// `f64` SAT of an unsnapped triangle (grid coordinates) against voxel `c` grown by `grow`
    /// voxels on every side (closed).
    fn float_overlap(t: [DVec3; 3], c: IVec3, grow: f64) -> bool {
        let centre = c.as_dvec3() + DVec3::splat(0.5);
        let half = 0.5 + grow;
        let v = t.map(|p| p - centre);
        let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
        let mut axes = vec![DVec3::X, DVec3::Y, DVec3::Z, e[0].cross(e[1])];
        for e in e {
            axes.extend([DVec3::X.cross(e), DVec3::Y.cross(e), DVec3::Z.cross(e)]);
        }
        axes.iter().all(|&a| {
            let p = v.map(|v| a.dot(v));
            let r = half * (a.x.abs() + a.y.abs() + a.z.abs());
            !(p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r)
        })
    }

    #[test]
    fn snapping_is_conservative_and_tight() {
        let mut rng = Rng(0x9e3779b97f4a7c15);
        let region = SnapRegion {
            origin: Vec3::new(-0.37, 0.11, 0.05),
            voxel_size: 0.0625,
            lo: IVec3::new(0, 0, 0),
            hi: IVec3::splat(24),
        };
        let size = region.size();
        for i in 0..400 {
            // Up to 60 voxels long (split), partly outside the box.
            let scale = [0.1f64, 0.5, 1.0, 4.0][i % 4];
            let c = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 1.6 - DVec3::splat(0.4);
            let p = [0; 3].map(|_| {
                let d = DVec3::new(rng.unit(), rng.unit(), rng.unit()) - DVec3::splat(0.5);
                (c + d * scale).as_vec3() + region.origin
            });
            let mut pieces = Vec::new();
            snap_triangle(&region, p, 0, &mut pieces);
            let marked: std::collections::BTreeSet<[i32; 3]> = pieces
                .iter()
                .flat_map(|q| piece_voxels(q, size))
                .map(|v| v.to_array())
                .collect();
            let g = p.map(|p| (p.as_dvec3() - region.origin.as_dvec3()) / 0.0625);
            // Marked voxels are at most 3/128 voxel (1.5 steps) from the triangle.
            let grow = 1.5 / SNAP as f64 + 1e-9;
            for z in 0..size.z {
                for y in 0..size.y {
                    for x in 0..size.x {
                        let v = IVec3::new(x, y, z);
                        let touched = float_overlap(g, v, 0.0);
                        let near = float_overlap(g, v, grow);
                        let m = marked.contains(&v.to_array());
                        assert!(!touched || m, "triangle {i} touches unmarked voxel {v}");
                        assert!(!m || near, "triangle {i} marks far voxel {v}");
                    }
                }
            }
        }
    }

    #[test]
    fn pieces_do_not_depend_on_the_box() {
        // A triangle much larger than the grid, voxelized as one box and as slabs.
        let region = SnapRegion {
            origin: Vec3::ZERO,
            voxel_size: 0.05,
            lo: IVec3::new(-20, 3, -7),
            hi: IVec3::new(44, 67, 57),
        };
        let tri = [
            Vec3::new(-400.0, 0.31, -300.0),
            Vec3::new(500.0, 2.9, -280.0),
            Vec3::new(20.0, 1.7, 900.0),
        ];
        let voxels = |r: &SnapRegion| {
            let mut pieces = Vec::new();
            snap_triangle(r, tri, 0, &mut pieces);
            assert!(pieces.len() < 200, "{} pieces", pieces.len());
            let mut out: Vec<[i32; 3]> = pieces
                .iter()
                .flat_map(|p| piece_voxels(p, r.size()))
                .map(|v| (v + r.lo).to_array())
                .collect();
            out.sort();
            out
        };
        let whole = voxels(&region);
        assert!(!whole.is_empty());
        let mut slabs = Vec::new();
        for z in (region.lo.z..region.hi.z).step_by(5) {
            let slab = SnapRegion {
                lo: IVec3::new(region.lo.x, region.lo.y, z),
                hi: IVec3::new(region.hi.x, region.hi.y, (z + 5).min(region.hi.z)),
                ..region
            };
            slabs.extend(voxels(&slab));
        }
        slabs.sort();
        assert_eq!(whole, slabs);
    }

    #[test]
    fn boundary_cases() {
        let size = IVec3::splat(8);
        let s = SNAP;
        let voxels = |q: [IVec3; 3]| -> Vec<[i32; 3]> {
            let p = Piece { q, triangle: 0 };
            check_piece(&p, size);
            piece_voxels(&p, size)
                .iter()
                .map(|v| v.to_array())
                .collect()
        };
        // A triangle in the face plane z = 3 marks both layers it separates.
        let f = voxels([
            IVec3::new(s + 4, s + 4, 3 * s),
            IVec3::new(2 * s - 4, s + 4, 3 * s),
            IVec3::new(s + 4, 2 * s - 4, 3 * s),
        ]);
        assert_eq!(f, vec![[1, 1, 2], [1, 1, 3]]);
        // A point on a voxel corner marks the 8 voxels around it.
        let c = IVec3::splat(2 * s);
        assert_eq!(voxels([c, c, c]).len(), 8);
        // One step (1/64 voxel) inside a face, and two steps: the dilation reaches one step.
        let inside = |d: i32| {
            voxels([
                IVec3::new(s + 4, s + 4, 3 * s - d),
                IVec3::new(2 * s - 4, s + 4, 3 * s - d),
                IVec3::new(s + 4, 2 * s - 4, 3 * s - d),
            ])
        };
        assert_eq!(inside(1), vec![[1, 1, 2], [1, 1, 3]]);
        assert_eq!(inside(2), vec![[1, 1, 2]]);
        // A slanted edge through a voxel edge line (x = y = 2 voxels) marks the four voxels
        // around it; the plane x + y = 4 voxels touches the diagonal corners.
        let e = voxels([
            IVec3::new(2 * s - 8, 2 * s + 8, s + 4),
            IVec3::new(2 * s + 8, 2 * s - 8, s + 12),
            IVec3::new(2 * s - 8, 2 * s + 8, s + 12),
        ]);
        for v in [[1, 1, 1], [1, 2, 1], [2, 1, 1], [2, 2, 1]] {
            assert!(e.contains(&v), "{v:?} in {e:?}");
        }
    }
}
