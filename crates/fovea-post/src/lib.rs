//! # fovea-post
//!
//! Image-space passes of the foveated frame.
