//! The library's WGSL as modules, composed with [wesl](https://wesl-lang.dev): a shader file is
//! the module named by its path under `src/` (`package::frame::common` is
//! `src/frame/common.wgsl`) and imports what it uses
//! (`import package::frame::common::{Camera, world_from_depth};`), so every declaration is
//! written once and a shader says what it depends on. Variants are `@if(name)` attributes,
//! chosen per composition ([`compose`]'s `features`); numeric constants a shader needs from
//! Rust come from a generated module mounted as the package `constants`.
//!
//! Composition keeps names as written (no mangling), so entry points, bindings and overrides are
//! what the module declares, and it keeps every declaration of every module it reaches (as the
//! concatenation it replaces did): a binding a pass does not use stays out of its derived
//! layout all the same. A module without imports is plain WGSL; shaders not yet moved to
//! imports still paste such modules together.

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
    "frame/common",
    "frame/lights",
    "frame/raster",
    "frame/gbuffer",
    "frame/rsm",
    "render/compose",
    "render/direct",
    "gi/lpv/sh",
    "gi/lpv/inject",
    "gi/lpv/lookup",
    "gi/lpv/propagate",
    "gi/lpv/octree",
    "voxel/svo/walk",
];

/// The module path wesl uses for a file `path` under `src/` (`frame/common` ->
/// `package::frame::common`).
fn module_path(path: &str) -> Result<ModulePath> {
    format!("package::{}", path.replace('/', "::"))
        .parse()
        .map_err(|e| Error::Gpu(format!("shader module '{path}': bad module path: {e}")))
}

/// Composes the shader whose main module is `main` (a path under `src/`, such as
/// `"render/compose"`) with every module it imports into one WGSL source. `features` set the
/// `@if` flags (a flag the sources use but `features` does not set is an error);
/// `constants`, where given, is WGSL mounted as the package `constants`
/// (`import constants::CONES;`).
pub fn compose(main: &str, features: &[(&str, bool)], constants: Option<&str>) -> Result<String> {
    compose_with(main, None, features, constants)
}

/// [`compose`] with the main module given as text (its imports resolved against the library's
/// modules): for shaders still assembled from fragments in Rust, which import the modules they
/// share; `label` names it in errors.
pub fn compose_text(label: &str, main: &str, features: &[(&str, bool)]) -> Result<String> {
    compose_with(label, Some(main), features, None)
}

fn compose_with(
    main: &str,
    text: Option<&str>,
    features: &[(&str, bool)],
    constants: Option<&str>,
) -> Result<String> {
    let mut files = VirtualResolver::new();
    for (path, source) in MODULES {
        files.add_module(module_path(path)?, Cow::Borrowed(*source));
    }
    // A main module given as text sits beside the others under a name no file has.
    let root = match text {
        Some(text) => {
            let root = module_path("composed")?;
            files.add_module(root.clone(), Cow::Owned(text.to_string()));
            root
        }
        None => module_path(main)?,
    };
    let mut router = Router::new();
    if let Some(constants) = constants {
        let mut generated = VirtualResolver::new();
        generated.add_module(ModulePath::new_root(), Cow::Owned(constants.to_string()));
        let package: ModulePath = "constants"
            .parse()
            .map_err(|e| Error::Gpu(format!("shader '{main}': {e}")))?;
        router.mount_resolver(package, generated);
    }
    router.mount_fallback_resolver(files);
    let mut compiler = Wesl::new("").set_custom_resolver(router);
    compiler
        .set_mangler(ManglerKind::None)
        .use_stripping(false)
        .set_missing_feature_behavior(Feature::Error);
    for &(name, on) in features {
        compiler.set_feature(name, on);
    }
    compiler
        .compile(&root)
        .map(|result| result.to_string())
        .map_err(|e| Error::Gpu(format!("shader '{main}' does not compose: {e}")))
}

/// [`compose`] for one of the library's own shaders (no constants). Their composition cannot
/// fail at run time unless a module is broken, which the test
/// `every_module_composes_into_valid_wgsl` rules out; a broken one stops here with wesl's
/// message.
pub fn library_shader(main: &str, features: &[(&str, bool)]) -> String {
    compose(main, features, None).unwrap_or_else(|e| panic!("internal shader error: {e}"))
}

/// A shader of the library's still assembled from fragments (`parts`, pasted in order) whose
/// fragments import modules: their `import` lines are gathered at the top (one per module,
/// the items merged) and the text is composed with [`compose_text`]. As with
/// [`library_shader`], a failure is a broken shader, which the tests that build every pipeline
/// catch.
pub fn library_shader_parts(label: &str, parts: &[&str]) -> String {
    let text = hoist_imports(&parts.join("\n"));
    compose_text(label, &text, &[]).unwrap_or_else(|e| panic!("internal shader error: {e}"))
}

/// `text` with its `import` lines (`import a::b::{x, y};` or `import a::b::x;`, one line each)
/// replaced by one import per module at the top.
fn hoist_imports(text: &str) -> String {
    let mut modules: Vec<(String, Vec<String>)> = Vec::new();
    let mut body = Vec::new();
    for line in text.lines() {
        let Some(import) = line
            .trim()
            .strip_prefix("import ")
            .and_then(|l| l.strip_suffix(';'))
        else {
            body.push(line);
            continue;
        };
        let (path, items) = match import.split_once("::{") {
            Some((path, items)) => (path, items.trim_end_matches('}')),
            None => import.rsplit_once("::").unwrap_or(("", import)),
        };
        let slot = match modules.iter().position(|(p, _)| p == path) {
            Some(i) => &mut modules[i].1,
            None => {
                modules.push((path.to_string(), Vec::new()));
                &mut modules.last_mut().unwrap().1
            }
        };
        for item in items.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            if !slot.iter().any(|i| i == item) {
                slot.push(item.to_string());
            }
        }
    }
    let mut out: Vec<String> = modules
        .iter()
        .map(|(path, items)| format!("import {path}::{{{}}};", items.join(", ")))
        .collect();
    out.extend(body.iter().map(|l| l.to_string()));
    out.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every module composes with its imports into WGSL that naga accepts as written (parse and
    /// validation), for both values of each `@if` flag it uses.
    #[test]
    fn every_module_composes_into_valid_wgsl() {
        for (path, source) in MODULES {
            let flags: Vec<&str> = flags_in(source);
            for bits in 0..(1u32 << flags.len()) {
                let features: Vec<(&str, bool)> = flags
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| (f, bits & (1 << i) != 0))
                    .collect();
                let wgsl = compose(path, &features, None).unwrap_or_else(|e| panic!("{e}"));
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
    fn fragments_imports_are_gathered_at_the_top_once_per_module() {
        let text = "// a\nimport package::m::{x, y};\nfn f() {}\nimport package::m::y;\nimport package::n::z;";
        assert_eq!(
            hoist_imports(text),
            "import package::m::{x, y};\nimport package::n::{z};\n// a\nfn f() {}"
        );
    }

    #[test]
    fn a_missing_import_is_an_error_naming_the_shader() {
        let err = compose("frame/nothing", &[], None).unwrap_err().to_string();
        assert!(err.contains("frame/nothing"), "{err}");
    }
}
