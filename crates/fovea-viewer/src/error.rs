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
    /// A file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
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
