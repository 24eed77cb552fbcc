//! The device behind a set of executors other than the CPU's (e.g. `fovea_gpu`'s), as the
//! frame's callers read it: the executors' own times, what the device moved, and the meeting
//! point of both eyes' submissions ([`super::lockstep`]). The executors' library implements
//! it; a caller (the CLI, the viewer, the bench) reports it without knowing the device.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde_json::{Map, Value};

use super::Lockstep;

/// The keys [`ExecutorDevice::report`] fills, as the frame's JSON `backend` object carries
/// them (`null` where no device ran): each executor's times since it was last read, the
/// BVH and surfaces uploaded, the device's submissions and traffic.
pub const DEVICE_REPORT_KEYS: [&str; 12] = [
    "gpu_reconstruct",
    "gpu_dof",
    "gpu_aa",
    "gpu_trace",
    "gpu_shadow",
    "gpu_direct_light",
    "gpu_environment_light",
    "gpu_tone_map",
    "gpu_bvh",
    "gpu_surfaces",
    "gpu_submissions",
    "gpu_traffic",
];

/// The device behind a set of executors.
pub trait ExecutorDevice: Send + Sync {
    /// Its figures, by [`DEVICE_REPORT_KEYS`] key (the executors' times read, not taken).
    fn report(&self) -> Map<String, Value>;
    /// Each stage's own pass time on the device (ms, from timestamps) since the last call,
    /// by stage name (`trace`, `shadow`, `direct_light`, `environment_light`, `aa`,
    /// `reconstruct`, `dof`); stages that did not run there are missing.
    fn take_pass_ms(&self) -> Vec<(&'static str, f64)>;
    /// What the device moved and waited for so far, by counter (bytes uploaded and read
    /// back, buffers and bind groups created, buffer maps, blocking waits, submissions).
    fn traffic(&self) -> BTreeMap<String, u64>;
    /// The device as the meeting point of both eyes' submissions.
    fn lockstep(&self) -> Arc<dyn Lockstep + Send + Sync>;
    /// Whether the output's tone map ran on the device since its times were last taken.
    fn tone_mapped(&self) -> bool;
}
