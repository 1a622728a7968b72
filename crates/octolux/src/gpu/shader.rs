//! The library's WGSL as modules, composed with [wesl](https://wesl-lang.dev): a shader file is
//! the module named by its path under `src/` (`octolux::frame::common` is
//! `src/frame/common.wgsl`) and imports what it uses
//! (`import octolux::frame::common::{Camera, world_from_depth};`), so every declaration is
//! written once and a shader says what it depends on. Variants are `@if(name)` attributes,
//! chosen per composition ([`compose`]'s `features`). A composition can add modules of its
//! own beside the library's: data a shader needs from Rust (the cone set,
//! `octolux::gi::vct::cone_set`), and a module chosen per use (the cone marcher imports
//! `octolux::gi::vct::structure::vct_sample`, and each structure puts its sampler's module
//! there), so a marcher is written once for every structure it reads.
//!
//! Composition keeps names as written (no mangling), so entry points, bindings and overrides are
//! what the module declares, and it keeps every declaration of every module it reaches (as the
//! concatenation it replaced did): a binding a pass does not use stays out of its derived
//! layout all the same. A module that several shaders share owns its bindings at fixed
//! numbers above every pass's own (the lights from 40, the octree walk from 44, the octree's
//! samplers from 50, the clipmap's from 64), and the Rust beside it has the function that
//! binds them, so a binding is declared once.

use crate::{Error, Result};
use std::borrow::Cow;
use wesl::{Feature, ManglerKind, ModulePath, Router, VirtualResolver, Wesl};

/// `(path under src/ without .wgsl, source)` of every module [`compose`] can resolve.
macro_rules! modules {
    ($($path:literal),* $(,)?) => {
        &[$(($path, include_str!(concat!("../", $path, ".wgsl")))),*]
    };
}

/// The modules of the library's shaders.
pub const MODULES: &[(&str, &str)] = modules![
    "gpu/work",
    "gpu/dispatch",
    "gpu/roofline",
    "frame/common",
    "frame/lights",
    "frame/raster",
    "frame/gbuffer",
    "frame/rsm",
    "frame/sparse",
    "frame/upsample",
    "render/compose",
    "render/direct",
    "embed/input",
    "gi/lpv/sh",
    "gi/lpv/inject",
    "gi/lpv/lookup",
    "gi/lpv/propagate",
    "gi/lpv/octree",
    "voxel/svo/walk",
    "voxel/pairs",
    "voxel/voxelize/overlap",
    "voxel/voxelize/voxelize",
    "voxel/svo/control",
    "voxel/svo/common",
    "voxel/svo/leaf_sums",
    "voxel/svo/build",
    "voxel/svo/dynamic",
    "voxel/svo/accumulate",
    "voxel/svo/pack",
    "voxel/svo/inject",
    "voxel/svo/aniso",
    "voxel/svo/aniso_radiance",
    "voxel/clipmap/emission",
    "voxel/clipmap/update",
    "voxel/clipmap/filter",
    "voxel/clipmap/inject_common",
    "voxel/clipmap/inject",
    "voxel/clipmap/inject_shadow",
    "voxel/facing",
    "voxel/svo/sample",
    "voxel/svo/radiance_sample",
    "voxel/svo/sample_aniso",
    "voxel/svo/radiance_sample_aniso",
    "voxel/svo/bounce_table",
    "voxel/clipmap/sample",
    "voxel/clipmap/radiance_sample",
    "voxel/clipmap/blend",
    "gi/vct/cone",
    "gi/vct/gather",
    "gi/vct/cone_lanes",
    "gi/vct/trace",
    "gi/vct/svo_trace",
    "gi/vct/bounce_list",
    "gi/vct/svo_bounce",
    "gi/vct/clipmap_trace",
    "gi/vct/clipmap_bounce",
    "gi/vct/clipmap_tail",
    "gi/probes/probes",
    "gi/probes/lattice",
    "gi/probes/encoding",
    "gi/probes/bvh",
    "gi/probes/voxel_rays",
    "gi/probes/probe_values",
    "gi/probes/moments",
    "gi/probes/grid",
    "gi/probes/grid_sample",
    "gi/probes/octree_params",
    "gi/probes/octree_tree",
    "gi/probes/octree_tree_read",
    "gi/probes/octree_tree_write",
    "gi/probes/octree_set",
    "gi/probes/octree_sample",
    "gi/probes/octree",
    "gi/probes/place",
    "gi/probes/place_bvh",
    "gi/probes/place_voxels",
    "gi/probes/light",
    "gi/probes/integrate",
    "gi/probes/gather",
    "gi/probes/moments_build",
    "gi/vpl/vpl",
    "gi/vpl/generate",
    "gi/vpl/shade",
    "gi/vpl/bounce",
];

/// The source of the library's module `path` (as in [`MODULES`]), to add under another path.
pub fn module_source(path: &str) -> Option<&'static str> {
    MODULES.iter().find(|(p, _)| *p == path).map(|(_, s)| *s)
}

/// The package the library's modules are mounted as: shaders import `octolux::frame::common`,
/// the name a crate embedding the library's shaders would give them.
const PACKAGE: &str = "octolux";

/// The path of the file `path` under `src/` (`frame/common`) inside the library's resolver
/// (`package::frame::common`), or, `imported`, as shaders import it
/// (`octolux::frame::common`).
fn module_path(path: &str, imported: bool) -> Result<ModulePath> {
    let root = if imported { PACKAGE } else { "package" };
    format!("{root}::{}", path.replace('/', "::"))
        .parse()
        .map_err(|e| Error::Gpu(format!("shader module '{path}': bad module path: {e}")))
}

/// Composes the shader whose main module is `main` (a path under `src/`, such as
/// `"render/compose"`) with every module it imports into one WGSL source. `features` set the
/// `@if` flags (a flag the sources use but `features` does not set is an error);
/// `extra` are `(path, WGSL)` modules added to the library's for this composition only: data
/// generated in Rust (the cone set, `gi/vct/cone_set`) or a module chosen per use (the
/// structure the cone marcher samples, `gi/vct/structure`; a probe set, `gi/probes/set`).
pub fn compose(main: &str, features: &[(&str, bool)], extra: &[(&str, &str)]) -> Result<String> {
    compose_with(main, None, features, extra)
}

/// [`compose`] with the main module given as text (its imports resolved against the library's
/// modules): for kernels written in Rust or in tests over the library's modules; `label`
/// names it in errors.
pub fn compose_text(
    label: &str,
    main: &str,
    features: &[(&str, bool)],
    extra: &[(&str, &str)],
) -> Result<String> {
    compose_with(label, Some(main), features, extra)
}

fn compose_with(
    main: &str,
    text: Option<&str>,
    features: &[(&str, bool)],
    extra: &[(&str, &str)],
) -> Result<String> {
    let mut files = VirtualResolver::new();
    for (path, source) in MODULES {
        files.add_module(module_path(path, false)?, Cow::Borrowed(*source));
    }
    // A main module given as text sits beside the others under a name no file has.
    let root = match text {
        Some(text) => {
            files.add_module(
                module_path("composed", false)?,
                Cow::Owned(text.to_string()),
            );
            module_path("composed", true)?
        }
        None => module_path(main, true)?,
    };
    for &(path, source) in extra {
        files.add_module(module_path(path, false)?, Cow::Owned(source.to_string()));
    }
    let mut router = Router::new();
    let package: ModulePath = PACKAGE
        .parse()
        .map_err(|e| Error::Gpu(format!("shader '{main}': {e}")))?;
    router.mount_resolver(package, files);
    let mut compiler = Wesl::new("").set_custom_resolver(router);
    compiler
        .set_mangler(ManglerKind::None)
        .use_stripping(false)
        .set_missing_feature_behavior(Feature::Error);
    // Work counting is off unless a counting renderer asks for it (`gpu/work.wgsl`).
    compiler.set_feature("count_work", false);
    for &(name, on) in features {
        compiler.set_feature(name, on);
    }
    compiler
        .compile(&root)
        .map(|result| result.to_string())
        .map_err(|e| Error::Gpu(format!("shader '{main}' does not compose: {e}")))
}

/// [`compose`] for one of the library's own shaders. Their composition cannot
/// fail at run time unless a module is broken, which the test
/// `every_module_composes_into_valid_wgsl` rules out; a broken one stops here with wesl's
/// message.
pub fn library_shader(main: &str, features: &[(&str, bool)]) -> String {
    library_shader_with(main, features, &[])
}

/// [`library_shader`] with extra modules ([`compose`]).
pub fn library_shader_with(
    main: &str,
    features: &[(&str, bool)],
    extra: &[(&str, &str)],
) -> String {
    compose(main, features, extra).unwrap_or_else(|e| panic!("internal shader error: {e}"))
}

/// One cone straight up: the cone set [`compose_alone`] gives the modules that import one (the
/// real sets are generated by `gi::vct::cone_set_wgsl`).
const ONE_CONE: &str = "const DIFFUSE_CONES: u32 = 1u;
const CONE_LANES: u32 = 1u;
const CONES_PER_LANE: u32 = 1u;
const CONE_RESULTS: u32 = 64u;
var<private> DIFFUSE_SET: array<vec4<f32>, 1> = array<vec4<f32>, 1>(vec4<f32>(0.0, 1.0, 0.0, 1.0));";

/// Composes the library module `path` on its own, for tools and tests that go over every
/// module: the modules composed in per use get what a technique would give that module (the
/// clipmap's structure for a clipmap module, else the octree's; the octree's probe set for an
/// octree module, else the grid's; BVH rays; the tree bindings the module reads), and one cone.
pub fn compose_alone(path: &str, features: &[(&str, bool)]) -> Result<String> {
    let module = |p: &str| {
        module_source(p).ok_or_else(|| Error::Gpu(format!("internal shader error: no module {p}")))
    };
    let octree = path.contains("octree") as usize;
    let structure = ["gi/vct/svo_trace", "gi/vct/clipmap_trace"][path.contains("clipmap") as usize];
    let tree = match path {
        "gi/probes/octree" => "gi/probes/octree_tree_write",
        _ => "gi/probes/octree_tree_read",
    };
    let extra = [
        ("gi/vct/cone_set", ONE_CONE),
        ("gi/vct/structure", module(structure)?),
        (
            "gi/probes/set",
            module(["gi/probes/grid", "gi/probes/octree_set"][octree])?,
        ),
        (
            "gi/probes/set_sample",
            module(["gi/probes/grid_sample", "gi/probes/octree_sample"][octree])?,
        ),
        ("gi/probes/rays", module("gi/probes/place_bvh")?),
        ("gi/probes/tree_bindings", module(tree)?),
    ];
    compose(path, features, &extra)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every module composes with its imports into WGSL that naga accepts as written (parse and
    /// validation), for both values of each `@if` flag it uses.
    #[test]
    fn every_module_composes_into_valid_wgsl() {
        // Every flag of any module, off unless the module under test varies it.
        let all_flags: Vec<&str> = {
            let mut f: Vec<&str> = MODULES.iter().flat_map(|(_, s)| flags_in(s)).collect();
            f.sort_unstable();
            f.dedup();
            f
        };
        for (path, source) in MODULES {
            let flags: Vec<&str> = flags_in(source);
            for bits in 0..(1u32 << flags.len()) {
                let features: Vec<(&str, bool)> = all_flags
                    .iter()
                    .map(|&f| {
                        let i = flags.iter().position(|&g| g == f);
                        (f, i.is_some_and(|i| bits & (1 << i) != 0))
                    })
                    .collect();
                let wgsl = compose_alone(path, &features).unwrap_or_else(|e| panic!("{e}"));
                let module = naga::front::wgsl::parse_str(&wgsl)
                    .unwrap_or_else(|e| panic!("{path}: {}", e.emit_to_string(&wgsl)));
                naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::all(),
                )
                .validate(&module)
                .unwrap_or_else(|e| panic!("{path} {features:?}: {e:?}"));
            }
        }
    }

    /// The `@if(name)` flags a source uses.
    fn flags_in(source: &str) -> Vec<&str> {
        let mut flags: Vec<&str> = source
            .match_indices("@if(")
            .filter_map(|(i, _)| {
                let rest = &source[i + 4..];
                let end = rest.find(')')?;
                let name = rest[..end].trim().trim_start_matches('!');
                name.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_')
                    .then_some(name)
            })
            .collect();
        flags.sort_unstable();
        flags.dedup();
        flags
    }

    #[test]
    fn a_missing_import_is_an_error_naming_the_shader() {
        let err = compose("frame/nothing", &[], &[]).unwrap_err().to_string();
        assert!(err.contains("frame/nothing"), "{err}");
    }
}
