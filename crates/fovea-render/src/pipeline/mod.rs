//! One foveated frame, end to end (DESIGN.md "How a frame flows", VaFR Sec. 3.4 and 6). The
//! frame is a short script over stage functions, each in the file of its stage:
//!
//! | stage | where | reads | writes |
//! |---|---|---|---|
//! | 1. eye state | `crate::eye` | gaze sample, tracker | [`EyeState`] |
//! | 2. plan | `crate::plan` | settings, eye state | [`FramePlan`] (mapping, footprint, AA, culling) |
//! | 3–4. trace, shade | [`trace_shade`] | plan, world | sample buffers |
//! | 5. sample-space post | [`sample_post`] | plan, history | sample buffers (temporal, denoise, AA) |
//! | 6. reconstruct | `fovea_post::inverse_map` | plan, sample buffers | screen colour + depth |
//! | 7. screen post | [`screen_post`] | plan, screen | contrast, DOF, CoC |
//! | 8. output | here | everything | [`Frame`], [`FrameStats`] |
//!
//! [`in_lockstep`] runs two eyes' scripts at the same time, their device work submitted
//! together ([`lockstep`]).
//!
//! [`render_planned`] is the script; it reads the plan and writes into a [`FrameContext`]
//! that keeps the buffers from frame to frame. [`render_frame`] and friends are the
//! one-call forms for a single frame: they build the eye state, the plan and a context.
//!
//! Full resolution runs through the same code with the identity mapping: every pixel is a
//! sample, no AA, the buffer is the screen.

use rayon::prelude::*;
use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::FoveationMapping;
use fovea_core::Image;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;

use crate::camera::EyeCamera;
use crate::error::{RenderError, Result};
use crate::eye::{EyeState, FocusDistance};
use crate::plan::FramePlan;
use crate::temporal::{TemporalAccumulator, TemporalStats};
use crate::world::World;

pub mod backends;
pub mod context;
pub mod device;
pub mod lockstep;
pub mod reconstruct;
pub mod sample_post;
pub mod screen_post;
pub mod timing;
pub mod trace_shade;

pub use backends::{Placement, StageBackends};
pub use context::{Executors, FrameContext};
pub use device::{ExecutorDevice, DEVICE_REPORT_KEYS};
pub use fovea_core::mapping::footprint::sample_spread_rad;
pub use lockstep::{in_lockstep, Lockstep};
pub use reconstruct::ReconstructExecutor;
pub use sample_post::{AaExecutor, DenoiseExecutor};
pub use screen_post::DofExecutor;
pub use timing::{Stage, StageMs, StageTimes, Stopwatch};
pub use trace_shade::{PolarRay, TraceExecutor};

pub use crate::plan::memory_estimate;

pub use crate::settings::{default_memory_limit, AaMode, FrameSettings};

/// Per-frame statistics, as `fovea render` prints and writes to JSON.
#[derive(Clone, Debug, Serialize)]
pub struct FrameStats {
    /// Method name.
    pub method: String,
    /// Display width, pixels.
    pub width: u32,
    /// Display height, pixels.
    pub height: u32,
    /// Samples the mapping shades (`sample_count()`); buffer pixels whose centre maps off the
    /// screen (corners of layered and kernel mappings) get no ray, so `rays_primary` may be
    /// slightly lower.
    pub samples: u64,
    /// Primary rays.
    pub rays_primary: u64,
    /// Shadow rays towards lights.
    pub rays_shadow: u64,
    /// Shadow rays towards the environment (direct shading with the occluded environment
    /// light).
    pub rays_environment: u64,
    /// Bounce rays (path-traced mode).
    pub rays_bounce: u64,
    /// All rays.
    pub rays: u64,
    /// Wall time per stage that ran, milliseconds.
    pub stages_ms: StageMs,
    /// Total wall time, milliseconds.
    pub total_ms: f64,
    /// Processor time per stage, milliseconds, summed over threads (`CLOCK_PROCESS_CPUTIME_ID`;
    /// unlike wall time, it leaves out time the machine's hypervisor gave to other guests).
    pub stages_cpu_ms: StageMs,
    /// Total processor time, milliseconds, summed over threads.
    pub total_cpu_ms: f64,
    /// Sample buffers (width × height per layer).
    pub buffers: Vec<[u32; 2]>,
    /// Anti-aliasing used.
    pub aa: AaMode,
    /// Estimated peak memory of the frame's buffers, bytes.
    pub memory_bytes: u64,
    /// The eye state the frame was rendered for (gaze, focus and where it came from, pupil).
    pub eye: EyeState,
    /// Focus distance used for depth of field, metres (`null` without DOF and when focused at
    /// infinity; `eye.focus` says which).
    pub focus_m: Option<f64>,
    /// Samples that hit a surface and were shaded.
    pub samples_shaded: u64,
    /// Samples that hit a surface and were culled by the DOF roulette (Liu Eq. 11).
    pub samples_culled: u64,
    /// The DOF filter applied, if any.
    pub dof_filter: Option<String>,
    /// Temporal accumulation of this frame (in a sequence with accumulation on).
    pub temporal: Option<TemporalStats>,
    /// The inset boundary smoothing applied (inset frames whose periphery is an exact 2× or 4×
    /// subsampling of the screen; `null` otherwise).
    pub inset_smoothing: Option<String>,
    /// What the sample-space denoiser did (`null` when it is off).
    pub denoise: Option<fovea_post::denoise::DenoiseStats>,
    /// The backend that ran the sample-space denoiser: `cpu`, or the name of the
    /// [`sample_post::DenoiseExecutor`] in the frame's context (`gpu`); `cpu` when it is off.
    pub denoise_backend: String,
    /// Whether every screen pixel had samples (see [`FramePlan::covers_screen`]).
    pub covers_screen: bool,
    /// The backend that ran the sample-space AA filter (stage 5): `cpu`, or the name of the
    /// [`sample_post::AaExecutor`] in the frame's context (`gpu`); `cpu` without AA.
    pub aa_backend: String,
    /// The backend that ran the reconstruct stage's lookup: `cpu`, or the name of the
    /// [`reconstruct::ReconstructExecutor`] in the frame's context (`gpu`). Every other stage
    /// runs on the CPU.
    pub reconstruct_backend: String,
    /// The backend that cast the primary rays: `cpu`, or the name of the
    /// [`trace_shade::TraceExecutor`] in the frame's context (`gpu`).
    pub trace_backend: String,
    /// The backend that generated the primary rays (the camera's rays through their screen
    /// points, which the CPU's plan and mapping place): `cpu`, or the
    /// [`trace_shade::TraceExecutor`]'s name where it generates them itself — every method's,
    /// polar or screen-aligned ([`trace_shade::TraceExecutor::generates_rays`]).
    pub ray_generation_backend: String,
    /// The backend that interpolated the surface at each primary hit (the G-buffer record:
    /// normals, UVs, materials, textures with their mips): `cpu`, or the
    /// [`trace_shade::TraceExecutor`]'s name where it did
    /// ([`trace_shade::TraceExecutor::interpolates_surfaces`]).
    pub surface_backend: String,
    /// The backend that cast the shade stage's shadow rays (lights and environment): `cpu`,
    /// or the [`trace_shade::TraceExecutor`]'s name where it cast them (direct shading, one
    /// ray per texel, no DOF culling).
    pub shadow_backend: String,
    /// The backend that computed the lights' part of direct shading (their BRDF-weighted
    /// radiance behind their shadow rays): `cpu`, or the executor's name where it did.
    pub direct_light_backend: String,
    /// The backend that computed the environment's part of direct shading (its MIS
    /// estimator behind its shadow rays): `cpu`, or the executor's name where it did
    /// ([`trace_shade::TraceExecutor::shades_environment`]).
    pub environment_light_backend: String,
    /// The backend that ran the depth-of-field stage (CoC map and filter): `cpu`, or the
    /// name of the [`screen_post::DofExecutor`] in the frame's context where it supports the
    /// filter (`gpu` for `gather`).
    pub dof_backend: String,
    /// Where each stage ran and, where an executor was there but the CPU ran it, why:
    /// decided once before the first pass ([`StageBackends::decide`]); the nine
    /// `*_backend` names above are copied from it.
    pub stage_backends: StageBackends,
}

impl FrameStats {
    /// Records where the stages ran: `backends`, and the `*_backend` names from it.
    pub fn set_backends(&mut self, backends: StageBackends) {
        let name = |p: &Placement| p.backend.clone();
        self.ray_generation_backend = name(&backends.ray_generation);
        self.trace_backend = name(&backends.trace);
        self.surface_backend = name(&backends.surface);
        self.shadow_backend = name(&backends.shadow);
        self.direct_light_backend = name(&backends.direct_light);
        self.environment_light_backend = name(&backends.environment_light);
        self.aa_backend = name(&backends.aa);
        self.reconstruct_backend = name(&backends.reconstruct);
        self.dof_backend = name(&backends.dof);
        self.denoise_backend = name(&backends.denoise);
        self.stage_backends = backends;
    }
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Linear RGB at display resolution.
    pub color: Image<Rgb>,
    /// Depth along the view axis, metres (∞ where nothing was hit).
    pub depth: Image<f32>,
    /// Samples per screen pixel predicted by the mapping's shading rates (when asked).
    pub density: Option<Image<f32>>,
    /// Signed circle of confusion per pixel (with depth of field), pixels.
    pub coc: Option<Image<f32>>,
    /// Counts and timings.
    pub stats: FrameStats,
    /// The shaded sample buffers before AA (when [`FrameSettings::keep_samples`]).
    pub samples: Option<SampleBuffers>,
}

/// Sample values known before tracing (e.g. warped from the other eye): texels whose `known`
/// flag is set get no ray and keep `color` and `depth`.
#[derive(Clone, Debug)]
pub struct Prefill {
    /// Colour per layer, the mapping's buffer sizes.
    pub color: Vec<Image<Rgb>>,
    /// Depth per layer.
    pub depth: Vec<Image<f32>>,
    /// Which texels are known.
    pub known: Vec<Image<bool>>,
}

/// The eye state and plan of a single frame looking at `gaze` (focus from the settings'
/// policy), with the time both took as the plan stage.
pub fn plan_frame(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    gaze: Gaze,
    jitter_texels: [f64; 2],
) -> Result<(FramePlan, StageTimes)> {
    let mut times = StageTimes::default();
    let t = Stopwatch::start();
    settings.validate()?;
    let eye = EyeState::fixating(world, camera, gaze, settings.dof.as_ref())?;
    let plan = FramePlan::new(world, camera, settings, &eye, jitter_texels)?;
    times.add(Stage::Plan, &t);
    Ok((plan, times))
}

/// Renders one frame looking at `gaze`. `progress(done, total)` is called after each chunk of
/// samples.
pub fn render_frame(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    gaze: Gaze,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    let (plan, times) = plan_frame(world, camera, settings, gaze, [0.0, 0.0])?;
    render_alone(
        world,
        camera,
        &plan,
        FrameInputs::default(),
        times,
        progress,
    )
}

/// Renders one frame for a given eye state (gaze and focus already decided, e.g. a frame of a
/// sequence rendered again with other settings).
pub fn render_for_eye(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    eye: &EyeState,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    let mut times = StageTimes::default();
    let t = Stopwatch::start();
    let plan = FramePlan::new(world, camera, settings, eye, [0.0, 0.0])?;
    times.add(Stage::Plan, &t);
    render_alone(
        world,
        camera,
        &plan,
        FrameInputs::default(),
        times,
        progress,
    )
}

/// [`render_planned`] into a context of its own, the frame handed over.
pub fn render_alone(
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
    inputs: FrameInputs<'_>,
    times: StageTimes,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    let mut ctx = FrameContext::new();
    render_planned(&mut ctx, world, camera, plan, inputs, times, progress)?;
    Ok(ctx.take_frame().expect("render_planned stores its frame"))
}

/// Renders the next frame of a sequence with temporal accumulation, looking at `gaze`:
/// samples jittered in sample space, the previous frame (kept in `accumulator`) reprojected
/// and folded into the fresh samples before AA, and this frame kept for the next.
pub fn render_frame_temporal(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    gaze: Gaze,
    accumulator: &mut TemporalAccumulator,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    let jitter = accumulator.jitter(settings.method);
    let (plan, times) = plan_frame(world, camera, settings, gaze, jitter)?;
    // The accumulator's frame count is the frame index of its random numbers.
    let plan = plan.with_noise(crate::shade::FrameNoise::new(accumulator.frame(), 0));
    let inputs = FrameInputs {
        accumulator: Some(accumulator),
        prefill: None,
    };
    render_alone(world, camera, &plan, inputs, times, progress)
}

/// What a frame takes besides its plan: the temporal history, and texels known before
/// tracing.
#[derive(Default)]
pub struct FrameInputs<'a> {
    /// Temporal accumulation: the history to fold in, and to keep this frame in. The plan's
    /// jitter should be the accumulator's ([`TemporalAccumulator::jitter`]).
    pub accumulator: Option<&'a mut TemporalAccumulator>,
    /// Sample values known before tracing (binocular reprojection): only the other texels
    /// get rays.
    pub prefill: Option<&'a Prefill>,
}

/// Renders the frame of `plan` into `ctx` (reusing its buffers) and returns it. `times`
/// holds the time already spent on the frame (its plan); the stages add theirs.
pub fn render_planned<'c>(
    ctx: &'c mut FrameContext,
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
    inputs: FrameInputs<'_>,
    mut times: StageTimes,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<&'c Frame> {
    let t_total = Stopwatch::start();
    let FrameInputs {
        mut accumulator,
        prefill,
    } = inputs;
    if camera.display != plan.display {
        return Err(RenderError::invalid(
            "camera",
            &camera.display.name,
            format!("the display the plan was made for ({})", plan.display.name),
        ));
    }
    let known = prefill.map(|p| p.known.as_slice());
    // Where each stage runs, decided once from the executors and the plan.
    let backends = StageBackends::decide(ctx.executors(), world, plan);

    // 3–4. Trace and shade into the sample buffers.
    let (samples, tracer, mut guides) = ctx.samples_and_tracer(plan, prefill)?;
    let counts = trace_shade::trace_and_shade(
        world,
        camera,
        plan,
        known,
        samples,
        guides.as_deref_mut(),
        &mut times,
        tracer,
        &backends,
        progress,
    )?;

    // 5. Sample-space post: temporal accumulation, denoising, then anti-aliasing. With both,
    // the denoiser's Monte Carlo part follows the colour through the blend (the exact part
    // set aside before, the accumulated colour less it after).
    let temporal = match accumulator.as_deref_mut() {
        Some(acc) => {
            let t = Stopwatch::start();
            let mut guides = guides.filter(|_| plan.settings.denoise.is_some());
            if let Some(g) = guides.as_deref_mut() {
                sample_post::complement_part(samples, g);
            }
            let s = sample_post::accumulate(plan, camera, acc, samples, guides.as_deref_mut())?;
            if let Some(g) = guides {
                sample_post::complement_part(samples, g);
            }
            times.add(Stage::Temporal, &t);
            Some(s)
        }
        None => {
            // No history: no temporal variance (the denoiser's spatial estimate).
            if let Some(g) = guides {
                g.variance.clear();
            }
            None
        }
    };
    // Denoising, before the reconstruction magnifies the periphery's noise.
    let denoise = match plan.settings.denoise {
        Some(params) => {
            let t = Stopwatch::start();
            let (samples, guides, scratch, executor) = ctx.samples_and_denoiser();
            let executor = executor.filter(|_| backends.denoise.on_executor());
            let s = sample_post::denoise(plan, &params, samples, guides, scratch, executor)?;
            times.add(Stage::Denoise, &t);
            Some(s)
        }
        None => None,
    };
    let (samples, _, _, _) = ctx.samples_and_denoiser();
    let kept_samples = plan.settings.keep_samples.then(|| samples.clone());
    let (samples, anti_aliaser) = ctx.samples_and_anti_aliaser();
    let anti_aliaser = anti_aliaser.filter(|_| backends.aa.on_executor());
    times.time(Stage::Aa, || {
        sample_post::anti_alias(plan, &mut samples.color, anti_aliaser)
    })?;

    // 6. Reconstruct into the context's screen buffers.
    let (mut color, mut depth) = ctx.screen_buffers(plan)?;
    let t = Stopwatch::start();
    let (samples, executor) = ctx.samples_and_executor();
    let executor = executor.filter(|_| backends.reconstruct.on_executor());
    let inset_smoothing =
        reconstruct::reconstruct(plan, samples, &mut color, &mut depth, executor)?;
    times.add(Stage::Reconstruct, &t);
    if let Some(acc) = accumulator {
        let t = Stopwatch::start();
        acc.finish(plan, camera, &color, &depth)?;
        times.add(Stage::Temporal, &t);
    }

    // 7. Screen post: peripheral contrast, then depth of field.
    let t = Stopwatch::start();
    if let Some(enhanced) = screen_post::contrast(plan, &color)? {
        ctx.keep_spare(std::mem::replace(&mut color, enhanced));
        times.add(Stage::Contrast, &t);
    }
    let t = Stopwatch::start();
    let dof_executor = ctx.dof_executor().filter(|_| backends.dof.on_executor());
    let coc = match screen_post::depth_of_field(plan, camera, &color, &depth, dof_executor)? {
        Some(out) => {
            ctx.keep_spare(std::mem::replace(&mut color, out.color));
            times.add(Stage::Dof, &t);
            Some(out.coc_px)
        }
        None => None,
    };

    // 8. Output.
    let density = if plan.settings.density_view {
        Some(density_view(plan.mapping(), &plan.display, &plan.eye.gaze)?)
    } else {
        None
    };
    let (total_ms, total_cpu_ms) = t_total.elapsed_ms();
    let mut stats = frame_stats(plan, counts, times, temporal, total_ms, total_cpu_ms);
    stats.inset_smoothing = inset_smoothing.map(|s| s.name().to_string());
    stats.denoise = denoise;
    stats.set_backends(backends);
    Ok(ctx.store(Frame {
        color,
        depth,
        density,
        coc,
        stats,
        samples: kept_samples,
    }))
}

/// The frame's statistics from its plan, the trace's counts and the stage times (`total_*`
/// are the stages' wall and CPU time after the plan, to which the plan's are added).
fn frame_stats(
    plan: &FramePlan,
    counts: trace_shade::TraceCounts,
    times: StageTimes,
    temporal: Option<TemporalStats>,
    total_ms: f64,
    total_cpu_ms: f64,
) -> FrameStats {
    let settings = &plan.settings;
    let focus = plan.settings.dof.as_ref().and(plan.eye.focus);
    FrameStats {
        method: settings.method.name().to_string(),
        width: plan.display.width_px,
        height: plan.display.height_px,
        samples: plan.sample_count,
        rays_primary: counts.primary,
        rays_shadow: counts.secondary.shadow,
        rays_environment: counts.secondary.environment,
        rays_bounce: counts.secondary.bounce,
        rays: counts.primary + counts.secondary.total(),
        total_ms: total_ms + times.wall.get(Stage::Plan),
        total_cpu_ms: total_cpu_ms + times.cpu.get(Stage::Plan),
        stages_ms: times.wall,
        stages_cpu_ms: times.cpu,
        buffers: plan.buffers.iter().map(|b| [b.width, b.height]).collect(),
        aa: plan.aa,
        memory_bytes: plan.memory_bytes,
        eye: plan.eye,
        focus_m: focus.and_then(FocusDistance::finite_m),
        samples_shaded: counts.shaded,
        samples_culled: counts.culled,
        dof_filter: settings
            .dof
            .as_ref()
            .and_then(|d| d.filter.map(|k| k.name().to_string())),
        temporal,
        inset_smoothing: None,
        denoise: None,
        denoise_backend: sample_post::CPU.to_string(),
        covers_screen: plan.covers_screen,
        aa_backend: sample_post::CPU.to_string(),
        reconstruct_backend: reconstruct::CPU.to_string(),
        trace_backend: trace_shade::CPU.to_string(),
        ray_generation_backend: trace_shade::CPU.to_string(),
        surface_backend: trace_shade::CPU.to_string(),
        shadow_backend: trace_shade::CPU.to_string(),
        direct_light_backend: trace_shade::CPU.to_string(),
        environment_light_backend: trace_shade::CPU.to_string(),
        dof_backend: reconstruct::CPU.to_string(),
        stage_backends: StageBackends::default(),
    }
}

/// Samples per screen pixel predicted by the mapping's rates: `ρ_r ρ_t / (ppd(e)/2)²`.
pub fn density_view(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
) -> Result<Image<f32>> {
    let (w, h) = (display.width_px, display.height_px);
    let mut img = Image::new(w, h, 0.0f32)?;
    img.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, v) in row.iter_mut().enumerate() {
                let p = fovea_core::units::ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                let e = display.eccentricity(p, gaze).0;
                let screen = display.rectilinear_ppd(fovea_core::units::Degrees(e)) / 2.0;
                let rr = mapping.radial_rate_cpd(e).clamp(0.0, 1e6);
                let rt = mapping.tangential_rate_cpd(e).clamp(0.0, 1e6);
                *v = (rr * rt / (screen * screen)) as f32;
            }
        });
    Ok(img)
}
