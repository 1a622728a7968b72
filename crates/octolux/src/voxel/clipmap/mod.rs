//! Voxel clipmap (Arnebäck 2017, chapter 4): `levels` dense volumes of equal resolution
//! `resolution`^3 around the camera, level `l` with voxels of `voxel_size * 2^l`, so each level
//! covers twice the extent of the one inside it.
//!
//! Addressing is toroidal: the voxel at integer world-voxel coordinates `g` of a level lives in
//! slot `g mod resolution`, so a level that follows the camera keeps every voxel it still
//! covers where it is; [`Clipmap::update`] revoxelises only the slabs that camera motion
//! exposes (at most three boxes per level), and a level is rebuilt whole only when it moves by
//! its full width. Each level is voxelized at its own resolution (per-level voxelization).
//!
//! Storage: one `array<u32>` of RGBA8 texels (averaged albedo, opacity 255 where any triangle
//! touches the voxel), level after level, and in the same layout the averaged normals and the
//! mean emission (RGB9E5, [`encode_emission`]): 12 bytes per voxel. [`Clipmap::inject`] adds
//! RGBA16F radiance (emission + reflected direct light, visibility by voxel shadow rays) and
//! the direction it leaves in (its facing, [`crate::voxel::facing`]), 12 bytes more.
//! The scene stays resident ([`Clipmap::set_scene`]: triangles uploaded once, their bounds
//! indexed on the CPU by [`crate::voxel::clipmap::index`]), so a per-frame [`Clipmap::follow`]
//! snaps and uploads only the triangles near the boxes it revoxelises, into scratch buffers
//! kept across updates. Moving objects: [`Clipmap::replace_triangles`] replaces an object's own
//! triangles and queues the boxes around their old and new bounds for the next update; or
//! revoxelise boxes explicitly ([`Clipmap::boxes_touching`], [`Clipmap::revoxelise`]). The
//! caller decides what moved.
//!
//! Options ([`ClipmapOptions`], [`Clipmap::with_options`]): `filtered` rebuilds the voxels of
//! every coarser level that lie wholly inside the next finer level from the 2x2x2 finer voxels
//! (opacity = covered fraction, premultiplied colour averaged) after each update, keeping
//! per-level voxelization only outside the finer level; `anisotropic` (implies `filtered`) adds
//! 6 directional values per voxel of levels 1 and up ([`Clipmap::aniso`]), composited front to
//! back from the finer level along each axis. Sampling with blending by distance to a level's
//! border and with directional values: [`crate::voxel::clipmap::sample`].
//!
//! The files: `settings.rs` (dimensions and options), `boxes.rs` (which boxes an update
//! revoxelises), `emission.rs` (the RGB9E5 emission format), `volume.rs` (the GPU object and
//! its levels following the camera), `scene.rs` (the resident scene and moving objects),
//! `revoxelise.rs` (the passes that voxelise boxes), `filter.rs` (coarser levels from finer
//! ones), `inject.rs` (light injection); each WGSL shader lies beside the Rust that drives it.

mod boxes;
pub mod cpu;
mod emission;
mod filter;
pub mod index;
mod inject;
mod revoxelise;
pub mod sample;
mod scene;
mod settings;
mod volume;

pub use boxes::{box_minus, covered_box, exposed_boxes, UpdateBox};
pub use emission::{
    decode_emission, decode_emission_fixed, emission_fixed, encode_emission, EMISSION_SCALE,
};
pub use inject::{injected_facing, injected_radiance, pack_facing, unpack_facing};
pub use revoxelise::{UpdateStats, SCRATCH_KEEP};
pub use settings::{ClipmapOptions, ClipmapSettings};
pub use volume::Clipmap;

/// Ledger owner of the clipmap's buffers.
pub const OWNER: &str = "clipmap";
