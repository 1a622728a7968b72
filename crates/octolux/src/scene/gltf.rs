//! Loader placeholder, being written.

use super::Scene;
use crate::{Error, Result};
use std::path::Path;

/// Loads a scene from `path`.
pub fn load(path: &Path) -> Result<Scene> {
    Err(Error::parse(path, "format not supported yet"))
}
