//! Helpers the integration tests share: the GPU context, a small deterministic random number
//! generator, a voxel triangle builder and a kernel runner for the samplers. (Each test file uses some of them.)
#![allow(dead_code)]

use glam::{Vec3, Vec4};
use octolux::gpu::{GpuContext, GpuOptions, PassTimer};
use octolux::voxel::VoxelTriangle;

/// The process's shared GPU context (any adapter; lavapipe without a GPU).
pub fn context() -> GpuContext {
    GpuContext::shared(&GpuOptions::default()).expect("a GPU adapter (install mesa-vulkan-drivers)")
}

/// A voxel triangle of `albedo` without emission, its normal from the winding.
pub fn tri(a: Vec3, b: Vec3, c: Vec3, albedo: [u8; 3]) -> VoxelTriangle {
    VoxelTriangle {
        positions: [a, b, c],
        albedo,
        normal: (b - a).cross(c - a).normalize_or(Vec3::Y),
        emission: Vec3::ZERO,
    }
}

/// A xorshift generator: the same sequence for the same seed on every machine.
pub struct Rng(pub u64);

impl Rng {
    /// A number in [0, 1) with 24 bits.
    pub fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A point of the box [lo, hi)^3.
    pub fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + Vec3::splat(lo)
    }

    /// A unit vector (rejection sampling in the unit ball).
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// Runs `kernel` (a WGSL module with an entry point `probe` reading `points: array<vec4<f32>>`
/// and writing `outputs` vec4 per point to `out: array<vec4<f32>>`, both declared here at
/// bindings 0 and 1) over `points` with `bindings` (the library's sampler entries) and returns
/// its output.
pub fn run_probe(
    ctx: &GpuContext,
    kernel: &str,
    bindings: Vec<(u32, wgpu::BindingResource<'_>)>,
    points: &[Vec4],
    outputs: usize,
) -> Vec<Vec4> {
    // Declarations may follow their use in WGSL; imports must come first.
    let kernel = format!(
        "{kernel}
@group(0) @binding(0) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
"
    );
    let source = octolux::gpu::shader::compose_text("probe", &kernel, &[], &[]).unwrap();
    let module = ctx.shader("probe", &source);
    let pipeline = ctx.compute_pipeline("probe", &module, "probe");
    let input = ctx.create_buffer_init(
        "test",
        "points",
        bytemuck::cast_slice(points),
        wgpu::BufferUsages::STORAGE,
    );
    let size = (points.len() * outputs) as u64 * 16;
    let out = ctx.create_buffer(
        "test",
        &wgpu::BufferDescriptor {
            label: Some("samples"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    );
    let entries: Vec<wgpu::BindGroupEntry> = bindings
        .into_iter()
        .chain([(0, input.as_entire_binding()), (1, out.as_entire_binding())])
        .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
        .collect();
    let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let mut timer = PassTimer::new(ctx);
    timer.pass("probe", |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("probe"),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((points.len() as u32).div_ceil(64), 1, 1);
    });
    timer.finish_frame().unwrap();
    let bytes = octolux::gpu::read_buffer(ctx, &out, 0, size).unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}
