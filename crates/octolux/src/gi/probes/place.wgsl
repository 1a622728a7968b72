// Surfel placement: one ray per surfel from its probe along its lattice direction; the
// closest hit becomes the surfel (position, normal facing the probe, albedo, emission),
// marked front or back face, or a miss. The ray structure (place_bvh.wgsl or
// place_voxels.wgsl, gi/probes/rays.rs) provides `surfel_hit` and its bindings from 2 on.
// Only probes the probe set asks for are placed; a hit beyond the probe's region (the
// octree's cube) is marked by a negative distance, or is a miss where the set keeps no far
// hits.

@group(0) @binding(0) var<storage, read> P: ProbeParams;
@group(0) @binding(1) var<storage, read_write> surfels: array<vec4<f32>>;

// What a ray structure reports for a surfel ray: distance (negative: no hit), the surface's
// normal as stored (not turned towards the ray; zero: none, the surface counts as seen
// head-on), packed RGBA8 albedo, emission.
struct SurfelHit {
    t: f32,
    normal: vec3<f32>,
    albedo: u32,
    emission: vec3<f32>,
};

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let s = linear_index(wg, nwg, li);
    if s >= P.roots.w {
        return;
    }
    let n = P.dims.w;
    let probe = s / n;
    if !probe_wants_place(probe) {
        return;
    }
    let d = lattice_dir(P.misc.x, s % n, n).xyz;
    let o = probe_origin(probe);
    let hit = surfel_hit(o, d, P.lo.w);
    let inside = hit.t <= probe_region_exit(probe, d);
    let b = s * SURFEL_VEC4;
    if hit.t < 0.0 || !(inside || probe_keeps_far_hits()) {
        surfels[b] = vec4<f32>(o, 0.0);
        surfels[b + 1u] = vec4<f32>(0.0);
        surfels[b + 2u] = vec4<f32>(0.0);
        return;
    }
    let geo = select(-d, hit.normal, dot(hit.normal, hit.normal) > 0.5);
    let front = dot(geo, d) < 0.0;
    surfels[b] = vec4<f32>(o + d * hit.t, select(2.0, 1.0, front));
    surfels[b + 1u] = vec4<f32>(select(-geo, geo, front), bitcast<f32>(hit.albedo));
    surfels[b + 2u] = vec4<f32>(hit.emission, select(-hit.t, hit.t, inside));
}
