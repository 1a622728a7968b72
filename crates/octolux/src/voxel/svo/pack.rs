//! The build's last brick pass: converts the RGBA16F pool the build filters in (216 bytes per
//! brick) into the finished RGBA8 pool (108 bytes per brick), clamping to 0..1
//! (`svo/pack.wgsl`).

use crate::gpu::pass::{bind_buffers, dispatch_1d};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::svo::OWNER;

/// `PackParams` of `svo/pack.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct PackParams {
    /// Texels of all bricks (27 per brick).
    pub(super) texels: u32,
    /// Bricks per pool buffer.
    pub(super) pool_bricks: u32,
    pub(super) pad: [u32; 2],
}

/// The pack kernel.
pub(super) struct PackBricks {
    pipeline: wgpu::ComputePipeline,
}

impl PackBricks {
    pub(super) fn new(ctx: &GpuContext) -> PackBricks {
        let module = ctx.shader("svo pack", &library_shader("voxel/svo/pack", &[]));
        PackBricks {
            pipeline: ctx.compute_pipeline("svo pack bricks", &module, "pack"),
        }
    }

    /// Records the conversion of the first `bricks` bricks of the `wide` pools into the
    /// `narrow` ones (both split over [`crate::voxel::svo::POOLS`] buffers of `pool_bricks`).
    pub(super) fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (wide, narrow): (&[wgpu::Buffer], &[wgpu::Buffer]),
        bricks: u32,
        pool_bricks: u32,
    ) {
        let texels = bricks * 27;
        let params = PackParams {
            texels,
            pool_bricks,
            pad: [0; 2],
        };
        let label = "pack params";
        let params = ctx.create_buffer_init(
            OWNER,
            label,
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        // The encoder keeps the buffer alive until it has run.
        ctx.ledger.forget(OWNER, label);
        let group = bind_buffers(
            ctx,
            &self.pipeline,
            &[
                (0, &params),
                (1, &wide[0]),
                (2, &wide[1]),
                (3, &wide[2]),
                (4, &wide[3]),
                (5, &narrow[0]),
                (6, &narrow[1]),
                (7, &narrow[2]),
                (8, &narrow[3]),
            ],
        );
        dispatch_1d(timer, "svo pack bricks", &self.pipeline, &group, texels);
    }
}
