// Directional sampling of the octree's anisotropic radiance (`svo/aniso_radiance.wgsl`), bound
// at 62 (`SvoAnisoRadiance::buffer`, `voxel::svo::sample::SVO_ANISO_RADIANCE_BINDING`).
//
// The same node-centred interpolation, level choice and face weights as the anisotropic
// albedo (`svo/sample_aniso.wgsl`), over RGBA16F values (premultiplied radiance, opacity).

// Node-centred trilinear sample of level d's directional radiance at grid position g.
import octolux::voxel::svo::sample::{svo_faces, svo_node_cell, svo_node_lod};

@group(0) @binding(62) var<storage, read> svo_aniso_radiance: array<u32>;

fn svo_radiance_aniso_level(g: vec3<f32>, d: u32, dir: vec3<f32>) -> vec4<f32> {
    let cell = svo_node_cell(g, d);
    let faces = svo_faces(dir);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let b = cell.bricks[k];
        if b == 0u {
            continue;
        }
        let base = (b - 1u) * 12u;
        var v = vec4<f32>(0.0);
        for (var a = 0u; a < 3u; a++) {
            let w = base + 2u * faces.face[a];
            v += faces.w[a] * vec4<f32>(unpack2x16float(svo_aniso_radiance[w]),
                                        unpack2x16float(svo_aniso_radiance[w + 1u]));
        }
        sum += cell.weights[k] * v;
    }
    return sum;
}

// Radiance and opacity seen travelling along `dir`, filtered over `footprint` metres (two
// finest voxels or more: the finest level below), quadrilinear between two levels.
fn svo_radiance_aniso(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32> {
    let lod = svo_node_lod(p, footprint);
    let a = svo_radiance_aniso_level(lod.g, lod.fine, dir);
    if lod.t <= 0.0 || lod.fine == 0u {
        return a;
    }
    return mix(a, svo_radiance_aniso_level(lod.g, lod.fine - 1u, dir), lod.t);
}
