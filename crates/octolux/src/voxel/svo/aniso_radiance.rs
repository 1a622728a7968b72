//! Anisotropic (6-direction) injected radiance of the sparse voxel octree (Arnebäck 2017
//! §3.1.4 applied to the radiance the cone tracer reads): every node with a brick gets 6
//! RGBA16F values (premultiplied radiance, opacity), one per travel direction +x, -x, +y, -y,
//! +z, -z, composited front to back from its children (its voxels on the leaf level) and
//! averaged across the direction, as [`crate::voxel::svo::aniso`] does for albedo.
//!
//! Why: the isotropic lattice holds mean occupancy, so a one-voxel-thick wall fades to `1/s`
//! at a level of voxels `s` times larger (the cone tracer scales it back, over-counting walls
//! seen edge-on); composited values keep a wall seen face-on opaque on every level and one seen
//! edge-on at the share of the node it covers, and a red wall in front of a green one stays red
//! seen from the front.
//!
//! Rebuilt every frame after the injection ([`SvoAnisoRadiance::record`], pass `svo
//! anisotropic radiance`: one dispatch per level and node range, finest first; the dynamic
//! ranges are read on the GPU, no readback). Storage: 12 words per brick of the octree's
//! capacity (48 bytes; the dynamic reserve's bricks included). Sampling:
//! the WGSL module `voxel/svo/radiance_sample_aniso`. CPU twin of the values: [`crate::voxel::svo::cpu::svo_aniso_radiance`].

use crate::gpu::pass::SLOT;
use crate::gpu::pass::{buffer_entry, dispatch_size};
use crate::gpu::{read_buffer, GpuContext, PassTimer};
use crate::voxel::svo::control::{args_offset, ARGS_DYN_NODES};
use crate::voxel::svo::{Svo, OWNER};
use crate::Result;
use glam::{Vec3, Vec4};

/// Words per brick: one RGBA16F value (two words) per direction.
pub const ANISO_RADIANCE_WORDS: u32 = 12;
/// Ledger label of the values buffer (owner [`OWNER`]).
pub const LEDGER_LABEL: &str = "anisotropic radiance";

/// Parameters of one level's node range (`AnisoRadianceParams` in `aniso_radiance.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct AnisoRadianceParams {
    pub(super) level: u32,
    /// 1 for the level's dynamic nodes (their range read on the GPU), 0 for its static ones.
    pub(super) dynamic_nodes: u32,
    /// 1 on the leaf level.
    pub(super) leaf: u32,
    /// Static leaf nodes (the dynamic leaves' voxel slots follow theirs).
    pub(super) static_leaves: u32,
    /// The level's static nodes `[first, first + count)`.
    pub(super) first: u32,
    pub(super) count: u32,
    pub(super) pad: [u32; 2],
}

/// The anisotropic radiance of one octree and the kernel that rebuilds it.
pub struct SvoAnisoRadiance {
    pipeline: wgpu::ComputePipeline,
    /// `array<u32>`: per brick `b` (node with `brick_index = b + 1`), 6 RGBA16F values (two
    /// `pack2x16float` words each) for travel along +x, -x, +y, -y, +z, -z.
    buffer: wgpu::Buffer,
    /// Per level, finest first: its static range's group and size, then, with a dynamic part,
    /// its dynamic range's group and indirect argument slot.
    steps: Vec<(wgpu::BindGroup, Step)>,
}

enum Step {
    Static(u32),
    Dynamic(u32),
}

impl SvoAnisoRadiance {
    /// Room for `svo`'s values (its whole brick capacity) and the kernel's bindings.
    pub fn new(ctx: &GpuContext, svo: &Svo) -> Result<SvoAnisoRadiance> {
        let bytes = svo.brick_capacity as u64 * ANISO_RADIANCE_WORDS as u64 * 4;
        ctx.check_storage_binding(
            &format!("the anisotropic radiance of {} bricks", svo.brick_capacity),
            bytes,
            "lower the octree resolution or turn `anisotropic` off",
        )?;
        let source = crate::gpu::shader::library_shader("voxel/svo/aniso_radiance", &[]);
        let module = ctx.shader("svo anisotropic radiance", &source);
        let pipeline = ctx.compute_pipeline("svo anisotropic radiance", &module, "build_level");
        let buffer = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some(LEDGER_LABEL),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        );
        let depth = svo.levels.len();
        let dynamic = svo.dynamic.is_some();
        let (first_leaf, end_leaf) = svo.levels.last().copied().unwrap_or((0, 0));
        // Finest level first: static range, then dynamic range.
        let mut slots = Vec::new();
        for d in (0..depth).rev() {
            let (start, end) = svo.levels[d];
            let level = AnisoRadianceParams {
                level: d as u32,
                dynamic_nodes: 0,
                leaf: (d + 1 == depth) as u32,
                static_leaves: end_leaf - first_leaf,
                first: start,
                count: end - start,
                pad: [0; 2],
            };
            slots.push((level, Step::Static(end - start)));
            if dynamic {
                let nodes = AnisoRadianceParams {
                    dynamic_nodes: 1,
                    first: 0,
                    count: 0,
                    ..level
                };
                slots.push((nodes, Step::Dynamic(ARGS_DYN_NODES + d as u32)));
            }
        }
        let mut words = vec![0u8; SLOT as usize * slots.len().max(1)];
        for (i, (p, _)) in slots.iter().enumerate() {
            let at = i * SLOT as usize;
            words[at..at + size_of::<AnisoRadianceParams>()].copy_from_slice(bytemuck::bytes_of(p));
        }
        let params = ctx.create_buffer_init(
            OWNER,
            "anisotropic radiance params",
            &words,
            wgpu::BufferUsages::STORAGE,
        );
        let layout = pipeline.get_bind_group_layout(0);
        let steps = slots
            .into_iter()
            .enumerate()
            .map(|(i, (_, step))| {
                let group =
                    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("svo anisotropic radiance"),
                        layout: &layout,
                        entries: &[
                            wgpu::BindGroupEntry {
                                binding: 0,
                                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                    buffer: &params,
                                    offset: i as u64 * SLOT,
                                    size: wgpu::BufferSize::new(
                                        size_of::<AnisoRadianceParams>() as u64
                                    ),
                                }),
                            },
                            buffer_entry(1, &svo.child),
                            buffer_entry(2, &svo.brick_plus_one),
                            buffer_entry(3, &svo.control),
                            buffer_entry(4, &svo.voxel_radiance),
                            buffer_entry(5, &buffer),
                        ],
                    });
                (group, step)
            })
            .collect();
        Ok(SvoAnisoRadiance {
            pipeline,
            buffer,
            steps,
        })
    }

    /// Records the rebuild of the values from `svo`'s injected voxel radiance as the timed
    /// pass `svo anisotropic radiance` (after [`crate::voxel::svo::SvoBuilder::inject`]).
    pub fn record(&self, timer: &mut PassTimer, svo: &Svo) {
        let last = self.steps.len().saturating_sub(1);
        timer.pass("svo anisotropic radiance", |encoder, stamps| {
            for (i, (group, step)) in self.steps.iter().enumerate() {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("svo anisotropic radiance level"),
                    timestamp_writes: stamps.compute_part(i == 0, i == last),
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, group, &[]);
                match *step {
                    Step::Static(0) => {}
                    Step::Static(count) => {
                        let (x, y) = dispatch_size(count);
                        pass.dispatch_workgroups(x, y, 1);
                    }
                    Step::Dynamic(slot) => {
                        pass.dispatch_workgroups_indirect(&svo.args, args_offset(slot));
                    }
                }
            }
        });
    }

    /// The values (`svo_aniso_radiance` of `voxel/svo/radiance_sample_aniso.wgsl`).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Bytes kept on the GPU: 48 per brick of the octree's capacity.
    pub fn bytes(&self) -> u64 {
        self.buffer.size()
    }

    /// Reads the values of `svo`'s current bricks back: per brick (order of
    /// [`crate::voxel::svo::SvoCpu::bricks`]), (radiance, opacity) for +x, -x, +y, -y, +z, -z.
    pub fn read_back(&self, ctx: &GpuContext, svo: &Svo) -> Result<Vec<[Vec4; 6]>> {
        if svo.brick_count == 0 {
            return Ok(Vec::new());
        }
        let bytes = read_buffer(
            ctx,
            &self.buffer,
            0,
            svo.brick_count as u64 * ANISO_RADIANCE_WORDS as u64 * 4,
        )?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        Ok(words
            .chunks_exact(ANISO_RADIANCE_WORDS as usize)
            .map(|w| {
                std::array::from_fn(|d| crate::gpu::pack::unpack_half4(w[2 * d], w[2 * d + 1]))
            })
            .collect())
    }

    /// Evaluates `svo_radiance_aniso` on the GPU at `points` (xyz position, w footprint), one
    /// travel direction per point. Blocks.
    pub fn probe(
        &self,
        ctx: &GpuContext,
        svo: &Svo,
        points: &[Vec4],
        dirs: &[Vec3],
    ) -> Result<Vec<Vec4>> {
        crate::voxel::svo::aniso::probe_node_values(
            ctx,
            svo,
            (
                &self.buffer,
                crate::voxel::svo::sample::SVO_ANISO_RADIANCE_BINDING,
            ),
            "svo_radiance_aniso(q.xyz, q.w, d.xyz)",
            points,
            (dirs, 1.0),
        )
    }
}
