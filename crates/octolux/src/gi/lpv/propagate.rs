//! Propagation: `iterations` gather steps on every grid, ping-ponging between two light buffers
//! and adding each step to the accumulation buffer (which starts as the injected light).

use super::{bind, groups, storage, GpuGrid, Layout, CELL_BYTES, SLOT};
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::Result;

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
    /// Injected light as 64-bit fixed-point sums: low words (one u32 per value).
    pub light_lo: wgpu::Buffer,
    /// High words of the injected light's sums.
    pub light_hi: wgpu::Buffer,
    /// Geometry volumes from the RSMs (first half) and the camera (second half), as injected:
    /// low words of 64-bit fixed-point sums.
    pub gv_lo: wgpu::Buffer,
    /// High words of the geometry sums.
    pub gv_hi: wgpu::Buffer,
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
            light_lo: storage(ctx, owner, "light injected (low words)", light),
            light_hi: storage(ctx, owner, "light injected (high words)", light),
            gv_lo: storage(ctx, owner, "geometry injected (low words)", gv * 2),
            gv_hi: storage(ctx, owner, "geometry injected (high words)", gv * 2),
            gv: storage(ctx, owner, "geometry", gv),
        }
    }
}

/// What propagation counts, on the CPU (its work is fixed by the grids and the iterations):
/// steps (dispatches, each waiting for the one before), lanes (invocations launched: every
/// grid's 4x4x4-cell bricks x 64, per step) and cell updates (every grid's cells, per step).
const PROPAGATE_WORK: &[&str] = &["steps", "lanes", "cell updates"];

/// The propagation pipeline and its bind groups (A->B and B->A, every grid at once).
pub struct Propagate {
    pipeline: wgpu::ComputePipeline,
    groups: [wgpu::BindGroup; 2],
}

/// The contents of the grid slot buffer for `grids` (`GridSlot` of `propagate.wgsl`): per
/// 256-byte slot the grid, the first of its 4x4x4-cell bricks in the dispatch and the
/// re-emission's `directional` share (`sh::reemit`).
pub fn slot_data(grids: &[GpuGrid], directional: f32) -> Vec<u8> {
    let mut data = vec![0u8; grids.len().max(1) * SLOT as usize];
    let mut first = 0u32;
    for (i, g) in grids.iter().enumerate() {
        let at = i * SLOT as usize;
        data[at..at + 32].copy_from_slice(bytemuck::bytes_of(g));
        data[at + 32..at + 36].copy_from_slice(&first.to_le_bytes());
        data[at + 36..at + 40].copy_from_slice(&directional.to_le_bytes());
        first += groups(g.n, 4).pow(3);
    }
    data
}

/// WGSL source of the propagation step.
pub fn source() -> String {
    library_shader("gi/lpv/propagate", &[])
}

impl Propagate {
    /// Builds the pipeline; `grid_slots` holds one `Grid` per 256-byte slot, one slot per grid
    /// and nothing more.
    pub fn new(ctx: &GpuContext, grid_slots: &wgpu::Buffer, v: &Volumes) -> Propagate {
        let module = ctx.shader("lpv propagate", &source());
        let pipeline = ctx.compute_pipeline("lpv propagate", &module, "main");
        let make = |src: &wgpu::Buffer, dst: &wgpu::Buffer| {
            bind(
                ctx,
                &pipeline,
                &[
                    (0, grid_slots.as_entire_binding()),
                    (1, src.as_entire_binding()),
                    (2, dst.as_entire_binding()),
                    (3, v.acc.as_entire_binding()),
                    (4, v.gv.as_entire_binding()),
                ],
            )
        };
        let groups = [make(&v.a, &v.b), make(&v.b, &v.a)];
        Propagate { pipeline, groups }
    }

    /// Records the pass `name`: acc = A, then `iterations` steps, each one dispatch over every
    /// grid. The last state ends in A or B; only `acc` is used afterwards. Where the context
    /// counts work, adds the steps, lanes and cell updates to `name`'s counts.
    pub fn record(
        &self,
        timer: &mut PassTimer,
        name: &str,
        v: &Volumes,
        layouts: &[Layout],
        iterations: u32,
    ) -> Result<()> {
        let bricks: u32 = layouts.iter().map(|l| groups(l.n, 4).pow(3)).sum();
        let cells: u64 = layouts.iter().map(|l| (l.n as u64).pow(3)).sum();
        let steps = iterations as u64;
        for (q, n) in [steps, steps * bricks as u64 * 64, steps * cells]
            .into_iter()
            .enumerate()
        {
            crate::gpu::work::add(timer.context(), name, PROPAGATE_WORK, q, n)?;
        }
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
                pass.set_bind_group(0, &self.groups[(it % 2) as usize], &[]);
                pass.dispatch_workgroups(bricks.min(65535), bricks.div_ceil(65535), 1);
            }
        });
        Ok(())
    }
}
