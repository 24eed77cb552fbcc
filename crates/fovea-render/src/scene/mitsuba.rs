//! (being written)
use super::Scene;
use crate::error::{RenderError, Result};
use std::path::Path;

/// Loads a scene file.
pub fn load(path: &Path) -> Result<Scene> {
    Err(RenderError::Unsupported(format!(
        "{} loader not yet written",
        path.display()
    )))
}
