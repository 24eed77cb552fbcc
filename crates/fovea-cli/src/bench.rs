//! `fovea bench`: the same view at several resolutions, full resolution against foveated
//! methods in one run, with rays, per-stage times and speedups; and the primary-ray throughput
//! of each available BVH backend on the same scene. The harness is
//! [`fovea_eval::experiments::bench`]; this file parses the options, shows progress and prints.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use anyhow::Result;
use clap::Args;
use indicatif::ProgressBar;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_eval::experiments::bench::{
    run_with as run_bench, BenchEvent, BenchExecutors, BenchParams, BenchResult, BenchRun,
    BenchScene, DofTiming, KernelTime, RayRate, ReconstructTiming, StereoTiming, RECONSTRUCT_REPS,
};
use fovea_eval::EvalError;
use fovea_post::dof::FilterKind;
use fovea_render::camera::{EyeCamera, HmdRig};
use fovea_render::pipeline::trace_shade::{SHADE_BATCH, TRACE_BATCH};
use fovea_render::pipeline::{FrameContext, FrameSettings, Stage};
use fovea_render::plan::FramePlan;
use fovea_render::quality::Quality;
use fovea_render::world::World;
use fovea_render::RenderError;

use crate::backend::Preflight;
use crate::choices::{BackendArg, EnvLightChoice, Eyes, LockstepArg, Shading, Switch};
use crate::common::{display_of, thousands, FrameOptions, MethodOptions};
use crate::dof_args::EyeArgs;
use crate::render::{memory_limit, progress_bar, shading, EnvLightArgs};
use crate::resident::GazePathArg;
use crate::scene_args::{load, Loaded, SceneArgs};

/// Options of `fovea bench`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct BenchArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Resolutions or presets, comma-separated: 2k, 4k, 6k, 8k, retinal, a headset, or WxH.
    #[arg(long, default_value = "2k,4k,8k,retinal")]
    pub res: String,
    /// Vertical field of view in degrees for WxH resolutions.
    #[arg(long, default_value_t = 90.0)]
    pub vfov: f64,
    /// Methods to compare with full resolution (always run), comma-separated.
    #[arg(long, default_value = "vafr")]
    pub methods: String,
    #[command(flatten)]
    pub options: MethodOptions,
    #[command(flatten)]
    pub frame: FrameOptions,
    /// Shading: direct or path.
    #[arg(long, value_enum, ignore_case = true)]
    pub shading: Option<Shading>,
    /// Indirect bounces of --shading indirect (default 3) or path (default 2), 1 to 16.
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Paths per sample of --shading path.
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    #[command(flatten)]
    pub env: EnvLightArgs,
    /// Primary rays per backend for the BVH throughput test (0 to skip).
    #[arg(long, default_value_t = 2_000_000)]
    pub bvh_rays: u64,
    /// Refuse frames needing more memory than this (e.g. 8G).
    #[arg(long)]
    pub max_memory: Option<String>,
    /// Also time depth-of-field filters side by side on each display's full-resolution frame:
    /// comma-separated names or `all`.
    #[arg(long)]
    pub dof: Option<String>,
    #[command(flatten)]
    pub eye: EyeArgs,
    /// Timed repetitions of each DOF filter (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub dof_reps: u32,
    /// Untimed frames per method before the timed ones (they allocate the buffers the timed
    /// frames reuse).
    #[arg(long, default_value_t = 1)]
    pub warmup: u32,
    /// Timed frames per method, rendered with the same buffers; the median frame is
    /// reported.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub frames: u32,
    /// Eyes: one, or both (also times binocular frames of every foveated method as
    /// VaFR_Dup and VaFR_Rep, side by side; with --backend gpu both eyes run on the GPU's
    /// executors, one after the other, and the GPU passes are summed over them).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Eyes::One)]
    pub eyes: Eyes,
    /// Timed repetitions of each binocular mode (alternating Dup and Rep; medians reported).
    #[arg(long, default_value_t = 3)]
    pub stereo_reps: u32,
    /// Which executor runs the stages a GPU can run (every method's ray generation, primary
    /// and shadow rays, full resolution's included, direct and environment light, sample-space
    /// AA and the reconstruction of polar methods and Weier's; every other stage stays on the
    /// CPU, labelled per stage): cpu, gpu (an error when there is no adapter or the build
    /// lacks the `gpu` feature) or auto. GPU figures are the passes' timestamps; on a CPU
    /// device (lavapipe) they are labelled CPU-emulated.
    #[arg(long, value_enum, ignore_case = true, default_value_t = BackendArg::Cpu)]
    pub backend: BackendArg,
    /// With a GPU backend, the binocular Dup frame: on renders both eyes at the same time,
    /// each eye's device work waiting for the other's so that both go to the GPU in one
    /// submission; off renders them one after the other; auto (default): on for a hardware
    /// GPU, off on a CPU-emulated one (lavapipe), where it measured slower. Rep always
    /// renders them in turn.
    #[arg(long, value_enum, ignore_case = true, default_value_t = LockstepArg::Auto)]
    pub lockstep: LockstepArg,
    /// With --backend gpu --eyes both: how the gaze moves from frame to frame in the
    /// binocular frames timed through the resident frame beside the staged path (saccade: a
    /// jump of --gaze-step degrees every frame; circle: arcs of --gaze-step; still).
    #[arg(long, value_enum, ignore_case = true, default_value_t = GazePathArg::Saccade)]
    pub gaze_path: GazePathArg,
    /// The gaze path's step, degrees a frame (0 to 30).
    #[arg(long, default_value_t = 8.0)]
    pub gaze_step: f64,
    /// With --backend gpu --eyes both: temporal accumulation in those binocular frames, on
    /// both paths (the resident frame's pass on the device, the staged path's on the CPU):
    /// on (default; the viewer's setting) or off.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Switch::On)]
    pub temporal: Switch,
    /// Print JSON only.
    #[arg(long)]
    pub json: bool,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The benchmark's parameters from the options, checked before anything is loaded.
pub fn params(args: &BenchArgs) -> Result<BenchParams> {
    let displays: Vec<DisplayProfile> = args
        .res
        .split(',')
        .map(|s| display_of(s, args.vfov))
        .collect::<Result<_>>()?;
    let methods: Vec<Method> = args
        .methods
        .split(',')
        .map(crate::common::parse_list_method)
        .collect::<Result<_>>()?;
    let mut frame = FrameSettings::new(Method::Full);
    frame.mapping = args
        .options
        .frame_config(args.frame.quality(Quality::Offline))?;
    args.options.warn_inapplicable(&methods);
    frame.shading = shading(
        args.shading,
        args.frame.quality(Quality::Offline),
        args.bounces,
        args.spp,
        1,
        &args.env,
        EnvLightChoice::Occluded,
    )?;
    args.frame.apply(&mut frame);
    frame.memory_limit_bytes = memory_limit(args.max_memory.as_deref())?;
    let dof_filters: Vec<FilterKind> = match args.dof.as_deref().map(str::trim) {
        None => Vec::new(),
        Some("all") => FilterKind::ALL.to_vec(),
        Some(list) => list
            .split(',')
            .map(|s| {
                FilterKind::parse(s).map_err(|_| {
                    anyhow::anyhow!(
                        "invalid parameter `dof` = {s}: expected `all` or a comma-separated \
                         list of {}",
                        FilterKind::ALL.map(|k| k.name()).join(", ")
                    )
                })
            })
            .collect::<Result<_>>()?,
    };
    let stereo = args.eyes == Eyes::Both;
    if !(args.gaze_step.is_finite() && (0.0..=30.0).contains(&args.gaze_step)) {
        anyhow::bail!(
            "invalid parameter `gaze-step` = {}: expected 0 to 30 degrees a frame",
            args.gaze_step
        );
    }
    let params = BenchParams {
        displays,
        methods,
        frame,
        bvh_rays: args.bvh_rays,
        dof_filters,
        dof: args.eye.settings(None)?,
        dof_reps: args.dof_reps,
        warmup: args.warmup,
        frames: args.frames,
        stereo,
        stereo_reps: args.stereo_reps,
    };
    params.validate()?;
    Ok(params)
}

pub fn run(args: BenchArgs) -> Result<()> {
    let params = params(&args)?;
    // Before any work: `gpu` without an adapter or without the feature is an error here.
    let preflight = crate::backend::preflight(args.backend)?;
    let mut loaded = load(&args.scene)?;
    if !args.json {
        print_backend(args.backend, &preflight);
    }
    let result = measure_with(
        &mut loaded,
        &args.scene,
        &params,
        &mut BenchBackend::new(args.backend, &preflight, args.lockstep),
        args.quiet || args.json,
        (!args.json).then_some(args.backend != BackendArg::Cpu),
    )?;
    // Both eyes on a GPU: the binocular frame resident against staged, the gaze moving.
    let resident = if params.stereo {
        crate::resident::bench_rows(
            &mut loaded,
            &args.scene,
            &params,
            &preflight,
            crate::resident::MovingGaze {
                path: args.gaze_path,
                step_deg: args.gaze_step,
                temporal: args.temporal.is_on(),
            },
            args.json,
        )?
    } else {
        Vec::new()
    };
    if args.json {
        let mut json = result.to_json();
        json["resident_binocular"] = resident.into();
        json["backend"] = serde_json::json!({
            "requested": args.backend,
            "resolved": preflight.describe,
            "adapter": preflight.adapter,
            "cpu_emulated": preflight.cpu_emulated,
        });
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        print_summary(&result);
    }
    Ok(())
}

/// The table's header line: what `--backend` resolved to, and whether GPU figures are
/// CPU-emulated.
fn print_backend(requested: BackendArg, p: &Preflight) {
    if requested == BackendArg::Cpu {
        return;
    }
    let emulated = if p.cpu_emulated {
        " — GPU figures CPU-emulated (the adapter is a CPU device)"
    } else {
        ""
    };
    match &p.adapter {
        Some(adapter) => println!(
            "backend: GPU: {adapter}{emulated}; every method generates and casts its primary \
             rays, casts its shadow rays, computes its direct and environment light and \
             anti-aliases on it, polar methods and Weier reconstruct on it, every other stage \
             on the CPU"
        ),
        None => println!("backend: {}: every stage on the CPU", p.describe),
    }
}

/// `--backend` for the benchmark's frames: each method's frames (full resolution's, the
/// speedup's reference, included) get the executors [`crate::backend::resolve`] makes for
/// them, as `fovea render` does.
struct BenchBackend {
    /// `cpu`, or what the preflight found a GPU for.
    requested: BackendArg,
    /// Whether a binocular Dup frame renders its eyes in lockstep (`--lockstep`).
    lockstep: LockstepArg,
    /// The right eye's context in lockstep, from the last [`BenchExecutors::install`].
    second: Option<(
        FrameContext,
        Arc<dyn fovea_render::pipeline::Lockstep + Send + Sync>,
    )>,
    /// The installed executors' device, for their per-frame times and its transfer
    /// counters (`None` while the CPU runs every stage).
    device: Option<Arc<dyn fovea_render::pipeline::ExecutorDevice>>,
}

impl BenchBackend {
    /// The CPU unless the preflight found a GPU for `requested`.
    fn new(requested: BackendArg, preflight: &Preflight, lockstep: LockstepArg) -> Self {
        Self {
            requested: if preflight.adapter.is_some() {
                requested
            } else {
                BackendArg::Cpu
            },
            lockstep,
            second: None,
            device: None,
        }
    }
}

impl BenchExecutors for BenchBackend {
    fn install(
        &mut self,
        world: &World,
        _plan: &FramePlan,
        ctx: &mut FrameContext,
    ) -> fovea_eval::Result<()> {
        self.device = None;
        if self.requested == BackendArg::Cpu {
            return Ok(());
        }
        let mut backend = crate::backend::resolve(self.requested, world)
            .map_err(|e| EvalError::Scene(format!("{e:#}")))?;
        backend.install(ctx);
        self.second = backend.second_eye(self.lockstep);
        self.device = backend.device.clone();
        Ok(())
    }

    fn device_counters(&mut self) -> BTreeMap<String, u64> {
        self.device
            .as_ref()
            .map(|d| d.traffic())
            .unwrap_or_default()
    }

    fn second_eye(
        &mut self,
    ) -> Option<(
        FrameContext,
        Arc<dyn fovea_render::pipeline::Lockstep + Send + Sync>,
    )> {
        self.second.take()
    }

    fn pass_ms(&mut self) -> BTreeMap<String, f64> {
        let passes = self.device.as_ref().map(|d| d.take_pass_ms());
        passes
            .into_iter()
            .flatten()
            .map(|(k, ms)| (k.to_string(), ms))
            .collect()
    }
}

/// The loaded scene as the benchmark views it: the camera and lights follow each display as
/// `fovea render` would set them.
struct LoadedScene<'a> {
    loaded: &'a mut Loaded,
    args: &'a SceneArgs,
}

impl BenchScene for LoadedScene<'_> {
    fn view(&mut self, display: &DisplayProfile) -> fovea_eval::Result<EyeCamera> {
        self.loaded
            .view(self.args, display)
            .map_err(|e| match e.downcast::<RenderError>() {
                Ok(r) => EvalError::Render(r),
                Err(e) => EvalError::Scene(format!("{e:#}")),
            })
    }
    fn world(&self) -> &World {
        &self.loaded.world
    }
    fn rig(&self) -> &HmdRig {
        self.loaded.rig()
    }
}

/// Runs the benchmark on `loaded` (viewed as `scene` says) with a progress bar per method
/// unless `quiet`, nothing printed, the frames on what `--backend` (`requested`, found by
/// `preflight`) resolves to for each method, as `fovea bench --backend` runs them.
pub fn measure_on(
    loaded: &mut Loaded,
    scene: &SceneArgs,
    params: &BenchParams,
    requested: BackendArg,
    preflight: &Preflight,
    quiet: bool,
) -> Result<BenchResult> {
    let mut executors = BenchBackend::new(requested, preflight, LockstepArg::Auto);
    measure_with(loaded, scene, params, &mut executors, quiet, None)
}

/// The benchmark with `executors` in each method's frames (progress bars unless `quiet`);
/// `print`: `Some(labels)` prints each run as it ends, with the trace, shade and reconstruct
/// stages labelled `(cpu)` / `(gpu)` when `labels`.
fn measure_with(
    loaded: &mut Loaded,
    scene: &SceneArgs,
    params: &BenchParams,
    executors: &mut dyn BenchExecutors,
    quiet: bool,
    print: Option<bool>,
) -> Result<BenchResult> {
    let current = Mutex::new(ProgressBar::hidden());
    let bar = || {
        current
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    };
    let observe = |e: BenchEvent<'_>| match e {
        BenchEvent::Started { display, method } => {
            let pb = progress_bar(quiet, &format!("{} {}", display.name, method));
            *current
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner) = pb;
        }
        BenchEvent::Samples { done, total } => {
            let pb = bar();
            pb.set_length(total);
            pb.set_position(done);
        }
        BenchEvent::DofTimed(t) => {
            bar().finish_and_clear();
            if print.is_some() {
                print_dof(&t.display, &t.filters);
            }
        }
        BenchEvent::Run(r) => {
            bar().finish_and_clear();
            if let Some(labels) = print {
                print_run(r, labels);
            }
        }
        BenchEvent::Stereo(s) => {
            if print.is_some() {
                print_stereo(s);
            }
        }
    };
    let mut view = LoadedScene {
        loaded,
        args: scene,
    };
    Ok(run_bench(&mut view, params, executors, &observe)?)
}

/// The closing lines of `fovea bench`: the scene and the BVH backends.
fn print_summary(r: &BenchResult) {
    println!(
        "scene {}: {} triangles, {} lights, BVH {}, {} threads",
        r.scene,
        thousands(r.triangles as u64),
        r.lights,
        r.bvh,
        r.threads,
    );
    let threads = r.threads;
    for b in &r.bvh_throughput {
        if !b.available {
            println!("BVH {:>6}: not in this build", b.backend);
            continue;
        }
        println!(
            "BVH {:>6}: build {:.0} ms{}",
            b.backend,
            json_number(b.build_ms).unwrap_or(0.0),
            if b.chosen { " (chosen)" } else { "" }
        );
        for (what, single, batched, how) in [
            (
                "primary",
                b.primary_single,
                b.primary_batched,
                format!("batches of {TRACE_BATCH}"),
            ),
            (
                "shadow",
                b.shadow_single,
                b.shadow_batched,
                format!("light by light over {SHADE_BATCH} samples"),
            ),
        ] {
            let (Some(one), Some(many)) = (single, batched) else {
                continue;
            };
            // Per CPU-second, and as `threads` busy threads would cast them (the machine's
            // share of other work left out).
            let rate = |r: &RayRate| {
                format!(
                    "{:.2} Mrays/s, {:.2} per CPU-s = {:.2} at {} threads, {:.0} % CPU",
                    r.mrays_per_s,
                    r.mrays_per_cpu_s,
                    r.mrays_per_cpu_s * threads as f64,
                    threads,
                    100.0 * r.cpu_share
                )
            };
            println!(
                "    {what:<7} one at a time {} | {how} {} | {:.2}x per CPU-s",
                rate(&one),
                rate(&many),
                many.mrays_per_cpu_s / one.mrays_per_cpu_s.max(1e-12)
            );
        }
    }
}

/// `v` as the JSON has it: non-finite numbers are `null`.
fn json_number(v: Option<f64>) -> Option<f64> {
    v.filter(|v| v.is_finite())
}

fn print_stereo(row: &StereoTiming) {
    let num = |v: f64| json_number(Some(v)).unwrap_or(f64::NAN);
    // "(gpu passes trace 1.23 …)" after a mode's time when a device ran it.
    let passes = |p: &std::collections::BTreeMap<String, f64>| {
        if p.is_empty() {
            String::new()
        } else {
            let v: Vec<String> = p.iter().map(|(k, ms)| format!("{k} {ms:.2}")).collect();
            format!(" (gpu passes {} ms)", v.join(" "))
        }
    };
    let dup = format!(
        "{}{}",
        passes(&row.dup_device_pass_ms),
        traffic_summary(&row.dup_device_traffic)
    );
    let rep = format!(
        "{}{}",
        passes(&row.rep_device_pass_ms),
        traffic_summary(&row.rep_device_traffic)
    );
    println!(
        "{} {}x{} {} binocular: dup {:.0} ms{dup}, {} primary rays | rep {:.0} ms{rep}, {} primary rays ({} holes) | rep/dup time {:.2}, rays {:.2}",
        row.display,
        row.width,
        row.height,
        row.method,
        num(row.dup_ms),
        thousands(row.dup_rays_primary),
        num(row.rep_ms),
        thousands(row.rep_rays_primary),
        thousands(row.rep_holes),
        num(row.rep_over_dup_time),
        num(row.rep_over_dup_rays),
    );
}

fn print_dof(display: &str, rows: &[DofTiming]) {
    println!("DOF filters on the {display} full-resolution frame (median of the runs):");
    for r in rows {
        println!(
            "  {:>13} {:>9.1} ms {:>9.1} ms/MP {:>6.2}x the fastest",
            r.name, r.ms, r.ms_per_megapixel, r.relative_to_fastest
        );
    }
}

/// " | bus 12.3 MB up 4.5 MB down, 57 submits, 57 waits, 80 ms blocked" from a frame's device traffic
/// (`gpu_traffic_per_frame`); empty when nothing ran on a device.
fn traffic_summary(t: &BTreeMap<String, u64>) -> String {
    if t.is_empty() {
        return String::new();
    }
    let get = |k: &str| t.get(k).copied().unwrap_or(0);
    format!(
        " | bus {:.1} MB up {:.1} MB down, {} submits, {} waits, {:.0} ms blocked",
        get("bytes_uploaded") as f64 / 1e6,
        get("bytes_read_back") as f64 / 1e6,
        get("submissions"),
        get("blocking_waits"),
        get("blocked_ns") as f64 / 1e6
    )
}

/// One run's line; with `labels`, the trace, shade and reconstruct stages say where they (and
/// the shade stage's shadow rays) ran and the GPU passes' own times follow.
fn print_run(r: &BenchRun, labels: bool) {
    let s = &r.stats;
    let st = |k: Stage| s.stages_ms.get(k);
    let on = |backend: &str| {
        if labels {
            format!(" ({backend})")
        } else {
            String::new()
        }
    };
    let gpu = if r.device_pass_ms.is_empty() {
        String::new()
    } else {
        let passes: Vec<String> = r
            .device_pass_ms
            .iter()
            .map(|(k, ms)| format!("{k} {ms:.2}"))
            .collect();
        format!(" | gpu passes {} ms", passes.join(" "))
    };
    let gpu = format!("{gpu}{}", traffic_summary(&r.device_traffic));
    println!(
        "{:>5}x{:<5} {:>6} rays {:>13} | trace {:>8.0}{} shade {:>8.0}{} denoise {:>6.0}{} (cpu {:.0} ms, {:.0}% of the frame's cpu; frame without it {:.0} ms, cpu {:.0} ms) aa {:>6.0}{} reconstruct {:>6.0}{}{gpu} | wall {:>8.0} ms, cpu {:>8.0} ms ({:.0}% of {} cores){} | {:.2} fps | speedup {:>6.2}x wall, {:>6.2}x cpu",
        s.width,
        s.height,
        s.method,
        thousands(s.rays),
        st(Stage::Trace),
        on(&format!("{}, surfaces {}", s.trace_backend, s.surface_backend)),
        st(Stage::Shade),
        on(&format!(
            "cpu, direct light {}, environment light {}, shadow rays {}",
            s.direct_light_backend, s.environment_light_backend, s.shadow_backend
        )),
        st(Stage::Denoise),
        on(&s.denoise_backend),
        s.stages_cpu_ms.get(Stage::Denoise),
        100.0 * s.stages_cpu_ms.get(Stage::Denoise) / s.total_cpu_ms.max(1e-9),
        s.total_ms - st(Stage::Denoise),
        s.total_cpu_ms - s.stages_cpu_ms.get(Stage::Denoise),
        st(Stage::Aa),
        on(&s.aa_backend),
        st(Stage::Reconstruct),
        on(&s.reconstruct_backend),
        s.total_ms,
        s.total_cpu_ms,
        r.cpu_share * 100.0,
        rayon::current_num_threads(),
        r.steal
            .map_or(String::new(), |f| format!(" ({:.0}% stolen)", f * 100.0)),
        r.fps(),
        r.speedup,
        r.speedup_cpu,
    );
    if let Some(t) = &r.reconstruct {
        print_reconstruct(t);
    }
}

/// The reconstruct kernels side by side and against the write-bandwidth floor.
fn print_reconstruct(t: &ReconstructTiming) {
    let time = |k: &KernelTime| {
        format!(
            "{:.1} ms (cpu {:.1} ms, {:.0} % CPU)",
            k.wall_ms,
            k.cpu_ms,
            100.0 * k.cpu_share
        )
    };
    let kernels: Vec<String> = t
        .kernels
        .iter()
        .map(|r| format!("{} {}", r.kernel.name(), time(&r.time)))
        .collect();
    let vs_scalar = match (t.kernels.first(), t.kernels.last()) {
        (Some(a), Some(b)) if a.kernel != b.kernel => format!(
            " | {} {:.2}x the {} by CPU time",
            b.kernel.name(),
            a.time.cost_ms() / b.time.cost_ms(),
            a.kernel.name()
        ),
        _ => String::new(),
    };
    println!(
        "    reconstruct kernels (best of {RECONSTRUCT_REPS}, warm buffers): {}{vs_scalar}",
        kernels.join(", ")
    );
    println!(
        "    write floor {:.0} MB: {} = {:.1} GB/s | {} at {:.2}x the floor by CPU time",
        t.output_bytes as f64 / 1e6,
        time(&t.write_floor),
        t.write_gb_per_s,
        t.kernel.name(),
        t.over_floor
    );
}
