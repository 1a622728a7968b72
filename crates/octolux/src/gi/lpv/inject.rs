//! Injection of VPLs into the light volumes and of surfels into the geometry volumes.

use super::propagate::Volumes;
use super::rsm::RsmTargets;
use super::{bind, groups, wgsl, GiFrame, CELL_BYTES};
use crate::gpu::{GpuContext, PassTimer};

/// The injection pipelines and bind groups.
pub struct Inject {
    light: (wgpu::ComputePipeline, wgpu::BindGroup),
    gv_rsm: (wgpu::ComputePipeline, wgpu::BindGroup),
    gv_camera: (wgpu::ComputePipeline, wgpu::BindGroup),
    combine: (wgpu::ComputePipeline, wgpu::BindGroup),
    rsm_size: u32,
    rsm_layers: u32,
    width: u32,
    height: u32,
}

/// WGSL source of the injection passes.
pub fn source() -> String {
    wgsl(&[
        include_str!("../../render/common.wgsl"),
        include_str!("sh.wgsl"),
        include_str!("inject.wgsl"),
    ])
}

impl Inject {
    /// Builds the pipelines; `grids` holds the `Grids` uniform.
    pub(crate) fn new(
        ctx: &GpuContext,
        grids: &wgpu::Buffer,
        rsm: &RsmTargets,
        v: &Volumes,
        frame: &GiFrame,
    ) -> Inject {
        let module = ctx.shader("lpv inject", &source());
        let tex = wgpu::BindingResource::TextureView;
        let light = ctx.compute_pipeline("lpv inject light", &module, "inject_light");
        let light_group = bind(
            ctx,
            &light,
            &[
                (0, grids.as_entire_binding()),
                (1, tex(&rsm.position_array)),
                (2, tex(&rsm.normal_array)),
                (3, tex(&rsm.flux_array)),
                (4, v.a.as_entire_binding()),
            ],
        );
        let gv_rsm = ctx.compute_pipeline("lpv inject gv rsm", &module, "inject_gv_rsm");
        let gv_rsm_group = bind(
            ctx,
            &gv_rsm,
            &[
                (0, grids.as_entire_binding()),
                (1, tex(&rsm.position_array)),
                (2, tex(&rsm.normal_array)),
                (3, tex(&rsm.flux_array)),
                (5, v.gv_both.as_entire_binding()),
            ],
        );
        let gv_camera = ctx.compute_pipeline("lpv inject gv camera", &module, "inject_gv_camera");
        let gv_camera_group = bind(
            ctx,
            &gv_camera,
            &[
                (0, grids.as_entire_binding()),
                (5, v.gv_both.as_entire_binding()),
                (6, frame.camera_uniform.as_entire_binding()),
                (7, tex(&frame.gbuffer.depth_view)),
                (8, tex(&frame.gbuffer.normal_view)),
            ],
        );
        let combine = ctx.compute_pipeline("lpv combine gv", &module, "combine_gv");
        let combine_group = bind(
            ctx,
            &combine,
            &[
                (0, grids.as_entire_binding()),
                (9, v.gv_both.as_entire_binding()),
                (10, v.gv.as_entire_binding()),
            ],
        );
        Inject {
            light: (light, light_group),
            gv_rsm: (gv_rsm, gv_rsm_group),
            gv_camera: (gv_camera, gv_camera_group),
            combine: (combine, combine_group),
            rsm_size: rsm.size,
            rsm_layers: rsm.layers,
            width: frame.gbuffer.albedo.width(),
            height: frame.gbuffer.albedo.height(),
        }
    }

    /// Records the clears and the four injection dispatches as one named pass.
    pub(crate) fn record(&self, timer: &mut PassTimer, name: &str, v: &Volumes, stride: u32) {
        timer.pass(name, |encoder, stamps| {
            encoder.clear_buffer(&v.a, 0, Some(v.cells as u64 * CELL_BYTES));
            encoder.clear_buffer(&v.gv_both, 0, None);
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
            pass.set_pipeline(&self.gv_camera.0);
            pass.set_bind_group(0, &self.gv_camera.1, &[]);
            pass.dispatch_workgroups(groups(self.width, 8), groups(self.height, 8), 1);
            pass.set_pipeline(&self.combine.0);
            pass.set_bind_group(0, &self.combine.1, &[]);
            let g = groups(v.gv_cells, 64);
            pass.dispatch_workgroups(g.min(65535), g.div_ceil(65535), 1);
        });
    }
}
