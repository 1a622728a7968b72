// Test kernel: the voxel rays' lattice ends and hits on the GPU, for their CPU twins.

// Per ray: (origin, t_max), (direction, 0).

import octolux::gi::probes::voxel_rays::{voxel_closest, voxel_ray};

@group(0) @binding(5) var<storage, read> rays: array<vec4<f32>>;
// Per ray: a (xyz, w = meets the grid), b, (voxel, albedo bits), (t, normal), (emission, 0).
@group(0) @binding(6) var<storage, read_write> out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&rays) / 2u {
        return;
    }
    let o = rays[2u * i];
    let d = rays[2u * i + 1u].xyz;
    let ray = voxel_ray(o.xyz, d, o.w);
    let hit = voxel_closest(o.xyz, d, ray);
    out[5u * i] = bitcast<vec4<u32>>(ray.a);
    out[5u * i + 1u] = bitcast<vec4<u32>>(ray.b);
    out[5u * i + 2u] = vec4<u32>(bitcast<vec3<u32>>(hit.voxel), hit.albedo);
    out[5u * i + 3u] = bitcast<vec4<u32>>(vec4<f32>(hit.t, hit.normal));
    out[5u * i + 4u] = bitcast<vec4<u32>>(vec4<f32>(hit.emission, 0.0));
}
