//! Level filtering (`filter.wgsl`) on a filtered clipmap, after each revoxelisation: each
//! coarser level's voxels that lie wholly inside the finer level are rebuilt from the 2x2x2
//! finer voxels (opacity = covered fraction, premultiplied colour averaged), finest level
//! first; with anisotropic voxels the revoxelised coarse boxes first get their isotropic value
//! copied into the 6 directional ones (`replicate`), since a voxel voxelized on its own has no
//! direction.

use super::boxes::covered_box;
use super::{Clipmap, UpdateBox};
use crate::gpu::pass::{bind_buffers, dispatch_1d};
use crate::gpu::{GpuContext, PassTimer};

/// Parameter block `FilterParams` of `filter.wgsl`: one box of one level.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct FilterParams {
    /// First voxel of the box (world-voxel coordinates of `level`).
    pub lo: [i32; 3],
    /// The level the box belongs to (1 and up: filtered from `level - 1`).
    pub level: u32,
    /// One past the last voxel.
    pub hi: [i32; 3],
    /// Voxels per axis of a level.
    pub resolution: u32,
    /// 1 where the clipmap keeps directional values.
    pub anisotropic: u32,
    pub _pad: [u32; 3],
}

impl Clipmap {
    /// Directional values of the revoxelised coarse boxes (a copy of the isotropic value),
    /// then each coarser level's voxels inside the finer level from the finer voxels.
    pub(super) fn filter_levels(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        boxes: &[UpdateBox],
    ) {
        let res = self.settings.resolution as i32;
        if self.aniso.is_some() {
            for b in boxes.iter().filter(|b| b.level > 0) {
                let name = format!("clipmap L{} replicate", b.level);
                self.filter_pass(ctx, timer, &self.replicate, &name, b);
            }
        }
        for l in 1..self.settings.levels {
            let (Some(fine), Some(_)) = (self.origins[l as usize - 1], self.origins[l as usize])
            else {
                continue;
            };
            let name = format!("clipmap L{l} filter");
            self.filter_pass(ctx, timer, &self.filter, &name, &covered_box(l, fine, res));
        }
    }

    /// One dispatch of `pipeline` (`filter_level` or `replicate`) over the voxels of `b`.
    fn filter_pass(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        pipeline: &wgpu::ComputePipeline,
        name: &str,
        b: &UpdateBox,
    ) {
        if b.volume() == 0 {
            return;
        }
        let params = FilterParams {
            lo: b.lo.to_array(),
            level: b.level,
            hi: b.hi.to_array(),
            resolution: self.settings.resolution,
            anisotropic: self.aniso.is_some() as u32,
            _pad: [0; 3],
        };
        let params_buffer = ctx.create_buffer_init(
            self.owner,
            "filter params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let aniso = self.aniso.as_ref().unwrap_or(&self.placeholder);
        let mut buffers = vec![(0, &params_buffer), (1, &self.voxels), (3, aniso)];
        // `replicate` has no normals or emission binding.
        if std::ptr::eq(pipeline, &self.filter) {
            buffers.push((2, &self.normals));
            buffers.push((4, &self.emission));
        }
        let group = bind_buffers(ctx, pipeline, &buffers);
        dispatch_1d(timer, name, pipeline, &group, b.volume() as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn filter_params_mirror_the_wgsl_block() {
        assert_mirrors_wgsl!(
            FilterParams,
            "voxel/clipmap/filter",
            "FilterParams",
            [lo, level, hi, resolution, anisotropic, _pad]
        );
    }
}
