//! (being written)
use super::Scene;
use crate::error::{RenderError, Result};
use std::path::Path;

/// Loads a PLY file as a scene with one mesh.
pub fn load_scene(path: &Path) -> Result<Scene> {
    Err(RenderError::Unsupported(format!(
        "{} loader not yet written",
        path.display()
    )))
}
