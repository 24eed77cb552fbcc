//! Typed errors of the render crate, split by whose fault they are.

use std::path::PathBuf;

use thiserror::Error;

/// Every error the render crate returns.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RenderError {
    /// A parameter outside its valid range (display, mapping, camera, light count…).
    #[error(transparent)]
    Core(#[from] fovea_core::FoveaError),
    /// A parameter of the renderer outside its valid range.
    #[error("invalid parameter `{name}` = {value}: expected {expected}")]
    InvalidParameter {
        /// Parameter name as the user writes it.
        name: String,
        /// The offending value.
        value: String,
        /// What would be accepted.
        expected: String,
    },
    /// A file could not be read.
    #[error("cannot read {path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// A file was read but its content is wrong (truncated, malformed, NaN vertices…).
    #[error("bad scene file {path}: {what}")]
    BadInput {
        /// The file.
        path: PathBuf,
        /// What is wrong, specific enough to fix it.
        what: String,
    },
    /// A feature of the input that the renderer does not support (e.g. Draco compression).
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// Another executor (e.g. the GPU) failed a stage; `message` says what to do.
    #[error("{stage} on the {backend} backend: {message}")]
    Executor {
        /// The stage.
        stage: &'static str,
        /// The backend's name.
        backend: String,
        /// Its one-line error.
        message: String,
    },
    /// A request that would exceed a resource limit, refused before allocating.
    #[error("resource limit: {what} needs {needed}, but the limit is {limit}")]
    ResourceLimit {
        /// What was requested.
        what: String,
        /// How much it would need.
        needed: String,
        /// The limit in force.
        limit: String,
    },
}

/// Result alias of the render crate.
pub type Result<T> = std::result::Result<T, RenderError>;

impl RenderError {
    /// Shorthand for [`RenderError::InvalidParameter`].
    pub fn invalid(
        name: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        RenderError::InvalidParameter {
            name: name.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }

    /// Shorthand for [`RenderError::BadInput`].
    pub fn bad(path: impl Into<PathBuf>, what: impl Into<String>) -> Self {
        RenderError::BadInput {
            path: path.into(),
            what: what.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, err: &std::io::Error) -> Self {
        RenderError::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }
}
