//! CPU decoders of the WGSL packing built-ins (`pack2x16float`, `pack4x8unorm`) and of
//! half-precision texels, for readbacks and the CPU twins.

use glam::Vec4;

/// IEEE 754 half to single precision.
pub fn f16_to_f32(h: u16) -> f32 {
    half::f16::from_bits(h).to_f32()
}

/// Decodes a `pack2x16float` word.
pub fn unpack_half2(w: u32) -> [f32; 2] {
    [f16_to_f32(w as u16), f16_to_f32((w >> 16) as u16)]
}

/// Decodes two `pack2x16float` words (x, y in `lo`; z, w in `hi`).
pub fn unpack_half4(lo: u32, hi: u32) -> Vec4 {
    let [x, y] = unpack_half2(lo);
    let [z, w] = unpack_half2(hi);
    Vec4::new(x, y, z, w)
}

/// Decodes a `pack4x8unorm` word.
pub fn unpack_unorm8(w: u32) -> Vec4 {
    Vec4::new(
        (w & 255) as f32,
        ((w >> 8) & 255) as f32,
        ((w >> 16) & 255) as f32,
        (w >> 24) as f32,
    ) / 255.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_decode_exactly() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
        assert_eq!(unpack_half2(0x3c00_4000), [2.0, 1.0]);
        assert_eq!(unpack_unorm8(0xff00_00ff), Vec4::new(1.0, 0.0, 0.0, 1.0));
    }
}
