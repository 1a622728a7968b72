// Shared by every voxelization kernel: the triangle layout, the region parameters and the exact
// integer triangle/box overlap test on the snapping lattice (separating axis theorem, closed
// dilated boxes: touching counts).

import octolux::voxel::svo::leaf_sums::{LEAF_EMISSION_SCALE, voxel_sum_words, VoxelSums};

// One triangle's surface data (`GpuTriangle` in voxel/mod.rs); its position reaches the kernels
// as the pieces it is snapped into (`Piece` below).
struct Tri {
    // Emitted radiance, W/(m^2 sr).
    emission: vec3<f32>,
    // Linear albedo x 255 as RGBA8, red in the low byte.
    albedo: u32,
    // Unit geometric normal x 127 as three snorm8 bytes, x in the low byte.
    normal: u32,
}

// What one fragment of `tri` adds to its leaf voxel's sums (svo/leaf_sums.wgsl): its albedo
// x255, a count of one, its emission in fixed point and its normal as snorm8.
fn fragment_sum_terms(tri: Tri) -> array<u32, 10> {
    let albedo = tri.albedo;
    let e = clamp(tri.emission, vec3<f32>(0.0), vec3<f32>(65504.0));
    let nb = vec3<u32>(tri.normal, tri.normal >> 8u, tri.normal >> 16u) & vec3<u32>(255u);
    return voxel_sum_words(VoxelSums(
        vec3<u32>(albedo, albedo >> 8u, albedo >> 16u) & vec3<u32>(255u),
        1u,
        vec3<u32>(round(e * LEAF_EMISSION_SCALE)),
        bitcast<vec3<i32>>(nb << vec3<u32>(24u)) >> vec3<u32>(24u),
    ));
}

// A box of voxels [lo, hi) of a grid and the work items over it (`VoxParams` in
// voxelize/mod.rs).
struct VoxParams {
    // First voxel of the box.
    lo: vec3<i32>,
    // Work items (pieces x chunks) of the dispatch.
    items: u32,
    // One past the last voxel of the box.
    hi: vec3<i32>,
    // `append_fragments`: the word of `append` that counts the fragments.
    counter: u32,
}

// ---- Exact overlap on the snapping lattice (CPU twin: voxelize/snap.rs) ------------------------------
// Triangles reach the GPU snapped on the CPU to a lattice of SNAP steps per voxel edge and split
// into pieces of at most 2048 steps (32 voxels) per axis, in coordinates relative to the box's
// first voxel. Everything below is integer arithmetic whose intermediates stay below
// 1.7 x 10^9 in magnitude (bounds in voxelize/snap.rs), so
// no compiler choice (fused multiply-add, evaluation order) can change a decision: every
// adapter and the CPU mark exactly the same voxels. A voxel's box is dilated by DILATE steps on
// every side, which covers the snapping error: conservative for the original triangle.

// A snapped triangle or piece of one (`GpuPiece` in voxelize/snap.rs): vertices in lattice steps
// relative to the corner of the box's first voxel.
struct Piece {
    a: vec3<i32>,
    // Index of the triangle the piece belongs to (into `Tri`s).
    triangle: u32,
    b: vec3<i32>,
    c: vec3<i32>,
}

const SNAP: i32 = 64;
const SNAP_SHIFT: u32 = 6u;
const DILATE: i32 = 1;
// n . v0 (up to 2^36) is summed as (n >> NORMAL_SPLIT) . v0 x 2^NORMAL_SPLIT + (n & mask) . v0.
const NORMAL_SPLIT: u32 = 12u;

fn ceil_snap(x: i32) -> i32 {
    return -((-x) >> SNAP_SHIFT);
}

fn floor_snap(x: i32) -> i32 {
    return x >> SNAP_SHIFT;
}

fn ceil_snap3(x: vec3<i32>) -> vec3<i32> {
    return -((-x) >> vec3<u32>(SNAP_SHIFT));
}

fn floor_snap3(x: vec3<i32>) -> vec3<i32> {
    return x >> vec3<u32>(SNAP_SHIFT);
}

fn cross_i(a: vec3<i32>, b: vec3<i32>) -> vec3<i32> {
    return a.yzx * b.zxy - a.zxy * b.yzx;
}

fn dot_i(a: vec3<i32>, b: vec3<i32>) -> i32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// Voxels [first, last] (inclusive, relative to the box's first voxel) whose dilated boxes the
// piece's bounding box touches, clipped to [0, size); empty when last < first on some axis.
fn piece_cells(p: Piece, size: vec3<i32>) -> array<vec3<i32>, 2> {
    let mn = min(min(p.a, p.b), p.c);
    let mx = max(max(p.a, p.b), p.c);
    let first = max(ceil_snap3(mn - vec3<i32>(SNAP + DILATE)), vec3<i32>(0));
    let last = min(floor_snap3(mx + vec3<i32>(DILATE)), size - vec3<i32>(1));
    return array<vec3<i32>, 2>(first, last);
}

// The separating-axis test of a piece, set up once per work item: per axis a, the range of
// a . l (l = voxel offset from the range's first voxel) where the projections overlap,
// ceil((tmin - bmax) / SNAP) ..= floor((tmax - bmin) / SNAP). Per voxel: one dot product (the
// triangle normal) and one cross product per edge (the axes edge x unit axis); the box normals
// are the cell range.
struct PieceTest {
    n: vec3<i32>,
    n_range: vec2<i32>,
    e0: vec3<i32>,
    e1: vec3<i32>,
    e2: vec3<i32>,
    lo0: vec3<i32>,
    hi0: vec3<i32>,
    lo1: vec3<i32>,
    hi1: vec3<i32>,
    lo2: vec3<i32>,
    hi2: vec3<i32>,
}

// Ranges of cross(e, l) for the three axes (0, -e.z, e.y), (e.z, 0, -e.x), (-e.y, e.x, 0).
fn edge_range(e: vec3<i32>, v0: vec3<i32>, v1: vec3<i32>, v2: vec3<i32>) -> array<vec3<i32>, 2> {
    let p0 = cross_i(e, v0);
    let p1 = cross_i(e, v1);
    let p2 = cross_i(e, v2);
    let ep = max(e, vec3<i32>(0));
    let en = max(-e, vec3<i32>(0));
    let pos = en.zxy + ep.yzx;
    let neg = ep.zxy + en.yzx;
    let lo = ceil_snap3(min(min(p0, p1), p2) - (SNAP + DILATE) * pos - DILATE * neg);
    let hi = floor_snap3(max(max(p0, p1), p2) + DILATE * pos + (SNAP + DILATE) * neg);
    return array<vec3<i32>, 2>(lo, hi);
}

fn piece_test(p: Piece, first: vec3<i32>) -> PieceTest {
    let o = first * SNAP;
    let v0 = p.a - o;
    let v1 = p.b - o;
    let v2 = p.c - o;
    var s: PieceTest;
    s.e0 = v1 - v0;
    s.e1 = v2 - v1;
    s.e2 = v0 - v2;
    s.n = cross_i(s.e0, s.e1);
    // t = n . v0 = a 2^NORMAL_SPLIT + b; ceil((t - x) / SNAP) = a 2^(NORMAL_SPLIT - SNAP_SHIFT)
    // + ceil((b - x) / SNAP), every term within i32.
    let nh = s.n >> vec3<u32>(NORMAL_SPLIT);
    let nl = s.n & vec3<i32>(4095); // 2^NORMAL_SPLIT - 1
    let a = dot_i(nh, v0) << (NORMAL_SPLIT - SNAP_SHIFT);
    let b = dot_i(nl, v0);
    let pos = dot_i(max(s.n, vec3<i32>(0)), vec3<i32>(1));
    let neg = dot_i(max(-s.n, vec3<i32>(0)), vec3<i32>(1));
    s.n_range = vec2<i32>(a + ceil_snap(b - (SNAP + DILATE) * pos - DILATE * neg),
                          a + floor_snap(b + DILATE * pos + (SNAP + DILATE) * neg));
    let r0 = edge_range(s.e0, v0, v1, v2);
    let r1 = edge_range(s.e1, v0, v1, v2);
    let r2 = edge_range(s.e2, v0, v1, v2);
    s.lo0 = r0[0];
    s.hi0 = r0[1];
    s.lo1 = r1[0];
    s.hi1 = r1[1];
    s.lo2 = r2[0];
    s.hi2 = r2[1];
    return s;
}

// Whether the piece touches the dilated voxel at offset l from the range's first voxel.
fn piece_touches(s: PieceTest, l: vec3<i32>) -> bool {
    let d = dot_i(s.n, l);
    if d < s.n_range.x || d > s.n_range.y {
        return false;
    }
    let c0 = cross_i(s.e0, l);
    if any(c0 < s.lo0) || any(c0 > s.hi0) {
        return false;
    }
    let c1 = cross_i(s.e1, l);
    if any(c1 < s.lo1) || any(c1 > s.hi1) {
        return false;
    }
    let c2 = cross_i(s.e2, l);
    return all(c2 >= s.lo2) && all(c2 <= s.hi2);
}

// Linear invocation index over a 2D dispatch of 64-wide workgroups.
fn linear_index(wg: vec3<u32>, nwg: vec3<u32>, local: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + local;
}

// Bounding-box voxels visited by one work item.
const CHUNK: u32 = 256u;

// Number of voxels in an inclusive range from `piece_cells` (0 when empty).
fn cell_count(range: array<vec3<i32>, 2>) -> u32 {
    let size = range[1] - range[0] + vec3<i32>(1);
    if any(size <= vec3<i32>(0)) {
        return 0u;
    }
    return u32(size.x) * u32(size.y) * u32(size.z);
}

// Offset from the range's first voxel of its i-th voxel, x fastest (the CPU reference's loop
// order).
fn nth_offset(range: array<vec3<i32>, 2>, i: u32) -> vec3<i32> {
    let size = vec3<u32>(range[1] - range[0] + vec3<i32>(1));
    let x = i % size.x;
    let y = (i / size.x) % size.y;
    let z = i / (size.x * size.y);
    return vec3<i32>(vec3<u32>(x, y, z));
}
