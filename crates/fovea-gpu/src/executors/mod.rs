//! The GPU passes as the frame pipeline's executors (`fovea_render::pipeline`'s executor
//! traits), for a frame context to plug in.
//!
//! * [`denoise`]: [`GpuDenoiser`](crate::GpuDenoiser) as the
//!   [`DenoiseExecutor`](fovea_render::pipeline::DenoiseExecutor) ([`GpuDenoiseExecutor`]).

pub mod denoise;

pub use denoise::GpuDenoiseExecutor;
