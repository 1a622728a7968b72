// Filtered injected radiance of the clipmap: `clip_radiance_sample(p, footprint)` returns RGB
// radiance (premultiplied by opacity) and opacity, with the level choice of `clip_sample`.
// Reads `Clipmap::radiance` at binding 66 (`voxel::clipmap::sample::CLIP_RADIANCE_BINDING`).

import octolux::voxel::clipmap::sample::{clip_cell, clip_corner, clip_info, clip_lod, clip_slot, clip_weight};

@group(0) @binding(66) var<storage, read> clip_radiance: array<u32>;

fn clip_radiance_voxel(l: u32, g: vec3<i32>) -> vec4<f32> {
    let slot = clip_slot(l, g);
    return vec4<f32>(unpack2x16float(clip_radiance[2u * slot]),
                     unpack2x16float(clip_radiance[2u * slot + 1u]));
}

fn clip_radiance_level(p: vec3<f32>, l: u32) -> vec4<f32> {
    let cell = clip_cell(p, l);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let o = clip_corner(k);
        sum += clip_weight(cell, o) * clip_radiance_voxel(l, cell.i0 + o);
    }
    return sum;
}

fn clip_radiance_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let lod = clip_lod(p, footprint);
    if lod.level >= clip_info.levels {
        return vec4<f32>(0.0);
    }
    let a = clip_radiance_level(p, lod.level);
    if lod.t <= 0.0 {
        return a;
    }
    return mix(a, clip_radiance_level(p, lod.level + 1u), lod.t);
}
