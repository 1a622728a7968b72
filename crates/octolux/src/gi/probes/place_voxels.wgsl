// Surfel rays through the scene's sparse voxel octree (`rays = "voxels"`, voxel_rays.wgsl):
// the first occupied voxel along the ray, walked with the VPL technique's integer walk
// (voxel/svo/walk.wgsl); its fragments' mean albedo, emission and normal, at the point where
// the ray meets the plane through the voxel's centre with that normal, kept inside the
// voxel. No BVH is built; the result is exact only to a voxel.

import octolux::gi::probes::probes::SurfelHit;
import octolux::gi::probes::voxel_rays::{voxel_closest, voxel_ray};
import octolux::voxel::svo::walk::count_walk_work;

fn surfel_hit(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> SurfelHit {
    let hit = voxel_closest(o, d, voxel_ray(o, d, t_max));
    return SurfelHit(hit.t, hit.normal, hit.albedo, hit.emission);
}

// Adds the rays' work to quantities q and q + 1 of the pass's counts (`PLACE_VOXEL_WORK` in
// engine.rs): cells the walks visited, octree nodes their descents passed.
fn count_ray_work(q: u32) {
    count_walk_work(q, q + 1u);
}
