// Probe integration: each probe sums its surfels' radiance, each over the solid angle of its
// lattice direction, into its encoding, and counts its back-face and total hits and the hits
// inside its region (the octree's hit count). A probe's surfels are summed by INTEGRATE_LANES
// lanes side by side, whose partial sums its first lane adds: one lane per probe running
// through all its surfels left a GPU nearly idle (the octree's 1387 probes of 226 surfels:
// 22 workgroups on an H200's 132 multiprocessors, each lane a chain of 226 loads).
//
// With two surfel sets (P.set_count = 2: probes-grid's accumulation over frames,
// docs/probes.md "Rays that turn every frame") a probe keeps a history: its value is the mean
// of the samples of the last frames (up to P.max_history), each sample one turned lattice.
// The history is first relit: the set placed before is integrated again in this frame's
// light, and what changed since it was integrated last (its stored raw value, `probe_raw`) is
// added, so that light that moved, switched or bounced once more reaches the history at once.
// In a frame where a light or an object changed, the history also forgets in proportion to
// that change, times P.forgetting (grid_gi.rs, FORGETTING), so the noise of a change fades
// as new samples come. Then the new set's sample is blended in with weight 1 / (frames + 1);
// a probe whose history is full and whose light did not change keeps its value (no flicker
// where nothing that lights it moves, though a light elsewhere does). A probe that restarts
// (the octree's new probes, `probe_restarts`) takes its latest set's sample alone.

import octolux::gi::probes::probes::{linear_index, P, probe_ray_dir, probe_surfels, PROBE_VEC4, Surfel};
import octolux::gi::probes::set::{probe_live, probe_restarts, probe_slot, probe_slots, probe_store_hits};
import octolux::gi::probes::encoding::probe_encode;
import octolux::gpu::work::count_work;
import octolux::gi::probes::octree_params::INTEGRATE_LANES;

@group(0) @binding(1) var<storage, read> surfels: array<Surfel>;
@group(0) @binding(2) var<storage, read> radiance: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> probes: array<vec4<f32>>;
// Per probe, 8 vec4s: the coefficients of the set placed most recently as last integrated
// (a placeholder with one set).
@group(0) @binding(4) var<storage, read_write> probe_raw: array<vec4<f32>>;

// Work counts (`INTEGRATE_WORK` in engine.rs): surfels read by this invocation, kept only by
// a counting shader; `count_integrate_work` adds them and the probe integrated.
@if(count_work) var<private> surfels_read: u32;

@if(count_work) fn note_surfels(n: u32) {
    surfels_read += n;
}

@if(!count_work) fn note_surfels(n: u32) {}

// A lane's counts: the probe (counted by its first lane) and the surfels the lane read.
@if(count_work) fn count_integrate_work(first: bool) {
    if first {
        count_work(0u, 1u);
    }
    count_work(1u, surfels_read);
}

@if(!count_work) fn count_integrate_work(first: bool) {}

// One set's sums: coefficients and hit counts.
struct SetSums {
    c: array<vec3<f32>, 8>,
    back: u32,
    hits: u32,
    inside: u32,
};

// Each lane's partial sums of the set being integrated.
var<workgroup> partial_c: array<array<vec3<f32>, 8>, 64>;
// (back-face hits, hits, hits inside) per lane.
var<workgroup> partial_n: array<vec3<u32>, 64>;

// The sums of surfel set `ray_set` of `probe`: lane j of the probe's INTEGRATE_LANES sums
// surfels j, j + INTEGRATE_LANES, ... in order, then its first lane adds the partial sums in
// lane order and gets the result (the other lanes zeros). Every lane of the workgroup calls
// it, in uniform control flow (it holds barriers); a lane with nothing to sum passes
// `summing` false.
fn integrate_set(probe: u32, ray_set: u32, n: u32, li: u32, summing: bool) -> SetSums {
    var c: array<vec3<f32>, 8>;
    var back = 0u;
    var hits = 0u;
    var inside = 0u;
    let lane = li % INTEGRATE_LANES;
    if summing {
        let first = probe * probe_surfels() + ray_set * n;
        for (var k = lane; k < n; k += INTEGRATE_LANES) {
            let s = first + k;
            let surfel = surfels[s];
            let state = surfel.state;
            hits += u32(state > 0.5);
            back += u32(state > 1.5);
            inside += u32(state > 0.5 && surfel.distance >= 0.0);
            let d = probe_ray_dir(ray_set, k, n);
            probe_encode(P.encoding, &c, radiance[s].rgb, d.xyz, d.w);
            note_surfels(1u);
        }
    }
    partial_c[li] = c;
    partial_n[li] = vec3<u32>(back, hits, inside);
    workgroupBarrier();
    var sums: SetSums;
    if lane == 0u {
        for (var l = li; l < li + INTEGRATE_LANES; l++) {
            for (var q = 0u; q < 8u; q++) {
                sums.c[q] += partial_c[l][q];
            }
            sums.back += partial_n[l].x;
            sums.hits += partial_n[l].y;
            sums.inside += partial_n[l].z;
        }
    }
    // Read before the next set's partial sums overwrite them.
    workgroupBarrier();
    return sums;
}

// Sum of the absolute values of every coefficient's channels.
fn level(c: array<vec3<f32>, 8>) -> f32 {
    var sum = 0.0;
    for (var k = 0u; k < 8u; k++) {
        sum += dot(abs(c[k]), vec3<f32>(1.0));
    }
    return sum;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    // INTEGRATE_LANES invocations per probe; no lane leaves before the sums (barriers).
    let k = linear_index(wg, nwg, li) / INTEGRATE_LANES;
    let first_lane = li % INTEGRATE_LANES == 0u;
    var probe = 0u;
    var has_probe = k < probe_slots();
    if has_probe {
        probe = probe_slot(k);
        has_probe = probe_live(probe);
    }
    let n = P.surfels_per_set;
    let b = probe * PROBE_VEC4;
    if P.set_count == 1u {
        let r = integrate_set(probe, 0u, n, li, has_probe);
        if !has_probe {
            return;
        }
        count_integrate_work(first_lane);
        if !first_lane {
            return;
        }
        for (var k = 0u; k < 8u; k++) {
            probes[b + k] = vec4<f32>(r.c[k], 0.0);
        }
        probe_store_hits(probe, r.inside);
        probes[b + 8u] = vec4<f32>(f32(r.back) / f32(n), f32(r.hits) / f32(n), select(0.0, 1.0, r.back <= P.max_back_faces), 0.0);
        return;
    }
    let sampled = P.latest_placed != 0u;
    // The set placed before this frame's: the other one when a new set was placed.
    let before = select(P.latest_set, 1u - P.latest_set, sampled);
    // A probe that restarts needs only the latest set (the one before when none was placed).
    let restarts = has_probe && probe_restarts(probe);
    let relit = integrate_set(probe, before, n, li, has_probe && !(restarts && sampled));
    var newest = relit;
    if sampled {
        newest = integrate_set(probe, P.latest_set, n, li, has_probe);
    }
    if !has_probe {
        return;
    }
    count_integrate_work(first_lane);
    if !first_lane {
        return;
    }
    let rb = probe * 8u;
    if restarts {
        // A new history (the octree's new probe, or one its slot held before): the latest
        // set's sample alone, which also gives the octree its hit count.
        let sample = newest;
        for (var k = 0u; k < 8u; k++) {
            probes[b + k] = vec4<f32>(sample.c[k], 0.0);
            probe_raw[rb + k] = vec4<f32>(sample.c[k], 0.0);
        }
        probe_store_hits(probe, sample.inside);
        let valid = sample.back <= P.max_back_faces;
        probes[b + 8u] = vec4<f32>(f32(sample.back) / f32(n), f32(sample.hits) / f32(n), select(0.0, 1.0, valid), 1.0);
        return;
    }
    var history: array<vec3<f32>, 8>;
    var raw: array<vec3<f32>, 8>;
    var change = 0.0;
    for (var k = 0u; k < 8u; k++) {
        raw[k] = probe_raw[rb + k].xyz;
        let delta = relit.c[k] - raw[k];
        history[k] = probes[b + k].xyz + delta;
        change += dot(abs(delta), vec3<f32>(1.0));
    }
    // (back-face share, hit share, valid, frames in the history)
    let state = probes[b + 8u];
    let scale = max(max(level(raw), level(relit.c)), 1e-30);
    var frames = state.w * max(1.0 - P.forgetting * change / scale, 0.0);
    var back = state.x;
    var hits = state.y;
    var latest = relit.c;
    // A full history whose light did not change at all is settled: it keeps its value, and
    // the new sample only becomes the set the next frame relights from.
    let settled = frames >= f32(P.max_history) && change == 0.0;
    if sampled && !settled {
        let sample = newest;
        let keep = frames / (frames + 1.0);
        for (var k = 0u; k < 8u; k++) {
            history[k] = mix(sample.c[k], history[k], keep);
        }
        back = mix(f32(sample.back) / f32(n), back, keep);
        hits = mix(f32(sample.hits) / f32(n), hits, keep);
        frames = min(frames + 1.0, f32(P.max_history));
        latest = sample.c;
    } else if sampled {
        latest = newest.c;
    }
    for (var k = 0u; k < 8u; k++) {
        probes[b + k] = vec4<f32>(history[k], 0.0);
        probe_raw[rb + k] = vec4<f32>(latest[k], 0.0);
    }
    // The back-face share is a mean over frames too: valid while it holds at most the limit's
    // count (+ 0.5: a single sample's share times n is an integer up to rounding).
    let valid = back * f32(n) <= f32(P.max_back_faces) + 0.5;
    probes[b + 8u] = vec4<f32>(back, hits, select(0.0, 1.0, valid), frames);
}
