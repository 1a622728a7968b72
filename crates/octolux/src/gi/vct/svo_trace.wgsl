// The octree back-end of `trace.wgsl` (mounted as its `structure`): samples the sparse voxel
// octree's injected radiance. The flags `anisotropic` and `facing` follow the settings; the
// anisotropic radiance is bound either way (a placeholder word without it), the facing pool
// only with `facing`.

import octolux::voxel::svo::sample::{SvoNodeLod, svo_info, svo_node_lod};
import octolux::voxel::svo::radiance_sample::{svo_radiance_facing_sample, svo_radiance_sample};
import octolux::voxel::facing::facing_toward;
import octolux::voxel::svo::radiance_sample_aniso::{svo_radiance_aniso, svo_radiance_aniso_level};
import octolux::voxel::svo::sample::count_lookup_work;

@if(anisotropic) const SVO_ANISOTROPIC: bool = true;
@else const SVO_ANISOTROPIC: bool = false;

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
    let s = svo_radiance_toward(p, footprint, dir);
    let k = min(max(footprint / svo_info.voxel_size, 1.0), 1.0 / max(s.a, 1e-6));
    if !SVO_ANISOTROPIC || lod.below <= 0.0 {
        return s * k;
    }
    return mix(s * k, svo_radiance_aniso_level(lod.g, lod.fine, dir), lod.below);
}

// The radiance sample, with the feature `facing` only the share that leaves towards the
// cone's apex (`facing_toward`: light on a wall's far face, or on a surface seen from
// behind, is not seen).
@if(facing) fn svo_radiance_toward(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let s = svo_radiance_facing_sample(p, footprint);
    return vec4<f32>(s.radiance.rgb * facing_toward(s.radiance, s.facing, dir), s.radiance.a);
}

@if(!facing) fn svo_radiance_toward(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    return svo_radiance_sample(p, footprint);
}

// Adds the octree lookups of this invocation's samples (and the nodes their descents
// passed) to quantities `q` and `q + 1` of the pass's work counts (`gpu/work.wgsl`).
fn vct_count_structure_work(q: u32) {
    count_lookup_work(q, q + 1u);
}

// One grid, but a surface reaches further off itself than in the clipmap: the octree's
// bricks are corner-sampled and each level's mip spreads a surface over the next lattice
// points, and the coverage scaling above makes what spreads opaque. Measured on the Cornell
// box (docs/vct.md), cones that start 1.5 x 4 finest voxels off the surface halve the
// ceiling's error against 1.5 x 1; so the octree's "surface voxel" is 4 finest voxels.
fn vct_surface_voxel(p: vec3<f32>, finest: f32) -> f32 {
    return 4.0 * svo_info.voxel_size;
}
