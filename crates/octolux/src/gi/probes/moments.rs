//! Depth moments per probe and DDGI's Chebyshev visibility (Majercik et al. 2019), against the
//! leaks of the probe gather through thin walls (docs/probes.md, "Leaks").
//!
//! Each probe keeps a [`MOMENT_RES`] x [`MOMENT_RES`] octahedral map of the mean distance and
//! mean squared distance of its surfels: texel `i` (centre direction `t_i`) holds
//! `sum_k w_k (d_k, d_k^2) / sum_k w_k` over the probe's surfels, `d_k` the hit distance along
//! lattice direction `w_k` (misses at the ray's maximum distance) and `w_k = max(0, t_i .
//! w_k)^32` (half its weight within 12 degrees). 16 x 16 texels (about 0.05 sr each, a
//! quarter of the solid angle of one of the default 64 surfels per frame; the maps gather the
//! turned lattices of their first frames): the map then follows the distances ray by ray,
//! which a probe close to a wall needs, since from there the wall is seen at grazing angles
//! where the distance grows fast, and the bilinear read's steps across an occluder's edge are
//! a quarter texel's solid angle of 8 x 8's (8 x 8 drew a saw-tooth of light and shade down a
//! sunlit pillar of the church: docs/probes.md, "Gather and leaks"). 4 x 4 texels with a
//! kernel of a texel's width (`^8`) blend the wall with the open room beyond its grazing
//! directions: on the leak scene (lit by a narrow spot then) they cut the grid's leak 1.6x
//! where 8 x 8 cut it 37x (docs/probes.md, "Leaks"). The maps are built by a pass of
//! [`MOMENT_LANES`] invocations per probe right after placement (once for a static scene),
//! each writing its own [`MOMENT_TEXELS`] / [`MOMENT_LANES`] texels.
//!
//! A point `q` (the gather's biased point) at distance `r` from probe `x` then weighs the
//! probe by 1 while `r <= mean` along `x -> q` (the map read bilinearly, its edges folded as
//! the octahedron's), and beyond by DDGI's sharpened Chebyshev bound
//! `(var / (var + (r - mean)^2))^3`, `var = max(E[d^2] - mean^2, floor)`; the floor is
//! `(VARIANCE_FLOOR x cell)^2`, `cell` the probe spacing (the octree's finest cube edge), so a
//! flat wall seen by a single ray per kernel does not have zero variance.

use glam::{Vec2, Vec3};

/// Texels per side of a probe's moment map.
pub const MOMENT_RES: u32 = 16;
/// Texels per probe.
pub const MOMENT_TEXELS: u32 = MOMENT_RES * MOMENT_RES;
/// Invocations that build one probe's map (`moments_build.wgsl`: a 64-lane workgroup per
/// probe, lane `l` making texels `l`, `l + 64`, `l + 128` and `l + 192`).
pub const MOMENT_LANES: u32 = 64;
const _: () = assert!(MOMENT_TEXELS == 4 * MOMENT_LANES);
/// Bytes of one probe's map (two `f32` per texel).
pub const MOMENT_BYTES: u64 = MOMENT_TEXELS as u64 * 8;
/// The variance floor's standard deviation, in probe spacings.
pub const VARIANCE_FLOOR: f32 = 0.05;

/// Whether the gather weighs probes by their visibility from the shaded point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Visibility {
    /// No visibility: a probe behind a wall contributes as if it were not there.
    None,
    /// Depth moments with Chebyshev visibility, as DDGI.
    Moments,
}

impl Visibility {
    /// The WGSL's mode (`P.visibility`).
    pub fn gpu_kind(self) -> u32 {
        match self {
            Visibility::None => 0,
            Visibility::Moments => 1,
        }
    }
}

impl std::str::FromStr for Visibility {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        match s {
            "none" => Ok(Visibility::None),
            "moments" => Ok(Visibility::Moments),
            other => Err(crate::Error::InvalidArgument(format!(
                "probes visibility '{other}': expected none or moments"
            ))),
        }
    }
}

/// The variance floor (m^2) for probes `cell` metres apart.
pub fn variance_floor(cell: f32) -> f32 {
    let s = VARIANCE_FLOOR * cell;
    s * s
}

fn sign(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// `oct_encode`: unit `d` on the octahedral square [-1, 1]^2, +z on the inner diamond.
pub fn oct_encode(d: Vec3) -> Vec2 {
    let a = d / (d.x.abs() + d.y.abs() + d.z.abs());
    if a.z >= 0.0 {
        Vec2::new(a.x, a.y)
    } else {
        (Vec2::ONE - Vec2::new(a.y, a.x).abs()) * sign(Vec2::new(a.x, a.y))
    }
}

/// `oct_decode`: the unit direction at `e` on the octahedral square.
pub fn oct_decode(e: Vec2) -> Vec3 {
    let z = 1.0 - e.x.abs() - e.y.abs();
    let xy = if z < 0.0 {
        (Vec2::ONE - Vec2::new(e.y, e.x).abs()) * sign(e)
    } else {
        e
    };
    xy.extend(z).normalize()
}

/// `moment_texel_dir`: direction of texel `i`'s centre.
pub fn texel_dir(i: u32) -> Vec3 {
    let t = Vec2::new((i % MOMENT_RES) as f32, (i / MOMENT_RES) as f32);
    oct_decode((t + 0.5) / MOMENT_RES as f32 * 2.0 - 1.0)
}

fn kernel(t: Vec3, d: Vec3) -> f32 {
    let c = t.dot(d).max(0.0);
    let c2 = c * c;
    let c4 = c2 * c2;
    let c8 = c4 * c4;
    let c16 = c8 * c8;
    c16 * c16
}

/// CPU twin of moments_build.wgsl for one probe: its map from its surfels' lattice
/// directions, states (0 miss) and hit distances (absolute values used), `far` the distance
/// of a miss.
pub fn build_map(dirs: &[Vec3], states: &[f32], dists: &[f32], far: f32) -> Vec<[f32; 2]> {
    (0..MOMENT_TEXELS)
        .map(|i| {
            let t = texel_dir(i);
            let (mut sum, mut total) = (Vec2::ZERO, 0.0f32);
            for ((d, &state), &dist) in dirs.iter().zip(states).zip(dists) {
                let dist = if state > 0.5 { dist.abs() } else { far };
                let w = kernel(t, *d);
                sum += w * Vec2::new(dist, dist * dist);
                total += w;
            }
            if total > 0.0 {
                (sum / total).to_array()
            } else {
                [far, far * far]
            }
        })
        .collect()
}

fn fetch(map: &[[f32; 2]], x: i32, y: i32) -> Vec2 {
    let r = MOMENT_RES as i32;
    let (mut ix, mut iy) = (x, y);
    if !(0..r).contains(&ix) {
        ix = ix.clamp(0, r - 1);
        iy = r - 1 - iy;
    }
    if !(0..r).contains(&iy) {
        iy = iy.clamp(0, r - 1);
        ix = r - 1 - ix;
    }
    Vec2::from_array(map[(iy * r + ix) as usize])
}

/// `moment_sample`: one probe's `map` along unit `d`, bilinear between texel centres.
pub fn sample(map: &[[f32; 2]], d: Vec3) -> Vec2 {
    let f = (oct_encode(d) * 0.5 + 0.5) * MOMENT_RES as f32 - 0.5;
    let i = f.floor();
    let t = f - i;
    let (x, y) = (i.x as i32, i.y as i32);
    let a = fetch(map, x, y).lerp(fetch(map, x + 1, y), t.x);
    let b = fetch(map, x, y + 1).lerp(fetch(map, x + 1, y + 1), t.x);
    a.lerp(b, t.y)
}

/// `probe_visibility`: the Chebyshev weight of point `q` seen from the probe at `x` with
/// moment `map`, variance floor `floor`.
pub fn visibility(map: &[[f32; 2]], floor: f32, x: Vec3, q: Vec3) -> f32 {
    let v = q - x;
    let r = v.length();
    if r <= 0.0 {
        return 1.0;
    }
    let m = sample(map, v / r);
    if r <= m.x {
        return 1.0;
    }
    let variance = (m.y - m.x * m.x).max(floor);
    let e = r - m.x;
    let c = variance / (variance + e * e);
    c * c * c
}

/// The moments the CPU gathers read: the maps of every probe slot (`MOMENT_TEXELS` each)
/// and the variance floor, or `None` for no visibility.
#[derive(Clone, Copy, Debug)]
pub struct MomentMaps<'a> {
    /// Every probe slot's map, one after the other.
    pub maps: &'a [[f32; 2]],
    /// The variance floor (m^2).
    pub floor: f32,
}

impl MomentMaps<'_> {
    /// The visibility of `q` from `probe` at `x`.
    pub fn visibility(&self, probe: usize, x: Vec3, q: Vec3) -> f32 {
        let t = MOMENT_TEXELS as usize;
        visibility(&self.maps[probe * t..(probe + 1) * t], self.floor, x, q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octahedral_map_round_trips_and_texels_cover_the_sphere() {
        for i in 0..MOMENT_TEXELS {
            let d = texel_dir(i);
            assert!((d.length() - 1.0).abs() < 1e-6);
            let e = oct_encode(d);
            let back = oct_decode(e);
            assert!(
                (back - d).length() < 1e-5,
                "texel {i}: {d} -> {e} -> {back}"
            );
        }
        // Every direction is within 60 degrees of some texel centre.
        for k in 0..500 {
            let (d, _) = super::super::lattice::direction(super::super::Lattice::Fibonacci, k, 500);
            let best = (0..MOMENT_TEXELS)
                .map(|i| texel_dir(i).dot(d))
                .fold(-1.0f32, f32::max);
            assert!(best > 0.5, "{d}: nearest texel at cos {best}");
        }
    }

    #[test]
    fn a_probe_in_a_box_sees_its_walls_and_not_beyond() {
        // A probe at the centre of a cube of edge 2 (walls at distance 1): the map's mean lies
        // between 1 and sqrt 3 everywhere; a point inside is visible, a point 0.3 beyond a
        // wall is not.
        let n = 256;
        let dirs: Vec<Vec3> = (0..n)
            .map(|k| super::super::lattice::direction(super::super::Lattice::Fibonacci, k, n).0)
            .collect();
        let dists: Vec<f32> = dirs.iter().map(|d| 1.0 / d.abs().max_element()).collect();
        let map = build_map(&dirs, &vec![1.0; n as usize], &dists, 10.0);
        for m in &map {
            assert!(m[0] >= 1.0 && m[0] <= 3f32.sqrt(), "{m:?}");
            assert!(m[1] >= m[0] * m[0] - 1e-5, "{m:?}");
        }
        let floor = variance_floor(0.5);
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::Z, Vec3::new(0.6, 0.0, -0.8)] {
            let inside = d * 0.8 / d.abs().max_element();
            let beyond = d * 1.3 / d.abs().max_element();
            let vis_in = visibility(&map, floor, Vec3::ZERO, inside);
            let vis_out = visibility(&map, floor, Vec3::ZERO, beyond);
            assert_eq!(vis_in, 1.0, "{d}");
            assert!(vis_out < 1e-3, "{d}: {vis_out}");
        }
        // Misses count at the far distance: an open direction stays visible.
        let map = build_map(&dirs, &vec![0.0; n as usize], &dists, 10.0);
        assert_eq!(
            visibility(&map, floor, Vec3::ZERO, Vec3::new(0.0, 5.0, 0.0)),
            1.0
        );
    }

    #[test]
    fn the_map_is_continuous_across_its_folded_edges() {
        // A smooth field (distance 2 + x + 0.5 y - z of the direction) read along directions
        // a hair apart on either side of the square's edges and the diamond's: no jumps.
        let n = 256;
        let dirs: Vec<Vec3> = (0..n)
            .map(|k| super::super::lattice::direction(super::super::Lattice::Fibonacci, k, n).0)
            .collect();
        let dists: Vec<f32> = dirs.iter().map(|d| 2.0 + d.x + 0.5 * d.y - d.z).collect();
        let map = build_map(&dirs, &vec![1.0; n as usize], &dists, 10.0);
        for k in 0..400 {
            let a = k as f32 / 400.0 * std::f32::consts::TAU;
            for z in [-0.999, -0.3, 0.0, 0.3] {
                let r = (1.0f32 - z * z).sqrt();
                let d = Vec3::new(r * a.cos(), r * a.sin(), z);
                let e = Vec3::new(1e-3, -7e-4, 5e-4);
                let (m0, m1) = (sample(&map, d), sample(&map, (d + e).normalize()));
                assert!((m0 - m1).abs().max_element() < 0.05, "{d}: {m0} {m1}");
            }
        }
    }
}
