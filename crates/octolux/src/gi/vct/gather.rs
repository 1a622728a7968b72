//! The diffuse gather's cone set: `003`'s six cones (one along the normal, five at 60 degrees
//! around it), weighted by the cosine of their angle to the normal and normalised to sum to 1.
//! Irradiance is `pi x` the weighted mean of the cones' radiance: exact for a uniform
//! environment (`pi L`), which `003`'s unnormalised weights (summing to 3.5) were not. For a
//! cosine-shaped environment `L0 max(0, cos)` the six cones give 0.643 where the integral is
//! 2/3: 3.6 % low, the price of six cones.
//!
//! Denser sets (the `cones` setting, 8 to 64) are cosine-distributed: directions on a
//! Fibonacci spiral of the unit disk lifted to the hemisphere (Malley's method), each
//! weighted 1/N, so irradiance is `pi x` their mean radiance, again exact for a uniform
//! environment.

use glam::Vec3;

/// Cone counts the diffuse gather accepts: `003`'s 6, or a cosine-distributed set of 8..=64.
pub fn check_cone_count(cones: u32) -> bool {
    cones == 6 || (8..=64).contains(&cones)
}

/// The diffuse cone set of `cones` cones (see [`check_cone_count`]): per cone its direction
/// in the frame whose +y is the normal and its weight (the weights sum to 1).
pub fn cone_set(cones: u32) -> Vec<[f32; 4]> {
    if cones == 6 {
        return (0..6)
            .map(|i| {
                let [x, y, z] = DIFFUSE_CONES_LOCAL[i];
                [x, y, z, diffuse_cone_weight(i)]
            })
            .collect();
    }
    let n = cones.max(1);
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|k| {
            let u = (k as f32 + 0.5) / n as f32;
            let (r, phi) = (u.sqrt(), k as f32 * golden);
            [
                r * phi.cos(),
                (1.0 - u).sqrt(),
                r * phi.sin(),
                1.0 / n as f32,
            ]
        })
        .collect()
}

/// WGSL declaring the cone set of `cones` cones (`DIFFUSE_CONES`, `DIFFUSE_SET`) and the lanes
/// a gather gives each item (`CONE_LANES`, [`cone_lanes`]), mounted as the module
/// `gi/vct/cone_set` that `gi/vct/gather` and its importers import.
pub fn cone_set_wgsl(cones: u32) -> String {
    let set = cone_set(cones);
    let items: Vec<String> = set
        .iter()
        .map(|[x, y, z, w]| format!("vec4<f32>({x:?}, {y:?}, {z:?}, {w:?})"))
        .collect();
    format!(
        "const DIFFUSE_CONES: u32 = {n}u;\nconst CONE_LANES: u32 = {lanes}u;\n\
         const CONES_PER_LANE: u32 = {per_lane}u;\nconst CONE_RESULTS: u32 = {results}u;\n\
         var<private> DIFFUSE_SET: array<vec4<f32>, {n}> = array<vec4<f32>, {n}>({});\n",
        items.join(", "),
        n = set.len(),
        lanes = cone_lanes(set.len() as u32),
        per_lane = cones_per_lane(set.len() as u32),
        results = 64 * cones_per_lane(set.len() as u32),
    )
}

/// Lanes per item of a gather of `cones` cones (`gi/vct/cone_lanes.wgsl`): one per cone,
/// rounded up to a power of two so that a 64-lane workgroup holds whole items, at most 16 (a
/// lane per cone of 64 repeats the item's setup more than the cones' work repays).
pub fn cone_lanes(cones: u32) -> u32 {
    cones.next_power_of_two().min(16)
}

/// Cones each lane of a gather of `cones` cones marches ([`cone_lanes`]).
pub fn cones_per_lane(cones: u32) -> u32 {
    cones.div_ceil(cone_lanes(cones))
}

/// Irradiance from the cones' radiance for the cone set `set` ([`cone_set`]): `pi x` their
/// weighted mean.
pub fn gather_irradiance_set(set: &[[f32; 4]], cone_radiance: &[Vec3]) -> Vec3 {
    set.iter()
        .zip(cone_radiance)
        .map(|(c, l)| *l * c[3])
        .sum::<Vec3>()
        * std::f32::consts::PI
}

/// World direction of cone `local` (a [`cone_set`] entry) around the unit normal `n`.
pub fn set_cone_dir(n: Vec3, local: [f32; 4]) -> Vec3 {
    let (t, b) = cone_basis(n);
    (t * local[0] + n * local[1] + b * local[2]).normalize()
}

/// `003`'s cone directions in the frame whose +y is the normal.
pub const DIFFUSE_CONES_LOCAL: [[f32; 3]; 6] = [
    [0.0, 1.0, 0.0],
    [0.0, 0.5, 0.866025],
    [0.823639, 0.5, 0.267617],
    [0.509037, 0.5, -0.700629],
    [-0.509037, 0.5, -0.700629],
    [-0.823639, 0.5, 0.267617],
];

/// Normalised cosine weight of cone `i` (1/3.5 for the centre cone, 0.5/3.5 for the ring).
pub fn diffuse_cone_weight(i: usize) -> f32 {
    DIFFUSE_CONES_LOCAL[i][1] / 3.5
}

/// An orthonormal basis `(t, b)` around the unit normal `n` (CPU twin of `cone_basis`).
pub fn cone_basis(n: Vec3) -> (Vec3, Vec3) {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

/// World direction of cone `i` around the unit normal `n` (CPU twin of `diffuse_cone_dir`).
pub fn diffuse_cone_dir(n: Vec3, i: usize) -> Vec3 {
    let [x, y, z] = DIFFUSE_CONES_LOCAL[i];
    let (t, b) = cone_basis(n);
    (t * x + n * y + b * z).normalize()
}

/// Irradiance from the six cones' radiance: `pi x` their weighted mean.
pub fn gather_irradiance(cone_radiance: &[Vec3; 6]) -> Vec3 {
    cone_radiance
        .iter()
        .enumerate()
        .map(|(i, l)| *l * diffuse_cone_weight(i))
        .sum::<Vec3>()
        * std::f32::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normals() -> Vec<Vec3> {
        let mut out = vec![
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
            Vec3::X,
            Vec3::NEG_X,
        ];
        for i in 0..50 {
            let a = i as f32 * 2.399963;
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 50.0;
            let r = (1.0 - z * z).sqrt();
            out.push(Vec3::new(r * a.cos(), r * a.sin(), z));
        }
        out
    }

    #[test]
    fn the_basis_is_orthonormal_and_the_cones_keep_their_angle_to_the_normal() {
        for n in normals() {
            let (t, b) = cone_basis(n);
            for (u, v) in [(t, b), (t, n), (b, n)] {
                assert!(u.dot(v).abs() < 1e-5, "{n}");
            }
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            for (i, local) in DIFFUSE_CONES_LOCAL.iter().enumerate() {
                let d = diffuse_cone_dir(n, i);
                assert!((d.dot(n) - local[1]).abs() < 1e-5, "{n} cone {i}");
            }
            // The ring is evenly spread: neighbours 72 degrees apart about the normal.
            for i in 1..6 {
                let j = if i == 5 { 1 } else { i + 1 };
                let (a, c) = (diffuse_cone_dir(n, i), diffuse_cone_dir(n, j));
                let (pa, pc) = (
                    (a - n * a.dot(n)).normalize(),
                    (c - n * c.dot(n)).normalize(),
                );
                assert!((pa.dot(pc) - 72f32.to_radians().cos()).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn denser_sets_are_unit_upper_hemisphere_and_integrate_a_cosine_environment() {
        assert!(check_cone_count(6) && check_cone_count(16) && check_cone_count(64));
        assert!(!check_cone_count(0) && !check_cone_count(7) && !check_cone_count(65));
        for cones in [8, 16, 32, 64] {
            let set = cone_set(cones);
            assert_eq!(set.len(), cones as usize);
            let total: f32 = set.iter().map(|c| c[3]).sum();
            assert!((total - 1.0).abs() < 1e-5);
            for c in &set {
                let d = Vec3::new(c[0], c[1], c[2]);
                assert!((d.length() - 1.0).abs() < 1e-5 && d.y > 0.0, "{d}");
            }
            // Uniform: exactly pi L. Cosine-shaped, L0 max(0, cos): pi x 2/3 within the
            // quadrature error, which shrinks with the count (measured +0.35 % at 8 cones,
            // +0.02 % at 64; the six cones are 3.6 % low).
            let l = Vec3::new(0.7, 1.3, 2.0);
            let e = gather_irradiance_set(&set, &vec![l; set.len()]);
            assert!((e - std::f32::consts::PI * l).abs().max_element() < 1e-4);
            let cosine: Vec<Vec3> = set.iter().map(|c| Vec3::splat(c[1])).collect();
            let e = gather_irradiance_set(&set, &cosine).x / std::f32::consts::PI;
            println!("{cones} cones: cosine environment {e} (exact 2/3)");
            assert!((e / (2.0 / 3.0) - 1.0).abs() < 0.02, "{cones}: {e}");
        }
        // The six-cone set is 003's with its weights.
        let six = cone_set(6);
        assert_eq!(six[0], [0.0, 1.0, 0.0, 1.0 / 3.5]);
        assert!(cone_set_wgsl(16).contains("array<vec4<f32>, 16>"));
        // Whole items per 64-lane workgroup: 6 cones take 8 lanes, 16 take 16, 64 one group.
        assert!(cone_set_wgsl(6).contains("CONE_LANES: u32 = 8u"));
        for (cones, lanes, per_lane) in [
            (6, 8, 1),
            (8, 8, 1),
            (9, 16, 1),
            (16, 16, 1),
            (33, 16, 3),
            (64, 16, 4),
        ] {
            assert_eq!(
                (cone_lanes(cones), cones_per_lane(cones)),
                (lanes, per_lane)
            );
            assert_eq!(64 % lanes, 0);
            assert!(lanes * per_lane >= cones);
        }
    }

    #[test]
    fn a_uniform_environment_gives_pi_l_and_a_cosine_one_is_within_four_percent() {
        let l = Vec3::new(0.7, 1.3, 2.0);
        let e = gather_irradiance(&[l; 6]);
        assert!(
            (e - std::f32::consts::PI * l).abs().max_element() < 1e-5,
            "{e}"
        );
        // L(w) = max(0, w.n): exact irradiance pi x 2/3.
        let cosine: [Vec3; 6] = std::array::from_fn(|i| Vec3::splat(DIFFUSE_CONES_LOCAL[i][1]));
        let e = gather_irradiance(&cosine).x / std::f32::consts::PI;
        assert!((e - 2.25 / 3.5).abs() < 1e-6);
        assert!((e / (2.0 / 3.0) - 1.0).abs() < 0.04, "{e}");
    }
}
