// What every probe pass shares (gi/probes/engine.rs): the parameters (binding 0 of every
// pass), the buffer layouts, what a ray structure reports. A probe set (grid.wgsl or
// octree_set.wgsl, composed in as `gi/probes/set`, with its irradiance lookup as
// `gi/probes/set_sample`) gives the probes' positions.

struct ProbeParams {
    // xyz: lower corner of the scene's box; w: max ray distance
    lo: vec4<f32>,
    // xyz: grid probe spacing per axis; w: gather offset along the normal (m)
    spacing: vec4<f32>,
    // xyz: grid probes per axis; w: surfels per probe
    dims: vec4<u32>,
    // x: lattice kind, y: encoding kind, z: light count, w: 1 = surfels get probe light
    misc: vec4<u32>,
    // x: static BVH root (0xffffffff none), y: animated objects (BVH instances), z: probe
    // slots, w: surfel count
    roots: vec4<u32>,
    // x: most back-face hits of a probe still gathered; y: visibility (0 none, 1 moments);
    // z: moved boxes; w: 1 = placement keeps the surfels whose rays cross no moved box
    limits: vec4<u32>,
    // x: variance floor of the depth moments (m^2)
    vis: vec4<f32>,
    // x: this frame's number (1, 2, ...), which placement stamps on the probes it re-traces
    frame: vec4<u32>,
};

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> P: ProbeParams;

// What a ray structure reports for a surfel ray: distance (negative: no hit), the surface's
// normal as stored (not turned towards the ray; zero: none, the surface counts as seen
// head-on), packed RGBA8 albedo, emission.
struct SurfelHit {
    t: f32,
    normal: vec3<f32>,
    albedo: u32,
    emission: vec3<f32>,
};

// Words (vec4) per probe: 8 encoding coefficients, then (back-face share, hit share, valid, 0).
const PROBE_VEC4: u32 = 9u;
// vec4s per surfel: (position, state 0 miss / 1 front / 2 back), (normal towards the probe,
// albedo bits), (emission, hit distance; negative: the hit lies beyond the probe's cube).
const SURFEL_VEC4: u32 = 3u;

// One invocation per item over a 2D grid of 64-wide workgroups (more than 65535 groups).
fn linear_index(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + li;
}

// DDGI's smooth back-face weight ((1 + cos)/2)^2 + 0.2 of a probe at `to_probe` from a
// point with unit normal n.
fn probe_facing_weight(to_probe: vec3<f32>, n: vec3<f32>) -> f32 {
    let len = length(to_probe);
    let facing = select(1.0, (dot(to_probe / len, n) + 1.0) * 0.5, len > 1e-6);
    return facing * facing + 0.2;
}
