//! Deferred direct lighting (`direct.wgsl`): emission plus the Lambertian response to every
//! light and the sky, shadowed through the shadow-map array; the sky where nothing was drawn.

use crate::frame::sky::SkyGpu;
use crate::frame::GBuffer;
use crate::frame::GpuLight;
use crate::frame::ShadowMaps;
use crate::gpu::alloc::image_target;
use crate::gpu::pass::{dispatch_2d, texture_entry};
use crate::gpu::{GpuContext, PassTimer};

const OWNER: &str = "direct";

/// Direct-light pass and its output.
pub(crate) struct DirectLight {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    pub output: wgpu::Texture,
    pub output_view: wgpu::TextureView,
    pub lights: wgpu::Buffer,
}

impl DirectLight {
    pub fn new(
        ctx: &GpuContext,
        camera: &wgpu::Buffer,
        gbuffer: &GBuffer,
        shadows: &ShadowMaps,
        sky: &SkyGpu,
        width: u32,
        height: u32,
    ) -> DirectLight {
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let lights = ctx.create_buffer_init(
            OWNER,
            "lights",
            &vec![0u8; shadows.slots.len().max(1) * std::mem::size_of::<GpuLight>()],
            storage,
        );
        let source = [
            include_str!("../frame/common.wgsl"),
            include_str!("../frame/lights.wgsl"),
            include_str!("direct.wgsl"),
        ]
        .concat();
        let module = ctx.shader("direct", &source);
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
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("direct"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                },
                texture_entry(1, &gbuffer.albedo_view),
                texture_entry(2, &gbuffer.normal_view),
                texture_entry(3, &gbuffer.emission_view),
                texture_entry(4, &gbuffer.depth_view),
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: lights.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: shadows.lookup().matrices.as_entire_binding(),
                },
                texture_entry(7, &shadows.array_view),
                wgpu::BindGroupEntry {
                    binding: 8,
                    resource: wgpu::BindingResource::Sampler(&shadows.sampler),
                },
                texture_entry(9, &output_view),
                wgpu::BindGroupEntry {
                    binding: 10,
                    resource: sky.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 11,
                    resource: sky.map.as_entire_binding(),
                },
            ],
        });
        DirectLight {
            pipeline,
            bind_group,
            output,
            output_view,
            lights,
        }
    }

    /// Uploads this frame's lights and shadow-layer matrices (column-major 4x4).
    pub fn upload(&self, queue: &wgpu::Queue, lights: &[GpuLight]) {
        if !lights.is_empty() {
            queue.write_buffer(&self.lights, 0, bytemuck::cast_slice(lights));
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
