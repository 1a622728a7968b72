// Filtered sampling of the sparse voxel octree: `svo_sample(p, footprint)` returns the
// premultiplied albedo and opacity at world position `p`, filtered over a footprint of
// `footprint` metres (the lattice spacing of the chosen level; quadrilinear between levels).
// The includer declares:
//   var<uniform> svo_info: SvoInfo;
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

// Trilinear sample of level d at grid position g (voxel units); zero where no node exists.
fn svo_sample_level(g: vec3<f32>, d: u32) -> vec4<f32> {
    let depth = svo_info.misc.x;
    let x = g / f32(1u << (depth - 1u - d));
    let size = 1u << d;
    if any(x < vec3<f32>(0.0)) || any(x > vec3<f32>(2.0 * f32(size))) {
        return vec4<f32>(0.0);
    }
    let c = min(vec3<u32>(x * 0.5), vec3<u32>(size - 1u));
    var node = 0u;
    for (var l = 0u; l < d; l++) {
        let first = svo_child[node];
        if first == 0u {
            return vec4<f32>(0.0);
        }
        let s = d - 1u - l;
        node = first + ((c.x >> s) & 1u) + (((c.y >> s) & 1u) << 1u) + (((c.z >> s) & 1u) << 2u);
    }
    // A node without a brick has an all-zero lattice.
    let b = svo_brick_index[node];
    if b == 0u {
        return vec4<f32>(0.0);
    }
    let local = clamp(x - 2.0 * vec3<f32>(c), vec3<f32>(0.0), vec3<f32>(2.0));
    let i0 = min(vec3<u32>(local), vec3<u32>(1u));
    let f = local - vec3<f32>(i0);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
        let w = select(1.0 - f, f, o == vec3<u32>(1u));
        sum += w.x * w.y * w.z * svo_texel(b - 1u, i0 + o);
    }
    return sum;
}

fn svo_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let depth = svo_info.misc.x;
    let g = (p - svo_info.origin.xyz) / svo_info.origin.w;
    // Level d has lattice spacing voxel * 2^(depth - 1 - d).
    let lod = clamp(log2(max(footprint / svo_info.origin.w, 1.0)), 0.0, f32(depth - 1u));
    let fine = depth - 1u - u32(floor(lod));
    let t = lod - floor(lod);
    let a = svo_sample_level(g, fine);
    if t <= 0.0 || fine == 0u {
        return a;
    }
    return mix(a, svo_sample_level(g, fine - 1u), t);
}
