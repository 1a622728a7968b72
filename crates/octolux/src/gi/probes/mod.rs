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
//! - [`rays`]: the choice between that BVH and the scene's sparse voxel octree, walked as
//!   the VPL technique walks it (no CPU build, exact to a voxel).
//! - [`encoding`]: the probes' irradiance: `004`'s 8 octahedron-facet bins or SH L1.
//! - [`moments`]: depth moments per probe and DDGI's Chebyshev visibility in the gather,
//!   against leaks through thin walls.
//! - `engine`: what both techniques share (placement, surfel light, probe integration,
//!   gather) over a probe set.
//! - `grid_gi`: the `probes-grid` technique, probes on a uniform grid.
//! - [`octree`]: `004`'s adaptive octree (encoding, allocation, state machine) on the CPU, the
//!   specification of the GPU's.
//! - [`debug`]: the probe debug view (`--view probes`), drawn on the CPU from read-back state.
//! - [`octree_gi`]: the `probes-octree` technique: that octree on the GPU, driven by the
//!   probes' surfel hit fractions, rebuilt around moving objects, gathered through the tree.

pub mod bvh;
pub mod debug;
pub mod encoding;
mod engine;
mod grid_gi;
mod history;
pub mod lattice;
pub mod moments;
pub mod octree;
pub mod octree_gi;
mod params;
pub mod rays;

pub use encoding::Encoding;
pub use engine::{GpuSurfel, PROBE_VEC4, SURFEL_VEC4};
pub use grid_gi::{
    grid_irradiance, integrate_probe, integrate_probe_history, ProbeGrid, ProbeHistory, ProbesGrid,
    SurfelSet, FORGETTING,
};
pub use lattice::Lattice;
pub use moments::Visibility;
pub use octree_gi::{ProbeOctreeView, ProbesOctree};
pub use rays::RayBackend;

use crate::gi::bounds::{require as check, Bounds};
use crate::{Error, Result};

/// How `probes-octree` reads its probes at a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OctreeGather {
    /// Through the octree: the probes of the leaves around the point (default).
    Octree,
    /// `004`'s loop over every probe, attenuated by distance and the probe's volume.
    All,
}

impl std::str::FromStr for OctreeGather {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "octree" => Ok(OctreeGather::Octree),
            "all" => Ok(OctreeGather::All),
            other => Err(Error::InvalidArgument(format!(
                "probes gather '{other}': expected octree or all"
            ))),
        }
    }
}

/// Which of an octree probe's surfels are lit and integrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SurfelRange {
    /// Only hits inside the probe's leaf cube, as `004` places them; the rest are misses.
    Cube,
    /// Every closest hit (default); only the hits inside the cube count for the hit fraction.
    Scene,
}

impl std::str::FromStr for SurfelRange {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "cube" => Ok(SurfelRange::Cube),
            "scene" => Ok(SurfelRange::Scene),
            other => Err(Error::InvalidArgument(format!(
                "probes surfel_range '{other}': expected cube or scene"
            ))),
        }
    }
}

/// Settings of the probe techniques. Scene files: `[settings.probes]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProbeSettings {
    /// Probes along x, y and z of the uniform grid, each 2..=128 (default 21 x 21 x 21, the
    /// 9261 probes of `004`).
    pub grid: [u32; 3],
    /// Surfels (rays) per probe, 8..=1024; unset: each technique's default, 64 for
    /// `probes-grid` (`004`'s) and 128 for `probes-octree`, whose few probes need the finer
    /// sampling to meet its error target (docs/probes.md). The latitude-longitude lattice has
    /// 8 parallels, so it needs a multiple of 8 (64 = 8 x 8, 128 = 8 x 16).
    pub surfels: Option<u32>,
    /// Direction lattice: `"fibonacci"` (default) or `"lat-long"`.
    pub lattice: Lattice,
    /// Probe encoding: `"sh1"` (default, spherical harmonics L1 of radiance, irradiance by
    /// the cosine convolution) or `"octahedron"` (`004`'s 8 facet bins).
    pub encoding: Encoding,
    /// Surfels also receive the probes' own indirect light of the previous frame, so light
    /// bounces once more every frame; unset: on for both techniques (`probes-grid`: its
    /// history relights the bounces at once, settled a fifth of one bounce's error on the
    /// Cornell box; `probes-octree`: rooms lit only by twice-bounced light need it,
    /// docs/probes.md).
    pub multi_bounce: Option<bool>,
    /// Frames a probe's value is the mean of, each frame's rays along the lattice turned anew
    /// (0..=1024; 0: one fixed lattice, recomputed every frame, no history; default 32).
    /// Light that changes reaches the history at once and makes it forget in proportion
    /// (docs/probes.md, "Rays that turn every frame"); held still for this many frames, the
    /// probes stop tracing and keep their value. `probes-octree`'s new probes (and those
    /// whose cubes moving geometry crossed) start their histories afresh.
    pub history: u32,
    /// Offset of the gather point along the surface normal, in probe spacings (default 0.2):
    /// keeps a wall's own probes from seeing the wall edge-on.
    pub normal_bias: f32,
    /// Share of a probe's rays that may hit back faces before it counts as inside geometry
    /// and is left out of the gather (default 0.25).
    pub backface_limit: f32,
    /// `probes-octree`: deepest level of the octree, 2..=5 (root 0; default 4: at most 4096
    /// leaves, 16 x 16 x 16 at the finest, 2.4 m on Crytek Sponza; docs/probes.md, "Probe
    /// spacing on large scenes": at 3 the Sponzas' probes are too far apart to beat GI off).
    /// Each level costs 8x the probe slots (the buffers hold the full tree).
    pub max_depth: u32,
    /// `probes-octree`: the tree is complete down to this level whatever the hit fractions:
    /// leaves above it always split, leaves at it or above keep their probes; only the levels
    /// below it follow the split/free rule. 0..=`max_depth`; 0 is `004`'s rule (default 3:
    /// 512 probes at least; with `004`'s rule open scenes collapse to one probe and a wall's
    /// middle loses its probes; at 2, the cells of a scene that holds the ground around a
    /// building are metres wide, and with multiple bounces their probes light its inside
    /// brighter than GI off is wrong, docs/probes.md).
    pub min_depth: u32,
    /// `probes-octree`: probe slots, the budget of the buffers (default 2048: 16 MiB of
    /// surfels with 128 each; the shipped scenes keep at most 890). 0: the full tree of
    /// `max_depth` (4608 slots at depth 4, 36864 at depth 5). A split that finds no free slot
    /// waits and the leaf keeps its probe; the tree stops refining, the image stays lit. At
    /// least the complete levels down to `min_depth` plus the probes their parents hold while
    /// they split (576 at `min_depth` 3).
    pub max_probes: u32,
    /// `probes-octree`: a leaf splits when at least this share of its probe's surfels land
    /// inside its cube (`004`: 1/2; default 1/4: at 1/2 a room whose height is less than
    /// the complete levels' cells, such as `living-room` in a scene that also holds the
    /// ground outside its window, keeps those coarse cells, and its pixels gather probes
    /// above its ceiling and beyond its walls: patches brighter and darker than GI off).
    pub split_fraction: f32,
    /// `probes-octree`: a probe is freed when less than this share of its surfels land inside
    /// its cube (`004`: 1/4; default 0: no probe is freed, since the buffers hold the full
    /// tree anyway and a freed leaf's pixels fall back on probes near geometry: on the
    /// Sponzas freeing doubles relMSE, docs/probes.md); below `split_fraction`.
    pub free_fraction: f32,
    /// `probes-octree`: how pixels read the probes, `"octree"` (default) or `"all"`.
    pub gather: OctreeGather,
    /// `probes-octree`: which surfels light a probe, `"scene"` (default: every hit) or
    /// `"cube"` (only hits inside its leaf's cube, as `004`).
    pub surfel_range: SurfelRange,
    /// Whether the gather weighs each probe by its visibility from the shaded point:
    /// `"moments"` (default: depth moments per probe and DDGI's Chebyshev test) or `"none"`.
    pub visibility: Visibility,
    /// What the surfel rays run through: `"bvh"` (default: the scene's triangles, exact) or
    /// `"voxels"` (the scene's sparse voxel octree, exact to a voxel; docs/probes.md
    /// compares the two).
    pub rays: RayBackend,
    /// With `rays = "voxels"`: voxels per side of the octree, a power of two in 16..=1024
    /// (default 128).
    pub voxel_resolution: u32,
}

impl Default for ProbeSettings {
    fn default() -> Self {
        ProbeSettings {
            grid: [21; 3],
            surfels: None,
            lattice: Lattice::Fibonacci,
            encoding: Encoding::ShL1,
            multi_bounce: None,
            history: 32,
            normal_bias: 0.2,
            backface_limit: 0.25,
            max_depth: 4,
            min_depth: 3,
            max_probes: 2048,
            split_fraction: 0.25,
            free_fraction: 0.0,
            gather: OctreeGather::Octree,
            surfel_range: SurfelRange::Scene,
            visibility: Visibility::Moments,
            rays: RayBackend::Bvh,
            voxel_resolution: 128,
        }
    }
}

/// Accepted probes per axis of the uniform grid.
pub const GRID: Bounds<u32> = Bounds::new("probes grid", 2, 128).counting("probes per axis");
/// Accepted history lengths (0: fixed rays, no history).
pub const HISTORY: Bounds<u32> = Bounds::new("probes history", 0, 1024).counting("frames");
/// Accepted depths of the probe octree.
pub const MAX_DEPTH: Bounds<u32> = Bounds::new("probes max_depth", 2, 5);
/// Accepted normal biases, in probe spacings.
pub const NORMAL_BIAS: Bounds<f32> =
    Bounds::new("probes normal_bias", 0.0, 1.0).counting("probe spacings");

/// Surfels per probe of `probes-grid` when `surfels` is unset (`004`'s 64).
pub const GRID_SURFELS: u32 = 64;
/// Surfels per probe of `probes-octree` when `surfels` is unset.
pub const OCTREE_SURFELS: u32 = 128;

impl ProbeSettings {
    /// Surfels per probe: the set value, or the grid's default.
    pub fn surfel_count(&self) -> u32 {
        self.surfels.unwrap_or(GRID_SURFELS)
    }

    /// These settings with the technique's own defaults filled in (`octree`: for
    /// `probes-octree`), as the technique runs with them.
    pub fn resolved(&self, octree: bool) -> ProbeSettings {
        let default = if octree { OCTREE_SURFELS } else { GRID_SURFELS };
        ProbeSettings {
            surfels: Some(self.surfels.unwrap_or(default)),
            multi_bounce: Some(self.multi_bounce.unwrap_or(true)),
            ..self.clone()
        }
    }

    /// Checks every value's range ([`ProbeSettings::for_technique`] also checks the grid's
    /// surfel count).
    pub fn validate(&self) -> Result<()> {
        check(
            self.grid.iter().all(|&n| GRID.contains(n)),
            GRID.name,
            &GRID.text(),
        )?;
        check(
            (8..=1024).contains(&self.surfel_count()),
            "probes surfels",
            "8..=1024 per probe",
        )?;
        check(
            self.lattice != Lattice::LatLong
                || self.surfel_count().is_multiple_of(lattice::PARALLELS),
            "probes surfels on the lat-long lattice",
            "a multiple of 8 (8 parallels: 64 = 8 x 8, 128 = 8 x 16)",
        )?;
        self.check_history()?;
        NORMAL_BIAS.check(self.normal_bias)?;
        check(
            self.backface_limit.is_finite() && (0.0..=1.0).contains(&self.backface_limit),
            "probes backface_limit",
            "0..=1",
        )?;
        MAX_DEPTH.check(self.max_depth)?;
        check(
            self.min_depth <= self.max_depth,
            "probes min_depth",
            &format!(
                "0..=max_depth ({}; min_depth is {}, 3 unless set)",
                self.max_depth, self.min_depth
            ),
        )?;
        let least = self.least_probes();
        check(
            self.max_probes == 0 || self.max_probes >= least,
            "probes max_probes",
            &format!(
                "0 (the full tree) or at least {least}: the complete levels down to min_depth {} \
                 and the probes their parents hold while they split",
                self.min_depth
            ),
        )?;
        check(
            self.free_fraction.is_finite()
                && self.split_fraction.is_finite()
                && 0.0 <= self.free_fraction
                && self.free_fraction < self.split_fraction
                && self.split_fraction <= 1.0,
            "probes free_fraction and split_fraction",
            "0 <= free_fraction < split_fraction <= 1",
        )?;
        check(
            (16..=crate::voxel::MAX_RESOLUTION).contains(&self.voxel_resolution)
                && self.voxel_resolution.is_power_of_two(),
            "probes voxel_resolution",
            "a power of two in 16..=1024",
        )?;
        Ok(())
    }

    /// Checks the grid's surfel count (the octree's buffers are checked against the
    /// adapter's binding limit when made).
    fn check_grid_surfels(&self) -> Result<()> {
        let count = self.grid.iter().map(|&n| n as u64).product::<u64>()
            * self.surfel_count() as u64
            * self.surfel_sets() as u64;
        check(
            count <= 1 << 24,
            "probes grid x surfels (x 2 sets with a history)",
            "at most 16M surfels",
        )
    }

    /// Whether light bounces once more every frame (`multi_bounce` as resolved; unset counts
    /// as off).
    pub fn bounces_over_frames(&self) -> bool {
        self.multi_bounce == Some(true)
    }

    /// The settings `probes-grid` (`octree` false) or `probes-octree` runs with, checked, the
    /// technique's defaults filled in.
    pub fn for_technique(&self, octree: bool) -> Result<ProbeSettings> {
        let resolved = self.resolved(octree);
        resolved.validate()?;
        if !octree {
            resolved.check_grid_surfels()?;
        }
        Ok(resolved)
    }

    /// Checks `history`'s range.
    pub(crate) fn check_history(&self) -> Result<()> {
        HISTORY.check(self.history)
    }

    /// Surfel sets per probe: two when the probes keep a history (the set placed this frame
    /// and the one before), else one.
    pub fn surfel_sets(&self) -> u32 {
        if self.history > 0 {
            2
        } else {
            1
        }
    }

    /// Most back-face hits of a probe that is still gathered: decided in integers on the CPU
    /// once, so that the GPU and its CPU twin agree on every adapter.
    pub fn max_back_faces(&self) -> u32 {
        (self.backface_limit as f64 * self.surfel_count() as f64).floor() as u32
    }

    /// Probe slots the complete levels down to `min_depth` need: `8^min_depth` and, while the
    /// level above splits into them, its `8^(min_depth - 1)`.
    pub fn least_probes(&self) -> u32 {
        let leaves = 8u32.pow(self.min_depth.min(5));
        leaves + leaves / 8
    }

    /// Probe slots of `probes-octree`: `max_probes`, or the full tree's where that is 0 or
    /// more.
    pub fn octree_probe_slots(&self) -> u32 {
        let full = self.octree_rule().full_capacity().1;
        if self.max_probes == 0 {
            full
        } else {
            self.max_probes.min(full)
        }
    }

    /// The octree's split/free rule. Its surfel count is the octree's (unset: 128), since
    /// only `probes-octree` has the rule.
    pub fn octree_rule(&self) -> octree::OctreeRule {
        octree::OctreeRule {
            max_depth: self.max_depth,
            min_depth: self.min_depth,
            surfels: self.surfels.unwrap_or(OCTREE_SURFELS),
            f_lower: self.free_fraction,
            f_upper: self.split_fraction,
        }
    }

    /// Probes in the grid.
    pub fn probe_count(&self) -> u32 {
        self.grid.iter().product()
    }
}
