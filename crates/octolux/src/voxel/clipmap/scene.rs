//! The clipmap's resident scene: its triangles uploaded once and their bounds indexed on the
//! CPU ([`crate::voxel::clipmap::index`]), so that a revoxelisation snaps and uploads only
//! the triangles near its boxes. Moving objects replace their own triangles in place and queue
//! the boxes around their old and new bounds for the next revoxelisation.

use super::index::TriangleIndex;
use super::{Clipmap, UpdateBox};
use crate::gpu::GpuContext;
use crate::voxel::voxelize::upload_triangles;
use crate::voxel::VoxelTriangle;
use crate::{Error, Result};
use glam::Vec3;

/// Bytes of one triangle on the GPU ([`crate::voxel::GpuTriangle`]).
const TRIANGLE_BYTES: u64 = std::mem::size_of::<crate::voxel::GpuTriangle>() as u64;

impl Clipmap {
    /// Makes `tris` the clipmap's scene: uploads their surface data once into a GPU buffer
    /// that stays resident (ledger: `clipmap / triangles`, 32 bytes per triangle; positions
    /// reach the GPU only as snapped pieces) and indexes their bounds on the CPU ([`crate::voxel::clipmap::index`]), so that an update snaps and uploads only the
    /// triangles near the boxes it revoxelises. Voxels already built are left as they are
    /// until revoxelised; pending boxes of [`Clipmap::replace_triangles`] are dropped.
    pub fn set_scene(&mut self, ctx: &GpuContext, tris: &[VoxelTriangle]) {
        let clock = std::time::Instant::now();
        self.scene = tris.to_vec();
        self.index = TriangleIndex::new(tris);
        // A new buffer, so that passes recorded earlier keep reading the triangles they saw.
        self.triangles = upload_triangles(ctx, self.owner, tris);
        self.pending.clear();
        self.has_scene = true;
        self.acc.upload_bytes += tris.len() as u64 * TRIANGLE_BYTES;
        self.acc.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
    }

    /// The clipmap's scene ([`Clipmap::set_scene`]).
    pub fn scene(&self) -> &[VoxelTriangle] {
        &self.scene
    }

    /// Moving objects: replaces triangles `first..first + tris.len()` of the clipmap's scene
    /// (an object's own triangles, in the same order and number) with `tris`, uploading only
    /// those, and queues for revoxelisation the boxes of every level around their old and
    /// their new bounds ([`Clipmap::boxes_touching`]). The next [`Clipmap::follow`],
    /// [`Clipmap::update`] or [`Clipmap::revoxelise`] revoxelises them, so a frame with a
    /// moving camera and moving objects needs one revoxelisation. Returns the boxes queued.
    ///
    /// The triangles' attributes (albedo, normal, emission) are written to the resident buffer
    /// with [`wgpu::Queue::write_buffer`], which takes effect at the next submission: passes
    /// recorded but not yet submitted read the new attributes (their positions are in the
    /// snapped pieces and stay as they were).
    pub fn replace_triangles(
        &mut self,
        ctx: &GpuContext,
        first: usize,
        tris: &[VoxelTriangle],
    ) -> Result<Vec<UpdateBox>> {
        if first
            .checked_add(tris.len())
            .is_none_or(|end| end > self.scene.len())
        {
            return Err(Error::InvalidArgument(format!(
                "replacing triangles {first}..{} of a clipmap scene of {}",
                first.saturating_add(tris.len()),
                self.scene.len()
            )));
        }
        let union = |tris: &[VoxelTriangle]| {
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for t in tris {
                if t.positions.iter().all(|p| p.is_finite()) {
                    for p in t.positions {
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
            }
            (lo, hi)
        };
        let (old_lo, old_hi) = union(&self.scene[first..first + tris.len()]);
        let (new_lo, new_hi) = union(tris);
        self.replace_range(ctx, first, tris);
        let mut boxes = Vec::new();
        for (lo, hi) in [(old_lo, old_hi), (new_lo, new_hi)] {
            if lo.cmple(hi).all() {
                boxes.extend(self.boxes_touching(lo, hi));
            }
        }
        self.pending.extend_from_slice(&boxes);
        Ok(boxes)
    }

    /// Writes triangles `first..` of the scene on the CPU, in the index and on the GPU.
    fn replace_range(&mut self, ctx: &GpuContext, first: usize, tris: &[VoxelTriangle]) {
        if tris.is_empty() {
            return;
        }
        let clock = std::time::Instant::now();
        self.scene[first..first + tris.len()].copy_from_slice(tris);
        self.index.replace(first, tris);
        let gpu: Vec<crate::voxel::GpuTriangle> = tris.iter().map(VoxelTriangle::to_gpu).collect();
        ctx.queue.write_buffer(
            &self.triangles,
            first as u64 * TRIANGLE_BYTES,
            bytemuck::cast_slice(&gpu),
        );
        self.acc.upload_bytes += tris.len() as u64 * TRIANGLE_BYTES;
        self.acc.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
    }

    /// Makes `tris` the scene: nothing when it is the scene already, the differing range when
    /// that is at most a quarter of it, else [`Clipmap::set_scene`].
    pub(super) fn sync_scene(&mut self, ctx: &GpuContext, tris: &[VoxelTriangle]) {
        if self.has_scene && tris.len() == self.scene.len() {
            let clock = std::time::Instant::now();
            let same = |(a, b): (&VoxelTriangle, &VoxelTriangle)| same_triangle(a, b);
            let first = self.scene.iter().zip(tris).position(|p| !same(p));
            self.acc.snap_ms += clock.elapsed().as_secs_f64() * 1e3;
            let Some(first) = first else {
                return;
            };
            let last = tris.len()
                - 1
                - self
                    .scene
                    .iter()
                    .rev()
                    .zip(tris.iter().rev())
                    .position(|p| !same(p))
                    .unwrap_or(0);
            if last + 1 - first <= tris.len() / 4 {
                self.replace_range(ctx, first, &tris[first..=last]);
                return;
            }
        }
        self.set_scene(ctx, tris);
    }
}

/// Whether two triangles are the same bit for bit (so that a NaN equals itself).
fn same_triangle(a: &VoxelTriangle, b: &VoxelTriangle) -> bool {
    let bits = |t: &VoxelTriangle| {
        let mut w = [0u32; 16];
        for (i, p) in t.positions.iter().enumerate() {
            w[3 * i] = p.x.to_bits();
            w[3 * i + 1] = p.y.to_bits();
            w[3 * i + 2] = p.z.to_bits();
        }
        w[9] = t.albedo[0] as u32 | (t.albedo[1] as u32) << 8 | (t.albedo[2] as u32) << 16;
        w[10..13].copy_from_slice(&t.normal.to_array().map(f32::to_bits));
        w[13..16].copy_from_slice(&t.emission.to_array().map(f32::to_bits));
        w
    };
    bits(a) == bits(b)
}
