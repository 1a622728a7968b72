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

/// Runs a kernel (one invocation per point) that evaluates the WGSL expression `sample` of the
/// point `q` (xyz position, w footprint) and the direction `d` (xyz, w the caller's flag) at
/// `points` and `dirs`, with `imports` (the sampler modules it calls) and `fixed` (their
/// bindings). Returns the samples (GPU side of the CPU-twin tests).
pub(crate) fn run_directional_probe(
    ctx: &crate::gpu::GpuContext,
    owner: &str,
    (imports, sample): (&str, &str),
    fixed: &[(u32, wgpu::BindingResource)],
    points: &[Vec4],
    dirs: &[Vec4],
) -> crate::Result<Vec<Vec4>> {
    let kernel = format!(
        "{imports}
@group(0) @binding(0) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> dirs: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> samples: array<vec4<f32>>;

@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {{
    if id.x >= arrayLength(&points) {{
        return;
    }}
    let q = points[id.x];
    let d = dirs[id.x];
    samples[id.x] = {sample};
}}
"
    );
    let source = crate::gpu::shader::compose_text(owner, &kernel, &[], &[])?;
    let module = ctx.shader(owner, &source);
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
    let mut entries = fixed.to_vec();
    entries.extend([
        (0, input.as_entire_binding()),
        (1, dir_buffer.as_entire_binding()),
        (2, out.as_entire_binding()),
    ]);
    let group = crate::gpu::pass::bind(ctx, &pipeline, &entries);
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
