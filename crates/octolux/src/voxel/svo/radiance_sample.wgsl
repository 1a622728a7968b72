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
    let w = (brick % svo_info.pool_bricks) * 54u + 2u * (t.x + 3u * t.y + 9u * t.z);
    var lo = 0u;
    var hi = 0u;
    switch brick / svo_info.pool_bricks {
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

// The facing pool (`Svo::facing`, bound at 68..71, `voxel::svo::sample::svo_facing_bindings`):
// per texel the radiance's weight (r + g + b) times the direction its surface faces, filtered
// as the radiance. `svo_radiance_facing_sample` reads it with the radiance, from one descent;
// `facing_toward` (`voxel/facing.wgsl`) says how much of it a cone sees.
@group(0) @binding(68) var<storage, read> svo_facing0: array<u32>;
@group(0) @binding(69) var<storage, read> svo_facing1: array<u32>;
@group(0) @binding(70) var<storage, read> svo_facing2: array<u32>;
@group(0) @binding(71) var<storage, read> svo_facing3: array<u32>;

struct SvoRadianceFacing {
    radiance: vec4<f32>,
    facing: vec3<f32>,
}

// Texel t of brick `brick`: radiance and facing, from one word index and one pool choice.
fn svo_radiance_facing_texel(brick: u32, t: vec3<u32>) -> SvoRadianceFacing {
    let w = (brick % svo_info.pool_bricks) * 54u + 2u * (t.x + 3u * t.y + 9u * t.z);
    var r: vec2<u32>;
    var f: vec2<u32>;
    switch brick / svo_info.pool_bricks {
        case 0u: { r = vec2<u32>(svo_radiance0[w], svo_radiance0[w + 1u]); f = vec2<u32>(svo_facing0[w], svo_facing0[w + 1u]); }
        case 1u: { r = vec2<u32>(svo_radiance1[w], svo_radiance1[w + 1u]); f = vec2<u32>(svo_facing1[w], svo_facing1[w + 1u]); }
        case 2u: { r = vec2<u32>(svo_radiance2[w], svo_radiance2[w + 1u]); f = vec2<u32>(svo_facing2[w], svo_facing2[w + 1u]); }
        default: { r = vec2<u32>(svo_radiance3[w], svo_radiance3[w + 1u]); f = vec2<u32>(svo_facing3[w], svo_facing3[w + 1u]); }
    }
    return SvoRadianceFacing(
        vec4<f32>(unpack2x16float(r.x), unpack2x16float(r.y)),
        vec3<f32>(unpack2x16float(f.x), unpack2x16float(f.y).x),
    );
}

fn svo_radiance_facing_cell(cell: SvoCell) -> SvoRadianceFacing {
    var sum = SvoRadianceFacing(vec4<f32>(0.0), vec3<f32>(0.0));
    if cell.brick == 0u {
        return sum;
    }
    for (var k = 0u; k < 8u; k++) {
        let o = svo_corner(k);
        let w = svo_weight(cell, o);
        let texel = svo_radiance_facing_texel(cell.brick - 1u, cell.i0 + o);
        sum.radiance += w * texel.radiance;
        sum.facing += w * texel.facing;
    }
    return sum;
}

// `svo_radiance_sample` with the facing sum, from the same cells.
fn svo_radiance_facing_sample(p: vec3<f32>, footprint: f32) -> SvoRadianceFacing {
    let lod = svo_lod(p, footprint);
    let blend = lod.t > 0.0 && lod.fine > 0u;
    let cells = svo_locate_levels(lod.g, lod.fine, blend);
    let a = svo_radiance_facing_cell(cells.fine);
    if !blend {
        return a;
    }
    let b = svo_radiance_facing_cell(cells.coarse);
    return SvoRadianceFacing(mix(a.radiance, b.radiance, lod.t), mix(a.facing, b.facing, lod.t));
}
