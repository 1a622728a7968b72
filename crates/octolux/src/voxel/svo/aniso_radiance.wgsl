// Anisotropic (6-direction) injected radiance of the sparse voxel octree's nodes, rebuilt
// every frame after the injection (`svo/aniso_radiance.rs`). Every node with a brick gets 6
// RGBA16F values (premultiplied radiance, opacity), one per travel direction +x, -x, +y, -y,
// +z, -z: what a cone travelling that way sees, the convention of the octree's anisotropic
// albedo (`svo/aniso.wgsl`). Direction +x composites the two finer values met one after the
// other along x front to back (c = c_front + (1 - a_front) c_back) and averages the 4 pairs
// across y and z. On the leaf level the finer values are the node's 8 voxels' injected
// radiance (`voxel_radiance`, isotropic); above, its 8 children's values for the same
// direction (a child without a brick is transparent zero). One dispatch per level and node
// range (static, then dynamic), finest level first.
//
// Unlike the isotropic lattice, whose mean occupancy fades a one-voxel-thick wall to 1/s at a
// level of voxels s times larger, compositing keeps a wall seen face-on opaque on every level,
// and one seen edge-on at the share of the node it covers.

import octolux::voxel::pairs::pair_along;
import octolux::voxel::svo::control::SvoControlValues;

struct AnisoRadianceParams {
    level: u32,
    // 1 for the level's dynamic nodes (their range from `control`), 0 for its static nodes
    // [first, first + count).
    dynamic_nodes: u32,
    // 1 on the leaf level.
    leaf: u32,
    // Static leaf nodes (the dynamic leaves' voxel slots follow theirs).
    static_leaves: u32,
    first: u32,
    count: u32,
    pad1: u32,
    pad2: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> P: AnisoRadianceParams;
@group(0) @binding(1) var<storage, read> child: array<u32>;
@group(0) @binding(2) var<storage, read> brick_index: array<u32>;
// The octree's control block (svo/control.wgsl), for the level's dynamic node range.
@group(0) @binding(3) var<storage, read> control: SvoControlValues;
@group(0) @binding(4) var<storage, read> voxel_radiance: array<u32>;
@group(0) @binding(5) var<storage, read_write> aniso: array<u32>;

const ANISO_RADIANCE_WORDS: u32 = 12u;

fn half4(lo: u32, hi: u32) -> vec4<f32> {
    return vec4<f32>(unpack2x16float(lo), unpack2x16float(hi));
}

// The value of node child `c` (brick index + 1, 0 = none) for direction `d`.
fn child_value(b: u32, d: u32) -> vec4<f32> {
    if b == 0u {
        return vec4<f32>(0.0);
    }
    let w = (b - 1u) * ANISO_RADIANCE_WORDS + 2u * d;
    return half4(aniso[w], aniso[w + 1u]);
}

@compute @workgroup_size(64)
fn build_level(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    var first = P.first;
    var count = P.count;
    if P.dynamic_nodes == 1u {
        let nodes = control.dynamic_levels[P.level];
        first = nodes.first;
        count = nodes.end - first;
    }
    if i >= count {
        return;
    }
    let n = first + i;
    let b = brick_index[n];
    if b == 0u {
        return;
    }
    var fine: array<vec4<f32>, 8>;
    var children: array<u32, 8>;
    let leaf = P.leaf == 1u;
    if leaf {
        let slot = 8u * select(i, P.static_leaves + i, P.dynamic_nodes == 1u);
        for (var o = 0u; o < 8u; o++) {
            let w = 2u * (slot + o);
            fine[o] = half4(voxel_radiance[w], voxel_radiance[w + 1u]);
        }
    } else {
        let c = child[n];
        for (var o = 0u; o < 8u; o++) {
            children[o] = select(0u, brick_index[c + o], c != 0u);
        }
    }
    for (var d = 0u; d < 6u; d++) {
        if !leaf {
            for (var o = 0u; o < 8u; o++) {
                fine[o] = child_value(children[o], d);
            }
        }
        var acc = vec4<f32>(0.0);
        for (var j = 0u; j < 4u; j++) {
            let pair = pair_along(d, j);
            let front = fine[pair.x];
            acc += front + (1.0 - front.a) * fine[pair.y];
        }
        acc *= 0.25;
        let w = (b - 1u) * ANISO_RADIANCE_WORDS + 2u * d;
        aniso[w] = pack2x16float(acc.xy);
        aniso[w + 1u] = pack2x16float(acc.zw);
    }
}
