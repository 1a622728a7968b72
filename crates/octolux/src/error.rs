//! The library's error type: every failure names what failed and, where there is one, the file.

use std::path::{Path, PathBuf};

/// Result alias used throughout octolux.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in octolux, phrased for the person who has to fix it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A file was read but its content is not valid.
    #[error("{path}: {message}")]
    Parse {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong with it, with a line number where known.
        message: String,
    },
    /// A scene (from any source) is unusable: no geometry, NaN vertices, bad indices...
    #[error("invalid scene '{scene}': {message}")]
    InvalidScene {
        /// Scene name or file.
        scene: String,
        /// What is wrong.
        message: String,
    },
    /// An argument or setting is out of range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A scene pulls in more than its [`crate::limits::Budget`] allows.
    #[error("{0}")]
    OverBudget(String),
    /// No usable GPU adapter, device creation failed, or a GPU operation failed.
    #[error("GPU: {0}")]
    Gpu(String),
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    /// A parse error in `path`.
    pub fn parse(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error::Parse {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }

    /// An invalid-scene error.
    pub fn scene(scene: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidScene {
            scene: scene.into(),
            message: message.into(),
        }
    }
}
