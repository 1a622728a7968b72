// Depth moments (moments.wgsl): one invocation per probe and texel of its map, over the
// probes the set has just placed (with a placement that keeps unchanged surfels,
// P.keep_unmoved, only those with a ray traced again this frame, stamped by the placement).
// Each texel holds the kernel-weighted mean distance and mean squared distance of the probe's
// surfels (misses at the ray's maximum distance, P.max_distance), weighted by
// `moment_kernel`, max(0, t . d)^32, for the texel's direction t and the surfel's lattice
// direction d. Each invocation writes its own texel: no atomics. With two surfel sets
// (probes-grid's accumulation) the maps are made from the set placed this frame, along its
// turned lattice, and blended into the maps of the frames before with weight
// 1 - P.moments_keep (P.moments_keep is 0 on the first frame and after an object moved).

import octolux::gi::probes::probes::{linear_index, P, probe_ray_dir, probe_surfels, Surfel};
import octolux::gi::probes::moments::{moment_kernel, moment_texel_dir, MOMENT_TEXELS};
import octolux::gi::probes::set::{probe_restarts, probe_slot, probe_slots, probe_wants_place};
import octolux::gpu::work::count_work;

@group(0) @binding(1) var<storage, read> surfels: array<Surfel>;
@group(0) @binding(2) var<storage, read_write> moments_out: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> probe_stamps: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    // Invocation k: texel k % MOMENT_TEXELS of the set's (k / MOMENT_TEXELS)-th probe.
    let k = linear_index(wg, nwg, li);
    if k >= probe_slots() * MOMENT_TEXELS {
        return;
    }
    let probe = probe_slot(k / MOMENT_TEXELS);
    let id = probe * MOMENT_TEXELS + k % MOMENT_TEXELS;
    if !probe_wants_place(probe) {
        return;
    }
    let accumulate = P.set_count > 1u;
    if !accumulate && P.keep_unmoved != 0u && probe_stamps[probe] != P.frame {
        return;
    }
    // A probe that restarts its history makes its maps afresh; the others keep theirs once
    // the maps' history is full (P.moments_keep 1: probes-octree, which runs this pass every
    // frame for the probes it restarts).
    let restarts = probe_restarts(probe);
    if accumulate && P.moments_keep >= 1.0 && !restarts {
        return;
    }
    let t = moment_texel_dir(id % MOMENT_TEXELS);
    let n = P.surfels_per_set;
    // Work counts (`MOMENTS_WORK` in engine.rs): texels made, kernel terms (surfels read).
    count_work(0u, 1u);
    count_work(1u, n);
    let ray_set = select(0u, P.latest_set, accumulate);
    let first = probe * probe_surfels() + ray_set * n;
    var sum = vec2<f32>(0.0);
    var total = 0.0;
    for (var k = 0u; k < n; k++) {
        let surfel = surfels[first + k];
        let dist = select(P.max_distance, abs(surfel.distance), surfel.state > 0.5);
        let w = moment_kernel(t, probe_ray_dir(ray_set, k, n).xyz);
        sum += w * vec2<f32>(dist, dist * dist);
        total += w;
    }
    let far = vec2<f32>(P.max_distance, P.max_distance * P.max_distance);
    let m = select(far, sum / total, total > 0.0);
    moments_out[id] = select(m, mix(m, moments_out[id], P.moments_keep), accumulate && !restarts);
}
