//! # fovea-gpu
//!
//! The GPU executor of the fovea frame plan, on [wgpu](https://wgpu.rs): compute passes that
//! mirror the CPU stages, so that the two can be compared pass by pass. One source of truth
//! for the math: the f64 Rust mappings of `fovea-core` stay the reference, and every constant a
//! shader needs is computed by them and uploaded; the WGSL derives none of its own.
//!
//! What exists (see `docs/gpu.md`):
//!
//! * [`device`]: opening a device with typed, one-line errors and no panics
//!   ([`GpuContext`], [`GpuRequest`], [`AdapterSummary`]).
//! * [`backend`]: `--backend cpu|gpu|auto` ([`BackendChoice`]).
//! * [`executors`]: this crate's passes as the render pipeline's executors, handed out for a
//!   world ([`executors::GpuExecutors::new`]).
//! * [`mapping`]: VaFR (Eq. 3 or exact rings), KFR, LaFR and visual-polar forward/inverse
//!   mappings on the GPU ([`GpuMapping`]).
//! * [`reconstruct`]: polar sample buffers back to the screen, bilinear or footprint-filtered
//!   ([`GpuReconstructor`]).
//! * [`pull_push`]: Weier's screen-aligned reconstruction, pull-push hole filling of the
//!   colour and the nearest shaded pixel's depth ([`GpuPullPush`]; [`GpuReconstructor`] runs
//!   it for Weier's mapping).
//! * [`sample_aa`]: FXAA (with the polar seam) and the 3×3 Gaussian inside sample buffers
//!   ([`GpuSampleAa`]).
//! * [`trace`]: closest hits and occlusion of ray batches through a BVH built by obvhs
//!   ([`GpuTracer`]).
//! * [`direct_light`]: the renderer's direct lighting of surface samples, shadow rays
//!   through the same BVH ([`GpuTracer::direct_light_timed`]).
//! * [`environment_light`]: the renderer's environment light (its MIS estimator, the same
//!   random numbers), shadow rays through the same BVH
//!   ([`GpuTracer::environment_light_timed`], [`GpuEnvironment`]).
//! * [`ray_generation`]: primary rays generated from their screen points and traced — a polar
//!   buffer's from their polar coordinates ([`GpuTracer::closest_hits_polar_timed`]), a
//!   screen-aligned buffer's from the points themselves
//!   ([`GpuTracer::closest_hits_screen_timed`]).
//! * [`surface`]: the scene's normals, UVs, materials and textures (with their mips) on the
//!   device, and the G-buffer record of each generated ray's hit interpolated there
//!   ([`GpuSurfaces`], [`GpuTracer::surfaces_polar_timed`]).
//! * [`dof`]: the signed CoC map from depth with the eye model and the scatter-as-gather
//!   depth-of-field filter ([`GpuDof`]).
//! * [`denoise`]: the sample-space SVGF à-trous denoiser, the twin of
//!   `fovea_post::denoise` ([`GpuDenoiser`], its guides [`DeviceGuides`]).
//! * [`executors`]: GPU passes as the frame pipeline's executors
//!   ([`executors::GpuDenoiseExecutor`]).
//! * [`tonemap`]: exposure, tone curve and 8-bit sRGB encoding ([`GpuToneMap`]).
//! * [`frame`]: the resident frame's buffers on the device ([`frame::DeviceSamples`]) and its
//!   sample side: every texel traced and shaded on the device, both eyes in one submission
//!   ([`frame::ResidentSamples`]); its screen side recorded into one encoder
//!   ([`frame::ScreenContext`]).
//! * [`shaders`]: the WGSL sources, validated with naga in a plain `cargo test`.
//!
//! ```no_run
//! use fovea_core::display::DisplayProfile;
//! use fovea_core::mapping::{Vafr, VafrParams};
//! use fovea_gpu::{BackendChoice, GpuMapping, GpuRequest, Resolved};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let display = DisplayProfile::preset("vive-pro-eye")?;
//! let vafr = Vafr::new(&display, display.gaze(700.0, 820.0)?, VafrParams::eq3())?;
//! match BackendChoice::Auto.resolve(&GpuRequest::default())? {
//!     Resolved::Gpu(ctx) => {
//!         let gpu = GpuMapping::vafr(&ctx, &vafr)?;
//!         let lp = gpu.forward(&[[900.5, 600.5]])?; // screen → LP buffer, on the GPU
//!         println!("GPU: {} → {:?}", ctx.adapter(), lp[0]);
//!     }
//!     cpu => println!("{}", cpu.describe()),
//! }
//! # Ok(())
//! # }
//! ```

pub mod backend;
pub mod denoise;
pub mod device;
pub mod direct_light;
pub mod dof;
pub mod environment_light;
pub mod error;
pub mod executors;
pub mod frame;
pub mod lockstep;
pub mod mapping;
pub mod pull_push;
pub mod ray_generation;
pub mod reconstruct;
mod records;
pub mod sample_aa;
pub mod samples;
pub mod shaders;
pub mod surface;
mod timestamps;
pub mod tonemap;
pub mod trace;
pub mod traffic;
mod transfer;

pub use backend::{BackendChoice, Resolved};
pub use denoise::{DenoiseTimes, DeviceGuides, GpuDenoiser};
pub use device::{AdapterSummary, DeviceKind, GpuContext, GpuRequest};
pub use direct_light::{DirectLight, GpuLight, GpuSurface};
pub use dof::{DofTimes, GpuDof};
pub use environment_light::{EnvironmentLight, GpuEnvironment};
pub use error::{GpuError, Result};
pub use lockstep::SubmissionCounts;
pub use mapping::{Direction, GpuMapping};
pub use pull_push::{GpuPullPush, PullPushTimes};
pub use ray_generation::{GpuPolarRay, GpuScreenRay, RayGenCamera};
pub use reconstruct::{GpuReconstructor, ReconstructTimes};
pub use sample_aa::{GpuSampleAa, SampleAaTimes, SampleFilter};
pub use surface::{GpuSurfaceRay, GpuSurfaces, SurfaceStats};
pub use tonemap::GpuToneMap;
pub use trace::{BvhStats, DirectLightModel, GpuHit, GpuRay, GpuTracer, TraceTimes};
pub use traffic::TrafficCounts;

/// Every WGSL module of the crate, as the device compiles it.
pub const ALL_SHADERS: &[shaders::ShaderSource] = &[
    mapping::vafr::SHADER,
    mapping::kfr::SHADER,
    mapping::lafr::SHADER,
    mapping::polar_table::SHADER,
    reconstruct::SHADER,
    pull_push::SHADER,
    sample_aa::FXAA_SHADER,
    sample_aa::GAUSSIAN_SHADER,
    trace::SHADER,
    surface::SHADER,
    dof::COC_SHADER,
    dof::GATHER_SHADER,
    tonemap::SHADER,
    frame::reconstruct::PAD_SHADER,
    frame::screen::SPLIT_SHADER,
    frame::screen::PRESENT_SHADER,
    denoise::SHADER,
    frame::shade::SHADER,
    frame::bounce::SHADER,
    frame::temporal::SHADER,
    frame::layers::SHADER,
    frame::pull_push::MASK_SHADER,
];
