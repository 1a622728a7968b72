// Rays through the scene's sparse voxel octree (`rays = "voxels"`): the ray clipped to the
// octree's grid and turned into lattice ends for the VPL technique's integer walk
// (voxel/svo/walk.wgsl, whose bindings it reads), and the surfel of the first occupied voxel
// it meets. CPU twin: `rays::voxel_surfel`.

import octolux::voxel::svo::walk::{svo_first_hit, svo_voxel_sums, vo, vpl_fixed_point};
import octolux::voxel::svo::leaf_sums::LEAF_EMISSION_SCALE;

// The ray o + t d, t in [0, t_max], clipped to the octree's grid: (t_in, t_out), empty when
// t_in > t_out.
fn voxel_ray_span(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec2<f32> {
    let hi = vo.origin + vec3<f32>(f32(1u << vo.depth) * vo.voxel);
    let span = voxel_ray_span_box(o, d, vo.origin, hi);
    return vec2<f32>(span.x, min(span.y, t_max));
}

// The lattice ends of the walk for the ray o + t d up to t_max (xyz of each), w = 1 where the
// ray meets the grid at all. Shared with the test kernel, so the CPU twin walks the same ends.
struct VoxelRay {
    a: vec4<i32>,
    b: vec4<i32>,
};

fn voxel_ray(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> VoxelRay {
    let span = voxel_ray_span(o, d, t_max);
    let zero = vec3<f32>(0.0);
    let a = vpl_fixed_point(o + d * span.x, zero);
    let b = vpl_fixed_point(o + d * span.y, zero);
    return VoxelRay(vec4<i32>(a, i32(span.x <= span.y)), vec4<i32>(b, 0));
}

// A surfel's hit through the voxels: the voxel, distance along d (negative: none), normal as
// stored (zero where the fragments' normals cancel), packed albedo, emission.
struct VoxelHit {
    voxel: vec3<i32>,
    t: f32,
    normal: vec3<f32>,
    albedo: u32,
    emission: vec3<f32>,
};

// The first occupied voxel along the ray o + t d whose walk is `ray`.
fn voxel_closest(o: vec3<f32>, d: vec3<f32>, ray: VoxelRay) -> VoxelHit {
    var hit = VoxelHit(vec3<i32>(0), -1.0, vec3<f32>(0.0), 0u, vec3<f32>(0.0));
    if ray.a.w == 0 {
        return hit;
    }
    let v = svo_first_hit(ray.a.xyz, ray.b.xyz);
    if v.w == 0 {
        return hit;
    }
    let s = svo_voxel_sums(v.xyz);
    if s.count == 0u {
        return hit;
    }
    hit.voxel = v.xyz;
    // The mean albedo x255 rounded in integers, so that every adapter packs the same bits.
    let count = s.count;
    let albedo = (s.albedo + vec3<u32>(count / 2u)) / count;
    hit.albedo = albedo.r | (albedo.g << 8u) | (albedo.b << 16u) | (255u << 24u);
    let c = f32(count);
    hit.emission = vec3<f32>(s.emission) / (c * LEAF_EMISSION_SCALE);
    let ns = vec3<f32>(s.normal);
    // Opposite faces in one voxel cancel: no normal (as the octree's injection decides).
    if dot(ns, ns) > 0.01 * c * c * 127.0 * 127.0 {
        hit.normal = normalize(ns);
    }
    // Where the ray crosses the voxel, and where it meets the voxel's plane within that.
    let lo = vo.origin + vec3<f32>(v.xyz) * vo.voxel;
    let span = voxel_ray_span_box(o, d, lo, lo + vec3<f32>(vo.voxel));
    var t = span.x;
    let facing = dot(d, hit.normal);
    if abs(facing) > 1e-3 {
        t = dot(lo + vec3<f32>(0.5 * vo.voxel) - o, hit.normal) / facing;
    }
    hit.t = clamp(t, span.x, max(span.x, span.y));
    return hit;
}

// The ray o + t d, t >= 0, through the box lo..hi: (t_in, t_out).
fn voxel_ray_span_box(o: vec3<f32>, d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let inv = 1.0 / select(d, vec3<f32>(1e-30), d == vec3<f32>(0.0));
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let t0 = min(a, b);
    let t1 = max(a, b);
    return vec2<f32>(max(0.0, max(t0.x, max(t0.y, t0.z))), min(t1.x, min(t1.y, t1.z)));
}

