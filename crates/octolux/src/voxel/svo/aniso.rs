//! Anisotropic (6-direction) voxels for the sparse voxel octree (Arnebäck 2017 §3.1.4), an
//! option built on demand after the octree: every node is the voxel of its level (level `d` has
//! `2^d` nodes per axis) and gets 6 RGBA8 values (premultiplied albedo, opacity), one per travel
//! direction +x, -x, +y, -y, +z, -z, meaning what a cone travelling along that direction sees
//! (the clipmap's convention, [`crate::voxel::clipmap::cpu::clipmap_aniso`]). Mipmapping them keeps a red wall
//! in front of a green one red seen from the front and green from behind, where the isotropic
//! bricks mix the two.
//!
//! - Finest level (nodes of 2x2x2 voxels): each voxel's isotropic value is the rounded integer
//!   mean of its fragments' albedo from the octree's leaf sums, opacity 1 (`leaf_voxel` in
//!   `svo/aniso.wgsl`); direction +x composites the two voxels met along x front to back
//!   (`c = c_front + (1 - a_front) c_back`, rounded integer arithmetic) and averages the 4
//!   pairs across y and z.
//! - Coarser levels, bottom-up, one dispatch per level: the same rule over the 8 children's
//!   values for the same direction (a child without a brick is transparent zero).
//!
//! Storage: 6 words per *brick* ([`SvoAnisoValues::buffer`], word
//! `(brick_index[node] - 1) * 6 + direction`), 24 bytes per brick. A node without a brick is
//! neither occupied nor next to an occupied node, so it contains no occupied voxel and all its
//! values are zero.
//!
//! Sampling: the WGSL module `voxel/svo/sample_aniso` (`svo_sample_aniso(p, footprint, dir)`), CPU twin
//! [`crate::voxel::svo::sample::svo_sample_aniso`]. CPU twin of the values: [`crate::voxel::svo::cpu::svo_aniso`].

use crate::gpu::pass::SLOT;
use crate::gpu::pass::{buffer_entry, dispatch_size};
use crate::gpu::{read_buffer, GpuContext, PassTimer};
use crate::voxel::svo::sample::{svo_albedo_bindings, svo_bindings, SvoInfo, SVO_ANISO_BINDING};
use crate::voxel::svo::{Svo, OWNER};
use crate::{Error, Result};
use glam::{Vec3, Vec4};

/// Words per brick: one RGBA8 value per direction (+x, -x, +y, -y, +z, -z).
pub const ANISO_WORDS: u32 = 6;
/// Ledger label of the values buffer (owner [`OWNER`]).
pub const LEDGER_LABEL: &str = "anisotropic values";

/// Parameters of one level's dispatch (`AnisoParams` in `svo/aniso.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct AnisoParams {
    /// The level's nodes `[first, first + count)`.
    pub(super) first: u32,
    pub(super) count: u32,
    /// The first leaf node.
    pub(super) first_leaf: u32,
    /// 1 on the leaf level.
    pub(super) leaf: u32,
    /// Static leaf nodes (the index words at the start of the leaf sums).
    pub(super) static_leaves: u32,
    pub(super) _pad: [u32; 3],
}

/// The anisotropic values of one octree's nodes.
pub struct SvoAnisoValues {
    /// `array<u32>`: per brick `b` (node with `brick_index = b + 1`), [`ANISO_WORDS`] RGBA8
    /// words (`pack4x8unorm`) for travel along +x, -x, +y, -y, +z, -z.
    pub buffer: wgpu::Buffer,
    /// Bricks covered (the octree's [`Svo::brick_count`] when built).
    pub brick_count: u32,
}

impl SvoAnisoValues {
    /// Bytes kept on the GPU: 24 per brick.
    pub fn bytes(&self) -> u64 {
        self.brick_count as u64 * ANISO_WORDS as u64 * 4
    }

    /// Reads the values back: per brick (order of [`crate::voxel::svo::SvoCpu::bricks`]), the 6
    /// RGBA8 words.
    pub fn read_back(&self, ctx: &GpuContext) -> Result<Vec<[u32; 6]>> {
        if self.brick_count == 0 {
            return Ok(Vec::new());
        }
        let bytes = read_buffer(ctx, &self.buffer, 0, self.bytes())?;
        Ok(bytemuck::cast_slice::<u8, u32>(&bytes)
            .chunks_exact(ANISO_WORDS as usize)
            .map(|w| std::array::from_fn(|d| w[d]))
            .collect())
    }
}

/// The kernels that build an octree's anisotropic values and the probe that samples them.
pub struct SvoAniso {
    pipeline: wgpu::ComputePipeline,
}

impl SvoAniso {
    /// Compiles the kernel.
    pub fn new(ctx: &GpuContext) -> SvoAniso {
        let source = crate::gpu::shader::library_shader("voxel/svo/aniso", &[]);
        let module = ctx.shader("svo anisotropic", &source);
        SvoAniso {
            pipeline: ctx.compute_pipeline("svo anisotropic", &module, "build_level"),
        }
    }

    /// Records the build of `svo`'s anisotropic values as the timed pass `svo anisotropic`
    /// (one dispatch per level, finest first); the values are ready once `timer`'s frame is
    /// finished. After the octree is rebuilt, calling this again rebuilds them (the ledger
    /// entry `svo / anisotropic values` is replaced, not added to).
    pub fn build(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        svo: &Svo,
    ) -> Result<SvoAnisoValues> {
        let bytes = svo.brick_count as u64 * ANISO_WORDS as u64 * 4;
        ctx.check_storage_binding(
            &format!("the anisotropic values of {} bricks", svo.brick_count),
            bytes,
            "lower the octree resolution",
        )?;
        let buffer = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some(LEDGER_LABEL),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        );
        let values = SvoAnisoValues {
            buffer,
            brick_count: svo.brick_count,
        };
        let depth = svo.levels.len();
        if depth == 0 {
            return Ok(values);
        }
        let first_leaf = svo.levels[depth - 1].0;
        let mut params = vec![0u8; SLOT as usize * depth];
        for (d, &(start, end)) in svo.levels.iter().enumerate() {
            let level = AnisoParams {
                first: start,
                count: end - start,
                first_leaf,
                leaf: (d + 1 == depth) as u32,
                static_leaves: svo.static_nodes - first_leaf,
                _pad: [0; 3],
            };
            let at = d * SLOT as usize;
            params[at..at + size_of::<AnisoParams>()].copy_from_slice(bytemuck::bytes_of(&level));
        }
        let params_buffer = ctx.create_buffer_init(
            OWNER,
            "anisotropic params",
            &params,
            wgpu::BufferUsages::STORAGE,
        );
        let layout = self.pipeline.get_bind_group_layout(0);
        let groups: Vec<wgpu::BindGroup> = (0..depth)
            .map(|d| {
                ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("svo anisotropic"),
                    layout: &layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: &params_buffer,
                                offset: d as u64 * SLOT,
                                size: wgpu::BufferSize::new(size_of::<AnisoParams>() as u64),
                            }),
                        },
                        buffer_entry(1, &svo.child),
                        buffer_entry(2, &svo.brick_plus_one),
                        buffer_entry(3, &svo.leaf_sums),
                        buffer_entry(4, &values.buffer),
                    ],
                })
            })
            .collect();
        timer.pass("svo anisotropic", |encoder, stamps| {
            for (i, d) in (0..depth).rev().enumerate() {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("svo anisotropic level"),
                    timestamp_writes: stamps.compute_part(i == 0, d == 0),
                });
                let (start, end) = svo.levels[d];
                if end > start {
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &groups[d], &[]);
                    let (x, y) = dispatch_size(end - start);
                    pass.dispatch_workgroups(x, y, 1);
                }
            }
        });
        ctx.ledger.forget(OWNER, "anisotropic params");
        Ok(values)
    }

    /// Evaluates `svo_sample_aniso` (with one travel direction per point) or, without `dirs`,
    /// the isotropic `svo_sample` on the GPU at `points` (xyz position, w footprint). Blocks.
    pub fn probe(
        ctx: &GpuContext,
        svo: &Svo,
        values: &SvoAnisoValues,
        points: &[Vec4],
        dirs: Option<&[Vec3]>,
    ) -> Result<Vec<Vec4>> {
        let none = vec![Vec3::ZERO; points.len()];
        probe_node_values(
            ctx,
            svo,
            (&values.buffer, SVO_ANISO_BINDING),
            "select(svo_sample(q.xyz, q.w), svo_sample_aniso(q.xyz, q.w, d.xyz), d.w > 0.5)",
            points,
            dirs.map_or((&none[..], 0.0), |d| (d, 1.0)),
        )
    }
}

/// Runs `sample` (a WGSL expression of the point `q`, xyz position and w footprint, and the
/// direction `d`, xyz and w = the flag in `dirs`) on the GPU at every point, with the
/// per-brick node values `values` bound at `binding` (the anisotropic albedo's or radiance's).
/// Blocks. For the octree's directional probes (albedo and radiance).
pub(crate) fn probe_node_values(
    ctx: &GpuContext,
    svo: &Svo,
    (values, binding): (&wgpu::Buffer, u32),
    sample: &str,
    points: &[Vec4],
    (dirs, flag): (&[Vec3], f32),
) -> Result<Vec<Vec4>> {
    if dirs.len() != points.len() {
        return Err(Error::InvalidArgument(format!(
            "{} directions for {} points",
            dirs.len(),
            points.len()
        )));
    }
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let owner = "svo probe";
    // The isotropic sample at a huge footprint (weighted by zero) keeps the albedo pool in
    // the layout whatever `sample` reads, so one set of bindings serves every probe.
    let imports = "import octolux::voxel::svo::sample::svo_sample;
import octolux::voxel::svo::sample_aniso::svo_sample_aniso;
import octolux::voxel::svo::radiance_sample_aniso::svo_radiance_aniso;";
    let sample = format!("{sample} + svo_sample(q.xyz, 1e9) * 0.0");
    let info = ctx.create_buffer_init(
        owner,
        "info",
        bytemuck::bytes_of(&SvoInfo::new(&svo.grid, svo.pool_bricks)),
        wgpu::BufferUsages::STORAGE,
    );
    let mut fixed = svo_bindings(&info, svo).to_vec();
    fixed.extend(svo_albedo_bindings(svo));
    fixed.push((binding, values.as_entire_binding()));
    let dirs: Vec<Vec4> = dirs.iter().map(|d| d.extend(flag)).collect();
    crate::voxel::sample::run_directional_probe(
        ctx,
        owner,
        (imports, &sample),
        &fixed,
        points,
        &dirs,
    )
}
