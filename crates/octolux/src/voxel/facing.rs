//! The radiance's facing, shared by both voxel structures (the WGSL module `voxel/facing`):
//! next to its radiance a voxel keeps the direction that radiance leaves in, as a facing sum
//! (the radiance's weight r + g + b times that direction) filtered as the radiance is, and a
//! cone sample keeps only the share of its radiance that leaves towards the cone's apex
//! ([`facing_toward`]). The octree keeps the sums in a pool beside its radiance
//! ([`crate::voxel::svo::SvoBuilder::with_facing`]), the clipmap the mean direction in a word
//! beside each voxel's radiance ([`crate::voxel::clipmap::Clipmap::radiance`]).

use glam::{Vec3, Vec4};

/// How fast radiance seen from behind fades in [`facing_toward`]: all of it is dropped once
/// the cone travels more than asin(1 / 4) (14.5 degrees) off the plane its surface faces out
/// of (`FACING_SHARPNESS` in `voxel/facing.wgsl`).
pub const FACING_SHARPNESS: f32 = 4.0;

/// CPU twin of `facing_toward` (`voxel/facing.wgsl`): the share of a sample's radiance
/// (`radiance`, premultiplied, with its facing sum `facing`) that leaves towards the apex of a
/// cone travelling along `dir`: 1 - [`FACING_SHARPNESS`] F . dir for the mean facing
/// F = facing / (r + g + b), at most 1 and at least 1 - |F| (the share that does not face
/// away, which keeps a wall thinner than a voxel with both faces lit exact from either side).
pub fn facing_toward(radiance: Vec4, facing: Vec3, dir: Vec3) -> f32 {
    let f = facing / (radiance.x + radiance.y + radiance.z).max(1e-20);
    let undirected = 1.0 - f.length().min(1.0);
    (1.0 - FACING_SHARPNESS * f.dot(dir))
        .min(1.0)
        .max(undirected)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A texel holding a wall thinner than a voxel: radiance `a` on its face towards -x, `b`
    /// on its face towards +x (grey), as the injection and the mips store it: the mean of
    /// the two voxels' radiance and of their facing sums.
    fn thin_wall(a: f32, b: f32) -> (Vec4, Vec3) {
        let radiance = Vec4::new(a + b, a + b, a + b, 2.0) * 0.5;
        let facing = (Vec3::NEG_X * 3.0 * a + Vec3::X * 3.0 * b) * 0.5;
        (radiance, facing)
    }

    #[test]
    fn a_thin_walls_face_is_seen_exactly_from_its_side_at_every_steep_enough_angle() {
        for (a, b) in [(1.0, 2.0), (2.0, 1.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)] {
            let (radiance, facing) = thin_wall(a, b);
            for degrees in [0.0f32, 30.0, 60.0, 75.0] {
                let (sin, cos) = degrees.to_radians().sin_cos();
                // A cone on the -x side travels +x towards the wall and sees face a.
                let towards_a_face = Vec3::new(cos, sin, 0.0);
                let seen = radiance.x * facing_toward(radiance, facing, towards_a_face);
                let seen_b = radiance.x * facing_toward(radiance, facing, -towards_a_face);
                // The brighter face is seen as the texel's mean (at most 1 is kept).
                let (want_a, want_b) = (a.min((a + b) / 2.0), b.min((a + b) / 2.0));
                assert!(
                    (seen - want_a).abs() < 1e-5 && (seen_b - want_b).abs() < 1e-5,
                    "faces {a}, {b} at {degrees} degrees off the normal: {seen}, {seen_b}"
                );
            }
        }
    }

    #[test]
    fn a_lit_face_seen_from_behind_is_dropped_unless_nearly_edge_on() {
        let radiance = Vec4::new(1.0, 1.0, 1.0, 1.0);
        let facing = Vec3::NEG_X * 3.0;
        // Travelling -x the cone sees the back of a face that faces -x (its light leaves
        // along the cone, away from the apex).
        for degrees in [0.0f32, 45.0, 75.0] {
            let (sin, cos) = degrees.to_radians().sin_cos();
            let keep = facing_toward(radiance, facing, Vec3::new(-cos, sin, 0.0));
            assert_eq!(keep, 0.0, "{degrees} degrees off the normal keeps {keep}");
        }
        // Edge-on and from the front it is kept whole; in between it fades.
        assert_eq!(facing_toward(radiance, facing, Vec3::Y), 1.0);
        assert_eq!(facing_toward(radiance, facing, Vec3::X), 1.0);
        // 5.7 degrees off the plane: 1 - 4 sin(5.7 degrees) = 0.6.
        let grazing = Vec3::new(-0.1, 0.995, 0.0).normalize();
        let keep = facing_toward(radiance, facing, grazing);
        assert!(keep > 0.5 && keep < 0.7, "{keep}");
    }

    #[test]
    fn no_facing_keeps_everything() {
        let radiance = Vec4::new(1.0, 0.5, 0.25, 1.0);
        assert_eq!(facing_toward(radiance, Vec3::ZERO, Vec3::X), 1.0);
        assert_eq!(facing_toward(Vec4::ZERO, Vec3::ZERO, Vec3::X), 1.0);
    }
}
