// Visibility through the sparse voxel octree: a stackless walk along a segment (002's
// SVO-restart, Fig. 3, in integer arithmetic), for VPL shadow rays and the probes' voxel rays.
// It reads the bindings declared below, the same in every shader that imports them
// (`voxel::svo::walk::walk_bindings` binds them in Rust): group 0 from binding 44 on. `vo` are
// the walk's parameters, `svo_child` the octree's `child`, `svo_leaf` its `leaf_sums` (whose
// first `leaf_count` words are the static leaves' index words: bits 0..7 the occupancy of
// their 2x2x2 voxels), `svo_state` and `svo_dyn_sums` the dynamic part's (placeholders
// without one), `svo_occupied` a bit per static node whose cell holds a static voxel.
//
// Every decision is made on integers: segment ends are points of a lattice of 2^14 steps per
// grid side (`1 << shift` steps per voxel), and the time along the segment is the fraction
// tn / td of two integers below 2^15. The CPU twin (`walk.rs`, `SvoWalkCpu`) runs the same
// integer code, so both visit the same cells on every adapter. Products stay below 2^30 in i32.
//
// Each step restarts at the deepest node of the previous step's descent whose cell also holds
// the current voxel (the walk keeps the path of its last descent; the root when nothing
// deeper does, as in kd-restart) and descends along that voxel, stopping at the first node
// whose cell holds no voxel (an empty octant of any level, or a node subdivided only for the
// bricks of its occupied neighbours: skipping those whole took a third of the cells off
// segments near walls) or at a leaf, where an empty leaf is skipped whole and
// an occupied one voxel by voxel. The cell is then left through its exit face: the next voxel
// is the one holding the point just after the exit time, found exactly (no t-epsilon).

import octolux::gpu::work::count_work;
import octolux::voxel::svo::leaf_sums::{LEAF_SUM_WORDS, voxel_sums, VoxelSums};

struct SvoWalk {
    // World position of the grid's corner, voxel edge (m).
    origin: vec3<f32>,
    voxel: f32,
    // Octree levels: the grid has 2^depth voxels per side.
    depth: u32,
    // log2 of the fixed-point steps per voxel (14 - depth).
    shift: u32,
    // First node of the finest level, and the number of static leaves with an index word.
    first_leaf: u32,
    leaf_count: u32,
    // Most cells one segment may visit (a safety bound; 3 x side + depth + 2 is never reached).
    cap: u32,
    // Segment ends move this many voxels along their surface normals (see `vpl_fixed_point`).
    end_offset: f32,
    // 1 when the octree has a dynamic part (`svo_state`, `svo_dyn_sums` are bound).
    dynamic: u32,
    // Nodes of the static part (those `svo_occupied` has a bit for).
    static_nodes: u32,
};

@group(0) @binding(44) var<storage, read> vo: SvoWalk;
@group(0) @binding(45) var<storage, read> svo_child: array<u32>;
@group(0) @binding(46) var<storage, read> svo_leaf: array<u32>;
@group(0) @binding(47) var<storage, read> svo_state: array<u32>;
@group(0) @binding(48) var<storage, read> svo_dyn_sums: array<u32>;
@group(0) @binding(49) var<storage, read> svo_occupied: array<u32>;

// Whether node's cell holds a voxel: static (its bit) or dynamic (its state's bit 0, set on
// every level by the dynamic part's `dyn_flag_occupied`).
fn svo_node_occupied(node: u32) -> bool {
    if node < vo.static_nodes && (svo_occupied[node >> 5u] & (1u << (node & 31u))) != 0u {
        return true;
    }
    return vo.dynamic != 0u && (svo_state[node] & 1u) != 0u;
}

// Work of the walks of one invocation (`gpu/work.wgsl`): cells visited and octree nodes
// descended through, kept only by a counting shader; a pass adds them to its counts with
// `count_walk_work`.
@if(count_work) var<private> walk_work: vec2<u32>;

@if(count_work) fn note_walk(cells: u32, nodes: u32) {
    walk_work += vec2<u32>(cells, nodes);
}

@if(!count_work) fn note_walk(cells: u32, nodes: u32) {}

// Adds this invocation's walk work to quantities `cells_q` and `nodes_q` of the pass's counts.
@if(count_work) fn count_walk_work(cells_q: u32, nodes_q: u32) {
    count_work(cells_q, walk_work.x);
    count_work(nodes_q, walk_work.y);
}

@if(!count_work) fn count_walk_work(cells_q: u32, nodes_q: u32) {}

// Occupancy of the 8 voxels of leaf node `node` (bit x + 2y + 4z): static and dynamic
// fragments.
fn vpl_leaf_mask(node: u32) -> u32 {
    let leaf = node - vo.first_leaf;
    var mask = 0u;
    if leaf < vo.leaf_count {
        mask = svo_leaf[leaf] & 255u;
    }
    if vo.dynamic != 0u {
        let slot = svo_state[node] >> 2u;
        if slot != 0u {
            for (var o = 0u; o < 8u; o++) {
                if svo_dyn_sums[((slot - 1u) * 8u + o) * 10u + 3u] != 0u {
                    mask |= 1u << o;
                }
            }
        }
    }
    return mask;
}

const VPL_FIXED_BITS: u32 = 14u;

// The voxel holding the point at time tn / td (+ an infinitesimal) of the segment a + t d:
// on an axis where the point lies on a voxel face, the voxel the segment enters next, and for
// a segment lying in a face (d = 0), the voxel above it (voxels are half-open).
fn vpl_voxel_at(a: vec3<i32>, d: vec3<i32>, tn: i32, td: i32) -> vec3<i32> {
    let den = vec3<i32>(td << vo.shift);
    let n = a * td + d * tn;
    let up = n / den;
    let down = (n + den - vec3<i32>(1)) / den - vec3<i32>(1);
    return select(up, down, d < vec3<i32>(0));
}

// Lattice point of world position `p` moved `end_offset` voxels along `n`, inside the grid.
fn vpl_fixed_point(p: vec3<f32>, n: vec3<f32>) -> vec3<i32> {
    let g = (p + n * (vo.end_offset * vo.voxel) - vo.origin) / vo.voxel;
    let top = (1 << VPL_FIXED_BITS) - 1;
    let q = vec3<i32>(floor(clamp(g, vec3<f32>(0.0), vec3<f32>(f32(1u << vo.depth))) * f32(1u << vo.shift)));
    return clamp(q, vec3<i32>(1), vec3<i32>(top));
}

// Whether the segment a -> b (lattice points) passes through an occupied voxel other than the
// voxels holding its two ends (where the surfaces it joins were voxelised).
fn svo_occluded(a: vec3<i32>, b: vec3<i32>) -> bool {
    return svo_first_hit(a, b).w != 0;
}

// The first occupied voxel the segment a -> b passes through other than the voxels holding its
// two ends (xyz), w = 1, or w = 0 when there is none.
fn svo_first_hit(a: vec3<i32>, b: vec3<i32>) -> vec4<i32> {
    let none = vec4<i32>(0);
    let d = b - a;
    let ad = abs(d);
    if all(ad == vec3<i32>(0)) {
        return none;
    }
    var tn = 0;
    var td = 1;
    var v = vpl_voxel_at(a, d, 0, 1);
    let first = v;
    var nodes = 0u;
    // path[k]: the node k levels above the voxels on the last descent, valid for k >= reached
    // (path[depth] is the root); prev: the voxel of that descent.
    var path: array<u32, 16>;
    path[vo.depth] = 0u;
    var reached = vo.depth;
    var prev = v;
    for (var it = 0u; it < vo.cap; it++) {
        // Restart at the deepest node of the last descent whose cell holds v, then descend.
        var k = reached;
        while k < vo.depth && any((v >> vec3<u32>(k)) != (prev >> vec3<u32>(k))) {
            k += 1u;
        }
        var node = path[k];
        var occupied = false;
        loop {
            nodes += 1u;
            if k == 1u {
                let mask = vpl_leaf_mask(node);
                if mask != 0u {
                    let bit = u32((v.x & 1) | ((v.y & 1) << 1u) | ((v.z & 1) << 2u));
                    occupied = (mask & (1u << bit)) != 0u;
                    k = 0u;
                }
                break;
            }
            let c = svo_child[node];
            if c == 0u || !svo_node_occupied(node) {
                break;
            }
            k -= 1u;
            let o = (v >> vec3<u32>(k)) & vec3<i32>(1);
            node = c + u32(o.x | (o.y << 1u) | (o.z << 2u));
            path[k] = node;
        }
        reached = max(k, 1u);
        prev = v;
        // Leave the cell (side 2^k voxels) through the face the segment reaches first.
        let lo = (v >> vec3<u32>(k)) << vec3<u32>(k);
        let bound = select(lo, lo + vec3<i32>(1 << k), d > vec3<i32>(0)) << vec3<u32>(vo.shift);
        let dist = select(a - bound, bound - a, d > vec3<i32>(0));
        var m = 3;
        for (var i = 0; i < 3; i++) {
            if ad[i] > 0 && (m == 3 || dist[i] * ad[m] < dist[m] * ad[i]) {
                m = i;
            }
        }
        let en = dist[m];
        let ed = ad[m];
        let holds_end = en >= ed;
        if occupied && !holds_end && any(v != first) {
            note_walk(it + 1u, nodes);
            return vec4<i32>(v, 1);
        }
        if holds_end {
            note_walk(it + 1u, nodes);
            return none;
        }
        tn = en;
        td = ed;
        v = vpl_voxel_at(a, d, tn, td);
    }
    note_walk(vo.cap, nodes);
    return none;
}

// The fragment sums of voxel v (svo/leaf_sums.wgsl), static and dynamic (zero where v is
// empty).
fn svo_voxel_sums(v: vec3<i32>) -> VoxelSums {
    var s = array<u32, 10>();
    var node = 0u;
    var k = vo.depth;
    while k > 1u {
        let c = svo_child[node];
        if c == 0u {
            return voxel_sums(s);
        }
        k -= 1u;
        let o = (v >> vec3<u32>(k)) & vec3<i32>(1);
        node = c + u32(o.x | (o.y << 1u) | (o.z << 2u));
    }
    let o = u32((v.x & 1) | ((v.y & 1) << 1u) | ((v.z & 1) << 2u));
    let leaf = node - vo.first_leaf;
    if leaf < vo.leaf_count {
        let entry = svo_leaf[leaf];
        let mask = entry & 255u;
        if (mask & (1u << o)) != 0u {
            let slot = (entry >> 8u) + countOneBits(mask & ((1u << o) - 1u));
            let at = vo.leaf_count + slot * LEAF_SUM_WORDS;
            for (var i = 0u; i < LEAF_SUM_WORDS; i++) {
                s[i] += svo_leaf[at + i];
            }
        }
    }
    if vo.dynamic != 0u {
        let slot = svo_state[node] >> 2u;
        if slot != 0u {
            let at = ((slot - 1u) * 8u + o) * LEAF_SUM_WORDS;
            for (var i = 0u; i < LEAF_SUM_WORDS; i++) {
                s[i] += svo_dyn_sums[at + i];
            }
        }
    }
    return voxel_sums(s);
}
