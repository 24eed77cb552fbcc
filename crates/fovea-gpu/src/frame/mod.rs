//! The resident frame (issue 37): a frame's buffers kept on the device from the first pass to
//! the tone map, so that passes chain on device memory instead of reading their results back
//! and uploading them again.
//!
//! * [`samples`]: the sample buffers of one eye's frame on the device ([`DeviceSamples`]),
//!   the record every sample-space pass writes or reads.
//! * [`shade`]: the sample side's fused kernel — ray generation, trace, surface, direct and
//!   environment light per texel into [`DeviceSamples`] — and what it serves ([`supports`]).
//! * [`bounce`]: indirect light — bounces with next-event estimation after the shade
//!   kernels, for plans with [`ShadingMode::Indirect`](fovea_render::shade::ShadingMode).
//! * [`compact`]: the list of a polar buffer's shaded texels the shade and bounce kernels run
//!   over, built on the device each frame ([`EyeList`]).
//! * [`context`]: each eye's persistent buffers and bind group; both eyes recorded into one
//!   encoder and submitted once ([`ResidentSamples`]).
//! * [`screen`]: the screen side — reconstruction, depth of field and tone map of one eye's
//!   [`DeviceSamples`] recorded into the caller's encoder ([`ScreenContext`]).
//! * [`layers`]: screen-aligned layered buffers (Guenter's layers, the inset) on both sides
//!   ([`ResidentLayers`]).
//! * [`reconstruct`]: the polar reconstruction the screen side records ([`ResidentPolar`]).
//! * [`pull_push`]: Weier's pull-push reconstruction the screen side records
//!   ([`ResidentPullPush`]); [`weier_pattern`]: Weier's sparse pattern as device tables, read
//!   by the shade kernels and the pull-push's mask.
//! * [`binocular`]: both eyes' sample and screen sides in one encoder, one submission
//!   ([`ResidentFrame`]).
//! * [`temporal`]: temporal accumulation in sample space between the shading and the screen
//!   side, with per-eye histories kept on the device ([`ResidentTemporal`]).
//! * [`timing`]: per-pass GPU times read back frames late, never blocking ([`FrameTimer`]).
//! * [`run`]: the resident frame as the tools run it — decided once before the first pass
//!   ([`Route`]), each frame counted ([`FrameCounts`]).
//! * [`gaze_path`]: how a benchmark's gaze moves from frame to frame ([`GazePath`]).
//! * [`compare`]: the binocular frame resident against staged, side by side
//!   ([`compare_binocular`]).
//! * [`sequence`]: a sequence's frames through the resident frame, or the staged track where
//!   it does not serve them ([`SequenceRoute`], [`run_sequence`]).

pub mod binocular;
pub mod bounce;
pub mod compact;
pub mod compare;
pub mod context;
pub mod gaze_path;
pub mod layers;
pub mod pull_push;
pub mod reconstruct;
pub mod run;
// The sample buffers live beside the frame (`crate::samples`): the denoiser reads them too,
// and the frame records the denoiser.
pub use crate::samples;
pub mod screen;
pub mod sequence;
pub mod shade;
pub mod temporal;
pub mod timing;
pub mod weier_pattern;

pub use binocular::{
    BinocularTimes, ResidentFrame, ToneSettings, BINOCULAR_PASSES, DENOISE_PASSES, TEMPORAL_PASSES,
};
pub use compact::EyeList;
pub use compare::{compare_binocular, BinocularComparison, CompareParams, PathSummary};
pub use context::{EyeShade, RecordTimes, ResidentSamples};
pub use gaze_path::{GazePath, SACCADE_STEP_DEG};
pub use layers::ResidentLayers;
pub use pull_push::ResidentPullPush;
pub use reconstruct::{PolarCapacity, ResidentPolar, ScreenPlanes, TableUpload};
pub use run::{refusal, FrameCounts, ResidentRun, Route};
pub use samples::{DeviceSamples, SampleLayer};
pub use screen::{
    ScreenConfig, ScreenContext, ScreenDof, ScreenInput, ScreenLimits, ScreenSizes, SCREEN_PASSES,
};
pub use sequence::{
    run_sequence, ImageReadback, ResidentSequence, SequenceFrameStats, SequenceImage,
    SequenceOutput, SequenceParams, SequenceReport, SequenceRoute,
};
pub use shade::{supports, RayLayout, ShadeScene};
pub use temporal::ResidentTemporal;
pub use timing::{FrameGpuTimes, FrameTimer};
