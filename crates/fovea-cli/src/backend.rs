//! `--backend cpu|gpu|auto` (docs/gpu.md): maps the option to a device choice, takes the
//! world's GPU executors from `fovea_gpu::executors` and says what ran where. The GPU path
//! needs the `gpu` feature (without it `gpu` says how to rebuild and `auto` is the CPU).
//!
//! * `cpu`: no GPU is looked for.
//! * `gpu`: the best adapter there is (lavapipe included); none is a one-line error.
//! * `auto` (default): a hardware adapter when there is one, the CPU otherwise.

use std::sync::Arc;

use anyhow::Result;
use serde_json::{Map, Value};

use fovea_post::tonemap::ToneMapExecutor;
use fovea_render::pipeline::{
    ExecutorDevice, Executors, FrameContext, FrameStats, Lockstep, DEVICE_REPORT_KEYS,
};
use fovea_render::world::World;

use crate::choices::{BackendArg, LockstepArg};

/// What `--backend` resolved to: the device's description and the executors for the frames.
pub struct Backend {
    /// What was asked for.
    pub requested: BackendArg,
    /// One line: `GPU: <adapter>` or `CPU (<reason>)`.
    pub describe: String,
    /// The adapter and its driver, when a GPU runs stages.
    pub adapter: Option<String>,
    /// The adapter is a CPU device (lavapipe, llvmpipe, WARP): its times are CPU-emulated.
    pub cpu_emulated: bool,
    executors: Executors,
    /// The right eye's executors in lockstep ([`Backend::second_eye`]).
    second: Option<Executors>,
    /// The executor of the 8-bit output's tone curve and encoding.
    pub tone_map: Option<Box<dyn ToneMapExecutor>>,
    /// The GPU's device and the executors' times.
    pub device: Option<Arc<dyn ExecutorDevice>>,
    /// The device itself, for the resident frame (`fovea_gpu::frame::Route`; the viewer
    /// renders its resident frames and draws its window with it).
    #[cfg(feature = "gpu")]
    pub gpu: Option<fovea_gpu::GpuContext>,
}

impl Backend {
    /// Every stage on the CPU.
    fn cpu(requested: BackendArg, describe: String) -> Self {
        Self {
            requested,
            describe,
            adapter: None,
            cpu_emulated: false,
            executors: Executors::default(),
            second: None,
            tone_map: None,
            device: None,
            #[cfg(feature = "gpu")]
            gpu: None,
        }
    }

    /// Whether a GPU runs stages.
    pub fn on_gpu(&self) -> bool {
        self.device.is_some()
    }

    /// Moves the executors, if any, into a frame context.
    pub fn install(&mut self, ctx: &mut FrameContext) {
        let executors = self.take_executors();
        if !executors.is_empty() {
            ctx.set_executors(executors);
        }
    }

    /// The right eye's context of a binocular frame rendered in lockstep, and the device
    /// where both eyes' submissions meet; `None` on the CPU or with `lockstep` off (`auto`:
    /// on a hardware GPU only).
    pub fn second_eye(
        &mut self,
        lockstep: LockstepArg,
    ) -> Option<(FrameContext, Arc<dyn Lockstep + Send + Sync>)> {
        let on = match lockstep {
            LockstepArg::On => true,
            LockstepArg::Off => false,
            LockstepArg::Auto => !self.cpu_emulated,
        };
        let device = self.device.as_ref().filter(|_| on)?.lockstep();
        let mut ctx = FrameContext::new();
        ctx.set_executors(self.second.take()?);
        Some((ctx, device))
    }

    /// Moves the executors out (e.g. to the viewer's frame contexts).
    pub fn take_executors(&mut self) -> Executors {
        std::mem::take(&mut self.executors)
    }

    /// Whether the tone map ran on the GPU.
    pub fn tone_mapped(&self) -> bool {
        self.device.as_ref().is_some_and(|d| d.tone_mapped())
    }

    /// The JSON of the frame's stats: what was asked, what ran, which stage ran where.
    pub fn json(&self, frame: &FrameStats) -> Value {
        let per_stage: Map<String, Value> = fovea_render::pipeline::Stage::ALL
            .iter()
            .filter(|&&k| frame.stages_ms.ran(k))
            .map(|&k| (k.name().to_string(), frame.stage_backends.of(k).into()))
            .collect();
        let mut json = serde_json::json!({
            "requested": self.requested,
            "resolved": self.describe,
            "adapter": self.adapter,
            "stages": per_stage,
            "rays": {
                "generation": frame.ray_generation_backend,
                "primary": frame.trace_backend,
                "shadow": frame.shadow_backend,
            },
            "direct_light": frame.direct_light_backend,
            "tone_map": if self.tone_mapped() { "gpu" } else { "cpu" },
            "environment_light": frame.environment_light_backend,
            "dof": frame.dof_backend,
            "cpu_emulated": self.cpu_emulated,
            "surface": frame.surface_backend,
        });
        let gpu = self.device.as_ref().map(|d| d.report()).unwrap_or_default();
        for k in DEVICE_REPORT_KEYS {
            json[k] = gpu.get(k).cloned().unwrap_or(Value::Null);
        }
        json
    }
}

/// What `--backend` resolves to before any frame, without executors (`fovea bench` says
/// it first).
pub type Preflight = Backend;

/// Fails as [`resolve`] would for any frame when `--backend gpu` cannot run at all (no
/// `gpu` feature, no adapter); otherwise says what the frames will get.
pub fn preflight(requested: BackendArg) -> Result<Preflight> {
    open(requested, None)
}

/// Resolves `--backend` for the frames of `world`: the device, checked against the
/// world's largest binding before anything runs, and the world's GPU executors on it.
pub fn resolve(requested: BackendArg, world: &World) -> Result<Backend> {
    open(requested, Some(world))
}

#[cfg(not(feature = "gpu"))]
fn open(requested: BackendArg, _world: Option<&World>) -> Result<Backend> {
    match requested {
        BackendArg::Gpu => anyhow::bail!(
            "--backend gpu: this fovea was built without GPU support; rebuild with `cargo \
             build --release --features gpu` (Rust 1.87 or later), or use --backend cpu"
        ),
        BackendArg::Cpu => Ok(Backend::cpu(requested, "CPU (asked for)".into())),
        BackendArg::Auto => Ok(Backend::cpu(
            requested,
            "CPU (auto: built without the gpu feature)".into(),
        )),
    }
}

#[cfg(feature = "gpu")]
fn open(requested: BackendArg, world: Option<&World>) -> Result<Backend> {
    use fovea_gpu::{executors, BackendChoice, DeviceKind, Resolved};
    let choice = match requested {
        BackendArg::Cpu => return Ok(Backend::cpu(requested, "CPU (asked for)".into())),
        BackendArg::Gpu => BackendChoice::Gpu,
        BackendArg::Auto => BackendChoice::Auto,
    };
    let request = world.map(executors::request_for).unwrap_or_default();
    let resolved = choice.resolve(&request)?;
    let mut b = Backend::cpu(requested, resolved.describe());
    let Resolved::Gpu(ctx) = resolved else {
        return Ok(b);
    };
    b.adapter = Some(format!("{} — {}", ctx.adapter(), ctx.adapter().driver));
    b.cpu_emulated = ctx.adapter().kind == DeviceKind::Software;
    if let Some(world) = world {
        let gpu = executors::GpuExecutors::new(&ctx, world)?;
        (b.executors, b.second, b.tone_map) = (gpu.first, Some(gpu.second), Some(gpu.tone_map));
        b.device = Some(Arc::new(gpu.report));
    }
    b.gpu = Some(ctx);
    Ok(b)
}
