// The probe set of `probes-grid` (gi/probes/grid_gi.rs): probes at the cell centres of a uniform
// grid; every probe is live and re-placed whenever placement runs.

import octolux::gi::probes::probes::P;

fn probe_coord(probe: u32) -> vec3<u32> {
    let d = P.dims;
    return vec3<u32>(probe % d.x, (probe / d.x) % d.y, probe / (d.x * d.y));
}

fn probe_position(c: vec3<u32>) -> vec3<f32> {
    return P.lo + (vec3<f32>(c) + 0.5) * P.spacing;
}

fn probe_origin(probe: u32) -> vec3<f32> {
    return probe_position(probe_coord(probe));
}

fn probe_live(probe: u32) -> bool {
    return true;
}

// The shared passes run over every probe: the k-th is probe k.
fn probe_slots() -> u32 {
    return P.probe_slots;
}

fn probe_slot(k: u32) -> u32 {
    return k;
}

fn probe_wants_place(probe: u32) -> bool {
    return true;
}

// Whether the probe starts its history afresh this frame: never on the grid, whose probes
// stay where they are.
fn probe_restarts(probe: u32) -> bool {
    return false;
}

// Distance from the probe along unit d to the end of its region, and whether hits beyond it
// are kept as surfels: the grid's probes see the whole scene.
fn probe_region_exit(probe: u32, d: vec3<f32>) -> f32 {
    return 3.0e38;
}

fn probe_keeps_far_hits() -> bool {
    return true;
}

fn probe_store_hits(probe: u32, inside: u32) {}
