//! The LPV kernels run on their own on given data (no scene, no renderer), for tests that
//! compare them with the CPU reference in [`super::sh`] and for measurements.

use super::octree::{LpvOctree, OctreeBuffers};
use super::propagate::{Propagate, Volumes};
use super::sh::{Cell, Sh};
use super::{layouts, GpuGrid, FLAG_INJECT, FLAG_OCCLUSION};
use crate::gpu::{read_buffer, GpuContext, PassTimer};
use crate::{Error, Result};

const OWNER: &str = "lpv-kernels";

fn upload_cells(ctx: &GpuContext, buffer: &wgpu::Buffer, offset: u64, cells: &[Cell]) {
    let floats: Vec<f32> = cells.iter().flatten().flatten().copied().collect();
    if !floats.is_empty() {
        ctx.queue
            .write_buffer(buffer, offset, bytemuck::cast_slice(&floats));
    }
}

/// Reads `count` cells from `first` of a light buffer.
pub(crate) fn read_cells(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    first: u32,
    count: u32,
) -> Result<Vec<Cell>> {
    let bytes = read_buffer(
        ctx,
        buffer,
        first as u64 * super::CELL_BYTES,
        count as u64 * super::CELL_BYTES,
    )?;
    let floats: &[f32] = bytemuck::try_cast_slice(&bytes)
        .map_err(|e| Error::Gpu(format!("volume readback: {e}")))?;
    Ok(floats
        .chunks_exact(12)
        .map(|c| {
            [
                [c[0], c[1], c[2], c[3]],
                [c[4], c[5], c[6], c[7]],
                [c[8], c[9], c[10], c[11]],
            ]
        })
        .collect())
}

fn read_u32(ctx: &GpuContext, buffer: &wgpu::Buffer, first: u32, count: u32) -> Result<Vec<u32>> {
    let bytes = read_buffer(ctx, buffer, first as u64 * 4, count as u64 * 4)?;
    Ok(bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}

fn write_slots(ctx: &GpuContext, buffer: &wgpu::Buffer, grids: &[GpuGrid], directional: f32) {
    ctx.queue
        .write_buffer(buffer, 0, &super::propagate::slot_data(grids, directional));
}

/// Result of [`propagate`].
pub struct Propagated {
    /// The light after the last step.
    pub last: Vec<Cell>,
    /// Injected light plus every step.
    pub accumulated: Vec<Cell>,
}

/// Runs `iterations` GPU propagation steps on an `n`^3 grid starting from `input`, occluded by
/// the `(n+1)^3` geometry volume `gv` when given, re-emitting with `directional` (`sh::reemit`).
pub fn propagate(
    ctx: &GpuContext,
    n: u32,
    input: &[Cell],
    gv: Option<&[Sh]>,
    iterations: u32,
    directional: f32,
) -> Result<Propagated> {
    let cells = n * n * n;
    if input.len() != cells as usize {
        return Err(Error::InvalidArgument(format!(
            "{} cells given for a {n}^3 grid",
            input.len()
        )));
    }
    let (grid_layouts, cells, gv_cells) = layouts(&[n], |_| {
        FLAG_INJECT | if gv.is_some() { FLAG_OCCLUSION } else { 0 }
    });
    let v = Volumes::new(ctx, OWNER, cells, gv_cells);
    upload_cells(ctx, &v.a, 0, input);
    if let Some(gv) = gv {
        let floats: Vec<f32> = gv.iter().flatten().copied().collect();
        ctx.queue
            .write_buffer(&v.gv, 0, bytemuck::cast_slice(&floats));
    }
    let slots = super::param_slots(ctx, OWNER, "grid slots", 1);
    write_slots(
        ctx,
        &slots,
        &[GpuGrid {
            origin: [0.0; 3],
            cell: 1.0,
            n,
            offset: 0,
            gv_offset: 0,
            flags: grid_layouts[0].flags,
        }],
        directional,
    );
    let p = Propagate::new(ctx, &slots, &v);
    let mut timer = PassTimer::new(ctx);
    p.record(&mut timer, "propagate", &v, &grid_layouts, iterations)?;
    timer.finish_frame()?;
    let last = if iterations.is_multiple_of(2) {
        &v.a
    } else {
        &v.b
    };
    Ok(Propagated {
        last: read_cells(ctx, last, 0, cells)?,
        accumulated: read_cells(ctx, &v.acc, 0, cells)?,
    })
}

/// Result of [`octree`].
pub struct OctreeRun {
    /// Levels O_0..O_{l-1} after injection and downsampling.
    pub injected: Vec<Vec<Cell>>,
    /// Index volume levels I_i.
    pub index: Vec<Vec<u32>>,
    /// Accumulated levels after propagation.
    pub accumulated: Vec<Vec<Cell>>,
    /// The merged n^3 volume.
    pub merged: Vec<Cell>,
}

/// Runs the octree passes on the GPU: level 0 = `level0`, occupancy from the level-0 geometry
/// volume `gv0` ((n+1)^3 cells), `iterations` unoccluded propagation steps on every level
/// (re-emission `directional`, `sh::reemit`), merge.
pub fn octree(
    ctx: &GpuContext,
    n: u32,
    level0: &[Cell],
    gv0: &[Sh],
    iterations: u32,
    directional: f32,
) -> Result<OctreeRun> {
    if !n.is_power_of_two() || n < 2 || level0.len() != (n * n * n) as usize {
        return Err(Error::InvalidArgument(format!(
            "octree of side {n} with {} cells",
            level0.len()
        )));
    }
    let l = n.trailing_zeros() + 1;
    let sides: Vec<u32> = (0..l).map(|i| n >> i).collect();
    let (grid_layouts, cells, gv_cells) = layouts(&sides, |i| if i == 0 { FLAG_INJECT } else { 0 });
    let v = Volumes::new(ctx, OWNER, cells, gv_cells);
    upload_cells(ctx, &v.a, 0, level0);
    let floats: Vec<f32> = gv0.iter().flatten().copied().collect();
    ctx.queue
        .write_buffer(&v.gv, 0, bytemuck::cast_slice(&floats));
    let b = OctreeBuffers::new(ctx, OWNER, n, cells);
    let o = LpvOctree::new(ctx, &b, &v);
    let mut timer = PassTimer::new(ctx);
    o.record_downsample(&mut timer, &v);
    o.record_index(&mut timer);
    timer.finish_frame()?;
    let mut injected = Vec::new();
    let mut index = Vec::new();
    for gl in &grid_layouts {
        let count = gl.n * gl.n * gl.n;
        injected.push(read_cells(ctx, &v.a, gl.offset, count)?);
        index.push(read_u32(ctx, &b.index, gl.offset, count)?);
    }
    let slots = super::param_slots(ctx, OWNER, "grid slots", l as u64);
    let grids: Vec<GpuGrid> = grid_layouts
        .iter()
        .map(|gl| GpuGrid {
            origin: [0.0; 3],
            cell: (n / gl.n) as f32,
            n: gl.n,
            offset: gl.offset,
            gv_offset: gl.gv_offset,
            flags: gl.flags,
        })
        .collect();
    write_slots(ctx, &slots, &grids, directional);
    let p = Propagate::new(ctx, &slots, &v);
    p.record(&mut timer, "propagate", &v, &grid_layouts, iterations)?;
    o.record_merge(&mut timer);
    timer.finish_frame()?;
    let mut accumulated = Vec::new();
    for gl in &grid_layouts {
        accumulated.push(read_cells(ctx, &v.acc, gl.offset, gl.n * gl.n * gl.n)?);
    }
    Ok(OctreeRun {
        injected,
        index,
        accumulated,
        merged: read_cells(ctx, &b.merged, 0, n * n * n)?,
    })
}
