//! Limits on what loading a scene may read, in the spirit of the `image` crate's `Limits`:
//! every loader (glTF, OBJ/MTL, PLY, Mitsuba) reads through them (see `files`).
//!
//! * Only regular files are read: a FIFO, a device (`/dev/zero`), a socket or a directory
//!   is refused before it is opened, also behind a symbolic link.
//! * A file is read up to what it declares (a glTF buffer's `byteLength`) and at most
//!   [`LoadLimits::max_file_bytes`]; one load reads at most [`LoadLimits::max_total_bytes`]
//!   in all (scene file, includes, buffers, meshes, material libraries, textures).
//! * XML elements nest at most [`LoadLimits::max_nesting`] deep.
//! * Files a scene names (buffers, images, `mtllib`, textures, Mitsuba `filename`s and
//!   includes) must lie inside the scene file's folder tree (after resolving `..` and
//!   symbolic links), unless [`LoadLimits::allow_outside_scene_dir`] is set. The scene file
//!   itself may lie anywhere.

use serde::Serialize;

use crate::error::{RenderError, Result};

/// Default [`LoadLimits::max_file_bytes`]: 2 GiB.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 2 << 30;
/// Default [`LoadLimits::max_total_bytes`]: 8 GiB.
pub const DEFAULT_MAX_TOTAL_BYTES: u64 = 8 << 30;
/// Default [`LoadLimits::max_nesting`]: 128 levels of XML elements (real Mitsuba scenes use
/// fewer than 10).
pub const DEFAULT_MAX_NESTING: u32 = 128;
/// Largest accepted [`LoadLimits::max_nesting`]: the XML tree is walked recursively, one
/// small stack frame per level, and 1,024 levels stay far below any thread's stack.
pub const MAX_NESTING_CAP: u32 = 1024;

/// What one scene load may read. [`Default`] gives the documented defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct LoadLimits {
    /// Largest single file read, bytes (default [`DEFAULT_MAX_FILE_BYTES`], 2 GiB). A file
    /// that is larger, or a glTF buffer that declares more, is refused before it is read.
    pub max_file_bytes: u64,
    /// Most bytes read by one load in all files together (default
    /// [`DEFAULT_MAX_TOTAL_BYTES`], 8 GiB).
    pub max_total_bytes: u64,
    /// Deepest XML element nesting of a Mitsuba scene, includes spliced in (default
    /// [`DEFAULT_MAX_NESTING`], 128; at most [`MAX_NESTING_CAP`]).
    pub max_nesting: u32,
    /// Whether files named by the scene may lie outside the scene file's folder tree
    /// (default `false`).
    pub allow_outside_scene_dir: bool,
    /// Memory budget of the load's large decoded data, bytes (default `u64::MAX`: none
    /// beyond the fixed caps). An environment map may take half of it and is reduced to fit
    /// (see `environment::file`). The CLI passes `--max-memory`.
    pub max_memory_bytes: u64,
}

impl Default for LoadLimits {
    fn default() -> Self {
        Self {
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
            max_total_bytes: DEFAULT_MAX_TOTAL_BYTES,
            max_nesting: DEFAULT_MAX_NESTING,
            allow_outside_scene_dir: false,
            max_memory_bytes: u64::MAX,
        }
    }
}

impl LoadLimits {
    /// Checks the limits themselves: sizes ≥ 1 byte, nesting in `1..=MAX_NESTING_CAP`.
    pub fn validate(&self) -> Result<()> {
        if self.max_file_bytes == 0 {
            return Err(RenderError::invalid(
                "max_file_bytes",
                self.max_file_bytes,
                "at least 1 byte",
            ));
        }
        if self.max_total_bytes == 0 {
            return Err(RenderError::invalid(
                "max_total_bytes",
                self.max_total_bytes,
                "at least 1 byte",
            ));
        }
        if !(1..=MAX_NESTING_CAP).contains(&self.max_nesting) {
            return Err(RenderError::invalid(
                "max_nesting",
                self.max_nesting,
                format!("1 to {MAX_NESTING_CAP} levels"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_limits_are_named() {
        assert!(LoadLimits::default().validate().is_ok());
        let e = LoadLimits {
            max_nesting: 0,
            ..Default::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.to_string().contains("max_nesting"), "{e}");
        let e = LoadLimits {
            max_file_bytes: 0,
            ..Default::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.to_string().contains("max_file_bytes"), "{e}");
    }
}
