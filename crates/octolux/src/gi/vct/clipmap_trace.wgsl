// The clipmap back-end of `trace.wgsl` (mounted as its `structure`): samples the clipmap's
// injected radiance.

import octolux::voxel::clipmap::sample::{clip_contains, clip_corner, clip_info};
import octolux::voxel::clipmap::radiance_sample::clip_radiance_level;
import octolux::voxel::clipmap::blend::clip_blend_choice;

// The clipmap's tail (`clipmap_tail.rs`): levels k = 1..=K of res / 2^k voxels over the
// coarsest level's region, for footprints past that level's voxel.
@group(0) @binding(13) var<storage, read> clip_tail: array<u32>;

// The injected radiance filtered over `footprint`: up to the coarsest level's voxel, the
// level choice of `clip_sample_blend` (`clipmap/blend.wgsl`: near the border of the level a
// sample reads, it fades to the next coarser level, so cones do not jump where a level ends);
// past it, the tail, quadrilinear between its levels (without the tail, wide cones
// point-sampled the coarsest level with steps of many voxels and the indirect light showed
// blotches of its voxels).
// Isotropic: `dir` is not read.
fn vct_sample(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let last = clip_info.levels - 1u;
    let coarsest = clip_info.voxel_size * f32(1u << last);
    if footprint <= coarsest {
        return clip_levels_sample(p, footprint);
    }
    let levels = clip_tail_levels();
    let m = min(log2(footprint / coarsest), f32(levels));
    let k = u32(floor(m));
    let t = m - f32(k);
    var a = vec4<f32>(0.0);
    if k == 0u {
        a = clip_levels_sample(p, coarsest);
    } else {
        a = clip_tail_level(p, k);
    }
    if t <= 0.0 || k >= levels {
        return a;
    }
    return mix(a, clip_tail_level(p, k + 1u), t);
}

fn clip_levels_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let c = clip_blend_choice(p, footprint);
    let l = u32(c.x);
    if l >= clip_info.levels {
        return vec4<f32>(0.0);
    }
    let a = clip_radiance_level(p, l);
    if c.y <= 0.0 {
        return a;
    }
    return mix(a, clip_radiance_level(p, l + 1u), c.y);
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

fn clip_tail_voxel(k: u32, first: u32, j: vec3<i32>) -> vec4<f32> {
    let n = clip_info.resolution >> k;
    if any(j < vec3<i32>(0)) || any(j >= vec3<i32>(i32(n))) {
        return vec4<f32>(0.0);
    }
    let slot = first + u32(j.x) + n * (u32(j.y) + n * u32(j.z));
    return vec4<f32>(unpack2x16float(clip_tail[2u * slot]),
                     unpack2x16float(clip_tail[2u * slot + 1u]));
}

// Trilinear sample of tail level k (outside the region: empty).
fn clip_tail_level(p: vec3<f32>, k: u32) -> vec4<f32> {
    let last = clip_info.levels - 1u;
    let coarsest = clip_info.voxel_size * f32(1u << last);
    let origin = vec3<f32>(clip_info.origins[last].xyz);
    let g = (p / coarsest - origin) / f32(1u << k) - 0.5;
    let i0 = vec3<i32>(floor(g));
    let f = g - floor(g);
    let first = clip_tail_first(k);
    var sum = vec4<f32>(0.0);
    for (var c = 0u; c < 8u; c++) {
        let o = clip_corner(c);
        let w = select(1.0 - f, f, o == vec3<i32>(1));
        sum += w.x * w.y * w.z * clip_tail_voxel(k, first, i0 + o);
    }
    return sum;
}

// The voxel of the finest level holding p (a coarse level's voxel is thicker than a fine
// level's offset, so the start offset grows with it).
fn vct_surface_voxel(p: vec3<f32>, finest: f32) -> f32 {
    var voxel = finest;
    for (var l = 0u; l < clip_info.levels; l++) {
        if clip_contains(p, l) {
            break;
        }
        voxel *= 2.0;
    }
    return voxel;
}

// The clipmap's samples are texture reads, counted as the cones' samples: nothing more to
// add to the pass's work counts.
fn vct_count_structure_work(q: u32) {}
