//! Voxel cone tracing (`003`): the cone marcher shared by the octree and clipmap back-ends.
//!
//! [`cone`] holds the marcher in WGSL ([`CONE_WGSL`]) and its CPU twin ([`march_cone`]),
//! written against one sampling function, `vct_sample(p, footprint) -> vec4<f32>` (premultiplied
//! radiance and opacity filtered over `footprint` metres), which the includer provides from
//! the structure it traces: the octree's or the clipmap's radiance sampler. [`gather`] holds
//! the diffuse gather's cone set and weights.

mod clipmap_gi;
pub mod cone;
pub mod gather;

pub use clipmap_gi::{VctClipmap, VctSettings};

pub use cone::{march_cone, ConeMarch, ConeParams, CONE_WGSL};
pub use gather::{diffuse_cone_dir, gather_irradiance, GATHER_WGSL};
