// The clipmap back-end of `trace.wgsl`: samples the clipmap's injected radiance.

@group(0) @binding(3) var<storage, read> clip_info: ClipInfo;
@group(0) @binding(4) var<storage, read> clip_radiance: array<u32>;
// Declared for the sampler's albedo path, which the gather does not read.
@group(0) @binding(7) var<storage, read> clip_voxels: array<u32>;

fn vct_sample(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    return clip_radiance_sample(p, footprint);
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
