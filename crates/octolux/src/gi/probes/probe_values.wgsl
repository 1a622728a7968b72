// A probe's stored values, read at binding 3 by the passes that sample the probes (the
// integration writes them through its own binding).

import octolux::gi::probes::probes::PROBE_VEC4;

@group(0) @binding(3) var<storage, read> probes: array<vec4<f32>>;

fn probe_coeffs(probe: u32) -> array<vec3<f32>, 8> {
    let b = probe * PROBE_VEC4;
    return array<vec3<f32>, 8>(probes[b].xyz, probes[b + 1u].xyz, probes[b + 2u].xyz, probes[b + 3u].xyz,
        probes[b + 4u].xyz, probes[b + 5u].xyz, probes[b + 6u].xyz, probes[b + 7u].xyz);
}

fn probe_valid(probe: u32) -> bool {
    return probes[probe * PROBE_VEC4 + 8u].z >= 0.5;
}
