//! The parameter block every probe pass reads (`ProbeParams` of `probes.wgsl`), and the
//! storage buffers the probe techniques allocate (checked against the adapter's binding limit).

use crate::gpu::GpuContext;
use crate::Result;

/// `ProbeParams` in probes.wgsl (the same fields at the same offsets; tested).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ProbeParams {
    /// Lower corner of the scene's box (of the probe grid's lattice).
    pub(crate) lo: [f32; 3],
    /// Longest surfel ray (m): a miss's distance.
    pub(crate) max_distance: f32,
    /// Grid probe spacing per axis.
    pub(crate) spacing: [f32; 3],
    /// Gather offset along the normal (m).
    pub(crate) normal_offset: f32,
    /// Grid probes per axis.
    pub(crate) dims: [u32; 3],
    /// Surfels per probe and set (rays of one lattice).
    pub(crate) surfels_per_set: u32,
    /// Lattice kind ([`super::lattice::Lattice::gpu_kind`]).
    pub(crate) lattice: u32,
    /// Encoding kind ([`super::encoding::Encoding::gpu_kind`]).
    pub(crate) encoding: u32,
    /// Lights this frame.
    pub(crate) light_count: u32,
    /// 1: surfels get probe light (bounces over frames).
    pub(crate) multi_bounce: u32,
    /// Static BVH root (0xffffffff none).
    pub(crate) static_root: u32,
    /// Animated objects (BVH instances).
    pub(crate) instance_count: u32,
    /// Probe slots.
    pub(crate) probe_slots: u32,
    /// Surfels over all probes and sets.
    pub(crate) surfel_count: u32,
    /// Most back-face hits of a probe still gathered.
    pub(crate) max_back_faces: u32,
    /// Visibility (0 none, 1 moments).
    pub(crate) visibility: u32,
    /// Moved boxes.
    pub(crate) moved_boxes: u32,
    /// 1: placement keeps the surfels whose rays cross no moved box.
    pub(crate) keep_unmoved: u32,
    /// Variance floor of the depth moments (m^2).
    pub(crate) variance_floor: f32,
    /// Weight of the depth maps' history.
    pub(crate) moments_keep: f32,
    /// Scale of last frame's probe light in the surfels' (the lights' power now over then, at
    /// most 1).
    pub(crate) bounce_scale: f32,
    /// Forgetting strength.
    pub(crate) forgetting: f32,
    /// This frame's number (1, 2, ...), which placement stamps on the probes it re-traces.
    pub(crate) frame: u32,
    /// Surfel sets per probe (1: one fixed lattice, no history; 2: the lattice turned anew
    /// each frame into one set, the other set the previous frame's).
    pub(crate) set_count: u32,
    /// The set placed most recently.
    pub(crate) latest_set: u32,
    /// 1: set `latest_set` was placed this frame (a new sample).
    pub(crate) latest_placed: u32,
    /// Most frames a probe's history holds.
    pub(crate) max_history: u32,
    pub(crate) _pad: [u32; 3],
    /// Rows of set 0's lattice rotation, then set 1's.
    pub(crate) rot: [[f32; 4]; 6],
}

/// The six rows of `rot` for two sets' rotations.
pub(crate) fn rotation_rows(sets: [glam::Mat3; 2]) -> [[f32; 4]; 6] {
    std::array::from_fn(|i| sets[i / 3].row(i % 3).extend(0.0).to_array())
}

/// A storage buffer of `bytes` for the probes, with a clear error when it exceeds the adapter's
/// storage-binding limit.
pub(crate) fn probe_storage(
    ctx: &GpuContext,
    owner: &str,
    label: &str,
    bytes: u64,
) -> Result<wgpu::Buffer> {
    crate::gpu::alloc::checked_storage(ctx, owner, label, bytes, "use fewer probes or surfels")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    #[test]
    fn surfels_mirror_the_wgsl() {
        use crate::gi::probes::GpuSurfel;
        assert_mirrors_wgsl!(
            GpuSurfel,
            "gi/probes/probes",
            "Surfel",
            [position, state, normal, albedo, emission, distance]
        );
        assert_eq!(std::mem::size_of::<GpuSurfel>() % 16, 0);
    }

    #[test]
    fn probe_params_mirror_the_wgsl() {
        assert_mirrors_wgsl!(
            ProbeParams,
            "gi/probes/probes",
            "ProbeParams",
            [
                lo,
                max_distance,
                spacing,
                normal_offset,
                dims,
                surfels_per_set,
                lattice,
                encoding,
                light_count,
                multi_bounce,
                static_root,
                instance_count,
                probe_slots,
                surfel_count,
                max_back_faces,
                visibility,
                moved_boxes,
                keep_unmoved,
                variance_floor,
                moments_keep,
                bounce_scale,
                forgetting,
                frame,
                set_count,
                latest_set,
                latest_placed,
                max_history,
                _pad,
                rot,
            ]
        );
    }
}
