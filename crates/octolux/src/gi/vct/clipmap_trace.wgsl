// The clipmap back-end of `trace.wgsl` (mounted as its `structure`): samples the clipmap's
// injected radiance. The flag `facing` follows the settings.

import octolux::voxel::clipmap::sample::{clip_contains, clip_corner, clip_info};
import octolux::voxel::clipmap::radiance_sample::{ClipRadianceFacing, clip_radiance_facing_level, clip_radiance_facing_mix, clip_radiance_facing_words, clip_thicken};
import octolux::voxel::facing::facing_toward;
import octolux::voxel::clipmap::blend::clip_blend_choice;

// The clipmap's tail (`clipmap_tail.rs`): levels k = 1..=K of res / 2^k voxels over the
// coarsest level's region, for footprints past that level's voxel.
@group(0) @binding(13) var<storage, read> clip_tail: array<u32>;

// The injected radiance filtered over `footprint`: up to the coarsest level's voxel, the
// level choice of `clip_sample_blend` (`clipmap/blend.wgsl`: near the border of the level a
// sample reads, it fades to the next coarser level, so cones do not jump where a level ends);
// past it, the tail, quadrilinear between its levels (without the tail, wide cones
// point-sampled the coarsest level with steps of many voxels and the indirect light showed
// blotches of its voxels). With `facing`, only the share of the radiance that leaves towards
// the cone's apex (`facing_toward`: the light on a wall's far face is not seen).
fn vct_sample(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let s = clip_radiance_facing(p, footprint);
    return vec4<f32>(s.radiance.rgb * clip_toward(s, dir), s.radiance.a);
}

@if(facing) fn clip_toward(s: ClipRadianceFacing, dir: vec3<f32>) -> f32 {
    return facing_toward(s.radiance, s.facing, dir);
}

@if(!facing) fn clip_toward(s: ClipRadianceFacing, dir: vec3<f32>) -> f32 {
    return 1.0;
}

fn clip_radiance_facing(p: vec3<f32>, footprint: f32) -> ClipRadianceFacing {
    let last = clip_info.levels - 1u;
    let coarsest = clip_info.voxel_size * f32(1u << last);
    let surface = clip_surface_level(p);
    if footprint <= coarsest {
        return clip_levels_sample(p, footprint, surface);
    }
    let levels = clip_tail_levels();
    let m = min(log2(footprint / coarsest), f32(levels));
    let k = u32(floor(m));
    let t = m - f32(k);
    var a: ClipRadianceFacing;
    if k == 0u {
        a = clip_levels_sample(p, coarsest, surface);
    } else {
        a = clip_thicken(clip_tail_level(p, k), last + k, surface);
    }
    if t <= 0.0 || k >= levels {
        return a;
    }
    let b = clip_thicken(clip_tail_level(p, k + 1u), last + k + 1u, surface);
    return clip_radiance_facing_mix(a, b, t);
}

fn clip_levels_sample(p: vec3<f32>, footprint: f32, surface: u32) -> ClipRadianceFacing {
    let c = clip_blend_choice(p, footprint);
    let l = u32(c.x);
    if l >= clip_info.levels {
        return ClipRadianceFacing(vec4<f32>(0.0), vec3<f32>(0.0));
    }
    let a = clip_thicken(clip_radiance_facing_level(p, l), l, surface);
    if c.y <= 0.0 {
        return a;
    }
    let b = clip_thicken(clip_radiance_facing_level(p, l + 1u), l + 1u, surface);
    return clip_radiance_facing_mix(a, b, c.y);
}

// The finest level that holds p: where the surfaces around p are voxelised (levels when none
// does).
fn clip_surface_level(p: vec3<f32>) -> u32 {
    var l = 0u;
    while l < clip_info.levels && !clip_contains(p, l) {
        l++;
    }
    return l;
}

// Tail levels: down to 2 voxels per side (resolution a power of two).
fn clip_tail_levels() -> u32 {
    return countTrailingZeros(max(clip_info.resolution, 4u)) - 1u;
}

// First slot of tail level k (`clipmap_tail::tail_offset`).
fn clip_tail_first(k: u32) -> u32 {
    var first = 0u;
    for (var i = 1u; i < k; i++) {
        let m = clip_info.resolution >> i;
        first += m * m * m;
    }
    return first;
}

// Tail voxel j of level k: radiance and facing sum, as a clipmap voxel's (3 words).
fn clip_tail_voxel(k: u32, first: u32, j: vec3<i32>) -> ClipRadianceFacing {
    let n = clip_info.resolution >> k;
    if any(j < vec3<i32>(0)) || any(j >= vec3<i32>(i32(n))) {
        return ClipRadianceFacing(vec4<f32>(0.0), vec3<f32>(0.0));
    }
    let i = 3u * (first + u32(j.x) + n * (u32(j.y) + n * u32(j.z)));
    return clip_radiance_facing_words(vec3<u32>(clip_tail[i], clip_tail[i + 1u], clip_tail[i + 2u]));
}

// Trilinear sample of tail level k (outside the region: empty).
fn clip_tail_level(p: vec3<f32>, k: u32) -> ClipRadianceFacing {
    let last = clip_info.levels - 1u;
    let coarsest = clip_info.voxel_size * f32(1u << last);
    let origin = vec3<f32>(clip_info.origins[last].xyz);
    let g = (p / coarsest - origin) / f32(1u << k) - 0.5;
    let i0 = vec3<i32>(floor(g));
    let f = g - floor(g);
    let first = clip_tail_first(k);
    var sum = ClipRadianceFacing(vec4<f32>(0.0), vec3<f32>(0.0));
    for (var c = 0u; c < 8u; c++) {
        let o = clip_corner(c);
        let w3 = select(1.0 - f, f, o == vec3<i32>(1));
        let w = w3.x * w3.y * w3.z;
        let v = clip_tail_voxel(k, first, i0 + o);
        sum.radiance += w * v.radiance;
        sum.facing += w * v.facing;
    }
    return sum;
}

// The voxel of the finest level holding p (a coarse level's voxel is thicker than a fine
// level's offset, so the start offset grows with it).
fn vct_surface_voxel(p: vec3<f32>, finest: f32) -> f32 {
    return finest * f32(1u << clip_surface_level(p));
}

// The clipmap's samples are texture reads, counted as the cones' samples: nothing more to
// add to the pass's work counts.
fn vct_count_structure_work(q: u32) {}
