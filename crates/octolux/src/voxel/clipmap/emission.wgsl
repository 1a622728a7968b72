// Clipmap emission storage, shared by voxelization, level filtering and light injection.
//
// Emission is summed in fixed point (EMISSION_SCALE units per W/(m^2 sr), as the octree's leaf
// sums) and stored per voxel slot as one RGB9E5 word (the layout of the shared-exponent texture
// format: red bits 0-8, green 9-17, blue 18-26, exponent 27-31, value = mantissa x
// 2^(exponent - 24)). Why this format: it holds HDR values up to 65408 in 4 bytes per voxel
// (half of RGBA16F, which would leave a channel unused), and it is encoded from the integer
// fixed-point mean with integer operations only, so the GPU and the CPU twin store the same bits
// and filtering (decode to fixed point, integer mean, encode) stays order independent. Values
// below 0.5 (fixed point < 512) are stored exactly; larger ones keep 9 bits of the largest
// channel (rounding error under 1/511 of it, against 1/2048 of each channel for f16).

const EMISSION_SCALE: f32 = 1024.0;
// Exponent field of the fixed-point unit: mantissa x 2^(EMISSION_E0 - 24) = mantissa / 1024.
const EMISSION_E0: u32 = 14u;
// Largest shift of the fixed-point value (exponent field 31).
const EMISSION_MAX_SHIFT: u32 = 17u;

// Fixed-point value (x EMISSION_SCALE, rounded) of one triangle's emission channel; the input
// is clamped to the f16 range like the octree's sums.
fn emission_fixed(e: f32) -> u32 {
    return u32(round(clamp(e, 0.0, 65504.0) * EMISSION_SCALE));
}

// RGB9E5 word of a fixed-point colour (each channel at most 511 << 17 after rounding is kept;
// larger values saturate). All zero gives 0.
fn emission_encode(q: vec3<u32>) -> u32 {
    let m = max(q.x, max(q.y, q.z));
    if m == 0u {
        return 0u;
    }
    var s = 0u;
    loop {
        let half = (1u << s) >> 1u;
        if s >= EMISSION_MAX_SHIFT || ((m + half) >> s) <= 511u {
            break;
        }
        s++;
    }
    let half = (1u << s) >> 1u;
    let v = min((q + vec3<u32>(half)) >> vec3<u32>(s), vec3<u32>(511u));
    return v.x | (v.y << 9u) | (v.z << 18u) | ((s + EMISSION_E0) << 27u);
}

// The fixed-point colour (x EMISSION_SCALE) of an RGB9E5 word: exact for every word
// `emission_encode` writes.
fn emission_decode_fixed(w: u32) -> vec3<u32> {
    let v = vec3<u32>(w & 511u, (w >> 9u) & 511u, (w >> 18u) & 511u);
    let e = w >> 27u;
    if e >= EMISSION_E0 {
        return v << vec3<u32>(e - EMISSION_E0);
    }
    return v >> vec3<u32>(EMISSION_E0 - e);
}

// Emitted radiance, W/(m^2 sr), of an RGB9E5 word (exact in f32).
fn emission_decode(w: u32) -> vec3<f32> {
    let v = vec3<f32>(f32(w & 511u), f32((w >> 9u) & 511u), f32((w >> 18u) & 511u));
    // 2^(exponent - 24) built from its bits (exponent - 24 + 127 is a normal f32 exponent).
    return v * bitcast<f32>(((w >> 27u) + 103u) << 23u);
}
