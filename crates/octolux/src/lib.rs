//! # octolux
//!
//! Real-time, fully dynamic diffuse global illumination on the GPU (wgpu + WGSL), with a CPU
//! reference path tracer and image-error metrics so that every technique can be compared against
//! ground truth on the same scene.
//!
//! The frame flows one way: scene update -> shadow maps -> G-buffer -> GI technique (indirect
//! irradiance per pixel) -> compose (direct + albedo x indirect) -> tone map. See
//! [`render::Renderer`] for the GPU side, [`embed::GiEngine`] for the GI inside another wgpu
//! renderer (its device, G-buffer and command encoder; the `Renderer` runs on it too),
//! [`reference`](mod@reference) for the path tracer and [`metrics`] for image comparisons.

pub mod embed;
pub mod error;
pub mod frame;
pub mod gi;
pub mod gpu;
pub mod image_io;
pub mod limits;
pub mod metrics;
pub mod reference;
pub mod render;
pub mod scene;
pub mod transport;
pub mod voxel;

pub use error::{Error, Result};
