//! Direction lattices on the unit sphere (`004` §2.4): the surfels of a probe are placed by
//! rays along these directions, and each direction carries the solid angle it stands for, so
//! that a probe's sum over its rays approximates an integral over the sphere.
//!
//! The pole axis of both lattices is the world's up axis, +y (`004` uses z): in the spherical
//! coordinates of eq. 2.2, `(sin t cos p, cos t, sin t sin p)`.
//!
//! Angles are reduced to [-pi, pi) before `sin`/`cos` with the same f32 steps on the CPU and
//! in `lattice.wgsl` (the module `gi/probes/lattice`), because WGSL only bounds the error of `sin`/`cos` on that interval
//! (absolute 2^-11), and a Fibonacci angle `g (i + 1/2)` reaches thousands of radians.

use glam::Vec3;

/// Parallels of the latitude-longitude lattice (`004` §4.1.1: 8 x 8 and 8 x 16).
pub const PARALLELS: u32 = 8;

/// The golden angle in turns, (3 - sqrt 5) / 2.
const GOLDEN_TURNS: f32 = 0.381_966_02;

/// Which lattice places a probe's surfels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Lattice {
    /// The Fibonacci lattice (eqs. 2.3, 2.4): equal areas, no poles.
    Fibonacci,
    /// [`PARALLELS`] parallels at equal angles (cell centres, no point on a pole) times
    /// `n / PARALLELS` meridians.
    LatLong,
}

impl Lattice {
    /// The `kind` argument of `lattice_dir` in WGSL.
    pub fn gpu_kind(self) -> u32 {
        match self {
            Lattice::Fibonacci => 0,
            Lattice::LatLong => 1,
        }
    }

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Lattice> {
        match name {
            "fibonacci" => Some(Lattice::Fibonacci),
            "lat-long" => Some(Lattice::LatLong),
            _ => None,
        }
    }
}

/// `turns` in [0, 1) as an angle in [-pi, pi).
fn reduced_angle(turns: f32) -> f32 {
    let t = if turns >= 0.5 { turns - 1.0 } else { turns };
    t * std::f32::consts::TAU
}

/// Direction `k` of `n` on `lattice` and the solid angle it stands for (the weights of a
/// lattice sum to 4 pi).
pub fn direction(lattice: Lattice, k: u32, n: u32) -> (Vec3, f32) {
    match lattice {
        Lattice::Fibonacci => {
            // Eq. 2.3 with i = k + 1: z = 1 - (2i - 1) / n, phi = g (i - 1/2).
            let odd = (2 * k + 1) as f32;
            let z = 1.0 - odd / n as f32;
            let turns = (odd * (0.5 * GOLDEN_TURNS)).fract();
            let phi = reduced_angle(turns);
            let r = (1.0 - z * z).max(0.0).sqrt();
            (
                Vec3::new(r * phi.cos(), z, r * phi.sin()),
                4.0 * std::f32::consts::PI / n as f32,
            )
        }
        Lattice::LatLong => {
            let meridians = (n / PARALLELS).max(1);
            let (i, j) = (k / meridians, k % meridians);
            let p = PARALLELS as f32;
            let theta = std::f32::consts::PI * (i as f32 + 0.5) / p;
            let phi = reduced_angle(j as f32 / meridians as f32);
            let (s, c) = (theta.sin(), theta.cos());
            // The band between the parallels' cell edges, split among the meridians.
            let lo = (std::f32::consts::PI * i as f32 / p).cos();
            let hi = (std::f32::consts::PI * (i + 1) as f32 / p).cos();
            (
                Vec3::new(s * phi.cos(), c, s * phi.sin()),
                (lo - hi) * std::f32::consts::TAU / meridians as f32,
            )
        }
    }
}

/// All `n` directions of `lattice` with their solid angles.
pub fn directions(lattice: Lattice, n: u32) -> Vec<(Vec3, f32)> {
    (0..n).map(|k| direction(lattice, k, n)).collect()
}

/// The radical inverse of `i` in `base` (the Halton sequence's coordinate).
fn radical_inverse(mut i: u32, base: u32) -> f32 {
    let (mut inv, mut f) = (0.0f64, 1.0f64 / base as f64);
    while i > 0 {
        inv += f * (i % base) as f64;
        i /= base;
        f /= base as f64;
    }
    inv as f32
}

/// The rotation that turns the lattice for sample `i` of a probe's history
/// (`probes-grid`'s accumulation, docs/probes.md "Rays that turn every frame"): the identity
/// for `i = 0`, so that a single frame sees the plain lattice, then rotations spread evenly
/// over all of SO(3) (Shoemake's uniform quaternion of the Halton point `i` in bases 2, 3
/// and 5), so that the mean over samples integrates over the whole sphere. Made on the CPU
/// only: the GPU receives its rows.
pub fn frame_rotation(i: u32) -> glam::Mat3 {
    if i == 0 {
        return glam::Mat3::IDENTITY;
    }
    let (u1, u2, u3) = (
        radical_inverse(i, 2),
        radical_inverse(i, 3),
        radical_inverse(i, 5),
    );
    let tau = std::f32::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = glam::Quat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    );
    glam::Mat3::from_quat(q.normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_rotations_start_at_the_identity_and_cover_the_sphere() {
        assert_eq!(frame_rotation(0), glam::Mat3::IDENTITY);
        let mut mean = Vec3::ZERO;
        for i in 1..1024 {
            let r = frame_rotation(i);
            assert!(
                (r.transpose() * r).abs_diff_eq(glam::Mat3::IDENTITY, 1e-5),
                "{i}: {r}"
            );
            assert!((r.determinant() - 1.0).abs() < 1e-5, "{i}");
            mean += r * Vec3::Y;
        }
        // Uniform over SO(3): the turned pole averages to the centre of the sphere.
        assert!((mean / 1023.0).length() < 0.02, "{mean}");
        assert_ne!(frame_rotation(1), frame_rotation(2));
    }

    #[test]
    fn weights_cover_the_sphere_and_directions_are_unit() {
        for (lattice, n) in [
            (Lattice::Fibonacci, 64),
            (Lattice::Fibonacci, 128),
            (Lattice::Fibonacci, 1000),
            (Lattice::LatLong, 64),
            (Lattice::LatLong, 128),
        ] {
            let dirs = directions(lattice, n);
            // Summed in f64: f32 rounding over 1000 terms alone is ~1e-4.
            let total64: f64 = dirs.iter().map(|d| d.1 as f64).sum();
            assert!(
                (total64 - 4.0 * std::f64::consts::PI).abs() < 1e-5,
                "{total64}"
            );
            let total = total64 as f32;
            for (d, _) in &dirs {
                assert!((d.length() - 1.0).abs() < 1e-5, "{d}");
            }
            // Weighted mean direction 0 and weighted second moment I/3: the quadrature
            // integrates polynomials of degree <= 2 over the sphere (exactly for lat-long by
            // symmetry; to O(1/n) for Fibonacci).
            let mean: Vec3 = dirs.iter().map(|(d, w)| *d * *w).sum::<Vec3>() / total;
            let yy: f32 = dirs.iter().map(|(d, w)| d.y * d.y * w).sum::<f32>() / total;
            let tol = if lattice == Lattice::Fibonacci {
                2.0 / n as f32
            } else {
                1e-4
            };
            assert!(mean.length() < tol, "{lattice:?} {n}: mean {mean}");
            // Lat-long's midpoint rule in theta is not exact for y^2; bound from 8 parallels.
            let tol_yy = if lattice == Lattice::Fibonacci {
                2.0 / n as f32
            } else {
                0.02
            };
            assert!(
                (yy - 1.0 / 3.0).abs() < tol_yy,
                "{lattice:?} {n}: <y^2> {yy}"
            );
        }
    }

    #[test]
    fn fibonacci_points_are_evenly_spread() {
        // Equal-area coverage: every one of 8 octants of the sphere gets n/8 points within
        // a few, and the closest pair is not much closer than the lattice spacing
        // sqrt(4 pi / n) (a lat-long lattice crowds its poles: its closest pair is far closer).
        let n = 128;
        let dirs = directions(Lattice::Fibonacci, n);
        let mut octants = [0; 8];
        for (d, _) in &dirs {
            octants[(d.x > 0.0) as usize
                | ((d.y > 0.0) as usize) << 1
                | ((d.z > 0.0) as usize) << 2] += 1;
        }
        for c in octants {
            assert!((c - 16i32).abs() <= 3, "{octants:?}");
        }
        let closest = |dirs: &[(Vec3, f32)]| {
            let mut best = f32::MAX;
            for (i, a) in dirs.iter().enumerate() {
                for b in &dirs[i + 1..] {
                    best = best.min(a.0.distance(b.0));
                }
            }
            best
        };
        let spacing = (4.0 * std::f32::consts::PI / n as f32).sqrt();
        let fib = closest(&dirs);
        let ll = closest(&directions(Lattice::LatLong, n));
        assert!(fib > 0.5 * spacing, "{fib} vs {spacing}");
        assert!(ll < 0.5 * fib, "lat-long {ll} fibonacci {fib}");
    }

    #[test]
    fn lat_long_has_eight_parallels() {
        let dirs = directions(Lattice::LatLong, 128);
        let mut ys: Vec<f32> = dirs.iter().map(|d| d.0.y).collect();
        ys.sort_by(f32::total_cmp);
        ys.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
        assert_eq!(ys.len(), 8);
    }
}
