//! The resident frame (issue 37): a frame's buffers kept on the device from the first pass to
//! the tone map, so that passes chain on device memory instead of reading their results back
//! and uploading them again.
//!
//! * [`samples`]: the sample buffers of one eye's frame on the device ([`DeviceSamples`]),
//!   the record every sample-space pass writes or reads.
//! * [`shade`]: the sample side's fused kernel — ray generation, trace, surface, direct and
//!   environment light per texel into [`DeviceSamples`] — and what it serves ([`supports`]).
//! * [`context`]: each eye's persistent buffers and bind group; both eyes recorded into one
//!   encoder and submitted once ([`ResidentSamples`]).
//! * [`screen`]: the screen side — reconstruction, depth of field and tone map of one eye's
//!   [`DeviceSamples`] recorded into the caller's encoder ([`ScreenContext`]).
//! * [`reconstruct`]: the polar reconstruction the screen side records ([`ResidentPolar`]).
//! * [`binocular`]: both eyes' sample and screen sides in one encoder, one submission
//!   ([`ResidentFrame`]).
//! * [`temporal`]: temporal accumulation in sample space between the shading and the screen
//!   side, with per-eye histories kept on the device ([`ResidentTemporal`]).
//! * [`timing`]: per-pass GPU times read back frames late, never blocking ([`FrameTimer`]).

pub mod binocular;
pub mod context;
pub mod reconstruct;
pub mod samples;
pub mod screen;
pub mod shade;
pub mod temporal;
pub mod timing;

pub use binocular::{
    BinocularTimes, ResidentFrame, ToneSettings, BINOCULAR_PASSES, DENOISE_PASSES,
};
pub use context::{EyeShade, RecordTimes, ResidentSamples};
pub use reconstruct::{PolarCapacity, ResidentPolar, TableUpload};
pub use samples::{DeviceSamples, SampleLayer};
pub use screen::{
    ScreenConfig, ScreenContext, ScreenDof, ScreenInput, ScreenLimits, SCREEN_PASSES,
};
pub use shade::{supports, RayLayout, ShadeScene};
pub use temporal::ResidentTemporal;
pub use timing::{FrameGpuTimes, FrameTimer};
