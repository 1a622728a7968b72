// The octree back-end of `trace.wgsl`: samples the sparse voxel octree's injected radiance.

@group(0) @binding(3) var<storage, read> svo_info: SvoInfo;
@group(0) @binding(4) var<storage, read> svo_child: array<u32>;
@group(0) @binding(7) var<storage, read> svo_brick_index: array<u32>;
@group(0) @binding(8) var<storage, read> svo_radiance0: array<u32>;
@group(0) @binding(9) var<storage, read> svo_radiance1: array<u32>;
@group(0) @binding(10) var<storage, read> svo_radiance2: array<u32>;
@group(0) @binding(11) var<storage, read> svo_radiance3: array<u32>;
// Declared for the sampler's albedo path, which the gather does not read.
@group(0) @binding(12) var<storage, read> svo_bricks0: array<u32>;
@group(0) @binding(13) var<storage, read> svo_bricks1: array<u32>;
@group(0) @binding(14) var<storage, read> svo_bricks2: array<u32>;
@group(0) @binding(15) var<storage, read> svo_bricks3: array<u32>;

// The octree's anisotropic radiance (`anisotropic` setting; a placeholder word otherwise).
@group(0) @binding(16) var<storage, read> svo_aniso_radiance: array<u32>;

// The isotropic lattice holds mean occupancy: a one-voxel-thick surface filling a voxel of
// side s (in finest voxels) averages to opacity 1/s there, so surfaces fade as cones widen.
// Scaling by s (the sample's footprint over the finest voxel) gives such a surface its
// coverage back, radiance alike (premultiplied); clamped at opacity 1. It over-counts
// surfaces seen edge-on, which the anisotropic values (composited per travel direction) do
// not: with `anisotropic`, footprints of two finest voxels and more read those, and between
// one and two voxels the sample blends from the scaled lattice to them.
fn vct_sample(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    var lod: SvoNodeLod;
    if SVO_ANISOTROPIC {
        lod = svo_node_lod(p, footprint);
        if lod.below >= 1.0 {
            return svo_radiance_aniso(p, footprint, dir);
        }
    }
    let s = svo_radiance_sample(p, footprint);
    let k = min(max(footprint / svo_info.origin.w, 1.0), 1.0 / max(s.a, 1e-6));
    if !SVO_ANISOTROPIC || lod.below <= 0.0 {
        return s * k;
    }
    return mix(s * k, svo_radiance_aniso_level(lod.g, lod.fine, dir), lod.below);
}

// One grid, but a surface reaches further off itself than in the clipmap: the octree's
// bricks are corner-sampled and each level's mip spreads a surface over the next lattice
// points, and the coverage scaling above makes what spreads opaque. Measured on the Cornell
// box (docs/vct.md), cones that start 1.5 x 4 finest voxels off the surface halve the
// ceiling's error against 1.5 x 1; so the octree's "surface voxel" is 4 finest voxels.
fn vct_surface_voxel(p: vec3<f32>) -> f32 {
    return 4.0 * svo_info.origin.w;
}
