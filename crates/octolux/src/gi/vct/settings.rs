//! Settings shared by both cone-tracing techniques (`[settings.vct]`).

use crate::{Error, Result};

/// Default sparse factor (see [`VctSettings::sparse`] and docs/vct.md for the measurements).
const SPARSE_DEFAULT: u32 = 4;

/// How `vct-clipmap` finds the visibility of the lights when it injects direct light.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ClipmapInjection {
    /// The renderer's shadow maps, one lookup per voxel and light (as `vct-svo` does).
    ShadowMaps,
    /// Shadow rays marched through the clipmap's own opacity (`inject_steps` samples).
    VoxelRays,
}

impl std::str::FromStr for ClipmapInjection {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "shadow-maps" => Ok(ClipmapInjection::ShadowMaps),
            "voxel-rays" => Ok(ClipmapInjection::VoxelRays),
            other => Err(Error::InvalidArgument(format!(
                "vct injection '{other}': expected shadow-maps or voxel-rays"
            ))),
        }
    }
}

/// Settings of voxel cone tracing. Scene files: `[settings.vct]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VctSettings {
    /// Voxels per side of every clipmap level, a power of two from 8 to 256 (default 64).
    pub resolution: u32,
    /// Clipmap levels, 1..=8 (default 4); the finest voxel is chosen so that the coarsest
    /// level, centred on the camera, reaches the scene's farthest point from where the camera
    /// is at the first frame (with 10 % to spare).
    pub levels: u32,
    /// Diffuse cones per gather: 6 (default, `003`'s set) or a cosine-distributed set of
    /// 8..=64 (lower `aperture` with it: the cones of a denser set are closer together).
    pub cones: u32,
    /// Full aperture of the six diffuse cones in degrees (default 60: the ring's cones, 60
    /// degrees apart, touch).
    pub aperture: f32,
    /// Step along a cone as a fraction of its footprint (default 0.5).
    pub step: f32,
    /// Apex offset along the normal and first sample, in voxels of the finest level holding
    /// the surface (default 1.5): off the surface's own voxels.
    pub start: f32,
    /// Accumulated opacity at which a cone stops (default 0.95).
    pub stop_opacity: f32,
    /// `vct-clipmap`: visibility of the lights for the injection, `shadow-maps` (default) or
    /// `voxel-rays`.
    pub injection: ClipmapInjection,
    /// Samples per shadow ray of the `voxel-rays` injection (default 256).
    pub inject_steps: u32,
    /// Sparse tracing: one traced pixel per `sparse` x `sparse` block, the others
    /// reconstructed from the traced ones by depth and normal (1 = every pixel; 1..=8).
    pub sparse: u32,
    /// `vct-svo`: voxels per side of the octree's grid, a power of two from 16 to 512
    /// (default 128), fitted around everything the scene's geometry covers over its animation.
    pub octree_resolution: u32,
    /// `vct-svo`: nodes (and bricks) reserved for the octree's dynamic part, the voxels of the
    /// animated objects rebuilt every frame (default 65536; unused in a static scene).
    pub dynamic_reserve: u32,
    /// Multiple bounces: every frame the voxels (the octree's static voxels, every clipmap
    /// voxel) gather indirect irradiance with the diffuse cones and add it to their direct
    /// irradiance at the next injection, so the light converges to all bounces over frames
    /// (default true; false computes one bounce).
    pub multi_bounce: bool,
    /// Trace one specular cone per pixel along the mirror direction into an extra image
    /// (default false; the diffuse irradiance stays the technique's output).
    pub specular: bool,
    /// Roughness of the specular cone, 0..=1 (default 0.3): aperture = roughness x 90 degrees,
    /// at least 2 degrees.
    pub roughness: f32,
    /// Fixed work for timing the structures against each other (`003` §5.3.5): when not 0
    /// (with `specular`), the specular cone takes exactly this many samples, from the structure's finest voxel
    /// on, and never stops early (default 0: it stops as the diffuse cones do). Its image is
    /// then meaningless; only its pass time is.
    pub specular_steps: u32,
}

impl Default for VctSettings {
    fn default() -> Self {
        VctSettings {
            resolution: 64,
            levels: 4,
            cones: 6,
            aperture: 60.0,
            step: 0.5,
            start: 1.5,
            stop_opacity: 0.95,
            injection: ClipmapInjection::ShadowMaps,
            inject_steps: 256,
            sparse: SPARSE_DEFAULT,
            octree_resolution: 128,
            dynamic_reserve: 1 << 16,
            multi_bounce: true,
            specular: false,
            roughness: 0.3,
            specular_steps: 0,
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

impl VctSettings {
    /// Checks every value's range.
    pub fn validate(&self) -> Result<()> {
        check(
            self.resolution.is_power_of_two() && (8..=256).contains(&self.resolution),
            "vct resolution",
            "a power of two from 8 to 256",
        )?;
        check((1..=8).contains(&self.levels), "vct levels", "1..=8")?;
        check(
            super::gather::check_cone_count(self.cones),
            "vct cones",
            "6 (003's set) or 8..=64",
        )?;
        check(
            self.aperture.is_finite() && self.aperture > 0.0 && self.aperture < 180.0,
            "vct aperture",
            "in (0, 180) degrees",
        )?;
        check(
            self.step.is_finite() && self.step >= 0.05 && self.step <= 4.0,
            "vct step",
            "0.05..=4",
        )?;
        check(
            self.start.is_finite() && (0.0..=16.0).contains(&self.start),
            "vct start",
            "0..=16 voxels",
        )?;
        check(
            self.stop_opacity.is_finite() && self.stop_opacity > 0.0 && self.stop_opacity <= 1.0,
            "vct stop_opacity",
            "in (0, 1]",
        )?;
        check(
            (1..=4096).contains(&self.inject_steps),
            "vct inject_steps",
            "1..=4096",
        )?;
        check((1..=8).contains(&self.sparse), "vct sparse", "1..=8")?;
        check(
            self.octree_resolution.is_power_of_two()
                && (16..=512).contains(&self.octree_resolution),
            "vct octree_resolution",
            "a power of two from 16 to 512",
        )?;
        check(
            (1..=1 << 24).contains(&self.dynamic_reserve),
            "vct dynamic_reserve",
            "1..=16777216 nodes",
        )?;
        check(
            self.roughness.is_finite() && (0.0..=1.0).contains(&self.roughness),
            "vct roughness",
            "0..=1",
        )?;
        check(
            self.specular_steps <= 4096,
            "vct specular_steps",
            "0..=4096",
        )?;
        check(
            self.specular_steps == 0 || self.specular,
            "vct specular_steps",
            "0 unless the specular cone is on (specular = true, --vct-specular)",
        )
    }

    /// Full aperture of the specular cone in radians.
    pub fn specular_aperture(&self) -> f32 {
        (self.roughness * 90.0).max(2.0).to_radians()
    }
}
