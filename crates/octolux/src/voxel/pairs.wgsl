// The anisotropic voxels (the octree's albedo and radiance, the clipmap's levels) composite
// each 2x2x2 block per travel direction d (+x, -x, +y, -y, +z, -z = 0..5) over the 4 pairs of
// octants (x + 2y + 4z) met one after the other along it. Pair j (0..4): x the front octant,
// y the back one. CPU twin: `pair_along` in voxel/cpu.rs.
fn pair_along(d: u32, j: u32) -> vec2<u32> {
    let a = d / 2u;
    let bit = 1u << a;
    // Octant with bit `a` cleared, the other two bits from j.
    let k0 = ((j >> a) << (a + 1u)) | (j & (bit - 1u));
    if (d & 1u) == 1u {
        return vec2<u32>(k0 | bit, k0);
    }
    return vec2<u32>(k0, k0 | bit);
}
