//! The parameter block every probe pass reads (`ProbeParams` of `probes.wgsl`), and the
//! storage buffers the probe techniques allocate (checked against the adapter's binding limit).

use crate::gpu::GpuContext;
use crate::Result;

/// `ProbeParams` in probes.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ProbeParams {
    pub(crate) lo: [f32; 4],
    pub(crate) spacing: [f32; 4],
    pub(crate) dims: [u32; 4],
    pub(crate) misc: [u32; 4],
    pub(crate) roots: [u32; 4],
    pub(crate) limits: [u32; 4],
    pub(crate) vis: [f32; 4],
    pub(crate) frame: [u32; 4],
    pub(crate) sets: [u32; 4],
    /// Rows of set 0's lattice rotation, then set 1's.
    pub(crate) rot: [[f32; 4]; 6],
}

/// The six rows of `rot` for two sets' rotations.
pub(crate) fn rotation_rows(sets: [glam::Mat3; 2]) -> [[f32; 4]; 6] {
    std::array::from_fn(|i| sets[i / 3].row(i % 3).extend(0.0).to_array())
}

/// A storage buffer of `bytes` for the probes, with a clear error when it exceeds the adapter's
/// storage-binding limit.
pub(crate) fn storage(
    ctx: &GpuContext,
    owner: &str,
    label: &str,
    bytes: u64,
) -> Result<wgpu::Buffer> {
    crate::gpu::alloc::checked_storage(ctx, owner, label, bytes, "use fewer probes or surfels")
}
