//! What the techniques read in a frame, made by the renderer before the GI passes: the scene
//! on the GPU ([`SceneGpu`]), the lights and their shadow maps ([`ShadowMaps`]), the
//! G-buffer ([`GBuffer`]), reflective shadow maps ([`rsm`]), the sky, and the shaders that
//! declare them (`common.wgsl` for the camera, `lights.wgsl`, `raster.wgsl`).
//!
//! This layer sits below the techniques (`gi`) and the voxel structures, and above the GPU
//! plumbing (`gpu`) and the scene model: it imports neither a technique nor the renderer.

mod culling;
mod gbuffer;
mod lights;
pub mod rsm;
pub(crate) mod scene_gpu;
pub(crate) mod shadow;
pub(crate) mod sky;
pub mod sparse;

pub use gbuffer::{GBuffer, GiSurfaces, GBUFFER_FORMAT};
pub(crate) use lights::sky_regions_of;
pub use lights::{
    light_bindings, light_kind_and_cone, render_lights, shadow_layer_count, sky_light_count,
    GpuLight, LIGHT_BINDINGS, LIGHT_BYTES, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT,
};
pub use scene_gpu::SceneGpu;
pub use shadow::{LayerView, ShadowLookup, ShadowLookupBuffers, ShadowMaps};
pub use sky::{sh_irradiance, sh_irradiance_coefficients, sky_lights};

use bytemuck::{Pod, Zeroable};

/// `Camera` of `common.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct CameraUniform {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    /// Eye position.
    pub position: [f32; 3],
    pub _pad: u32,
    /// Pixels: width, height.
    pub size: [f32; 2],
    /// 1 / width, 1 / height.
    pub inv_size: [f32; 2],
    /// Exposure scale 2^ev (octolux's own compose).
    pub exposure: f32,
    /// Lights in the lights buffer.
    pub light_count: u32,
    /// Scene time, s.
    pub time: f32,
    /// What `render/compose.wgsl` shows ([`crate::render::Output`]).
    pub output: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_uniform_mirrors_the_wgsl_block() {
        crate::gpu::layout::assert_mirrors_wgsl!(
            CameraUniform,
            "frame/common",
            "Camera",
            [
                view_proj,
                inv_view_proj,
                position,
                _pad,
                size,
                inv_size,
                exposure,
                light_count,
                time,
                output
            ]
        );
    }
}
