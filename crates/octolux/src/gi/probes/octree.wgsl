// The probe octree's state machine on the GPU: `ProbeOctree::frame` (octree.rs, its CPU
// specification, which a test compares word for word). Three passes per frame:
// `memory_update` (one workgroup; M2 frees, M4 collapses, M1/M3 allocate from the free lists
// by prefix sums in node order, frees return to the lists in node order), `light_select`
// (one invocation per node: the moved-geometry test, L1 leaves ask for surfels) and, after
// the surfels are placed and counted, `light_decide` (the split/free rule).

import octolux::gi::probes::octree_tree::{octree_cube, octree_meta};
import octolux::gi::probes::tree_bindings::{O, tree};
import octolux::gpu::work::count_work;
import octolux::gi::probes::octree_params::{FREE_INFO, INTEGRATE_LANES, LIVE_COUNT, LIVE_FIRST, ProbeInfo};
import octolux::gpu::dispatch::{dispatch_covering, DispatchArgs};

// The parameters and the tree (bindings 0, 1) are octree_tree_write.wgsl's.
// Per probe slot: position and depth, or (0, 0, 0, -1) when free.
@group(0) @binding(2) var<storage, read_write> probe_info: array<ProbeInfo>;
// Per probe slot: 1 = place its surfels this frame.
@group(0) @binding(3) var<storage, read_write> place_flags: array<u32>;
// Per probe slot: surfels inside its cube.
@group(0) @binding(4) var<storage, read> hits: array<u32>;
// Free-list tops (probes, clusters), the free lists and per-node marks, see `state_*`.
@group(0) @binding(5) var<storage, read_write> state: array<u32>;
// The leaf ring: word k x (tree words) + node = state code queued in segment k.
@group(0) @binding(6) var<storage, read_write> ring: array<atomic<u32>>;
// Moved boxes: (lo, 0), (hi, 0) each.
@group(0) @binding(7) var<storage, read> boxes: array<vec4<f32>>;
// The live probes, listed by the memory update: word 0 their count, then their slots in
// increasing order. The shared probe passes run over this list, not over every slot.
@group(0) @binding(8) var<storage, read_write> live: array<u32>;
// Their indirect dispatches, workgroups of 64 (x, y, z each): one invocation per surfel
// (place, light), per moment texel, per probe (integrate). `GpuOctree::live_args`.
@group(0) @binding(9) var<storage, read_write> live_args: array<DispatchArgs, 3>;
// Slots of `live_args` (`LIVE_SURFELS`... in gi/probes/octree_gi.rs).
const LIVE_SURFELS: u32 = 0u;
const LIVE_MOMENT_LANES: u32 = 1u;
const LIVE_PROBES: u32 = 2u;

// State codes (`State::code`); a push keeps the higher code.
const L3: u32 = 1u;
const L2: u32 = 2u;
const L1: u32 = 3u;
const L0: u32 = 4u;
const M4: u32 = 5u;
const M3: u32 = 6u;
const M2: u32 = 7u;
const M1: u32 = 8u;
const M0: u32 = 9u;

// `freed` marks: a probe slot p is p + 1, a cluster has this bit set.
const FREED_CLUSTER: u32 = 0x80000000u;
const THREADS: u32 = 256u;

// Layout of `state` (`GpuOctree::state_words`).
// The state buffer's head (`STATE_*` in octree_gi.rs): the free lists' tops, then 2 spare
// words.
const STATE_PROBE_TOP: u32 = 0u;
const STATE_CLUSTER_TOP: u32 = 1u;
const STATE_HEAD: u32 = 4u;
fn free_probe_at(k: u32) -> u32 {
    return STATE_HEAD + k;
}
fn free_cluster_at(k: u32) -> u32 {
    return STATE_HEAD + O.probe_slots + k;
}
fn no_split_at(i: u32) -> u32 {
    return STATE_HEAD + O.probe_slots + O.clusters + i;
}
fn request_at(i: u32) -> u32 {
    return no_split_at(i) + O.tree_words;
}
fn freed_at(i: u32) -> u32 {
    return no_split_at(i) + 2u * O.tree_words;
}

fn push(offset: u32, node: u32, code: u32) {
    let k = (O.ring_origin + offset) % 3u;
    atomicMax(&ring[k * O.tree_words + node], code);
}

fn parent_of(i: u32) -> u32 {
    return u32(~tree[octree_meta(i)]);
}

fn set_probe(node: u32, p: u32) {
    let c = octree_cube(node);
    probe_info[p] = ProbeInfo(c.lo + vec3<f32>(c.size * 0.5), f32(c.depth));
    tree[node] = ~i32(p);
}

// Work counts of a memory update thread (`MEMORY_WORK` in octree_gi.rs): probes allocated
// and freed, kept only by a counting shader and added at the thread's end.
@if(count_work) var<private> memory_work: vec2<u32>;

@if(count_work) fn note_memory(allocated: u32, freed: u32) {
    memory_work += vec2<u32>(allocated, freed);
}

@if(!count_work) fn note_memory(allocated: u32, freed: u32) {}

@if(count_work) fn count_memory_work() {
    count_work(2u, memory_work.x);
    count_work(3u, memory_work.y);
}

@if(!count_work) fn count_memory_work() {}

var<workgroup> scan: array<vec2<u32>, THREADS>;
var<workgroup> scan_total: vec2<u32>;
var<workgroup> used_clusters: atomic<u32>;
var<workgroup> used_probes: atomic<u32>;

// Exclusive prefix sums of the threads' v in thread order, and their total.
fn exclusive_scan(t: u32, v: vec2<u32>) -> vec4<u32> {
    scan[t] = v;
    workgroupBarrier();
    if t == 0u {
        var acc = vec2<u32>(0u);
        for (var k = 0u; k < THREADS; k++) {
            let x = scan[k];
            scan[k] = acc;
            acc += x;
        }
        scan_total = acc;
    }
    workgroupBarrier();
    let r = vec4<u32>(scan[t], scan_total);
    workgroupBarrier();
    return r;
}

// What node i asks to allocate: (clusters, probes).
fn demand(i: u32) -> vec2<u32> {
    let r = state[request_at(i)];
    return select(select(vec2<u32>(0u), vec2<u32>(0u, 1u), r == 1u), vec2<u32>(1u, 8u), r == 2u);
}

@compute @workgroup_size(256)
fn memory_update(@builtin(local_invocation_index) t: u32) {
    let len = O.tree_words;
    let per = (len + THREADS - 1u) / THREADS;
    let start = min(t * per, len);
    let end = min(start + per, len);
    let seg = O.ring_origin * len;
    if t == 0u {
        atomicStore(&used_clusters, 0u);
        atomicStore(&used_probes, 0u);
    }
    // 1. M2: free the probe; the freed leaf keeps watching (L3).
    for (var i = start; i < end; i++) {
        state[freed_at(i)] = 0u;
        if atomicLoad(&ring[seg + i]) != M2 {
            continue;
        }
        let v = tree[i];
        if v < 0 {
            state[freed_at(i)] = u32(~v) + 1u;
            probe_info[u32(~v)] = FREE_INFO;
            tree[i] = 0;
        }
        if i != 0u {
            push(2u, parent_of(i), M4);
        }
        push(1u, i, L3);
    }
    storageBarrier();
    workgroupBarrier();
    // 2. M4: decide on the tree after step 1 which clusters to free ...
    for (var i = start; i < end; i++) {
        if atomicLoad(&ring[seg + i]) != M4 {
            continue;
        }
        let v = tree[i];
        if v <= 0 {
            continue;
        }
        var empty = true;
        for (var k = 1u; k <= 8u; k++) {
            empty = empty && tree[u32(v) + k] == 0;
        }
        if empty {
            state[freed_at(i)] = FREED_CLUSTER | u32(v);
        }
    }
    storageBarrier();
    workgroupBarrier();
    // ... then free them; the collapsed parent asks for a probe and may not split again.
    for (var i = start; i < end; i++) {
        let f = state[freed_at(i)];
        if (f & FREED_CLUSTER) == 0u {
            continue;
        }
        let cluster = f & ~FREED_CLUSTER;
        tree[cluster] = 0;
        tree[i] = 0;
        for (var k = 1u; k <= 8u; k++) {
            push(1u, cluster + k, L0);
        }
        if i != 0u {
            push(2u, parent_of(i), M4);
        }
        state[no_split_at(i)] = 1u;
        push(2u, i, M1);
    }
    storageBarrier();
    workgroupBarrier();
    // 3. M1 and M3 allocate in node order from the free lists as they were before this
    // update: a request succeeds when it and all before it fit.
    var mine = vec2<u32>(0u);
    for (var i = start; i < end; i++) {
        let code = atomicLoad(&ring[seg + i]);
        let v = tree[i];
        var r = 0u;
        if code == M1 && v == 0 && (i == 0u || tree[octree_meta(i)] != 0) {
            r = 1u;
        } else if code == M3 && v < 0 {
            r = 2u;
        }
        state[request_at(i)] = r;
        mine += demand(i);
    }
    let probe_top = state[STATE_PROBE_TOP];
    let cluster_top = state[STATE_CLUSTER_TOP];
    let available = vec2<u32>(cluster_top, probe_top);
    var before = exclusive_scan(t, mine).xy;
    for (var i = start; i < end; i++) {
        let d = demand(i);
        if all(d == vec2<u32>(0u)) {
            continue;
        }
        let after = before + d;
        let r = state[request_at(i)];
        if any(after > available) {
            push(1u, i, select(L2, L3, r == 1u));
            before = after;
            continue;
        }
        note_memory(d.y, 0u);
        if r == 1u {
            set_probe(i, state[free_probe_at(probe_top - 1u - before.y)]);
            push(1u, i, L1);
        } else {
            let own = u32(~tree[i]);
            let cluster = state[free_cluster_at(cluster_top - 1u - before.x)];
            tree[cluster] = ~i32(i);
            tree[i] = i32(cluster);
            for (var k = 1u; k <= 8u; k++) {
                let child = cluster + k;
                state[no_split_at(child)] = 0u;
                set_probe(child, state[free_probe_at(probe_top - before.y - k)]);
                push(1u, child, L1);
            }
            probe_info[own] = FREE_INFO;
            state[freed_at(i)] = own + 1u;
        }
        atomicMax(&used_clusters, after.x);
        atomicMax(&used_probes, after.y);
        before = after;
    }
    storageBarrier();
    workgroupBarrier();
    // 4. What this update freed goes back on the free lists, in node order.
    mine = vec2<u32>(0u);
    for (var i = start; i < end; i++) {
        let f = state[freed_at(i)];
        mine += select(vec2<u32>(0u, u32(f != 0u)), vec2<u32>(1u, 0u), (f & FREED_CLUSTER) != 0u);
    }
    let probes_left = probe_top - atomicLoad(&used_probes);
    let clusters_left = cluster_top - atomicLoad(&used_clusters);
    let scanned = exclusive_scan(t, mine);
    before = scanned.xy;
    for (var i = start; i < end; i++) {
        let f = state[freed_at(i)];
        if (f & FREED_CLUSTER) != 0u {
            state[free_cluster_at(clusters_left + before.x)] = f & ~FREED_CLUSTER;
            before.x += 1u;
        } else if f != 0u {
            state[free_probe_at(probes_left + before.y)] = f - 1u;
            before.y += 1u;
            note_memory(0u, 1u);
        }
        state[freed_at(i)] = 0u;
        state[request_at(i)] = 0u;
        atomicStore(&ring[seg + i], 0u);
    }
    if t == 0u {
        state[STATE_PROBE_TOP] = probes_left + scanned.w;
        state[STATE_CLUSTER_TOP] = clusters_left + scanned.z;
    }
    storageBarrier();
    workgroupBarrier();
    list_live_probes(t);
    count_memory_work();
}

// Lists the live probe slots in increasing order (each thread a run of consecutive slots)
// and sets the shared passes' dispatches from their count.
fn list_live_probes(t: u32) {
    let capacity = O.probe_slots;
    let per = (capacity + THREADS - 1u) / THREADS;
    let start = min(t * per, capacity);
    let end = min(start + per, capacity);
    var mine = 0u;
    for (var p = start; p < end; p++) {
        mine += u32(probe_info[p].depth >= 0.0);
    }
    let scanned = exclusive_scan(t, vec2<u32>(mine, 0u));
    var at = scanned.x;
    for (var p = start; p < end; p++) {
        if probe_info[p].depth >= 0.0 {
            live[LIVE_FIRST + at] = p;
            at += 1u;
        }
    }
    if t == 0u {
        let count = scanned.z;
        live[LIVE_COUNT] = count;
        // Work counts: the live probes the shared passes run over.
        count_work(1u, count);
        set_args(LIVE_SURFELS, count * O.surfels_per_probe);
        set_args(LIVE_MOMENT_LANES, count * O.moment_lanes);
        set_args(LIVE_PROBES, count * INTEGRATE_LANES);
    }
}

// Workgroups of 64 for n invocations (at least one) in `live_args[slot]`.
fn set_args(slot: u32, n: u32) {
    live_args[slot] = dispatch_covering(max((n + 63u) / 64u, 1u));
}

// The moved-geometry test and the L states that need no hit count; L1 leaves with a probe
// ask for their surfels (`place_flags`) and wait for `light_decide`.
@compute @workgroup_size(64)
fn light_select(@builtin(global_invocation_id) id: vec3<u32>) {
    // At most 37449 nodes (depth 5): one row of workgroups.
    let i = id.x;
    if i >= O.tree_words {
        return;
    }
    let at = ((O.ring_origin + 1u) % 3u) * O.tree_words + i;
    var code = atomicLoad(&ring[at]);
    if code == 0u {
        return;
    }
    // Work counts (`SELECT_WORK` in octree_gi.rs): queued nodes, box tests, placements asked.
    count_work(1u, 1u);
    atomicStore(&ring[at], 0u);
    let v = tree[i];
    if code == L0 || v > 0 {
        return;
    }
    let c = octree_cube(i);
    let hi = c.lo + vec3<f32>(c.size);
    var tests = O.moved_boxes;
    for (var k = 0u; k < O.moved_boxes; k++) {
        if all(c.lo <= boxes[2u * k + 1u].xyz) && all(boxes[2u * k].xyz <= hi) {
            tests = k + 1u;
            state[no_split_at(i)] = 0u;
            if v == 0 {
                count_work(2u, tests);
                push(2u, i, M1);
                return;
            }
            code = L1;
            break;
        }
    }
    count_work(2u, tests);
    if code == L1 && v < 0 {
        count_work(3u, 1u);
        state[request_at(i)] = 1u;
        place_flags[u32(~v)] = 1u;
        return;
    }
    push(0u, i, select(L3, L2, v < 0));
}

// The split/free rule for the leaves `light_select` left waiting, from their probes' hits.
@compute @workgroup_size(64)
fn light_decide(@builtin(global_invocation_id) id: vec3<u32>) {
    // At most 37449 nodes (depth 5): one row of workgroups.
    let i = id.x;
    if i >= O.tree_words || state[request_at(i)] == 0u {
        return;
    }
    // Work counts (`DECIDE_WORK` in octree_gi.rs): leaves decided.
    count_work(1u, 1u);
    state[request_at(i)] = 0u;
    let p = u32(~tree[i]);
    place_flags[p] = 0u;
    let h = hits[p];
    let depth = u32(probe_info[p].depth);
    // `OctreeRule::decide`: levels above the minimum depth (O.min_depth) always split, leaves
    // down to it keep their probes.
    let min_depth = O.min_depth;
    let may_split = depth < O.max_depth && state[no_split_at(i)] == 0u;
    let kept = min_depth > 0u && depth <= min_depth;
    if may_split && depth < min_depth {
        push(2u, i, M3);
        if i != 0u {
            push(2u, parent_of(i), M0);
        }
    } else if h < O.free_below && !kept {
        push(2u, i, M2);
    } else if may_split && h >= O.split_from {
        push(2u, i, M3);
        if i != 0u {
            push(2u, parent_of(i), M0);
        }
    } else {
        push(0u, i, L2);
    }
}
