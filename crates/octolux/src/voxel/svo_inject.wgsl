// Light injection into the sparse voxel octree (Arnebäck 2017 §3.2: direct light from the
// shadow maps). `accumulate` sums the fragments' albedo, emission and normal per leaf voxel;
// `inject` turns every leaf voxel into outgoing radiance emission + albedo / pi x direct
// irradiance, with visibility from the renderer's shadow-map array (PCF as in
// `render/direct.wgsl`), and writes the leaf bricks of the radiance pool (RGBA16F, radiance
// and opacity) the way `leaf_fill` writes albedo. The transfer and mip kernels of `svo.wgsl`
// then filter the pool upward.

// Per leaf voxel (8 per leaf node, octant order): albedo r, g, b x255 sums, fragment count,
// emission r, g, b sums x EMISSION_SCALE, normal x, y, z sums (snorm8, two's complement).
const SUM_WORDS: u32 = 10u;
const EMISSION_SCALE: f32 = 1024.0;

// x: fragments, y: depth, z: first leaf node, w: leaf nodes.
struct AccumulateParams {
    misc: vec4<u32>,
}

@group(0) @binding(0) var<uniform> A: AccumulateParams;
@group(0) @binding(1) var<storage, read> fragments: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tris: array<Tri>;
@group(0) @binding(3) var<storage, read> child: array<u32>;
@group(0) @binding(4) var<storage, read_write> sums: array<atomic<u32>>;

fn unpack3(c: u32) -> vec3<u32> {
    return vec3<u32>(c & 1023u, (c >> 10u) & 1023u, (c >> 20u) & 1023u);
}

fn sign_extend8(b: u32) -> i32 {
    return (i32(b << 24u)) >> 24u;
}

@compute @workgroup_size(64)
fn accumulate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= A.misc.x {
        return;
    }
    let frag = fragments[f];
    let v = unpack3(frag.x);
    let leaf = A.misc.y - 1u;
    let c = v >> vec3<u32>(1u);
    var node = 0u;
    for (var l = 0u; l < leaf; l++) {
        let first = child[node];
        if first == 0u {
            return;
        }
        let s = leaf - 1u - l;
        node = first + (((c.x >> s) & 1u) | (((c.y >> s) & 1u) << 1u) | (((c.z >> s) & 1u) << 2u));
    }
    if node < A.misc.z || node >= A.misc.z + A.misc.w {
        return;
    }
    let o = (v.x & 1u) | ((v.y & 1u) << 1u) | ((v.z & 1u) << 2u);
    let w = ((node - A.misc.z) * 8u + o) * SUM_WORDS;
    let tri = tris[frag.y];
    let albedo = bitcast<u32>(tri.p0.w);
    atomicAdd(&sums[w], albedo & 255u);
    atomicAdd(&sums[w + 1u], (albedo >> 8u) & 255u);
    atomicAdd(&sums[w + 2u], (albedo >> 16u) & 255u);
    atomicAdd(&sums[w + 3u], 1u);
    let e = clamp(vec3<f32>(tri.p2.w, tri.extra.x, tri.extra.y), vec3<f32>(0.0), vec3<f32>(65504.0));
    for (var k = 0u; k < 3u; k++) {
        atomicAdd(&sums[w + 4u + k], u32(round(e[k] * EMISSION_SCALE)));
    }
    let nb = bitcast<u32>(tri.p1.w);
    for (var k = 0u; k < 3u; k++) {
        atomicAdd(&sums[w + 7u + k], bitcast<u32>(sign_extend8((nb >> (8u * k)) & 255u)));
    }
}

// `Light`, `light_incidence` and `shadow_visibility` come from `render/lights.wgsl`.

struct InjectParams {
    // xyz grid origin, w voxel size
    origin_voxel: vec4<f32>,
    // x: first leaf node, y: leaf nodes, z: lights, w: bricks per pool buffer
    misc: vec4<u32>,
}

@group(0) @binding(10) var<uniform> P: InjectParams;
@group(0) @binding(11) var<storage, read> leaf_sums: array<u32>;
@group(0) @binding(12) var<storage, read> node_coord: array<u32>;
@group(0) @binding(13) var<storage, read> brick_index: array<u32>;
@group(0) @binding(14) var<storage, read> lights: array<Light>;
@group(0) @binding(15) var<storage, read> shadow_matrices: array<mat4x4<f32>>;
@group(0) @binding(16) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(17) var shadow_sampler: sampler_comparison;
@group(0) @binding(18) var<storage, read_write> voxel_radiance: array<u32>;
@group(0) @binding(19) var<storage, read_write> pool0: array<u32>;
@group(0) @binding(20) var<storage, read_write> pool1: array<u32>;
@group(0) @binding(21) var<storage, read_write> pool2: array<u32>;
@group(0) @binding(22) var<storage, read_write> pool3: array<u32>;

const PI: f32 = 3.14159265358979;

fn pool_store(b: u32, i: u32, v: u32) {
    let w = (b % P.misc.w) * 54u + i;
    switch b / P.misc.w {
        case 0u: { pool0[w] = v; }
        case 1u: { pool1[w] = v; }
        case 2u: { pool2[w] = v; }
        default: { pool3[w] = v; }
    }
}

// Outgoing radiance and opacity of leaf voxel `i` (node-major, octant order) at `p`.
fn voxel_value(i: u32, p: vec3<f32>) -> vec4<f32> {
    let w = i * SUM_WORDS;
    let count = leaf_sums[w + 3u];
    if count == 0u {
        return vec4<f32>(0.0);
    }
    let c = f32(count);
    let albedo = vec3<f32>(f32(leaf_sums[w]), f32(leaf_sums[w + 1u]), f32(leaf_sums[w + 2u])) / c / 255.0;
    let emission = vec3<f32>(f32(leaf_sums[w + 4u]), f32(leaf_sums[w + 5u]), f32(leaf_sums[w + 6u])) / c / EMISSION_SCALE;
    var n = vec3<f32>(f32(bitcast<i32>(leaf_sums[w + 7u])), f32(bitcast<i32>(leaf_sums[w + 8u])),
                      f32(bitcast<i32>(leaf_sums[w + 9u])));
    let has_normal = dot(n, n) > 0.01 * c * c * 127.0 * 127.0;
    if has_normal {
        n = normalize(n);
    } else {
        n = vec3<f32>(0.0);
    }
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < P.misc.z; k++) {
        let light = lights[k];
        let inc = light_incidence(light, p);
        // A voxel without a dominant normal (opposite faces cancelled) is lit as facing the light.
        var cos_theta = 1.0;
        if has_normal {
            cos_theta = dot(n, inc.to_light);
        }
        if cos_theta <= 0.0 || all(inc.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        // Looked up half a voxel along the normal: the surface may lie anywhere in the voxel.
        let lift = 0.5 * P.origin_voxel.w;
        e += inc.irradiance * cos_theta * shadow_visibility(light, p, n, inc.to_light, inc.dist, lift);
    }
    return vec4<f32>(emission + albedo / PI * e, 1.0);
}

fn octant(o: u32) -> vec3<u32> {
    return vec3<u32>(o & 1u, (o >> 1u) & 1u, (o >> 2u) & 1u);
}

@compute @workgroup_size(64)
fn inject(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    let l = linear_index(wg, nwg, li);
    if l >= P.misc.y {
        return;
    }
    let n = P.misc.x + l;
    let b1 = brick_index[n];
    let c = unpack3(node_coord[n]);
    var voxels: array<vec4<f32>, 8>;
    for (var o = 0u; o < 8u; o++) {
        let v = 2u * c + octant(o);
        let p = P.origin_voxel.xyz + (vec3<f32>(v) + 0.5) * P.origin_voxel.w;
        voxels[o] = voxel_value(l * 8u + o, p);
        voxel_radiance[2u * (l * 8u + o)] = pack2x16float(voxels[o].xy);
        voxel_radiance[2u * (l * 8u + o) + 1u] = pack2x16float(voxels[o].zw);
    }
    if b1 == 0u {
        return;
    }
    let b = b1 - 1u;
    for (var t = 0u; t < 27u; t++) {
        let i = vec3<u32>(t % 3u, (t / 3u) % 3u, t / 9u);
        var sum = vec4<f32>(0.0);
        for (var o = 0u; o < 8u; o++) {
            let a = octant(o);
            if all(i >= a) && all(i - a <= vec3<u32>(1u)) {
                sum += voxels[o] * 0.125;
            }
        }
        pool_store(b, 2u * t, pack2x16float(sum.xy));
        pool_store(b, 2u * t + 1u, pack2x16float(sum.zw));
    }
}
