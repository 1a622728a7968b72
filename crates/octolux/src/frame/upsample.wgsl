// Sparse shading's reconstruction (`frame/sparse.rs`): every pixel takes the irradiance of the
// 2 x 2 shaded blocks around it (one shaded pixel per f x f block, at the block's centre),
// weighted bilinearly and by how alike the traced pixel's surface is: relative view depth
// (exp(-|dz| / (0.05 z))) and normal (max(0, n.n')^8). Where no neighbour is alike (a
// silhouette against unrelated surfaces) it takes the most alike one. Alpha (the ambient
// occlusion) is reconstructed alike.

import octolux::frame::common::{Camera, world_from_depth};
import octolux::frame::sparse::block_pixel;

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var depth_tex: texture_depth_2d;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(3) var sparse_tex: texture_2d<f32>;
// The sparse factor f (a storage block: "Parameter blocks" in voxel/mod.rs).
@group(0) @binding(4) var<storage, read> sparse_factor: u32;
@group(0) @binding(5) var out_tex: texture_storage_2d<rgba16float, write>;

fn view_depth(px: vec2<u32>) -> f32 {
    let d = textureLoad(depth_tex, px, 0);
    return distance(world_from_depth(cam, px, d), cam.position.xyz);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    if textureLoad(depth_tex, id.xy, 0) >= 1.0 {
        textureStore(out_tex, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let f = sparse_factor;
    let blocks = (size + vec2<u32>(f - 1u)) / f;
    let z = view_depth(id.xy);
    let n = normalize(textureLoad(normal_tex, id.xy, 0).xyz);
    // Position in block units relative to the block centres.
    let g = (vec2<f32>(id.xy) + 0.5) / f32(f) - 0.5;
    let b0 = vec2<i32>(floor(g));
    let t = g - floor(g);
    var sum = vec4<f32>(0.0);
    var weight = 0.0;
    var best = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    var best_likeness = -1.0;
    for (var k = 0u; k < 4u; k++) {
        let o = vec2<i32>(i32(k & 1u), i32(k >> 1u));
        let b = vec2<u32>(clamp(b0 + o, vec2<i32>(0), vec2<i32>(blocks) - vec2<i32>(1)));
        let px = block_pixel(b, f, size);
        if textureLoad(depth_tex, px, 0) >= 1.0 {
            continue;
        }
        let dz = abs(view_depth(px) - z) / max(0.05 * z, 1e-6);
        let likeness = exp(-dz) * pow(max(dot(n, normalize(textureLoad(normal_tex, px, 0).xyz)), 0.0), 8.0);
        let e = textureLoad(sparse_tex, b, 0);
        let bilinear = select(1.0 - t.x, t.x, o.x == 1) * select(1.0 - t.y, t.y, o.y == 1);
        sum += bilinear * likeness * e;
        weight += bilinear * likeness;
        if likeness > best_likeness {
            best_likeness = likeness;
            best = e;
        }
    }
    var e = best;
    if weight > 1e-4 {
        e = sum / weight;
    }
    textureStore(out_tex, id.xy, e);
}
