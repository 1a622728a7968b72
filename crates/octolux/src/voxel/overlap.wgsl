// Shared by every voxelization kernel: the triangle layout, the region parameters and the exact
// triangle/box overlap test (separating axis theorem, closed boxes: touching counts).

struct Tri {
    p0: vec4<f32>,
    p1: vec4<f32>,
    p2: vec4<f32>,
    extra: vec4<f32>,
}

// What one fragment of `tri` adds to its leaf voxel's sums (the octree's 10 words per voxel):
// albedo r, g, b (x255), 1 (the count), emission r, g, b (fixed point x1024, W/(m^2 sr)),
// normal x, y, z (snorm8 as two's complement). Integer sums do not depend on their order.
fn fragment_sum_terms(tri: Tri) -> array<u32, 10> {
    var t: array<u32, 10>;
    let albedo = bitcast<u32>(tri.p0.w);
    t[0] = albedo & 255u;
    t[1] = (albedo >> 8u) & 255u;
    t[2] = (albedo >> 16u) & 255u;
    t[3] = 1u;
    let e = clamp(vec3<f32>(tri.p2.w, tri.extra.x, tri.extra.y), vec3<f32>(0.0), vec3<f32>(65504.0));
    let nb = bitcast<u32>(tri.p1.w);
    for (var k = 0u; k < 3u; k++) {
        t[4u + k] = u32(round(e[k] * 1024.0));
        t[7u + k] = bitcast<u32>(i32(((nb >> (8u * k)) & 255u) << 24u) >> 24u);
    }
    return t;
}

// A box of voxels [lo, hi) of a grid whose voxel (0,0,0) starts at `origin.xyz` and whose voxels
// have edge 1 / origin.w; misc.x = triangle count, misc.y/z/w are kernel specific.
struct VoxParams {
    lo: vec4<i32>,
    hi: vec4<i32>,
    origin: vec4<f32>,
    misc: vec4<u32>,
}

// Grid coordinates of a world position; the CPU reference does the same two operations.
fn to_grid(p: vec3<f32>, origin: vec4<f32>) -> vec3<f32> {
    return (p - origin.xyz) * origin.w;
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// True if the projections of the triangle and the box on `axis` are disjoint.
fn separated(axis: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> bool {
    let p0 = dot3(axis, v0);
    let p1 = dot3(axis, v1);
    let p2 = dot3(axis, v2);
    let r = 0.5 * (abs(axis.x) + abs(axis.y) + abs(axis.z));
    return min(min(p0, p1), p2) > r || max(max(p0, p1), p2) < -r;
}

fn edge_separates(e: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> bool {
    return separated(vec3<f32>(0.0, -e.z, e.y), v0, v1, v2)
        || separated(vec3<f32>(e.z, 0.0, -e.x), v0, v1, v2)
        || separated(vec3<f32>(-e.y, e.x, 0.0), v0, v1, v2);
}

// Exact overlap of triangle (a, b, c) (grid coordinates) with the closed voxel `cell`.
fn tri_box_overlap(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, cell: vec3<i32>) -> bool {
    let centre = vec3<f32>(cell) + vec3<f32>(0.5);
    let v0 = a - centre;
    let v1 = b - centre;
    let v2 = c - centre;
    let mn = min(min(v0, v1), v2);
    let mx = max(max(v0, v1), v2);
    if any(mn > vec3<f32>(0.5)) || any(mx < vec3<f32>(-0.5)) {
        return false;
    }
    let e0 = v1 - v0;
    let e1 = v2 - v1;
    let e2 = v0 - v2;
    let n = vec3<f32>(e0.y * e1.z - e0.z * e1.y, e0.z * e1.x - e0.x * e1.z, e0.x * e1.y - e0.y * e1.x);
    if separated(n, v0, v0, v0) {
        return false;
    }
    return !(edge_separates(e0, v0, v1, v2) || edge_separates(e1, v0, v1, v2)
        || edge_separates(e2, v0, v1, v2));
}

// Voxels [first, last] (inclusive) that the triangle's bounding box touches, clipped to the
// region; empty when last < first on some axis.
fn tri_cells(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, lo: vec3<i32>, hi: vec3<i32>) -> array<vec3<i32>, 2> {
    let big = vec3<f32>(1.0e6);
    let mn = clamp(min(min(a, b), c), -big, big);
    let mx = clamp(max(max(a, b), c), -big, big);
    let first = max(vec3<i32>(ceil(mn)) - vec3<i32>(1), lo);
    let last = min(vec3<i32>(floor(mx)), hi - vec3<i32>(1));
    return array<vec3<i32>, 2>(first, last);
}

// Linear invocation index over a 2D dispatch of 64-wide workgroups.
fn linear_index(wg: vec3<u32>, nwg: vec3<u32>, local: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + local;
}

// Bounding-box voxels visited by one work item.
const CHUNK: u32 = 4096u;

// Number of voxels in an inclusive range from `tri_cells` (0 when empty).
fn cell_count(range: array<vec3<i32>, 2>) -> u32 {
    let size = range[1] - range[0] + vec3<i32>(1);
    if any(size <= vec3<i32>(0)) {
        return 0u;
    }
    return u32(size.x) * u32(size.y) * u32(size.z);
}

// The i-th voxel of an inclusive range, x fastest (the CPU reference's loop order).
fn nth_cell(range: array<vec3<i32>, 2>, i: u32) -> vec3<i32> {
    let size = vec3<u32>(range[1] - range[0] + vec3<i32>(1));
    let x = i % size.x;
    let y = (i / size.x) % size.y;
    let z = i / (size.x * size.y);
    return range[0] + vec3<i32>(vec3<u32>(x, y, z));
}
