//! The resident frame (issue 37): a frame's buffers kept on the device from the first pass to
//! the tone map, so that passes chain on device memory instead of reading their results back
//! and uploading them again.
//!
//! * [`samples`]: the sample buffers of one eye's frame on the device ([`DeviceSamples`]),
//!   the record every sample-space pass writes or reads.

pub mod samples;

pub use samples::{DeviceSamples, SampleLayer};
