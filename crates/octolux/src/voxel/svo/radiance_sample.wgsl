// Filtered injected radiance of the sparse voxel octree: `svo_radiance_sample(p, footprint)`
// returns RGB radiance (premultiplied by opacity) and opacity with the level choice and
// interpolation of `svo_sample`, from the octree's 4 radiance buffers (`Svo::radiance`,
// bound by `voxel::svo::sample::svo_radiance_bindings`).

import octolux::voxel::svo::sample::{SvoCell, svo_corner, svo_info, svo_locate_levels, svo_lod, svo_weight};

@group(0) @binding(57) var<storage, read> svo_radiance0: array<u32>;
@group(0) @binding(58) var<storage, read> svo_radiance1: array<u32>;
@group(0) @binding(59) var<storage, read> svo_radiance2: array<u32>;
@group(0) @binding(60) var<storage, read> svo_radiance3: array<u32>;

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

fn svo_radiance_cell(cell: SvoCell) -> vec4<f32> {
    var sum = vec4<f32>(0.0);
    if cell.brick == 0u {
        return sum;
    }
    for (var k = 0u; k < 8u; k++) {
        let o = svo_corner(k);
        sum += svo_weight(cell, o) * svo_radiance_texel(cell.brick - 1u, cell.i0 + o);
    }
    return sum;
}

fn svo_radiance_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let lod = svo_lod(p, footprint);
    let blend = lod.t > 0.0 && lod.fine > 0u;
    let cells = svo_locate_levels(lod.g, lod.fine, blend);
    let a = svo_radiance_cell(cells.fine);
    if !blend {
        return a;
    }
    return mix(a, svo_radiance_cell(cells.coarse), lod.t);
}
