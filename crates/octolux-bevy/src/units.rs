//! Bevy's photometric units to octolux's radiometric ones and back.
//!
//! Bevy lights its scenes in photometric units: point and spot lights in lumens (luminous power
//! over the whole sphere: the shader divides by 4 pi to get candela), directional lights in lux,
//! emissive materials and ambient light in nits (cd/m^2), all multiplied by the camera's
//! exposure before tone mapping. Octolux works in radiometric units: W/sr, W/m^2 and
//! W/(m^2 sr). Its transport is linear, so any constant factor between the two systems cancels
//! as long as the same one is used both ways; octolux's own glTF importer uses 683 lm/W (the
//! luminous efficacy of 555 nm light), and so does this crate, which keeps octolux's numbers
//! those of the same scene loaded by octolux itself (and its 16-bit float images far from
//! overflow under a 100 000 lux sun).

use bevy::color::{Color, LinearRgba};
use glam::Vec3;

/// Lumens per watt between Bevy's photometric and octolux's radiometric units.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// Linear RGB of a Bevy colour, as octolux takes colours.
pub fn linear_rgb(color: Color) -> Vec3 {
    let c = LinearRgba::from(color);
    Vec3::new(c.red, c.green, c.blue)
}

/// Radiant intensity (W/sr) of a Bevy point or spot light of `lumens`: Bevy spreads a light's
/// lumens over the whole sphere (a spot light is a masked point light), candela = lm / (4 pi).
pub fn intensity_from_lumens(lumens: f32) -> f32 {
    lumens / (4.0 * std::f32::consts::PI) / LUMENS_PER_WATT
}

/// Irradiance (W/m^2) of a Bevy directional light of `lux`.
pub fn irradiance_from_lux(lux: f32) -> f32 {
    lux / LUMENS_PER_WATT
}

/// Radiance (W/(m^2 sr)) of `nits` (cd/m^2): emissive surfaces, ambient light as a sky.
pub fn radiance_from_nits(nits: f32) -> f32 {
    nits / LUMENS_PER_WATT
}

/// The factor that turns octolux's indirect irradiance E (W/m^2) into what Bevy's shading adds
/// for a Lambertian surface of diffuse colour `c`: `c / pi * E` in nits (x 683), times the
/// camera's `exposure`, the scale Bevy applies to its own direct and ambient light.
pub fn compose_scale(exposure: f32) -> f32 {
    exposure * LUMENS_PER_WATT / std::f32::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glTF lamp of 2049 cd reaches Bevy as 2049 * 4 pi lm (bevy_gltf) and must come back to
    /// octolux as the 3 W/sr its own importer makes of it.
    #[test]
    fn gltf_candela_round_trip() {
        let lumens = 2049.0 * 4.0 * std::f32::consts::PI;
        assert!((intensity_from_lumens(lumens) - 3.0).abs() < 1e-5);
        assert!((irradiance_from_lux(683.0) - 1.0).abs() < 1e-6);
        assert!((radiance_from_nits(683.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn compose_gives_nits_of_a_lambertian_surface() {
        // E = pi W/m^2 on a white Lambertian surface: radiance 1 W/(m^2 sr) = 683 nits.
        let nits = compose_scale(1.0) * std::f32::consts::PI;
        assert!((nits - 683.0).abs() < 1e-3);
    }
}
