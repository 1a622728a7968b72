// Sparse voxel octree, built level by level. Level d has 2^d nodes per axis; the finest level
// (depth - 1) holds nodes of 2x2x2 voxels. Nodes are struct-of-arrays: `child` (index of the
// first of 8 contiguous children, 0 = none; the root is never a child) and `nbr` (+x, +y, +z
// neighbour on the same level, 0 = none). After the structure phase `brick_plus_one` holds
// each node's brick index + 1 (0 = no brick: only needed nodes get one). A brick is 27
// corner-sampled RGBA texels (premultiplied albedo, opacity) as f16 pairs, 54 words. `coord`
// is build scratch.

import octolux::voxel::voxelize::overlap::linear_index;
import octolux::voxel::svo::control::SvoControl;
import octolux::gpu::dispatch::{dispatch_covering, DispatchArgs};
import octolux::voxel::svo::common::{brick_of, bw_index, child, find, brick_plus_one, fragments, INVALID, L, NEEDED, OCCUPIED, octant_offset, pack3, unpack3};

@group(0) @binding(4) var<storage, read_write> nbr: array<u32>;
@group(0) @binding(5) var<storage, read_write> coord: array<u32>;
// Counters and level ranges (svo/control.wgsl).
@group(0) @binding(7) var<storage, read_write> control: SvoControl;
@group(0) @binding(8) var<storage, read_write> bricks0: array<u32>;
@group(0) @binding(9) var<storage, read_write> bricks1: array<u32>;
@group(0) @binding(10) var<storage, read_write> bricks2: array<u32>;
@group(0) @binding(11) var<storage, read_write> bricks3: array<u32>;
// Indirect dispatch arguments, one per slot (bound only by finish_level).
@group(1) @binding(0) var<storage, read_write> args: array<DispatchArgs>;

// Entry i of level L.d's node range (its static nodes or, with L.range == 1, its dynamic
// ones), INVALID past the range's end.
fn level_entry(i: u32) -> u32 {
    let r = level_range(L.d, L.range);
    let n = r.x + i;
    if n >= r.y {
        return INVALID;
    }
    return n;
}

// Node range [x, y) of level d: its static nodes (range 0) or its dynamic ones (range 1, empty
// without a dynamic part).
fn level_range(d: u32, range: u32) -> vec2<u32> {
    if range == 1u {
        return dynamic_level_range(d);
    }
    return vec2<u32>(atomicLoad(&control.levels[d].first), atomicLoad(&control.levels[d].end));
}

// Node range [x, y) of level d's dynamic nodes.
fn dynamic_level_range(d: u32) -> vec2<u32> {
    return vec2<u32>(atomicLoad(&control.dynamic_levels[d].first),
                     atomicLoad(&control.dynamic_levels[d].end));
}

// Node of this invocation on level L.d (one node per invocation).
fn level_node(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    return level_entry(linear_index(wg, nwg, li));
}

// Index of this workgroup in a dispatch of one workgroup per node (slots + NODE_ARGS).
fn group_index(wg: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wg.y * nwg.x + wg.x;
}

// Indirect arguments: slot s holds one invocation per entry (groups of 64), slot
// s + NODE_ARGS one workgroup per entry, for kernels that spread a node's 27 texels over the
// lanes of a workgroup instead of computing them one after another in one invocation (a
// latency chain of hundreds of dependent reads on a GPU).
const NODE_ARGS: u32 = 96u;

fn write_args(slot: u32, count: u32) {
    args[slot] = dispatch_covering((count + 63u) / 64u);
    args[slot + NODE_ARGS] = dispatch_covering(count);
}

// Shared by the kernels that give a workgroup one node: the node's brick (or other word)
// handed from lane 0 to the workgroup as a uniform value, and staging for texels.
var<workgroup> group_word: u32;
var<workgroup> group_first: u32;
var<workgroup> group_texels: array<vec4<f32>, 216>;
var<workgroup> group_children: array<u32, 8>;

// Brick words are plain loads and stores: atomics (which only the leaf sums need, in
// `svo/accumulate.wgsl`) bypass the caches and were the limit of every brick pass on a GPU.
fn bw_load(b: u32, i: u32) -> u32 {
    let w = bw_index(b, i);
    switch b / L.pool_bricks {
        case 0u: { return bricks0[w]; }
        case 1u: { return bricks1[w]; }
        case 2u: { return bricks2[w]; }
        default: { return bricks3[w]; }
    }
}

fn bw_store(b: u32, i: u32, v: u32) {
    let w = bw_index(b, i);
    switch b / L.pool_bricks {
        case 0u: { bricks0[w] = v; }
        case 1u: { bricks1[w] = v; }
        case 2u: { bricks2[w] = v; }
        default: { bricks3[w] = v; }
    }
}

fn read_texel(brick: u32, t: u32) -> vec4<f32> {
    if brick == INVALID {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(unpack2x16float(bw_load(brick, 2u * t)), unpack2x16float(bw_load(brick, 2u * t + 1u)));
}

fn write_texel(brick: u32, t: u32, v: vec4<f32>) {
    bw_store(brick, 2u * t, pack2x16float(v.xy));
    bw_store(brick, 2u * t + 1u, pack2x16float(v.zw));
}

// With the feature `facing` (the radiance mip of an octree that keeps its radiance's facing,
// `SvoBuilder::with_facing`), the mip and transfer kernels filter the facing pool with the
// same taps as the radiance, in the same dispatches; without it these are no-ops.
@if(facing) @group(0) @binding(12) var<storage, read_write> facing0: array<u32>;
@if(facing) @group(0) @binding(13) var<storage, read_write> facing1: array<u32>;
@if(facing) @group(0) @binding(14) var<storage, read_write> facing2: array<u32>;
@if(facing) @group(0) @binding(15) var<storage, read_write> facing3: array<u32>;
@if(facing) var<workgroup> group_facing: array<vec4<f32>, 216>;

@if(facing) fn read_facing(brick: u32, t: u32) -> vec4<f32> {
    if brick == INVALID {
        return vec4<f32>(0.0);
    }
    let w = bw_index(brick, 2u * t);
    var lo = 0u;
    var hi = 0u;
    switch brick / L.pool_bricks {
        case 0u: { lo = facing0[w]; hi = facing0[w + 1u]; }
        case 1u: { lo = facing1[w]; hi = facing1[w + 1u]; }
        case 2u: { lo = facing2[w]; hi = facing2[w + 1u]; }
        default: { lo = facing3[w]; hi = facing3[w + 1u]; }
    }
    return vec4<f32>(unpack2x16float(lo), unpack2x16float(hi));
}

@if(!facing) fn read_facing(brick: u32, t: u32) -> vec4<f32> {
    return vec4<f32>(0.0);
}

@if(facing) fn write_facing(brick: u32, t: u32, v: vec4<f32>) {
    let w = bw_index(brick, 2u * t);
    let lo = pack2x16float(v.xy);
    let hi = pack2x16float(v.zw);
    switch brick / L.pool_bricks {
        case 0u: { facing0[w] = lo; facing0[w + 1u] = hi; }
        case 1u: { facing1[w] = lo; facing1[w + 1u] = hi; }
        case 2u: { facing2[w] = lo; facing2[w + 1u] = hi; }
        default: { facing3[w] = lo; facing3[w + 1u] = hi; }
    }
}

@if(!facing) fn write_facing(brick: u32, t: u32, v: vec4<f32>) {}

// The mip's staging of the children's facing texels (`group_facing`).
@if(facing) fn stage_facing(i: u32, brick: u32) {
    group_facing[i] = read_facing(brick, i % 27u);
}

@if(!facing) fn stage_facing(i: u32, brick: u32) {}

@if(facing) fn staged_facing(i: u32) -> vec4<f32> {
    return group_facing[i];
}

@if(!facing) fn staged_facing(i: u32) -> vec4<f32> {
    return vec4<f32>(0.0);
}

fn texel_index(i: vec3<u32>) -> u32 {
    return i.x + 3u * i.y + 9u * i.z;
}

// Texel t's coordinates in its brick (the inverse of `texel_index`); also the offset k of a
// 3x3x3 stencil.
fn texel_coords(t: u32) -> vec3<u32> {
    return vec3<u32>(t % 3u, (t / 3u) % 3u, t / 9u);
}

@compute @workgroup_size(64)
fn flag_occupied(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= L.fragments {
        return;
    }
    let v = unpack3(fragments[f].x);
    let n = find(v >> vec3<u32>(L.depth - L.d), L.d);
    // Read first: on the coarse levels thousands of fragments share a node, and an atomic
    // read-modify-write each would serialise them on its word.
    if n != INVALID && (atomicLoad(&brick_plus_one[n]) & OCCUPIED) == 0u {
        atomicOr(&brick_plus_one[n], OCCUPIED);
    }
}

// Neighbour links of every node of the level, and the 26-neighbourhood of occupied nodes.
@compute @workgroup_size(64)
fn flag_needed(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let n = level_node(wg, nwg, li);
    if n == INVALID {
        return;
    }
    let c = unpack3(coord[n]);
    let size = 1u << L.d;
    for (var a = 0u; a < 3u; a++) {
        var e = vec3<u32>(0u);
        e[a] = 1u;
        let cc = c + e;
        var link = 0u;
        if cc[a] < size {
            let m = find(cc, L.d);
            if m != INVALID {
                link = m;
            }
        }
        nbr[3u * n + a] = link;
    }
    if (atomicLoad(&brick_plus_one[n]) & OCCUPIED) == 0u {
        return;
    }
    for (var k = 0u; k < 27u; k++) {
        let o = vec3<i32>(i32(k % 3u), i32((k / 3u) % 3u), i32(k / 9u)) - vec3<i32>(1);
        let cc = vec3<i32>(c) + o;
        if any(cc < vec3<i32>(0)) || any(cc >= vec3<i32>(i32(size))) {
            continue;
        }
        let m = find(vec3<u32>(cc), L.d);
        if m != INVALID && (atomicLoad(&brick_plus_one[m]) & NEEDED) == 0u {
            atomicOr(&brick_plus_one[m], NEEDED);
        }
    }
}

@compute @workgroup_size(64)
fn subdivide(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) li: u32) {
    let n = level_node(wg, nwg, li);
    if n == INVALID || (atomicLoad(&brick_plus_one[n]) & NEEDED) == 0u {
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

// Records the node range of level d + 1 and its indirect dispatch size.
@compute @workgroup_size(1)
fn finish_level() {
    let start = atomicLoad(&control.levels[L.d].end);
    let end = min(atomicLoad(&control.node_count), L.capacity);
    atomicStore(&control.levels[L.d + 1u].first, start);
    atomicStore(&control.levels[L.d + 1u].end, end);
    write_args(L.d + 1u, end - start);
}

// Bit n % 32 of word n / 32 of the occupied-node bits: node n's cell holds a voxel of the
// static geometry. The visibility walk (`svo/walk.wgsl`) skips the other nodes' cells whole,
// although those next to an occupied node are subdivided (for the bricks' lattice,
// `flag_needed`). The structure phase has no bricks yet and binds the bits as pool 0.
// One invocation per word of 32 nodes (each word has one writer: no atomics); runs before
// `assign_bricks` turns the flags into brick indices.
@compute @workgroup_size(64)
fn mark_occupied(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let w = linear_index(wg, nwg, li);
    let nodes = min(atomicLoad(&control.node_count), L.capacity);
    if w * 32u >= nodes {
        return;
    }
    var bits = 0u;
    for (var i = 0u; i < 32u; i++) {
        let n = w * 32u + i;
        if n < nodes && (atomicLoad(&brick_plus_one[n]) & OCCUPIED) != 0u {
            bits |= 1u << i;
        }
    }
    bricks0[w] = bits;
}

// Gives every needed node a brick (the others have an all-zero lattice and need none); the
// node's flags become its brick index + 1.
@compute @workgroup_size(64)
fn assign_bricks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let n = linear_index(wg, nwg, li);
    if n >= min(atomicLoad(&control.node_count), L.capacity) {
        return;
    }
    var brick = 0u;
    if (atomicLoad(&brick_plus_one[n]) & NEEDED) != 0u {
        brick = atomicAdd(&control.brick_count, 1u) + 1u;
    }
    atomicStore(&brick_plus_one[n], brick);
}

// Leaf bricks: texel (i, j, k) sits on a voxel corner and holds this node's share of the box
// filter there, the sum of its touching voxels / 8; the neighbour transfer adds the shares of
// the neighbouring nodes.
// One workgroup per node: lanes 0..7 average the voxels, lanes 0..26 write one texel each.
@compute @workgroup_size(64)
fn leaf_fill(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) li: u32) {
    if li == 0u {
        let n = level_entry(group_index(wg, nwg));
        group_word = INVALID;
        if n != INVALID {
            group_word = brick_of(n);
        }
    }
    let b = workgroupUniformLoad(&group_word);
    if b == INVALID {
        return;
    }
    if li < 8u {
        let w = li * 4u;
        let count = bw_load(b, w + 3u);
        var voxel = vec4<f32>(0.0);
        if count != 0u {
            let c = f32(count);
            voxel = vec4<f32>(f32(bw_load(b, w)) / c / 255.0,
                              f32(bw_load(b, w + 1u)) / c / 255.0,
                              f32(bw_load(b, w + 2u)) / c / 255.0, 1.0);
        }
        group_texels[li] = voxel;
    }
    // Every sum is read before any texel overwrites it.
    workgroupBarrier();
    if li >= 27u {
        return;
    }
    let i = texel_coords(li);
    var sum = vec4<f32>(0.0);
    for (var o = 0u; o < 8u; o++) {
        let a = octant_offset(o);
        if all(i >= a) && all(i - a <= vec3<u32>(1u)) {
            sum += group_texels[o] * 0.125;
        }
    }
    write_texel(b, li, sum);
}

// Neighbour transfer along one axis: the face shared by a node and its + neighbour gets the
// sum of both partial values, written to both bricks.
// One node per invocation (dispatched in groups of 64 per level entry, `Dispatch::Indirect`):
// its 18 face texels are all read before any is written, so the loads are in flight together
// rather than a chain. (One 16-lane workgroup per node, a lane per texel, left most of a
// GPU's lanes idle: the leaf level's three transfers took a third of the radiance mip.) Each
// pair's texels are its own within one axis: n's + face and m's - face.
fn transfer(wg: vec3<u32>, nwg: vec3<u32>, li: u32, axis: u32) {
    let n = level_node(wg, nwg, li);
    if n != INVALID {
        transfer_pair(n, axis);
    }
}

// Node n and its + neighbour along `axis`.
fn transfer_pair(n: u32, axis: u32) {
    let m = nbr[3u * n + axis];
    // A node without a brick has an all-zero lattice: nothing to add or to receive.
    if m == 0u {
        return;
    }
    let bn = brick_of(n);
    let bm = brick_of(m);
    if bn == INVALID || bm == INVALID {
        return;
    }
    var sums: array<vec4<f32>, 9>;
    var facing: array<vec4<f32>, 9>;
    for (var k = 0u; k < 9u; k++) {
        let t = face_texels(axis, k);
        sums[k] = read_texel(bn, t.x) + read_texel(bm, t.y);
        facing[k] = read_facing(bn, t.x) + read_facing(bm, t.y);
    }
    for (var k = 0u; k < 9u; k++) {
        let t = face_texels(axis, k);
        write_texel(bn, t.x, sums[k]);
        write_texel(bm, t.y, sums[k]);
        write_facing(bn, t.x, facing[k]);
        write_facing(bm, t.y, facing[k]);
    }
}

// Texel k of the face a node shares with its + neighbour along `axis`: its index in the
// node's brick (x, on the + face) and in the neighbour's (y, on the - face).
fn face_texels(axis: u32, k: u32) -> vec2<u32> {
    var hi = vec3<u32>(0u);
    var lo = vec3<u32>(0u);
    hi[axis] = 2u;
    hi[(axis + 1u) % 3u] = k % 3u;
    hi[(axis + 2u) % 3u] = k / 3u;
    lo[(axis + 1u) % 3u] = k % 3u;
    lo[(axis + 2u) % 3u] = k / 3u;
    return vec2<u32>(texel_index(hi), texel_index(lo));
}

@compute @workgroup_size(64)
fn transfer_x(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    transfer(wg, nwg, li, 0u);
}

@compute @workgroup_size(64)
fn transfer_y(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    transfer(wg, nwg, li, 1u);
}

@compute @workgroup_size(64)
fn transfer_z(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    transfer(wg, nwg, li, 2u);
}

fn tap_weight(o: u32) -> f32 {
    return select(0.25, 0.5, o == 1u);
}

// Mipmap: each coarse texel is the separable [1/4 1/2 1/4] filter of the 27 finer texels
// around it, read from this node's children. A finer texel on this node's boundary is shared
// with the neighbour node, which adds the same texel when the coarse texel is shared too: its
// weight is divided by the number of nodes sharing it (inside the grid), and the neighbour transfer that follows
// sums the shares.
struct MipTap {
    // Index of the finer texel among the 8 children's 216 (child octant * 27 + texel).
    texel: u32,
    // 0: the tap lies outside the node.
    weight: f32,
}

// Tap k (0..26) of coarse texel c of the node at coordinates nc on a level of `size` nodes
// per axis. `mip` and `mip_coarse` both sum the taps through this, in the same order.
fn mip_tap(c: vec3<u32>, k: u32, nc: vec3<u32>, size: u32) -> MipTap {
    let o = texel_coords(k);
    let f = vec3<i32>(2u * c + o) - vec3<i32>(1);
    if any(f < vec3<i32>(0)) || any(f > vec3<i32>(4)) {
        return MipTap(0u, 0.0);
    }
    let a = min(vec3<u32>(f) / 2u, vec3<u32>(1u));
    let local = vec3<u32>(f) - 2u * a;
    var w = tap_weight(o.x) * tap_weight(o.y) * tap_weight(o.z);
    for (var ax = 0u; ax < 3u; ax++) {
        // Shared only where a neighbour node exists inside the grid.
        let inner = (c[ax] == 0u && nc[ax] > 0u) || (c[ax] == 2u && nc[ax] + 1u < size);
        if inner && o[ax] == 1u {
            w *= 0.5;
        }
    }
    let ch = a.x + 2u * a.y + 4u * a.z;
    return MipTap(ch * 27u + texel_index(local), w);
}

// One workgroup per node: the 8 children's bricks are staged in workgroup memory, then lane
// t < 27 filters texel t.
@compute @workgroup_size(64)
fn mip(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
       @builtin(local_invocation_index) li: u32) {
    if li == 0u {
        let n = level_entry(group_index(wg, nwg));
        group_word = INVALID;
        if n != INVALID {
            let first = child[n];
            group_first = first;
            if first != 0u {
                group_word = brick_of(n);
            }
        }
    }
    let bn = workgroupUniformLoad(&group_word);
    if bn == INVALID {
        return;
    }
    let first = group_first;
    if li < 8u {
        group_children[li] = brick_of(first + li);
    }
    workgroupBarrier();
    for (var i = li; i < 216u; i += 64u) {
        group_texels[i] = read_texel(group_children[i / 27u], i % 27u);
        stage_facing(i, group_children[i / 27u]);
    }
    workgroupBarrier();
    if li >= 27u {
        return;
    }
    let n = level_entry(group_index(wg, nwg));
    let nc = unpack3(coord[n]);
    let c = texel_coords(li);
    var sum = vec4<f32>(0.0);
    var facing = vec4<f32>(0.0);
    for (var k = 0u; k < 27u; k++) {
        let tap = mip_tap(c, k, nc, 1u << L.d);
        if tap.weight != 0.0 {
            sum += tap.weight * group_texels[tap.texel];
            facing += tap.weight * staged_facing(tap.texel);
        }
    }
    write_texel(bn, li, sum);
    write_facing(bn, li, facing);
}

// The coarsest levels' mip and neighbour transfers in one dispatch of one workgroup: levels
// L.d down to 0 (level d has at most 8^d nodes), each one's static and dynamic nodes. As
// separate dispatches, four per level, each waited on a chain of dependent loads for a few
// dozen nodes. The workgroup's lanes take the items of a step (a texel of a node for the mip,
// a node for a transfer) in turn; a storage barrier separates the steps. Each texel sums the
// same taps in the same order as `mip`: the bricks are the same.
const COARSE_LANES: u32 = 256u;

@compute @workgroup_size(256)
fn mip_coarse(@builtin(local_invocation_index) li: u32) {
    for (var step = 0u; step <= L.d; step++) {
        let d = L.d - step;
        for (var range = 0u; range < 2u; range++) {
            let r = level_range(d, range);
            for (var i = li; i < 27u * (r.y - r.x); i += COARSE_LANES) {
                mip_texel(r.x + i / 27u, i % 27u, d);
            }
        }
        storageBarrier();
        for (var axis = 0u; axis < 3u; axis++) {
            for (var range = 0u; range < 2u; range++) {
                let r = level_range(d, range);
                for (var n = r.x + li; n < r.y; n += COARSE_LANES) {
                    transfer_pair(n, axis);
                }
            }
            storageBarrier();
        }
    }
}

// Texel t of node n of level d, filtered from its children (as `mip`, without the staging).
fn mip_texel(n: u32, t: u32, d: u32) {
    let first = child[n];
    let bn = brick_of(n);
    if first == 0u || bn == INVALID {
        return;
    }
    let nc = unpack3(coord[n]);
    let c = texel_coords(t);
    var sum = vec4<f32>(0.0);
    var facing = vec4<f32>(0.0);
    for (var k = 0u; k < 27u; k++) {
        let tap = mip_tap(c, k, nc, 1u << d);
        if tap.weight != 0.0 {
            let b = brick_of(first + tap.texel / 27u);
            sum += tap.weight * read_texel(b, tap.texel % 27u);
            facing += tap.weight * read_facing(b, tap.texel % 27u);
        }
    }
    write_texel(bn, t, sum);
    write_facing(bn, t, facing);
}
