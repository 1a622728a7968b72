//! Which lights a frame is lit by: the scene's own, then the directional lights that stand in
//! for its sky, and how many shadow views (and reflective shadow maps) they need. The packing
//! of lights for the shaders is `lights.wgsl`.

use crate::scene::{Light, LightKind, Scene};
use bytemuck::{Pod, Zeroable};

/// One light as `lights.wgsl` declares it (`Light`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
pub struct GpuLight {
    /// Position (point and spot lights).
    pub position: [f32; 3],
    /// [`LIGHT_POINT`], [`LIGHT_SPOT`] or [`LIGHT_DIRECTIONAL`].
    pub kind: u32,
    /// Unit direction of travel (spot and directional lights).
    pub direction: [f32; 3],
    /// Cosine of a spot cone's inner half-angle (1 for other lights).
    pub cos_inner: f32,
    /// Radiant intensity, W/sr (point, spot), or irradiance, W/m^2 (directional).
    pub radiant: [f32; 3],
    /// Cosine of a spot cone's outer half-angle (-1 for other lights).
    pub cos_outer: f32,
    /// The light's first shadow view (its lookup matrix; a point light's six follow it), -1
    /// for none.
    pub shadow_view: i32,
    /// World size of a shadow texel: per metre of distance (perspective views) or absolute
    /// (orthographic ones).
    pub shadow_texel: f32,
    /// 1 when the light's shadow views are orthographic.
    pub shadow_orthographic: u32,
    /// Sky lights (`frame/sky.rs`): 1 + the shadow-map layer that holds their tile; 0 for
    /// every other light.
    pub sky_layer_plus_one: u32,
    /// Sky lights: tangent of the angular radius of the sky region the light stands for
    /// (0: hard shadows).
    pub sky_spread: f32,
    /// Sky lights: depth range of the shadow view (world distance = depth x range).
    pub sky_depth_range: f32,
    /// Sky lights: the largest soft-shadow filter radius, texels (the tile's free margin).
    pub sky_margin: f32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: u32,
}

impl GpuLight {
    /// `light` without shadow maps (`shadow_view` -1): what a pass that finds visibility its
    /// own way reads.
    pub fn unshadowed(light: &Light) -> GpuLight {
        let (kind, cos_inner, cos_outer) = light_kind_and_cone(light.kind);
        GpuLight {
            position: light.position.to_array(),
            kind,
            direction: light.direction.to_array(),
            cos_inner,
            radiant: light.radiant().to_array(),
            cos_outer,
            shadow_view: -1,
            ..Default::default()
        }
    }
}

/// [`GpuLight::kind`] of a point light.
pub const LIGHT_POINT: u32 = 0;
/// [`GpuLight::kind`] of a spot light.
pub const LIGHT_SPOT: u32 = 1;
/// [`GpuLight::kind`] of a directional light.
pub const LIGHT_DIRECTIONAL: u32 = 2;

/// The [`GpuLight::kind`] of `kind` with its cone's cosines (inner, outer); 1 and -1 for
/// lights without a cone.
pub fn light_kind_and_cone(kind: LightKind) -> (u32, f32, f32) {
    match kind {
        LightKind::Point => (LIGHT_POINT, 1.0, -1.0),
        LightKind::Spot {
            inner_angle,
            outer_angle,
        } => (LIGHT_SPOT, inner_angle.cos(), outer_angle.cos()),
        LightKind::Directional => (LIGHT_DIRECTIONAL, 1.0, -1.0),
    }
}

/// The first binding of the lights and shadow maps in group 0 of every shader that imports
/// `frame/lights.wgsl` (lights, lookup matrices, shadow maps, comparison sampler: four in a
/// row), above every pass's own bindings.
pub const LIGHT_BINDINGS: u32 = 40;

/// The bind-group entries of `frame/lights.wgsl`'s bindings: `lights` (the renderer's
/// [`GpuLight`] buffer) and the shadow maps' lookup.
pub fn light_bindings<'a>(
    lights: &'a wgpu::Buffer,
    shadows: super::ShadowLookup<'a>,
) -> [(u32, wgpu::BindingResource<'a>); 4] {
    [
        (LIGHT_BINDINGS, lights.as_entire_binding()),
        (LIGHT_BINDINGS + 1, shadows.matrices.as_entire_binding()),
        (
            LIGHT_BINDINGS + 2,
            wgpu::BindingResource::TextureView(shadows.view),
        ),
        (
            LIGHT_BINDINGS + 3,
            wgpu::BindingResource::Sampler(shadows.sampler),
        ),
    ]
}

/// Bytes of one [`GpuLight`] in a lights buffer.
pub const LIGHT_BYTES: u64 = std::mem::size_of::<GpuLight>() as u64;

/// The lights the GPU renderer lights `scene` with: the scene's own, then the directional
/// lights that stand in for its sky ([`super::sky_lights`]), which every technique sees like any sun.
pub fn render_lights(scene: &Scene) -> Vec<Light> {
    let mut lights = scene.lights.clone();
    lights.extend(sky_lights_of(scene));
    lights
}

fn sky_lights_of(scene: &Scene) -> Vec<Light> {
    sky_regions_of(scene).into_iter().map(|(l, _)| l).collect()
}

/// The sky lights of `scene` with the tangents of their angular radii (none without a sky).
pub(crate) fn sky_regions_of(scene: &Scene) -> Vec<(Light, f32)> {
    scene
        .sky
        .as_ref()
        .filter(|s| !s.is_black())
        .map(super::sky::sky_regions)
        .unwrap_or_default()
}

/// The number of directional lights [`render_lights`] adds for `scene`'s sky.
/// (Counted without cutting the sky.)
pub fn sky_light_count(scene: &Scene) -> usize {
    scene
        .sky
        .as_ref()
        .filter(|s| !s.is_black())
        .map_or(0, super::sky::sky_light_count)
}

/// Shadow views (matrices, and reflective shadow maps) `lights` need: one per spot or
/// directional light, six per point light.
pub fn shadow_layer_count(lights: &[Light]) -> u32 {
    lights
        .iter()
        .map(|l| if l.kind == LightKind::Point { 6 } else { 1 })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn gpu_light_mirrors_the_wgsl_light() {
        assert_mirrors_wgsl!(
            GpuLight,
            "frame/lights",
            "Light",
            [
                position,
                kind,
                direction,
                cos_inner,
                radiant,
                cos_outer,
                shadow_view,
                shadow_texel,
                shadow_orthographic,
                sky_layer_plus_one,
                sky_spread,
                sky_depth_range,
                sky_margin,
                _pad
            ]
        );
    }
}
