//! The clipmap's tail: coarser copies of its coarsest level, for cones wider than that
//! level's voxel.
//!
//! A clipmap's coarsest voxel is its extent over its resolution (1/64 of it by default), while
//! a 60-degree diffuse cone is as wide as it is long: most of a cone's samples are wider than
//! any level's voxel. Without coarser data the marcher can only point-sample the coarsest
//! level with steps many voxels long, so whether a sample lands on a wall depends on where the
//! pixel is, and the indirect light shows blotches of coarse voxels. The tail adds levels of
//! `res / 2^k` voxels (k = 1..=K, down to 2 per side) over the coarsest level's region, each
//! the mean of the 8 voxels below it, and the trace samples them for footprints past the
//! coarsest voxel (`clipmap_trace.wgsl`), quadrilinear between them.

use crate::gpu::alloc::storage;
use crate::gpu::pass::KeptBindGroup;
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::clipmap::sample::{CLIP_BINDINGS, CLIP_RADIANCE_BINDING};
use glam::{IVec3, Vec3, Vec4};

/// The tail of a clipmap of `res` voxels per side: its levels k = 1..=K have `res >> k`
/// voxels per side, down to 2.
pub fn tail_levels(res: u32) -> u32 {
    res.max(4).trailing_zeros() - 1
}

/// First voxel slot of tail level `k` in the tail buffer (levels one after the other, x
/// fastest).
pub fn tail_offset(res: u32, k: u32) -> u32 {
    (1..k).map(|i| (res >> i).pow(3)).sum()
}

/// Parameter block `TailParams` of `clipmap_tail.wgsl`: one tail level.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct TailParams {
    /// The level, k (1..=K).
    level: u32,
    /// Voxels per side of the level (`res >> k`).
    side: u32,
    /// First voxel slot of the level in the tail buffer.
    first: u32,
    /// First voxel slot of level k - 1, which level k averages (unused for level 1, which
    /// averages the coarsest clipmap level).
    source_first: u32,
}

/// The tail's buffer and the passes that fill it from the clipmap's injected radiance.
pub(crate) struct ClipmapTail {
    res: u32,
    /// Per voxel, as the clipmap's radiance: RGBA16F premultiplied radiance and opacity and
    /// the radiance's facing (snorm8 x 3), 3 words; levels one after the other.
    pub buffer: wgpu::Buffer,
    params: Vec<wgpu::Buffer>,
    pipeline: wgpu::ComputePipeline,
    /// Each level's bind group, kept while the clipmap's buffers are the same.
    groups: Vec<KeptBindGroup>,
}

impl ClipmapTail {
    /// The tail of a clipmap of `res` voxels per side, recorded in the ledger under `owner`.
    pub fn new(ctx: &GpuContext, owner: &str, res: u32) -> ClipmapTail {
        let levels = tail_levels(res);
        let voxels = tail_offset(res, levels + 1) as u64;
        let buffer = storage(ctx, owner, "clipmap tail", voxels * 12);
        let params: Vec<wgpu::Buffer> = (1..=levels)
            .map(|k| {
                let p = TailParams {
                    level: k,
                    side: res >> k,
                    first: tail_offset(res, k),
                    source_first: if k > 1 { tail_offset(res, k - 1) } else { 0 },
                };
                ctx.create_buffer_init(
                    owner,
                    "clipmap tail params",
                    bytemuck::bytes_of(&p),
                    wgpu::BufferUsages::STORAGE,
                )
            })
            .collect();
        let source = crate::gpu::shader::library_shader("gi/vct/clipmap_tail", &[]);
        let module = ctx.shader("clipmap tail", &source);
        let pipeline = ctx.compute_pipeline("clipmap tail", &module, "build_tail");
        ClipmapTail {
            res,
            buffer,
            groups: params.iter().map(|_| KeptBindGroup::default()).collect(),
            params,
            pipeline,
        }
    }

    /// Records the pass `vct tail`: level 1 from the coarsest level of `radiance` (the
    /// clipmap's injected radiance, described by `info`, a `ClipInfo` block), then each level
    /// from the one before.
    pub fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        info: &wgpu::Buffer,
        radiance: &wgpu::Buffer,
    ) {
        let groups: Vec<wgpu::BindGroup> = self
            .params
            .iter()
            .zip(&self.groups)
            .map(|(params, kept)| {
                let entries = [
                    (0, params.as_entire_binding()),
                    (1, self.buffer.as_entire_binding()),
                    (CLIP_BINDINGS, info.as_entire_binding()),
                    (CLIP_RADIANCE_BINDING, radiance.as_entire_binding()),
                ];
                kept.get(ctx, "clipmap tail", &self.pipeline, &entries)
            })
            .collect();
        let last = groups.len().saturating_sub(1);
        timer.pass("tail", |encoder, stamps| {
            // One compute pass per level: each reads what the one before wrote.
            for (k, group) in groups.iter().enumerate() {
                let n = self.res >> (k + 1);
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("vct tail"),
                    timestamp_writes: stamps.compute_part(k == 0, k == last),
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(n.div_ceil(4), n.div_ceil(4), n.div_ceil(4));
            }
        });
    }
}

/// CPU twin of the tail build: the tail levels (level k at [`tail_offset`]) of a clipmap of
/// `res` voxels per side whose coarsest level reads `coarsest(g)` at world-voxel coordinates
/// `g` (radiance and opacity, and the direction the radiance leaves in), with that level's
/// first voxel at `origin`. Each voxel's radiance is the mean of the 8 below it, its facing
/// the mean of theirs weighted by their radiance's r + g + b. In f32: the GPU stores each
/// level's radiance in f16 (relative 2^-11 per store) and its facing in snorm8 (0.5 / 127 per
/// store), so its values differ by the rounding of up to K stores.
pub fn tail_cpu(
    res: u32,
    origin: IVec3,
    coarsest: impl Fn(IVec3) -> (Vec4, Vec3),
) -> Vec<(Vec4, Vec3)> {
    let levels = tail_levels(res);
    let mut tail = vec![(Vec4::ZERO, Vec3::ZERO); tail_offset(res, levels + 1) as usize];
    for k in 1..=levels {
        let n = res >> k;
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let (mut sum, mut facing) = (Vec4::ZERO, Vec3::ZERO);
                    for c in 0..8u32 {
                        let j = 2 * glam::UVec3::new(x, y, z)
                            + glam::UVec3::new(c & 1, (c >> 1) & 1, (c >> 2) & 1);
                        let (r, f) = if k == 1 {
                            coarsest(origin + j.as_ivec3())
                        } else {
                            let m = 2 * n;
                            tail[(tail_offset(res, k - 1) + j.x + m * (j.y + m * j.z)) as usize]
                        };
                        sum += r;
                        facing += f * r.truncate().element_sum();
                    }
                    let f = facing / sum.truncate().element_sum().max(1e-20);
                    tail[(tail_offset(res, k) + x + n * (y + n * z)) as usize] = (sum * 0.125, f);
                }
            }
        }
    }
    tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn tail_params_mirror_the_wgsl_block() {
        assert_mirrors_wgsl!(
            TailParams,
            "gi/vct/clipmap_tail",
            "TailParams",
            [level, side, first, source_first]
        );
    }
    use crate::gpu::pack::f16_to_f32;
    use crate::gpu::{read_buffer, GpuOptions};
    use crate::voxel::clipmap::sample::ClipInfo;
    use crate::voxel::clipmap::ClipmapSettings;

    #[test]
    fn tail_sizes() {
        assert_eq!(tail_levels(4), 1);
        assert_eq!(tail_levels(64), 5);
        assert_eq!(tail_offset(64, 1), 0);
        assert_eq!(tail_offset(64, 3), 32 * 32 * 32 + 16 * 16 * 16);
        assert_eq!(tail_offset(8, tail_levels(8) + 1), 64 + 8);
    }

    /// The GPU tail of a clipmap filled with arbitrary f16 radiance and facing, its coarsest
    /// level's origin odd on every axis (so the toroidal wrap is crossed), equals the CPU twin
    /// within the rounding of its stores: the radiance relative 2^-11 per level, two levels,
    /// bound 2^-9; the facing 0.5 / 127 per level (snorm8), bound 1.5 / 127.
    #[test]
    fn gpu_tail_equals_cpu_twin() {
        use crate::voxel::clipmap::{pack_facing, unpack_facing};
        let ctx = GpuContext::shared(&GpuOptions::default())
            .expect("a GPU adapter (install mesa-vulkan-drivers)");
        let res = 8u32;
        let settings = ClipmapSettings {
            resolution: res,
            levels: 2,
            voxel_size: 0.1,
        };
        let origins = [Some(IVec3::new(-8, 2, 0)), Some(IVec3::new(-3, 5, -1))];
        let slots = 2 * res.pow(3) as usize;
        // Positive finite f16s from a fixed linear congruential sequence: exponents 10..=17
        // (about 2^-5 to 4), any mantissa; facings of any direction and length up to 1.
        let mut state = 12345u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state
        };
        let mut half = || {
            let s = next();
            let e = 10 + (s >> 29);
            (e << 10 | (s >> 8) & 1023) as u16
        };
        let halves: Vec<u16> = (0..4 * slots).map(|_| half()).collect();
        let facings: Vec<u32> = (0..slots)
            .map(|_| {
                let s = next();
                let c = |k: u32| ((s >> (8 * k)) & 255) as f32 / 255.0 * 2.0 - 1.0;
                let f = Vec3::new(c(0), c(1), c(2));
                pack_facing(f / f.length().max(1.0))
            })
            .collect();
        let words: Vec<u32> = (0..slots)
            .flat_map(|i| {
                let h = &halves[4 * i..4 * i + 4];
                [
                    h[0] as u32 | (h[1] as u32) << 16,
                    h[2] as u32 | (h[3] as u32) << 16,
                    facings[i],
                ]
            })
            .collect();
        let radiance = ctx.create_buffer_init(
            "test",
            "radiance",
            bytemuck::cast_slice(&words),
            wgpu::BufferUsages::STORAGE,
        );
        let info = ctx.create_buffer_init(
            "test",
            "info",
            bytemuck::bytes_of(&ClipInfo::new(&settings, &origins)),
            wgpu::BufferUsages::STORAGE,
        );
        let tail = ClipmapTail::new(&ctx, "test", res);
        let mut timer = PassTimer::new(&ctx);
        tail.record(&ctx, &mut timer, &info, &radiance);
        timer.finish_frame().expect("tail pass");
        let bytes = read_buffer(&ctx, &tail.buffer, 0, tail.buffer.size()).expect("read tail");
        let gpu: Vec<u32> = bytemuck::cast_slice(&bytes).to_vec();

        let level_slot = |g: IVec3| {
            let m = g.rem_euclid(IVec3::splat(res as i32)).as_uvec3();
            (res.pow(3) + m.x + res * (m.y + res * m.z)) as usize
        };
        let coarsest = |g: IVec3| {
            let s = level_slot(g);
            let r = Vec4::from_array(std::array::from_fn(|c| f16_to_f32(halves[4 * s + c])));
            (r, unpack_facing(facings[s]))
        };
        let cpu = tail_cpu(res, IVec3::new(-3, 5, -1), coarsest);
        assert_eq!(cpu.len(), 72);
        let mut worst_facing = 0.0f32;
        for (i, (want, want_facing)) in cpu.iter().enumerate() {
            let got = crate::gpu::pack::unpack_half4(gpu[3 * i], gpu[3 * i + 1]);
            let err = (got - *want).abs().max_element();
            assert!(
                err <= want.abs().max_element() * 2f32.powi(-9),
                "tail voxel {i}: GPU {got} CPU {want}"
            );
            let facing = unpack_facing(gpu[3 * i + 2]);
            worst_facing = worst_facing.max((facing - *want_facing).abs().max_element());
        }
        assert!(
            worst_facing <= 1.5 / 127.0,
            "tail facing: GPU and CPU differ by {worst_facing}"
        );
    }
}
