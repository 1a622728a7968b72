// The diffuse gathers' cones side by side: a workgroup of 64 lanes gathers GATHER_ITEMS items
// (pixels or voxels), CONE_LANES lanes per item, each marching CONES_PER_LANE of its cones
// (lane l of an item: cones l, l + CONE_LANES, ...; from the generated `cone_set`: the cone
// count rounded up to a power of two, at most 16 lanes). One lane per item marching every cone
// in turn left a GPU mostly idle: a sparse image or a list of voxels holds a few tens of
// thousands of items, too few lanes to fill a large GPU, and each lane ran its cones one after
// another (on an H200 the clipmap's bounce took 0.5 ms for 1216 voxels). A lane per cone of a
// 64-cone set repeated the item's setup 64 times, which cost more than it saved where the
// cones are short. Lavapipe runs lanes one after another either way: its work counts do not
// change.
//
// An item's first lane sums its cones' weighted results in cone order, the order of the loop
// over the cones it replaces.

import octolux::gi::vct::cone_set::{CONE_LANES, CONE_RESULTS, CONES_PER_LANE, DIFFUSE_CONES};

const GATHER_ITEMS: u32 = 64u / CONE_LANES;
// Result slots per item.
const CONE_SLOTS: u32 = CONE_LANES * CONES_PER_LANE;

var<workgroup> cone_results: array<vec4<f32>, CONE_RESULTS>;

// The item lane `li` of workgroup `wg` (linear index) gathers for.
fn gather_item(wg: u32, li: u32) -> u32 {
    return wg * GATHER_ITEMS + li / CONE_LANES;
}

// Cone j (< CONES_PER_LANE) of lane `li`; DIFFUSE_CONES and above: none.
fn lane_cone(li: u32, j: u32) -> u32 {
    return li % CONE_LANES + j * CONE_LANES;
}

// Whether lane `li` is its item's first (the one that gets the sum).
fn first_lane(li: u32) -> bool {
    return li % CONE_LANES == 0u;
}

// Keeps the weighted result of cone `cone` of lane `li`'s item.
fn keep_cone(li: u32, cone: u32, weighted: vec4<f32>) {
    cone_results[li / CONE_LANES * CONE_SLOTS + cone] = weighted;
}

// Sums the kept results over each item's cones: the item's first lane gets the sum, the
// others zero. Every lane of the workgroup calls it, in uniform control flow (it holds a
// barrier), after keeping its cones.
fn sum_item_cones(li: u32) -> vec4<f32> {
    workgroupBarrier();
    var sum = vec4<f32>(0.0);
    if first_lane(li) {
        let base = li / CONE_LANES * CONE_SLOTS;
        for (var k = 0u; k < DIFFUSE_CONES; k++) {
            sum += cone_results[base + k];
        }
    }
    return sum;
}
