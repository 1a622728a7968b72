// Filtered injected radiance of the clipmap: `clip_radiance_sample(p, footprint)` returns RGB
// radiance (premultiplied by opacity) and opacity, with the level choice of `clip_sample`;
// `clip_radiance_facing_level` adds the facing sum (`voxel/facing.wgsl`) of one level's
// trilinear sample, and `clip_thicken` reads a coarse level's opacity as a medium's. Reads
// `Clipmap::radiance` at binding 66 (`voxel::clipmap::sample::CLIP_RADIANCE_BINDING`): three
// words per voxel slot, RGBA16F radiance and opacity, then the direction the radiance leaves
// in (snorm8 x 3).

import octolux::voxel::clipmap::sample::{clip_cell, clip_corner, clip_info, clip_lod, clip_slot, clip_weight};

@group(0) @binding(66) var<storage, read> clip_radiance: array<u32>;

// Radiance (premultiplied) and opacity, with its facing sum: the radiance's weight r + g + b
// times the direction it leaves in, interpolated as the radiance.
struct ClipRadianceFacing {
    radiance: vec4<f32>,
    facing: vec3<f32>,
}

fn clip_radiance_voxel(l: u32, g: vec3<i32>) -> vec4<f32> {
    let slot = clip_slot(l, g);
    return vec4<f32>(unpack2x16float(clip_radiance[3u * slot]),
                     unpack2x16float(clip_radiance[3u * slot + 1u]));
}

// A voxel's three words (the clipmap's and the tail's layout): RGBA16F radiance and opacity,
// then its facing (snorm8 x 3), made a facing sum.
fn clip_radiance_facing_words(w: vec3<u32>) -> ClipRadianceFacing {
    let r = vec4<f32>(unpack2x16float(w.x), unpack2x16float(w.y));
    return ClipRadianceFacing(r, unpack4x8snorm(w.z).xyz * (r.r + r.g + r.b));
}

fn clip_radiance_facing_voxel(l: u32, g: vec3<i32>) -> ClipRadianceFacing {
    let i = 3u * clip_slot(l, g);
    let w = vec3<u32>(clip_radiance[i], clip_radiance[i + 1u], clip_radiance[i + 2u]);
    return clip_radiance_facing_words(w);
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

fn clip_radiance_facing_level(p: vec3<f32>, l: u32) -> ClipRadianceFacing {
    let cell = clip_cell(p, l);
    var sum = ClipRadianceFacing(vec4<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < 8u; k++) {
        let o = clip_corner(k);
        let w = clip_weight(cell, o);
        let v = clip_radiance_facing_voxel(l, cell.i0 + o);
        sum.radiance += w * v.radiance;
        sum.facing += w * v.facing;
    }
    return sum;
}

// a + (b - a) t for both parts.
fn clip_radiance_facing_mix(a: ClipRadianceFacing, b: ClipRadianceFacing, t: f32) -> ClipRadianceFacing {
    return ClipRadianceFacing(mix(a.radiance, b.radiance, t), mix(a.facing, b.facing, t));
}

// A surface is voxelised opaque on the finest level that holds it (every voxel a triangle
// touches), and each coarser level, filtered from the one below (the tail averaged from the
// coarsest), holds the fraction of its voxels' volume that is occupied: a thin surface's
// opacity halves per level, so cones that read coarse levels saw through surfaces and lost
// their light (the Cornell box's indirect light fell to 0.61 of the reference's with the
// levels centred in the box). Read as a medium instead, a voxel of level `level` whose
// occupied fraction is a, crossed over its width, passes a ray through 2^(level - surface)
// voxels of the level `surface` where its surfaces are voxelised, each occupied with
// probability a: its opacity is 1 - (1 - a)^(2^(level - surface)), as the cone's step
// correction (`gi/vct/cone.wgsl`) reads an opacity over a path; radiance and facing scale
// alike. A plane keeps at least 1 - 1/e of its opacity at every level instead of
// 2^-(level - surface) of it. Scaling the opacity by 2^(level - surface) instead (a plane's
// exact coverage, as the octree's `gi/vct/svo_trace.wgsl` does) made every corner and clutter
// of surfaces opaque and the Cornell box 1.3-1.45 times too bright (docs/vct.md, "Opacity on
// coarse levels"). CPU twin: `voxel::clipmap::sample::clip_thicken`.
fn clip_thicken(s: ClipRadianceFacing, level: u32, surface: u32) -> ClipRadianceFacing {
    if level <= surface {
        return s;
    }
    let a = clamp(s.radiance.a, 0.0, 1.0);
    if a <= 0.0 || a >= 1.0 {
        return s;
    }
    let thick = 1.0 - pow(1.0 - a, f32(1u << min(level - surface, 30u)));
    let k = thick / a;
    return ClipRadianceFacing(s.radiance * k, s.facing * k);
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
