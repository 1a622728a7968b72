// Surfel rays through the scene's two-level BVH (`rays = "bvh"`, bvh.wgsl): the closest
// triangle, its geometric normal, albedo and emission; exact.

@group(0) @binding(2) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(3) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(4) var<storage, read> bvh_instances: array<BvhInstance>;

fn surfel_hit(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> SurfelHit {
    let hit = bvh_closest(P.roots.xy, o, d, t_max);
    if hit.tri == BVH_MISS {
        return SurfelHit(-1.0, vec3<f32>(0.0), 0u, vec3<f32>(0.0));
    }
    let tri = bvh_tris[hit.tri];
    return SurfelHit(hit.t, bvh_hit_normal(hit), bitcast<u32>(tri.p0.w), tri.emission.rgb);
}
