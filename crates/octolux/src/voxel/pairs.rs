//! The octant pairs every anisotropic voxel kernel composites front to back per travel
//! direction, in WGSL (the module `voxel/pairs`) and on the CPU, with the 8-bit channel packing the
//! anisotropic values use.

/// The four 8-bit channels of a packed word.
pub fn unpack_u8(w: u32) -> [u32; 4] {
    [w & 255, (w >> 8) & 255, (w >> 16) & 255, w >> 24]
}

pub fn pack_u8(v: [u32; 4]) -> u32 {
    v[0] | (v[1] << 8) | (v[2] << 16) | (v[3] << 24)
}

/// Direction `d` (+x, -x, +y, -y, +z, -z) of a 2x2x2 block of RGBA8 values `fine(octant)`:
/// the two met along the direction composited front to back, averaged over the 4 pairs.
pub fn composite_pairs(d: usize, fine: impl Fn(usize) -> [u32; 4]) -> u32 {
    let mut acc = [0u32; 4];
    for (front, back) in (0..4).map(|j| pair_along(d, j)) {
        let f = fine(front);
        let b = fine(back);
        for i in 0..4 {
            acc[i] += f[i] + ((255 - f[3]) * b[i] + 127) / 255;
        }
    }
    pack_u8(acc.map(|a| (a + 2) / 4))
}

/// Pair `j` (0..4) of octants (x + 2y + 4z) met one after the other travelling along
/// direction `d` (+x, -x, +y, -y, +z, -z): (front, back).
pub fn pair_along(d: usize, j: usize) -> (usize, usize) {
    let axis = d / 2;
    let bit = 1usize << axis;
    let k0 = ((j >> axis) << (axis + 1)) | (j & (bit - 1));
    if d.is_multiple_of(2) {
        (k0, k0 | bit)
    } else {
        (k0 | bit, k0)
    }
}
