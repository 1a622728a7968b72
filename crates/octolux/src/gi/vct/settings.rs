//! Settings shared by both cone-tracing techniques (`[settings.vct]`).
//!
//! The diffuse cones (`cones`, `aperture`, `start`) are the exception: each technique has its
//! own defaults for the pixels' gather ([`VctStructure::default_cones`], by structure and
//! `multi_bounce`) and for the voxels' bounce gather ([`VctStructure::default_bounce_cones`]),
//! measured on the shipped scenes (docs/vct.md), and a value given in the settings overrides
//! them for both techniques and both gathers.

use crate::gi::bounds::{require as check, Bounds};
use crate::{Error, Result};

/// Default sparse factor: chosen from the image height ([`VctSettings::sparse_factor`]; see
/// docs/vct.md for the measurements).
const SPARSE_DEFAULT: u32 = 0;
/// Rows the traced image of automatic sparse tracing keeps at least.
const SPARSE_ROWS: u32 = 45;

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

/// Which structure a technique traces; the diffuse cones' defaults depend on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VctStructure {
    /// The sparse voxel octree (`vct-svo`).
    Octree,
    /// The clipmap (`vct-clipmap`).
    Clipmap,
}

/// The diffuse cones one technique gathers with, every value resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseCones {
    /// Cones per gather: 6 (`003`'s set) or a cosine-distributed set of 8..=64.
    pub cones: u32,
    /// Full aperture of each cone in degrees.
    pub aperture: f32,
    /// Apex offset along the normal and first sample, in voxels of the finest level holding
    /// the surface.
    pub start: f32,
}

impl VctStructure {
    /// The structure's own cones for the pixels' diffuse gather, used where the settings give
    /// none, for multiple bounces (`multi_bounce`) or one (measured on the shipped scenes,
    /// docs/vct.md):
    /// - the octree: 64 cones of 18 degrees started 2 voxels out (the Cornell box's error
    ///   falls with every doubling of the cone count from 16 to 64, for a pixel pass that is a
    ///   small part of the octree's frame);
    /// - the clipmap: 16 cones of 36 degrees started 2 voxels out, or at one bounce `003`'s
    ///   six cones of 60 degrees started 1.5 voxels out (16 cones double its relMSE on the
    ///   McGuire box against the one-bounce reference; with multiple bounces they lower it on
    ///   every shipped scene).
    pub fn default_cones(self, multi_bounce: bool) -> DiffuseCones {
        match (self, multi_bounce) {
            (VctStructure::Octree, _) => DiffuseCones {
                cones: 64,
                aperture: 18.0,
                start: 2.0,
            },
            (VctStructure::Clipmap, false) => DiffuseCones {
                cones: 6,
                aperture: 60.0,
                start: 1.5,
            },
            (VctStructure::Clipmap, true) => Self::BOUNCE_CONES,
        }
    }

    /// The structure's own cones for the voxels' bounce gather (`multi_bounce`), used where
    /// the settings give none: 16 cones started 2 voxels out for both, of 18 degrees on the
    /// octree and 36 on the clipmap. The bounce gathers at every voxel, so its cost grows with
    /// the cone count far faster than the pixels' (2.8x the octree's bounce pass from 16 to 32
    /// cones), and the light it feeds back is smooth. On the octree the 36-degree cones'
    /// coarse samples reach across a wall as thin as its voxels sooner, and the voxels behind
    /// it light each other with what leaks, frame after frame (docs/vct.md, "A thin wall lets
    /// light through"); 18-degree cones take about 1.8x the samples.
    pub fn default_bounce_cones(self) -> DiffuseCones {
        match self {
            VctStructure::Octree => DiffuseCones {
                aperture: 18.0,
                ..Self::BOUNCE_CONES
            },
            VctStructure::Clipmap => Self::BOUNCE_CONES,
        }
    }

    const BOUNCE_CONES: DiffuseCones = DiffuseCones {
        cones: 16,
        aperture: 36.0,
        start: 2.0,
    };
}

/// Settings of voxel cone tracing. Scene files: `[settings.vct]`.
///
/// The diffuse cones' fields (`cones`, `aperture`, `start`) are optional: `None` (the key left
/// out, no `--vct-*` flag) lets each technique use its own default
/// ([`VctStructure::default_cones`], which also depends on `multi_bounce`); a value given
/// applies to both techniques.
/// [`VctSettings::diffuse_cones`] resolves them.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VctSettings {
    /// Voxels per side of every clipmap level, a power of two from 8 to 256 (default 64).
    pub resolution: u32,
    /// Clipmap levels, 1..=8 (default 4); the finest voxel is chosen so that the coarsest
    /// level, centred on the camera, reaches the scene's farthest point from where the camera
    /// is at the first frame (with 10 % to spare).
    pub levels: u32,
    /// Diffuse cones per gather: 6 (`003`'s set) or a cosine-distributed set of 8..=64 (lower
    /// `aperture` with it: the cones of a denser set are closer together); a value applies to
    /// the pixels' gather and to the voxels' bounce gather. Default `None`: the technique's
    /// own ([`VctStructure::default_cones`]: `vct-svo` 64 per pixel, `vct-clipmap` 16, with
    /// `multi_bounce = false` 6; [`VctStructure::default_bounce_cones`]: 16 per voxel).
    pub cones: Option<u32>,
    /// Full aperture of the diffuse cones in degrees. Default `None`: the technique's own
    /// (`vct-svo` 18 per pixel; `vct-clipmap` 36, with `multi_bounce = false` 60, the six
    /// cones' ring, 60 degrees apart, touches; for the bounce gather 18 per voxel on the
    /// octree, 36 on the clipmap).
    pub aperture: Option<f32>,
    /// Step along a cone as a fraction of its footprint (default 0.5).
    pub step: f32,
    /// Apex offset of the diffuse cones along the normal and their first sample, in voxels of
    /// the finest level holding the surface: off the surface's own voxels. Default `None`: the
    /// technique's own (2; `vct-clipmap` with `multi_bounce = false`: 1.5).
    pub start: Option<f32>,
    /// Accumulated opacity at which a cone stops (default 0.95).
    pub stop_opacity: f32,
    /// `vct-clipmap`: visibility of the lights for the injection, `shadow-maps` (default) or
    /// `voxel-rays`.
    pub injection: ClipmapInjection,
    /// Samples per shadow ray of the `voxel-rays` injection (default 256).
    pub inject_steps: u32,
    /// Sparse tracing: one traced pixel per `sparse` x `sparse` block, the others
    /// reconstructed from the traced ones by depth and normal (1 = every pixel; 1..=16), or 0
    /// (default) for [`VctSettings::sparse_factor`]'s choice from the image height.
    pub sparse: u32,
    /// `vct-svo`: voxels per side of the octree's grid, a power of two from 16 to 512
    /// (default 128), fitted around everything the scene's geometry covers over its animation.
    pub octree_resolution: u32,
    /// `vct-svo`: nodes (and bricks) reserved for the octree's dynamic part, the voxels of the
    /// animated objects rebuilt every frame (default 65536; unused in a static scene).
    pub dynamic_reserve: u32,
    /// `vct-svo`: cones read the octree's radiance anisotropically: 6 values per node, one
    /// per travel direction, composited front to back from its children
    /// ([`crate::voxel::svo::aniso_radiance`]), instead of the isotropic lattice scaled by
    /// the sample's footprint; 48 bytes more per brick and one pass per frame. Default
    /// false: measured, it stops the leaks through walls as thin as a voxel but doubles the
    /// error in rooms lit by their bounce light (docs/vct.md, "Anisotropic radiance").
    pub anisotropic: bool,
    /// `vct-svo`: only the voxels' bounce gather reads the anisotropic radiance; the pixels'
    /// cones keep the isotropic lattice (default false; `anisotropic` implies it). Measured,
    /// it cuts the excess light small bright objects send their surroundings and the leak
    /// through thin walls without the error `anisotropic` adds in rooms lit by their bounce
    /// light, at the cost of a slower bounce gather (docs/vct.md, "Anisotropic radiance in
    /// the bounce only").
    pub anisotropic_bounce: bool,
    /// Both techniques: every radiance texel (octree) or voxel (clipmap) also keeps the
    /// direction its radiance leaves in (the radiance-weighted mean facing of its surfaces; a
    /// wall thinner than a voxel faces the light that lights it), and a cone sample keeps of
    /// the radiance only the share that leaves towards the cone's apex, so light on one face
    /// of a thin wall is not seen from the other face. Default true: without it the sunlit
    /// outside of a building (its roof, its outer walls, the ground around it) is read through
    /// the walls by the coarse cones, and `vct-svo` ends many times farther from the reference
    /// than GI off in a stone church and a living room lit through their windows
    /// (`stone-church`, `living-room`); with it, it beats GI off on every shipped scene. The
    /// clipmap, whose coarse levels hold the surfaces as a medium (`clip_thicken`), is brighter
    /// than the reference in most shipped scenes without it. It costs the octree 216 bytes per
    /// brick, a second radiance mip per frame and 22 storage buffers per shader stage in the
    /// light injection, the clipmap a word per voxel, and a little error in rooms lit by their
    /// own bounce light (docs/vct.md, "The radiance's facing").
    pub facing: bool,
    /// Multiple bounces: every frame the voxels (the octree's static voxels, every clipmap
    /// voxel) gather indirect irradiance with the diffuse cones and add it to their direct
    /// irradiance at the next injection, so the light converges to all bounces over frames
    /// (default true; false computes one bounce).
    pub multi_bounce: bool,
    /// Multiple bounces: the frames one round of the voxels' bounce gather is spread over,
    /// 1..=8 (default 2). After the technique's first 3 frames (every voxel gathers while the
    /// light starts from nothing), each frame the voxels of one of `bounce_frames` interleaved
    /// sets (by voxel coordinates, a checkerboard for 2) gather, the others keep what they
    /// gathered last; the converged light is the same, the gather's cost falls by this factor
    /// and the light takes up to this many frames per bounce to follow a change (docs/vct.md,
    /// "The bounce gather over frames"). The octree's dynamic voxels gather every frame.
    pub bounce_frames: u32,
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
            cones: None,
            aperture: None,
            step: 0.5,
            start: None,
            stop_opacity: 0.95,
            injection: ClipmapInjection::ShadowMaps,
            inject_steps: 256,
            sparse: SPARSE_DEFAULT,
            octree_resolution: 128,
            dynamic_reserve: 1 << 16,
            anisotropic: false,
            anisotropic_bounce: false,
            facing: true,
            multi_bounce: true,
            bounce_frames: 2,
            specular: false,
            roughness: 0.3,
            specular_steps: 0,
        }
    }
}

/// Accepted clipmap levels.
pub const LEVELS: Bounds<u32> = Bounds::new("vct levels", 1, 8);
/// Accepted frames over which the bounce gather is spread.
pub const BOUNCE_FRAMES: Bounds<u32> = Bounds::new("vct bounce_frames", 1, 8);
/// Accepted steps of the clipmap's injection march.
pub const INJECT_STEPS: Bounds<u32> = Bounds::new("vct inject_steps", 1, 4096);
/// Accepted sparse-tracing block sides (0: chosen from the image height).
pub const SPARSE: Bounds<u32> = Bounds::new("vct sparse", 0, 16);
/// Accepted cone step, in footprints.
pub const STEP: Bounds<f32> = Bounds::new("vct step", 0.05, 4.0);
/// Accepted cone start, in voxels.
pub const START: Bounds<f32> = Bounds::new("vct start", 0.0, 16.0).counting("voxels");

impl VctSettings {
    /// The sparse factor for images `height` pixels high: the setting, or where it is 0 the
    /// factor from 4 to 16 that keeps at least 45 traced rows (4 below 225 rows, 8 at 360, 16
    /// from 720). Cone-traced irradiance is smooth: on the Cornell box at 640x360 tracing one
    /// pixel per 8 x 8 block errs no more than per 4 x 4 for a quarter of the trace, and at
    /// 1920x1080 per 16 x 16 no more than per 8 x 8 (Cornell box, Crytek Sponza); at 160x90
    /// it errs 14 % more, so small images keep 4 (docs/vct.md).
    pub fn sparse_factor(&self, height: u32) -> u32 {
        match self.sparse {
            0 => (height / SPARSE_ROWS).clamp(4, 16),
            f => f,
        }
    }

    /// Checks every value's range.
    pub fn validate(&self) -> Result<()> {
        check(
            self.resolution.is_power_of_two() && (8..=256).contains(&self.resolution),
            "vct resolution",
            "a power of two from 8 to 256",
        )?;
        LEVELS.check(self.levels)?;
        BOUNCE_FRAMES.check(self.bounce_frames)?;
        check(
            self.cones.is_none_or(super::gather::check_cone_count),
            "vct cones",
            "6 (003's set) or 8..=64",
        )?;
        check(
            self.aperture
                .is_none_or(|a| a.is_finite() && a > 0.0 && a < 180.0),
            "vct aperture",
            "in (0, 180) degrees",
        )?;
        STEP.check(self.step)?;
        if let Some(start) = self.start {
            START.check(start)?;
        }
        check(
            self.stop_opacity.is_finite() && self.stop_opacity > 0.0 && self.stop_opacity <= 1.0,
            "vct stop_opacity",
            "in (0, 1]",
        )?;
        INJECT_STEPS.check(self.inject_steps)?;
        check(
            SPARSE.contains(self.sparse),
            SPARSE.name,
            "0 (chosen from the image height) or 1..=16",
        )?;
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

    /// Whether the voxels' bounce gather reads the anisotropic radiance (`anisotropic` or
    /// `anisotropic_bounce`).
    pub fn anisotropic_radiance_in_bounce(&self) -> bool {
        self.anisotropic || self.anisotropic_bounce
    }

    /// The diffuse cones of the technique tracing `structure`: the values given here, the
    /// structure's own defaults for the others.
    pub fn diffuse_cones(&self, structure: VctStructure) -> DiffuseCones {
        self.resolve_cones(structure.default_cones(self.multi_bounce))
    }

    /// The cones the voxels gather with for multiple bounces on `structure`: the values the
    /// settings give (they apply to both gathers), else the structure's own bounce cones
    /// ([`VctStructure::default_bounce_cones`]).
    pub fn bounce_cones(&self, structure: VctStructure) -> DiffuseCones {
        self.resolve_cones(structure.default_bounce_cones())
    }

    fn resolve_cones(&self, own: DiffuseCones) -> DiffuseCones {
        DiffuseCones {
            cones: self.cones.unwrap_or(own.cones),
            aperture: self.aperture.unwrap_or(own.aperture),
            start: self.start.unwrap_or(own.start),
        }
    }

    /// Full aperture of the specular cone in radians.
    pub fn specular_aperture(&self) -> f32 {
        (self.roughness * 90.0).max(2.0).to_radians()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> std::result::Result<VctSettings, toml::de::Error> {
        toml::from_str(text)
    }

    #[test]
    fn each_structure_has_its_own_cones_unless_given() {
        for multi_bounce in [false, true] {
            let s = VctSettings {
                multi_bounce,
                ..VctSettings::default()
            };
            for structure in [VctStructure::Octree, VctStructure::Clipmap] {
                let own = structure.default_cones(multi_bounce);
                assert_eq!(s.diffuse_cones(structure), own);
                assert_eq!(s.bounce_cones(structure), structure.default_bounce_cones());
                let bounce = structure.default_bounce_cones();
                VctSettings {
                    cones: Some(bounce.cones),
                    aperture: Some(bounce.aperture),
                    start: Some(bounce.start),
                    ..s.clone()
                }
                .validate()
                .unwrap();
                // Every default is a valid value.
                let given = VctSettings {
                    cones: Some(own.cones),
                    aperture: Some(own.aperture),
                    start: Some(own.start),
                    ..s.clone()
                };
                given.validate().unwrap();
            }
        }
        // The clipmap at one bounce keeps 003's six cones; the octree's pixels gather with 64,
        // its voxels with 16.
        assert_eq!(VctStructure::Clipmap.default_cones(false).cones, 6);
        assert_eq!(VctStructure::Octree.default_cones(false).cones, 64);
        assert_eq!(VctStructure::Octree.default_bounce_cones().cones, 16);
        // The octree's voxels gather with narrower cones than the clipmap's.
        assert_eq!(VctStructure::Octree.default_bounce_cones().aperture, 18.0);
        assert_eq!(VctStructure::Clipmap.default_bounce_cones().aperture, 36.0);
        // A value given applies to both structures; the others stay each one's own.
        let s = parse("cones = 8\nstart = 3.0\nmulti_bounce = false\n").unwrap();
        s.validate().unwrap();
        for structure in [VctStructure::Octree, VctStructure::Clipmap] {
            let c = s.diffuse_cones(structure);
            assert_eq!((c.cones, c.start), (8, 3.0));
            assert_eq!(c.aperture, structure.default_cones(false).aperture);
            let b = s.bounce_cones(structure);
            assert_eq!((b.cones, b.start), (8, 3.0));
            assert_eq!(b.aperture, structure.default_bounce_cones().aperture);
        }
    }

    #[test]
    fn bad_cone_settings_are_clear_errors() {
        for (text, what) in [
            ("cones = 7", "vct cones"),
            ("cones = 65", "vct cones"),
            ("aperture = 180.0", "vct aperture"),
            ("aperture = 0.0", "vct aperture"),
            ("start = -0.5", "vct start"),
            ("start = 17.0", "vct start"),
        ] {
            let err = parse(text).unwrap().validate().expect_err(text);
            assert!(err.to_string().contains(what), "{text}: {err}");
        }
        // Wrong types and unknown keys fail to parse, naming what was expected.
        let err = parse("cones = \"many\"").expect_err("a string");
        assert!(err.to_string().contains("cones"), "{err}");
        assert!(parse("cone_aperture = 30.0").is_err());
    }
}
