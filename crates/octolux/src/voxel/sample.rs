//! The common sampling interface of the voxel structures: "filtered value and opacity at
//! position `p` with footprint `d`". Each structure implements it in WGSL with a CPU twin
//! beside itself: the octree in [`super::svo::sample`] (`svo_sample`, `svo_sample_aniso`), the
//! clipmap in [`super::clipmap::sample`] (`clip_sample`, `clip_radiance_sample`,
//! `clip_sample_blend`, `clip_sample_aniso`). Both return premultiplied RGB and opacity.
//!
//! This module holds what the two share: trilinear filtering and the GPU probe that evaluates a
//! sampler at given points for the CPU-twin tests.

use glam::{UVec3, Vec3, Vec4};

/// Trilinear interpolation of the 8 texels around a point with fractional position `f`
/// (`texel(o)` for the corner offset `o` in {0,1}^3).
pub(crate) fn trilinear(f: Vec3, mut texel: impl FnMut(UVec3) -> Vec4) -> Vec4 {
    let mut sum = Vec4::ZERO;
    for k in 0..8u32 {
        let o = UVec3::new(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let w = Vec3::select(o.cmpeq(UVec3::ONE), f, Vec3::ONE - f);
        sum += w.x * w.y * w.z * texel(o);
    }
    sum
}

/// Runs a `probe` kernel (`source`, one invocation per point, 64 wide) that samples a voxel
/// structure at `points` travelling along `dirs`: `fixed` are the structure's bindings, and the
/// points, directions and an output of one `vec4<f32>` per point follow at the next three
/// bindings. Returns the samples (GPU side of the CPU-twin tests).
pub(crate) fn run_directional_probe(
    ctx: &crate::gpu::GpuContext,
    owner: &str,
    source: &str,
    fixed: &[(u32, &wgpu::Buffer)],
    points: &[Vec4],
    dirs: &[Vec4],
) -> crate::Result<Vec<Vec4>> {
    let module = ctx.shader(owner, source);
    let pipeline = ctx.compute_pipeline(owner, &module, "probe");
    let storage = wgpu::BufferUsages::STORAGE;
    let input = ctx.create_buffer_init(owner, "points", bytemuck::cast_slice(points), storage);
    let dir_buffer =
        ctx.create_buffer_init(owner, "directions", bytemuck::cast_slice(dirs), storage);
    let n = points.len() as u64;
    let out = ctx.create_buffer(
        owner,
        &wgpu::BufferDescriptor {
            label: Some("samples"),
            size: (n * 16).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    );
    let next = fixed.len() as u32;
    let mut buffers = fixed.to_vec();
    buffers.extend([(next, &input), (next + 1, &dir_buffer), (next + 2, &out)]);
    let group = crate::gpu::pass::bind_buffers(ctx, &pipeline, &buffers);
    let mut timer = crate::gpu::PassTimer::new(ctx);
    timer.pass(owner, |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(owner),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    });
    timer.finish_frame()?;
    let bytes = crate::gpu::read_buffer(ctx, &out, 0, n * 16)?;
    Ok(bytemuck::cast_slice::<u8, Vec4>(&bytes).to_vec())
}
