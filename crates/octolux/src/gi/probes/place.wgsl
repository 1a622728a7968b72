// Surfel placement: one ray per surfel from its probe along its lattice direction; the
// closest hit becomes the surfel (position, normal facing the probe, albedo, emission),
// marked front or back face, or a miss. The ray structure (place_bvh.wgsl or
// place_voxels.wgsl, gi/probes/rays.rs, composed in as `gi/probes/rays`) provides
// `surfel_hit` and its bindings.
// Only probes the probe set asks for are placed; a hit beyond the probe's region (the
// octree's cube) is marked by a negative distance, or is a miss where the set keeps no far
// hits. With P.keep_unmoved set (surfels placed by an earlier frame, objects moved since), a
// surfel whose ray, from the probe to its hit (or to the ray's end for a miss), crosses none
// of the moved objects' old and new boxes keeps its hit: only the rays that may have changed
// are traced again. With two surfel sets (P.set_count, probes-grid's accumulation) the set
// placed this frame is traced whole along its turned lattice, and the other set keeps its
// surfels but where objects moved (both are traced for a probe that restarts its history).

import octolux::gi::probes::probes::{linear_index, P, probe_ray_dir, probe_surfels, Surfel, SURFEL_BACK, SURFEL_FRONT, SURFEL_MISS};
import octolux::gi::probes::set::{probe_keeps_far_hits, probe_origin, probe_region_exit, probe_restarts, probe_slot, probe_slots, probe_wants_place};
import octolux::gi::probes::rays::{count_ray_work, surfel_hit};
import octolux::gpu::work::count_work;

@group(0) @binding(1) var<storage, read_write> surfels: array<Surfel>;
// Per moved box: (lower corner, 0), (upper corner, 0).
@group(0) @binding(7) var<storage, read> moved_boxes: array<vec4<f32>>;
// Per probe, the last frame that traced any of its rays again (for the moments' pass). Every
// invocation that stores writes the same value: a plain store, no read-modify-write.
@group(0) @binding(8) var<storage, read_write> probe_stamps: array<atomic<u32>>;

// Stamps the probe with this frame (see `probe_stamps`). Counting, it swaps instead of
// storing and returns 1 for the first of the probe's rays traced this frame, so that each
// probe traced counts once (quantity 0 of `PLACE_*_WORK` in engine.rs).
@if(count_work) fn stamp_probe(probe: u32) -> u32 {
    return u32(atomicExchange(&probe_stamps[probe], P.frame) != P.frame);
}

@if(!count_work) fn stamp_probe(probe: u32) -> u32 {
    atomicStore(&probe_stamps[probe], P.frame);
    return 0u;
}

// Whether the segment a -> b meets any of the P.moved_boxes moved boxes.
fn segment_meets_moved(a: vec3<f32>, b: vec3<f32>) -> bool {
    let d = b - a;
    let inv = 1.0 / select(d, vec3<f32>(1e-30), d == vec3<f32>(0.0));
    for (var i = 0u; i < P.moved_boxes; i++) {
        let t0 = (moved_boxes[2u * i].xyz - a) * inv;
        let t1 = (moved_boxes[2u * i + 1u].xyz - a) * inv;
        let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
        let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), 1.0));
        if near <= far {
            return true;
        }
    }
    return false;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    // Invocation k: surfel k % per of the set's (k / per)-th probe; per probe, set j holds
    // surfels j n .. j n + n - 1.
    let k = linear_index(wg, nwg, li);
    let n = P.surfels_per_set;
    let per = probe_surfels();
    if k >= probe_slots() * per {
        return;
    }
    let probe = probe_slot(k / per);
    let ray_set = (k % per) / n;
    let s = probe * per + k % per;
    if !probe_wants_place(probe) {
        return;
    }
    // A probe that restarts its history (the octree's new ones) traces both sets.
    let fresh = (P.latest_placed != 0u && ray_set == P.latest_set) || probe_restarts(probe);
    // Two sets, nothing moved: the older set keeps its surfels.
    if !fresh && P.set_count > 1u && P.keep_unmoved == 0u {
        return;
    }
    let d = probe_ray_dir(ray_set, k % n, n).xyz;
    let o = probe_origin(probe);
    if !fresh && P.keep_unmoved != 0u {
        let old = surfels[s];
        let end = select(old.position, o + d * P.max_distance, old.state == SURFEL_MISS);
        if !segment_meets_moved(o, end) {
            return;
        }
    }
    // Work counts: probes traced, rays traced, then the ray structure's work.
    count_work(0u, stamp_probe(probe));
    count_work(1u, 1u);
    let hit = surfel_hit(o, d, P.max_distance);
    count_ray_work(2u);
    let inside = hit.t <= probe_region_exit(probe, d);
    if hit.t < 0.0 || !(inside || probe_keeps_far_hits()) {
        surfels[s] = Surfel(o, SURFEL_MISS, vec3<f32>(0.0), 0u, vec3<f32>(0.0), 0.0);
        return;
    }
    let geo = select(-d, hit.normal, dot(hit.normal, hit.normal) > 0.5);
    let front = dot(geo, d) < 0.0;
    surfels[s] = Surfel(o + d * hit.t, select(SURFEL_BACK, SURFEL_FRONT, front),
                        select(-geo, geo, front), hit.albedo, hit.emission,
                        select(-hit.t, hit.t, inside));
}
