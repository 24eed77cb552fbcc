//! The viewer's errors: each one line saying what is wrong and what to do.

use std::path::PathBuf;

/// What can go wrong opening or running the viewer.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// No display server to open a window on.
    #[error("no display server: {0}")]
    NoDisplay(String),
    /// The window or the device drawing it failed.
    #[error("{0}")]
    Window(String),
    /// A bad option, gaze or setting.
    #[error("{0}")]
    Input(String),
    /// The renderer refused a frame.
    #[error("{0}")]
    Render(String),
    /// A file or folder could not be written.
    #[error("cannot write {}: {reason}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why (in the message, not a `source`: a chain of contexts prints it once).
        reason: std::io::Error,
    },
    /// An output file could not be written (through [`fovea_core::atomic_file`]: nothing
    /// is left under its name).
    #[error(transparent)]
    Write(#[from] fovea_core::atomic_file::WriteError),
}

impl From<fovea_render::RenderError> for ViewerError {
    fn from(e: fovea_render::RenderError) -> Self {
        ViewerError::Render(e.to_string())
    }
}

impl From<fovea_core::FoveaError> for ViewerError {
    fn from(e: fovea_core::FoveaError) -> Self {
        ViewerError::Input(e.to_string())
    }
}

/// The viewer's results.
pub type Result<T> = std::result::Result<T, ViewerError>;
