//! `--backend cpu|gpu|auto`: which executor runs a frame, and how `auto` decides.
//!
//! * [`BackendChoice::Cpu`]: the CPU path, always; no GPU is looked for.
//! * [`BackendChoice::Gpu`]: the GPU path on the best adapter there is, a software one
//!   (lavapipe/llvmpipe) included; no adapter is an error ([`GpuError::NoAdapter`]), never a
//!   silent fallback, so a run that asked for the GPU never measures the CPU.
//! * [`BackendChoice::Auto`]: the GPU path when a hardware adapter (discrete, integrated or
//!   virtual GPU) exists and opens a device that meets the request; otherwise the CPU path,
//!   with the reason (no adapter, only a software adapter, an adapter too small, a device that
//!   would not open). A software adapter is not picked by `auto`: on these machines the CPU
//!   path is faster than lavapipe. Whatever it picks, [`Resolved::describe`] says which in one
//!   line, e.g. `GPU: NVIDIA H200 (Vulkan, discrete GPU)` or
//!   `CPU (auto: only a software GPU adapter, llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, CPU))`.

use crate::device::{GpuContext, GpuRequest};
use crate::error::{GpuError, Result};

/// Which executor the user asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BackendChoice {
    /// The CPU path.
    Cpu,
    /// The GPU path, on any adapter (software ones included); an error without one.
    Gpu,
    /// A hardware GPU when there is one, the CPU path otherwise (the default).
    #[default]
    Auto,
}

impl BackendChoice {
    /// Every choice, in `--help` order.
    pub const ALL: [BackendChoice; 3] =
        [BackendChoice::Cpu, BackendChoice::Gpu, BackendChoice::Auto];

    /// Lower-case name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BackendChoice::Cpu => "cpu",
            BackendChoice::Gpu => "gpu",
            BackendChoice::Auto => "auto",
        }
    }

    /// Parses `cpu`, `gpu` or `auto` (any case).
    pub fn parse(text: &str) -> Result<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "cpu" => Ok(BackendChoice::Cpu),
            "gpu" => Ok(BackendChoice::Gpu),
            "auto" => Ok(BackendChoice::Auto),
            _ => Err(GpuError::InvalidBackend(text.to_string())),
        }
    }

    /// Resolves the choice on this machine: opens the GPU device for `Gpu`, and for `Auto`
    /// when a hardware adapter meets `request`. Errors only for `Gpu`.
    pub fn resolve(self, request: &GpuRequest) -> Result<Resolved> {
        match self {
            BackendChoice::Cpu => Ok(Resolved::Cpu {
                reason: "asked for".to_string(),
            }),
            BackendChoice::Gpu => GpuContext::new(request).map(Resolved::Gpu),
            BackendChoice::Auto => {
                let hardware = GpuRequest {
                    allow_software: false,
                    ..request.clone()
                };
                match GpuContext::new(&hardware) {
                    Ok(ctx) => Ok(Resolved::Gpu(ctx)),
                    Err(e) => Ok(Resolved::Cpu {
                        reason: format!("auto: {}", auto_reason(&e)),
                    }),
                }
            }
        }
    }
}

/// Why `auto` fell back, shorter than the error (which tells a `gpu` user what to install).
fn auto_reason(e: &GpuError) -> String {
    match e {
        GpuError::SoftwareOnly { adapters } => format!("only a software GPU adapter, {adapters}"),
        GpuError::NoAdapter { .. } => "no GPU adapter".to_string(),
        other => other.to_string(),
    }
}

impl std::fmt::Display for BackendChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for BackendChoice {
    type Err = GpuError;
    fn from_str(s: &str) -> Result<Self> {
        Self::parse(s)
    }
}

/// The executor a [`BackendChoice`] resolved to on this machine.
pub enum Resolved {
    /// The CPU path, and why (asked for, or why `auto` did not pick a GPU).
    Cpu {
        /// One phrase.
        reason: String,
    },
    /// The GPU path on this device.
    Gpu(GpuContext),
}

impl Resolved {
    /// One line for the user: `GPU: <adapter>` or `CPU (<reason>)`.
    pub fn describe(&self) -> String {
        match self {
            Resolved::Cpu { reason } => format!("CPU ({reason})"),
            Resolved::Gpu(ctx) => format!("GPU: {}", ctx.adapter()),
        }
    }
}

impl std::fmt::Debug for Resolved {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_say_what_is_expected() {
        for c in BackendChoice::ALL {
            assert_eq!(BackendChoice::parse(c.name()).unwrap(), c);
            assert_eq!(c.name().parse::<BackendChoice>().unwrap(), c);
        }
        assert_eq!(BackendChoice::parse(" GPU ").unwrap(), BackendChoice::Gpu);
        let e = BackendChoice::parse("cuda").unwrap_err().to_string();
        assert!(e.contains("cuda") && e.contains("cpu, gpu or auto"), "{e}");
        assert_eq!(BackendChoice::default(), BackendChoice::Auto);
    }

    #[test]
    fn cpu_never_looks_for_a_gpu() {
        // An impossible request: the CPU choice must not even try it.
        let request = GpuRequest {
            storage_binding_bytes: u64::MAX,
            ..GpuRequest::default()
        };
        let r = BackendChoice::Cpu.resolve(&request).unwrap();
        assert_eq!(r.describe(), "CPU (asked for)");
    }
}
