// Anisotropic (6-direction) values of the sparse voxel octree's nodes (Arnebäck 2017 §3.1.4).
// Every node is the voxel of its level; it gets 6 RGBA8 words (premultiplied albedo, opacity)
// for travel along +x, -x, +y, -y, +z, -z, stored per brick: word (brick_index[node] - 1) * 6
// + direction. Nodes without a brick hold no occupied voxel and are zero (they have no words).
//
// Direction +x composites the two finer values met one after the other along x, front to
// back (c = c_front + (1 - a_front) c_back, rounded integer arithmetic), and averages the 4
// pairs across y and z, as the clipmap's anisotropic voxels do (`clipmap/filter.wgsl`). On the
// finest level the finer values are the node's 8 voxels (`leaf_voxel`, isotropic); above, its
// 8 children's values for the same direction (a child without a brick is transparent zero).
// One dispatch per level, finest first.

import octolux::voxel::svo::leaf_sums::leaf_sum_offset;
import octolux::voxel::pairs::pair_along;

// One level's parameters (`AnisoParams` in svo/aniso.rs).
struct AnisoParams {
    // The level's nodes [first, first + count).
    first: u32,
    count: u32,
    // The first leaf node.
    first_leaf: u32,
    // 1 on the leaf level.
    leaf: u32,
    // Static leaf nodes (the index words at the start of `leaf_sums`, svo/leaf_sums.wgsl).
    static_leaves: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> P: AnisoParams;
@group(0) @binding(1) var<storage, read> child: array<u32>;
@group(0) @binding(2) var<storage, read> brick_index: array<u32>;
@group(0) @binding(3) var<storage, read> leaf_sums: array<u32>;
@group(0) @binding(4) var<storage, read_write> aniso: array<u32>;


// The isotropic value of voxel `octant` (x + 2y + 4z) of leaf node `node`: the rounded
// integer mean of its fragments' albedo, opacity 1; zero when no fragment touches it.
fn leaf_voxel(node: u32, octant: u32) -> vec4<f32> {
    let w = leaf_sum_offset(leaf_sums[node - P.first_leaf], octant, P.static_leaves);
    if w == 0xffffffffu {
        return vec4<f32>(0.0);
    }
    let count = leaf_sums[w + 3u];
    if count == 0u {
        return vec4<f32>(0.0);
    }
    let sums = vec3<u32>(leaf_sums[w], leaf_sums[w + 1u], leaf_sums[w + 2u]);
    let rgb = (sums + vec3<u32>(count / 2u)) / count;
    return vec4<f32>(vec3<f32>(rgb) / 255.0, 1.0);
}

fn unpack_u8(w: u32) -> vec4<u32> {
    return vec4<u32>(w & 255u, (w >> 8u) & 255u, (w >> 16u) & 255u, w >> 24u);
}

fn pack_u8(v: vec4<u32>) -> u32 {
    return v.x | (v.y << 8u) | (v.z << 16u) | (v.w << 24u);
}

// Front-to-back compositing of premultiplied RGBA8 values, rounded.
fn over(front: vec4<u32>, back: vec4<u32>) -> vec4<u32> {
    return front + ((255u - front.w) * back + vec4<u32>(127u)) / 255u;
}

@compute @workgroup_size(64)
fn build_level(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    if i >= P.count {
        return;
    }
    let n = P.first + i;
    let b = brick_index[n];
    if b == 0u {
        return;
    }
    let leaf = P.leaf == 1u;
    let first = child[n];
    var iso: array<vec4<u32>, 8>;
    if leaf {
        for (var o = 0u; o < 8u; o++) {
            iso[o] = unpack_u8(pack4x8unorm(leaf_voxel(n, o)));
        }
    }
    for (var d = 0u; d < 6u; d++) {
        var fine: array<vec4<u32>, 8>;
        for (var o = 0u; o < 8u; o++) {
            if leaf {
                fine[o] = iso[o];
            } else {
                fine[o] = vec4<u32>(0u);
                if first != 0u {
                    let cb = brick_index[first + o];
                    if cb != 0u {
                        fine[o] = unpack_u8(aniso[(cb - 1u) * 6u + d]);
                    }
                }
            }
        }
        var acc = vec4<u32>(0u);
        for (var j = 0u; j < 4u; j++) {
            let pair = pair_along(d, j);
            acc += over(fine[pair.x], fine[pair.y]);
        }
        aniso[(b - 1u) * 6u + d] = pack_u8((acc + vec4<u32>(2u)) / 4u);
    }
}
