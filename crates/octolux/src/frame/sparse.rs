//! Sparse shading: a technique whose per-pixel gather is costly (cone tracing, VPL shadow
//! rays) shades one pixel per `f` x `f` block of the image, at the block's centre
//! (`block_pixel` in `sparse.wgsl`), into a reduced image, and [`SparseImage::record`]
//! reconstructs every pixel from the 2 x 2 shaded blocks around it, weighted bilinearly and by
//! how alike their surfaces are (`upsample.wgsl`). Indirect irradiance varies slowly over a
//! surface, so the gather's cost falls by f^2 for little error (docs/vct.md, docs/vpl.md).

use super::GiSurfaces;
use crate::gpu::pass::{dispatch_2d, KeptBindGroup};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};

/// The reduced image of a sparse gather and its reconstruction into a full-size one.
pub struct SparseImage {
    factor: u32,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    group: KeptBindGroup,
}

impl SparseImage {
    /// The reduced image (`Rgba16Float`, ceil(width / factor) x ceil(height / factor), written
    /// by a compute pass) of an image of `width` x `height`, recorded under `owner`, and the
    /// reconstruction pipeline.
    pub fn new(ctx: &GpuContext, owner: &str, factor: u32, width: u32, height: u32) -> Self {
        let factor = factor.max(1);
        let (texture, view) = crate::gpu::alloc::image_target(
            ctx,
            owner,
            "sparse irradiance",
            width.div_ceil(factor),
            height.div_ceil(factor),
            wgpu::TextureFormat::Rgba16Float,
            wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let module = ctx.shader("upsample", &library_shader("frame/upsample", &[]));
        let pipeline = ctx.compute_pipeline("upsample", &module, "main");
        let params = ctx.create_buffer_init(
            owner,
            "sparse factor",
            &factor.to_le_bytes(),
            wgpu::BufferUsages::STORAGE,
        );
        SparseImage {
            factor,
            texture,
            view,
            pipeline,
            params,
            group: KeptBindGroup::default(),
        }
    }

    /// The sparse factor f.
    pub fn factor(&self) -> u32 {
        self.factor
    }

    /// The reduced image the gather writes, one texel per block.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The reduced image's texture.
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// Records the reconstruction of every pixel of `out` (the full-size image, a storage
    /// texture of `Rgba16Float`) as the pass `name`, from the reduced image and the G-buffer
    /// seen through the camera uniform `camera` (its work count: the pixels).
    pub fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        name: &str,
        camera: &wgpu::Buffer,
        gbuffer: GiSurfaces<'_>,
        out: &wgpu::TextureView,
    ) -> crate::Result<()> {
        let tex = wgpu::BindingResource::TextureView;
        let entries = [
            (0, camera.as_entire_binding()),
            (1, tex(gbuffer.depth_view)),
            (2, tex(gbuffer.normal_view)),
            (3, tex(&self.view)),
            (4, self.params.as_entire_binding()),
            (5, tex(out)),
        ];
        let group = self.group.get(ctx, name, &self.pipeline, &entries);
        let (w, h) = (gbuffer.width, gbuffer.height);
        crate::gpu::work::add(ctx, name, &["pixels"], 0, u64::from(w) * u64::from(h))?;
        dispatch_2d(timer, name, &self.pipeline, &group, w, h);
        Ok(())
    }
}
