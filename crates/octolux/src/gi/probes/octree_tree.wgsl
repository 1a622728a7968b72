// The probe octree's encoding (gi/probes/octree.rs, `ProbeOctree`): shared by the state
// machine (octree.wgsl) and the probe set (octree_set.wgsl). Its bindings (`O`, `tree`) are
// composed in as `gi/probes/tree_bindings`: written by the state machine
// (octree_tree_write.wgsl), read by the probe set (octree_tree_read.wgsl).

import octolux::gi::probes::tree_bindings::{O, tree};

struct Cube {
    lo: vec3<f32>,
    size: f32,
    depth: u32,
};

// Meta word of the cluster holding node i > 0.
fn octree_meta(i: u32) -> u32 {
    return 1u + 9u * ((i - 1u) / 9u);
}

// Cube of node i, rebuilt bottom-up through the meta words' parent links, then top-down with
// the same operations as `ProbeOctree::cube` (bit-exact).
fn octree_cube(i: u32) -> Cube {
    var slots: array<u32, 16>;
    var depth = 0u;
    var node = i;
    while node != 0u && depth < 16u {
        let m = octree_meta(node);
        slots[depth] = node - m - 1u;
        depth += 1u;
        node = u32(~tree[m]);
    }
    var lo = O.root_lo;
    var size = O.root_size;
    for (var k = depth; k > 0u; k--) {
        let s = slots[k - 1u];
        let half = size * 0.5;
        lo += select(vec3<f32>(0.0), vec3<f32>(half), vec3<bool>((s & 1u) != 0u, (s & 2u) != 0u, (s & 4u) != 0u));
        size = half;
    }
    return Cube(lo, size, depth);
}

// The leaf holding point q (clamped into the root cube): node index and cube. CPU twin:
// `OctreeView::leaf`.
fn octree_leaf(q: vec3<f32>) -> vec2<u32> {
    var node = 0u;
    var lo = O.root_lo;
    var size = O.root_size;
    for (var d = 0u; d <= O.max_depth; d++) {
        let v = tree[node];
        if v <= 0 {
            return vec2<u32>(node, d);
        }
        let half = size * 0.5;
        let upper = q >= lo + vec3<f32>(half);
        lo += select(vec3<f32>(0.0), vec3<f32>(half), upper);
        size = half;
        node = u32(v) + 1u + select(0u, 1u, upper.x) + select(0u, 2u, upper.y) + select(0u, 4u, upper.z);
    }
    return vec2<u32>(node, O.max_depth);
}
