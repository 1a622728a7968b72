// The probe grid and its buffers, shared by the probe passes (gi/probes/grid.rs). The includer
// declares `P: ProbeParams`.

struct ProbeParams {
    // xyz: lower corner of the grid's box; w: max ray distance
    lo: vec4<f32>,
    // xyz: probe spacing per axis; w: gather offset along the normal (m)
    spacing: vec4<f32>,
    // xyz: probes per axis; w: surfels per probe
    dims: vec4<u32>,
    // x: lattice kind, y: encoding kind, z: light count, w: 1 = surfels get probe light
    misc: vec4<u32>,
    // x, y: BVH roots (static, animated; 0xffffffff none), z: probe count, w: surfel count
    roots: vec4<u32>,
    // x: most back-face hits of a probe still gathered
    limits: vec4<u32>,
};

// Words (vec4) per probe: 8 encoding coefficients, then (back-face share, hit share, valid, 0).
const PROBE_VEC4: u32 = 9u;
// vec4s per surfel: (position, state 0 miss / 1 front / 2 back), (normal towards the probe,
// albedo bits), (emission, hit distance).
const SURFEL_VEC4: u32 = 3u;

// One invocation per item over a 2D grid of 64-wide workgroups (more than 65535 groups).
fn linear_index(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + li;
}

fn probe_coord(probe: u32) -> vec3<u32> {
    let d = P.dims.xyz;
    return vec3<u32>(probe % d.x, (probe / d.x) % d.y, probe / (d.x * d.y));
}

fn probe_position(c: vec3<u32>) -> vec3<f32> {
    return P.lo.xyz + (vec3<f32>(c) + 0.5) * P.spacing.xyz;
}

