// Multiple bounces on the clipmap (`multi_bounce`): every occupied voxel with a dominant normal
// gathers the indirect irradiance at the voxel with the diffuse cones of `trace.wgsl` through
// the radiance injected this frame, from the voxel's centre along its mean normal. The next
// frame's injection adds it to the voxel's direct irradiance (`Clipmap::set_bounce`), so each
// frame carries the light one bounce further.
//
// `bounce_list` lists the voxels that gather and zeroes the others' bounce, `bounce_args`
// (`bounce_list.wgsl`) sizes the gather, and `bounce` gathers the listed voxels, their cones
// spread over lanes (`cone_lanes.wgsl`).
//
// `bounce_clear`: zeroes the slots of one box the clipmap revoxelised this frame (slots that
// wrapped to new voxels as the clipmap scrolled, regions moving objects left or entered), so
// no voxel starts with another voxel's bounce.

import octolux::gi::vct::cone::march_cone;
import octolux::gi::vct::gather::{diffuse_cone_dir, diffuse_cone_weight};
import octolux::gi::vct::trace::trace;
import octolux::voxel::clipmap::sample::{clip_info, clip_slot, clip_slot_centre, clip_voxels};
import octolux::gi::vct::cone_set::{CONES_PER_LANE, DIFFUSE_CONES};
import octolux::gi::vct::cone_lanes::{
    first_lane, gather_item, keep_cone, lane_cone, sum_item_cones,
};
import octolux::gi::vct::structure::{vct_count_structure_work, vct_surface_voxel};
import octolux::gi::vct::cone::count_cone_work;
import octolux::gpu::work::count_work;
import octolux::gi::vct::bounce_list::{bounce_due, list_or_clear, listed_slot, store_bounce};

// `BounceParams` in clipmap_bounce.rs.
struct BounceParams {
    // Voxel slots (levels * res^3).
    slots: u32,
    // This frame's set of `bounce_due` (`bounce_list.wgsl`).
    spread: u32,
}

// A box of one level the clear zeroes (`BounceBox` in clipmap_bounce.rs).
struct BounceBox {
    // First voxel (world voxel coordinates of the level).
    lo: vec3<i32>,
    // The box's level.
    level: u32,
    // Voxels along each axis.
    size: vec3<u32>,
}

@group(0) @binding(20) var<storage, read> bounce_params: BounceParams;
@group(0) @binding(21) var<storage, read> clip_normals: array<u32>;
@group(0) @binding(23) var<storage, read> bounce_box: BounceBox;

// Whether slot i gathers: occupied, with a dominant normal (opposite faces cancel).
fn gathers(i: u32) -> bool {
    let n = unpack4x8snorm(clip_normals[i]).xyz;
    return unpack4x8unorm(clip_voxels[i]).a > 0.0 && dot(n, n) > 0.01;
}

// Lists the slots that gather (`bounce_list.wgsl`) and zeroes the others' bounce.
@compute @workgroup_size(64)
fn bounce_list(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    let slot = i < bounce_params.slots;
    // The slot's voxel in the level's (wrapped) grid, and its level.
    let r = clip_info.resolution;
    let m = vec3<u32>(i % r, (i / r) % r, (i / (r * r)) % r);
    let due = bounce_due(m + vec3<u32>(i / (r * r * r), 0u, 0u), bounce_params.spread);
    list_or_clear(i, slot, slot && gathers(i), due, li);
}

@compute @workgroup_size(64)
fn bounce(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    // Work counts (`BOUNCE_WORK` in tracer.rs): lanes launched, then what the voxels did.
    count_work(0u, 1u);
    // One listed voxel per item, its cones spread over the item's lanes (`cone_lanes.wgsl`).
    let i = listed_slot(gather_item(wg.y * nwg.x + wg.x, li));
    if i != 0xffffffffu {
        let nn = normalize(unpack4x8snorm(clip_normals[i]).xyz);
        let centre = clip_slot_centre(i);
        let p = centre.xyz;
        // The apex leaves the voxel's own level too: a coarse voxel's centre may lie up to
        // half its size behind the surface it holds.
        let voxel = max(vct_surface_voxel(p, trace.cone.voxel), centre.w);
        var cone = trace.cone;
        cone.voxel = voxel;
        cone.start = trace.apex_offset * voxel;
        let apex = p + nn * cone.start;
        for (var j = 0u; j < CONES_PER_LANE; j++) {
            let k = lane_cone(li, j);
            if k < DIFFUSE_CONES {
                let l = march_cone(apex, diffuse_cone_dir(nn, k), cone).rgb;
                keep_cone(li, k, vec4<f32>(diffuse_cone_weight(k) * l, 0.0));
            }
        }
    }
    let e = sum_item_cones(li);
    if i != 0xffffffffu && first_lane(li) {
        count_work(1u, 1u);
        store_bounce(i, 3.14159265 * e.rgb);
    }
    count_cone_work(2u, 3u);
    vct_count_structure_work(4u);
}

@compute @workgroup_size(64)
fn bounce_clear(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    let size = bounce_box.size;
    if i >= size.x * size.y * size.z {
        return;
    }
    let c = bounce_box.lo + vec3<i32>(vec3<u32>(i % size.x, (i / size.x) % size.y,
                                                    i / (size.x * size.y)));
    store_bounce(clip_slot(bounce_box.level, c), vec3<f32>(0.0));
}
