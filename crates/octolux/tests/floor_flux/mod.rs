//! Shared by the RSM flux tests (`lpv`, `vpl`): a square Lambertian floor of albedo 0.5 and
//! half side `A` at y = 0, and one light of each type with the flux the floor reflects, in
//! closed form:
//!   point (I, height h): albedo I Omega(square), Omega = 4 atan(a^2 / (h sqrt(2a^2 + h^2)))
//!   spot: albedo I 2 pi integral s(theta) sin(theta) dtheta (the cone lies on the floor)
//!   directional (E, direction d): albedo E |d.y| (2a)^2

use glam::Vec3;
use octolux::scene::{Light, LightKind};

/// Half side of the floor (m).
pub const A: f32 = 1.0;

/// (name, light, reflected flux in W) for a point, a spot and a directional light.
pub fn cases() -> Vec<(&'static str, Light, f32)> {
    let (a, h, albedo) = (A, 0.6f32, 0.5f32);
    let base = Light {
        name: "l".into(),
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity: 2.0,
        position: Vec3::new(0.0, h, 0.0),
        direction: Vec3::NEG_Y,
        animation: None,
    };
    let omega = 4.0 * (a * a / (h * (2.0 * a * a + h * h).sqrt())).atan();
    let (inner, outer) = (30f32.to_radians(), 40f32.to_radians());
    let spot = Light {
        kind: LightKind::Spot {
            inner_angle: inner,
            outer_angle: outer,
        },
        ..base.clone()
    };
    let steps = 20000;
    let cone: f32 = (0..steps)
        .map(|i| {
            let theta = (i as f32 + 0.5) / steps as f32 * outer;
            spot.spot_factor(Vec3::new(theta.sin(), -theta.cos(), 0.0))
                * theta.sin()
                * (outer / steps as f32)
        })
        .sum::<f32>()
        * 2.0
        * std::f32::consts::PI;
    let sun_dir = Vec3::new(0.3, -1.0, 0.2).normalize();
    let sun = Light {
        kind: LightKind::Directional,
        direction: sun_dir,
        ..base.clone()
    };
    vec![
        ("point", base, albedo * 2.0 * omega),
        ("spot", spot, albedo * 2.0 * cone),
        (
            "directional",
            sun,
            albedo * 2.0 * sun_dir.y.abs() * 4.0 * a * a,
        ),
    ]
}
