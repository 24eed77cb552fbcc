//! # fovea-render
//!
//! Scenes, ray casting and the foveated frame pipeline of the fovea toolkit.

pub mod error;
pub mod scene;

pub use error::{RenderError, Result};
