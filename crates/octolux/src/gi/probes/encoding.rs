//! How a probe stores the light around it so that a pixel can evaluate irradiance for its
//! normal. A probe sees radiance `L_j` along its lattice directions `w_j`, each standing for
//! solid angle `dw_j` ([`super::lattice`]); both encodings are linear in these samples.
//!
//! - [`Encoding::Octahedron`], `004`'s 8 bins along the facet normals `f_k = (+-1, +-1, +-1)/sqrt 3`
//!   of an octahedron. `004` does not say what a bin holds; here bin `k` is the irradiance
//!   for a surface facing `f_k`, `E_k = sum_j L_j max(0, f_k . w_j) dw_j`, and a normal `n`
//!   blends the bins trilinearly at `n / max|n_i|` on the cube whose corners are the `f_k`
//!   (so `n = f_k` reads `E_k` exactly, and a constant environment reads the same everywhere).
//! - [`Encoding::ShL1`]: spherical harmonics bands 0 and 1 of radiance, `c_lm = sum_j L_j
//!   Y_lm(w_j) dw_j`, and irradiance by the cosine lobe's band factors (Ramamoorthi and
//!   Hanrahan 2001): `E(n) = pi c_00 Y_00 + 2 pi / 3 sum_m c_1m Y_1m(n)`, clamped at 0.
//!
//! Both use 8 RGB coefficients of storage per probe (SH L1 the first 4).

use glam::Vec3;

/// Coefficients per probe.
pub const COEFFS: usize = 8;

const Y0: f32 = 0.282_095;
const Y1: f32 = 0.488_603;

/// A probe's irradiance encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
pub enum Encoding {
    /// `004`'s 8 octahedron-facet bins.
    #[serde(rename = "octahedron")]
    Octahedron,
    /// Spherical harmonics L1 of radiance, evaluated as irradiance.
    #[serde(rename = "sh1")]
    ShL1,
}

impl Encoding {
    /// The `kind` argument of the WGSL functions.
    pub fn gpu_kind(self) -> u32 {
        match self {
            Encoding::Octahedron => 0,
            Encoding::ShL1 => 1,
        }
    }

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Encoding> {
        match name {
            "octahedron" => Some(Encoding::Octahedron),
            "sh1" => Some(Encoding::ShL1),
            _ => None,
        }
    }

    /// Adds radiance `l` arriving from unit direction `dir` over solid angle `dw`.
    pub fn add(self, coeffs: &mut [Vec3; COEFFS], l: Vec3, dir: Vec3, dw: f32) {
        match self {
            Encoding::Octahedron => {
                for (k, c) in coeffs.iter_mut().enumerate() {
                    *c += l * (facet(k).dot(dir).max(0.0) * dw);
                }
            }
            Encoding::ShL1 => {
                coeffs[0] += l * (Y0 * dw);
                coeffs[1] += l * (Y1 * dir.y * dw);
                coeffs[2] += l * (Y1 * dir.z * dw);
                coeffs[3] += l * (Y1 * dir.x * dw);
            }
        }
    }

    /// The coefficients of the samples `(radiance, direction, solid angle)`.
    pub fn project(self, samples: &[(Vec3, Vec3, f32)]) -> [Vec3; COEFFS] {
        let mut coeffs = [Vec3::ZERO; COEFFS];
        for &(l, dir, dw) in samples {
            self.add(&mut coeffs, l, dir, dw);
        }
        coeffs
    }

    /// Irradiance (W/m^2) on a surface with unit normal `n`.
    pub fn irradiance(self, coeffs: &[Vec3; COEFFS], n: Vec3) -> Vec3 {
        match self {
            Encoding::Octahedron => {
                let m = n / n.abs().max_element().max(1e-20);
                let mut e = Vec3::ZERO;
                for (k, c) in coeffs.iter().enumerate() {
                    let f = signs(k);
                    let w = ((Vec3::ONE + f * m) * 0.5).clamp(Vec3::ZERO, Vec3::ONE);
                    e += *c * (w.x * w.y * w.z);
                }
                e
            }
            Encoding::ShL1 => {
                let pi = std::f32::consts::PI;
                let e = coeffs[0] * (pi * Y0)
                    + (coeffs[1] * (Y1 * n.y) + coeffs[2] * (Y1 * n.z) + coeffs[3] * (Y1 * n.x))
                        * (2.0 * pi / 3.0);
                e.max(Vec3::ZERO)
            }
        }
    }
}

/// The signs of facet `k`: bit 0, 1, 2 of `k` set = +x, +y, +z.
fn signs(k: usize) -> Vec3 {
    let s = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
    Vec3::new(s(0), s(1), s(2))
}

/// Unit facet normal `k` of the octahedron (bit 0, 1, 2 of `k` set = +x, +y, +z).
pub fn facet(k: usize) -> Vec3 {
    signs(k) * (1.0 / 3f32.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gi::probes::lattice::{directions, Lattice};

    const PI: f32 = std::f32::consts::PI;

    fn normals() -> Vec<Vec3> {
        let mut v: Vec<Vec3> = directions(Lattice::Fibonacci, 50)
            .into_iter()
            .map(|d| d.0)
            .collect();
        v.extend([Vec3::X, Vec3::NEG_Y, Vec3::Z, facet(3), facet(6)]);
        v
    }

    #[test]
    fn a_uniform_environment_gives_pi_times_its_radiance() {
        // Radiance 2 from everywhere: E = 2 pi for every normal. The lattice quadrature of
        // max(0, cos) is not exact (2048 Fibonacci points: the clamped lobe's kink costs
        // ~1e-3 relative), SH band 0 and 1 of a constant are (exactly in the weights' sum).
        for lattice in [Lattice::Fibonacci, Lattice::LatLong] {
            let n = if lattice == Lattice::Fibonacci {
                2048
            } else {
                1024
            };
            let samples: Vec<_> = directions(lattice, n)
                .into_iter()
                .map(|(d, w)| (Vec3::splat(2.0), d, w))
                .collect();
            for enc in [Encoding::Octahedron, Encoding::ShL1] {
                let c = enc.project(&samples);
                for n in normals() {
                    let e = enc.irradiance(&c, n);
                    let tol = if lattice == Lattice::Fibonacci {
                        0.01
                    } else {
                        0.05
                    };
                    assert!(
                        (e - Vec3::splat(2.0 * PI)).abs().max_element() < tol,
                        "{lattice:?} {enc:?} {n}: {e}"
                    );
                }
            }
        }
    }

    #[test]
    fn one_direction_gives_the_projection_of_the_cosine_lobe() {
        // Radiance 1 over solid angle 1 from d. Exact irradiance is max(0, n.d); SH L1 keeps
        // its bands 0 and 1, 1/4 + n.d/2 (clamped at 0); the octahedron bins hold it exactly
        // at the facet normals and blend it elsewhere.
        let d = Vec3::new(0.3, 0.8, -0.52).normalize();
        let sh = Encoding::ShL1.project(&[(Vec3::ONE, d, 1.0)]);
        for n in normals() {
            let e = Encoding::ShL1.irradiance(&sh, n).x;
            let want = (0.25 + 0.5 * n.dot(d)).max(0.0);
            assert!((e - want).abs() < 1e-5, "{n}: {e} vs {want}");
        }
        let oct = Encoding::Octahedron.project(&[(Vec3::ONE, d, 1.0)]);
        for k in 0..8 {
            let e = Encoding::Octahedron.irradiance(&oct, facet(k)).x;
            assert!((e - facet(k).dot(d).max(0.0)).abs() < 1e-5, "bin {k}: {e}");
        }
        // Between bins: a blend of bins, so within the range of the bins around it, and
        // facing away from d reads less than facing d.
        let toward = Encoding::Octahedron.irradiance(&oct, d).x;
        let away = Encoding::Octahedron.irradiance(&oct, -d).x;
        assert!(toward > 0.5 && away < 0.1, "{toward} {away}");
    }
}
