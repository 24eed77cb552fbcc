//! # fovea-render
//!
//! Scenes, ray casting and the foveated frame pipeline of the fovea toolkit.
//!
//! * [`scene`]: glTF 2.0, Wavefront OBJ/MTL, Mitsuba 0.6 XML and PLY loaders, and built-in
//!   procedural scenes, all producing one [`scene::Scene`] in world space.
//! * [`bvh`]: closest-hit and shadow-ray queries (obvhs by default; Embree with the `embree`
//!   feature; a brute-force reference).
//! * [`camera`]: per-eye cameras from a display profile, the HMD rig.
//! * [`trace`], [`shade`]: primary rays to a G-buffer; direct lighting with shadows, path
//!   tracing.
//! * [`lights`]: generated light rigs (1, 12, 21, 31… lights).
//! * [`pipeline`]: one frame of any foveation method, stage by stage, with timings.

#![allow(clippy::needless_range_loop)] // per-channel pixel loops read best indexed

pub mod bvh;
pub mod camera;
pub mod camera_path;
pub mod cull_fill;
pub mod dof;
pub mod error;
pub mod eye;
pub mod lights;
pub mod lod;
pub mod pipeline;
pub mod plan;
pub mod quality;
pub mod scene;
pub mod sequence;
pub mod settings;
pub mod shade;
pub mod stereo;
pub mod temporal;
pub mod thin_lens;
pub mod trace;
pub mod world;

pub use error::{RenderError, Result};
