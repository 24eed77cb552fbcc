//! The resident frame (issue 37): a frame's buffers kept on the device from the first pass to
//! the tone map, so that passes chain on device memory instead of reading their results back
//! and uploading them again.
//!
//! * [`samples`]: the sample buffers of one eye's frame on the device ([`DeviceSamples`]),
//!   the record every sample-space pass writes or reads.
//! * [`shade`]: the sample side's kernels — ray generation, trace, surface, direct and
//!   environment light per texel into [`DeviceSamples`] — and what they serve ([`supports`]).
//! * [`context`]: each eye's persistent buffers and bind group; both eyes recorded into one
//!   encoder and submitted once ([`ResidentSamples`]).

pub mod context;
pub mod samples;
pub mod shade;

pub use context::{EyeShade, RecordTimes, ResidentSamples};
pub use samples::{DeviceSamples, SampleLayer};
pub use shade::{supports, RayLayout, ShadeScene};
