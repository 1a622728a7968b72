// The probe set of `probes-octree` (gi/probes/octree_gi.rs): one probe at the centre of each
// leaf that holds one; a probe's surfels are placed when the state machine asks for them (or
// every frame while objects move and surfels beyond the cube are kept). Composed in as
// `gi/probes/set`, with octree_tree_read.wgsl as the tree's bindings.

import octolux::gi::probes::tree_bindings::O;
import octolux::gi::probes::octree_params::{LIVE_COUNT, LIVE_FIRST, ProbeInfo};

@group(1) @binding(2) var<storage, read> probe_info: array<ProbeInfo>;
@group(1) @binding(3) var<storage, read> place_flags: array<u32>;
@group(1) @binding(4) var<storage, read_write> hits: array<u32>;
// The live probes (octree.wgsl's `live`): count, then slots.
@group(1) @binding(5) var<storage, read> live: array<u32>;

// The shared passes run over the live probes: `probe_slots()` of them, the k-th in slot
// `probe_slot(k)`.
fn probe_slots() -> u32 {
    return live[LIVE_COUNT];
}

fn probe_slot(k: u32) -> u32 {
    return live[LIVE_FIRST + k];
}

fn probe_origin(probe: u32) -> vec3<f32> {
    return probe_info[probe].position;
}

fn probe_live(probe: u32) -> bool {
    return probe_info[probe].depth >= 0.0;
}

fn probe_wants_place(probe: u32) -> bool {
    return probe_live(probe) && (place_flags[probe] != 0u || O.place_all != 0u);
}

// Whether the probe starts its history afresh this frame: the state machine asked for its
// surfels (a new probe, or one whose cube moving geometry crossed), until `light_decide`
// clears the flag at the end of the frame's probe passes. Its slot may have held another
// probe, so both its surfel sets are traced and its history and depth maps made anew.
fn probe_restarts(probe: u32) -> bool {
    return place_flags[probe] != 0u;
}

// Edge of the probe's leaf cube.
fn probe_edge(probe: u32) -> f32 {
    return ldexp(O.root_size, -i32(probe_info[probe].depth));
}

// Distance from the probe (its cube's centre) along unit d to its cube's boundary.
fn probe_region_exit(probe: u32, d: vec3<f32>) -> f32 {
    let t = vec3<f32>(probe_edge(probe) * 0.5) / max(abs(d), vec3<f32>(1e-20));
    return min(t.x, min(t.y, t.z));
}

fn probe_keeps_far_hits() -> bool {
    return O.keep_outside != 0u;
}

fn probe_store_hits(probe: u32, inside: u32) {
    hits[probe] = inside;
}
