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
    light_bindings, render_lights, shadow_layer_count, sky_light_count, GpuLight, LIGHT_BINDINGS,
    LIGHT_BYTES,
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
    pub position: [f32; 4],
    pub size: [f32; 4],
    pub params: [f32; 4],
}
