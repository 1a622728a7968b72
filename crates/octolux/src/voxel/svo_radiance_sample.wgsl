// Filtered injected radiance of the sparse voxel octree: `svo_radiance_sample(p, footprint)`
// returns RGB radiance (premultiplied by opacity) and opacity with the level choice and
// interpolation of `svo_sample`. Goes after `sample_svo.wgsl`; the includer also declares
//   var<storage, read> svo_radiance0: array<u32>; (and svo_radiance1..3: Svo::radiance)

fn svo_radiance_texel(brick: u32, t: vec3<u32>) -> vec4<f32> {
    let w = (brick % svo_info.misc.z) * 54u + 2u * (t.x + 3u * t.y + 9u * t.z);
    var lo = 0u;
    var hi = 0u;
    switch brick / svo_info.misc.z {
        case 0u: { lo = svo_radiance0[w]; hi = svo_radiance0[w + 1u]; }
        case 1u: { lo = svo_radiance1[w]; hi = svo_radiance1[w + 1u]; }
        case 2u: { lo = svo_radiance2[w]; hi = svo_radiance2[w + 1u]; }
        default: { lo = svo_radiance3[w]; hi = svo_radiance3[w + 1u]; }
    }
    return vec4<f32>(unpack2x16float(lo), unpack2x16float(hi));
}

fn svo_radiance_level(g: vec3<f32>, d: u32) -> vec4<f32> {
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
        sum += w.x * w.y * w.z * svo_radiance_texel(b - 1u, i0 + o);
    }
    return sum;
}

fn svo_radiance_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let depth = svo_info.misc.x;
    let g = (p - svo_info.origin.xyz) / svo_info.origin.w;
    let lod = clamp(log2(max(footprint / svo_info.origin.w, 1.0)), 0.0, f32(depth - 1u));
    let fine = depth - 1u - u32(floor(lod));
    let t = lod - floor(lod);
    let a = svo_radiance_level(g, fine);
    if t <= 0.0 || fine == 0u {
        return a;
    }
    return mix(a, svo_radiance_level(g, fine - 1u), t);
}
