// Surfel rays through the scene's two-level BVH (`rays = "bvh"`, bvh.wgsl): the closest
// triangle, its geometric normal, albedo and emission; exact.

import octolux::gi::probes::probes::{P, SurfelHit};
import octolux::gi::probes::bvh::{bvh_closest, bvh_hit_normal, BVH_MISS, bvh_tris, count_bvh_work};

fn surfel_hit(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> SurfelHit {
    let hit = bvh_closest(vec2<u32>(P.static_root, P.instance_count), o, d, t_max);
    if hit.tri == BVH_MISS {
        return SurfelHit(-1.0, vec3<f32>(0.0), 0u, vec3<f32>(0.0));
    }
    let tri = bvh_tris[hit.tri];
    return SurfelHit(hit.t, bvh_hit_normal(hit), tri.albedo, tri.emission);
}

// Adds the rays' work to quantities q and q + 1 of the pass's counts (`PLACE_BVH_WORK` in
// engine.rs): BVH nodes visited, triangles tested.
fn count_ray_work(q: u32) {
    count_bvh_work(q, q + 1u);
}
