//! Emission storage, the CPU twin of `emission.wgsl`: voxelization sums each channel in fixed
//! point ([`EMISSION_SCALE`] units per W/(m^2 sr)) and stores the mean as one RGB9E5 word per
//! voxel slot. The encoding uses integer operations only, so the GPU and these functions store
//! the same bits and level filtering (decode to fixed point, integer mean, encode) does not
//! depend on the order of its additions.

use glam::Vec3;

/// Fixed-point units per W/(m^2 sr) of the emission sums (`EMISSION_SCALE` in
/// `clipmap/emission.wgsl`).
pub const EMISSION_SCALE: f32 = 1024.0;

/// Fixed-point value (x [`EMISSION_SCALE`], rounded half to even like WGSL `round`) of one
/// triangle's emission channel, clamped to `[0, 65504]` (`emission_fixed` in WGSL).
pub fn emission_fixed(e: f32) -> u32 {
    (e.clamp(0.0, 65504.0) * EMISSION_SCALE).round_ties_even() as u32
}

/// The RGB9E5 word (red bits 0-8, green 9-17, blue 18-26, exponent 27-31, value = mantissa x
/// 2^(exponent - 24)) of a fixed-point colour (x [`EMISSION_SCALE`]), as `emission_encode` in
/// `clipmap/emission.wgsl` computes it: the smallest shift that fits the largest channel in 9
/// bits after rounding, each channel rounded half up; values under 512 (0.5 W/(m^2 sr)) are
/// exact. Zero gives 0.
pub fn encode_emission(q: [u32; 3]) -> u32 {
    let m = q[0].max(q[1]).max(q[2]);
    if m == 0 {
        return 0;
    }
    let half = |s: u32| (1u64 << s) >> 1;
    let mut s = 0;
    while s < 17 && (m as u64 + half(s)) >> s > 511 {
        s += 1;
    }
    let v = q.map(|c| (((c as u64 + half(s)) >> s) as u32).min(511));
    v[0] | (v[1] << 9) | (v[2] << 18) | ((s + 14) << 27)
}

/// The fixed-point colour (x [`EMISSION_SCALE`]) of an RGB9E5 word (`emission_decode_fixed`).
pub fn decode_emission_fixed(w: u32) -> [u32; 3] {
    let e = w >> 27;
    [w & 511, (w >> 9) & 511, (w >> 18) & 511].map(|v| {
        if e >= 14 {
            v << (e - 14)
        } else {
            v >> (14 - e)
        }
    })
}

/// Emitted radiance, W/(m^2 sr), of an RGB9E5 word (`emission_decode`; exact in f32).
pub fn decode_emission(w: u32) -> Vec3 {
    let scale = f32::from_bits(((w >> 27) + 103) << 23);
    Vec3::new(
        (w & 511) as f32,
        ((w >> 9) & 511) as f32,
        ((w >> 18) & 511) as f32,
    ) * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emission_format_is_exact_below_512_and_rounds_to_9_bits_above() {
        assert_eq!(encode_emission([0; 3]), 0);
        assert_eq!(decode_emission(0), Vec3::ZERO);
        let mut rng = 0x9e3779b97f4a7c15u64;
        let mut next = |bits: u32| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> (64 - bits)) as u32
        };
        for i in 0..20000 {
            let bits = 1 + i % 27;
            let q = [next(bits), next(bits), next(bits)].map(|v| v.min(511 << 17));
            let w = encode_emission(q);
            let back = decode_emission_fixed(w);
            let m = q[0].max(q[1]).max(q[2]);
            // The float decoding is the fixed-point one / 1024, exactly.
            let f = decode_emission(w);
            for c in 0..3 {
                assert_eq!(f[c], back[c] as f32 / EMISSION_SCALE, "{q:?}");
                if m < 512 {
                    assert_eq!(back[c], q[c], "{q:?}");
                } else {
                    // Half a step of 9 bits under the largest channel's exponent: under
                    // 1/511 of the largest channel.
                    let err = (back[c] as i64 - q[c] as i64).unsigned_abs();
                    assert!(err as f64 <= m as f64 / 511.0, "{q:?} -> {back:?}");
                }
            }
            // Re-encoding a decoded word gives the same word (filtering is stable).
            assert_eq!(encode_emission(back), w);
        }
        assert_eq!(emission_fixed(-1.0), 0);
        assert_eq!(emission_fixed(1.5), 1536);
        assert_eq!(
            decode_emission(encode_emission([emission_fixed(1e9); 3])).x,
            65408.0
        );
    }
}
