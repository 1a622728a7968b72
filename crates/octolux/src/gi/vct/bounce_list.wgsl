// The voxels a bounce gather visits this frame, listed (`bounce_list.rs`), for the octree's
// and the clipmap's bounce. Most slots of a structure hold no voxel that gathers (a tenth of a
// clipmap's in Crytek Sponza, a seventh of the octree's leaf voxel slots), so a gather with
// one invocation per slot leaves most lanes of a GPU's SIMD group idle while one marches its
// cones. A bounce's `bounce_list` entry point calls `list_slot` for every slot (compacted per
// workgroup: one global atomic per workgroup, not per voxel), `bounce_args` turns the count
// into an indirect dispatch, and the gather takes one listed slot per item, its cones spread
// over the item's lanes (`cone_lanes.wgsl`). The list's order varies between runs; no voxel's
// gather depends on it.

// Every slot's bounce irradiance (RGB as half floats in two words), written by the gathers.

import octolux::gi::vct::cone_set::CONE_LANES;
import octolux::gpu::dispatch::{dispatch_covering, DispatchArgs};
@group(0) @binding(22) var<storage, read_write> bounce_irradiance: array<u32>;
@group(0) @binding(27) var<storage, read_write> listed_slots: array<u32>;
// Cleared before the list is made.
@group(0) @binding(28) var<storage, read_write> listed_count: atomic<u32>;
// The gather's indirect dispatch: x, y, z workgroups of 64 lanes.
@group(0) @binding(29) var<storage, read_write> gather_args: DispatchArgs;

var<workgroup> listed_here: atomic<u32>;
var<workgroup> list_base: u32;

// Stores irradiance `e` as slot `i`'s bounce.
fn store_bounce(i: u32, e: vec3<f32>) {
    bounce_irradiance[2u * i] = pack2x16float(e.rg);
    bounce_irradiance[2u * i + 1u] = pack2x16float(vec2<f32>(e.b, 0.0));
}

// Whether the voxel at grid coordinates `cell` gathers this frame (`bounce_frames`): `spread`
// holds the number of interleaved sets N (bits 0..7) and this frame's set (bits 8..15); the
// voxel's set is (x + y + z) mod N, a checkerboard for N = 2, so neighbours gather on
// different frames and every voxel once in N frames.
fn bounce_due(cell: vec3<u32>, spread: u32) -> bool {
    let sets = max(spread & 255u, 1u);
    return (cell.x + cell.y + cell.z) % sets == ((spread >> 8u) & 255u);
}

// A bounce's `bounce_list` step for invocation `li` and slot `i` (`slot`: i is a slot of the
// structure): lists it where its voxel `gathers` and is `due` this frame (`bounce_due`),
// zeroes its bounce where it does not gather, as a gather without light would, and leaves a
// voxel that gathers on another frame as it is. Every invocation of the workgroup calls it,
// in uniform control flow.
fn list_or_clear(i: u32, slot: bool, gathers: bool, due: bool, li: u32) {
    if slot && !gathers {
        store_bounce(i, vec3<f32>(0.0));
    }
    list_slot(i, slot && gathers && due, li);
}

// Appends slot `i` to the list where `listed`. Every invocation of the workgroup calls it, in
// uniform control flow (it holds barriers).
fn list_slot(i: u32, listed: bool, li: u32) {
    var at = 0u;
    if listed {
        at = atomicAdd(&listed_here, 1u);
    }
    workgroupBarrier();
    if li == 0u {
        list_base = atomicAdd(&listed_count, atomicLoad(&listed_here));
    }
    workgroupBarrier();
    if listed {
        listed_slots[list_base + at] = i;
    }
}

// The slot gather invocation `k` takes, or 0xffffffff past the end of the list.
fn listed_slot(k: u32) -> u32 {
    if k >= atomicLoad(&listed_count) {
        return 0xffffffffu;
    }
    return listed_slots[k];
}

// The gather's workgroups: CONE_LANES lanes per listed slot (`cone_lanes.wgsl`).
@compute @workgroup_size(1)
fn bounce_args() {
    let groups = (atomicLoad(&listed_count) * CONE_LANES + 63u) / 64u;
    gather_args = dispatch_covering(groups);
}
