//! VPL generation: the RSMs' reflected flux is summed into a pyramid and N VPLs are drawn from
//! it by inverting its distribution at stratified points (`generate.wgsl`), each carrying
//! physical flux. [`sample_cpu`] is the CPU twin.

use crate::frame::rsm::{RsmImage, RsmTargets};
use crate::gpu::pass::SLOT;
use crate::gpu::{GpuContext, PassTimer};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// `GenParams` of `generate.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GenParams {
    size: u32,
    layers: u32,
    levels: u32,
    count: u32,
    offsets: [u32; 16],
    inv_twice_count: f32,
    _pad: [u32; 3],
    /// A bit per layer drawn at half the side ([`crate::frame::rsm::half_layer_mask`]).
    half_layers: [u32; 8],
}

/// First word of every pyramid level and the total words, for `layers` RSMs of side `size`.
fn offsets(size: u32, layers: u32) -> ([u32; 16], u64) {
    let mut out = [0u32; 16];
    let mut at = 0u64;
    let levels = size.trailing_zeros();
    for (k, o) in out.iter_mut().enumerate().take(levels as usize + 1) {
        *o = at as u32;
        let side = (size >> k) as u64;
        at += layers as u64 * side * side;
    }
    (out, at)
}

/// A VPL read back to the CPU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vpl {
    /// World position.
    pub position: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// Flux (W) per channel.
    pub flux: Vec3,
    /// The surface area it stands for (m^2): its RSM texel's over the probability of drawing
    /// it times the VPL count, so the VPLs' areas sum to the area the RSMs see (in
    /// expectation) as their fluxes to its reflected flux. Its geometry term is bounded as a
    /// disk of that area's ([`crate::gi::vpl::vpl_clamp`]).
    pub area: f32,
}

/// One VPL as the GPU stores it (`Vpl` in `vpl.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuVpl {
    /// World position.
    pub position: [f32; 3],
    /// The surface area it stands for, m^2 ([`Vpl::area`]).
    pub area: f32,
    /// Unit normal.
    pub normal: [f32; 3],
    /// Padding (WGSL aligns a `vec3<f32>` to 16 bytes).
    pub _pad: u32,
    /// Flux, W.
    pub flux: [f32; 3],
    /// Mean of the flux's channels.
    pub mean_flux: f32,
}

/// Bytes of one VPL in the VPL buffer.
pub const VPL_BYTES: u64 = std::mem::size_of::<GpuVpl>() as u64;

/// Decodes the VPL buffer's bytes.
pub fn decode(bytes: &[u8]) -> Vec<Vpl> {
    bytes
        .chunks_exact(VPL_BYTES as usize)
        .map(|b| {
            let v: GpuVpl = bytemuck::pod_read_unaligned(b);
            Vpl {
                position: v.position.into(),
                normal: v.normal.into(),
                flux: v.flux.into(),
                area: v.area,
            }
        })
        .collect()
}

/// The generation passes and their buffers.
pub struct Generate {
    base: wgpu::ComputePipeline,
    level: wgpu::ComputePipeline,
    sample: wgpu::ComputePipeline,
    groups: Vec<wgpu::BindGroup>,
    size: u32,
    layers: u32,
    count: u32,
    params: wgpu::Buffer,
    /// The VPLs (`array<Vpl>`), `count` of them.
    pub vpls: wgpu::Buffer,
}

impl Generate {
    /// Pipelines and buffers for `count` VPLs drawn from `rsm`, in a buffer of `capacity` VPLs
    /// (the later bounces follow them).
    pub fn new(
        ctx: &GpuContext,
        owner: &str,
        rsm: &RsmTargets,
        count: u32,
        capacity: u32,
    ) -> Generate {
        let source = crate::gpu::shader::library_shader("gi/vpl/generate", &[]);
        let module = ctx.shader("vpl generate", &source);
        let base = ctx.compute_pipeline("vpl pyramid base", &module, "pyramid_base");
        let level = ctx.compute_pipeline("vpl pyramid level", &module, "pyramid_level");
        let sample = ctx.compute_pipeline("vpl sample", &module, "sample_vpls");
        let (size, layers) = (rsm.size, rsm.layers.max(1));
        let levels = size.trailing_zeros();
        let (offsets, words) = offsets(size, layers);
        let params = GenParams {
            size,
            layers: rsm.layers,
            levels,
            count,
            offsets,
            inv_twice_count: inv_twice(count),
            _pad: [0; 3],
            half_layers: [0; 8],
        };
        let usage = wgpu::BufferUsages::STORAGE;
        let params =
            ctx.create_buffer_init(owner, "vpl generation", bytemuck::bytes_of(&params), usage);
        let mut slots = vec![0u8; (levels as usize + 1) * SLOT as usize];
        for k in 0..=levels {
            slots[k as usize * SLOT as usize..][..4].copy_from_slice(&k.to_le_bytes());
        }
        let slots = ctx.create_buffer_init(owner, "vpl pyramid levels", &slots, usage);
        let storage = |label: &str, bytes: u64| {
            ctx.create_buffer(
                owner,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.max(16),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            )
        };
        let pyramid = storage("flux pyramid", words * 4);
        let vpls = storage("vpls", capacity.max(count) as u64 * VPL_BYTES);
        let tex = wgpu::BindingResource::TextureView;
        let groups = (0..=levels)
            .map(|k| {
                let pipeline = match k {
                    0 => &base,
                    _ => &level,
                };
                let mut entries = vec![(0, params.as_entire_binding())];
                if k == 0 {
                    entries.push((1, tex(&rsm.position_array)));
                    entries.push((3, tex(&rsm.flux_array)));
                } else {
                    entries.push((
                        6,
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &slots,
                            offset: k as u64 * SLOT,
                            size: wgpu::BufferSize::new(4),
                        }),
                    ));
                }
                entries.push((4, pyramid.as_entire_binding()));
                crate::gpu::pass::bind(ctx, pipeline, &entries)
            })
            .chain(std::iter::once(crate::gpu::pass::bind(
                ctx,
                &sample,
                &[
                    (0, params.as_entire_binding()),
                    (1, tex(&rsm.position_array)),
                    (2, tex(&rsm.normal_array)),
                    (3, tex(&rsm.flux_array)),
                    (4, pyramid.as_entire_binding()),
                    (5, vpls.as_entire_binding()),
                ],
            )))
            .collect();
        Generate {
            base,
            level,
            sample,
            groups,
            size,
            layers: rsm.layers,
            count,
            params,
            vpls,
        }
    }

    /// Uploads which layers this frame draws at half the side
    /// ([`crate::frame::rsm::half_layer_mask`]): their
    /// texels outside the drawn corner weigh nothing.
    pub fn set_half_layers(&self, ctx: &GpuContext, mask: [u32; 8]) {
        let at = std::mem::offset_of!(GenParams, half_layers) as u64;
        ctx.queue
            .write_buffer(&self.params, at, bytemuck::cast_slice(&mask));
    }

    /// Records the pyramid and the sampling as the pass `name`.
    pub fn record(&self, timer: &mut PassTimer, name: &str) {
        if self.layers == 0 {
            return;
        }
        timer.pass(name, |encoder, stamps| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(name),
                timestamp_writes: stamps.compute(),
            });
            let levels = self.size.trailing_zeros();
            for k in 0..=levels {
                let side = self.size >> k;
                pass.set_pipeline(if k == 0 { &self.base } else { &self.level });
                pass.set_bind_group(0, &self.groups[k as usize], &[]);
                pass.dispatch_workgroups(side.div_ceil(8), side.div_ceil(8), self.layers);
            }
            pass.set_pipeline(&self.sample);
            pass.set_bind_group(0, &self.groups[levels as usize + 1], &[]);
            pass.dispatch_workgroups(self.count.div_ceil(64), 1, 1);
        });
    }
}

/// `1 / (2 count)`, rounded once here for the GPU and the twin alike.
fn inv_twice(count: u32) -> f32 {
    1.0 / (2.0 * count.max(1) as f32)
}

/// CPU twin of `generate.wgsl`: `count` VPLs drawn from the RSM images (all of one side, a
/// power of two; `half[l]`: layer l was drawn at half of it, in its corner), with the same
/// pyramid sums and the same descent.
pub fn sample_cpu(images: &[RsmImage], half: &[bool], count: u32) -> Vec<Vpl> {
    let Some(size) = images.first().map(|i| i.size) else {
        return vec![
            Vpl {
                position: Vec3::ZERO,
                normal: Vec3::ZERO,
                flux: Vec3::ZERO,
                area: 0.0,
            };
            count as usize
        ];
    };
    let texel = |l: usize, i: usize| {
        let p = images[l].position[i];
        let f = images[l].flux[i];
        Vec3::new(f[0], f[1], f[2]).max(Vec3::ZERO) * p[3].max(0.0)
    };
    // `texel_weight` of generate.wgsl, operation for operation.
    let weight = |l: usize, i: usize| {
        let (x, y) = (i as u32 % size, i as u32 / size);
        if half.get(l) == Some(&true) && (x >= size / 2 || y >= size / 2) {
            return 0.0;
        }
        let f = Vec3::from_slice(&images[l].flux[i][..3]).max(Vec3::ZERO);
        (f.x + f.y + f.z) * images[l].position[i][3].max(0.0)
    };
    // pyramid[k][layer] = level k of that layer, side size >> k.
    let levels = size.trailing_zeros() as usize;
    let mut pyramid: Vec<Vec<Vec<f32>>> = vec![(0..images.len())
        .map(|l| (0..(size * size) as usize).map(|i| weight(l, i)).collect())
        .collect()];
    for k in 1..=levels {
        let (side, fine) = ((size >> k) as usize, (size >> (k - 1)) as usize);
        let next = pyramid[k - 1]
            .iter()
            .map(|f| {
                (0..side * side)
                    .map(|i| {
                        let (x, y) = (2 * (i % side), 2 * (i / side));
                        (f[y * fine + x] + f[y * fine + x + 1])
                            + (f[(y + 1) * fine + x] + f[(y + 1) * fine + x + 1])
                    })
                    .collect()
            })
            .collect();
        pyramid.push(next);
    }
    let tops: Vec<f32> = pyramid[levels].iter().map(|l| l[0]).collect();
    let mut total = 0.0f32;
    for &t in &tops {
        total += t;
    }
    (0..count)
        .map(|i| {
            let zero = Vpl {
                position: Vec3::ZERO,
                normal: Vec3::ZERO,
                flux: Vec3::ZERO,
                area: 0.0,
            };
            if total <= 0.0 {
                return zero;
            }
            let mut t = ((2 * i + 1) as f32 * total * inv_twice(count)).clamp(0.0, total);
            let mut layer = tops.iter().rposition(|&w| w > 0.0).unwrap_or(0);
            for (l, &w) in tops.iter().enumerate() {
                if w > 0.0 && t < w {
                    layer = l;
                    break;
                }
                t -= w;
            }
            t = t.clamp(0.0, tops[layer]);
            let (mut x, mut y) = (0usize, 0usize);
            for k in (1..=levels).rev() {
                let fine = (size >> (k - 1)) as usize;
                let f = &pyramid[k - 1][layer];
                let w = |c: usize| f[(2 * y + (c >> 1)) * fine + 2 * x + (c & 1)];
                let mut chosen = None;
                let mut last_nonzero = 0;
                for c in 0..4 {
                    if w(c) > 0.0 {
                        last_nonzero = c;
                        if chosen.is_none() {
                            if t < w(c) {
                                chosen = Some(c);
                            } else {
                                t -= w(c);
                            }
                        }
                    }
                }
                let c = chosen.unwrap_or_else(|| {
                    t = w(last_nonzero);
                    last_nonzero
                });
                x = 2 * x + (c & 1);
                y = 2 * y + (c >> 1);
            }
            let at = y * size as usize + x;
            let phi = texel(layer, at);
            let p = images[layer].position[at];
            let n = images[layer].normal[at];
            let scale = total / (count as f32 * weight(layer, at).max(1e-30));
            Vpl {
                position: Vec3::new(p[0], p[1], p[2]),
                normal: Vec3::new(n[0], n[1], n[2]).normalize_or_zero(),
                flux: phi * scale,
                area: p[3].max(0.0) * n[3].max(0.0) * scale,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_vpl_mirrors_the_wgsl_record() {
        crate::gpu::layout::assert_mirrors_wgsl!(
            GpuVpl,
            "gi/vpl/vpl",
            "Vpl",
            [position, area, normal, _pad, flux, mean_flux]
        );
    }
}
