//! Revoxelisation of boxes of voxels (the slabs a scrolling level exposes, the regions moving
//! objects left and entered). Per box, cut into z slices that fit the accumulation scratch:
//! the CPU finds the triangles near the slice in the scene's index, snaps them to the slice's
//! lattice and splits them into work items; the GPU accumulates each voxel's albedo, normal
//! and emission sums (`accumulate` in `update.wgsl`) and resolves them into the voxel's
//! toroidal slot (`resolve`). A filtered clipmap then rebuilds the coarser levels inside the
//! finer ones (`filter.rs`).
//!
//! The pieces, work items and box parameters go into scratch buffers kept across updates
//! ([`Scratch`]); writes land at the next submission, so several updates recorded before one
//! take successive regions of them.

use super::{Clipmap, UpdateBox};
use crate::gpu::alloc::storage;
use crate::gpu::pass::SLOT;
use crate::gpu::pass::{bind, dispatch_1d};
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::voxelize::snap::{snap_triangle, GpuPiece, Piece, SnapRegion};
use crate::voxel::voxelize::work_items;
use crate::voxel::VoxelTriangle;
use crate::Result;
use bytemuck::Zeroable;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// Scratch words per voxel of an update box (`ACCUM_WORDS` in `clipmap/update.wgsl`): albedo
/// sums (3), fragment count, normal sums (3), emission sums (3 x 64 bits).
pub(super) const ACCUM_WORDS: u64 = 13;
/// Bytes of the accumulation scratch; larger update boxes are processed in z slices.
pub(super) const ACCUM_BYTES: u64 = 64 << 20;
/// Largest scratch buffer (triangle pieces, work items, box parameters) a clipmap keeps
/// between updates; an update that needs more (a first build, a jump) uses buffers of its own.
pub const SCRATCH_KEEP: u64 = 4 << 20;
/// Initial size of each kept scratch buffer, allocated with the clipmap so that the usual
/// per-frame updates (a camera step, a moving object) never change the memory ledger.
const SCRATCH_START: u64 = 64 << 10;
/// Pieces (48 bytes) per 768-byte alignment step of a box's block of pieces.
const PIECE_ALIGN: u64 = 16;
/// Work items (8 bytes) per 256-byte alignment step of a box's block of work items.
const ITEM_ALIGN: u64 = 32;
/// Bytes of one triangle piece and of one work item on the GPU.
const PIECE_BYTES: u64 = std::mem::size_of::<GpuPiece>() as u64;
const ITEM_BYTES: u64 = 8;

/// Parameter block `BoxParams` of `update.wgsl`: one z slice of an update box.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct BoxParams {
    /// First voxel of the slice (world-voxel coordinates of its level).
    pub lo: [i32; 3],
    /// Work items of the slice.
    pub items: u32,
    /// One past the last voxel.
    pub hi: [i32; 3],
    /// First voxel slot of the slice's level in the clipmap's buffers.
    pub level_first: u32,
    /// Voxels per axis of a level.
    pub resolution: u32,
    pub _pad: [u32; 3],
}

/// CPU cost and size of the last [`Clipmap::update`] or [`Clipmap::revoxelise`] (zero when it
/// revoxelised nothing). Times are wall-clock milliseconds on the calling thread; GPU times
/// are the passes in the [`PassTimer`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UpdateStats {
    /// Boxes revoxelised, after splitting into z slices that fit the accumulation scratch.
    pub parts: u32,
    /// Triangles snapped (summed over the parts).
    pub triangles_snapped: u64,
    /// Triangle pieces uploaded.
    pub pieces: u64,
    /// Work items uploaded.
    pub work_items: u64,
    /// Bytes written to the GPU (triangles, pieces, work items, parameters).
    pub upload_bytes: u64,
    /// Finding (index queries), snapping and splitting triangles, making work items and
    /// packing them for upload; with [`Clipmap::update`] or [`Clipmap::revoxelise`] also the
    /// comparison of the given triangles with the scene.
    pub snap_ms: f64,
    /// Creating or writing GPU buffers.
    pub upload_ms: f64,
    /// Creating bind groups and recording the passes.
    pub record_ms: f64,
}

impl UpdateStats {
    /// All CPU time of the update.
    pub fn cpu_ms(&self) -> f64 {
        self.snap_ms + self.upload_ms + self.record_ms
    }
}

/// One z slice's triangles, snapped: its pieces, their work items, how many triangles the
/// index returned, and (once packed) its first piece and work item in the scratch.
struct Snapped {
    pieces: Vec<Piece>,
    items: Vec<[u32; 2]>,
    candidates: usize,
    first: (u64, u64),
}

/// Every slice's data packed for upload, one block per slice at offsets a storage binding
/// accepts ([`Snapped::first`]): pieces, work items, and a [`BoxParams`] every
/// [`SLOT`] bytes.
struct Packed {
    pieces: Vec<GpuPiece>,
    items: Vec<[u32; 2]>,
    params: Vec<u8>,
}

/// Where the packed data lies on the GPU: each scratch buffer with the offset of the region
/// this update took.
struct Uploaded {
    pieces: (wgpu::Buffer, u64),
    items: (wgpu::Buffer, u64),
    params: (wgpu::Buffer, u64),
}

impl Uploaded {
    /// The [`BoxParams`] of part `i`.
    fn part_params(&self, i: u64) -> wgpu::BindingResource<'_> {
        let (params, at) = &self.params;
        range(params, at + i * SLOT, SLOT)
    }
}

/// The scratch buffers kept across updates, in the order of [`Scratch::NAMES`].
pub(super) struct Scratch {
    kept: [wgpu::Buffer; 3],
    /// The timer submission the kept scratch was last written for, and the bytes of each
    /// used since: writes land at the next submission, so later updates recorded before it
    /// take the space after them instead of overwriting data earlier passes still read.
    used: (Option<u64>, [u64; 3]),
}

impl Scratch {
    /// Ledger names of the kept buffers, and of the buffers of one large update.
    const NAMES: [&str; 3] = ["triangle pieces", "work items", "box params"];
    const ONE_OFF: [&str; 3] = [
        "triangle pieces (one update)",
        "work items (one update)",
        "box params (one update)",
    ];

    /// The kept buffers at their initial size.
    pub(super) fn new(ctx: &GpuContext, owner: &str) -> Scratch {
        Scratch {
            kept: Self::NAMES.map(|name| scratch_buffer(ctx, owner, name, SCRATCH_START)),
            used: (None, [0; 3]),
        }
    }

    /// A region of `bytes` for buffer `which`, and its offset: in the kept buffer after what
    /// updates since the last submission of `timer` took (a new, larger kept buffer when that
    /// does not fit, up to [`SCRATCH_KEEP`]); a buffer of this update's own above (in the
    /// ledger as `... (one update)` until the next update).
    fn region(
        &mut self,
        ctx: &GpuContext,
        owner: &str,
        timer: &PassTimer,
        which: usize,
        bytes: u64,
    ) -> (wgpu::Buffer, u64) {
        let bytes = bytes.max(256).next_multiple_of(256);
        let one_off = Self::ONE_OFF[which];
        if bytes > SCRATCH_KEEP {
            return (scratch_buffer(ctx, owner, one_off, bytes), 0);
        }
        // Recorded while it lives (until the next update).
        ctx.ledger.forget(owner, one_off);
        if self.used.0 != Some(timer.submissions()) {
            self.used = (Some(timer.submissions()), [0; 3]);
        }
        let used = self.used.1[which];
        let kept = &self.kept[which];
        if kept.size() >= used + bytes {
            self.used.1[which] = used + bytes;
            return (kept.clone(), used);
        }
        // A new buffer (the old one lives on while recorded passes use it), with room for
        // growth: a quarter more, within the cap, and never smaller than the old one (which
        // was too small only for this submission's updates together).
        let size = (bytes + bytes / 4)
            .next_multiple_of(256)
            .min(SCRATCH_KEEP)
            .max(kept.size());
        let buffer = scratch_buffer(ctx, owner, Self::NAMES[which], size);
        self.kept[which] = buffer.clone();
        self.used.1[which] = bytes;
        (buffer, 0)
    }
}

/// A scratch buffer the CPU writes and passes read.
fn scratch_buffer(ctx: &GpuContext, owner: &str, label: &str, bytes: u64) -> wgpu::Buffer {
    storage(ctx, owner, label, bytes)
}

/// A binding of `size` bytes of `buffer` from `offset`.
fn range(buffer: &wgpu::Buffer, offset: u64, size: u64) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset,
        size: wgpu::BufferSize::new(size),
    })
}

impl Clipmap {
    /// Revoxelises the given boxes (each inside its level's current extent), for example the
    /// region a moving object left and entered ([`Clipmap::boxes_touching`]), with `tris` as
    /// the scene (see [`Clipmap::update`]), and the boxes [`Clipmap::replace_triangles`]
    /// queued. A filtered clipmap then rebuilds every coarser level's voxels inside the finer
    /// level, finest first.
    ///
    /// An update writes its triangle pieces, work items and box parameters into scratch
    /// buffers kept across updates (ledger: `clipmap / triangle pieces`, `work items`, `box
    /// params`; grown on demand up to [`SCRATCH_KEEP`] bytes each, larger updates such as a
    /// first build use buffers of their own) with [`wgpu::Queue::write_buffer`], which takes
    /// effect at the next submission. Several updates recorded into one frame (`timer`) use
    /// successive regions, so none overwrites data an earlier one's passes still read.
    pub fn revoxelise(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        tris: &[VoxelTriangle],
        boxes: &[UpdateBox],
    ) -> Result<()> {
        self.sync_scene(ctx, tris);
        self.revoxelise_boxes(ctx, timer, boxes)
    }

    /// Revoxelises `boxes` and the boxes moving objects queued, as a list of passes.
    pub(super) fn revoxelise_boxes(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        boxes: &[UpdateBox],
    ) -> Result<()> {
        let mut stats = std::mem::take(&mut self.acc);
        // 1. The boxes: those given, and those moving objects queued, clipped to the levels'
        //    current extents.
        let boxes = self.with_pending(boxes);
        self.revoxelised.clone_from(&boxes);
        if !boxes.is_empty() {
            // 2. Parts: each box cut into z slices that fit the accumulation scratch.
            let depth = self.slice_depth();
            let parts: Vec<UpdateBox> = boxes.iter().flat_map(|b| b.z_slices(depth)).collect();
            // 3. Snap (CPU): each part's nearby triangles on its lattice, as work items.
            let clock = Instant::now();
            let mut snapped = self.snap(&parts);
            let packed = self.pack(&parts, &mut snapped, &mut stats);
            stats.snap_ms += clock.elapsed().as_secs_f64() * 1e3;
            // 4. Upload the pieces, work items and box parameters into the scratch.
            let clock = Instant::now();
            let uploaded = self.upload(ctx, timer, &packed, &mut stats);
            stats.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
            // 5. Per part: accumulate its voxels' sums, then resolve them into the levels.
            let clock = Instant::now();
            for (i, (part, s)) in parts.iter().zip(&snapped).enumerate() {
                let part = (i as u64, part);
                self.accumulate_part(ctx, timer, part, s, &uploaded);
                self.resolve_part(ctx, timer, part, &uploaded);
            }
            // 6. Filtered clipmap: coarser levels rebuilt inside the finer levels.
            if self.options.filters() {
                self.filter_levels(ctx, timer, &boxes);
            }
            stats.record_ms += clock.elapsed().as_secs_f64() * 1e3;
        }
        self.stats = stats;
        Ok(())
    }

    /// `boxes` followed by the boxes [`Clipmap::replace_triangles`] queued (taken from the
    /// queue), clipped to the levels' current extents.
    fn with_pending(&mut self, boxes: &[UpdateBox]) -> Vec<UpdateBox> {
        let res = self.settings.resolution as i32;
        let origins = &self.origins;
        let pending = std::mem::take(&mut self.pending).into_iter();
        let queued = pending.filter_map(|b| b.clip_to_level(origins[b.level as usize]?, res));
        boxes.iter().copied().chain(queued).collect()
    }

    /// The most z layers of a level the accumulation scratch holds.
    fn slice_depth(&self) -> i32 {
        let layer = (self.settings.resolution as u64).pow(2).max(1);
        (self.accum.size() / (ACCUM_WORDS * 4) / layer).max(1) as i32
    }

    /// Finds (index), snaps and splits the triangles near each part, in parallel; pieces come
    /// triangle after triangle in increasing order, as snapping all triangles gives them.
    fn snap(&self, parts: &[UpdateBox]) -> Vec<Snapped> {
        let (scene, index, settings) = (&self.scene, &self.index, &self.settings);
        parts
            .par_iter()
            .map(|part| {
                let region = SnapRegion {
                    origin: Vec3::ZERO,
                    voxel_size: settings.level_voxel(part.level),
                    lo: part.lo,
                    hi: part.hi,
                };
                // A voxel of margin (snapping drops whatever keeps 2/64 voxel away), widened
                // for the rounding of the bounds to f32.
                let v = region.voxel_size as f64;
                let (lo, hi) = (part.lo.as_dvec3() * v, part.hi.as_dvec3() * v);
                let margin = DVec3::splat(v) + lo.abs().max(hi.abs()) * 1e-6;
                let mut ids = Vec::new();
                index.query((lo - margin).as_vec3(), (hi + margin).as_vec3(), &mut ids);
                let mut pieces = Vec::new();
                for &t in &ids {
                    snap_triangle(&region, scene[t as usize].positions, t, &mut pieces);
                }
                let items = work_items(&pieces, region.size());
                Snapped {
                    pieces,
                    items,
                    candidates: ids.len(),
                    first: (0, 0),
                }
            })
            .collect()
    }

    /// Packs every part's pieces, work items and [`BoxParams`] into one block each, counting
    /// them in `stats`.
    fn pack(
        &self,
        parts: &[UpdateBox],
        snapped: &mut [Snapped],
        stats: &mut UpdateStats,
    ) -> Packed {
        let (mut n_pieces, mut n_items) = (0u64, 0u64);
        for s in snapped.iter_mut() {
            s.first = (n_pieces, n_items);
            n_pieces += (s.pieces.len().max(1) as u64).next_multiple_of(PIECE_ALIGN);
            n_items += (s.items.len().max(1) as u64).next_multiple_of(ITEM_ALIGN);
        }
        let mut packed = Packed {
            pieces: vec![GpuPiece::zeroed(); n_pieces as usize],
            items: vec![[0u32; 2]; n_items as usize],
            params: vec![0u8; parts.len() * SLOT as usize],
        };
        for (i, (part, s)) in parts.iter().zip(snapped.iter()).enumerate() {
            let (p0, i0) = (s.first.0 as usize, s.first.1 as usize);
            for (k, p) in s.pieces.iter().enumerate() {
                packed.pieces[p0 + k] = p.to_gpu();
            }
            packed.items[i0..i0 + s.items.len()].copy_from_slice(&s.items);
            let params = BoxParams {
                lo: part.lo.to_array(),
                items: s.items.len() as u32,
                hi: part.hi.to_array(),
                level_first: (part.level as u64 * (self.settings.resolution as u64).pow(3)) as u32,
                resolution: self.settings.resolution,
                _pad: [0; 3],
            };
            let at = i * SLOT as usize;
            packed.params[at..at + std::mem::size_of::<BoxParams>()]
                .copy_from_slice(bytemuck::bytes_of(&params));
            stats.parts += 1;
            stats.triangles_snapped += s.candidates as u64;
            stats.pieces += s.pieces.len() as u64;
            stats.work_items += s.items.len() as u64;
        }
        packed
    }

    /// Writes the packed data into regions of the scratch buffers.
    fn upload(
        &mut self,
        ctx: &GpuContext,
        timer: &PassTimer,
        packed: &Packed,
        stats: &mut UpdateStats,
    ) -> Uploaded {
        let blocks: [&[u8]; 3] = [
            bytemuck::cast_slice(&packed.pieces),
            bytemuck::cast_slice(&packed.items),
            &packed.params,
        ];
        let [pieces, items, params] = [0, 1, 2].map(|which| {
            let bytes = blocks[which];
            let (buffer, at) =
                self.scratch
                    .region(ctx, self.owner, timer, which, bytes.len() as u64);
            ctx.queue.write_buffer(&buffer, at, bytes);
            stats.upload_bytes += bytes.len() as u64;
            (buffer, at)
        });
        Uploaded {
            pieces,
            items,
            params,
        }
    }

    /// Records the pass `clipmap L<l> voxelize` of part `i`: each of its work items adds the
    /// albedo, normal and emission of the voxels its piece touches to the sums.
    fn accumulate_part(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (i, part): (u64, &UpdateBox),
        snapped: &Snapped,
        uploaded: &Uploaded,
    ) {
        let (p0, i0) = snapped.first;
        let (pieces, pieces_at) = &uploaded.pieces;
        let (items, items_at) = &uploaded.items;
        // A block of at least one element, as the packing leaves room for.
        let block = |n: usize, bytes: u64| n.max(1) as u64 * bytes;
        let items = range(
            items,
            items_at + i0 * ITEM_BYTES,
            block(snapped.items.len(), ITEM_BYTES),
        );
        let pieces = range(
            pieces,
            pieces_at + p0 * PIECE_BYTES,
            block(snapped.pieces.len(), PIECE_BYTES),
        );
        let entries = [
            (0, uploaded.part_params(i)),
            (1, self.triangles.as_entire_binding()),
            (2, items),
            (3, self.accum.as_entire_binding()),
            (8, pieces),
        ];
        let group = bind(ctx, &self.accumulate, &entries);
        let name = format!("clipmap L{} voxelize", part.level);
        let work = snapped.items.len() as u32;
        dispatch_1d(timer, &name, &self.accumulate, &group, work);
    }

    /// Records the pass `clipmap L<l> resolve` of part `i`: each voxel's sums become its
    /// albedo and opacity, normal and emission in its toroidal slot, and the sums are zeroed.
    fn resolve_part(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (i, part): (u64, &UpdateBox),
        uploaded: &Uploaded,
    ) {
        let entries = [
            (0, uploaded.part_params(i)),
            (3, self.accum.as_entire_binding()),
            (4, self.voxels.as_entire_binding()),
            (5, self.written.as_entire_binding()),
            (6, self.normals.as_entire_binding()),
            (7, self.emission.as_entire_binding()),
        ];
        let group = bind(ctx, &self.resolve, &entries);
        let name = format!("clipmap L{} resolve", part.level);
        dispatch_1d(timer, &name, &self.resolve, &group, part.volume() as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn box_params_mirror_the_wgsl_block() {
        assert_mirrors_wgsl!(
            BoxParams,
            "voxel/clipmap/update",
            "BoxParams",
            [lo, items, hi, level_first, resolution, _pad]
        );
    }
}
