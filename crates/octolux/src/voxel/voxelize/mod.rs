//! Conservative voxelization in compute shaders (wgpu has no geometry shaders): one invocation
//! per work item (a triangle piece and a chunk of its bounding box) visits the voxels of its
//! chunk and keeps those the triangle touches, decided by an exact integer separating-axis
//! test on a fixed-point lattice ([`crate::voxel::voxelize::snap`], `voxelize/overlap.wgsl`): the CPU snaps and splits the
//! triangles before upload, the GPU decides in integers, so the result is the same on every
//! adapter. Thin poles and 45-degree planes are never lost, unlike rasterisation-based
//! voxelization.
//!
//! [`Voxelizer::fragments`] builds a voxel fragment list whose memory is bounded by a count
//! pass: the list holds one 8-byte fragment per (piece, voxel) pair (one per (triangle,
//! voxel) pair, except on the seams of triangles split into pieces).

pub mod cpu;
pub mod snap;

use crate::gpu::pass::{bind_buffers, dispatch_1d};
use crate::gpu::{read_buffer, GpuContext, PassTimer, PassTiming};
use crate::voxel::voxelize::snap::{snap_triangles, Piece, SnapRegion};
use crate::voxel::{VoxelGrid, VoxelTriangle};
use crate::{Error, Result};

/// Parameter block `VoxParams` of `voxelize/overlap.wgsl` (a read-only storage buffer).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VoxParams {
    /// First voxel of the region.
    pub lo: [i32; 3],
    /// Work items (pieces x chunks) of the dispatch.
    pub items: u32,
    /// One past the last voxel of the region.
    pub hi: [i32; 3],
    /// The appending kernel's counter: the word of its `append` buffer it adds to.
    pub counter: u32,
}

impl VoxParams {
    /// The block for all of `grid`, `items` work items and the append counter `counter`.
    fn whole_grid(grid: &VoxelGrid, items: u32, counter: u32) -> VoxParams {
        VoxParams {
            lo: [0; 3],
            items,
            hi: [grid.resolution as i32; 3],
            counter,
        }
    }
}

/// Uploads triangles in the GPU layout under `owner`.
pub fn upload_triangles(ctx: &GpuContext, owner: &str, tris: &[VoxelTriangle]) -> wgpu::Buffer {
    upload_storage(
        ctx,
        owner,
        "triangles",
        tris.iter().map(VoxelTriangle::to_gpu).collect(),
    )
}

/// Uploads snapped pieces ([`crate::voxel::voxelize::snap`]) in the GPU layout under `owner`.
pub fn upload_pieces(ctx: &GpuContext, owner: &str, pieces: &[Piece]) -> wgpu::Buffer {
    upload_storage(
        ctx,
        owner,
        "triangle pieces",
        pieces.iter().map(Piece::to_gpu).collect(),
    )
}

/// A storage buffer holding `items`; an empty list gets one zero element, since a binding
/// must hold at least one (kernels are told the real count).
fn upload_storage<T: bytemuck::Pod>(
    ctx: &GpuContext,
    owner: &str,
    label: &str,
    mut items: Vec<T>,
) -> wgpu::Buffer {
    if items.is_empty() {
        items.push(bytemuck::Zeroable::zeroed());
    }
    ctx.create_buffer_init(
        owner,
        label,
        bytemuck::cast_slice(&items),
        wgpu::BufferUsages::STORAGE,
    )
}

pub use crate::voxel::voxelize::snap::{work_items, CHUNK};

/// A voxel fragment list on the GPU: `count` fragments of two words, (packed voxel coordinate
/// as in [`crate::voxel::pack_coord`], triangle index).
pub struct FragmentList {
    /// The fragments (`array<vec2<u32>>`), at least one element long.
    pub buffer: wgpu::Buffer,
    /// Number of fragments.
    pub count: u32,
    /// The triangles the fragments refer to (`array<Tri>` of `voxelize/overlap.wgsl`).
    pub triangles: wgpu::Buffer,
    /// Number of triangles.
    pub triangle_count: u32,
}

/// The fragment-list voxelizer's pipelines.
pub struct Voxelizer {
    count: wgpu::ComputePipeline,
    emit: wgpu::ComputePipeline,
    append: wgpu::ComputePipeline,
}

impl Voxelizer {
    /// Compiles the voxelization kernels.
    pub fn new(ctx: &GpuContext) -> Voxelizer {
        let source = crate::gpu::shader::library_shader("voxel/voxelize/voxelize", &[]);
        let module = ctx.shader("voxelize", &source);
        Voxelizer {
            count: ctx.compute_pipeline("voxelize count", &module, "count_fragments"),
            emit: ctx.compute_pipeline("voxelize emit", &module, "emit_fragments"),
            append: ctx.compute_pipeline("voxelize append", &module, "append_fragments"),
        }
    }

    /// Voxelizes `tris` into `grid`: a count pass, a scan of the counts on the CPU (which also
    /// sizes the list), and an emit pass. Buffers are recorded under `owner`; the pass times
    /// (`voxelize count`, `voxelize emit`) are appended to `timings`.
    pub fn fragments(
        &self,
        ctx: &GpuContext,
        owner: &str,
        grid: &VoxelGrid,
        tris: &[VoxelTriangle],
        timings: &mut Vec<PassTiming>,
    ) -> Result<FragmentList> {
        let n = u32::try_from(tris.len())
            .map_err(|_| Error::InvalidArgument(format!("{} triangles", tris.len())))?;
        let (pieces, items, n_items) = snap_grid(grid, tris)?;
        let params = VoxParams::whole_grid(grid, n_items, 0);
        let params_buffer = ctx.create_buffer_init(
            owner,
            "voxelize params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let triangles = upload_triangles(ctx, owner, tris);
        let pieces_buffer = upload_pieces(ctx, owner, &pieces);
        let items_buffer = ctx.create_buffer_init(
            owner,
            "work items",
            bytemuck::cast_slice(&items),
            wgpu::BufferUsages::STORAGE,
        );
        let counts = ctx.create_buffer(
            owner,
            &wgpu::BufferDescriptor {
                label: Some("fragment counts"),
                size: (n_items as u64 * 4).max(16),
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let mut timer = PassTimer::new(ctx);
        let group = bind_buffers(
            ctx,
            &self.count,
            &[
                (0, &params_buffer),
                (1, &pieces_buffer),
                (2, &counts),
                (4, &items_buffer),
            ],
        );
        dispatch_1d(&mut timer, "voxelize count", &self.count, &group, n_items);
        timings.extend(timer.finish_frame()?);
        let bytes = read_buffer(ctx, &counts, 0, n_items as u64 * 4)?;
        let counts_cpu: &[u32] = bytemuck::cast_slice(&bytes);
        let mut offsets = Vec::with_capacity(counts_cpu.len());
        let mut total: u64 = 0;
        for &c in counts_cpu {
            offsets.push(total as u32);
            total += c as u64;
        }
        let limit = ctx.device.limits().max_storage_buffer_binding_size / 8;
        if total > limit.min(u32::MAX as u64) {
            return Err(Error::InvalidArgument(format!(
                "voxelizing {} triangles at {}^3 gives {total} fragments, more than this GPU \
                 can bind ({limit}); use a lower resolution",
                tris.len(),
                grid.resolution
            )));
        }
        let buffer = ctx.create_buffer(
            owner,
            &wgpu::BufferDescriptor {
                label: Some("fragments"),
                size: (total * 8).max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        );
        if n_items > 0 {
            ctx.queue
                .write_buffer(&counts, 0, bytemuck::cast_slice(&offsets));
        }
        let group = bind_buffers(
            ctx,
            &self.emit,
            &[
                (0, &params_buffer),
                (1, &pieces_buffer),
                (2, &counts),
                (3, &buffer),
                (4, &items_buffer),
            ],
        );
        dispatch_1d(&mut timer, "voxelize emit", &self.emit, &group, n_items);
        timings.extend(timer.finish_frame()?);
        // The counts are scratch: forget them in the ledger once the list exists.
        ctx.ledger.forget(owner, "fragment counts");
        ctx.ledger.forget(owner, "work items");
        ctx.ledger.forget(owner, "triangle pieces");
        Ok(FragmentList {
            buffer,
            count: total as u32,
            triangles,
            triangle_count: n,
        })
    }
}

impl Voxelizer {
    /// Records the voxelization of `tris` into `grid` as one pass (`name`) that appends to
    /// `fragments` (a list of fixed capacity, 8 bytes per fragment) without waiting for the
    /// GPU: each work item reserves its range with an atomic add on word `word` of `counter`,
    /// which must be zero before the pass and ends at the number of fragments
    /// (also when they exceed the capacity; those past it are dropped). Fragment order varies
    /// from run to run. Returns the uploaded triangles, which the fragments refer to.
    pub(crate) fn append(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (owner, name): (&str, &str),
        grid: &VoxelGrid,
        tris: &[VoxelTriangle],
        (fragments, counter, word): (&wgpu::Buffer, &wgpu::Buffer, u32),
    ) -> Result<wgpu::Buffer> {
        u32::try_from(tris.len())
            .map_err(|_| Error::InvalidArgument(format!("{} triangles", tris.len())))?;
        let (pieces, items, n_items) = snap_grid(grid, tris)?;
        let triangles = upload_triangles(ctx, owner, tris);
        if n_items == 0 {
            return Ok(triangles);
        }
        let params = VoxParams::whole_grid(grid, n_items, word);
        let params_buffer = ctx.create_buffer_init(
            owner,
            "voxelize params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let pieces_buffer = upload_pieces(ctx, owner, &pieces);
        let items_buffer = ctx.create_buffer_init(
            owner,
            "work items",
            bytemuck::cast_slice(&items),
            wgpu::BufferUsages::STORAGE,
        );
        let group = bind_buffers(
            ctx,
            &self.append,
            &[
                (0, &params_buffer),
                (1, &pieces_buffer),
                (3, fragments),
                (4, &items_buffer),
                (5, counter),
            ],
        );
        dispatch_1d(timer, name, &self.append, &group, n_items);
        for label in ["voxelize params", "work items", "triangle pieces"] {
            ctx.ledger.forget(owner, label);
        }
        Ok(triangles)
    }
}

/// Reads a fragment list back: (voxel coordinate, triangle index) pairs in list order.
pub fn read_fragments(ctx: &GpuContext, list: &FragmentList) -> Result<Vec<([u32; 3], u32)>> {
    if list.count == 0 {
        return Ok(Vec::new());
    }
    let bytes = read_buffer(ctx, &list.buffer, 0, list.count as u64 * 8)?;
    let words: &[u32] = bytemuck::cast_slice(&bytes);
    Ok(words
        .chunks_exact(2)
        .map(|w| (crate::voxel::unpack_coord(w[0]), w[1]))
        .collect())
}

/// `tris` snapped to the whole grid and split into pieces, their work items and the item
/// count.
fn snap_grid(
    grid: &VoxelGrid,
    tris: &[VoxelTriangle],
) -> Result<(Vec<crate::voxel::voxelize::snap::Piece>, Vec<[u32; 2]>, u32)> {
    let region = SnapRegion {
        origin: grid.origin,
        voxel_size: grid.voxel_size,
        lo: glam::IVec3::ZERO,
        hi: glam::IVec3::splat(grid.resolution as i32),
    };
    let pieces = snap_triangles(&region, tris);
    let items = work_items(&pieces, region.size());
    let n_items = u32::try_from(items.len())
        .map_err(|_| Error::InvalidArgument(format!("{} work items", items.len())))?;
    Ok((pieces, items, n_items))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn vox_params_mirror_the_wgsl_block() {
        assert_mirrors_wgsl!(
            VoxParams,
            "voxel/voxelize/overlap",
            "VoxParams",
            [lo, items, hi, counter]
        );
    }

    #[test]
    fn triangles_and_pieces_mirror_the_wgsl_records() {
        use crate::voxel::voxelize::snap::GpuPiece;
        use crate::voxel::GpuTriangle;
        assert_mirrors_wgsl!(
            GpuTriangle,
            "voxel/voxelize/overlap",
            "Tri",
            [emission, albedo, normal]
        );
        assert_mirrors_wgsl!(
            GpuPiece,
            "voxel/voxelize/overlap",
            "Piece",
            [a, triangle, b, c]
        );
    }
}
