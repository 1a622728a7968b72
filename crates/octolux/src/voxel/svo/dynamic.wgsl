// Dynamic part of the sparse voxel octree (Arnebäck 2017 §3.1.7), compiled after svo/build.wgsl.
// The static part (nodes [0, S), bricks [0, B)) is built once; every update clears what the
// previous update added, then flags, subdivides and links for the dynamic fragments only,
// allocating new nodes after S and new bricks after B. Nothing of the static part is
// rewritten except the pointers into the dynamic section and the bricks whose lattice the
// dynamic geometry changes (or changed in the previous update), which are recomputed by
// gathering ("dirty" nodes: the needed lists below).
//
// Per node `state` (group 2; group 1 holds the dispatch arguments, bound only for the
// dyn_finish_* kernels that write them): bit 0 occupied by a dynamic fragment, bit 1 needed by
// dynamic geometry (in its 26-neighbourhood), bits 2..31 on leaf nodes: 1 + the node's slot in
// `dyn_sums` (its index in the occupied list). Lists hold node indices: the occupied list and
// the needed list are appended level by level, their per-level ranges kept in `control`.

import octolux::voxel::voxelize::overlap::{fragment_sum_terms, linear_index};
import octolux::voxel::svo::leaf_sums::{leaf_sum_offset, LEAF_SUM_WORDS};
import octolux::voxel::svo::control::SvoControlValues;
import octolux::voxel::svo::common::{child, find, brick_plus_one, fragments, INVALID, L, leaf_of_voxel, octant_offset, pack3, tris, unpack3};
import octolux::voxel::svo::build::{bricks0, bricks1, bricks2, bricks3, control, coord, dynamic_level_range, group_index, group_texels, group_word, nbr, tap_weight, texel_coords, texel_index, write_args};

struct DynParams {
    // Nodes and bricks of the static part, S and B (the dynamic ones follow).
    static_nodes: u32,
    static_bricks: u32,
    // Nodes and bricks the pools hold: the static part and the reserve.
    node_capacity: u32,
    brick_capacity: u32,
    // Capacities of the fragment list and of the occupied and needed lists.
    fragment_capacity: u32,
    occupied_capacity: u32,
    needed_capacity: u32,
    first_static_leaf: u32,
    // The control block as the previous update left it, copied on the GPU before this update
    // resets it (its node count, dynamic node ranges and needed-list ranges): nothing of the
    // previous update passes through the CPU.
    last: SvoControlValues,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(2) @binding(1) var<storage, read> D: DynParams;
@group(2) @binding(2) var<storage, read_write> state: array<atomic<u32>>;
@group(2) @binding(3) var<storage, read_write> occ_list: array<u32>;
@group(2) @binding(4) var<storage, read_write> need_list: array<u32>;
@group(2) @binding(5) var<storage, read> last_need_list: array<u32>;
@group(2) @binding(6) var<storage, read_write> dyn_sums: array<atomic<u32>>;
@group(2) @binding(7) var<storage, read> static_sums: array<u32>;

const DYN_OCCUPIED: u32 = 1u;
const DYN_NEEDED: u32 = 2u;
// `control.dynamic_overflow`: what ran out.
const LIST_OVERFLOW: u32 = 1u;
const BRICK_OVERFLOW: u32 = 2u;
// Indirect argument slots (3 words each): static levels 0.., dynamic nodes 16.., occupied
// list 32.., needed list 48.., all needed nodes 63, fragments 64, the previous update's
// dynamic nodes 65 and needed list 66, its needed list per level 67...
const ARGS_DYN_NODES: u32 = 16u;
const ARGS_OCC: u32 = 32u;
const ARGS_NEED: u32 = 48u;
const ARGS_ALL_NEEDED: u32 = 63u;
const ARGS_FRAGMENTS: u32 = 64u;
const ARGS_UNLINK: u32 = 65u;
const ARGS_RESET: u32 = 66u;
const ARGS_LAST_NEED: u32 = 67u;
const SUM_WORDS: u32 = LEAF_SUM_WORDS;

// Entry `i` of the range [r.x, r.y), INVALID past its end.
fn range_entry(wg: vec3<u32>, nwg: vec3<u32>, li: u32, r: vec2<u32>) -> u32 {
    let i = r.x + linear_index(wg, nwg, li);
    if i >= r.y {
        return INVALID;
    }
    return i;
}

// This update's occupied-list and needed-list entries of level d.
fn occupied_range(d: u32) -> vec2<u32> {
    return vec2<u32>(atomicLoad(&control.occupied_ranges[d].first),
                     atomicLoad(&control.occupied_ranges[d].end));
}

fn needed_range(d: u32) -> vec2<u32> {
    return vec2<u32>(atomicLoad(&control.needed_ranges[d].first),
                     atomicLoad(&control.needed_ranges[d].end));
}

// Dynamic fragments of this update that the list holds.
fn fragment_count() -> u32 {
    return min(atomicLoad(&control.dynamic_fragments), D.fragment_capacity);
}

// The previous update's node count (its dynamic nodes are [S, this)).
fn last_node_count() -> u32 {
    return max(min(D.last.node_count, D.node_capacity), D.static_nodes);
}

// The previous update's needed-list length (where its finest level's range ends).
fn last_need_count() -> u32 {
    return min(D.last.needed_ranges[L.depth - 1u].end, D.needed_capacity);
}

// ---- Sizing from the GPU's own counters ------------------------------------------------------

// Sizes the undo of the previous update (its dynamic nodes, its needed list, and per level
// its needed nodes, whose bricks are gathered again) from the control block it left.
@compute @workgroup_size(1)
fn dyn_begin() {
    write_args(ARGS_UNLINK, last_node_count() - D.static_nodes);
    write_args(ARGS_RESET, last_need_count());
    for (var d = 0u; d < L.depth; d++) {
        let r = last_need_range(d);
        write_args(ARGS_LAST_NEED + d, r.y - r.x);
    }
}

// Sizes the passes over this update's fragments once the voxelization has appended them.
@compute @workgroup_size(1)
fn dyn_finish_fragments() {
    write_args(ARGS_FRAGMENTS, fragment_count());
}

// The previous update's needed-list range of level d.
fn last_need_range(d: u32) -> vec2<u32> {
    let end = min(D.last.needed_ranges[d].end, D.needed_capacity);
    return vec2<u32>(min(D.last.needed_ranges[d].first, end), end);
}

// ---- Clearing the previous update -------------------------------------------------------

// Previous dynamic nodes [S, previous count): the static node below each of them on every
// axis pointed to it; that link goes back to 0 (in the static part it had no neighbour there).
@compute @workgroup_size(64)
fn dyn_unlink(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let n = D.static_nodes + linear_index(wg, nwg, li);
    if n >= last_node_count() {
        return;
    }
    let c = unpack3(coord[n]);
    let d = node_level(n);
    for (var a = 0u; a < 3u; a++) {
        if c[a] == 0u {
            continue;
        }
        var e = vec3<u32>(0u);
        e[a] = 1u;
        let m = find(c - e, d);
        if m != INVALID && m < D.static_nodes {
            nbr[3u * m + a] = 0u;
        }
    }
}

// The level of dynamic node n in the previous update.
fn node_level(n: u32) -> u32 {
    for (var d = 1u; d < L.depth; d++) {
        if n < D.last.dynamic_levels[d].end {
            return d;
        }
    }
    return L.depth - 1u;
}

// Previous needed list: static nodes drop children and bricks taken from the dynamic
// section, and every listed node's state is cleared.
@compute @workgroup_size(64)
fn dyn_reset(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) li: u32) {
    let i = linear_index(wg, nwg, li);
    if i >= last_need_count() {
        return;
    }
    let n = last_need_list[i];
    if n >= D.static_nodes {
        return;
    }
    if child[n] >= D.static_nodes {
        child[n] = 0u;
    }
    if atomicLoad(&brick_plus_one[n]) > D.static_bricks {
        atomicStore(&brick_plus_one[n], 0u);
    }
    atomicStore(&state[n], 0u);
}

// ---- Structure ----------------------------------------------------------------------------

// Every dynamic fragment flags its node on level d; the first one lists the node.
@compute @workgroup_size(64)
fn dyn_flag_occupied(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                     @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= fragment_count() {
        return;
    }
    let v = unpack3(fragments[f].x);
    let n = find(v >> vec3<u32>(L.depth - L.d), L.d);
    if n == INVALID {
        return;
    }
    let old = atomicOr(&state[n], DYN_OCCUPIED);
    if (old & DYN_OCCUPIED) != 0u {
        return;
    }
    let i = atomicAdd(&control.occupied_count, 1u);
    if i >= D.occupied_capacity {
        atomicStore(&control.dynamic_overflow, LIST_OVERFLOW);
        return;
    }
    occ_list[i] = n;
    if L.d + 1u == L.depth {
        atomicOr(&state[n], (i + 1u) << 2u);
    }
}

// The occupied and needed lists close their range of level d (it starts where level d - 1's
// ended, at the list's length then) and size its dispatch.
@compute @workgroup_size(1)
fn dyn_finish_occupied() {
    var start = 0u;
    if L.d > 0u {
        start = atomicLoad(&control.occupied_ranges[L.d - 1u].end);
    }
    let end = min(atomicLoad(&control.occupied_count), D.occupied_capacity);
    atomicStore(&control.occupied_ranges[L.d].first, start);
    atomicStore(&control.occupied_ranges[L.d].end, end);
    write_args(ARGS_OCC + L.d, end - start);
}

@compute @workgroup_size(1)
fn dyn_finish_needed() {
    var start = 0u;
    if L.d > 0u {
        start = atomicLoad(&control.needed_ranges[L.d - 1u].end);
    }
    let end = min(atomicLoad(&control.needed_count), D.needed_capacity);
    atomicStore(&control.needed_ranges[L.d].first, start);
    atomicStore(&control.needed_ranges[L.d].end, end);
    write_args(ARGS_NEED + L.d, end - start);
    write_args(ARGS_ALL_NEEDED, end);
}

// The 26-neighbourhood of every node the dynamic fragments occupy on level d (all of these
// nodes exist: their parents' neighbourhoods were subdivided) is needed; each is listed once.
@compute @workgroup_size(64)
fn dyn_flag_needed(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                   @builtin(local_invocation_index) li: u32) {
    let i = range_entry(wg, nwg, li, occupied_range(L.d));
    if i == INVALID {
        return;
    }
    let c = vec3<i32>(unpack3(coord[occ_list[i]]));
    let size = i32(1u << L.d);
    for (var k = 0u; k < 27u; k++) {
        let cc = c + vec3<i32>(i32(k % 3u), i32((k / 3u) % 3u), i32(k / 9u)) - vec3<i32>(1);
        if any(cc < vec3<i32>(0)) || any(cc >= vec3<i32>(size)) {
            continue;
        }
        let m = find(vec3<u32>(cc), L.d);
        if m == INVALID {
            continue;
        }
        let old = atomicOr(&state[m], DYN_NEEDED);
        if (old & DYN_NEEDED) != 0u {
            continue;
        }
        let j = atomicAdd(&control.needed_count, 1u);
        if j >= D.needed_capacity {
            atomicStore(&control.dynamic_overflow, LIST_OVERFLOW);
            continue;
        }
        need_list[j] = m;
    }
}

// Needed nodes of level d without children get 8, allocated in the dynamic section.
@compute @workgroup_size(64)
fn dyn_subdivide(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let i = range_entry(wg, nwg, li, needed_range(L.d));
    if i == INVALID {
        return;
    }
    let n = need_list[i];
    if child[n] != 0u {
        return;
    }
    let base = atomicAdd(&control.node_count, 8u);
    if base + 8u > L.capacity {
        atomicStore(&control.node_overflow, 1u);
        return;
    }
    child[n] = base;
    let c = unpack3(coord[n]);
    for (var o = 0u; o < 8u; o++) {
        coord[base + o] = pack3(c * 2u + octant_offset(o));
    }
}

// Records the dynamic node range of level d + 1 (allocated by `dyn_subdivide` on level d).
@compute @workgroup_size(1)
fn dyn_finish_nodes() {
    let start = atomicLoad(&control.dynamic_levels[L.d].end);
    let end = min(atomicLoad(&control.node_count), L.capacity);
    atomicStore(&control.dynamic_levels[L.d + 1u].first, start);
    atomicStore(&control.dynamic_levels[L.d + 1u].end, end);
    write_args(ARGS_DYN_NODES + L.d + 1u, end - start);
}

// Links of the new nodes of level d: their own +x, +y, +z links, and the +axis link of a
// static node just below them, which had no neighbour there before.
@compute @workgroup_size(64)
fn dyn_link(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
            @builtin(local_invocation_index) li: u32) {
    let n = range_entry(wg, nwg, li, dynamic_level_range(L.d));
    if n == INVALID {
        return;
    }
    let c = unpack3(coord[n]);
    let size = 1u << L.d;
    for (var a = 0u; a < 3u; a++) {
        var e = vec3<u32>(0u);
        e[a] = 1u;
        var link = 0u;
        if c[a] + 1u < size {
            let m = find(c + e, L.d);
            if m != INVALID {
                link = m;
            }
        }
        nbr[3u * n + a] = link;
        if c[a] > 0u {
            let m = find(c - e, L.d);
            if m != INVALID && m < D.static_nodes {
                nbr[3u * m + a] = n;
            }
        }
    }
}

// Every needed node without a brick gets one after the static bricks.
@compute @workgroup_size(64)
fn dyn_assign_bricks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                     @builtin(local_invocation_index) li: u32) {
    let i = linear_index(wg, nwg, li);
    if i >= min(atomicLoad(&control.needed_count), D.needed_capacity) {
        return;
    }
    let n = need_list[i];
    if atomicLoad(&brick_plus_one[n]) != 0u {
        return;
    }
    let b = atomicAdd(&control.brick_count, 1u);
    if b >= D.brick_capacity {
        atomicStore(&control.dynamic_overflow, BRICK_OVERFLOW);
        return;
    }
    atomicStore(&brick_plus_one[n], b + 1u);
}

// ---- Leaf sums and bricks -------------------------------------------------------------------

// Dynamic fragments add albedo, emission and normal sums into their leaf's slot, as the
// static build's leaf sums do (`svo/inject.wgsl`).
@compute @workgroup_size(64)
fn dyn_accumulate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= fragment_count() {
        return;
    }
    let frag = fragments[f];
    let v = unpack3(frag.x);
    let n = leaf_of_voxel(v);
    if n == INVALID {
        return;
    }
    let slot = atomicLoad(&state[n]) >> 2u;
    if slot == 0u {
        return;
    }
    let o = (v.x & 1u) | ((v.y & 1u) << 1u) | ((v.z & 1u) << 2u);
    let w = ((slot - 1u) * 8u + o) * SUM_WORDS;
    let terms = fragment_sum_terms(tris[frag.y]);
    for (var k = 0u; k < SUM_WORDS; k++) {
        atomicAdd(&dyn_sums[w + k], terms[k]);
    }
}

// Albedo and opacity of leaf voxel v (grid coordinates): the static and dynamic sums of its
// fragments together, averaged like `leaf_fill`.
fn voxel_albedo(v: vec3<i32>) -> vec4<f32> {
    let res = i32(1u << L.depth);
    if any(v < vec3<i32>(0)) || any(v >= vec3<i32>(res)) {
        return vec4<f32>(0.0);
    }
    let u = vec3<u32>(v);
    let n = leaf_of_voxel(u);
    if n == INVALID {
        return vec4<f32>(0.0);
    }
    let o = (u.x & 1u) | ((u.y & 1u) << 1u) | ((u.z & 1u) << 2u);
    // The sums' first four words (svo/leaf_sums.wgsl): albedo x255 and the fragment count.
    var s = vec4<u32>(0u);
    if n >= D.first_static_leaf && n < D.static_nodes {
        let w = leaf_sum_offset(static_sums[n - D.first_static_leaf], o, D.static_nodes - D.first_static_leaf);
        if w != 0xffffffffu {
            s = vec4<u32>(static_sums[w], static_sums[w + 1u], static_sums[w + 2u], static_sums[w + 3u]);
        }
    }
    let slot = atomicLoad(&state[n]) >> 2u;
    if slot != 0u {
        let w = ((slot - 1u) * 8u + o) * SUM_WORDS;
        s += vec4<u32>(atomicLoad(&dyn_sums[w]), atomicLoad(&dyn_sums[w + 1u]),
                       atomicLoad(&dyn_sums[w + 2u]), atomicLoad(&dyn_sums[w + 3u]));
    }
    let count = s.w;
    if count == 0u {
        return vec4<f32>(0.0);
    }
    let c = f32(count);
    return vec4<f32>(f32(s.x) / c / 255.0, f32(s.y) / c / 255.0, f32(s.z) / c / 255.0, 1.0);
}

// Texel t of the finished RGBA8 pool (27 words per brick); `b1` is brick + 1, 0 = none.
fn texel8(b1: u32, t: u32) -> vec4<f32> {
    if b1 == 0u {
        return vec4<f32>(0.0);
    }
    let b = b1 - 1u;
    let w = (b % L.pool_bricks) * 27u + t;
    switch b / L.pool_bricks {
        case 0u: { return unpack4x8unorm(bricks0[w]); }
        case 1u: { return unpack4x8unorm(bricks1[w]); }
        case 2u: { return unpack4x8unorm(bricks2[w]); }
        default: { return unpack4x8unorm(bricks3[w]); }
    }
}

fn store8(b1: u32, t: u32, v: vec4<f32>) {
    if b1 == 0u || b1 > D.brick_capacity {
        return;
    }
    let b = b1 - 1u;
    let w = (b % L.pool_bricks) * 27u + t;
    let p = pack4x8unorm(clamp(v, vec4<f32>(0.0), vec4<f32>(1.0)));
    switch b / L.pool_bricks {
        case 0u: { bricks0[w] = p; }
        case 1u: { bricks1[w] = p; }
        case 2u: { bricks2[w] = p; }
        default: { bricks3[w] = p; }
    }
}

// Bricks (+ 1) of the 3x3x3 nodes around c on level d (index x + 3y + 9z, c at 13).
// Entry k of the 3x3x3 block of level-d nodes around node c: the node's brick index + 1,
// 0 where there is no node.
fn block_entry(c: vec3<u32>, d: u32, k: u32) -> u32 {
    let size = i32(1u << d);
    let cc = vec3<i32>(c) + vec3<i32>(i32(k % 3u), i32((k / 3u) % 3u), i32(k / 9u)) - vec3<i32>(1);
    if all(cc >= vec3<i32>(0)) && all(cc < vec3<i32>(size)) {
        let m = find(vec3<u32>(cc), d);
        if m != INVALID {
            return atomicLoad(&brick_plus_one[m]);
        }
    }
    return 0u;
}

// Writes texel t of node (block centre) to every node sharing its lattice point, so shared
// faces stay identical even where a neighbour is not recomputed.
fn store_shared(block: array<u32, 27>, t: vec3<u32>, v: vec4<f32>) {
    for (var k = 0u; k < 27u; k++) {
        let o = vec3<i32>(i32(k % 3u), i32((k / 3u) % 3u), i32(k / 9u)) - vec3<i32>(1);
        // In the neighbour at offset o the point is at t - 2o, which must lie in 0..2.
        let local = vec3<i32>(t) - 2 * o;
        if any(local < vec3<i32>(0)) || any(local > vec3<i32>(2)) {
            continue;
        }
        store8(block[k], texel_index(vec3<u32>(local)), v);
    }
}

// Entry i of the dirty nodes of level d: this update's needed list, or (when L.range == 1)
// the previous update's, whose static nodes must return to their static values.
fn dirty_entry(i: u32) -> u32 {
    if L.range == 1u {
        let r = last_need_range(L.d);
        if r.x + i >= r.y {
            return INVALID;
        }
        let n = last_need_list[r.x + i];
        if n >= D.static_nodes {
            return INVALID;
        }
        return n;
    }
    let r = needed_range(L.d);
    let e = r.x + i;
    if e >= r.y {
        return INVALID;
    }
    return need_list[e];
}

// The packed coordinates of this workgroup's dirty node (one workgroup per node), handed to
// every lane as a uniform value; INVALID when there is none or it has no brick.
fn dirty_group_coord(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    if li == 0u {
        let n = dirty_entry(group_index(wg, nwg));
        group_word = INVALID;
        if n != INVALID && atomicLoad(&brick_plus_one[n]) != 0u {
            group_word = coord[n];
        }
    }
    return workgroupUniformLoad(&group_word);
}

var<workgroup> group_block: array<u32, 27>;
var<workgroup> group_fine: array<u32, 64>;

// Leaf bricks of dirty nodes, gathered: texel (i, j, k) = the 8 voxels touching the corner / 8.
// One workgroup per node: lane k fetches voxel k of the 4^3 around it and block entry k, then
// lane t < 27 sums texel t.
@compute @workgroup_size(64)
fn dyn_leaf_gather(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                   @builtin(local_invocation_index) li: u32) {
    let packed = dirty_group_coord(wg, nwg, li);
    if packed == INVALID {
        return;
    }
    let c = unpack3(packed);
    let base = 2 * vec3<i32>(c) - vec3<i32>(1);
    group_texels[li] = voxel_albedo(base + vec3<i32>(i32(li % 4u), i32((li / 4u) % 4u), i32(li / 16u)));
    if li < 27u {
        group_block[li] = block_entry(c, L.d, li);
    }
    workgroupBarrier();
    if li >= 27u {
        return;
    }
    let i = texel_coords(li);
    var sum = vec4<f32>(0.0);
    for (var o = 0u; o < 8u; o++) {
        // Voxel 2c + i - 1 + octant, at block index i + octant.
        let q = i + octant_offset(o);
        sum += group_texels[q.x + 4u * q.y + 16u * q.z] * 0.125;
    }
    store_shared(group_block, i, sum);
}

// Coarser bricks of dirty nodes, gathered: the [1/4 1/2 1/4] filter of the 27 finer lattice
// points around each texel, read from whichever finer node holds them (any sharer holds the
// whole value; a missing or brickless sharer means the value is zero). One workgroup per node:
// lane k finds finer node k of the 4^3 around it and block entry k, then lane t < 27 filters
// texel t.
@compute @workgroup_size(64)
fn dyn_mip_gather(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) li: u32) {
    let packed = dirty_group_coord(wg, nwg, li);
    if packed == INVALID {
        return;
    }
    let c = unpack3(packed);
    let fine = L.d + 1u;
    let fine_size = i32(1u << fine);
    // Finer nodes 2c - 1 .. 2c + 2 on every axis.
    let q = 2 * vec3<i32>(c) - vec3<i32>(1) + vec3<i32>(i32(li % 4u), i32((li / 4u) % 4u), i32(li / 16u));
    var fine_brick_plus_one = 0u;
    if all(q >= vec3<i32>(0)) && all(q < vec3<i32>(fine_size)) {
        let m = find(vec3<u32>(q), fine);
        if m != INVALID {
            fine_brick_plus_one = atomicLoad(&brick_plus_one[m]);
        }
    }
    group_fine[li] = fine_brick_plus_one;
    if li < 27u {
        group_block[li] = block_entry(c, L.d, li);
    }
    workgroupBarrier();
    if li >= 27u {
        return;
    }
    let ti = vec3<i32>(texel_coords(li));
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < 27u; k++) {
        let o = texel_coords(k);
        // Finer lattice point (global, in finer half-node units).
        let g = 4 * vec3<i32>(c) + 2 * ti + vec3<i32>(o) - vec3<i32>(1);
        if any(g < vec3<i32>(0)) || any(g > vec3<i32>(2 * fine_size)) {
            continue;
        }
        let node = min(g / 2, vec3<i32>(fine_size - 1));
        let local = vec3<u32>(g - 2 * node);
        let r = vec3<u32>(node - (2 * vec3<i32>(c) - vec3<i32>(1)));
        let w = tap_weight(o.x) * tap_weight(o.y) * tap_weight(o.z);
        sum += w * texel8(group_fine[r.x + 4u * r.y + 16u * r.z], texel_index(local));
    }
    store_shared(group_block, vec3<u32>(ti), sum);
}
