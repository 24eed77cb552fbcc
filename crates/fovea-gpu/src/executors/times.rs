//! The executors' own times, as the frame's JSON reports them (`fovea render --json`'s
//! `backend.gpu_*`, `fovea bench`'s per-pass GPU ms): each executor leaves its figures in a
//! shared slot ([`Slot`]) that a reader takes once per frame.

use std::sync::{Arc, Mutex};

use serde::Serialize;

/// Where an executor leaves its figures for a reader (taken or read once per frame).
pub type Slot<T> = Arc<Mutex<Option<T>>>;

/// The slot's value, leaving it as it is (a poisoned lock is read through).
pub fn peek<T: Copy>(slot: &Mutex<Option<T>>) -> Option<T> {
    *slot.lock().unwrap_or_else(|e| e.into_inner())
}

/// The slot's value, leaving `None` for the next frame.
pub fn take<T>(slot: &Mutex<Option<T>>) -> Option<T> {
    slot.lock().unwrap_or_else(|e| e.into_inner()).take()
}

/// Sums of optional pass times: a missing figure (no timestamps) does not erase the others.
pub(crate) fn add_ms(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    }
}

/// The GPU reconstruction's own times of the last frame (ms).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GpuReconstructMs {
    /// Tables on the CPU (u(r) table, columns, prefilter).
    pub tables_ms: f64,
    /// Buffers, upload, recording, submission.
    pub upload_ms: f64,
    /// Submission to the images filled (GPU work, readback, unpacking).
    pub run_and_readback_ms: f64,
    /// The compute pass alone, from timestamps (when the device has them).
    pub gpu_pass_ms: Option<f64>,
    /// Bands of rows the screen was split into.
    pub bands: u32,
}

/// The GPU AA filter's own times (ms): sums over its calls (one per sample buffer: layers,
/// eyes) since the slot was last taken.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GpuAaMs {
    /// The grid's tables on the CPU (0 when reused from the last frame).
    pub tables_ms: f64,
    /// Buffers, upload, recording, submission.
    pub upload_ms: f64,
    /// Submission to the image filled (GPU work, readback).
    pub run_and_readback_ms: f64,
    /// The compute passes alone, from timestamps (when the device has them).
    pub gpu_pass_ms: Option<f64>,
    /// Layers filtered.
    pub layers: u32,
}

/// The GPU tone map's times (ms): sums over its calls (the images written).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GpuToneMs {
    /// Images encoded.
    pub calls: u32,
    /// Upload, passes, readback, wall ms, over all calls.
    pub total_ms: f64,
}

/// The GPU tracer's own times of one kind of ray (ms): sums over the stage's calls (one per
/// chunk of texels) since the slot was last taken.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GpuTraceMs {
    /// The compute passes alone, from timestamps (when the device has them), summed over
    /// the calls and their batches.
    pub gpu_pass_ms: Option<f64>,
    /// Batches (compute passes) the rays were split into, over all calls.
    pub batches: u32,
    /// Calls of the tracer (chunks of the frame's texels).
    pub calls: u32,
    /// Preparing, uploading, tracing and reading back, wall ms, over all calls.
    pub total_ms: f64,
}

impl GpuTraceMs {
    /// Adds one call's times to the slot's sums.
    pub(crate) fn add_to(slot: &Mutex<Option<GpuTraceMs>>, t: crate::trace::TraceTimes) {
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        let sum = slot.get_or_insert_with(GpuTraceMs::default);
        sum.gpu_pass_ms = add_ms(sum.gpu_pass_ms, t.gpu_pass_ms);
        sum.batches += t.batches;
        sum.calls += 1;
        sum.total_ms += t.total_ms;
    }
}

/// The GPU depth of field's own times of the last frame (ms).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GpuDofMs {
    /// Buffers, upload, recording, submission.
    pub upload_ms: f64,
    /// Submission to the images filled (GPU work, readback).
    pub run_and_readback_ms: f64,
    /// The CoC and gather passes alone, from timestamps (when the device has them).
    pub gpu_pass_ms: Option<f64>,
    /// All of it, wall ms.
    pub total_ms: f64,
}

/// Every executor's slot: the readers of a set of GPU executors' times.
#[derive(Clone, Default)]
pub struct PassTimes {
    /// The reconstruct executor's last frame.
    pub reconstruct: Slot<GpuReconstructMs>,
    /// The depth-of-field executor's last frame.
    pub dof: Slot<GpuDofMs>,
    /// The AA executors (both eyes'), summed over calls.
    pub aa: Slot<GpuAaMs>,
    /// The trace executor's primary rays.
    pub trace: Slot<GpuTraceMs>,
    /// The trace executor's shadow rays (the shade stage's).
    pub shadow: Slot<GpuTraceMs>,
    /// The lights' part of direct shading.
    pub direct_light: Slot<GpuTraceMs>,
    /// The environment's part of direct shading.
    pub environment_light: Slot<GpuTraceMs>,
    /// The tone map, summed over the images it encoded.
    pub tone_map: Slot<GpuToneMs>,
}

impl PassTimes {
    /// Each stage's compute passes alone (ms, from timestamps) since the last call, by
    /// stage name (`trace`, `shadow`, `direct_light`, `environment_light`, `aa`,
    /// `reconstruct`, `dof`); the slots are left empty for the next frame. Stages that did
    /// not run on the GPU, or ran on a device without timestamps, are missing.
    pub fn take_pass_ms(&self) -> Vec<(&'static str, f64)> {
        let trace = |s: &Slot<GpuTraceMs>| take(s).and_then(|t| t.gpu_pass_ms);
        [
            ("aa", take(&self.aa).and_then(|t| t.gpu_pass_ms)),
            ("direct_light", trace(&self.direct_light)),
            ("environment_light", trace(&self.environment_light)),
            ("trace", trace(&self.trace)),
            ("shadow", trace(&self.shadow)),
            (
                "reconstruct",
                take(&self.reconstruct).and_then(|t| t.gpu_pass_ms),
            ),
            ("dof", take(&self.dof).and_then(|t| t.gpu_pass_ms)),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect()
    }

    /// Whether the tone map ran on the GPU since its slot was last taken.
    pub fn tone_mapped(&self) -> bool {
        peek(&self.tone_map).is_some()
    }
}
