// Test kernels: the lattice and the BVH traversal on the GPU, for their CPU twins.

import octolux::gi::probes::lattice::lattice_dir;
import octolux::gi::probes::bvh::{bvh_closest, bvh_hit_normal, BVH_MISS, bvh_occluded};

struct TestParams {
    // x: lattice kind, y: directions, z: rays
    misc: vec4<u32>,
    // x: static BVH root, y: animated objects
    roots: vec4<u32>,
};

// The BVH's nodes, triangles and instances are bvh.wgsl's bindings (2 to 4).
@group(0) @binding(0) var<storage, read> T: TestParams;
// Per ray: (origin, t_max), (direction, 0).
@group(0) @binding(6) var<storage, read> rays: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn dirs(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < T.misc.y {
        out[id.x] = lattice_dir(T.misc.x, id.x, T.misc.y);
    }
}

// Per ray: (triangle bits, t, u, v), (occluded, instance bits, world normal xy).
@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= T.misc.z {
        return;
    }
    let o = rays[2u * id.x];
    let d = rays[2u * id.x + 1u].xyz;
    let hit = bvh_closest(T.roots.xy, o.xyz, d, o.w);
    out[2u * id.x] = vec4<f32>(bitcast<f32>(hit.tri), hit.t, hit.u, hit.v);
    let occluded = select(0.0, 1.0, bvh_occluded(T.roots.xy, o.xyz, d, o.w));
    var n = vec3<f32>(0.0);
    if hit.tri != BVH_MISS {
        n = bvh_hit_normal(hit);
    }
    out[2u * id.x + 1u] = vec4<f32>(occluded, bitcast<f32>(hit.instance), n.x, n.y);
}
