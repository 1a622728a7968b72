//! Every selectable technique in one table: its name, what it is, which family of settings it
//! reads, how its settings are checked and how it is made. The library ([`super::create`],
//! [`crate::embed::GiEngine`]), the command line (`render`, `bench`, `view`), the viewer's
//! panels, the Bevy plugin and the example renderer all read this table, so adding a
//! technique is its folder plus one entry in [`REGISTRY`].

use super::{lpv, probes, vct, vpl, GiSettings, GiTechnique, LpvGi, NoGi};
use crate::gpu::GpuContext;
use crate::scene::Scene;
use crate::{Error, Result};

/// What kind of technique an entry is: which settings it reads and which views it offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// No indirect light.
    None,
    /// A light propagation volume (`[settings.lpv]`, and `clpv`/`olpv` for their variants).
    Lpv(lpv::Variant),
    /// Voxel cone tracing on a structure (`[settings.vct]`).
    ConeTracing(vct::VctStructure),
    /// Many-lights VPL GI (`[settings.vpl]`).
    Vpl,
    /// Probes and surfels (`[settings.probes]`); `octree` for the adaptive octree.
    Probes {
        /// The adaptive octree rather than the uniform grid.
        octree: bool,
    },
}

/// Makes a technique for images of `width` x `height`.
type Create = fn(&GpuContext, &Scene, &GiSettings, u32, u32) -> Result<Box<dyn GiTechnique>>;

/// One selectable technique.
#[derive(Clone, Copy)]
pub struct Technique {
    /// The name on the command line, in scene files and in `GiConfig`.
    pub name: &'static str,
    /// One line on what it is.
    pub summary: &'static str,
    /// Its family.
    pub family: Family,
    /// Checks its settings before any GPU work (so a tool can check every technique it will
    /// run before it runs the first).
    pub validate: fn(&GiSettings) -> Result<()>,
    create: Create,
}

impl std::fmt::Debug for Technique {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Technique")
            .field("name", &self.name)
            .field("family", &self.family)
            .finish()
    }
}

impl Technique {
    /// Creates the technique for images of `width` x `height`, its settings checked first.
    pub fn create(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        settings: &GiSettings,
        width: u32,
        height: u32,
    ) -> Result<Box<dyn GiTechnique>> {
        (self.validate)(settings)?;
        (self.create)(ctx, scene, settings, width, height)
    }

    /// Whether it is one of the probe techniques (which offer the probe view).
    pub fn is_probes(&self) -> bool {
        matches!(self.family, Family::Probes { .. })
    }
}

/// The technique `octolux render` uses when none is named.
pub const DEFAULT_TECHNIQUE: &str = "probes-grid";

/// Every GPU technique, in the order tools list them.
pub const REGISTRY: [Technique; 9] = [
    Technique {
        name: "none",
        summary: "direct light only",
        family: Family::None,
        validate: |_| Ok(()),
        create: |ctx, _, _, w, h| Ok(Box::new(NoGi::new(ctx, w, h))),
    },
    lpv_entry(
        "lpv",
        "light propagation volume on one uniform grid",
        lpv::Variant::Uniform,
    ),
    lpv_entry(
        "clpv",
        "cascaded light propagation volumes",
        lpv::Variant::Cascaded,
    ),
    lpv_entry(
        "olpv",
        "light propagation volume on an octree",
        lpv::Variant::Octree,
    ),
    Technique {
        name: "vct-svo",
        summary: "voxel cone tracing on a sparse voxel octree",
        family: Family::ConeTracing(vct::VctStructure::Octree),
        validate: |s| s.vct.validate(),
        create: |ctx, scene, s, w, h| Ok(Box::new(vct::VctSvo::new(ctx, &s.vct, scene, w, h)?)),
    },
    Technique {
        name: "vct-clipmap",
        summary: "voxel cone tracing on a clipmap",
        family: Family::ConeTracing(vct::VctStructure::Clipmap),
        validate: |s| s.vct.validate(),
        create: |ctx, scene, s, w, h| Ok(Box::new(vct::VctClipmap::new(ctx, &s.vct, scene, w, h)?)),
    },
    Technique {
        name: "vpl",
        summary: "many-lights VPL GI with sparse-voxel-octree visibility",
        family: Family::Vpl,
        validate: |s| s.vpl.validate(),
        create: |ctx, scene, s, w, h| Ok(Box::new(vpl::VplGi::new(ctx, &s.vpl, scene, w, h)?)),
    },
    Technique {
        name: "probes-grid",
        summary: "probes and surfels on a uniform grid",
        family: Family::Probes { octree: false },
        validate: |s| s.probes.for_technique(false).map(|_| ()),
        create: |ctx, scene, s, w, h| {
            Ok(Box::new(probes::ProbesGrid::new(
                ctx, &s.probes, scene, w, h,
            )?))
        },
    },
    Technique {
        name: "probes-octree",
        summary: "probes and surfels on an adaptive octree",
        family: Family::Probes { octree: true },
        validate: |s| s.probes.for_technique(true).map(|_| ()),
        create: |ctx, scene, s, w, h| {
            Ok(Box::new(probes::ProbesOctree::new(
                ctx, &s.probes, scene, w, h,
            )?))
        },
    },
];

const fn lpv_entry(name: &'static str, summary: &'static str, variant: lpv::Variant) -> Technique {
    // One function per variant: a `const` entry cannot capture the variant in a closure.
    let (validate, create): (fn(&GiSettings) -> Result<()>, Create) = match variant {
        lpv::Variant::Uniform => (
            |s| lpv::validate(lpv::Variant::Uniform, s),
            |ctx, scene, s, w, h| {
                Ok(Box::new(LpvGi::new(
                    ctx,
                    lpv::Variant::Uniform,
                    s,
                    scene,
                    w,
                    h,
                )?))
            },
        ),
        lpv::Variant::Cascaded => (
            |s| lpv::validate(lpv::Variant::Cascaded, s),
            |ctx, scene, s, w, h| {
                Ok(Box::new(LpvGi::new(
                    ctx,
                    lpv::Variant::Cascaded,
                    s,
                    scene,
                    w,
                    h,
                )?))
            },
        ),
        lpv::Variant::Octree => (
            |s| lpv::validate(lpv::Variant::Octree, s),
            |ctx, scene, s, w, h| {
                Ok(Box::new(LpvGi::new(
                    ctx,
                    lpv::Variant::Octree,
                    s,
                    scene,
                    w,
                    h,
                )?))
            },
        ),
    };
    Technique {
        name,
        summary,
        family: Family::Lpv(variant),
        validate,
        create,
    }
}

/// The names of [`REGISTRY`], in its order.
pub const TECHNIQUES: &[&str] = &{
    let mut names = [""; REGISTRY.len()];
    let mut i = 0;
    while i < REGISTRY.len() {
        names[i] = REGISTRY[i].name;
        i += 1;
    }
    names
};

/// The technique called `name`; an error that lists the names otherwise (the one place that
/// says so: `render`, `bench`, `view` and `GiEngine` all ask here).
pub fn technique(name: &str) -> Result<&'static Technique> {
    REGISTRY.iter().find(|t| t.name == name).ok_or_else(|| {
        Error::InvalidArgument(format!(
            "unknown GI technique '{name}' (available: {}; `render` also takes reference)",
            TECHNIQUES.join(", ")
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_the_default_is_one_of_them() {
        for (i, t) in REGISTRY.iter().enumerate() {
            assert!(
                REGISTRY[..i].iter().all(|u| u.name != t.name),
                "{} twice",
                t.name
            );
            assert_eq!(technique(t.name).unwrap().name, t.name);
        }
        assert!(TECHNIQUES.contains(&DEFAULT_TECHNIQUE));
        let e = technique("ssgi").unwrap_err().to_string();
        assert!(e.contains("'ssgi'") && e.contains("probes-octree"), "{e}");
    }

    #[test]
    fn every_default_setting_is_valid() {
        for t in &REGISTRY {
            (t.validate)(&GiSettings::default()).unwrap_or_else(|e| panic!("{}: {e}", t.name));
        }
    }
}
