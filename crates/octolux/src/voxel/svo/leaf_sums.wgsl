// Compact leaf sums of the octree's static part: `leaf_sums` starts with one word per static
// leaf node, (first sum slot << 8) | occupancy mask of its 8 voxels (bit x + 2y + 4z), then
// holds LEAF_SUM_WORDS words per occupied voxel only (albedo r, g, b x255, fragment count,
// emission r, g, b x1024, normal x, y, z as snorm8 sums), so empty voxels cost nothing.

const LEAF_SUM_WORDS: u32 = 10u;
// Fixed-point scale of the emission sums, W/(m^2 sr).
const LEAF_EMISSION_SCALE: f32 = 1024.0;

// A voxel's LEAF_SUM_WORDS words by name. The words are integer sums (atomic adds of
// `voxel_sum_words`), so they do not depend on the fragments' order.
struct VoxelSums {
    // Albedo x255.
    albedo: vec3<u32>,
    // Fragments summed.
    count: u32,
    // Emission x LEAF_EMISSION_SCALE.
    emission: vec3<u32>,
    // Unit normals as snorm8 (x127).
    normal: vec3<i32>,
}

// The sums held in the words `w`, in the order above.
fn voxel_sums(w: array<u32, 10>) -> VoxelSums {
    return VoxelSums(vec3<u32>(w[0], w[1], w[2]), w[3], vec3<u32>(w[4], w[5], w[6]),
                     bitcast<vec3<i32>>(vec3<u32>(w[7], w[8], w[9])));
}

// The words of `s`, the inverse of `voxel_sums` (signed normals in two's complement, which
// add as unsigned words do).
fn voxel_sum_words(s: VoxelSums) -> array<u32, 10> {
    let n = bitcast<vec3<u32>>(s.normal);
    return array<u32, 10>(s.albedo.r, s.albedo.g, s.albedo.b, s.count,
                          s.emission.r, s.emission.g, s.emission.b, n.x, n.y, n.z);
}

// Word offset in `leaf_sums` of the sums of voxel `octant` of the static leaf node whose
// index word is `entry`, with `leaf_count` static leaf nodes; 0xffffffff when it is empty.
fn leaf_sum_offset(entry: u32, octant: u32, leaf_count: u32) -> u32 {
    let mask = entry & 255u;
    if (mask & (1u << octant)) == 0u {
        return 0xffffffffu;
    }
    let slot = (entry >> 8u) + countOneBits(mask & ((1u << octant) - 1u));
    return leaf_count + slot * LEAF_SUM_WORDS;
}
