// A probe's stored values, read at binding 3 by the passes that sample the probes (the
// integration writes them through its own binding).

import octolux::gi::probes::encoding::probe_irradiance;
import octolux::gi::probes::probes::{P, PROBE_VEC4};

@group(0) @binding(3) var<storage, read> probes: array<vec4<f32>>;

// The irradiance probe `probe` holds for unit normal n. SH L1 (kind 1) reads only its four
// coefficients: loading the other four of the 8-bin layout for nothing doubled the bytes every
// probe lookup (8 per pixel or surfel) asked for.
fn probe_irradiance_at(probe: u32, n: vec3<f32>) -> vec3<f32> {
    let b = probe * PROBE_VEC4;
    let zero = vec3<f32>(0.0);
    if P.encoding == 1u {
        let c = array<vec3<f32>, 8>(probes[b].xyz, probes[b + 1u].xyz, probes[b + 2u].xyz,
            probes[b + 3u].xyz, zero, zero, zero, zero);
        return probe_irradiance(1u, c, n);
    }
    let c = array<vec3<f32>, 8>(probes[b].xyz, probes[b + 1u].xyz, probes[b + 2u].xyz, probes[b + 3u].xyz,
        probes[b + 4u].xyz, probes[b + 5u].xyz, probes[b + 6u].xyz, probes[b + 7u].xyz);
    return probe_irradiance(P.encoding, c, n);
}

fn probe_valid(probe: u32) -> bool {
    return probes[probe * PROBE_VEC4 + 8u].z >= 0.5;
}
