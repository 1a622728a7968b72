// Probe integration: each probe sums its surfels' radiance, each over the solid angle of its
// lattice direction, into its encoding, and counts its back-face and total hits and the hits
// inside its region (the octree's hit count).

import octolux::gi::probes::probes::{linear_index, P, PROBE_VEC4, SURFEL_VEC4};
import octolux::gi::probes::set::{probe_live, probe_slot, probe_slots, probe_store_hits};
import octolux::gi::probes::encoding::probe_encode;
import octolux::gi::probes::lattice::lattice_dir;

@group(0) @binding(1) var<storage, read> surfels: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> radiance: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> probes: array<vec4<f32>>;

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
    let n = P.dims.w;
    var c: array<vec3<f32>, 8>;
    var back = 0u;
    var hits = 0u;
    var inside = 0u;
    for (var k = 0u; k < n; k++) {
        let s = probe * n + k;
        let state = surfels[s * SURFEL_VEC4].w;
        hits += u32(state > 0.5);
        back += u32(state > 1.5);
        inside += u32(state > 0.5 && surfels[s * SURFEL_VEC4 + 2u].w >= 0.0);
        let d = lattice_dir(P.misc.x, k, n);
        probe_encode(P.misc.y, &c, radiance[s].rgb, d.xyz, d.w);
    }
    let b = probe * PROBE_VEC4;
    for (var k = 0u; k < 8u; k++) {
        probes[b + k] = vec4<f32>(c[k], 0.0);
    }
    probe_store_hits(probe, inside);
    probes[b + 8u] = vec4<f32>(f32(back) / f32(n), f32(hits) / f32(n), select(0.0, 1.0, back <= P.limits.x), 0.0);
}
