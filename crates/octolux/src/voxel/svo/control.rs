//! The blocks the octree's kernels share with the Rust that drives them: the control block
//! (node and brick counters, level ranges; `control` in `svo/build.wgsl`), the indirect
//! dispatch argument slots, and the per-level parameter slots ([`LevelParams`]).

use crate::gpu::GpuContext;
use crate::voxel::svo::OWNER;

/// Bytes between parameter slots bound at offsets (a multiple of any adapter's
/// `min_storage_buffer_offset_alignment`).
pub(crate) const PARAM_STRIDE: u64 = 256;
/// Words of the control block.
pub(crate) const CONTROL_WORDS: u64 = 128;
/// Word of `control` counting bricks (`BRICK_COUNTER` in `svo/build.wgsl`).
pub(crate) const BRICK_COUNTER: usize = 60;
/// Indirect dispatch slots (3 words each): static levels, dynamic levels, dynamic lists and
/// the dynamic update's own sizes (`svo/dynamic.wgsl`); each slot again from `NODE_ARGS` on,
/// sized for one workgroup per entry.
pub(crate) const ARGS_SLOTS: u64 = 2 * NODE_ARGS as u64;
/// Slot `s + NODE_ARGS` holds slot `s`'s count as one workgroup per entry (`NODE_ARGS` in
/// `svo/build.wgsl`).
pub(crate) const NODE_ARGS: u32 = 96;
/// First indirect slot of the dynamic node ranges (`ARGS_DYN_NODES` in `svo/dynamic.wgsl`).
pub(crate) const ARGS_DYN_NODES: u32 = 16;

/// Parameters of one level of the octree kernels (`LevelParams` in `svo/common.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LevelParams {
    pub d: u32,
    pub depth: u32,
    pub fragments: u32,
    pub capacity: u32,
    pub pool_bricks: u32,
    /// 0: the level's static nodes; 1: its dynamic nodes (or, for the dynamic update's
    /// gather kernels, the previous update's dirty list).
    pub range: u32,
    pub pad: [u32; 2],
}

/// Read-only storage buffer of one [`LevelParams`] per slot ([`PARAM_STRIDE`] bytes apart):
/// slot `d` walks level `d`'s static nodes, slot `depth + d` its dynamic ones.
pub(crate) fn level_params(
    ctx: &GpuContext,
    label: &str,
    depth: u32,
    fragments: u32,
    capacity: u32,
    pool_bricks: u32,
) -> wgpu::Buffer {
    let mut params = vec![0u8; PARAM_STRIDE as usize * 2 * depth as usize];
    for slot in 0..2 * depth {
        let p = LevelParams {
            d: slot % depth,
            depth,
            fragments,
            capacity,
            pool_bricks,
            range: slot / depth,
            pad: [0; 2],
        };
        let at = slot as usize * PARAM_STRIDE as usize;
        params[at..at + 32].copy_from_slice(bytemuck::bytes_of(&p));
    }
    ctx.create_buffer_init(OWNER, label, &params, wgpu::BufferUsages::STORAGE)
}
