//! `fovea bench`: the same view at several resolutions, full resolution against foveated
//! methods in one run, with rays, per-stage times and speedups; and the primary-ray throughput
//! of each available BVH backend on the same scene.

use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use rayon::prelude::*;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_render::bvh::{self, Backend, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, FrameStats, Stage, StageMs,
    StageTimes, Stopwatch,
};
use fovea_render::plan::FramePlan;

use crate::common::{display_of, thousands, MethodOptions};
use crate::dof_args::EyeArgs;
use crate::render::{memory_limit, progress_bar, shading};
use crate::scene_args::{load, Loaded, SceneArgs};
use fovea_core::units::Metres;
use fovea_post::dof::coc::coc_map;
use fovea_post::dof::{DofInput, FilterKind};
use fovea_render::dof::{auto_focus_m, coc_params, px_per_degree, FocusMode};

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
    /// Shading: direct or path.
    #[arg(long, default_value = "direct")]
    pub shading: String,
    /// Indirect bounces of --shading path.
    #[arg(long, default_value_t = 2)]
    pub bounces: u32,
    /// Paths per sample of --shading path.
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
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
    /// VaFR_Dup and VaFR_Rep, side by side).
    #[arg(long, default_value = "one")]
    pub eyes: String,
    /// Timed repetitions of each binocular mode (alternating Dup and Rep; medians reported).
    #[arg(long, default_value_t = 3)]
    pub stereo_reps: u32,
    /// Print JSON only.
    #[arg(long)]
    pub json: bool,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Primary-ray throughput of `caster` through `camera`: about `n` rays on a regular grid over
/// the screen, Mrays/s (wall time, all threads).
fn primary_throughput(caster: &dyn bvh::RayCaster, camera: &EyeCamera, n: u64) -> f64 {
    let d = &camera.display;
    let (w, h) = (d.width_px as u64, d.height_px as u64);
    let side = ((n as f64) * (w as f64 / h as f64)).sqrt().max(1.0) as u64;
    let rows = (n / side).max(1);
    let t = Instant::now();
    let hits: u64 = (0..rows)
        .into_par_iter()
        .map(|j| {
            let mut c = 0u64;
            for i in 0..side {
                let x = (i as f32 + 0.5) * w as f32 / side as f32;
                let y = (j as f32 + 0.5) * h as f32 / rows as f32;
                let r = Ray {
                    origin: camera.position,
                    dir: camera.direction(x, y),
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                c += caster.intersect(&r).is_some() as u64;
            }
            c
        })
        .sum();
    std::hint::black_box(hits);
    (side * rows) as f64 / t.elapsed().as_secs_f64() / 1e6
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

/// The validated options of one benchmark.
pub struct Plan {
    displays: Vec<DisplayProfile>,
    methods: Vec<Method>,
    config: fovea_core::mapping::MappingConfig,
    shading_mode: fovea_render::shade::ShadingMode,
    memory_limit: u64,
    dof_filters: Vec<FilterKind>,
    dof_settings: fovea_render::dof::DofSettings,
    stereo: bool,
}

/// Checks every option before anything is loaded or rendered.
pub fn plan(args: &BenchArgs) -> Result<Plan> {
    let displays: Vec<DisplayProfile> = args
        .res
        .split(',')
        .map(|s| display_of(s, args.vfov))
        .collect::<Result<_>>()?;
    let mut methods = vec![Method::Full];
    for m in args.methods.split(',') {
        let m = Method::parse(m)?;
        if !methods.contains(&m) {
            methods.push(m);
        }
    }
    let config = args.options.frame_config()?;
    let shading_mode = shading(&args.shading, args.bounces, args.spp, 1)?;
    let memory_limit = memory_limit(args.max_memory.as_deref())?;
    let dof_filters: Vec<FilterKind> = match args.dof.as_deref().map(str::trim) {
        None => Vec::new(),
        Some("all") => FilterKind::ALL.to_vec(),
        Some(list) => list
            .split(',')
            .map(FilterKind::parse)
            .collect::<Result<_, _>>()?,
    };
    if !(1..=100).contains(&args.dof_reps) {
        anyhow::bail!(
            "invalid parameter `dof-reps` = {}: expected 1 to 100",
            args.dof_reps
        );
    }
    let dof_settings = args.eye.settings(None)?;
    let stereo = match args.eyes.trim().to_ascii_lowercase().as_str() {
        "one" | "1" => false,
        "both" | "2" => true,
        e => anyhow::bail!("invalid parameter `eyes` = {e}: expected one or both"),
    };
    if !(1..=100).contains(&args.stereo_reps) {
        anyhow::bail!(
            "invalid parameter `stereo-reps` = {}: expected 1 to 100",
            args.stereo_reps
        );
    }
    Ok(Plan {
        displays,
        methods,
        config,
        shading_mode,
        memory_limit,
        dof_filters,
        dof_settings,
        stereo,
    })
}

pub fn run(args: BenchArgs) -> Result<()> {
    let plan = plan(&args)?;
    let mut loaded = load(&args.scene)?;
    let json = measure(&args, &plan, &mut loaded, !args.json)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        print_summary(&json);
    }
    Ok(())
}

/// Runs the benchmark on `loaded`; prints each run as it ends when `print`. Returns the JSON
/// of `fovea bench --json`.
pub fn measure(
    args: &BenchArgs,
    plan: &Plan,
    loaded: &mut Loaded,
    print: bool,
) -> Result<serde_json::Value> {
    let Plan {
        displays,
        methods,
        config,
        shading_mode,
        memory_limit,
        dof_filters,
        dof_settings,
        stereo,
    } = plan;
    let (shading_mode, memory_limit, stereo) = (*shading_mode, *memory_limit, *stereo);
    let mut dof_report = Vec::new();
    let mut stereo_report = Vec::new();
    // Loaded and built once; the camera and generated lights follow each display.
    let backend_name = loaded.world.caster.backend().name();
    let mut runs: Vec<Run> = Vec::new();
    let mut bvh_report = Vec::new();
    for (k, display) in displays.iter().enumerate() {
        let camera = loaded.view(&args.scene, display)?;
        let world = &loaded.world;
        if k == 0 && args.bvh_rays > 0 {
            for b in [Backend::Obvhs, Backend::Embree] {
                if !b.available() {
                    bvh_report.push(serde_json::json!({
                        "backend": b.name(), "available": false,
                        "note": "build with --features embree (Debian libembree-dev)",
                    }));
                    continue;
                }
                let t = Instant::now();
                let caster = bvh::build(b, &world.tris)?;
                let build_ms = t.elapsed().as_secs_f64() * 1e3;
                let mrays = primary_throughput(caster.as_ref(), &camera, args.bvh_rays);
                bvh_report.push(serde_json::json!({
                    "backend": b.name(), "available": true,
                    "build_ms": build_ms, "primary_mrays_per_s": mrays,
                    "chosen": b.name() == backend_name,
                }));
            }
        }
        let gaze = display.centre_gaze();
        let mut full: Option<(f64, f64)> = None;
        for &m in methods {
            let mut s = FrameSettings::new(m);
            s.mapping = config.clone();
            s.shading = shading_mode;
            s.memory_limit_bytes = memory_limit;
            let pb = progress_bar(args.quiet || args.json, &format!("{} {}", display.name, m));
            let jiffies = machine_jiffies();
            // Warm-up frames (untimed: they allocate the context's buffers), then the timed
            // frames with the same context; the median frame's statistics are kept.
            let eye = EyeState::looking_at(gaze);
            let mut ctx = FrameContext::new();
            let mut timed: Vec<FrameStats> = Vec::new();
            let mut allocations_after_warmup = 0;
            for k in 0..args.warmup + args.frames {
                if k == args.warmup {
                    allocations_after_warmup = ctx.screen_allocations();
                }
                let mut times = StageTimes::default();
                let t = Stopwatch::start();
                let plan = FramePlan::new(world, &camera, &s, &eye, [0.0, 0.0])?;
                times.add(Stage::Plan, &t);
                let frame = render_planned(
                    &mut ctx,
                    world,
                    &camera,
                    &plan,
                    FrameInputs::default(),
                    times,
                    &|d, t| {
                        pb.set_length(t);
                        pb.set_position(d);
                    },
                )?;
                if k >= args.warmup {
                    timed.push(frame.stats.clone());
                }
            }
            let screen_allocations = ctx.screen_allocations() - allocations_after_warmup;
            timed.sort_by(|a, b| a.total_ms.total_cmp(&b.total_ms));
            let stats = timed.swap_remove(timed.len() / 2);
            let frame = ctx.frame().context("no frame rendered")?;
            // The images are freed with the context, except the full frame's while DOF
            // filters are timed on it.
            if m == Method::Full && !dof_filters.is_empty() {
                pb.finish_and_clear();
                let rows = time_dof_filters(
                    world,
                    &camera,
                    &gaze,
                    dof_settings,
                    &frame.color,
                    &frame.depth,
                    dof_filters,
                    args.dof_reps,
                )?;
                if print {
                    print_dof(&display.name, &rows);
                }
                dof_report.push(serde_json::json!({
                    "display": display.name,
                    "width": display.width_px,
                    "height": display.height_px,
                    "filters": rows,
                }));
            }
            drop(ctx);
            let steal = steal_fraction(jiffies, machine_jiffies());
            pb.finish_and_clear();
            if m == Method::Full {
                full = Some((stats.total_ms, stats.total_cpu_ms));
            }
            let run = Run {
                speedup: full.map_or(1.0, |f| f.0 / stats.total_ms),
                speedup_cpu: full.map_or(1.0, |f| f.1 / stats.total_cpu_ms),
                cpu_share: stats.total_cpu_ms
                    / (stats.total_ms * rayon::current_num_threads() as f64),
                screen_allocations,
                steal,
                stats,
            };
            if print {
                print_run(&run);
            }
            runs.push(run);
        }
        if stereo {
            for &m in methods.iter().filter(|&&m| m != Method::Full) {
                let row = time_stereo(
                    world,
                    loaded.rig(),
                    display,
                    m,
                    config,
                    shading_mode,
                    memory_limit,
                    args.stereo_reps,
                )?;
                if print {
                    println!(
                        "{} {}x{} {m} binocular: dup {:.0} ms, {} primary rays | rep {:.0} ms, {} primary rays ({} holes) | rep/dup time {:.2}, rays {:.2}",
                        display.name,
                        display.width_px,
                        display.height_px,
                        row["dup_ms"].as_f64().unwrap_or(f64::NAN),
                        thousands(row["dup_rays_primary"].as_u64().unwrap_or(0)),
                        row["rep_ms"].as_f64().unwrap_or(f64::NAN),
                        thousands(row["rep_rays_primary"].as_u64().unwrap_or(0)),
                        thousands(row["rep_holes"].as_u64().unwrap_or(0)),
                        row["rep_over_dup_time"].as_f64().unwrap_or(f64::NAN),
                        row["rep_over_dup_rays"].as_f64().unwrap_or(f64::NAN),
                    );
                }
                stereo_report.push(row);
            }
        }
    }
    let world = &loaded.world;
    let (scene_name, triangles, n_lights) =
        (&world.scene.name, world.tris.len(), world.lights.len());
    let json = serde_json::json!({
        "scene": scene_name,
        "triangles": triangles,
        "lights": n_lights,
        "bvh": backend_name,
        "threads": rayon::current_num_threads(),
        "bvh_throughput": bvh_report,
        "dof": dof_report,
        "binocular": stereo_report,
        "runs": runs.iter().map(|r| {
            let s = &r.stats;
            let post = |st: &StageMs| st.sum(&[Stage::Aa, Stage::Reconstruct]);
            serde_json::json!({
                "method": s.method,
                "width": s.width,
                "height": s.height,
                "samples": s.samples,
                "rays": s.rays,
                "rays_primary": s.rays_primary,
                "rays_shadow": s.rays_shadow,
                "rays_bounce": s.rays_bounce,
                "total_ms": s.total_ms,
                "stages_ms": s.stages_ms,
                "cpu_ms": s.total_cpu_ms,
                "stages_cpu_ms": s.stages_cpu_ms,
                "post_fraction": post(&s.stages_ms) / s.total_ms,
                "post_fraction_cpu": post(&s.stages_cpu_ms) / s.total_cpu_ms,
                "speedup_vs_full": r.speedup,
                "speedup_vs_full_cpu": r.speedup_cpu,
                "machine_steal_fraction": r.steal,
                "cpu_share": r.cpu_share,
                "screen_allocations_after_warmup": r.screen_allocations,
            })
        }).collect::<Vec<_>>(),
    });
    Ok(json)
}

/// The closing lines of `fovea bench`: the scene and the BVH backends.
fn print_summary(json: &serde_json::Value) {
    println!(
        "scene {}: {} triangles, {} lights, BVH {}, {} threads",
        json["scene"].as_str().unwrap_or(""),
        thousands(json["triangles"].as_u64().unwrap_or(0)),
        json["lights"].as_u64().unwrap_or(0),
        json["bvh"].as_str().unwrap_or(""),
        json["threads"].as_u64().unwrap_or(0),
    );
    for b in json["bvh_throughput"].as_array().into_iter().flatten() {
        if b["available"].as_bool() == Some(true) {
            println!(
                "BVH {:>6}: {:.2} Mrays/s primary, build {:.0} ms{}",
                b["backend"].as_str().unwrap_or(""),
                b["primary_mrays_per_s"].as_f64().unwrap_or(0.0),
                b["build_ms"].as_f64().unwrap_or(0.0),
                if b["chosen"].as_bool() == Some(true) {
                    " (chosen)"
                } else {
                    ""
                }
            );
        } else {
            println!(
                "BVH {:>6}: not in this build",
                b["backend"].as_str().unwrap_or("")
            );
        }
    }
}

/// Binocular frame of `method` on `display`, Dup and Rep alternately `reps` times, both eyes
/// fixating the first surface under the centre of the cyclopean view; medians.
#[allow(clippy::too_many_arguments)]
fn time_stereo(
    world: &fovea_render::world::World,
    rig: &fovea_render::camera::HmdRig,
    display: &DisplayProfile,
    method: Method,
    config: &fovea_core::mapping::MappingConfig,
    shading_mode: fovea_render::shade::ShadingMode,
    memory_limit: u64,
    reps: u32,
) -> Result<serde_json::Value> {
    use fovea_render::stereo::{fixating_eyes, render_stereo, StereoMode};
    let (_, [(lc, lg), (rc, rg)]) = fixating_eyes(world, rig, display, &display.centre_gaze())?;
    let mut settings = FrameSettings::new(method);
    settings.mapping = config.clone();
    settings.shading = shading_mode;
    settings.memory_limit_bytes = memory_limit;
    let eyes = [EyeState::looking_at(lg), EyeState::looking_at(rg)];
    let (mut dup_ms, mut rep_ms) = (Vec::new(), Vec::new());
    let (mut dup_rays, mut rep_rays, mut holes) = (0, 0, 0);
    for _ in 0..reps {
        let d = render_stereo(
            world,
            &lc,
            &rc,
            &settings,
            eyes,
            StereoMode::Dup,
            &|_, _| {},
        )?;
        dup_ms.push(d.stats.total_ms);
        dup_rays = d.stats.rays_primary;
        let r = render_stereo(
            world,
            &lc,
            &rc,
            &settings,
            eyes,
            StereoMode::Rep,
            &|_, _| {},
        )?;
        rep_ms.push(r.stats.total_ms);
        rep_rays = r.stats.rays_primary;
        holes = r.stats.holes_traced;
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (dm, rm) = (median(&mut dup_ms), median(&mut rep_ms));
    Ok(serde_json::json!({
        "display": display.name,
        "width": display.width_px,
        "height": display.height_px,
        "method": method.name(),
        "dup_ms": dm,
        "rep_ms": rm,
        "dup_rays_primary": dup_rays,
        "rep_rays_primary": rep_rays,
        "rep_holes": holes,
        "rep_over_dup_time": rm / dm,
        "rep_over_dup_rays": rep_rays as f64 / dup_rays as f64,
    }))
}

/// One DOF filter's time on one frame.
#[derive(serde::Serialize)]
struct DofTiming {
    name: &'static str,
    /// Median wall time, milliseconds.
    ms: f64,
    /// Median wall time per megapixel, milliseconds.
    ms_per_megapixel: f64,
    /// This filter's time over the fastest filter's, measured in the same run.
    relative_to_fastest: f64,
}

/// Times each filter `reps` times on one frame (auto or fixed focus of `settings`).
#[allow(clippy::too_many_arguments)]
fn time_dof_filters(
    world: &fovea_render::world::World,
    camera: &EyeCamera,
    gaze: &fovea_core::display::Gaze,
    settings: &fovea_render::dof::DofSettings,
    color: &fovea_core::Image<fovea_post::Rgb>,
    depth: &fovea_core::Image<f32>,
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
            .collect::<Result<_, _>>()?;
        times.sort_by(|a, b| a.total_cmp(b));
        let ms = times[times.len() / 2];
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

fn print_dof(display: &str, rows: &[DofTiming]) {
    println!("DOF filters on the {display} full-resolution frame (median of the runs):");
    for r in rows {
        println!(
            "  {:>13} {:>9.1} ms {:>9.1} ms/MP {:>6.2}x the fastest",
            r.name, r.ms, r.ms_per_megapixel, r.relative_to_fastest
        );
    }
}

/// One timed frame and its comparison with the full-resolution frame of the same display.
struct Run {
    stats: FrameStats,
    /// Full-resolution wall time over this frame's.
    speedup: f64,
    /// Full-resolution CPU time over this frame's.
    speedup_cpu: f64,
    /// Share of the machine's time stolen by the hypervisor during the frame.
    steal: Option<f64>,
    /// The process's CPU time over wall time × threads: the share of its cores it got.
    cpu_share: f64,
    /// Screen buffers allocated during the timed frames (0: reused from the warm-up).
    screen_allocations: u64,
}

fn print_run(r: &Run) {
    let s = &r.stats;
    let st = |k: Stage| s.stages_ms.get(k);
    println!(
        "{:>5}x{:<5} {:>6} rays {:>13} | trace {:>8.0} shade {:>8.0} aa {:>6.0} reconstruct {:>6.0} | wall {:>8.0} ms, cpu {:>8.0} ms ({:.0}% of {} cores){} | speedup {:>6.2}x wall, {:>6.2}x cpu",
        s.width,
        s.height,
        s.method,
        thousands(s.rays),
        st(Stage::Trace),
        st(Stage::Shade),
        st(Stage::Aa),
        st(Stage::Reconstruct),
        s.total_ms,
        s.total_cpu_ms,
        r.cpu_share * 100.0,
        rayon::current_num_threads(),
        r.steal
            .map_or(String::new(), |f| format!(" ({:.0}% stolen)", f * 100.0)),
        r.speedup,
        r.speedup_cpu,
    );
}
