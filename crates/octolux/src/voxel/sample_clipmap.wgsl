// Filtered sampling of the clipmap: `clip_sample(p, footprint)` returns the premultiplied
// albedo and opacity at world position `p` from the finest level whose voxels are at least
// `footprint` and which contains `p` with its whole trilinear neighbourhood (a level that does
// not contain the point is never read), blended with the next level by the fractional level.
// The includer declares:
//   var<uniform> clip_info: ClipInfo;
//   var<storage, read> clip_voxels: array<u32>;

struct ClipInfo {
    // x: finest voxel size.
    voxel: vec4<f32>,
    // x: resolution, y: levels.
    misc: vec4<u32>,
    // First voxel of each level (world-voxel coordinates of that level).
    origins: array<vec4<i32>, 8>,
}

fn clip_voxel(l: u32, g: vec3<i32>) -> vec4<f32> {
    let res = i32(clip_info.misc.x);
    let m = vec3<u32>(((g % res) + res) % res);
    let r = clip_info.misc.x;
    return unpack4x8unorm(clip_voxels[l * r * r * r + m.x + r * (m.y + r * m.z)]);
}

// Whether level l holds p's trilinear neighbourhood.
fn clip_contains(p: vec3<f32>, l: u32) -> bool {
    let g = p / (clip_info.voxel.x * f32(1u << l)) - 0.5;
    let lo = vec3<f32>(clip_info.origins[l].xyz);
    return all(g >= lo) && all(g < lo + vec3<f32>(f32(clip_info.misc.x) - 1.0));
}

fn clip_sample_level(p: vec3<f32>, l: u32) -> vec4<f32> {
    let g = p / (clip_info.voxel.x * f32(1u << l)) - 0.5;
    let i0 = vec3<i32>(floor(g));
    let f = g - floor(g);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
        let w = select(1.0 - f, f, o == vec3<u32>(1u));
        sum += w.x * w.y * w.z * clip_voxel(l, i0 + vec3<i32>(o));
    }
    return sum;
}

fn clip_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let levels = clip_info.misc.y;
    let lod = clamp(log2(max(footprint / clip_info.voxel.x, 1.0)), 0.0, f32(levels - 1u));
    var l = u32(floor(lod));
    while l < levels && !clip_contains(p, l) {
        l++;
    }
    if l >= levels {
        return vec4<f32>(0.0);
    }
    let a = clip_sample_level(p, l);
    let t = lod - floor(lod);
    if t <= 0.0 || f32(l) > floor(lod) || l + 1u >= levels || !clip_contains(p, l + 1u) {
        return a;
    }
    return mix(a, clip_sample_level(p, l + 1u), t);
}
