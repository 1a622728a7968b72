//! Deferred direct lighting (`direct.wgsl`): emission plus the Lambertian response to every
//! light and the sky, shadowed through the shadow-map array; the sky where nothing was drawn.

use crate::embed::LitScene;
use crate::frame::light_bindings;
use crate::frame::GBuffer;
use crate::gpu::alloc::image_target;
use crate::gpu::pass::{bind, dispatch_2d};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};

const OWNER: &str = "direct";

/// Direct-light pass and its output.
pub(crate) struct DirectLight {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    pub output: wgpu::Texture,
    pub output_view: wgpu::TextureView,
}

impl DirectLight {
    pub fn new(
        ctx: &GpuContext,
        camera: &wgpu::Buffer,
        gbuffer: &GBuffer,
        lit: &LitScene,
        width: u32,
        height: u32,
    ) -> DirectLight {
        let (shadows, sky, lights) = (&lit.shadows, &lit.sky, &lit.lights);
        let module = ctx.shader("direct", &library_shader("render/direct", &[]));
        let pipeline = ctx.compute_pipeline("direct", &module, "main");
        let (output, output_view) = image_target(
            ctx,
            OWNER,
            "direct radiance",
            width,
            height,
            wgpu::TextureFormat::Rgba16Float,
            wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let mut entries = vec![
            (0, camera.as_entire_binding()),
            (1, texture(&gbuffer.albedo_view)),
            (2, texture(&gbuffer.normal_view)),
            (3, texture(&gbuffer.emission_view)),
            (4, texture(&gbuffer.depth_view)),
            (9, texture(&output_view)),
            (10, sky.params.as_entire_binding()),
            (11, sky.map.as_entire_binding()),
        ];
        entries.extend(light_bindings(lights, shadows.lookup()));
        let bind_group = bind(ctx, &pipeline, &entries);
        DirectLight {
            pipeline,
            bind_group,
            output,
            output_view,
        }
    }

    pub fn render(&self, timer: &mut PassTimer, width: u32, height: u32) {
        dispatch_2d(
            timer,
            "direct light",
            &self.pipeline,
            &self.bind_group,
            width,
            height,
        );
    }
}

fn texture(view: &wgpu::TextureView) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::TextureView(view)
}
