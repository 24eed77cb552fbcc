//! The speed harness: the same view at several resolutions, full resolution against foveated
//! methods in one run — rays, per-stage wall and processor times, speedups (VaFR Sec. 6 and
//! Table 1's sample counts; Weier et al. 2018, Table 1's per-stage timings) — the primary-ray
//! throughput of each available BVH backend, the time of each depth-of-field filter on a
//! full-resolution frame (Konrad et al.'s per-pixel cost), and binocular frames as VaFR's Dup
//! (both eyes traced) and Rep (the right eye reprojected from the left, holes traced).
//!
//! Each method renders `warmup` untimed frames, then `frames` timed frames in one
//! [`FrameContext`] (the warm-up allocates the buffers the timed frames reuse); the median
//! timed frame is reported. Timing goes into the result, never into an assertion.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::Metres;
use fovea_core::Image;
use fovea_post::dof::coc::coc_map;
use fovea_post::dof::{DofInput, FilterKind};
use fovea_post::inverse_map::{reconstruct_into_with_kernel, PolarKernel, SampleBuffers};
use fovea_post::Rgb;
use fovea_render::bvh::{self, Backend, Ray};
use fovea_render::camera::{EyeCamera, HmdRig};
use fovea_render::dof::{auto_focus_m, coc_params, px_per_degree, DofSettings, FocusMode};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::trace_shade::{SHADE_BATCH, TRACE_BATCH};
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, FrameStats, Lockstep, Stage, StageMs,
    StageTimes, Stopwatch,
};
use fovea_render::plan::FramePlan;
use fovea_render::scene::Light;
use fovea_render::stereo::{fixating_eyes, render_stereo_in, SecondEye, StereoMode};
use fovea_render::world::World;
use glam::Vec3;

use crate::error::{EvalError, Result};

use super::median;

/// Most warm-up, timed frames, DOF and binocular repetitions.
pub const MAX_REPS: u32 = 1000;

/// The scene as the benchmark views it on each display: the world, whose lights may follow
/// the view (generated around the camera), and the head with both eyes.
pub trait BenchScene {
    /// The eye's camera on `display`, with the world set up for it.
    fn view(&mut self, display: &DisplayProfile) -> Result<EyeCamera>;
    /// The world as the last [`view`](Self::view) left it.
    fn world(&self) -> &World;
    /// The head rig (both eyes), for binocular frames.
    fn rig(&self) -> &HmdRig;
}

/// A world whose lights do not follow the view, seen by one eye of a head rig.
pub struct FixedScene<'a> {
    /// The world.
    pub world: &'a World,
    /// The head.
    pub rig: HmdRig,
    /// The eye that renders single-eye frames.
    pub eye: fovea_render::camera::Eye,
}

impl BenchScene for FixedScene<'_> {
    fn view(&mut self, display: &DisplayProfile) -> Result<EyeCamera> {
        Ok(self.rig.eye(self.eye, display)?)
    }
    fn world(&self) -> &World {
        self.world
    }
    fn rig(&self) -> &HmdRig {
        &self.rig
    }
}

/// Executors other than the CPU's for the benchmark's frames (`fovea bench --backend`, a GPU
/// that runs some stages): the harness hands each method's fresh [`FrameContext`] to
/// [`install`](Self::install) before its first frame, and asks after every frame for the
/// device's own times of it.
pub trait BenchExecutors {
    /// Before the first frame of a method on a display: puts the executors that serve frames
    /// of `plan` (that first frame's plan) into `ctx`, or nothing (the CPU runs every stage).
    fn install(&mut self, world: &World, plan: &FramePlan, ctx: &mut FrameContext) -> Result<()>;
    /// After each frame: the device's per-pass times of that frame, ms by pass name (e.g.
    /// `trace`, `reconstruct`); empty when nothing ran on a device.
    fn pass_ms(&mut self) -> BTreeMap<String, f64>;
    /// After [`Self::install`]: the right eye's context of a binocular Dup frame rendered in
    /// lockstep with the left's, its executors installed on the same device as `ctx`'s, and
    /// the device's meeting point for both eyes' submissions; `None` (the default): the eyes
    /// render one after the other.
    fn second_eye(&mut self) -> Option<(FrameContext, Arc<dyn Lockstep + Send + Sync>)> {
        None
    }
    /// The device's transfer counters so far, by name (bytes uploaded and read back,
    /// submissions, blocking waits, buffers and bind groups created; cumulative: the bench
    /// takes the difference around each frame); empty (the default) when nothing runs on a
    /// device.
    fn device_counters(&mut self) -> BTreeMap<String, u64> {
        BTreeMap::new()
    }
}

/// What a device moved during one frame: `after − before` of two
/// [`BenchExecutors::device_counters`] snapshots, counter by counter.
fn counters_since(
    before: &BTreeMap<String, u64>,
    after: &BTreeMap<String, u64>,
) -> BTreeMap<String, u64> {
    after
        .iter()
        .map(|(k, &v)| {
            (
                k.clone(),
                v.saturating_sub(before.get(k).copied().unwrap_or(0)),
            )
        })
        .collect()
}

/// Every stage on the CPU (what [`run`] uses).
pub struct CpuOnly;

impl BenchExecutors for CpuOnly {
    fn install(&mut self, _: &World, _: &FramePlan, _: &mut FrameContext) -> Result<()> {
        Ok(())
    }
    fn pass_ms(&mut self) -> BTreeMap<String, f64> {
        BTreeMap::new()
    }
}

/// Parameters of a benchmark.
#[derive(Clone, Debug, Serialize)]
pub struct BenchParams {
    /// Displays, in order. Default: the 2k, 4k, 8k and retinal presets.
    pub displays: Vec<DisplayProfile>,
    /// Methods compared with full resolution, which always runs first. Default: VaFR.
    pub methods: Vec<Method>,
    /// What every frame renders with besides its method: mapping parameters, shading, AA,
    /// memory limit (the method is replaced per run). Default: `FrameSettings::new(full)`.
    pub frame: FrameSettings,
    /// Primary rays per backend for the BVH throughput test on the first display (0 skips
    /// it). Default: 2,000,000.
    pub bvh_rays: u64,
    /// Depth-of-field filters to time on each display's full-resolution frame. Default: none.
    pub dof_filters: Vec<FilterKind>,
    /// The eye and focus of the DOF timing (its filter is ignored). Default: auto focus, the
    /// standard eye ([`DofSettings::new`]).
    pub dof: DofSettings,
    /// Timed repetitions of each DOF filter (the median is reported), 1 to 100. Default: 3.
    pub dof_reps: u32,
    /// Untimed frames per method before the timed ones, 0 to [`MAX_REPS`]. Default: 1.
    pub warmup: u32,
    /// Timed frames per method (the median frame is reported), 1 to [`MAX_REPS`]. Default: 1.
    pub frames: u32,
    /// Also time binocular frames of every foveated method as Dup and Rep. Default: no.
    pub stereo: bool,
    /// Timed repetitions of each binocular mode (alternating; medians), 1 to 100. Default: 3.
    pub stereo_reps: u32,
}

impl Default for BenchParams {
    fn default() -> Self {
        Self {
            displays: ["2k", "4k", "8k", "retinal"]
                .into_iter()
                .filter_map(|n| DisplayProfile::preset(n).ok())
                .collect(),
            methods: vec![Method::Vafr],
            frame: FrameSettings::new(Method::Full),
            bvh_rays: 2_000_000,
            dof_filters: Vec::new(),
            dof: DofSettings::new(None, FocusMode::Auto),
            dof_reps: 3,
            warmup: 1,
            frames: 1,
            stereo: false,
            stereo_reps: 3,
        }
    }
}

impl BenchParams {
    /// Checks every parameter: at least one valid display, the frame and DOF settings, and the
    /// repetition counts.
    pub fn validate(&self) -> Result<()> {
        if self.displays.is_empty() {
            return Err(EvalError::invalid(
                "res",
                "none",
                "at least one display (resolution or preset)",
            ));
        }
        for d in &self.displays {
            d.validate()?;
        }
        self.frame.validate()?;
        self.dof.validate()?;
        let count = |name: &str, v: u32, lo: u32, hi: u32| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(EvalError::invalid(name, v, format!("{lo} to {hi}")))
            }
        };
        count("dof-reps", self.dof_reps, 1, 100)?;
        count("stereo-reps", self.stereo_reps, 1, 100)?;
        count("warmup", self.warmup, 0, MAX_REPS)?;
        count("frames", self.frames, 1, MAX_REPS)?;
        Ok(())
    }

    /// The methods in run order: full resolution, then the others (each once).
    pub fn run_methods(&self) -> Vec<Method> {
        let mut methods = vec![Method::Full];
        for &m in &self.methods {
            if !methods.contains(&m) {
                methods.push(m);
            }
        }
        methods
    }
}

/// A ray rate: rays cast over wall time and over the process's CPU time.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RayRate {
    /// Rays cast.
    pub rays: u64,
    /// Millions of rays per second of wall time, all threads.
    pub mrays_per_s: f64,
    /// Millions of rays per CPU-second (the process's CPU time summed over its threads): what
    /// a machine shared with other work still measures.
    pub mrays_per_cpu_s: f64,
    /// The process's CPU time over the wall time (2.0: two cores busy throughout).
    pub cpu_share: f64,
}

impl RayRate {
    fn of(rays: u64, (wall_ms, cpu_ms): (f64, f64)) -> Self {
        Self {
            rays,
            mrays_per_s: rays as f64 / (wall_ms * 1e3).max(1e-9),
            mrays_per_cpu_s: rays as f64 / (cpu_ms * 1e3).max(1e-9),
            cpu_share: cpu_ms / wall_ms.max(1e-9),
        }
    }
}

/// One BVH backend's throughput: primary rays and shadow rays, one at a time and in the
/// batches the renderer casts (`fovea_render::pipeline::trace_shade`: [`TRACE_BATCH`]
/// neighbouring texels' primary rays; each light's shadow rays of [`SHADE_BATCH`]
/// neighbouring samples), measured side by side.
#[derive(Clone, Debug, Serialize)]
pub struct BvhThroughput {
    /// Backend name.
    pub backend: &'static str,
    /// Whether this build has it.
    pub available: bool,
    /// Build time, milliseconds (when available).
    pub build_ms: Option<f64>,
    /// Primary rays per second one at a time, millions, all threads (when available):
    /// `primary_single.mrays_per_s`.
    pub primary_mrays_per_s: Option<f64>,
    /// Primary rays one at a time (`RayCaster::intersect`).
    pub primary_single: Option<RayRate>,
    /// Primary rays in the renderer's batches (`RayCaster::intersect_batch`; Embree: one ray
    /// stream, traversed in packets).
    pub primary_batched: Option<RayRate>,
    /// Shadow rays from the primary hits towards every light, sample by sample, one ray at a
    /// time (how the renderer cast them before batching).
    pub shadow_single: Option<RayRate>,
    /// The same shadow rays light by light over batches of neighbouring samples
    /// (`RayCaster::occluded_batch`), as the renderer casts them.
    pub shadow_batched: Option<RayRate>,
    /// Whether the world uses this backend.
    pub chosen: bool,
}

/// One DOF filter's time on one frame.
#[derive(Clone, Debug, Serialize)]
pub struct DofTiming {
    /// Filter name.
    pub name: &'static str,
    /// Median wall time, milliseconds.
    pub ms: f64,
    /// Median wall time per megapixel, milliseconds.
    pub ms_per_megapixel: f64,
    /// This filter's time over the fastest filter's, measured in the same run.
    pub relative_to_fastest: f64,
}

/// The DOF filters timed on one display's full-resolution frame.
#[derive(Clone, Debug, Serialize)]
pub struct DofTimings {
    /// Display name.
    pub display: String,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Per filter.
    pub filters: Vec<DofTiming>,
}

/// A binocular frame of one method on one display, Dup against Rep (medians).
#[derive(Clone, Debug, Serialize)]
pub struct StereoTiming {
    /// Display name.
    pub display: String,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Method name.
    pub method: &'static str,
    /// Dup wall time, milliseconds.
    pub dup_ms: f64,
    /// Rep wall time, milliseconds.
    pub rep_ms: f64,
    /// Dup primary rays (both eyes).
    pub dup_rays_primary: u64,
    /// Rep primary rays (the left eye and the right eye's holes).
    pub rep_rays_primary: u64,
    /// Rep: right texels traced.
    pub rep_holes: u64,
    /// `rep_ms / dup_ms`.
    pub rep_over_dup_time: f64,
    /// `rep_rays_primary / dup_rays_primary`.
    pub rep_over_dup_rays: f64,
    /// The median Dup frame's per-pass times on a device, both eyes summed, ms by pass
    /// ([`BenchExecutors`]; empty when every stage ran on the CPU).
    pub dup_device_pass_ms: BTreeMap<String, f64>,
    /// The same for the median Rep frame.
    pub rep_device_pass_ms: BTreeMap<String, f64>,
    /// What the device moved during the median Dup frame (both eyes), by counter
    /// ([`BenchExecutors::device_counters`]; empty when every stage ran on the CPU).
    pub dup_device_traffic: BTreeMap<String, u64>,
    /// The same for the median Rep frame.
    pub rep_device_traffic: BTreeMap<String, u64>,
    /// Where the left eye's primary rays were cast (`cpu` or the executor's name).
    pub trace_backend: String,
    /// Whether Dup rendered both eyes at the same time, their device work in shared
    /// submissions ([`fovea_render::pipeline::lockstep`]); Rep always renders them in turn.
    pub dup_lockstep: bool,
}

/// Wall and CPU time of one timed piece of work, best of its repetitions.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct KernelTime {
    /// Wall milliseconds.
    pub wall_ms: f64,
    /// The process's CPU milliseconds, summed over its threads.
    pub cpu_ms: f64,
    /// `cpu_ms / wall_ms` (2.0: two cores busy throughout).
    pub cpu_share: f64,
}

impl KernelTime {
    /// What the bench compares: CPU milliseconds, or wall where the CPU clock is missing.
    pub fn cost_ms(&self) -> f64 {
        if self.cpu_ms.is_finite() {
            self.cpu_ms
        } else {
            self.wall_ms
        }
    }

    /// The fastest (by CPU time, wall where the CPU clock is missing) of `reps` runs of `f`.
    fn best_of(reps: u32, mut f: impl FnMut() -> Result<()>) -> Result<Self> {
        let mut best: Option<Self> = None;
        for _ in 0..reps.max(1) {
            let t = Stopwatch::start();
            f()?;
            let (wall_ms, cpu_ms) = t.elapsed_ms();
            let this = Self {
                wall_ms,
                cpu_ms,
                cpu_share: cpu_ms / wall_ms.max(1e-9),
            };
            if best.as_ref().is_none_or(|b| this.cost_ms() < b.cost_ms()) {
                best = Some(this);
            }
        }
        Ok(best.expect("at least one repetition"))
    }
}

/// The reconstruct stage of a polar method at memory speed, or not: the lookup on the frame's
/// mapping and display with each kernel this processor runs (`fovea_post::inverse_map`'s
/// [`PolarKernel`]s, same buffers, warm), beside the time to merely write the stage's output
/// (16 bytes per screen pixel: linear RGB and depth as `f32`) into the same buffers — the
/// floor no reconstruction can beat. Each figure is the best of [`RECONSTRUCT_REPS`].
#[derive(Clone, Debug, Serialize)]
pub struct ReconstructTiming {
    /// Bytes the stage writes.
    pub output_bytes: u64,
    /// Writing those bytes, all threads (the write-bandwidth floor).
    pub write_floor: KernelTime,
    /// Write bandwidth of the floor, GB/s (wall).
    pub write_gb_per_s: f64,
    /// The kernel the renderer uses ([`PolarKernel::detect`]).
    pub kernel: PolarKernel,
    /// Each kernel this processor runs: scalar, then vector.
    pub kernels: Vec<KernelRun>,
    /// The renderer's kernel over the floor, by CPU time (wall where CPU is missing).
    pub over_floor: f64,
}

/// One reconstruction kernel's time.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct KernelRun {
    /// The kernel.
    pub kernel: PolarKernel,
    /// Its time.
    #[serde(flatten)]
    pub time: KernelTime,
}

/// Repetitions of each reconstruction timing (the best is kept).
pub const RECONSTRUCT_REPS: u32 = 3;

/// [`ReconstructTiming`] of `plan`'s mapping (`None` for mappings without a polar buffer).
fn time_reconstruct(plan: &FramePlan) -> Result<Option<ReconstructTiming>> {
    let mapping = plan.mapping();
    if mapping.polar_layout().is_none() {
        return Ok(None);
    }
    let display = &plan.display;
    let (w, h) = (display.width_px, display.height_px);
    let n = w as usize * h as usize;
    let mut samples = SampleBuffers::random(mapping, 1)?;
    let mut color = Image::from_vec(w, h, fovea_post::alloc::zeroed::<Rgb>(n))?;
    let mut depth = Image::from_vec(w, h, fovea_post::alloc::zeroed::<f32>(n))?;
    let filter = plan.settings.reconstruct_filter;
    let kernel = PolarKernel::detect();
    let mut run = |k: PolarKernel, color: &mut Image<Rgb>, depth: &mut Image<f32>| {
        reconstruct_into_with_kernel(mapping, display, &mut samples, color, depth, filter, k)
            .map_err(EvalError::from)
    };
    // Untimed: faults the output's pages in.
    run(kernel, &mut color, &mut depth)?;
    let mut kernels = Vec::new();
    for k in [PolarKernel::Scalar, PolarKernel::Avx2] {
        if k.available() {
            let time = KernelTime::best_of(RECONSTRUCT_REPS, || run(k, &mut color, &mut depth))?;
            kernels.push(KernelRun { kernel: k, time });
        }
    }
    let wu = w as usize;
    let write_floor = KernelTime::best_of(RECONSTRUCT_REPS, || {
        color
            .data_mut()
            .par_chunks_mut(wu)
            .zip(depth.data_mut().par_chunks_mut(wu))
            .for_each(|(c, d)| {
                c.fill([0.25, 0.5, 0.75]);
                d.fill(1.0);
            });
        std::hint::black_box((&color, &depth));
        Ok(())
    })?;
    let output_bytes = (n * (std::mem::size_of::<Rgb>() + std::mem::size_of::<f32>())) as u64;
    let used = kernels
        .iter()
        .find(|r| r.kernel == kernel)
        .map(|r| r.time)
        .expect("the detected kernel is available");
    Ok(Some(ReconstructTiming {
        output_bytes,
        write_gb_per_s: output_bytes as f64 / (write_floor.wall_ms * 1e6).max(1e-9),
        over_floor: used.cost_ms() / write_floor.cost_ms().max(1e-9),
        write_floor,
        kernel,
        kernels,
    }))
}

/// One timed frame and its comparison with the full-resolution frame of the same display.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRun {
    /// The median timed frame's statistics.
    pub stats: FrameStats,
    /// Full-resolution wall time over this frame's.
    pub speedup: f64,
    /// Full-resolution CPU time over this frame's.
    pub speedup_cpu: f64,
    /// Share of the machine's time stolen by the hypervisor during the frames.
    pub steal: Option<f64>,
    /// The process's CPU time over wall time × threads: the share of its cores it got.
    pub cpu_share: f64,
    /// Screen buffers allocated during the timed frames (0: reused from the warm-up).
    pub screen_allocations: u64,
    /// The reconstruct stage's kernels against the write-bandwidth floor (polar methods).
    pub reconstruct: Option<ReconstructTiming>,
    /// The median frame's per-pass times on a device, ms by pass ([`BenchExecutors`];
    /// empty when every stage ran on the CPU).
    pub device_pass_ms: BTreeMap<String, f64>,
    /// What the device moved during the median frame, by counter
    /// ([`BenchExecutors::device_counters`]; empty when every stage ran on the CPU).
    pub device_traffic: BTreeMap<String, u64>,
}

impl BenchRun {
    /// Frames per second at the median frame's wall time.
    pub fn fps(&self) -> f64 {
        1000.0 / self.stats.total_ms
    }
}

/// Everything a benchmark measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchResult {
    /// Scene name.
    pub scene: String,
    /// Triangles.
    pub triangles: usize,
    /// Lights after the last view.
    pub lights: usize,
    /// The world's BVH backend.
    pub bvh: &'static str,
    /// Rayon threads.
    pub threads: usize,
    /// Per backend (empty when skipped).
    pub bvh_throughput: Vec<BvhThroughput>,
    /// Per display, with DOF filters asked for.
    pub dof: Vec<DofTimings>,
    /// Per display and foveated method, with stereo.
    pub binocular: Vec<StereoTiming>,
    /// Per display and method, in run order.
    pub runs: Vec<BenchRun>,
}

/// What the benchmark tells its observer as it goes.
#[derive(Clone, Copy, Debug)]
pub enum BenchEvent<'a> {
    /// A method's frames on a display start.
    Started {
        /// The display.
        display: &'a DisplayProfile,
        /// The method.
        method: Method,
    },
    /// Samples done of the frame being rendered (from the render threads).
    Samples {
        /// Done.
        done: u64,
        /// In all.
        total: u64,
    },
    /// The DOF filters were timed on a display's full-resolution frame.
    DofTimed(&'a DofTimings),
    /// A method's run ended.
    Run(&'a BenchRun),
    /// A binocular timing ended.
    Stereo(&'a StereoTiming),
}

/// Runs the benchmark on `scene`; `observe` hears each step (from several threads for
/// [`BenchEvent::Samples`]).
pub fn run(
    scene: &mut dyn BenchScene,
    params: &BenchParams,
    observe: &(dyn Fn(BenchEvent<'_>) + Sync),
) -> Result<BenchResult> {
    run_with(scene, params, &mut CpuOnly, observe)
}

/// [`run`] with `executors` installed into each method's frame context (the single-eye
/// frames; binocular timings and the DOF filters stay on the CPU).
pub fn run_with(
    scene: &mut dyn BenchScene,
    params: &BenchParams,
    executors: &mut dyn BenchExecutors,
    observe: &(dyn Fn(BenchEvent<'_>) + Sync),
) -> Result<BenchResult> {
    params.validate()?;
    let methods = params.run_methods();
    let backend_name = scene.world().caster.backend().name();
    let mut result = BenchResult {
        scene: String::new(),
        triangles: 0,
        lights: 0,
        bvh: backend_name,
        threads: rayon::current_num_threads(),
        bvh_throughput: Vec::new(),
        dof: Vec::new(),
        binocular: Vec::new(),
        runs: Vec::new(),
    };
    for (k, display) in params.displays.iter().enumerate() {
        let camera = scene.view(display)?;
        let world = scene.world();
        if k == 0 && params.bvh_rays > 0 {
            result.bvh_throughput = bvh_throughput(world, &camera, params.bvh_rays)?;
        }
        let gaze = display.centre_gaze();
        let mut full: Option<(f64, f64)> = None;
        for &m in &methods {
            let mut s = params.frame.clone();
            s.method = m;
            observe(BenchEvent::Started { display, method: m });
            let jiffies = machine_jiffies();
            // Warm-up frames (untimed: they allocate the context's buffers), then the timed
            // frames with the same context; the median frame's statistics are kept.
            let eye = EyeState::looking_at(gaze);
            let mut ctx = FrameContext::new();
            // Each timed frame's stats, device pass times and device traffic.
            type Timed = (FrameStats, BTreeMap<String, f64>, BTreeMap<String, u64>);
            let mut timed: Vec<Timed> = Vec::new();
            let mut allocations_after_warmup = 0;
            let mut last_plan = None;
            for k in 0..params.warmup + params.frames {
                if k == params.warmup {
                    allocations_after_warmup = ctx.screen_allocations();
                }
                let mut times = StageTimes::default();
                let t = Stopwatch::start();
                let plan = FramePlan::new(world, &camera, &s, &eye, [0.0, 0.0])?;
                times.add(Stage::Plan, &t);
                if k == 0 {
                    executors.install(world, &plan, &mut ctx)?;
                }
                let counters = executors.device_counters();
                let frame = render_planned(
                    &mut ctx,
                    world,
                    &camera,
                    &plan,
                    FrameInputs::default(),
                    times,
                    &|done, total| observe(BenchEvent::Samples { done, total }),
                )?;
                let device_ms = executors.pass_ms();
                let traffic = counters_since(&counters, &executors.device_counters());
                if k >= params.warmup {
                    timed.push((frame.stats.clone(), device_ms, traffic));
                }
                last_plan = Some(plan);
            }
            let screen_allocations = ctx.screen_allocations() - allocations_after_warmup;
            timed.sort_by(|a, b| a.0.total_ms.total_cmp(&b.0.total_ms));
            let (stats, device_pass_ms, device_traffic) = timed.swap_remove(timed.len() / 2);
            // The images are freed with the context, except the full frame's while DOF
            // filters are timed on it.
            if m == Method::Full && !params.dof_filters.is_empty() {
                // `frames` ≥ 1 (validated), so the context holds the last timed frame.
                let frame = ctx.frame().expect("a timed frame was rendered");
                let timings = DofTimings {
                    display: display.name.clone(),
                    width: display.width_px,
                    height: display.height_px,
                    filters: time_dof_filters(
                        world,
                        &camera,
                        &gaze,
                        &params.dof,
                        &frame.color,
                        &frame.depth,
                        &params.dof_filters,
                        params.dof_reps,
                    )?,
                };
                observe(BenchEvent::DofTimed(&timings));
                result.dof.push(timings);
            }
            drop(ctx);
            let steal = steal_fraction(jiffies, machine_jiffies());
            // After the frames' own timing (its steal window closed above).
            let reconstruct = match &last_plan {
                Some(plan) => time_reconstruct(plan)?,
                None => None,
            };
            if m == Method::Full {
                full = Some((stats.total_ms, stats.total_cpu_ms));
            }
            let run = BenchRun {
                speedup: full.map_or(1.0, |f| f.0 / stats.total_ms),
                speedup_cpu: full.map_or(1.0, |f| f.1 / stats.total_cpu_ms),
                cpu_share: stats.total_cpu_ms
                    / (stats.total_ms * rayon::current_num_threads() as f64),
                screen_allocations,
                steal,
                stats,
                reconstruct,
                device_pass_ms,
                device_traffic,
            };
            observe(BenchEvent::Run(&run));
            result.runs.push(run);
        }
        if params.stereo {
            for &m in methods.iter().filter(|&&m| m != Method::Full) {
                let row = time_stereo(
                    world,
                    scene.rig(),
                    display,
                    m,
                    &params.frame,
                    params.stereo_reps,
                    executors,
                )?;
                observe(BenchEvent::Stereo(&row));
                result.binocular.push(row);
            }
        }
    }
    let world = scene.world();
    result.scene = world.scene.name.clone();
    result.triangles = world.tris.len();
    result.lights = world.lights.len();
    Ok(result)
}

impl BenchResult {
    /// The JSON of `fovea bench --json`.
    pub fn to_json(&self) -> serde_json::Value {
        let bvh: Vec<serde_json::Value> = self
            .bvh_throughput
            .iter()
            .map(|b| {
                if b.available {
                    serde_json::json!({
                        "backend": b.backend, "available": true,
                        "build_ms": b.build_ms, "primary_mrays_per_s": b.primary_mrays_per_s,
                        "primary_single": b.primary_single,
                        "primary_batched": b.primary_batched,
                        "shadow_single": b.shadow_single,
                        "shadow_batched": b.shadow_batched,
                        "chosen": b.chosen,
                    })
                } else {
                    serde_json::json!({
                        "backend": b.backend, "available": false,
                        "note": "build with --features embree (Debian libembree-dev)",
                    })
                }
            })
            .collect();
        serde_json::json!({
            "scene": self.scene,
            "triangles": self.triangles,
            "lights": self.lights,
            "bvh": self.bvh,
            "threads": self.threads,
            "bvh_throughput": bvh,
            "dof": self.dof,
            "binocular": self.binocular,
            "runs": self.runs.iter().map(|r| {
                let s = &r.stats;
                let post = |st: &StageMs| st.sum(&[Stage::Aa, Stage::Reconstruct]);
                // The denoise stage where it ran (the CPU, or the GPU's upload, passes and
                // readback), its wall and CPU ms, and the frame without it.
                let denoise_stage = serde_json::json!({
                    "backend": s.denoise_backend,
                    "ms": s.stages_ms.get(Stage::Denoise),
                    "cpu_ms": s.stages_cpu_ms.get(Stage::Denoise),
                    "frame_ms_without": s.total_ms - s.stages_ms.get(Stage::Denoise),
                    "frame_cpu_ms_without": s.total_cpu_ms - s.stages_cpu_ms.get(Stage::Denoise),
                });
                serde_json::json!({
                    "method": s.method,
                    "width": s.width,
                    "height": s.height,
                    "samples": s.samples,
                    "rays": s.rays,
                    "rays_primary": s.rays_primary,
                    "rays_shadow": s.rays_shadow,
                    "rays_environment": s.rays_environment,
                    "rays_bounce": s.rays_bounce,
                    "total_ms": s.total_ms,
                    "stages_ms": s.stages_ms,
                    "cpu_ms": s.total_cpu_ms,
                    "stages_cpu_ms": s.stages_cpu_ms,
                    "post_fraction": post(&s.stages_ms) / s.total_ms,
                    "post_fraction_cpu": post(&s.stages_cpu_ms) / s.total_cpu_ms,
                    // The sample-space denoiser's share of the frame (0 when it is off).
                    "denoise_fraction": s.stages_ms.get(Stage::Denoise) / s.total_ms,
                    "denoise_fraction_cpu": s.stages_cpu_ms.get(Stage::Denoise) / s.total_cpu_ms,
                    "denoise_stage": denoise_stage,
                    "speedup_vs_full": r.speedup,
                    "speedup_vs_full_cpu": r.speedup_cpu,
                    "fps": r.fps(),
                    "stage_backends": {
                        "trace": s.trace_backend,
                        "surface": s.surface_backend,
                        "shadow_rays": s.shadow_backend,
                        "direct_light": s.direct_light_backend,
                        "environment_light": s.environment_light_backend,
                        "aa": s.aa_backend,
                        "reconstruct": s.reconstruct_backend,
                    },
                    "gpu_pass_ms": r.device_pass_ms,
                    "gpu_traffic_per_frame": r.device_traffic,
                    // The render thread's own time on the frame: its wall time less the
                    // time it sat blocked in submits and waits for the device.
                    "host_ms_unblocked": r.device_traffic.get("blocked_ns")
                        .map(|&ns| s.total_ms - ns as f64 / 1e6),
                    "machine_steal_fraction": r.steal,
                    "cpu_share": r.cpu_share,
                    "screen_allocations_after_warmup": r.screen_allocations,
                    "reconstruct_kernels": r.reconstruct,
                })
            }).collect::<Vec<_>>(),
        })
    }
}

/// Builds each backend on the world's triangles and measures its primary-ray throughput
/// through `camera`.
fn bvh_throughput(world: &World, camera: &EyeCamera, rays: u64) -> Result<Vec<BvhThroughput>> {
    let chosen = world.caster.backend().name();
    let mut out = Vec::new();
    for b in [Backend::Obvhs, Backend::Embree] {
        if !b.available() {
            out.push(BvhThroughput {
                backend: b.name(),
                available: false,
                build_ms: None,
                primary_mrays_per_s: None,
                primary_single: None,
                primary_batched: None,
                shadow_single: None,
                shadow_batched: None,
                chosen: false,
            });
            continue;
        }
        let t = Instant::now();
        let caster = bvh::build(b, &world.tris)?;
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = Throughputs::measure(caster.as_ref(), world, camera, rays);
        out.push(BvhThroughput {
            backend: b.name(),
            available: true,
            build_ms: Some(build_ms),
            primary_mrays_per_s: Some(t.primary_single.mrays_per_s),
            primary_single: Some(t.primary_single),
            primary_batched: Some(t.primary_batched),
            shadow_single: t.shadow_single,
            shadow_batched: t.shadow_batched,
            chosen: b.name() == chosen,
        });
    }
    Ok(out)
}

/// The four rates of one backend.
struct Throughputs {
    primary_single: RayRate,
    primary_batched: RayRate,
    shadow_single: Option<RayRate>,
    shadow_batched: Option<RayRate>,
}

impl Throughputs {
    /// About `n` primary rays on a regular grid over `camera`'s screen (row by row), cast one
    /// at a time and in batches of [`TRACE_BATCH`] along the rows; then shadow rays from
    /// (up to `n` / lights of) their hits towards every light of `world`, about `n` in all,
    /// sample by sample and light by light over batches of [`SHADE_BATCH`] samples. Single
    /// and batched runs alternate (single, batched, single, batched) and each rate is the
    /// better of its two, so a burst of other work on the machine hits both alike.
    fn measure(caster: &dyn bvh::RayCaster, world: &World, camera: &EyeCamera, n: u64) -> Self {
        let d = &camera.display;
        let (w, h) = (d.width_px as u64, d.height_px as u64);
        let side = ((n as f64) * (w as f64 / h as f64)).sqrt().max(1.0) as u64;
        let rows = (n / side).max(1);
        let ray = |i: u64, j: u64| Ray {
            origin: camera.position,
            dir: camera.direction(
                (i as f32 + 0.5) * w as f32 / side as f32,
                (j as f32 + 0.5) * h as f32 / rows as f32,
            ),
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let single = || -> Vec<Option<bvh::Hit>> {
            (0..rows)
                .into_par_iter()
                .flat_map_iter(|j| (0..side).map(move |i| caster.intersect(&ray(i, j))))
                .collect()
        };
        let batched = || -> Vec<Option<bvh::Hit>> {
            (0..rows)
                .into_par_iter()
                .flat_map_iter(|j| {
                    let rs: Vec<Ray> = (0..side).map(|i| ray(i, j)).collect();
                    let mut hits = vec![None; rs.len()];
                    for (r, o) in rs
                        .chunks(TRACE_BATCH as usize)
                        .zip(hits.chunks_mut(TRACE_BATCH as usize))
                    {
                        caster.intersect_batch(r, o);
                    }
                    hits
                })
                .collect()
        };
        let timed = |f: &mut dyn FnMut() -> u64| -> RayRate {
            let t = Stopwatch::start();
            let rays = std::hint::black_box(f());
            RayRate::of(rays, t.elapsed_ms())
        };
        let best = |a: RayRate, b: RayRate| {
            if b.mrays_per_cpu_s > a.mrays_per_cpu_s {
                b
            } else {
                a
            }
        };
        let count = side * rows;
        let mut hits = Vec::new();
        let (mut ps, mut pb) = (None::<RayRate>, None::<RayRate>);
        for _ in 0..2 {
            let s = timed(&mut || {
                std::hint::black_box(single());
                count
            });
            ps = Some(ps.map_or(s, |p| best(p, s)));
            let b = timed(&mut || {
                hits = batched();
                count
            });
            pb = Some(pb.map_or(b, |p| best(p, b)));
        }
        // Shadow rays from the hit points (pulled back along the ray), towards each light.
        let lights = &world.lights;
        let points: Vec<Vec3> = (0..rows)
            .flat_map(|j| (0..side).map(move |i| (i, j)))
            .zip(&hits)
            .filter_map(|((i, j), h)| {
                h.map(|h| {
                    let r = ray(i, j);
                    r.origin + r.dir * (h.t * (1.0 - 1e-4))
                })
            })
            .take((n as usize / lights.len().max(1)).max(1))
            .collect();
        let shadow = |p: Vec3, light: &Light| -> Ray {
            let (dir, dist) = match *light {
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    let v = position - p;
                    (v.normalize_or_zero(), v.length() * (1.0 - 1e-4))
                }
                Light::Directional { direction, .. } => (-direction, f32::INFINITY),
            };
            Ray {
                origin: p,
                dir,
                t_min: 0.0,
                t_max: dist,
            }
        };
        let (mut ss, mut sb) = (None::<RayRate>, None::<RayRate>);
        if !lights.is_empty() && !points.is_empty() {
            let rays = (points.len() * lights.len()) as u64;
            for _ in 0..2 {
                let s = timed(&mut || {
                    let blocked: usize = points
                        .par_chunks(SHADE_BATCH)
                        .map(|ps| {
                            ps.iter()
                                .map(|&p| {
                                    lights
                                        .iter()
                                        .filter(|l| caster.occluded(&shadow(p, l)))
                                        .count()
                                })
                                .sum::<usize>()
                        })
                        .sum();
                    std::hint::black_box(blocked);
                    rays
                });
                ss = Some(ss.map_or(s, |p| best(p, s)));
                let b = timed(&mut || {
                    let blocked: usize = points
                        .par_chunks(SHADE_BATCH)
                        .map(|ps| {
                            let mut out = vec![false; ps.len()];
                            let mut n = 0;
                            for l in lights {
                                let rs: Vec<Ray> = ps.iter().map(|&p| shadow(p, l)).collect();
                                caster.occluded_batch(&rs, &mut out);
                                n += out.iter().filter(|&&o| o).count();
                            }
                            n
                        })
                        .sum();
                    std::hint::black_box(blocked);
                    rays
                });
                sb = Some(sb.map_or(b, |p| best(p, b)));
            }
        }
        Self {
            primary_single: ps.expect("measured above"),
            primary_batched: pb.expect("measured above"),
            shadow_single: ss,
            shadow_batched: sb,
        }
    }
}

/// Jiffies of the whole machine from `/proc/stat`: (stolen by the hypervisor, all).
fn machine_jiffies() -> Option<(u64, u64)> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let fields: Vec<u64> = stat
        .lines()
        .next()?
        .split_whitespace()
        .skip(1)
        .filter_map(|f| f.parse().ok())
        .collect();
    Some((*fields.get(7)?, fields.iter().take(8).sum()))
}

/// Share of the machine's time the hypervisor gave to other guests between two readings.
fn steal_fraction(a: Option<(u64, u64)>, b: Option<(u64, u64)>) -> Option<f64> {
    let ((s0, t0), (s1, t1)) = (a?, b?);
    (t1 > t0).then(|| (s1 - s0) as f64 / (t1 - t0) as f64)
}

/// Binocular frame of `method` on `display`, Dup and Rep alternately `reps` times, both eyes
/// fixating the first surface under the centre of the cyclopean view; medians. Both modes
/// render in one frame context holding `executors`' executors (installed for the left eye's
/// first plan), so a device runs both eyes of every frame; Dup renders the right eye at the
/// same time in a second context where the executors offer one
/// ([`BenchExecutors::second_eye`]).
#[allow(clippy::too_many_arguments)]
fn time_stereo(
    world: &World,
    rig: &HmdRig,
    display: &DisplayProfile,
    method: Method,
    template: &FrameSettings,
    reps: u32,
    executors: &mut dyn BenchExecutors,
) -> Result<StereoTiming> {
    let (_, [(lc, lg), (rc, rg)]) = fixating_eyes(world, rig, display, &display.centre_gaze())?;
    let mut settings = template.clone();
    settings.method = method;
    let eyes = [EyeState::looking_at(lg), EyeState::looking_at(rg)];
    let mut ctx = FrameContext::new();
    let plan = FramePlan::new(world, &lc, &settings, &eyes[0], [0.0, 0.0])?;
    executors.install(world, &plan, &mut ctx)?;
    drop(plan);
    let mut second = executors.second_eye();
    // Per mode: each rep's wall ms, device passes and device traffic.
    type Reps = Vec<(f64, BTreeMap<String, f64>, BTreeMap<String, u64>)>;
    let (mut dup, mut rep): (Reps, Reps) = (Vec::new(), Vec::new());
    let (mut dup_rays, mut rep_rays, mut holes) = (0, 0, 0);
    let mut trace_backend = String::new();
    for _ in 0..reps {
        for mode in [StereoMode::Dup, StereoMode::Rep] {
            let pair = SecondEye::of(&mut second);
            let counters = executors.device_counters();
            let f = render_stereo_in(
                &mut ctx,
                pair,
                world,
                &lc,
                &rc,
                &settings,
                eyes,
                mode,
                &|_, _| {},
            )?;
            let passes = executors.pass_ms();
            let traffic = counters_since(&counters, &executors.device_counters());
            trace_backend.clone_from(&f.left.stats.trace_backend);
            match mode {
                StereoMode::Dup => {
                    dup.push((f.stats.total_ms, passes, traffic));
                    dup_rays = f.stats.rays_primary;
                }
                StereoMode::Rep => {
                    rep.push((f.stats.total_ms, passes, traffic));
                    rep_rays = f.stats.rays_primary;
                    holes = f.stats.holes_traced;
                }
            }
        }
    }
    // The median rep's wall time, its device passes and traffic.
    let median_of = |mut v: Reps| {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v.swap_remove(v.len() / 2)
    };
    let (
        (dm, dup_device_pass_ms, dup_device_traffic),
        (rm, rep_device_pass_ms, rep_device_traffic),
    ) = (median_of(dup), median_of(rep));
    Ok(StereoTiming {
        display: display.name.clone(),
        width: display.width_px,
        height: display.height_px,
        method: method.name(),
        dup_ms: dm,
        rep_ms: rm,
        dup_rays_primary: dup_rays,
        rep_rays_primary: rep_rays,
        rep_holes: holes,
        rep_over_dup_time: rm / dm,
        rep_over_dup_rays: rep_rays as f64 / dup_rays as f64,
        dup_device_pass_ms,
        rep_device_pass_ms,
        dup_device_traffic,
        rep_device_traffic,
        trace_backend,
        dup_lockstep: second.is_some(),
    })
}

/// Times each filter `reps` times on one frame (auto or fixed focus of `settings`).
#[allow(clippy::too_many_arguments)]
fn time_dof_filters(
    world: &World,
    camera: &EyeCamera,
    gaze: &Gaze,
    settings: &DofSettings,
    color: &Image<Rgb>,
    depth: &Image<f32>,
    filters: &[FilterKind],
    reps: u32,
) -> Result<Vec<DofTiming>> {
    let focus_m = match settings.focus {
        FocusMode::Fixed(f) => f,
        FocusMode::Auto => auto_focus_m(world, camera, gaze)?,
    };
    let params = coc_params(settings, camera);
    let coc = coc_map(&params, Metres(focus_m), depth)?;
    let input = DofInput {
        color,
        depth_m: depth,
        coc_px: &coc,
        focus_m: focus_m as f32,
        px_per_dioptre: params.px_per_dioptre() as f32,
        gaze_px: [gaze.point.x_px as f32, gaze.point.y_px as f32],
        px_per_degree: px_per_degree(camera) as f32,
    };
    let mp = color.width() as f64 * color.height() as f64 / 1e6;
    let mut rows = Vec::new();
    for &k in filters {
        let f = k.build();
        let mut times: Vec<f64> = (0..reps)
            .map(|_| {
                let t = Instant::now();
                let out = f.apply(&input);
                let ms = t.elapsed().as_secs_f64() * 1e3;
                out.map(|_| ms)
            })
            .collect::<std::result::Result<_, _>>()?;
        let ms = median(&mut times);
        rows.push(DofTiming {
            name: k.name(),
            ms,
            ms_per_megapixel: ms / mp,
            relative_to_fastest: 0.0,
        });
    }
    let fastest = rows.iter().map(|r| r.ms).fold(f64::INFINITY, f64::min);
    for r in &mut rows {
        r.relative_to_fastest = r.ms / fastest;
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_render::shade::ShadingMode;

    use crate::experiments::invalid_parameter as invalid;

    #[test]
    fn default_params_are_valid_and_run_full_first() {
        let p = BenchParams::default();
        p.validate().unwrap();
        assert_eq!(p.displays.len(), 4);
        assert_eq!(p.run_methods(), vec![Method::Full, Method::Vafr]);
        let p = BenchParams {
            methods: vec![Method::Kfr, Method::Full, Method::Kfr],
            ..BenchParams::default()
        };
        assert_eq!(p.run_methods(), vec![Method::Full, Method::Kfr]);
    }

    #[test]
    fn bad_params_give_typed_errors() {
        let bad = |f: &dyn Fn(&mut BenchParams)| {
            let mut p = BenchParams::default();
            f(&mut p);
            p.validate()
        };
        assert_eq!(invalid(bad(&|p| p.displays.clear())), "res");
        assert_eq!(invalid(bad(&|p| p.dof_reps = 0)), "dof-reps");
        assert_eq!(invalid(bad(&|p| p.stereo_reps = 101)), "stereo-reps");
        assert_eq!(invalid(bad(&|p| p.frames = 0)), "frames");
        assert_eq!(invalid(bad(&|p| p.warmup = MAX_REPS + 1)), "warmup");
        assert!(matches!(
            bad(&|p| p.frame.shading = ShadingMode::Path { bounces: 0, spp: 1, seed: 1 }),
            Err(EvalError::Render(fovea_render::RenderError::InvalidParameter { ref name, .. }))
                if name == "bounces"
        ));
        assert_eq!(
            bad(&|p| p.dof.max_coc_px = f64::NAN)
                .unwrap_err()
                .parameter(),
            Some("max-coc")
        );
        let mut d = DisplayProfile::preset("2k").unwrap();
        d.width_px = 0;
        assert!(bad(&|p| p.displays = vec![d.clone()]).is_err());
    }
}
