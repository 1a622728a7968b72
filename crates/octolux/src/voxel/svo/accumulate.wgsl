// The leaf sums of the octree build, the one brick pass that needs atomics: every fragment
// adds its albedo to its leaf voxel. Its own module, so that the brick pools can be plain
// arrays everywhere else (same bind group layout as `svo/build.wgsl`; the bindings they share are
// `svo/common.wgsl`'s).

import octolux::voxel::voxelize::overlap::linear_index;
import octolux::voxel::svo::common::{brick_of, bw_index, fragments, INVALID, L, leaf_of_voxel, tris, unpack3};

@group(0) @binding(8) var<storage, read_write> bricks0: array<atomic<u32>>;
@group(0) @binding(9) var<storage, read_write> bricks1: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read_write> bricks2: array<atomic<u32>>;
@group(0) @binding(11) var<storage, read_write> bricks3: array<atomic<u32>>;

fn bw_add(b: u32, i: u32, v: u32) {
    let w = bw_index(b, i);
    switch b / L.pool_bricks {
        case 0u: { atomicAdd(&bricks0[w], v); }
        case 1u: { atomicAdd(&bricks1[w], v); }
        case 2u: { atomicAdd(&bricks2[w], v); }
        default: { atomicAdd(&bricks3[w], v); }
    }
}

// Leaf voxels: integer sums of albedo (x255) and fragment count, in words 0..31 of the leaf's
// brick, 4 per voxel (octant order).
@compute @workgroup_size(64)
fn leaf_accumulate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                   @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= L.fragments {
        return;
    }
    let frag = fragments[f];
    let v = unpack3(frag.x);
    let n = leaf_of_voxel(v);
    if n == INVALID {
        return;
    }
    let b = brick_of(n);
    if b == INVALID {
        return;
    }
    let o = (v.x & 1u) | ((v.y & 1u) << 1u) | ((v.z & 1u) << 2u);
    let albedo = tris[frag.y].albedo;
    let w = o * 4u;
    bw_add(b, w, albedo & 255u);
    bw_add(b, w + 1u, (albedo >> 8u) & 255u);
    bw_add(b, w + 2u, (albedo >> 16u) & 255u);
    bw_add(b, w + 3u, 1u);
}
