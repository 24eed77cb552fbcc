//! `fovea render --backend cpu|gpu|auto` (issue 18, docs/gpu.md): which executor runs which
//! stage of the frame. Today the GPU casts every method's rays — the trace stage's primary
//! rays (generated there from their screen points, polar or screen-aligned, and their closest
//! hits found through a BVH, `fovea_gpu::GpuTracer`) and the shade stage's shadow rays — and
//! computes the lights' part of direct shading (the BRDF, the lights' falloff, their
//! shadow rays: `GpuTracer::direct_light_timed`) and the environment's (its MIS estimator
//! with the CPU's random numbers, its shadow rays: `GpuTracer::environment_light_timed`),
//! and interpolates the surface at each primary hit from the scene's normals, UVs, materials
//! and textures uploaded beside the BVH (`fovea_gpu::GpuSurfaces`; textures larger than a
//! binding keep the surfaces on the CPU); it runs the sample-space AA filter (FXAA with the polar seam,
//! the 3×3 Gaussian; `fovea_gpu::GpuSampleAa`), the reconstruct stage's lookup of polar
//! buffers (VaFR, KFR, LaFR, visual-polar, liu-hybrid; `fovea_gpu::GpuReconstructor`) and
//! Weier's pull-push of its sparse screen samples (`fovea_gpu::GpuPullPush`; a screen whose
//! pyramid exceeds the device's storage binding is reconstructed on the CPU), and
//! the screen post's depth of field with the `gather` filter (the eye's CoC map and the
//! scatter-as-gather filter, thin-lens or stabilised CoC; `fovea_gpu::GpuDof`). Every other
//! stage runs on the CPU.
//!
//! * `cpu`: no GPU is looked for.
//! * `gpu`: the best adapter there is (lavapipe included); none is a one-line error, so a run
//!   that asked for the GPU never silently measures the CPU.
//! * `auto` (default): a hardware adapter when there is one, the CPU otherwise; a one-line
//!   notice says which and why.
//!
//! Both eyes of a Dup pair can render at the same time on one device, their passes in shared
//! submissions (`--lockstep`, [`Backend::second_eye`], `fovea_render::pipeline::lockstep`).
//!
//! The GPU path is compiled with the CLI's `gpu` feature (off by default: wgpu is a long
//! build). Without it `gpu` says how to rebuild and `auto` is the CPU.

use std::sync::{Arc, Mutex};

use anyhow::Result;
use serde::Serialize;

#[cfg(feature = "gpu")]
use fovea_core::mapping::FoveationMapping;
use fovea_post::tonemap::ToneMapExecutor;
use fovea_render::pipeline::{
    AaExecutor, DofExecutor, Executors, FrameContext, Lockstep, ReconstructExecutor, TraceExecutor,
};
use fovea_render::world::World;

use crate::choices::{BackendArg, LockstepArg};

/// The GPU reconstruction's own times of the last frame (ms), as JSON.
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

/// The GPU AA filter's own times (ms), as JSON: sums over its calls (one per sample buffer:
/// layers, eyes) since the slot was last taken.
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

/// The GPU tone map's times (ms), as JSON: sums over its calls (the images written).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GpuToneMs {
    /// Images encoded.
    pub calls: u32,
    /// Upload, passes, readback, wall ms, over all calls.
    pub total_ms: f64,
}

/// The GPU tracer's own times of a frame's primary rays (ms), as JSON: sums over the trace
/// stage's calls (one per chunk of texels) since the slot was last taken.
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

/// The GPU depth of field's own times of the last frame (ms), as JSON.
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

/// What `--backend` resolved to for one frame.
pub struct Backend {
    /// What was asked for.
    pub requested: BackendArg,
    /// One line: `GPU: <adapter>` or `CPU (<reason>)`.
    pub describe: String,
    /// The adapter, when a GPU runs a stage.
    pub adapter: Option<String>,
    /// The reconstruct executor to plug into the frame's context.
    pub executor: Option<Box<dyn ReconstructExecutor>>,
    /// The trace executor to plug into the frame's context.
    pub tracer: Option<Box<dyn TraceExecutor>>,
    /// The depth-of-field executor to plug into the frame's context.
    pub dof: Option<Box<dyn DofExecutor>>,
    /// The AA executor to plug into the frame's context.
    pub anti_aliaser: Option<Box<dyn AaExecutor>>,
    /// The sample-space denoiser to plug into the frame's context.
    pub denoiser: Option<Box<dyn fovea_render::pipeline::DenoiseExecutor>>,
    /// The executor of the 8-bit output's tone curve and encoding.
    pub tone_map: Option<Box<dyn ToneMapExecutor>>,
    /// The GPU's BVH, when it traces.
    pub gpu_bvh: Option<serde_json::Value>,
    /// The scene's surfaces on the GPU (what was uploaded), or why they stay on the CPU.
    pub gpu_surfaces: Option<serde_json::Value>,
    /// Filled by the executor after each frame.
    pub times: Arc<Mutex<Option<GpuReconstructMs>>>,
    /// Filled by the depth-of-field executor after each frame it ran.
    pub dof_times: Arc<Mutex<Option<GpuDofMs>>>,
    /// Filled by the AA executor: sums over its calls since the slot was last taken.
    pub aa_times: Arc<Mutex<Option<GpuAaMs>>>,
    /// Filled by the trace executor after each frame: its primary rays.
    pub trace_times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// Filled by the trace executor after each frame: the shade stage's shadow rays.
    pub shadow_times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// Filled by the trace executor after each frame: the lights' part of direct shading.
    pub direct_times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// Filled by the tone-map executor: sums over the images it encoded.
    pub tone_times: Arc<Mutex<Option<GpuToneMs>>>,
    /// Filled by the trace executor after each frame: the environment's part of direct
    /// shading.
    pub environment_times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// The adapter is a CPU device (lavapipe, llvmpipe, WARP): its times are CPU-emulated.
    pub cpu_emulated: bool,
    /// The right eye's executors for a binocular frame rendered in lockstep with the left's
    /// ([`Backend::second_eye`]): on the GPU, second handles to the same device objects.
    pub second: Option<Executors>,
    /// The device the executors share, where both eyes' submissions meet.
    pub device: Option<Arc<dyn SharedDevice>>,
}

impl Backend {
    fn cpu(requested: BackendArg, reason: &str) -> Self {
        Self::cpu_described(requested, format!("CPU ({reason})"))
    }

    /// Every stage on the CPU, with `describe` as the GPU resolution worded it.
    fn cpu_described(requested: BackendArg, describe: String) -> Self {
        Self {
            requested,
            describe,
            adapter: None,
            executor: None,
            tracer: None,
            dof: None,
            gpu_bvh: None,
            gpu_surfaces: None,
            times: Arc::default(),
            dof_times: Arc::default(),
            anti_aliaser: None,
            denoiser: None,
            tone_map: None,
            tone_times: Arc::default(),
            aa_times: Arc::default(),
            trace_times: Arc::default(),
            shadow_times: Arc::default(),
            direct_times: Arc::default(),
            environment_times: Arc::default(),
            cpu_emulated: false,
            second: None,
            device: None,
        }
    }

    /// Whether a GPU runs a stage (the rays, the AA, the reconstruction or the tone map).
    pub fn on_gpu(&self) -> bool {
        self.tracer.is_some()
            || self.executor.is_some()
            || self.anti_aliaser.is_some()
            || self.tone_map.is_some()
    }

    /// Moves the GPU executors, if any, into a frame context (each frame rendered with it
    /// then runs the stages they support on the GPU).
    pub fn install(&mut self, ctx: &mut FrameContext) {
        let executors = self.take_executors();
        if !executors.is_empty() {
            ctx.set_executors(executors);
        }
    }

    /// The right eye's context of a binocular frame whose eyes render in lockstep, its
    /// executors installed, and the device where both eyes' submissions meet; `None` on the
    /// CPU (the eyes render one after the other) or when `lockstep` is off (`auto`: on a
    /// hardware GPU only).
    pub fn second_eye(
        &mut self,
        lockstep: LockstepArg,
    ) -> Option<(FrameContext, Arc<dyn Lockstep + Send + Sync>)> {
        let on = match lockstep {
            LockstepArg::On => true,
            LockstepArg::Off => false,
            LockstepArg::Auto => !self.cpu_emulated,
        };
        if !on {
            return None;
        }
        let device = self.device.as_ref()?.lockstep();
        let executors = self.second.take()?;
        let mut ctx = FrameContext::new();
        ctx.set_executors(executors);
        Some((ctx, device))
    }

    /// Moves the GPU executors, if any, out (e.g. to the viewer's frame contexts).
    pub fn take_executors(&mut self) -> Executors {
        Executors {
            tracer: self.tracer.take(),
            reconstructor: self.executor.take(),
            dof: self.dof.take(),
            anti_aliaser: self.anti_aliaser.take(),
            denoiser: self.denoiser.take(),
        }
    }

    /// The JSON of the frame's stats: what was asked, what ran, which stage ran where.
    pub fn json(&self, frame: &fovea_render::pipeline::FrameStats) -> serde_json::Value {
        use fovea_render::pipeline::Stage;
        let (stages, reconstruct, trace) = (
            &frame.stages_ms,
            frame.reconstruct_backend.as_str(),
            frame.trace_backend.as_str(),
        );
        let per_stage: serde_json::Map<String, serde_json::Value> = Stage::ALL
            .iter()
            .filter(|&&k| stages.ran(k))
            .map(|&k| {
                let on = match k {
                    Stage::Reconstruct => reconstruct,
                    Stage::Trace => trace,
                    Stage::Dof => frame.dof_backend.as_str(),
                    Stage::Aa => frame.aa_backend.as_str(),
                    Stage::Denoise => frame.denoise_backend.as_str(),
                    _ => "cpu",
                };
                (k.name().to_string(), serde_json::Value::from(on))
            })
            .collect();
        let tone = *self.tone_times.lock().unwrap_or_else(|e| e.into_inner());
        serde_json::json!({
            "requested": self.requested,
            "resolved": self.describe,
            "adapter": self.adapter,
            "stages": per_stage,
            "gpu_reconstruct": *self.times.lock().unwrap_or_else(|e| e.into_inner()),
            "gpu_dof": *self.dof_times.lock().unwrap_or_else(|e| e.into_inner()),
            "gpu_aa": *self.aa_times.lock().unwrap_or_else(|e| e.into_inner()),
            "gpu_trace": *self.trace_times.lock().unwrap_or_else(|e| e.into_inner()),
            "gpu_shadow": *self.shadow_times.lock().unwrap_or_else(|e| e.into_inner()),
            "gpu_direct_light": *self.direct_times.lock().unwrap_or_else(|e| e.into_inner()),
            "gpu_environment_light":
                *self.environment_times.lock().unwrap_or_else(|e| e.into_inner()),
            "rays": {
                "generation": frame.ray_generation_backend,
                "primary": trace,
                "shadow": frame.shadow_backend,
            },
            "direct_light": frame.direct_light_backend,
            "tone_map": if tone.is_some() { "gpu" } else { "cpu" },
            "gpu_tone_map": tone,
            "environment_light": frame.environment_light_backend,
            "dof": frame.dof_backend,
            "cpu_emulated": self.cpu_emulated,
            "gpu_bvh": self.gpu_bvh,
            "surface": frame.surface_backend,
            "gpu_surfaces": self.gpu_surfaces,
            "gpu_submissions": self.device.as_ref().map(|d| d.submissions()),
            "gpu_traffic": self.device.as_ref().map(|d| d.traffic()),
        })
    }
}

/// The device the GPU executors share: where the submissions of both eyes rendered in
/// lockstep meet (`fovea_render::pipeline::lockstep`), and how its submissions went.
pub trait SharedDevice: Send + Sync {
    /// Submissions so far, as JSON: `submissions` (`Queue::submit` calls), `joint` (those
    /// that carried both eyes' work), `posted` (the passes' own submissions).
    fn submissions(&self) -> serde_json::Value;
    /// The device as the pipeline's meeting point of both eyes' submissions.
    fn lockstep(&self) -> Arc<dyn Lockstep + Send + Sync>;
    /// What the device moved and waited for so far, by counter (`fovea_gpu::traffic`):
    /// bytes uploaded and read back, buffers and bind groups created, buffer maps, blocking
    /// waits, submissions.
    fn traffic(&self) -> std::collections::BTreeMap<String, u64>;
}

#[cfg(feature = "gpu")]
impl SharedDevice for fovea_gpu::GpuContext {
    fn lockstep(&self) -> Arc<dyn Lockstep + Send + Sync> {
        Arc::new(self.clone())
    }

    fn submissions(&self) -> serde_json::Value {
        let c = self.submission_counts();
        serde_json::json!({
            "submissions": c.submissions,
            "joint": c.joint,
            "posted": c.posted,
            "timed_out": c.timed_out,
        })
    }

    fn traffic(&self) -> std::collections::BTreeMap<String, u64> {
        fovea_gpu::GpuContext::traffic(self)
            .named()
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect()
    }
}

/// Resolves `--backend` for the frames of `world`: on the GPU, every method's primary rays
/// (generated there), shadow rays, direct and environment light, AA, polar methods' and
/// Weier's reconstruction, the gather DOF and the tone map. The largest GPU
/// buffer every frame needs (the triangles) is checked against the adapter before anything
/// runs; a polar buffer too large for it (KFR at 8K on lavapipe) is reconstructed on the CPU,
/// frame by frame (`GpuReconstructor::fits`), and the frame's stats say so.
pub fn resolve(requested: BackendArg, world: &World) -> Result<Backend> {
    if requested == BackendArg::Cpu {
        return Ok(Backend::cpu(requested, "asked for"));
    }
    gpu(requested, world)
}

/// The error of `--backend gpu` in a build without the `gpu` feature.
#[cfg(not(feature = "gpu"))]
const NO_GPU_FEATURE: &str = "--backend gpu: this fovea was built without GPU support; rebuild \
     with `cargo build --release --features gpu` (Rust 1.87 or later), or use --backend cpu";

/// What `--backend` resolves to before any frame: which adapter a command that renders
/// several frames (`fovea bench`) will use, said before its first frame.
pub struct Preflight {
    /// One line: `GPU: <adapter>` or `CPU (<reason>)`.
    pub describe: String,
    /// The adapter and its driver, when there is a GPU.
    pub adapter: Option<String>,
    /// The adapter is a CPU device (lavapipe): GPU times are CPU-emulated.
    pub cpu_emulated: bool,
}

impl Preflight {
    fn cpu(reason: &str) -> Self {
        Self {
            describe: format!("CPU ({reason})"),
            adapter: None,
            cpu_emulated: false,
        }
    }

    /// What a GPU context offers: its adapter and driver, and whether it is a CPU device.
    #[cfg(feature = "gpu")]
    fn gpu(ctx: &fovea_gpu::GpuContext, describe: String) -> Self {
        Self {
            describe,
            adapter: Some(format!("{} — {}", ctx.adapter(), ctx.adapter().driver)),
            cpu_emulated: ctx.adapter().kind == fovea_gpu::DeviceKind::Software,
        }
    }
}

/// Fails as [`resolve`] would for any frame when `--backend gpu` cannot run at all (a build
/// without the `gpu` feature, no adapter), so a command that renders several frames (`fovea
/// bench`) says so before its first one; otherwise says what the frames will get.
#[cfg(not(feature = "gpu"))]
pub fn preflight(requested: BackendArg) -> Result<Preflight> {
    match requested {
        BackendArg::Gpu => anyhow::bail!(NO_GPU_FEATURE),
        BackendArg::Cpu => Ok(Preflight::cpu("asked for")),
        BackendArg::Auto => Ok(Preflight::cpu("auto: built without the gpu feature")),
    }
}

/// Fails as [`resolve`] would for any frame when `--backend gpu` cannot run at all (a build
/// without the `gpu` feature, no adapter), so a command that renders several frames (`fovea
/// bench`) says so before its first one; otherwise says what the frames will get.
#[cfg(feature = "gpu")]
pub fn preflight(requested: BackendArg) -> Result<Preflight> {
    use fovea_gpu::{BackendChoice, GpuRequest, Resolved};
    let choice = match requested {
        BackendArg::Cpu => return Ok(Preflight::cpu("asked for")),
        BackendArg::Gpu => BackendChoice::Gpu,
        BackendArg::Auto => BackendChoice::Auto,
    };
    let resolved = choice.resolve(&GpuRequest::default())?;
    let describe = resolved.describe();
    Ok(match resolved {
        Resolved::Gpu(ctx) => Preflight::gpu(&ctx, describe),
        Resolved::Cpu { .. } => Preflight {
            describe,
            adapter: None,
            cpu_emulated: false,
        },
    })
}

#[cfg(not(feature = "gpu"))]
fn gpu(requested: BackendArg, _world: &World) -> Result<Backend> {
    if requested == BackendArg::Gpu {
        anyhow::bail!(NO_GPU_FEATURE);
    }
    Ok(Backend::cpu(
        requested,
        "auto: built without the gpu feature",
    ))
}

#[cfg(feature = "gpu")]
fn gpu(requested: BackendArg, world: &World) -> Result<Backend> {
    use fovea_gpu::{BackendChoice, GpuDof, GpuReconstructor, GpuRequest, GpuTracer, Resolved};
    let choice = match requested {
        BackendArg::Gpu => BackendChoice::Gpu,
        _ => BackendChoice::Auto,
    };
    // The largest binding every frame needs: the triangles.
    let bytes = world.tris.len() as u64 * fovea_gpu::trace::TRIANGLE_BYTES;
    let request = GpuRequest {
        storage_binding_bytes: bytes,
        buffer_bytes: bytes,
        ..GpuRequest::default()
    };
    let resolved = choice.resolve(&request)?;
    let describe = resolved.describe();
    let ctx = match resolved {
        Resolved::Gpu(ctx) => ctx,
        Resolved::Cpu { .. } => return Ok(Backend::cpu_described(requested, describe)),
    };
    let facts = Preflight::gpu(&ctx, describe);
    let tris = world.tris.vertex_arrays();
    let tracer = GpuTracer::new(&ctx, &tris)?;
    let s = tracer.stats();
    let gpu_bvh = serde_json::json!({
        "triangles": s.triangles,
        "nodes": s.nodes,
        "depth": s.depth,
        "build_ms": s.build_ms,
    });
    // The scene's normals, UVs, materials and textures beside the BVH, unless the device
    // cannot hold them (the surfaces are then interpolated on the CPU, as the stats say).
    let (surfaces, gpu_surfaces) = match fovea_gpu::GpuSurfaces::new(&tracer, world) {
        Ok(surfaces) => {
            let s = surfaces.stats();
            let json = serde_json::json!({
                "triangles": s.triangles,
                "vertices": s.vertices,
                "materials": s.materials,
                "textures": s.textures,
                "mip_levels": s.mip_levels,
                "bytes": s.bytes,
                "texel_bytes": s.texel_bytes,
                "upload_ms": s.upload_ms,
            });
            (Some(Arc::new(surfaces)), json)
        }
        Err(
            e @ (fovea_gpu::GpuError::AdapterTooSmall { .. } | fovea_gpu::GpuError::Unsupported(_)),
        ) => (None, serde_json::json!({ "on_cpu_because": e.to_string() })),
        Err(e) => return Err(e.into()),
    };
    let times = Arc::new(Mutex::new(None));
    let trace_times = Arc::new(Mutex::new(None));
    let shadow_times = Arc::new(Mutex::new(None));
    let direct_times = Arc::new(Mutex::new(None));
    let environment_times = Arc::new(Mutex::new(None));
    let environment = Arc::new(fovea_gpu::GpuEnvironment::new(
        &ctx,
        &world.scene.environment,
    )?);
    let dof_times = Arc::new(Mutex::new(None));
    let executor = GpuExecutor {
        gpu: Arc::new(GpuReconstructor::new(&ctx)?),
        times: times.clone(),
    };
    let dof = GpuDofExecutor {
        gpu: Arc::new(GpuDof::new(&ctx)?),
        times: dof_times.clone(),
    };
    let tone_times = Arc::new(Mutex::new(None));
    let tone_map = GpuToneExecutor {
        gpu: fovea_gpu::GpuToneMap::new(&ctx)?,
        times: tone_times.clone(),
    };
    let aa_times = Arc::new(Mutex::new(None));
    let anti_aliaser = GpuAaExecutor {
        gpu: Arc::new(fovea_gpu::GpuSampleAa::new(&ctx)?),
        times: aa_times.clone(),
    };
    let tracer = GpuTraceExecutor {
        gpu: Arc::new(tracer),
        surfaces,
        fingerprint: world.tris_fingerprint,
        times: trace_times.clone(),
        shadow_times: shadow_times.clone(),
        direct_times: direct_times.clone(),
        environment,
        environment_times: environment_times.clone(),
    };
    // The right eye's executors in lockstep: second handles to the same device objects.
    let second = Executors {
        tracer: Some(Box::new(tracer.clone())),
        reconstructor: Some(Box::new(executor.clone())),
        dof: Some(Box::new(dof.clone())),
        // Its own AA: the filter keeps the tables of the last grid it ran, and each eye's
        // grid follows its own gaze.
        anti_aliaser: Some(Box::new(GpuAaExecutor {
            gpu: Arc::new(fovea_gpu::GpuSampleAa::new(&ctx)?),
            times: aa_times.clone(),
        })),
        denoiser: Some(Box::new(fovea_gpu::executors::GpuDenoiseExecutor::new(
            &ctx,
        )?)),
    };
    Ok(Backend {
        requested,
        describe: facts.describe,
        adapter: facts.adapter,
        executor: Some(Box::new(executor)),
        anti_aliaser: Some(Box::new(anti_aliaser)),
        denoiser: Some(Box::new(fovea_gpu::executors::GpuDenoiseExecutor::new(
            &ctx,
        )?)),
        tone_map: Some(Box::new(tone_map)),
        tone_times,
        tracer: Some(Box::new(tracer)),
        second: Some(second),
        device: Some(Arc::new(ctx)),
        dof: Some(Box::new(dof)),
        gpu_bvh: Some(gpu_bvh),
        gpu_surfaces: Some(gpu_surfaces),
        times,
        dof_times,
        aa_times,
        trace_times,
        shadow_times,
        direct_times,
        environment_times,
        cpu_emulated: facts.cpu_emulated,
    })
}

/// `fovea_gpu::GpuTracer` as the pipeline's trace executor, for the world it was built from.
#[cfg(feature = "gpu")]
#[derive(Clone)]
struct GpuTraceExecutor {
    gpu: Arc<fovea_gpu::GpuTracer>,
    /// The world's surfaces on the device (`None`: interpolated on the CPU).
    surfaces: Option<Arc<fovea_gpu::GpuSurfaces>>,
    fingerprint: u64,
    /// The primary rays' times.
    times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// The shadow rays' times.
    shadow_times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// The direct-light passes' times.
    direct_times: Arc<Mutex<Option<GpuTraceMs>>>,
    /// The world's environment on the device.
    environment: Arc<fovea_gpu::GpuEnvironment>,
    /// The environment-light passes' times.
    environment_times: Arc<Mutex<Option<GpuTraceMs>>>,
}

#[cfg(feature = "gpu")]
impl GpuTraceExecutor {
    /// `camera` as the ray-generation shader reads it, screen points measured from `origin_px`.
    fn ray_gen_camera(
        camera: &fovea_render::camera::EyeCamera,
        origin_px: [f64; 2],
    ) -> fovea_gpu::RayGenCamera {
        fovea_gpu::RayGenCamera::new(
            camera.position.into(),
            [camera.forward.into(), camera.right.into(), camera.up.into()],
            camera.focal_px(),
            camera.principal_point_px(),
            origin_px,
        )
    }

    /// The rays in the GPU's layout.
    fn gpu_rays(rays: &[fovea_render::bvh::Ray]) -> Vec<fovea_gpu::GpuRay> {
        rays.iter()
            .map(|r| fovea_gpu::GpuRay {
                origin: r.origin.into(),
                t_min: r.t_min,
                dir: r.dir.into(),
                t_max: r.t_max,
            })
            .collect()
    }

    /// The generated rays' directions and hits in the renderer's types.
    fn generated_hits(
        out: Vec<fovea_gpu::ray_generation::GeneratedHit>,
    ) -> Vec<(glam::Vec3, Option<fovea_render::bvh::Hit>)> {
        out.into_iter()
            .map(|(dir, h)| {
                let hit = h.map(|h| fovea_render::bvh::Hit {
                    t: h.t,
                    tri: h.tri,
                    bary: glam::Vec2::from(h.bary),
                });
                (glam::Vec3::from(dir), hit)
            })
            .collect()
    }

    /// The surface pass over rays given by their two coordinates (polar `(r_px, turn)`
    /// around `origin_px`, or screen points from the screen's origin) and their cones.
    fn surfaces_of(
        &mut self,
        camera: &fovea_render::camera::EyeCamera,
        origin_px: [f64; 2],
        coords: impl Iterator<Item = [f32; 2]>,
        spreads: &[f32],
        polar: bool,
    ) -> std::result::Result<Vec<fovea_render::trace::GSample>, String> {
        let surfaces = self.surfaces.as_ref().ok_or("no surfaces on the GPU")?;
        let cam = Self::ray_gen_camera(camera, origin_px);
        let rays: Vec<fovea_gpu::GpuSurfaceRay> = coords
            .zip(spreads)
            .map(|([a, b], &spread)| fovea_gpu::GpuSurfaceRay { a, b, spread })
            .collect();
        let run = if polar {
            fovea_gpu::GpuTracer::surfaces_polar_timed
        } else {
            fovea_gpu::GpuTracer::surfaces_screen_timed
        };
        let (out, t) = run(&self.gpu, surfaces, &cam, &rays).map_err(|e| e.to_string())?;
        Self::add(&self.times, t);
        Ok(out)
    }

    /// Adds one call's times to a frame's: the stages call the tracer once per chunk of the
    /// frame's texels, and the frame's figures are the sums over its calls (a reader takes
    /// them once per frame).
    fn add(slot: &Mutex<Option<GpuTraceMs>>, t: fovea_gpu::trace::TraceTimes) {
        if let Ok(mut slot) = slot.lock() {
            let sum = slot.get_or_insert_with(GpuTraceMs::default);
            sum.gpu_pass_ms = match (sum.gpu_pass_ms, t.gpu_pass_ms) {
                (Some(a), Some(b)) => Some(a + b),
                (a, b) => a.or(b),
            };
            sum.batches += t.batches;
            sum.calls += 1;
            sum.total_ms += t.total_ms;
        }
    }
}

#[cfg(feature = "gpu")]
impl TraceExecutor for GpuTraceExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn serves(&self, world: &World) -> bool {
        world.tris_fingerprint == self.fingerprint
    }

    fn closest_hits(
        &mut self,
        rays: &[fovea_render::bvh::Ray],
    ) -> std::result::Result<Vec<Option<fovea_render::bvh::Hit>>, String> {
        let (hits, t) = self
            .gpu
            .closest_hits_timed(&Self::gpu_rays(rays))
            .map_err(|e| e.to_string())?;
        Self::add(&self.times, t);
        Ok(hits
            .into_iter()
            .map(|h| {
                h.map(|h| fovea_render::bvh::Hit {
                    t: h.t,
                    tri: h.tri,
                    bary: glam::Vec2::from(h.bary),
                })
            })
            .collect())
    }

    fn occluded(
        &mut self,
        rays: &[fovea_render::bvh::Ray],
    ) -> std::result::Result<Vec<bool>, String> {
        let (blocked, t) = self
            .gpu
            .occluded_timed(&Self::gpu_rays(rays))
            .map_err(|e| e.to_string())?;
        Self::add(&self.shadow_times, t);
        Ok(blocked)
    }

    fn generates_rays(&self) -> bool {
        true
    }

    fn closest_hits_polar(
        &mut self,
        camera: &fovea_render::camera::EyeCamera,
        centre: fovea_core::units::ScreenPoint,
        rays: &[fovea_render::pipeline::PolarRay],
    ) -> std::result::Result<Vec<(glam::Vec3, Option<fovea_render::bvh::Hit>)>, String> {
        let cam = Self::ray_gen_camera(camera, [centre.x_px, centre.y_px]);
        let polar: Vec<fovea_gpu::GpuPolarRay> = rays
            .iter()
            .map(|r| fovea_gpu::GpuPolarRay {
                r_px: r.r_px as f32,
                turn: r.turn as f32,
            })
            .collect();
        let (out, t) = self
            .gpu
            .closest_hits_polar_timed(&cam, &polar)
            .map_err(|e| e.to_string())?;
        Self::add(&self.times, t);
        Ok(Self::generated_hits(out))
    }

    fn closest_hits_screen(
        &mut self,
        camera: &fovea_render::camera::EyeCamera,
        points: &[fovea_core::units::ScreenPoint],
    ) -> std::result::Result<Vec<(glam::Vec3, Option<fovea_render::bvh::Hit>)>, String> {
        let cam = Self::ray_gen_camera(camera, [0.0, 0.0]);
        // Rounded to f32 as `EyeCamera::ray` rounds them.
        let screen: Vec<fovea_gpu::GpuScreenRay> = points
            .iter()
            .map(|p| fovea_gpu::GpuScreenRay {
                x_px: p.x_px as f32,
                y_px: p.y_px as f32,
            })
            .collect();
        let (out, t) = self
            .gpu
            .closest_hits_screen_timed(&cam, &screen)
            .map_err(|e| e.to_string())?;
        Self::add(&self.times, t);
        Ok(Self::generated_hits(out))
    }

    fn interpolates_surfaces(&self) -> bool {
        self.surfaces.is_some()
    }

    fn surfaces_polar(
        &mut self,
        camera: &fovea_render::camera::EyeCamera,
        centre: fovea_core::units::ScreenPoint,
        rays: &[fovea_render::pipeline::PolarRay],
        spreads: &[f32],
    ) -> std::result::Result<Vec<fovea_render::trace::GSample>, String> {
        let coords = rays.iter().map(|r| [r.r_px as f32, r.turn as f32]);
        self.surfaces_of(camera, [centre.x_px, centre.y_px], coords, spreads, true)
    }

    fn surfaces_screen(
        &mut self,
        camera: &fovea_render::camera::EyeCamera,
        points: &[fovea_core::units::ScreenPoint],
        spreads: &[f32],
    ) -> std::result::Result<Vec<fovea_render::trace::GSample>, String> {
        // Rounded to f32 as `EyeCamera::ray` rounds them.
        let coords = points.iter().map(|p| [p.x_px as f32, p.y_px as f32]);
        self.surfaces_of(camera, [0.0, 0.0], coords, spreads, false)
    }

    fn shades_direct_light(&self) -> bool {
        true
    }

    fn direct_light(
        &mut self,
        hits: &[&fovea_render::trace::GSample],
        lights: &[fovea_render::scene::Light],
    ) -> std::result::Result<Vec<(glam::Vec3, u32)>, String> {
        use fovea_gpu::{DirectLightModel, GpuLight, GpuSurface};
        let surfaces: Vec<GpuSurface> = hits.iter().map(|g| GpuSurface::of(g)).collect();
        let lights: Vec<GpuLight> = lights.iter().map(GpuLight::of).collect();
        let (out, t) = self
            .gpu
            .direct_light_timed(&surfaces, &lights, &DirectLightModel::RENDERER)
            .map_err(|e| e.to_string())?;
        Self::add(&self.direct_times, t);
        Ok(out
            .into_iter()
            .map(|d| (glam::Vec3::from(d.radiance), d.shadow_rays))
            .collect())
    }

    fn shades_environment(&self) -> bool {
        true
    }

    fn environment_light(
        &mut self,
        hits: &[&fovea_render::trace::GSample],
        keys: &[u64],
        samples: u32,
    ) -> std::result::Result<Vec<(glam::Vec3, u32)>, String> {
        if keys.len() != hits.len() {
            return Err(format!(
                "{} keys for {} surface samples",
                keys.len(),
                hits.len()
            ));
        }
        let surfaces: Vec<fovea_gpu::GpuSurface> = hits
            .iter()
            .zip(keys)
            .map(|(g, &k)| fovea_gpu::GpuSurface::keyed(g, k))
            .collect();
        let (out, t) = self
            .gpu
            .environment_light_timed(&surfaces, &self.environment, samples)
            .map_err(|e| e.to_string())?;
        Self::add(&self.environment_times, t);
        Ok(out
            .into_iter()
            .map(|e| (glam::Vec3::from(e.radiance), e.rays))
            .collect())
    }
}

/// `fovea_gpu::GpuReconstructor` as the pipeline's reconstruct executor.
#[cfg(feature = "gpu")]
#[derive(Clone)]
struct GpuExecutor {
    gpu: Arc<fovea_gpu::GpuReconstructor>,
    times: Arc<Mutex<Option<GpuReconstructMs>>>,
}

#[cfg(feature = "gpu")]
impl ReconstructExecutor for GpuExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(&self, mapping: &dyn FoveationMapping) -> bool {
        // A frame too large for the device (KFR's texels at 8K on lavapipe, a Weier pyramid
        // past one binding) is reconstructed on the CPU; the frame's stats say so.
        fovea_gpu::GpuReconstructor::supports(mapping) && self.gpu.fits(mapping)
    }

    fn reconstruct_into(
        &mut self,
        mapping: &dyn FoveationMapping,
        display: &fovea_core::display::DisplayProfile,
        samples: &fovea_post::inverse_map::SampleBuffers,
        filter: fovea_post::inverse_map::ReconstructFilter,
        color: &mut fovea_core::Image<fovea_post::Rgb>,
        depth: &mut fovea_core::Image<f32>,
    ) -> std::result::Result<(), String> {
        let t = self
            .gpu
            .reconstruct_into(mapping, display, samples, filter, color, depth)
            .map_err(|e| e.to_string())?;
        if let Ok(mut slot) = self.times.lock() {
            *slot = Some(GpuReconstructMs {
                tables_ms: t.tables_ms,
                upload_ms: t.upload_ms,
                run_and_readback_ms: t.run_and_readback_ms,
                gpu_pass_ms: t.gpu_pass_ms,
                bands: t.bands,
            });
        }
        Ok(())
    }
}

/// `fovea_gpu::GpuDof` as the pipeline's depth-of-field executor: the gather filter (its
/// default parameters, as `FilterKind::Gather` builds it) on the GPU's own CoC map.
#[cfg(feature = "gpu")]
#[derive(Clone)]
struct GpuDofExecutor {
    gpu: Arc<fovea_gpu::GpuDof>,
    times: Arc<Mutex<Option<GpuDofMs>>>,
}

#[cfg(feature = "gpu")]
impl DofExecutor for GpuDofExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(
        &self,
        filter: fovea_post::dof::FilterKind,
        coc_model: &fovea_post::dof::coc::CocModel,
    ) -> bool {
        filter == fovea_post::dof::FilterKind::Gather && fovea_gpu::GpuDof::supports_coc(coc_model)
    }

    fn fits(&self, width_px: u32, height_px: u32) -> bool {
        // A frame too large for the device (8K on lavapipe) is filtered on the CPU.
        self.gpu.fits(width_px, height_px)
    }

    fn depth_of_field(
        &mut self,
        filter: fovea_post::dof::FilterKind,
        coc: &fovea_post::dof::coc::CocParams,
        focus_m: f64,
        color: &fovea_core::Image<fovea_post::Rgb>,
        depth_m: &fovea_core::Image<f32>,
    ) -> std::result::Result<(fovea_core::Image<fovea_post::Rgb>, fovea_core::Image<f32>), String>
    {
        if filter != fovea_post::dof::FilterKind::Gather {
            return Err(format!(
                "the {} filter is not on the GPU; use --backend cpu",
                filter.name()
            ));
        }
        let gather = fovea_post::dof::gather::ScatterAsGather::default();
        let (blurred, coc_px, t) = self
            .gpu
            .coc_and_gather(
                &gather,
                coc,
                fovea_core::units::Metres(focus_m),
                color,
                depth_m,
            )
            .map_err(|e| e.to_string())?;
        if let Ok(mut slot) = self.times.lock() {
            *slot = Some(GpuDofMs {
                upload_ms: t.upload_ms,
                run_and_readback_ms: t.run_and_readback_ms,
                gpu_pass_ms: t.gpu_pass_ms,
                total_ms: t.total_ms,
            });
        }
        Ok((blurred, coc_px))
    }
}

/// `fovea_gpu::GpuSampleAa` as the pipeline's AA executor (FXAA and the Gaussian, on rect and
/// polar grids).
#[cfg(feature = "gpu")]
#[derive(Clone)]
struct GpuAaExecutor {
    gpu: Arc<fovea_gpu::GpuSampleAa>,
    /// The frame's AA times, summed over its layers until taken.
    times: Arc<Mutex<Option<GpuAaMs>>>,
}

#[cfg(feature = "gpu")]
impl AaExecutor for GpuAaExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(
        &self,
        mode: fovea_render::pipeline::AaMode,
        grid: &fovea_post::grid::Grid,
    ) -> bool {
        use fovea_render::pipeline::AaMode;
        // A buffer too large for the device (a full-resolution 8K frame with --aa forced)
        // is filtered on the CPU.
        matches!(mode, AaMode::Fxaa | AaMode::Gaussian) && self.gpu.fits(grid)
    }

    fn anti_alias(
        &mut self,
        mode: fovea_render::pipeline::AaMode,
        params: &fovea_post::fxaa::FxaaParams,
        grid: &fovea_post::grid::Grid,
        color: &fovea_core::Image<fovea_post::Rgb>,
    ) -> std::result::Result<fovea_core::Image<fovea_post::Rgb>, String> {
        use fovea_gpu::SampleFilter;
        use fovea_render::pipeline::AaMode;
        let filter = match mode {
            AaMode::Fxaa => SampleFilter::Fxaa(*params),
            AaMode::Gaussian => SampleFilter::Gaussian,
            other => {
                return Err(format!(
                    "AA mode {other:?} is not a filter; use --backend cpu"
                ))
            }
        };
        let (out, t) = self
            .gpu
            .run(color, grid, filter)
            .map_err(|e| e.to_string())?;
        if let Ok(mut slot) = self.times.lock() {
            let sum = slot.get_or_insert_with(GpuAaMs::default);
            sum.tables_ms += t.tables_ms;
            sum.upload_ms += t.upload_ms;
            sum.run_and_readback_ms += t.run_and_readback_ms;
            sum.gpu_pass_ms = match (sum.gpu_pass_ms, t.gpu_pass_ms) {
                (Some(a), Some(b)) => Some(a + b),
                (a, b) => a.or(b),
            };
            sum.layers += 1;
        }
        Ok(out)
    }
}

/// `fovea_gpu::GpuToneMap` as the output's tone-map executor (any size: bands of rows).
#[cfg(feature = "gpu")]
struct GpuToneExecutor {
    gpu: fovea_gpu::GpuToneMap,
    /// Sums over the images encoded.
    times: Arc<Mutex<Option<GpuToneMs>>>,
}

#[cfg(feature = "gpu")]
impl ToneMapExecutor for GpuToneExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn to_srgb8(
        &mut self,
        img: &fovea_core::Image<fovea_post::Rgb>,
        exposure_stops: f32,
        curve: fovea_post::tonemap::ToneCurve,
    ) -> std::result::Result<Vec<u8>, String> {
        let t = std::time::Instant::now();
        let bytes = self
            .gpu
            .to_srgb8(img, exposure_stops, curve)
            .map_err(|e| e.to_string())?;
        if let Ok(mut slot) = self.times.lock() {
            let sum = slot.get_or_insert_with(GpuToneMs::default);
            sum.calls += 1;
            sum.total_ms += t.elapsed().as_secs_f64() * 1e3;
        }
        Ok(bytes)
    }
}
