//! Lookup: indirect irradiance per G-buffer pixel from the accumulated (or merged) volume.

use super::{bind, groups, GiFrame};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};

/// The indirect-irradiance image.
pub struct Output {
    /// `Rgba16Float`, G-buffer sized.
    pub texture: wgpu::Texture,
    /// View for compose.
    pub view: wgpu::TextureView,
}

impl Output {
    /// Allocates the output image.
    pub fn new(ctx: &GpuContext, owner: &str, width: u32, height: u32) -> Output {
        let (texture, view) = crate::gi::indirect_target(ctx, owner, width, height);
        Output { texture, view }
    }
}

/// The lookup pipeline.
pub struct Lookup {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
}

/// WGSL source of the lookup.
pub fn source() -> String {
    library_shader("gi/lpv/lookup", &[])
}

impl Lookup {
    /// Builds the pipeline reading `volume` as described by the `Grids` uniform `grids`.
    pub(crate) fn new(
        ctx: &GpuContext,
        grids: &wgpu::Buffer,
        volume: &wgpu::Buffer,
        output: &Output,
        frame: &GiFrame,
    ) -> Lookup {
        let module = ctx.shader("lpv lookup", &source());
        let pipeline = ctx.compute_pipeline("lpv lookup", &module, "main");
        let tex = wgpu::BindingResource::TextureView;
        let group = bind(
            ctx,
            &pipeline,
            &[
                (0, frame.camera_uniform.as_entire_binding()),
                (1, grids.as_entire_binding()),
                (2, tex(frame.gbuffer.depth_view)),
                (3, tex(frame.gbuffer.normal_view)),
                (4, volume.as_entire_binding()),
                (5, tex(&output.view)),
            ],
        );
        Lookup { pipeline, group }
    }

    /// Records the lookup over every pixel (its work count: the pixels).
    pub(crate) fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        name: &str,
        output: &Output,
    ) -> crate::Result<()> {
        let (w, h) = (output.texture.width(), output.texture.height());
        crate::gpu::work::add(ctx, name, &["pixels"], 0, u64::from(w) * u64::from(h))?;
        timer.pass(name, |encoder, stamps| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(name),
                timestamp_writes: stamps.compute(),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.group, &[]);
            pass.dispatch_workgroups(groups(w, 8), groups(h, 8), 1);
        });
        Ok(())
    }
}
