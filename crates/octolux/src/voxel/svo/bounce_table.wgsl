// The table that carries the octree's dynamic voxels' bounce light from one frame to the next
// (their leaves are rebuilt every frame, in another order): open addressing with linear
// probing over a power-of-two capacity, keyed by the voxel's geometry word (coordinates, bit
// 30 set; 0 marks an empty entry), RGBA16F irradiance values. `gi/vct/svo_bounce.wgsl`
// inserts, `svo/inject.wgsl` looks up. A key not placed within BOUNCE_TABLE_PROBES entries
// (a table fuller than the dynamic reserve allows for) is dropped: that voxel gets no bounce.

const BOUNCE_TABLE_PROBES: u32 = 32u;

// Integer hash of a key (the murmur3 finaliser): neighbouring voxels land far apart.
fn bounce_table_hash(key: u32) -> u32 {
    var h = key;
    h ^= h >> 16u;
    h *= 0x85ebca6bu;
    h ^= h >> 13u;
    h *= 0xc2b2ae35u;
    h ^= h >> 16u;
    return h;
}
