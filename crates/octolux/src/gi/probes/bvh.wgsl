// BVH traversal (gi/probes/bvh.rs, whose `Bvh::closest` and `Bvh::occluded` are the CPU
// twins, step for step). The includer declares
//   bvh_nodes: array<BvhNode>, bvh_tris: array<BvhTri>
// Nodes: inner (b == 0): left child = this + 1, right child = a; leaf: triangles a .. a + b.

struct BvhNode {
    min: vec3<f32>,
    a: u32,
    max: vec3<f32>,
    b: u32,
};

struct BvhTri {
    // xyz vertex 0, w: packed RGBA8 albedo
    p0: vec4<f32>,
    e1: vec4<f32>,
    e2: vec4<f32>,
    // rgb emitted radiance
    emission: vec4<f32>,
};

struct BvhHit {
    // triangle index, or 0xffffffff for a miss
    tri: u32,
    t: f32,
    u: f32,
    v: f32,
};

const BVH_MISS: u32 = 0xffffffffu;
const BVH_STACK: u32 = 42u; // MAX_DEPTH + 2 in bvh.rs
const BVH_MIN_DIR: f32 = 1e-8;

fn bvh_safe_dir(d: vec3<f32>) -> vec3<f32> {
    let s = select(vec3<f32>(BVH_MIN_DIR), vec3<f32>(-BVH_MIN_DIR), d < vec3<f32>(0.0));
    return select(d, s, abs(d) < vec3<f32>(BVH_MIN_DIR));
}

// Entry distance into node `i`'s box, or -1 if the ray does not enter it before t_max.
fn bvh_slab(i: u32, o: vec3<f32>, inv: vec3<f32>, t_max: f32) -> f32 {
    let node = bvh_nodes[i];
    let t0 = (node.min - o) * inv;
    let t1 = (node.max - o) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    let near = max(max(max(lo.x, lo.y), lo.z), 0.0);
    let far = min(min(min(hi.x, hi.y), hi.z), t_max);
    return select(-1.0, near, near <= far);
}

// Möller-Trumbore as in the reference: (t, u, v, 1) for a hit with t in (0, t_max), else w = 0.
fn bvh_intersect(i: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec4<f32> {
    let tri = bvh_tris[i];
    let e1 = tri.e1.xyz;
    let e2 = tri.e2.xyz;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if abs(det) < 1e-12 {
        return vec4<f32>(0.0);
    }
    let inv = 1.0 / det;
    let s = o - tri.p0.xyz;
    let u = dot(s, p) * inv;
    if u < 0.0 || u > 1.0 {
        return vec4<f32>(0.0);
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return vec4<f32>(0.0);
    }
    let t = dot(e2, q) * inv;
    if t > 0.0 && t < t_max {
        return vec4<f32>(t, u, v, 1.0);
    }
    return vec4<f32>(0.0);
}

// Closest hit (any_hit false) or the first hit found (any_hit true) in the BVH at `root`.
fn bvh_trace(root: u32, o: vec3<f32>, d: vec3<f32>, t_max_in: f32, any_hit: bool) -> BvhHit {
    var best = BvhHit(BVH_MISS, t_max_in, 0.0, 0.0);
    if root == BVH_MISS {
        return best;
    }
    let inv = 1.0 / bvh_safe_dir(d);
    var stack: array<u32, BVH_STACK>;
    stack[0] = root;
    var top = 1u;
    while top > 0u {
        top -= 1u;
        let index = stack[top];
        if bvh_slab(index, o, inv, best.t) < 0.0 {
            continue;
        }
        let node = bvh_nodes[index];
        if node.b > 0u {
            for (var i = node.a; i < node.a + node.b; i++) {
                let h = bvh_intersect(i, o, d, best.t);
                if h.w > 0.0 {
                    best = BvhHit(i, h.x, h.y, h.z);
                    if any_hit {
                        return best;
                    }
                }
            }
            continue;
        }
        let left = index + 1u;
        let right = node.a;
        let tl = bvh_slab(left, o, inv, best.t);
        let tr = bvh_slab(right, o, inv, best.t);
        // Farther child first, so the nearer one is popped next.
        if tl >= 0.0 && tr >= 0.0 {
            if tr < tl {
                stack[top] = left;
                stack[top + 1u] = right;
            } else {
                stack[top] = right;
                stack[top + 1u] = left;
            }
            top += 2u;
        } else if tl >= 0.0 {
            stack[top] = left;
            top += 1u;
        } else if tr >= 0.0 {
            stack[top] = right;
            top += 1u;
        }
    }
    return best;
}

// Closest hit over the parts whose roots are `roots` (BVH_MISS: no such part).
fn bvh_closest(roots: vec2<u32>, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> BvhHit {
    let a = bvh_trace(roots.x, o, d, t_max, false);
    let b = bvh_trace(roots.y, o, d, a.t, false);
    if b.tri != BVH_MISS {
        return b;
    }
    return a;
}

// Whether any triangle of the parts at `roots` lies on o + t d, t in (0, t_max).
fn bvh_occluded(roots: vec2<u32>, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    return bvh_trace(roots.x, o, d, t_max, true).tri != BVH_MISS
        || bvh_trace(roots.y, o, d, t_max, true).tri != BVH_MISS;
}

// Unit albedo (linear) of triangle `i`.
fn bvh_albedo(i: u32) -> vec3<f32> {
    return unpack4x8unorm(bitcast<u32>(bvh_tris[i].p0.w)).rgb;
}

// Unit geometric normal (the winding's) of triangle `i`.
fn bvh_normal(i: u32) -> vec3<f32> {
    let t = bvh_tris[i];
    return normalize(cross(t.e1.xyz, t.e2.xyz));
}
