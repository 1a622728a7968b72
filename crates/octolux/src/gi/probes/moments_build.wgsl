// Depth moments (moments.wgsl): one workgroup per probe, four texels of its map per lane, over the
// probes the set has just placed (with a placement that keeps unchanged surfels,
// P.keep_unmoved, only those with a ray traced again this frame, stamped by the placement).
// Each texel holds the kernel-weighted mean distance and mean squared distance of the probe's
// surfels (misses at the ray's maximum distance, P.max_distance), weighted by
// `moment_kernel`, max(0, t . d)^32, for the texel's direction t and the surfel's lattice
// direction d. Each invocation writes its own texel: no atomics. With two surfel sets
// (probes-grid's accumulation) the maps are made from the set placed this frame, along its
// turned lattice, and blended into the maps of the frames before with weight
// 1 - P.moments_keep (P.moments_keep is 0 on the first frame and after an object moved).

import octolux::gi::probes::probes::{P, probe_ray_dir, probe_surfels, Surfel};
import octolux::gi::probes::moments::{moment_kernel, moment_texel_dir, MOMENT_TEXELS};
import octolux::gi::probes::set::{probe_restarts, probe_slot, probe_slots, probe_wants_place};
import octolux::gpu::work::count_work;

@group(0) @binding(1) var<storage, read> surfels: array<Surfel>;
@group(0) @binding(2) var<storage, read_write> moments_out: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> probe_stamps: array<u32>;

// A workgroup is one probe's map (MOMENT_TEXELS = 256 texels, four per lane: lane li makes
// texels li, li + 64, li + 128 and li + 192), and every texel reads every surfel of the set:
// each lane fetches one surfel and makes its lattice direction once per round of 64, into
// these, and all 256 texels read them from here (instead of each lane reading all the surfels
// and making all their directions itself).
var<workgroup> round_dirs: array<vec4<f32>, 64>;
// Whether the workgroup's probe makes its map this frame (lane 0's decision, read back as a
// uniform value so that every lane reaches the barriers or none does).
var<workgroup> group_makes: u32;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    // Workgroup w: the set's w-th probe; lane li: texels li + 64 k of its map.
    let w = wg.y * nwg.x + wg.x;
    let accumulate = P.set_count > 1u;
    if li == 0u {
        group_makes = u32(probe_makes_map(w, accumulate));
    }
    if workgroupUniformLoad(&group_makes) == 0u {
        return;
    }
    let probe = probe_slot(w);
    let restarts = probe_restarts(probe);
    var t: array<vec3<f32>, 4>;
    for (var k = 0u; k < 4u; k++) {
        t[k] = moment_texel_dir(li + 64u * k);
    }
    let n = P.surfels_per_set;
    // Work counts (`MOMENTS_WORK` in engine.rs): texels made, kernel terms (surfels read).
    count_work(0u, 4u);
    count_work(1u, 4u * n);
    let ray_set = select(0u, P.latest_set, accumulate);
    let first = probe * probe_surfels() + ray_set * n;
    var sum: array<vec2<f32>, 4>;
    var total: array<f32, 4>;
    // The surfels in rounds of 64, in order, so each texel sums them as one lane alone would.
    for (var base = 0u; base < n; base += 64u) {
        let k = base + li;
        if k < n {
            let surfel = surfels[first + k];
            let dist = select(P.max_distance, abs(surfel.distance), surfel.state > 0.5);
            round_dirs[li] = vec4<f32>(probe_ray_dir(ray_set, k, n).xyz, dist);
        }
        workgroupBarrier();
        let count = min(n - base, 64u);
        for (var j = 0u; j < count; j++) {
            let ray = round_dirs[j];
            let m = vec2<f32>(ray.w, ray.w * ray.w);
            for (var k = 0u; k < 4u; k++) {
                let wt = moment_kernel(t[k], ray.xyz);
                sum[k] += wt * m;
                total[k] += wt;
            }
        }
        workgroupBarrier();
    }
    let far = vec2<f32>(P.max_distance, P.max_distance * P.max_distance);
    let keep = accumulate && !restarts;
    for (var k = 0u; k < 4u; k++) {
        let m = select(far, sum[k] / total[k], total[k] > 0.0);
        let id = probe * MOMENT_TEXELS + li + 64u * k;
        moments_out[id] = select(m, mix(m, moments_out[id], P.moments_keep), keep);
    }
}

// Whether the set's w-th probe makes its map this frame.
fn probe_makes_map(w: u32, accumulate: bool) -> bool {
    if w >= probe_slots() {
        return false;
    }
    let probe = probe_slot(w);
    if !probe_wants_place(probe) {
        return false;
    }
    if !accumulate && P.keep_unmoved != 0u && probe_stamps[probe] != P.frame {
        return false;
    }
    // A probe that restarts its history makes its maps afresh; the others keep theirs once
    // the maps' history is full (P.moments_keep 1: probes-octree, which runs this pass every
    // frame for the probes it restarts).
    return !(accumulate && P.moments_keep >= 1.0 && !probe_restarts(probe));
}
