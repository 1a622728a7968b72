// Multiple bounces on the octree (`multi_bounce`): every static leaf voxel that gathers
// gathers the indirect irradiance at the voxel with the diffuse cones of `trace.wgsl`
// through the radiance injected this frame, from the voxel's centre along its mean normal
// (the geometry the injection wrote, `SvoBounce`). The next frame's injection adds it to the
// voxel's direct irradiance, so each frame carries the light one bounce further and the
// octree converges to multi-bounce radiance. `bounce_list` lists the static slots whose voxel
// gathers and zeroes the others' bounce, `bounce_args` (`bounce_list.wgsl`) sizes the gather,
// and `bounce` gathers the listed voxels, their cones spread over lanes
// (`cone_lanes.wgsl`). The dynamic part's voxels (`bounce_dynamic`, a workgroup per leaf
// node) gather the same way; their leaves are rebuilt every frame in another order, so their
// irradiance goes into a table keyed by voxel (`svo/bounce_table.wgsl`) instead of by slot.

import octolux::gi::vct::cone::march_cone;
import octolux::gi::vct::gather::{diffuse_cone_dir, diffuse_cone_weight};
import octolux::gi::vct::trace::{SurfaceCone, surface_cone};
import octolux::voxel::svo::sample::svo_info;
import octolux::voxel::svo::control::SvoControlValues;
import octolux::voxel::svo::bounce_table::{BOUNCE_TABLE_PROBES, bounce_table_hash};
import octolux::gi::vct::cone_set::{CONE_LANES, CONES_PER_LANE, DIFFUSE_CONES};
import octolux::gi::vct::cone_lanes::{
    GATHER_ITEMS, first_lane, gather_item, keep_cone, lane_cone, sum_item_cones,
};
import octolux::gi::vct::cone::count_cone_work;
import octolux::gi::vct::structure::vct_count_structure_work;
import octolux::gpu::work::count_work;
import octolux::gi::vct::bounce_list::{bounce_due, list_or_clear, listed_slot, store_bounce};

// `BounceParams` in svo_gi.rs.
struct BounceParams {
    // Static leaf voxel slots (the dynamic leaves' slots follow).
    static_slots: u32,
    // Entries of the dynamic voxels' table (a power of two).
    table_capacity: u32,
    // The leaf level (its dynamic nodes: `svo_control.dynamic_levels[leaf_level]`).
    leaf_level: u32,
    // This frame's set of `bounce_due` (`bounce_list.wgsl`; the static voxels only).
    spread: u32,
}

@group(0) @binding(20) var<storage, read> bounce_params: BounceParams;
@group(0) @binding(21) var<storage, read> bounce_geometry: array<u32>;
@group(0) @binding(23) var<storage, read> svo_control: SvoControlValues;
@group(0) @binding(24) var<storage, read_write> table_keys: array<atomic<u32>>;
@group(0) @binding(25) var<storage, read_write> table_values: array<u32>;

// Whether the voxel of geometry slot `i` gathers: occupied, with a dominant normal.
fn voxel_gathers(i: u32) -> bool {
    let n = unpack4x8snorm(bounce_geometry[2u * i + 1u]).xyz;
    return (bounce_geometry[2u * i] & (1u << 30u)) != 0u && dot(n, n) > 0.25;
}

// Where the cones of the voxel of geometry slot `i` start and which way it faces.
struct BounceVoxel {
    normal: vec3<f32>,
    start: SurfaceCone,
}

// The grid coordinates of the voxel of geometry slot `i`.
fn geometry_voxel(i: u32) -> vec3<u32> {
    let g = bounce_geometry[2u * i];
    return vec3<u32>(g & 1023u, (g >> 10u) & 1023u, (g >> 20u) & 1023u);
}

fn bounce_voxel(i: u32) -> BounceVoxel {
    let v = geometry_voxel(i);
    let p = svo_info.origin + (vec3<f32>(v) + 0.5) * svo_info.voxel_size;
    var b: BounceVoxel;
    b.normal = normalize(unpack4x8snorm(bounce_geometry[2u * i + 1u]).xyz);
    b.start = surface_cone(p, b.normal);
    return b;
}

// The weighted radiance cone k of voxel `b` gathers.
fn bounce_cone(b: BounceVoxel, k: u32) -> vec3<f32> {
    let dir = diffuse_cone_dir(b.normal, k);
    return diffuse_cone_weight(k) * march_cone(b.start.apex, dir, b.start.cone).rgb;
}

// Work counts (`BOUNCE_WORK` in tracer.rs) of a lane: the voxel it gathered (`first`: the
// item's first lane, where voxel i gathers), its cones, samples and lookups (the lanes
// launched are counted by the entry points).
fn count_bounce_work(i: u32, first: bool) {
    if first && voxel_gathers(i) {
        count_work(1u, 1u);
    }
    count_cone_work(2u, 3u);
    vct_count_structure_work(4u);
}

// Marches lane `li`'s cones of the voxel of geometry slot `i` and keeps their weighted
// results for `sum_item_cones` (the static and the dynamic gathers alike).
fn keep_voxel_cones(i: u32, li: u32) {
    let b = bounce_voxel(i);
    for (var j = 0u; j < CONES_PER_LANE; j++) {
        let k = lane_cone(li, j);
        if k < DIFFUSE_CONES {
            keep_cone(li, k, vec4<f32>(bounce_cone(b, k), 0.0));
        }
    }
}

// Lists the static slots whose voxel gathers (`bounce_list.wgsl`) and zeroes the others'.
@compute @workgroup_size(64)
fn bounce_list(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    let slot = i < bounce_params.static_slots;
    var due = false;
    if slot {
        due = bounce_due(geometry_voxel(i), bounce_params.spread);
    }
    list_or_clear(i, slot, slot && voxel_gathers(i), due, li);
}

@compute @workgroup_size(64)
fn bounce(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    count_work(0u, 1u);
    // One listed voxel per item, its cones spread over the item's lanes (`cone_lanes.wgsl`).
    let i = listed_slot(gather_item(wg.y * nwg.x + wg.x, li));
    // Listed voxels gather (`bounce_list`).
    if i != 0xffffffffu {
        keep_voxel_cones(i, li);
    }
    let e = sum_item_cones(li);
    if i != 0xffffffffu {
        count_bounce_work(i, first_lane(li));
        if first_lane(li) {
            store_bounce(i, 3.14159265 * e.rgb);
        }
    }
}

// One workgroup per dynamic leaf node (the range the octree's last dynamic update left on
// the GPU): its 8 voxel slots gathered as the static voxels are, their cones spread over the
// lanes (`cone_lanes.wgsl`), in rounds of GATHER_ITEMS voxels; each occupied voxel enters the
// table (cleared before). One lane per voxel marching its cones in turn, in workgroups of 8,
// left three quarters of a GPU's SIMD lanes idle and each lane a long chain: on an H200 it
// took 1.7 ms for a third of the static bounce's cones, which take 0.6 ms. Keys are distinct
// (one slot per voxel), so an insert competes only with the few keys that hash near it.
const DYNAMIC_ROUNDS: u32 = (8u + GATHER_ITEMS - 1u) / GATHER_ITEMS;

@compute @workgroup_size(64)
fn bounce_dynamic(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) li: u32) {
    count_work(0u, 1u);
    let l = wg.y * nwg.x + wg.x;
    let leaves = svo_control.dynamic_levels[bounce_params.leaf_level];
    // No lane leaves early: the rounds hold barriers.
    let live = l < leaves.end - leaves.first;
    for (var round = 0u; round < DYNAMIC_ROUNDS; round++) {
        let o = round * GATHER_ITEMS + li / CONE_LANES;
        let i = bounce_params.static_slots + 8u * l + o;
        let present = live && o < 8u && bounce_geometry[2u * i] != 0u;
        let gathers = present && voxel_gathers(i);
        if gathers {
            keep_voxel_cones(i, li);
        }
        let e = sum_item_cones(li);
        if present && first_lane(li) {
            if gathers {
                count_work(1u, 1u);
            }
            // A voxel that does not gather enters with no light.
            table_insert(bounce_geometry[2u * i], select(vec3<f32>(0.0), 3.14159265 * e.rgb, gathers));
        }
        // The next round's cones overwrite the results this one summed.
        workgroupBarrier();
    }
    count_cone_work(2u, 3u);
    vct_count_structure_work(4u);
}

// Enters irradiance `e` under voxel key `key` (nonzero) in the dynamic voxels' table.
fn table_insert(key: u32, e: vec3<f32>) {
    let mask = bounce_params.table_capacity - 1u;
    var at = bounce_table_hash(key) & mask;
    var probes = 0u;
    // Bounded even if weak exchanges kept failing spuriously.
    for (var tries = 0u; tries < 4u * BOUNCE_TABLE_PROBES && probes < BOUNCE_TABLE_PROBES; tries++) {
        let r = atomicCompareExchangeWeak(&table_keys[at], 0u, key);
        if r.exchanged || r.old_value == key {
            table_values[2u * at] = pack2x16float(e.rg);
            table_values[2u * at + 1u] = pack2x16float(vec2<f32>(e.b, 0.0));
            return;
        }
        // A weak exchange may fail spuriously on an empty entry: try it again.
        if r.old_value != 0u {
            at = (at + 1u) & mask;
            probes++;
        }
    }
}
