// Compact leaf sums of the octree's static part: `leaf_sums` starts with one word per static
// leaf node, (first sum slot << 8) | occupancy mask of its 8 voxels (bit x + 2y + 4z), then
// holds LEAF_SUM_WORDS words per occupied voxel only (albedo r, g, b x255, fragment count,
// emission r, g, b x1024, normal x, y, z as snorm8 sums), so empty voxels cost nothing.

const LEAF_SUM_WORDS: u32 = 10u;

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
