//! Random numbers and sampling for the path tracer. Every stream is derived from a hash of
//! (seed, pixel, sample), so images do not depend on thread count or scheduling.

use glam::{Vec2, Vec3};

/// SplitMix64 finaliser: a good 64-bit mixing function for deriving independent streams.
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A small PCG32 generator (O'Neill's XSH-RR variant).
#[derive(Clone, Debug)]
pub(crate) struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A generator for one (seed, pixel, sample) triple.
    pub(crate) fn new(seed: u64, pixel: u64, sample: u64) -> Rng {
        let a = mix64(seed ^ mix64(pixel.wrapping_mul(0x2545_f491_4f6c_dd1d)));
        let b = mix64(a ^ sample.wrapping_add(0x632b_e59b_d9b4_e019));
        let mut rng = Rng {
            state: 0,
            inc: (mix64(b ^ 0xda94_2042_e4dd_58b5) << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(b);
        rng.next_u32();
        rng
    }

    /// Next 32 random bits.
    pub(crate) fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub(crate) fn next_f32(&mut self) -> f32 {
        // 24 bits so the result is exactly representable and strictly below 1.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniforms in [0, 1).
    pub(crate) fn next_vec2(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// Sample `index` of the R2 low-discrepancy sequence (Roberts' additive recurrence), shifted by
/// `shift` modulo 1. With a uniformly random shift per pixel every sample is uniform over the
/// pixel on its own (so any prefix is unbiased, which matters when a time budget stops early),
/// while successive samples stay well stratified.
pub(crate) fn r2(index: u32, shift: Vec2) -> Vec2 {
    const G: f64 = 1.324_717_957_244_746;
    const A1: f64 = 1.0 / G;
    const A2: f64 = 1.0 / (G * G);
    let i = index as f64;
    let x = (shift.x as f64 + i * A1).fract();
    let y = (shift.y as f64 + i * A2).fract();
    Vec2::new(x as f32, y as f32)
}

/// An orthonormal basis (tangent, bitangent) around the unit vector `n` (Duff et al. 2017).
pub(crate) fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction on the hemisphere around unit `n` (pdf = cos / pi).
pub(crate) fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    let (t, b) = basis(n);
    let z = (1.0 - u.x).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize_or(n)
}

/// Index `i` with `cdf[i] <= u < cdf[i + 1]` (cdf increasing from 0 to 1), skipping empty bins.
pub(crate) fn search(cdf: &[f32], u: f32) -> usize {
    let i = cdf.partition_point(|&c| c <= u);
    i.saturating_sub(1).min(cdf.len() - 2)
}

/// Turns weights into a cumulative distribution; None when they sum to zero.
pub(crate) fn cumulative(weights: impl Iterator<Item = f64>, n: usize) -> Option<Vec<f32>> {
    let mut cdf = Vec::with_capacity(n + 1);
    let mut sum = 0.0f64;
    cdf.push(0.0);
    let mut partial = Vec::with_capacity(n);
    for w in weights {
        sum += w;
        partial.push(sum);
    }
    if sum <= 0.0 {
        return None;
    }
    cdf.extend(partial.iter().map(|&s| (s / sum) as f32));
    if let Some(last) = cdf.last_mut() {
        *last = 1.0;
    }
    Some(cdf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_deterministic_and_uniformish() {
        let mut a = Rng::new(1, 2, 3);
        let mut b = Rng::new(1, 2, 3);
        let mut sum = 0.0;
        for _ in 0..10_000 {
            let x = a.next_f32();
            assert_eq!(x, b.next_f32());
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        assert!((sum / 10_000.0 - 0.5).abs() < 0.02);
        assert_ne!(Rng::new(1, 2, 3).next_u32(), Rng::new(1, 2, 4).next_u32());
    }

    #[test]
    fn cosine_samples_lie_in_the_hemisphere() {
        let mut rng = Rng::new(7, 0, 0);
        let n = Vec3::new(0.3, -0.8, 0.5).normalize();
        let mut mean_cos = 0.0;
        for _ in 0..20_000 {
            let d = cosine_hemisphere(n, rng.next_vec2());
            assert!((d.length() - 1.0).abs() < 1e-4);
            assert!(d.dot(n) >= -1e-6);
            mean_cos += d.dot(n) as f64;
        }
        // E[cos] under pdf cos/pi is 2/3.
        assert!((mean_cos / 20_000.0 - 2.0 / 3.0).abs() < 0.01);
    }
}
