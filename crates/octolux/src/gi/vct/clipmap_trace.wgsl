// The clipmap back-end of `trace.wgsl`: samples the clipmap's injected radiance.

@group(0) @binding(3) var<storage, read> clip_info: ClipInfo;
@group(0) @binding(4) var<storage, read> clip_radiance: array<u32>;
// Declared for the sampler's albedo path, which the gather does not read.
@group(0) @binding(7) var<storage, read> clip_voxels: array<u32>;

// Declared for the blending sampler's anisotropic path, which the gather does not read.
@group(0) @binding(12) var<storage, read> clip_aniso: array<u32>;

// The injected radiance with the level choice of `clip_sample_blend` (`clipmap/blend.wgsl`):
// near the border of the level a sample reads, it fades to the next coarser level, so cones
// do not jump where a level ends (without it, each pixel's cones switched levels at other
// places and the indirect light showed blocks of the coarse voxels).
fn vct_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let c = clip_blend_choice(p, footprint);
    let l = u32(c.x);
    if l >= clip_info.misc.y {
        return vec4<f32>(0.0);
    }
    let a = clip_radiance_level(p, l);
    if c.y <= 0.0 {
        return a;
    }
    return mix(a, clip_radiance_level(p, l + 1u), c.y);
}

// The voxel of the finest level holding p (a coarse level's voxel is thicker than a fine
// level's offset, so the start offset grows with it).
fn vct_surface_voxel(p: vec3<f32>) -> f32 {
    var voxel = trace.cone.voxel;
    for (var l = 0u; l < clip_info.misc.y; l++) {
        if clip_contains(p, l) {
            break;
        }
        voxel *= 2.0;
    }
    return voxel;
}
