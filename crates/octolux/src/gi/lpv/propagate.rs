//! Propagation: `iterations` gather steps on every grid, ping-ponging between two light buffers
//! and adding each step to the accumulation buffer (which starts as the injected light).

use super::{bind, groups, slot, storage, wgsl, Layout, CELL_BYTES};
use crate::gpu::{GpuContext, PassTimer};

/// The light and geometry buffers every pass of the family shares.
pub struct Volumes {
    /// Cells in all grids.
    pub cells: u32,
    /// Cells in all geometry volumes.
    pub gv_cells: u32,
    /// Light state A (injection target, even steps' source).
    pub a: wgpu::Buffer,
    /// Light state B.
    pub b: wgpu::Buffer,
    /// Accumulated light.
    pub acc: wgpu::Buffer,
    /// Injected light as 64-bit fixed-point sums (two u32 words per value).
    pub light_fixed: wgpu::Buffer,
    /// Geometry volumes from the RSMs (first half) and the camera (second half), as injected:
    /// 64-bit fixed-point sums (two u32 words per value).
    pub gv_fixed: wgpu::Buffer,
    /// Max-combined geometry volumes.
    pub gv: wgpu::Buffer,
}

impl Volumes {
    /// Allocates the buffers for `cells` light cells and `gv_cells` geometry cells.
    pub fn new(ctx: &GpuContext, owner: &str, cells: u32, gv_cells: u32) -> Volumes {
        let light = cells as u64 * CELL_BYTES;
        let gv = gv_cells as u64 * 16;
        Volumes {
            cells,
            gv_cells,
            a: storage(ctx, owner, "light a", light),
            b: storage(ctx, owner, "light b", light),
            acc: storage(ctx, owner, "light accumulated", light),
            light_fixed: storage(ctx, owner, "light injected (fixed point)", light * 2),
            gv_fixed: storage(ctx, owner, "geometry injected (fixed point)", gv * 4),
            gv: storage(ctx, owner, "geometry", gv),
        }
    }
}

/// The propagation pipeline and its bind groups (per grid, A->B and B->A).
pub struct Propagate {
    pipeline: wgpu::ComputePipeline,
    /// Per grid: [A->B, B->A].
    groups: Vec<[wgpu::BindGroup; 2]>,
}

/// WGSL source of the propagation step.
pub fn source() -> String {
    wgsl(&[include_str!("sh.wgsl"), include_str!("propagate.wgsl")])
}

impl Propagate {
    /// Builds the pipeline; `grid_slots` holds one `Grid` per 256-byte slot.
    pub fn new(
        ctx: &GpuContext,
        grid_slots: &wgpu::Buffer,
        grid_count: usize,
        v: &Volumes,
    ) -> Propagate {
        let module = ctx.shader("lpv propagate", &source());
        let pipeline = ctx.compute_pipeline("lpv propagate", &module, "main");
        let groups = (0..grid_count as u64)
            .map(|g| {
                let make = |src: &wgpu::Buffer, dst: &wgpu::Buffer| {
                    bind(
                        ctx,
                        &pipeline,
                        &[
                            (0, slot(grid_slots, g, 32)),
                            (1, src.as_entire_binding()),
                            (2, dst.as_entire_binding()),
                            (3, v.acc.as_entire_binding()),
                            (4, v.gv.as_entire_binding()),
                        ],
                    )
                };
                [make(&v.a, &v.b), make(&v.b, &v.a)]
            })
            .collect();
        Propagate { pipeline, groups }
    }

    /// Records: acc = A, then `iterations` steps on every grid. The last state ends in A or B;
    /// only `acc` is used afterwards.
    pub fn record(
        &self,
        timer: &mut PassTimer,
        name: &str,
        v: &Volumes,
        layouts: &[Layout],
        iterations: u32,
    ) {
        timer.pass(name, |encoder, stamps| {
            encoder.copy_buffer_to_buffer(&v.a, 0, &v.acc, 0, v.cells as u64 * CELL_BYTES);
            if iterations == 0 {
                // Keep the pass timed even with nothing to do.
                let _ = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(name),
                    timestamp_writes: stamps.compute(),
                });
                return;
            }
            for it in 0..iterations {
                // One compute pass per step: the next step reads what this one wrote.
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(name),
                    timestamp_writes: stamps.compute_part(it == 0, it + 1 == iterations),
                });
                pass.set_pipeline(&self.pipeline);
                for (g, l) in layouts.iter().enumerate() {
                    pass.set_bind_group(0, &self.groups[g][(it % 2) as usize], &[]);
                    let d = groups(l.n, 4);
                    pass.dispatch_workgroups(d, d, d);
                }
            }
        });
    }
}
