//! Where the shared real-world test scenes live.

use std::path::PathBuf;

/// The folder holding the shared test scenes (Sponza, Cornell box, bunny, dragon): the
/// `OCTOLUX_SCENES` environment variable if set, otherwise `shared/scenes` next to the
/// repository (the repository and `shared/` are checked out side by side). The folder may not
/// exist; callers check.
pub fn scenes_dir() -> PathBuf {
    match std::env::var_os("OCTOLUX_SCENES") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/scenes"
        )),
    }
}
