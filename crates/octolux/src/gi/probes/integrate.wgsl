// Probe integration: each probe sums its surfels' radiance, each over the solid angle of its
// lattice direction, into its encoding, and counts its back-face and total hits and the hits
// inside its region (the octree's hit count).
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

@if(count_work) fn count_integrate_work() {
    count_work(0u, 1u);
    count_work(1u, surfels_read);
}

@if(!count_work) fn count_integrate_work() {}

// One set's sums: coefficients and hit counts.
struct SetSums {
    c: array<vec3<f32>, 8>,
    back: u32,
    hits: u32,
    inside: u32,
};

fn integrate_set(probe: u32, ray_set: u32, n: u32) -> SetSums {
    var c: array<vec3<f32>, 8>;
    var back = 0u;
    var hits = 0u;
    var inside = 0u;
    let first = probe * probe_surfels() + ray_set * n;
    note_surfels(n);
    for (var k = 0u; k < n; k++) {
        let s = first + k;
        let surfel = surfels[s];
        let state = surfel.state;
        hits += u32(state > 0.5);
        back += u32(state > 1.5);
        inside += u32(state > 0.5 && surfel.distance >= 0.0);
        let d = probe_ray_dir(ray_set, k, n);
        probe_encode(P.encoding, &c, radiance[s].rgb, d.xyz, d.w);
    }
    return SetSums(c, back, hits, inside);
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
    let k = linear_index(wg, nwg, li);
    if k >= probe_slots() {
        return;
    }
    let probe = probe_slot(k);
    if !probe_live(probe) {
        return;
    }
    let n = P.surfels_per_set;
    let b = probe * PROBE_VEC4;
    if P.set_count == 1u {
        let r = integrate_set(probe, 0u, n);
        for (var k = 0u; k < 8u; k++) {
            probes[b + k] = vec4<f32>(r.c[k], 0.0);
        }
        probe_store_hits(probe, r.inside);
        probes[b + 8u] = vec4<f32>(f32(r.back) / f32(n), f32(r.hits) / f32(n), select(0.0, 1.0, r.back <= P.max_back_faces), 0.0);
        count_integrate_work();
        return;
    }
    let rb = probe * 8u;
    if probe_restarts(probe) {
        // A new history (the octree's new probe, or one its slot held before): the latest
        // set's sample alone, which also gives the octree its hit count.
        let sample = integrate_set(probe, P.latest_set, n);
        for (var k = 0u; k < 8u; k++) {
            probes[b + k] = vec4<f32>(sample.c[k], 0.0);
            probe_raw[rb + k] = vec4<f32>(sample.c[k], 0.0);
        }
        probe_store_hits(probe, sample.inside);
        let valid = sample.back <= P.max_back_faces;
        probes[b + 8u] = vec4<f32>(f32(sample.back) / f32(n), f32(sample.hits) / f32(n), select(0.0, 1.0, valid), 1.0);
        count_integrate_work();
        return;
    }
    let sampled = P.latest_placed != 0u;
    // The set placed before this frame's: the other one when a new set was placed.
    let before = select(P.latest_set, 1u - P.latest_set, sampled);
    let relit = integrate_set(probe, before, n);
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
        let sample = integrate_set(probe, P.latest_set, n);
        let keep = frames / (frames + 1.0);
        for (var k = 0u; k < 8u; k++) {
            history[k] = mix(sample.c[k], history[k], keep);
        }
        back = mix(f32(sample.back) / f32(n), back, keep);
        hits = mix(f32(sample.hits) / f32(n), hits, keep);
        frames = min(frames + 1.0, f32(P.max_history));
        latest = sample.c;
    } else if sampled {
        latest = integrate_set(probe, P.latest_set, n).c;
    }
    for (var k = 0u; k < 8u; k++) {
        probes[b + k] = vec4<f32>(history[k], 0.0);
        probe_raw[rb + k] = vec4<f32>(latest[k], 0.0);
    }
    // The back-face share is a mean over frames too: valid while it holds at most the limit's
    // count (+ 0.5: a single sample's share times n is an integer up to rounding).
    let valid = back * f32(n) <= f32(P.max_back_faces) + 0.5;
    probes[b + 8u] = vec4<f32>(back, hits, select(0.0, 1.0, valid), frames);
    count_integrate_work();
}
