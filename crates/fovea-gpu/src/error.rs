//! Typed errors of the GPU crate, split by whose fault they are: the machine (no adapter, an
//! adapter too small, a lost device), the caller (a mapping the shaders cannot express), or a
//! bug in this crate (a validation error of wgpu).
//!
//! Every message is one line that says what to do, so the CLI can print it as it is.

use thiserror::Error;

/// Every error the GPU crate returns.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GpuError {
    /// No adapter of the kind asked for. `backends` names the wgpu backends that were searched.
    #[error(
        "no GPU adapter found ({backends}): install a Vulkan driver (on Debian/Ubuntu \
         `apt-get install mesa-vulkan-drivers` gives lavapipe, a software Vulkan device that runs \
         on the CPU), or use --backend cpu"
    )]
    NoAdapter {
        /// The backends that were searched, e.g. "Vulkan".
        backends: String,
    },
    /// Only software adapters exist (lavapipe/llvmpipe) and the request asked for a hardware one
    /// (`--backend auto` does; `--backend gpu` takes a software adapter).
    #[error(
        "only a software GPU adapter ({adapters}): use --backend gpu to run on it anyway, or \
         --backend cpu"
    )]
    SoftwareOnly {
        /// The software adapters found.
        adapters: String,
    },
    /// The adapter exists but cannot give what the request needs; refused before anything is
    /// allocated.
    #[error(
        "GPU adapter {adapter} is too small: {what} needs {needed} bytes, its limit \
         `{limit_name}` is {limit} bytes; use --backend cpu or a smaller resolution"
    )]
    AdapterTooSmall {
        /// The adapter, as [`crate::AdapterSummary`] prints it.
        adapter: String,
        /// What needed the space (e.g. "the mapping's point buffer").
        what: String,
        /// Bytes needed.
        needed: u64,
        /// The wgpu limit that is too small.
        limit_name: &'static str,
        /// Its value on this adapter.
        limit: u64,
    },
    /// The adapter refused to open a device.
    #[error("GPU adapter {adapter} could not open a device: {reason}; use --backend cpu")]
    RequestDevice {
        /// The adapter.
        adapter: String,
        /// wgpu's reason.
        reason: String,
    },
    /// The device was lost (driver reset, GPU removed, or destroyed); nothing more runs on it.
    #[error("the GPU device was lost ({reason}); rerun, or use --backend cpu")]
    DeviceLost {
        /// The driver's reason, as wgpu reports it.
        reason: String,
    },
    /// The GPU ran out of memory.
    #[error("the GPU ran out of memory during {what}; use --backend cpu or a smaller resolution")]
    OutOfMemory {
        /// The operation.
        what: String,
    },
    /// wgpu rejected an operation of this crate: a bug here, not the caller's fault.
    #[error(
        "GPU validation error during {what} (a bug in fovea-gpu, please report it): {message}"
    )]
    Validation {
        /// The operation.
        what: String,
        /// wgpu's message, on one line.
        message: String,
    },
    /// A mapping or parameter the GPU path does not support (yet).
    #[error("unsupported on the GPU: {0}; use --backend cpu")]
    Unsupported(String),
    /// Input the caller handed over is inconsistent (buffers of the wrong size, an image
    /// too large to allocate): the caller's fault.
    #[error("invalid input to the GPU path: {0}")]
    Input(String),
    /// `--backend` (or `FOVEA_BACKEND`) had a value that is not a backend.
    #[error("invalid backend `{0}`: expected cpu, gpu or auto")]
    InvalidBackend(String),
}

/// Result alias of the GPU crate.
pub type Result<T> = std::result::Result<T, GpuError>;

/// wgpu's multi-line messages folded onto one line.
pub(crate) fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}
