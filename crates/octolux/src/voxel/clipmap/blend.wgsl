// Clipmap sampling with blending between levels by distance and with anisotropic voxels.
// `clip_sample_aniso` reads `Clipmap::aniso` at binding 67
// (`voxel::clipmap::sample::CLIP_ANISO_BINDING`).
//
// `clip_sample_blend(p, footprint)` reads the level l that `clip_sample` picks (the finest
// whose voxel is at least the footprint and which holds p's trilinear neighbourhood) and mixes
// in level l + 1 with weight 1 - (1 - t) (1 - e): t is the fractional level of the footprint
// (when l is the footprint's level), e = 1 - smoothstep(0, CLIP_BLEND_CELLS, distance from p to
// the border of the region where level l holds p, in level-l voxels). At that border the
// sample is level l + 1 alone, so nothing jumps where level l ends. Level l + 1 is read only
// when it holds p; a level that does not contain p is never read.
//
// `clip_sample_aniso(p, footprint, dir)` is the same with each coarse voxel's value seen along
// the travel direction `dir`: the directional values of the three axes dir points along,
// weighted by |dir.x|, |dir.y|, |dir.z| (normalised to sum to one). Level 0 is isotropic.

import octolux::voxel::clipmap::sample::{clip_contains, clip_info, clip_sample_level};

@group(0) @binding(67) var<storage, read> clip_aniso: array<u32>;

const CLIP_BLEND_CELLS: f32 = 2.0;

// Distance (voxels of level l) from p to the border of the region where level l holds p's
// trilinear neighbourhood (negative outside).
fn clip_border_distance(p: vec3<f32>, l: u32) -> f32 {
    let g = p / (clip_info.voxel_size * f32(1u << l)) - 0.5;
    let lo = vec3<f32>(clip_info.origins[l].xyz);
    let hi = lo + vec3<f32>(f32(clip_info.resolution) - 1.0);
    let d = min(g - lo, hi - g);
    return min(d.x, min(d.y, d.z));
}

// x: the level to read (levels when none holds p), y: the weight of level x + 1.
fn clip_blend_choice(p: vec3<f32>, footprint: f32) -> vec2<f32> {
    let levels = clip_info.levels;
    let lod = clamp(log2(max(footprint / clip_info.voxel_size, 1.0)), 0.0, f32(levels - 1u));
    var l = u32(floor(lod));
    while l < levels && !clip_contains(p, l) {
        l++;
    }
    if l >= levels {
        return vec2<f32>(f32(levels), 0.0);
    }
    if l + 1u >= levels || !clip_contains(p, l + 1u) {
        return vec2<f32>(f32(l), 0.0);
    }
    var t = 0.0;
    if f32(l) == floor(lod) {
        t = lod - floor(lod);
    }
    let x = clamp(clip_border_distance(p, l) / CLIP_BLEND_CELLS, 0.0, 1.0);
    let e = 1.0 - x * x * (3.0 - 2.0 * x);
    return vec2<f32>(f32(l), 1.0 - (1.0 - t) * (1.0 - e));
}

fn clip_sample_blend(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let c = clip_blend_choice(p, footprint);
    let l = u32(c.x);
    if l >= clip_info.levels {
        return vec4<f32>(0.0);
    }
    let a = clip_sample_level(p, l);
    if c.y <= 0.0 {
        return a;
    }
    return mix(a, clip_sample_level(p, l + 1u), c.y);
}

fn clip_aniso_voxel(l: u32, g: vec3<i32>, d: u32) -> vec4<f32> {
    let res = i32(clip_info.resolution);
    let m = vec3<u32>(((g % res) + res) % res);
    let r = clip_info.resolution;
    let slot = (l - 1u) * r * r * r + m.x + r * (m.y + r * m.z);
    return unpack4x8unorm(clip_aniso[slot * 6u + d]);
}

fn clip_aniso_level(p: vec3<f32>, l: u32, dir: vec3<f32>) -> vec4<f32> {
    if l == 0u {
        return clip_sample_level(p, 0u);
    }
    let a = abs(dir);
    let w = a / max(a.x + a.y + a.z, 1e-20);
    let dx = select(1u, 0u, dir.x >= 0.0);
    let dy = select(3u, 2u, dir.y >= 0.0);
    let dz = select(5u, 4u, dir.z >= 0.0);
    let g = p / (clip_info.voxel_size * f32(1u << l)) - 0.5;
    let i0 = vec3<i32>(floor(g));
    let f = g - floor(g);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
        let t = select(1.0 - f, f, o == vec3<u32>(1u));
        let q = i0 + vec3<i32>(o);
        let v = w.x * clip_aniso_voxel(l, q, dx) + w.y * clip_aniso_voxel(l, q, dy)
            + w.z * clip_aniso_voxel(l, q, dz);
        sum += t.x * t.y * t.z * v;
    }
    return sum;
}

fn clip_sample_aniso(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let c = clip_blend_choice(p, footprint);
    let l = u32(c.x);
    if l >= clip_info.levels {
        return vec4<f32>(0.0);
    }
    let a = clip_aniso_level(p, l, dir);
    if c.y <= 0.0 {
        return a;
    }
    return mix(a, clip_aniso_level(p, l + 1u, dir), c.y);
}
