// Filtered injected radiance of the clipmap: `clip_radiance_sample(p, footprint)` returns RGB
// radiance (premultiplied by opacity) and opacity, with the level choice of `clip_sample`.
// Needs `sample_clipmap.wgsl` before it; the includer also declares
//   var<storage, read> clip_radiance: array<u32>;   (Clipmap::radiance)

fn clip_radiance_voxel(l: u32, g: vec3<i32>) -> vec4<f32> {
    let res = i32(clip_info.misc.x);
    let m = vec3<u32>(((g % res) + res) % res);
    let r = clip_info.misc.x;
    let slot = l * r * r * r + m.x + r * (m.y + r * m.z);
    return vec4<f32>(unpack2x16float(clip_radiance[2u * slot]),
                     unpack2x16float(clip_radiance[2u * slot + 1u]));
}

fn clip_radiance_level(p: vec3<f32>, l: u32) -> vec4<f32> {
    let g = p / (clip_info.voxel.x * f32(1u << l)) - 0.5;
    let i0 = vec3<i32>(floor(g));
    let f = g - floor(g);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
        let w = select(1.0 - f, f, o == vec3<u32>(1u));
        sum += w.x * w.y * w.z * clip_radiance_voxel(l, i0 + vec3<i32>(o));
    }
    return sum;
}

fn clip_radiance_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let levels = clip_info.misc.y;
    let lod = clamp(log2(max(footprint / clip_info.voxel.x, 1.0)), 0.0, f32(levels - 1u));
    var l = u32(floor(lod));
    while l < levels && !clip_contains(p, l) {
        l++;
    }
    if l >= levels {
        return vec4<f32>(0.0);
    }
    let a = clip_radiance_level(p, l);
    let t = lod - floor(lod);
    if t <= 0.0 || f32(l) > floor(lod) || l + 1u >= levels || !clip_contains(p, l + 1u) {
        return a;
    }
    return mix(a, clip_radiance_level(p, l + 1u), t);
}
