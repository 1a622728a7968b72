// Second and third bounce VPLs (002 §3.2: "adding second-bounce VPL sampling from first-bounce
// VPLs"), spawned through the octree. Every VPL of the source generation (flux Phi, normal n)
// casts one ray in a cosine-distributed direction about n; the first occupied voxel the walk
// meets becomes a VPL at the voxel's centre with the voxel's mean normal (turned towards the
// ray) and flux Phi x the voxel's mean albedo. A Lambertian emitter sends its flux out with
// the density cos / pi, so one cosine-sampled ray carries all of Phi: the new generation's
// flux is an unbiased estimate of the light the source generation's surfaces reflect once more.
// Rays that leave the grid, or hit a voxel without fragments, give a zero VPL.

struct BounceParams {
    // VPLs per generation, first VPL of the source generation.
    count: u32,
    source: u32,
    pad0: u32,
    pad1: u32,
};

struct Vpl {
    position: vec4<f32>,
    normal: vec4<f32>,
    flux: vec4<f32>,
};

@group(0) @binding(0) var<storage, read> vo: VplOctree;
@group(0) @binding(1) var<storage, read> svo_child: array<u32>;
@group(0) @binding(2) var<storage, read> svo_leaf: array<u32>;
@group(0) @binding(3) var<storage, read> svo_state: array<u32>;
@group(0) @binding(4) var<storage, read> svo_dyn_sums: array<u32>;
@group(0) @binding(5) var<storage, read_write> vpls: array<Vpl>;
@group(0) @binding(6) var<storage, read> bp: BounceParams;

const SUM_WORDS: u32 = 10u;

// Fragment sums of voxel v (static and dynamic): albedo x255 (xyz) and count (w), and the
// snorm8 normal sums.
struct VoxelSums {
    albedo_count: vec4<f32>,
    normal: vec3<f32>,
};

fn add_sums(s: ptr<function, VoxelSums>, w: u32, dynamic: bool) {
    var k = array<u32, 10>();
    for (var i = 0u; i < SUM_WORDS; i++) {
        k[i] = select(svo_leaf[w + i], svo_dyn_sums[w + i], dynamic);
    }
    (*s).albedo_count += vec4<f32>(f32(k[0]), f32(k[1]), f32(k[2]), f32(k[3]));
    (*s).normal += vec3<f32>(f32(bitcast<i32>(k[7])), f32(bitcast<i32>(k[8])), f32(bitcast<i32>(k[9])));
}

fn voxel_sums(v: vec3<i32>) -> VoxelSums {
    var s = VoxelSums(vec4<f32>(0.0), vec3<f32>(0.0));
    var node = 0u;
    var k = vo.depth;
    while k > 1u {
        let c = svo_child[node];
        if c == 0u {
            return s;
        }
        k -= 1u;
        let o = (v >> vec3<u32>(k)) & vec3<i32>(1);
        node = c + u32(o.x | (o.y << 1u) | (o.z << 2u));
    }
    let o = u32((v.x & 1) | ((v.y & 1) << 1u) | ((v.z & 1) << 2u));
    let leaf = node - vo.first_leaf;
    if leaf < vo.leaf_count {
        let entry = svo_leaf[leaf];
        let mask = entry & 255u;
        if (mask & (1u << o)) != 0u {
            let slot = (entry >> 8u) + countOneBits(mask & ((1u << o) - 1u));
            add_sums(&s, vo.leaf_count + slot * SUM_WORDS, false);
        }
    }
    if vo.dynamic != 0u {
        let slot = svo_state[node] >> 2u;
        if slot != 0u {
            add_sums(&s, ((slot - 1u) * 8u + o) * SUM_WORDS, true);
        }
    }
    return s;
}

@compute @workgroup_size(64)
fn bounce(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= bp.count {
        return;
    }
    let src = vpls[bp.source + i];
    var out: Vpl;
    out.position = vec4<f32>(0.0);
    out.normal = vec4<f32>(0.0);
    out.flux = vec4<f32>(0.0);
    let dst = bp.source + bp.count + i;
    if src.flux.w <= 0.0 {
        vpls[dst] = out;
        return;
    }
    // Cosine-distributed direction from the R2 low-discrepancy sequence (per generation).
    let r = fract(vec2<f32>(0.7548776662, 0.5698402910) * f32(i + bp.source) + 0.5);
    let n = src.normal.xyz;
    let t = normalize(select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9));
    let u = normalize(cross(t, n));
    let w = cross(n, u);
    let phi = 6.283185307 * r.x;
    let sin_t = sqrt(r.y);
    let dir = normalize(u * (cos(phi) * sin_t) + w * (sin(phi) * sin_t) + n * sqrt(max(0.0, 1.0 - r.y)));
    // The ray to the grid's boundary (the grid keeps a voxel of margin around the scene).
    let lo = vo.origin;
    let hi = vo.origin + vec3<f32>(f32(1u << vo.depth) * vo.voxel);
    let p = src.position.xyz;
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
    let s = voxel_sums(hit.xyz);
    if s.albedo_count.w <= 0.0 {
        vpls[dst] = out;
        return;
    }
    let albedo = s.albedo_count.rgb / (255.0 * s.albedo_count.w);
    var nv = s.normal / max(length(s.normal), 1e-6);
    if dot(nv, dir) > 0.0 {
        nv = -nv;
    }
    if dot(nv, nv) < 0.5 {
        nv = -dir;
    }
    let flux = src.flux.rgb * albedo;
    out.position = vec4<f32>(vo.origin + (vec3<f32>(hit.xyz) + 0.5) * vo.voxel, 0.0);
    out.normal = vec4<f32>(nv, 0.0);
    out.flux = vec4<f32>(flux, (flux.r + flux.g + flux.b) / 3.0);
    vpls[dst] = out;
}
