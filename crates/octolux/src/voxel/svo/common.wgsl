// Shared by the octree's modules (`svo/build.wgsl` + `svo/dynamic.wgsl`, `svo/accumulate.wgsl`):
// the bindings they all read (group 0, the layout of `SvoBuilder`)
// and the helpers that walk nodes and address bricks.

import octolux::voxel::voxelize::overlap::Tri;
import octolux::voxel::svo::control::LevelParams;

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> L: LevelParams;
@group(0) @binding(1) var<storage, read> fragments: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tris: array<Tri>;
@group(0) @binding(3) var<storage, read_write> child: array<u32>;
// Each node's brick index + 1 (0 = no brick). During the static build's structure phase it
// holds the node's OCCUPIED / NEEDED flags instead, which `assign_bricks` turns into the
// brick index + 1.
@group(0) @binding(6) var<storage, read_write> brick_plus_one: array<atomic<u32>>;

const INVALID: u32 = 0xffffffffu;
const OCCUPIED: u32 = 1u;
const NEEDED: u32 = 2u;

fn unpack3(c: u32) -> vec3<u32> {
    return vec3<u32>(c & 1023u, (c >> 10u) & 1023u, (c >> 20u) & 1023u);
}

fn pack3(c: vec3<u32>) -> u32 {
    return (c.x & 1023u) | ((c.y & 1023u) << 10u) | ((c.z & 1023u) << 20u);
}

fn octant_offset(o: u32) -> vec3<u32> {
    return vec3<u32>(o & 1u, (o >> 1u) & 1u, (o >> 2u) & 1u);
}

// The node of level d at coordinates c, or INVALID when an ancestor has no children.
fn find(c: vec3<u32>, d: u32) -> u32 {
    var node = 0u;
    for (var l = 0u; l < d; l++) {
        let first = child[node];
        if first == 0u {
            return INVALID;
        }
        let s = d - 1u - l;
        let o = ((c.x >> s) & 1u) | (((c.y >> s) & 1u) << 1u) | (((c.z >> s) & 1u) << 2u);
        node = first + o;
    }
    return node;
}

// Brick of a node (after assign_bricks), INVALID when it has none.
fn brick_of(node: u32) -> u32 {
    return atomicLoad(&brick_plus_one[node]) - 1u;
}

// Word i (0..53) of brick b: pool b / pool_bricks, slot b % pool_bricks.
fn bw_index(b: u32, i: u32) -> u32 {
    return (b % L.pool_bricks) * 54u + i;
}

// The leaf node holding voxel `v` (level depth - 1: nodes of 2x2x2 voxels), INVALID when the
// octree has none there.
fn leaf_of_voxel(v: vec3<u32>) -> u32 {
    return find(v >> vec3<u32>(1u), L.depth - 1u);
}
