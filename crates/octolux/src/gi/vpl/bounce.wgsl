// Second and third bounce VPLs (002 §3.2: "adding second-bounce VPL sampling from first-bounce
// VPLs"), spawned through the octree. Every VPL of the source generation (flux Phi, normal n)
// casts one ray in a cosine-distributed direction about n; the first occupied voxel the walk
// meets becomes a VPL at the voxel's centre with the voxel's mean normal (turned towards the
// ray) and flux Phi x the voxel's mean albedo. A Lambertian emitter sends its flux out with
// the density cos / pi, so one cosine-sampled ray carries all of Phi: the new generation's
// flux is an unbiased estimate of the light the source generation's surfaces reflect once more.
// Rays that leave the grid, or hit a voxel without fragments, give a zero VPL.

import octolux::voxel::svo::walk::{svo_first_hit, svo_voxel_sums, vo, vpl_fixed_point};
import octolux::gi::vpl::vpl::Vpl;

struct BounceParams {
    // VPLs per generation, first VPL of the source generation.
    count: u32,
    source: u32,
    pad0: u32,
    pad1: u32,
};


@group(0) @binding(5) var<storage, read_write> vpls: array<Vpl>;
@group(0) @binding(6) var<storage, read> bp: BounceParams;

@compute @workgroup_size(64)
fn bounce(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= bp.count {
        return;
    }
    let src = vpls[bp.source + i];
    var out: Vpl;
    out.position = vec3<f32>(0.0);
    out.area = 0.0;
    out.normal = vec3<f32>(0.0);
    out.flux = vec3<f32>(0.0);
    out.mean_flux = 0.0;
    let dst = bp.source + bp.count + i;
    if src.mean_flux <= 0.0 {
        vpls[dst] = out;
        return;
    }
    // Cosine-distributed direction from the R2 low-discrepancy sequence (per generation).
    let r = fract(vec2<f32>(0.7548776662, 0.5698402910) * f32(i + bp.source) + 0.5);
    let n = src.normal;
    let t = normalize(select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9));
    let u = normalize(cross(t, n));
    let w = cross(n, u);
    let phi = 6.283185307 * r.x;
    let sin_t = sqrt(r.y);
    let dir = normalize(u * (cos(phi) * sin_t) + w * (sin(phi) * sin_t) + n * sqrt(max(0.0, 1.0 - r.y)));
    // The ray to the grid's boundary (the grid keeps a voxel of margin around the scene).
    let lo = vo.origin;
    let hi = vo.origin + vec3<f32>(f32(1u << vo.depth) * vo.voxel);
    let p = src.position;
    let safe = select(vec3<f32>(-1e-12), vec3<f32>(1e-12), dir >= vec3<f32>(0.0));
    let exits = (select(lo, hi, dir >= vec3<f32>(0.0)) - p) / (dir + safe);
    let ray_len = max(min(exits.x, min(exits.y, exits.z)) - 0.5 * vo.voxel, 0.0);
    let a = vpl_fixed_point(p, n);
    let end = p + dir * ray_len;
    // `vpl_fixed_point` moves a point along its normal: cancel that for the far end.
    let b = vpl_fixed_point(end - n * (vo.end_offset * vo.voxel), n);
    let hit = svo_first_hit(a, b);
    if hit.w == 0 {
        vpls[dst] = out;
        return;
    }
    let s = svo_voxel_sums(hit.xyz);
    if s.count == 0u {
        vpls[dst] = out;
        return;
    }
    let albedo = vec3<f32>(s.albedo) / (255.0 * f32(s.count));
    let ns = vec3<f32>(s.normal);
    var nv = ns / max(length(ns), 1e-6);
    if dot(nv, dir) > 0.0 {
        nv = -nv;
    }
    if dot(nv, nv) < 0.5 {
        nv = -dir;
    }
    let flux = src.flux * albedo;
    // Area 0: the shading bounds a bounce VPL by the clamp alone (what patch of surface a
    // hit stands for is not known).
    out.position = vo.origin + (vec3<f32>(hit.xyz) + 0.5) * vo.voxel;
    out.area = 0.0;
    out.normal = nv;
    out.flux = flux;
    out.mean_flux = (flux.r + flux.g + flux.b) / 3.0;
    vpls[dst] = out;
}
