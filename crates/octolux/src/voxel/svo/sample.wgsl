// Filtered sampling of the sparse voxel octree: `svo_sample(p, footprint)` returns the
// premultiplied albedo and opacity at world position `p`, filtered over a footprint of
// `footprint` metres (the lattice spacing of the chosen level; quadrilinear between levels).
// The includer declares:
//   var<storage, read> svo_info: SvoInfo; (storage, not uniform: "Parameter blocks" in
//   voxel/mod.rs)
//   var<storage, read> svo_child: array<u32>;
//   var<storage, read> svo_bricks0: array<u32>; (and svo_bricks1..3: the pool's 4 buffers)
//   var<storage, read> svo_brick_index: array<u32>;

struct SvoInfo {
    // xyz: grid origin, w: voxel size.
    origin: vec4<f32>,
    // x: depth (levels), y: resolution, z: bricks per pool buffer.
    misc: vec4<u32>,
}

fn svo_texel(brick: u32, t: vec3<u32>) -> vec4<f32> {
    let w = (brick % svo_info.misc.z) * 27u + t.x + 3u * t.y + 9u * t.z;
    var word = 0u;
    switch brick / svo_info.misc.z {
        case 0u: { word = svo_bricks0[w]; }
        case 1u: { word = svo_bricks1[w]; }
        case 2u: { word = svo_bricks2[w]; }
        default: { word = svo_bricks3[w]; }
    }
    return unpack4x8unorm(word);
}

// The brick cell of level d holding grid position g (voxel units): `brick` is the brick index
// + 1 (0 where no node or no brick exists: an all-zero lattice), `i0` the lower lattice corner
// and `f` the trilinear weights inside the cell. Shared by every channel's sampler.
struct SvoCell {
    brick: u32,
    i0: vec3<u32>,
    f: vec3<f32>,
}

fn svo_locate(g: vec3<f32>, d: u32) -> SvoCell {
    var cell: SvoCell;
    let depth = svo_info.misc.x;
    let x = g / f32(1u << (depth - 1u - d));
    let size = 1u << d;
    if any(x < vec3<f32>(0.0)) || any(x > vec3<f32>(2.0 * f32(size))) {
        return cell;
    }
    let c = min(vec3<u32>(x * 0.5), vec3<u32>(size - 1u));
    var node = 0u;
    for (var l = 0u; l < d; l++) {
        let first = svo_child[node];
        if first == 0u {
            return cell;
        }
        let s = d - 1u - l;
        node = first + ((c.x >> s) & 1u) + (((c.y >> s) & 1u) << 1u) + (((c.z >> s) & 1u) << 2u);
    }
    cell.brick = svo_brick_index[node];
    let local = clamp(x - 2.0 * vec3<f32>(c), vec3<f32>(0.0), vec3<f32>(2.0));
    cell.i0 = min(vec3<u32>(local), vec3<u32>(1u));
    cell.f = local - vec3<f32>(cell.i0);
    return cell;
}

// Trilinear weight of corner `k` (bit 0: x, 1: y, 2: z) of a cell, and its lattice offset.
fn svo_corner(k: u32) -> vec3<u32> {
    return vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
}

fn svo_weight(cell: SvoCell, o: vec3<u32>) -> f32 {
    let w = select(1.0 - cell.f, cell.f, o == vec3<u32>(1u));
    return w.x * w.y * w.z;
}

// Level choice for a footprint: the finer level, the blend `t` towards the next coarser one,
// and the grid position. Level d has lattice spacing voxel * 2^(depth - 1 - d).
struct SvoLod {
    fine: u32,
    t: f32,
    g: vec3<f32>,
}

fn svo_lod(p: vec3<f32>, footprint: f32) -> SvoLod {
    let depth = svo_info.misc.x;
    let lod = clamp(log2(max(footprint / svo_info.origin.w, 1.0)), 0.0, f32(depth - 1u));
    return SvoLod(depth - 1u - u32(floor(lod)), lod - floor(lod), (p - svo_info.origin.xyz) / svo_info.origin.w);
}

// Trilinear albedo/opacity sample of level d at grid position g; zero where no node exists.
fn svo_sample_level(g: vec3<f32>, d: u32) -> vec4<f32> {
    let cell = svo_locate(g, d);
    var sum = vec4<f32>(0.0);
    if cell.brick == 0u {
        return sum;
    }
    for (var k = 0u; k < 8u; k++) {
        let o = svo_corner(k);
        sum += svo_weight(cell, o) * svo_texel(cell.brick - 1u, cell.i0 + o);
    }
    return sum;
}

fn svo_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let lod = svo_lod(p, footprint);
    let a = svo_sample_level(lod.g, lod.fine);
    if lod.t <= 0.0 || lod.fine == 0u {
        return a;
    }
    return mix(a, svo_sample_level(lod.g, lod.fine - 1u), lod.t);
}
