//! Injection of VPLs into the light volumes and of surfels into the geometry volumes.

use super::propagate::Volumes;
use super::{bind, groups, GiFrame};
use crate::frame::rsm::{RsmLayer, RsmTargets};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::Result;

/// At most this many G-buffer samples per side feed the camera's geometry volume: larger
/// outputs are sampled in square blocks (see `inject_gv_camera`), so injection costs the same at
/// any output size.
pub const CAMERA_SAMPLES: u32 = 256;

/// G-buffer pixels per side of one camera surfel for a `width` x `height` output.
pub fn camera_stride(width: u32, height: u32) -> u32 {
    width.max(height).div_ceil(CAMERA_SAMPLES).max(1)
}

/// The injection pipelines and bind groups.
pub struct Inject {
    light: (wgpu::ComputePipeline, wgpu::BindGroup),
    gv_rsm: (wgpu::ComputePipeline, wgpu::BindGroup),
    gv_camera: (wgpu::ComputePipeline, wgpu::BindGroup),
    resolve: (wgpu::ComputePipeline, wgpu::BindGroup),
    combine: (wgpu::ComputePipeline, wgpu::BindGroup),
    rsm_size: u32,
    rsm_layers: u32,
    width: u32,
    height: u32,
}

/// What the injection counts (`count_inject_work` in `inject.wgsl`).
const INJECT_WORK: &[&str] = &[
    "RSM texels",
    "VPL injections",
    "surfel injections",
    "atomic adds",
];

/// WGSL source of the injection passes (`count_work`: with work counting).
pub fn source(count_work: bool) -> String {
    library_shader("gi/lpv/inject", &[("count_work", count_work)])
}

impl Inject {
    /// Builds the pipelines of the pass `name`; `grids` holds the `Grids` uniform.
    pub(crate) fn new(
        ctx: &GpuContext,
        name: &str,
        grids: &wgpu::Buffer,
        rsm: &RsmTargets,
        v: &Volumes,
        frame: &GiFrame,
    ) -> Result<Inject> {
        let module = ctx.shader("lpv inject", &source(ctx.work().is_some()));
        let work = crate::gpu::work::entry(ctx, name, INJECT_WORK)?;
        // The three injections count their work; the resolves do not.
        let bind_counted = |pipeline: &wgpu::ComputePipeline,
                            entries: &[(u32, wgpu::BindingResource)]| {
            let mut entries = entries.to_vec();
            entries.extend(work.clone());
            bind(ctx, pipeline, &entries)
        };
        let tex = wgpu::BindingResource::TextureView;
        let light = ctx.compute_pipeline("lpv inject light", &module, "inject_light");
        let light_group = bind_counted(
            &light,
            &[
                (0, grids.as_entire_binding()),
                (1, tex(&rsm.position_array)),
                (2, tex(&rsm.normal_array)),
                (3, tex(&rsm.flux_array)),
                (4, v.light_lo.as_entire_binding()),
                (12, v.light_hi.as_entire_binding()),
            ],
        );
        let gv_rsm = ctx.compute_pipeline("lpv inject gv rsm", &module, "inject_gv_rsm");
        let gv_rsm_group = bind_counted(
            &gv_rsm,
            &[
                (0, grids.as_entire_binding()),
                (1, tex(&rsm.position_array)),
                (2, tex(&rsm.normal_array)),
                (3, tex(&rsm.flux_array)),
                (5, v.gv_lo.as_entire_binding()),
                (13, v.gv_hi.as_entire_binding()),
            ],
        );
        let gv_camera = ctx.compute_pipeline("lpv inject gv camera", &module, "inject_gv_camera");
        let gv_camera_group = bind_counted(
            &gv_camera,
            &[
                (0, grids.as_entire_binding()),
                (5, v.gv_lo.as_entire_binding()),
                (13, v.gv_hi.as_entire_binding()),
                (6, frame.camera_uniform.as_entire_binding()),
                (7, tex(frame.gbuffer.depth_view)),
                (8, tex(frame.gbuffer.normal_view)),
            ],
        );
        let resolve = ctx.compute_pipeline("lpv resolve light", &module, "resolve_light");
        let resolve_group = bind(
            ctx,
            &resolve,
            &[
                (0, grids.as_entire_binding()),
                (9, v.light_lo.as_entire_binding()),
                (14, v.light_hi.as_entire_binding()),
                (11, v.a.as_entire_binding()),
            ],
        );
        let combine = ctx.compute_pipeline("lpv combine gv", &module, "combine_gv");
        let combine_group = bind(
            ctx,
            &combine,
            &[
                (0, grids.as_entire_binding()),
                (9, v.gv_lo.as_entire_binding()),
                (14, v.gv_hi.as_entire_binding()),
                (10, v.gv.as_entire_binding()),
            ],
        );
        Ok(Inject {
            light: (light, light_group),
            gv_rsm: (gv_rsm, gv_rsm_group),
            gv_camera: (gv_camera, gv_camera_group),
            resolve: (resolve, resolve_group),
            combine: (combine, combine_group),
            rsm_size: rsm.size,
            rsm_layers: rsm.layers,
            width: frame.gbuffer.width,
            height: frame.gbuffer.height,
        })
    }

    /// Records the clears, the three injection dispatches and the two resolves as one named
    /// pass.
    pub(crate) fn record(&self, timer: &mut PassTimer, name: &str, v: &Volumes, stride: u32) {
        timer.pass(name, |encoder, stamps| {
            for sums in [&v.light_lo, &v.light_hi, &v.gv_lo, &v.gv_hi] {
                encoder.clear_buffer(sums, 0, None);
            }
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(name),
                timestamp_writes: stamps.compute(),
            });
            if self.rsm_layers > 0 {
                let blocks = groups(self.rsm_size.div_ceil(stride.max(1)), 8);
                pass.set_pipeline(&self.light.0);
                pass.set_bind_group(0, &self.light.1, &[]);
                pass.dispatch_workgroups(blocks, blocks, self.rsm_layers);
                let texels = groups(self.rsm_size, 8);
                pass.set_pipeline(&self.gv_rsm.0);
                pass.set_bind_group(0, &self.gv_rsm.1, &[]);
                pass.dispatch_workgroups(texels, texels, self.rsm_layers);
            }
            let s = camera_stride(self.width, self.height);
            pass.set_pipeline(&self.gv_camera.0);
            pass.set_bind_group(0, &self.gv_camera.1, &[]);
            pass.dispatch_workgroups(
                groups(self.width.div_ceil(s), 8),
                groups(self.height.div_ceil(s), 8),
                1,
            );
            for (pipeline, count) in [(&self.resolve, v.cells * 12), (&self.combine, v.gv_cells)] {
                pass.set_pipeline(&pipeline.0);
                pass.set_bind_group(0, &pipeline.1, &[]);
                let g = groups(count, 64);
                pass.dispatch_workgroups(g.min(65535), g.div_ceil(65535), 1);
            }
        });
    }
}

/// The fixed-point scale of the injected light sums for RSM layers `layers`: a power of two that
/// leaves the largest possible sum (all reflected flux in one cell) 2^58 units, well inside the
/// signed 64-bit range, so the smallest unit is 2^-58 of the light's total reflected flux.
pub fn light_scale(layers: &[RsmLayer]) -> f32 {
    let bound = crate::frame::rsm::reflected_flux_bound(layers);
    if !(bound.is_finite() && bound > 0.0) {
        return 1.0;
    }
    let exponent = (58 - bound.log2().ceil() as i32).clamp(-100, 100);
    2f32.powi(exponent)
}
