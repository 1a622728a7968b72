//! Probe + surfel GI (`004` ch. 2.6 and 3, after Dellson's grid system): probes on a uniform
//! grid over the scene bounds (`probes-grid`); around each probe, surfels placed by rays along
//! a lattice of directions; every frame the surfels are lit with the renderer's direct light
//! and shadow maps, each probe integrates its surfels' outgoing radiance into an irradiance
//! encoding, and every pixel interpolates the 8 probes around it.
//!
//! - [`lattice`]: latitude-longitude and Fibonacci directions (CPU and WGSL).
//! - [`bvh`]: the rays. No ray-tracing hardware is assumed: the scene's triangles sit in a
//!   binary BVH built on the CPU and traversed in WGSL, a static part built once and a small
//!   part for the animated objects rebuilt every frame.
//! - [`encoding`]: the probes' irradiance: `004`'s 8 octahedron-facet bins or SH L1.
//! - [`grid`]: the `probes-grid` technique (placement, surfel light, probe integration,
//!   gather).
//! - [`octree`]: `004`'s adaptive octree (encoding, allocation, state machine) on the CPU, the
//!   specification of the coming `probes-octree`.

pub mod bvh;
pub mod encoding;
#[cfg(test)]
mod gpu_tests;
mod grid;
pub mod lattice;
pub mod octree;

pub use encoding::Encoding;
pub use grid::{grid_irradiance, integrate_probe, ProbeGrid, ProbesGrid};
pub use lattice::Lattice;

use crate::{Error, Result};

/// Settings of the probe techniques. Scene files: `[settings.probes]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProbeSettings {
    /// Probes along x, y and z of the uniform grid, each 2..=128 (default 21 x 21 x 21, the
    /// 9261 probes of `004`).
    pub grid: [u32; 3],
    /// Surfels (rays) per probe (default 64). The latitude-longitude lattice has 8 parallels,
    /// so it needs a multiple of 8 (64 = 8 x 8, 128 = 8 x 16); 8..=1024.
    pub surfels: u32,
    /// Direction lattice: `"fibonacci"` (default) or `"lat-long"`.
    pub lattice: Lattice,
    /// Probe encoding: `"sh1"` (default, spherical harmonics L1 of radiance, irradiance by
    /// the cosine convolution) or `"octahedron"` (`004`'s 8 facet bins).
    pub encoding: Encoding,
    /// Surfels also receive the probes' own indirect light of the previous frame, so light
    /// bounces once more every frame (default false: one bounce).
    pub multi_bounce: bool,
    /// Offset of the gather point along the surface normal, in probe spacings (default 0.2):
    /// keeps a wall's own probes from seeing the wall edge-on.
    pub normal_bias: f32,
    /// Share of a probe's rays that may hit back faces before it counts as inside geometry
    /// and is left out of the gather (default 0.25).
    pub backface_limit: f32,
}

impl Default for ProbeSettings {
    fn default() -> Self {
        ProbeSettings {
            grid: [21; 3],
            surfels: 64,
            lattice: Lattice::Fibonacci,
            encoding: Encoding::ShL1,
            multi_bounce: false,
            normal_bias: 0.2,
            backface_limit: 0.25,
        }
    }
}

fn check(ok: bool, what: &str, range: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!("{what} must be {range}")))
    }
}

impl ProbeSettings {
    /// Checks every value's range.
    pub fn validate(&self) -> Result<()> {
        check(
            self.grid.iter().all(|n| (2..=128).contains(n)),
            "probes grid",
            "2..=128 probes per axis",
        )?;
        check(
            (8..=1024).contains(&self.surfels),
            "probes surfels",
            "8..=1024 per probe",
        )?;
        check(
            self.lattice != Lattice::LatLong || self.surfels.is_multiple_of(lattice::PARALLELS),
            "probes surfels on the lat-long lattice",
            "a multiple of 8 (8 parallels: 64 = 8 x 8, 128 = 8 x 16)",
        )?;
        check(
            self.normal_bias.is_finite() && (0.0..=1.0).contains(&self.normal_bias),
            "probes normal_bias",
            "0..=1 probe spacings",
        )?;
        check(
            self.backface_limit.is_finite() && (0.0..=1.0).contains(&self.backface_limit),
            "probes backface_limit",
            "0..=1",
        )?;
        let count = self.grid.iter().map(|&n| n as u64).product::<u64>() * self.surfels as u64;
        check(
            count <= 1 << 24,
            "probes grid x surfels",
            "at most 16M surfels",
        )
    }

    /// Most back-face hits of a probe that is still gathered: decided in integers on the CPU
    /// once, so that the GPU and its CPU twin agree on every adapter.
    pub fn max_back_faces(&self) -> u32 {
        (self.backface_limit as f64 * self.surfels as f64).floor() as u32
    }

    /// Probes in the grid.
    pub fn probe_count(&self) -> u32 {
        self.grid.iter().product()
    }
}
