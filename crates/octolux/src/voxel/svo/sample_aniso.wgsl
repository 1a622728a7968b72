// Directional sampling of the octree's anisotropic node values (svo/aniso.wgsl), bound at 61
// (`SvoAnisoValues::buffer`, `voxel::svo::sample::SVO_ANISO_BINDING`).
//
// `svo_sample_aniso(p, footprint, dir)` returns premultiplied albedo and opacity at `p` seen by
// a cone travelling along `dir`, filtered over `footprint` metres. Level d's values sit at its
// node centres (node size voxel * 2^(depth - d)) and are interpolated trilinearly; the level
// whose node size matches the footprint is read, quadrilinear between two levels. Each node's
// value is its directional values for the three faces `dir` travels through (+x when
// dir.x >= 0), weighted by |dir.x|, |dir.y|, |dir.z| normalised to sum to one. Below the finest
// node size (footprint < 2 voxels) the sample blends from the isotropic `svo_sample` (at one
// voxel and less) to the finest directional level (at two voxels). Zero where no node exists.

// Node-centred trilinear sample of level d's directional values at grid position g (voxels).
import octolux::voxel::svo::sample::{svo_faces, svo_node_cell, svo_node_lod, svo_sample};

@group(0) @binding(61) var<storage, read> svo_aniso: array<u32>;

fn svo_aniso_level(g: vec3<f32>, d: u32, dir: vec3<f32>) -> vec4<f32> {
    let cell = svo_node_cell(g, d);
    let faces = svo_faces(dir);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let b = cell.bricks[k];
        if b == 0u {
            continue;
        }
        let base = (b - 1u) * 6u;
        let v = faces.w.x * unpack4x8unorm(svo_aniso[base + faces.face.x])
            + faces.w.y * unpack4x8unorm(svo_aniso[base + faces.face.y])
            + faces.w.z * unpack4x8unorm(svo_aniso[base + faces.face.z]);
        sum += cell.weights[k] * v;
    }
    return sum;
}

fn svo_sample_aniso(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let lod = svo_node_lod(p, footprint);
    if lod.below < 1.0 {
        return mix(svo_sample(p, footprint), svo_aniso_level(lod.g, lod.fine, dir), lod.below);
    }
    let a = svo_aniso_level(lod.g, lod.fine, dir);
    if lod.t <= 0.0 || lod.fine == 0u {
        return a;
    }
    return mix(a, svo_aniso_level(lod.g, lod.fine - 1u, dir), lod.t);
}
