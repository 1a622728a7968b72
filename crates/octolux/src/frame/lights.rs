//! Which lights a frame is lit by: the scene's own, then the directional lights that stand in
//! for its sky, and how many shadow views (and reflective shadow maps) they need. The packing
//! of lights for the shaders is `lights.wgsl`.

use crate::scene::{Light, LightKind, Scene};
use bytemuck::{Pod, Zeroable};

/// One light as `lights.wgsl` declares it (`Light`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
pub struct GpuLight {
    /// xyz position (sky lights: spread, depth range, filter margin), w kind.
    pub position_kind: [f32; 4],
    /// xyz direction, w cosine of the inner cone angle.
    pub direction_cos_inner: [f32; 4],
    /// rgb radiant intensity or irradiance, w cosine of the outer cone angle.
    pub radiant_cos_outer: [f32; 4],
    /// Shadow lookup: first layer (-1 none), texel footprint, orthographic flag, sky layer + 1.
    pub shadow: [f32; 4],
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
