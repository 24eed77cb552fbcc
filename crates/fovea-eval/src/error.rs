//! Typed errors of the evaluation crate, split by whose fault they are.

use std::path::PathBuf;

use thiserror::Error;

use fovea_core::FoveaError;
use fovea_render::RenderError;

/// Every error the experiments return.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EvalError {
    /// A parameter of an experiment outside its valid range.
    #[error("invalid parameter `{name}` = {value}: expected {expected}")]
    InvalidParameter {
        /// Parameter name as the user writes it (the CLI flag).
        name: String,
        /// The offending value.
        value: String,
        /// What would be accepted.
        expected: String,
    },
    /// A metric or display parameter out of range.
    #[error(transparent)]
    Core(#[from] FoveaError),
    /// Rendering failed (bad settings, resource limit, …).
    #[error(transparent)]
    Render(#[from] RenderError),
    /// An output file or folder could not be written.
    #[error("cannot write {path}: {message}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's (or encoder's) message.
        message: String,
    },
    /// The caller's view of the scene failed (see
    /// [`crate::experiments::bench::BenchScene::view`]); the caller's message as it is.
    #[error("{0}")]
    Scene(String),
}

/// Result alias of the evaluation crate's experiments.
pub type Result<T> = std::result::Result<T, EvalError>;

impl EvalError {
    /// Shorthand for [`EvalError::InvalidParameter`].
    pub fn invalid(
        name: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        EvalError::InvalidParameter {
            name: name.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, err: impl std::fmt::Display) -> Self {
        EvalError::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }

    /// The parameter name of an [`InvalidParameter`](Self::InvalidParameter) error, wherever
    /// it came from (this crate, the renderer or the core crate); `None` for other errors.
    pub fn parameter(&self) -> Option<&str> {
        match self {
            EvalError::InvalidParameter { name, .. }
            | EvalError::Core(FoveaError::InvalidParameter { name, .. })
            | EvalError::Render(RenderError::InvalidParameter { name, .. })
            | EvalError::Render(RenderError::Core(FoveaError::InvalidParameter { name, .. })) => {
                Some(name)
            }
            _ => None,
        }
    }
}
