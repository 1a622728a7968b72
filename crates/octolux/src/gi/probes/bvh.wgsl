// BVH traversal (gi/probes/bvh.rs, whose `Bvh::closest`, `Bvh::occluded` and
// `SceneBvh::closest` are the CPU twins, step for step). Its bindings (group 0, 2 to 4) are
// the nodes, triangles and instances (`gi/probes/bvh.rs`, `BVH_BINDINGS`).
// Nodes: inner (tri_count == 0): left child = this + 1, right child = right_or_first; leaf:
// triangles right_or_first .. right_or_first + tri_count.
// A two-level BVH: the static objects' BVH in world space, and one BVH per animated object
// in its model space, traversed with the ray moved into that space by the object's
// world-to-object transform of this frame (`bvh_instances`).

import octolux::gpu::work::count_work;

// `GpuNode` in bvh.rs.
struct BvhNode {
    min: vec3<f32>,
    // Inner node: the right child; leaf: the first triangle.
    right_or_first: u32,
    max: vec3<f32>,
    // 0 for an inner node, else the leaf's triangle count.
    tri_count: u32,
};

// `GpuTri` in bvh.rs: vertex 0 and the edges from it (Möller-Trumbore).
struct BvhTri {
    p0: vec3<f32>,
    // Linear albedo x 255 as RGBA8, red in the low byte.
    albedo: u32,
    e1: vec3<f32>,
    e2: vec3<f32>,
    // Emitted radiance, W/(m^2 sr).
    emission: vec3<f32>,
};

struct BvhHit {
    // triangle index, or 0xffffffff for a miss
    tri: u32,
    t: f32,
    u: f32,
    v: f32,
    // the animated object hit (index into bvh_instances), 0xffffffff for a static triangle
    instance: u32,
};

struct BvhInstance {
    // rows of the world-to-object matrix
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    root: u32,
    // -1 for a mirroring transform (flips the winding's normal)
    sign: f32,
    pad0: u32,
    pad1: u32,
};

@group(0) @binding(2) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(3) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(4) var<storage, read> bvh_instances: array<BvhInstance>;

// Work of the traversals of one invocation (`gpu/work.wgsl`): nodes visited (popped, their
// box entered) and triangles tested, kept only by a counting shader (`Bvh::closest_counted`
// counts the same); a pass adds them to its counts with `count_bvh_work`.
@if(count_work) var<private> bvh_work: vec2<u32>;

@if(count_work) fn note_bvh(nodes: u32, tris: u32) {
    bvh_work += vec2<u32>(nodes, tris);
}

@if(!count_work) fn note_bvh(nodes: u32, tris: u32) {}

// Adds this invocation's traversal work to quantities `nodes_q` and `tris_q` of the pass's
// counts.
@if(count_work) fn count_bvh_work(nodes_q: u32, tris_q: u32) {
    count_work(nodes_q, bvh_work.x);
    count_work(tris_q, bvh_work.y);
}

@if(!count_work) fn count_bvh_work(nodes_q: u32, tris_q: u32) {}

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
    let e1 = tri.e1;
    let e2 = tri.e2;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if abs(det) < 1e-12 {
        return vec4<f32>(0.0);
    }
    let inv = 1.0 / det;
    let s = o - tri.p0;
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
    var best = BvhHit(BVH_MISS, t_max_in, 0.0, 0.0, BVH_MISS);
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
        note_bvh(1u, 0u);
        let node = bvh_nodes[index];
        if node.tri_count > 0u {
            for (var i = node.right_or_first; i < node.right_or_first + node.tri_count; i++) {
                note_bvh(0u, 1u);
                let h = bvh_intersect(i, o, d, best.t);
                if h.w > 0.0 {
                    best = BvhHit(i, h.x, h.y, h.z, BVH_MISS);
                    if any_hit {
                        return best;
                    }
                }
            }
            continue;
        }
        let left = index + 1u;
        let right = node.right_or_first;
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

// The object-space point (w = 1) or direction (w = 0) of world `p` for instance `k`.
fn bvh_to_object(k: u32, p: vec4<f32>) -> vec3<f32> {
    let inst = bvh_instances[k];
    return vec3<f32>(dot(inst.row0, p), dot(inst.row1, p), dot(inst.row2, p));
}

// Closest hit: the static BVH at `roots.x` (BVH_MISS: none), then the `roots.y` animated
// objects in order, each up to the closest hit so far.
fn bvh_closest(roots: vec2<u32>, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> BvhHit {
    var best = bvh_trace(roots.x, o, d, t_max, false);
    for (var k = 0u; k < roots.y; k++) {
        let oo = bvh_to_object(k, vec4<f32>(o, 1.0));
        let dd = bvh_to_object(k, vec4<f32>(d, 0.0));
        let h = bvh_trace(bvh_instances[k].root, oo, dd, best.t, false);
        if h.tri != BVH_MISS {
            best = h;
            best.instance = k;
        }
    }
    return best;
}

// Whether any triangle lies on o + t d, t in (0, t_max) (`roots` as for `bvh_closest`).
fn bvh_occluded(roots: vec2<u32>, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    if bvh_trace(roots.x, o, d, t_max, true).tri != BVH_MISS {
        return true;
    }
    for (var k = 0u; k < roots.y; k++) {
        let oo = bvh_to_object(k, vec4<f32>(o, 1.0));
        let dd = bvh_to_object(k, vec4<f32>(d, 0.0));
        if bvh_trace(bvh_instances[k].root, oo, dd, t_max, true).tri != BVH_MISS {
            return true;
        }
    }
    return false;
}

// Unit world geometric normal of `hit`: the winding's, moved out of the object's space by
// the inverse transpose of its transform (the transpose of its world-to-object matrix).
fn bvh_hit_normal(hit: BvhHit) -> vec3<f32> {
    let n = bvh_normal(hit.tri);
    if hit.instance == BVH_MISS {
        return n;
    }
    let inst = bvh_instances[hit.instance];
    return normalize((inst.row0.xyz * n.x + inst.row1.xyz * n.y + inst.row2.xyz * n.z) * inst.sign);
}

// Unit albedo (linear) of triangle `i`.
fn bvh_albedo(i: u32) -> vec3<f32> {
    return unpack4x8unorm(bvh_tris[i].albedo).rgb;
}

// Unit geometric normal (the winding's) of triangle `i`.
fn bvh_normal(i: u32) -> vec3<f32> {
    let t = bvh_tris[i];
    return normalize(cross(t.e1, t.e2));
}
