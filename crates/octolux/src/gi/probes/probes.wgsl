// What every probe pass shares (gi/probes/engine.rs): the parameters (binding 0 of every
// pass), the buffer layouts, what a ray structure reports. A probe set (grid.wgsl or
// octree_set.wgsl, composed in as `gi/probes/set`, with its irradiance lookup as
// `gi/probes/set_sample`) gives the probes' positions.

import octolux::gi::probes::lattice::lattice_dir;

struct ProbeParams {
    // Lower corner of the scene's box (of the probe grid's lattice)
    lo: vec3<f32>,
    // Longest surfel ray (m): a miss's distance
    max_distance: f32,
    // Grid probe spacing per axis
    spacing: vec3<f32>,
    // Gather offset along the normal (m)
    normal_offset: f32,
    // Grid probes per axis
    dims: vec3<u32>,
    // Surfels per probe and set (rays of one lattice)
    surfels_per_set: u32,
    // Lattice kind (`Lattice::gpu_kind`)
    lattice: u32,
    // Encoding kind (`Encoding::gpu_kind`)
    encoding: u32,
    // Lights this frame
    light_count: u32,
    // 1 = surfels get probe light
    multi_bounce: u32,
    // Static BVH root (0xffffffff none)
    static_root: u32,
    // Animated objects (BVH instances)
    instance_count: u32,
    // Probe slots
    probe_slots: u32,
    // Surfels over all probes and sets
    surfel_count: u32,
    // Most back-face hits of a probe still gathered
    max_back_faces: u32,
    // Visibility (0 none, 1 moments)
    visibility: u32,
    // Moved boxes
    moved_boxes: u32,
    // 1 = placement keeps the surfels whose rays cross no moved box
    keep_unmoved: u32,
    // Variance floor of the depth moments (m^2)
    variance_floor: f32,
    // Weight of the depth maps' history
    moments_keep: f32,
    // Scale of last frame's probe light in the surfels' (the lights' power now over then, at
    // most 1)
    bounce_scale: f32,
    // Forgetting strength
    forgetting: f32,
    // This frame's number (1, 2, ...), which placement stamps on the probes it re-traces
    frame: u32,
    // Surfel sets (probes-grid's accumulation over frames, docs/probes.md "Rays that turn
    // every frame"): sets per probe (1: one fixed lattice, no history; 2: the lattice turned
    // anew each frame into one set, the other set the previous frame's)
    set_count: u32,
    // The set placed most recently
    latest_set: u32,
    // 1 = set `latest_set` was placed this frame (a new sample)
    latest_placed: u32,
    // Most frames a probe's history holds
    max_history: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    // Rows of the rotation that turns each set's lattice (w unused): set 0's, then set 1's.
    // Made on the CPU (`lattice::frame_rotation`): the GPU only multiplies.
    rot: array<vec4<f32>, 6>,
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
// One surfel: where a probe's ray hit (`GpuSurfel` in engine.rs; 3 vec4s, `SURFEL_VEC4`).
struct Surfel {
    position: vec3<f32>,
    // SURFEL_MISS, SURFEL_FRONT or SURFEL_BACK (the face the ray hit). A float, as the CPU
    // twins (`integrate_probe`) read it.
    state: f32,
    // Unit normal, towards the probe.
    normal: vec3<f32>,
    // Linear albedo x 255 as RGBA8.
    albedo: u32,
    // Emitted radiance, W/(m^2 sr).
    emission: vec3<f32>,
    // Hit distance; negative: the hit lies beyond the probe's cube.
    distance: f32,
};
const SURFEL_MISS: f32 = 0.0;
const SURFEL_FRONT: f32 = 1.0;
const SURFEL_BACK: f32 = 2.0;
// vec4s per surfel, for the buffer's size.
const SURFEL_VEC4: u32 = 3u;

// Surfels per probe over all its sets.
fn probe_surfels() -> u32 {
    return P.surfels_per_set * P.set_count;
}

// Direction k of n of surfel set `ray_set` and its solid angle: the lattice turned by the set's
// rotation (the identity on the first frame, so that a single frame sees the plain lattice:
// 1 x + 0 y + 0 z is exact on every adapter).
fn probe_ray_dir(ray_set: u32, k: u32, n: u32) -> vec4<f32> {
    let d = lattice_dir(P.lattice, k, n);
    let r = 3u * min(ray_set, 1u);
    return vec4<f32>(dot(P.rot[r].xyz, d.xyz), dot(P.rot[r + 1u].xyz, d.xyz), dot(P.rot[r + 2u].xyz, d.xyz), d.w);
}

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
