//! Compose and tone map (`compose.wgsl`): direct + albedo/pi x indirect irradiance, then
//! exposure, the filmic curve and sRGB encoding for display.

use crate::frame::GBuffer;
use crate::gpu::alloc::image_target;
use crate::gpu::pass::{dispatch_2d, texture_entry};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};

const OWNER: &str = "compose";

/// Compose pass and its HDR and display outputs.
pub(crate) struct Compose {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// Stand-in for a technique without a specular image (1 x 1, black).
    no_specular: wgpu::TextureView,
    pub hdr: wgpu::Texture,
    hdr_view: wgpu::TextureView,
    pub ldr: wgpu::Texture,
    ldr_view: wgpu::TextureView,
}

impl Compose {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Compose {
        let module = ctx.shader("compose", &library_shader("render/compose", &[]));
        let pipeline = ctx.compute_pipeline("compose", &module, "main");
        let layout = pipeline.get_bind_group_layout(0);
        let usage = wgpu::TextureUsages::STORAGE_BINDING;
        let (hdr, hdr_view) = image_target(
            ctx,
            OWNER,
            "hdr",
            width,
            height,
            wgpu::TextureFormat::Rgba32Float,
            usage,
        );
        let (ldr, ldr_view) = image_target(
            ctx,
            OWNER,
            "ldr",
            width,
            height,
            wgpu::TextureFormat::Rgba8Unorm,
            usage,
        );
        let (_, no_specular) = image_target(
            ctx,
            OWNER,
            "no specular",
            1,
            1,
            wgpu::TextureFormat::Rgba16Float,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        Compose {
            pipeline,
            layout,
            bind_group: None,
            no_specular,
            hdr,
            hdr_view,
            ldr,
            ldr_view,
        }
    }

    /// (Re)binds the inputs; called when the GI technique (and so its output) changes.
    pub fn bind(
        &mut self,
        ctx: &GpuContext,
        camera: &wgpu::Buffer,
        direct: &wgpu::TextureView,
        gbuffer: &GBuffer,
        indirect: &wgpu::TextureView,
        specular: Option<&wgpu::TextureView>,
    ) {
        self.bind_group = Some(ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("compose"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                },
                texture_entry(1, direct),
                texture_entry(2, &gbuffer.albedo_view),
                texture_entry(3, indirect),
                texture_entry(4, &self.hdr_view),
                texture_entry(5, &self.ldr_view),
                texture_entry(6, specular.unwrap_or(&self.no_specular)),
            ],
        }));
    }

    pub fn render(&self, timer: &mut PassTimer, width: u32, height: u32) {
        if let Some(group) = &self.bind_group {
            dispatch_2d(timer, "compose", &self.pipeline, group, width, height);
        }
    }
}
