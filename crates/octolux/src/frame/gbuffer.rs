//! The G-buffer: albedo, world normal (facing the viewer) and emission in `Rgba16Float`, depth
//! in `Depth32Float`. World positions are reconstructed from depth (`common.wgsl`), which keeps
//! the colour attachments within the 32 bytes per pixel every adapter allows.

use super::scene_gpu::{raster_pipeline, SceneGpu};
use crate::gpu::alloc::image_target;
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};

const OWNER: &str = "gbuffer";
/// Format of the albedo, normal and emission targets.
pub const GBUFFER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The part of a G-buffer the GI techniques read, at the resolution of their output: depth
/// (`Depth32Float`, wgpu's 0 at the near plane to 1 at the far plane, 1 where nothing was
/// drawn) under the camera uniform's `view_proj`, and the world-space unit normal facing the
/// viewer (`Rgba16Float`, xyz). Octolux's own [`GBuffer`] holds them in this form; a caller's
/// G-buffer is brought into it by [`crate::embed`]'s input pass.
#[derive(Clone, Copy, Debug)]
pub struct GiSurfaces<'a> {
    /// Depth in octolux's convention (above).
    pub depth_view: &'a wgpu::TextureView,
    /// World normal facing the viewer.
    pub normal_view: &'a wgpu::TextureView,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// G-buffer targets. GI techniques read these (the boundary of docs/architecture.md, "The GI boundary").
pub struct GBuffer {
    /// Linear albedo (rgb), a = 1 where there is geometry.
    pub albedo: wgpu::Texture,
    /// World-space unit normal (xyz), facing the camera.
    pub normal: wgpu::Texture,
    /// Emitted radiance (rgb).
    pub emission: wgpu::Texture,
    /// Depth, 0..1 (1 = background).
    pub depth: wgpu::Texture,
    /// Views of the above.
    pub albedo_view: wgpu::TextureView,
    /// View of `normal`.
    pub normal_view: wgpu::TextureView,
    /// View of `emission`.
    pub emission_view: wgpu::TextureView,
    /// View of `depth`.
    pub depth_view: wgpu::TextureView,
    pipeline: wgpu::RenderPipeline,
}

impl GBuffer {
    pub(crate) fn new(ctx: &GpuContext, scene_gpu: &SceneGpu, width: u32, height: u32) -> GBuffer {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let (albedo, albedo_view) =
            image_target(ctx, OWNER, "albedo", width, height, GBUFFER_FORMAT, usage);
        let (normal, normal_view) =
            image_target(ctx, OWNER, "normal", width, height, GBUFFER_FORMAT, usage);
        let (emission, emission_view) =
            image_target(ctx, OWNER, "emission", width, height, GBUFFER_FORMAT, usage);
        let (depth, depth_view) = image_target(
            ctx,
            OWNER,
            "depth",
            width,
            height,
            wgpu::TextureFormat::Depth32Float,
            usage,
        );
        let module = ctx.shader("gbuffer", &library_shader("frame/gbuffer", &[]));
        let layout = scene_gpu.layouts.pipeline_layout(&ctx.device);
        let color = Some(wgpu::ColorTargetState {
            format: GBUFFER_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let pipeline = raster_pipeline(
            &ctx.device,
            "gbuffer",
            &layout,
            &module,
            "fs_gbuffer",
            &[color.clone(), color.clone(), color],
            Default::default(),
        );
        GBuffer {
            albedo,
            normal,
            emission,
            depth,
            albedo_view,
            normal_view,
            emission_view,
            depth_view,
            pipeline,
        }
    }

    /// What the GI techniques read of it.
    pub fn surfaces(&self) -> GiSurfaces<'_> {
        GiSurfaces {
            depth_view: &self.depth_view,
            normal_view: &self.normal_view,
            width: self.depth.width(),
            height: self.depth.height(),
        }
    }

    /// Rasterises the scene; view uniform 0 must hold the camera. Counts the triangles drawn
    /// ([`GBUFFER_WORK`]).
    pub(crate) fn render(&self, timer: &mut PassTimer, scene_gpu: &SceneGpu) -> crate::Result<()> {
        let mut triangles = 0;
        timer.pass("gbuffer", |encoder, stamps| {
            let clear = |view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("gbuffer"),
                color_attachments: &[
                    clear(&self.albedo_view),
                    clear(&self.normal_view),
                    clear(&self.emission_view),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: stamps.render(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &scene_gpu.view_group, &[0]);
            triangles = scene_gpu.draw(&mut pass, 0);
        });
        crate::gpu::work::add(timer.context(), "gbuffer", GBUFFER_WORK, 0, triangles)
    }
}

/// What the G-buffer pass counts: the triangles drawn (those of clusters in the camera's view,
/// `frame/culling.rs`).
pub const GBUFFER_WORK: &[&str] = &["triangles drawn"];
