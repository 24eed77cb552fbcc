//! `fovea render`: one frame of a scene through one foveation method.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use fovea_core::mapping::Method;
use fovea_post::tonemap::ToneCurve;
use fovea_render::camera::EyeCamera;
use fovea_render::eye::{EyeState, FocusDistance};
use fovea_render::pipeline::{
    default_memory_limit, render_planned, FrameContext, FrameInputs, FrameSettings, Stage,
    StageTimes, Stopwatch,
};
use fovea_render::plan::FramePlan;
use fovea_render::quality::{Quality, ShadingKind};
use fovea_render::shade::{EnvLight, ShadingMode};

use crate::choices::{
    Aa, BackendArg, EnvLightChoice, Eyes, Headset, LockstepArg, MethodChoice, Shading, Stereo,
    Switch, Tonemap,
};
use crate::common::{thousands, DisplayArgs, FrameOptions, MethodOptions};
use crate::dof_args::DofArgs;
use crate::exposure_args::{expose, exposure_json, ExposureArgs};
use crate::output::{check_image_path, write_rgb_on, write_scalar};
use crate::resident::Rendered;
use crate::scene_args::{prepare, GazeArgs, SceneArgs};

/// Options of `fovea render`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    /// Foveation method: full, vafr, kfr, lafr, visual-polar, guenter, inset, weier, or
    /// liu-hybrid (Liu et al.'s whole method: visual-polar sampling, DOF-aware culling and
    /// bokeh with LCA; auto focus unless --focus is given).
    #[arg(long, value_enum, ignore_case = true, default_value_t = MethodChoice::Vafr)]
    pub method: MethodChoice,
    #[command(flatten)]
    pub dof: DofArgs,
    /// Also write the signed circle-of-confusion view (with --dof; .png false colour of |CoC|
    /// in pixels, or .exr signed).
    #[arg(long)]
    pub coc_out: Option<PathBuf>,
    #[command(flatten)]
    pub options: MethodOptions,
    #[command(flatten)]
    pub gaze: GazeArgs,
    #[command(flatten)]
    pub frame: FrameOptions,
    /// Sample-space anti-aliasing: auto (the method's own), none, fxaa, gaussian.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Aa::Auto)]
    pub aa: Aa,
    /// Shading: indirect (direct light plus --bounces bounces of indirect light, default 3,
    /// with next-event estimation at every bounce, the environment included), direct (lights,
    /// shadows and the environment: the default before issue 38) or path (path tracing with
    /// next-event estimation of the lights).
    #[arg(long, value_enum, ignore_case = true)]
    pub shading: Option<Shading>,
    /// Indirect bounces of --shading indirect (default 3) or path (default 2), 1 to 16.
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Paths per sample of --shading path.
    #[arg(long, default_value_t = 4)]
    pub spp: u32,
    /// Random seed of --shading path.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub env: EnvLightArgs,
    /// Output image: .png (8-bit sRGB) or .exr (linear float).
    #[arg(long, default_value = "fovea-out/render.png")]
    pub out: PathBuf,
    /// Also write the depth view (.png false colour, .exr metres).
    #[arg(long)]
    pub depth_out: Option<PathBuf>,
    /// Also write the sample-density view (samples per pixel; .png false colour or .exr).
    #[arg(long)]
    pub density_out: Option<PathBuf>,
    /// Statistics JSON (default: the output path with .json).
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Also write the frame plan as JSON (the eye state, the mapping's buffers, footprint and
    /// spacing tables, AA, culling limits, tiles, memory): what the frame was decided to be.
    #[arg(long)]
    pub plan_out: Option<PathBuf>,
    #[command(flatten)]
    pub exposure: ExposureArgs,
    /// Tone curve for PNG output: clamp or reinhard.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Tonemap::Reinhard)]
    pub tonemap: Tonemap,
    /// Refuse frames needing more memory than this (e.g. 8G, 512M; default 80 % of available).
    #[arg(long)]
    pub max_memory: Option<String>,
    /// Eyes: one (--eye) or both (a side-by-side left | right image, each eye with its own
    /// gaze at the fixated world point).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Eyes::One)]
    pub eyes: Eyes,
    /// Gaze-contingent level of detail (Liu Eq. 14): on keeps objects within 5° of the gaze
    /// and inside the depth of field at full detail and renders the rest simplified.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Switch::Off)]
    pub lod: Switch,
    /// Share of triangles the simplified level keeps (quadric simplification, meshoptimizer).
    #[arg(long, default_value_t = 0.3)]
    pub lod_keep: f32,
    /// With --eyes both: dup (render both eyes) or rep (reproject the left eye's sample
    /// buffer to the right eye and trace only the holes, VaFR_Rep).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Stereo::Rep)]
    pub stereo: Stereo,
    /// Which executor runs the stages a GPU can run (every method's ray generation, primary
    /// rays and their surfaces, shadow rays, direct and environment light, sample-space AA,
    /// the reconstruct stage of polar methods and Weier, the gather DOF and the PNG's tone
    /// map; the plan and every other stage run on the CPU): cpu, gpu (any adapter, lavapipe included; an error without one) or auto (a
    /// hardware GPU when there is one, else the CPU). The GPU needs a fovea built with
    /// `--features gpu`.
    #[arg(long, value_enum, ignore_case = true, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// With --eyes both --stereo dup on a GPU: on renders both eyes at the same time, each
    /// eye's device work waiting for the other's so that both go to the GPU in one
    /// submission (the JSON's backend.gpu_submissions counts them); off renders them one
    /// after the other; auto (default): on for a hardware GPU, off on a CPU-emulated one
    /// (lavapipe), where it measured slower. The frames are the same either way.
    #[arg(long, value_enum, ignore_case = true, default_value_t = LockstepArg::Auto)]
    pub lockstep: LockstepArg,
    /// With a GPU backend: the staged path (each stage lent to the GPU call by call, its
    /// results back on the host) even where the resident frame (the whole frame on the device,
    /// one submission) serves the frame; for comparison and tests.
    #[arg(long)]
    pub staged: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The frame memory budget: `--max-memory` parsed, or the pipeline's default (80 % of the
/// memory available).
pub fn memory_limit(max_memory: Option<&str>) -> Result<u64> {
    max_memory.map_or_else(|| Ok(default_memory_limit()), parse_bytes)
}

/// Parses sizes like `8G`, `512M`, `1.5GiB`, `1000000` (bytes).
fn parse_bytes(text: &str) -> Result<u64> {
    let t = text.trim().to_ascii_uppercase();
    let t = t.trim_end_matches("IB").trim_end_matches('B');
    let (num, mult) = match t.chars().last() {
        Some('K') => (&t[..t.len() - 1], 1u64 << 10),
        Some('M') => (&t[..t.len() - 1], 1 << 20),
        Some('G') => (&t[..t.len() - 1], 1 << 30),
        Some('T') => (&t[..t.len() - 1], 1 << 40),
        _ => (t, 1),
    };
    let v: f64 = num.trim().parse().map_err(|_| {
        anyhow::anyhow!("invalid parameter `max-memory` = {text}: expected a size like 8G or 512M")
    })?;
    if !(v.is_finite() && v > 0.0) {
        bail!("invalid parameter `max-memory` = {text}: expected a positive size like 8G");
    }
    Ok((v * mult as f64) as u64)
}

/// `--env-light` and `--env-samples`: the environment light of direct shading.
#[derive(Args, Debug, Clone, Copy)]
pub struct EnvLightArgs {
    /// Environment light in direct shading: occluded (shadow rays towards the sky or the
    /// environment map, so closed rooms stay dark and interiors are lit through their
    /// openings) or unshadowed (the environment's mean as an ambient term, no rays, no noise;
    /// lights rooms through their walls). Default: occluded; unshadowed for dof-compare, whose
    /// comparison with its reference would otherwise measure Monte Carlo noise.
    #[arg(long, value_enum, ignore_case = true)]
    pub env_light: Option<EnvLightChoice>,
    /// Environment rays per shading sample with --env-light occluded, 0 to 256 (0: no
    /// environment light; default 4).
    #[arg(long)]
    pub env_samples: Option<u32>,
}

impl EnvLightArgs {
    /// `--env-light`, or `default` when it is not given.
    fn choice(&self, default: EnvLightChoice) -> EnvLightChoice {
        self.env_light.unwrap_or(default)
    }

    /// The library's setting (range-checked by `ShadingMode::validate`).
    /// `default_samples`: the quality preset's environment rays when `--env-samples` is not
    /// given.
    pub fn env_light(&self, default: EnvLightChoice, default_samples: u32) -> EnvLight {
        match self.choice(default) {
            EnvLightChoice::Occluded => EnvLight::Occluded {
                samples: self.env_samples.unwrap_or(default_samples),
            },
            EnvLightChoice::Unshadowed => EnvLight::Unshadowed,
        }
    }

    /// Warns about options that `kind` of shading ignores.
    pub fn warn_inapplicable(&self, kind: Shading, default: EnvLightChoice) {
        if kind == Shading::Path && self.env_light.is_some() {
            eprintln!(
                "warning: --env-light applies to --shading direct and indirect only (path \
                 tracing sees the environment through its bounces); ignored"
            );
        }
        if self.env_samples.is_some()
            && (kind == Shading::Path || self.choice(default) == EnvLightChoice::Unshadowed)
        {
            eprintln!(
                "warning: --env-samples applies to --shading direct or indirect with \
                 --env-light occluded only; ignored"
            );
        }
    }
}

/// The shading mode of `--shading` with the path tracer's numbers and the environment rays
/// checked (`default_env`: the command's environment light when `--env-light` is not given);
/// warns about environment options the mode ignores.
pub fn shading(
    kind: Option<Shading>,
    quality: Quality,
    bounces: Option<u32>,
    spp: u32,
    seed: u64,
    env: &EnvLightArgs,
    default_env: EnvLightChoice,
) -> Result<ShadingMode> {
    // `--shading` overrides the preset's kind, `--env-samples` its environment rays.
    let kind = kind.unwrap_or(match quality.shading_kind() {
        ShadingKind::Indirect => Shading::Indirect,
        ShadingKind::Direct => Shading::Direct,
    });
    env.warn_inapplicable(kind, default_env);
    match kind {
        Shading::Direct | Shading::Indirect => {
            let env_light = env.env_light(default_env, quality.env_samples());
            let mode = if kind == Shading::Direct {
                if bounces.is_some() {
                    eprintln!("warning: --bounces applies to --shading indirect and path; ignored");
                }
                ShadingMode::Direct { env_light }
            } else {
                ShadingMode::Indirect {
                    env_light,
                    bounces: bounces.unwrap_or(quality.bounces()),
                }
            };
            mode.validate()?;
            Ok(mode)
        }
        Shading::Path => {
            let bounces = bounces.unwrap_or(2);
            if !(1..=16).contains(&bounces) {
                bail!("invalid parameter `bounces` = {bounces}: expected 1 to 16");
            }
            if !(1..=1024).contains(&spp) {
                bail!("invalid parameter `spp` = {spp}: expected 1 to 1024");
            }
            Ok(ShadingMode::Path { bounces, spp, seed })
        }
    }
}

/// A progress bar over samples (hidden when quiet or not a terminal).
pub fn progress_bar(quiet: bool, label: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(1);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg:>14} [{bar:40}] {percent:>3}% {pos}/{len} samples, eta {eta}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    pb.set_message(label.to_string());
    pb
}

pub fn run(args: RenderArgs) -> Result<()> {
    args.exposure.asked()?;
    check_image_path(&args.out)?;
    for p in [&args.depth_out, &args.density_out, &args.coc_out]
        .into_iter()
        .flatten()
    {
        check_image_path(p)?;
    }
    // Checked before the scene loads; the view's display may take the file camera's field of
    // view (see `Loaded::display`).
    args.display.display(Headset::VivePro)?;
    let liu_hybrid = args.method.is_liu_hybrid();
    let method = args.method.method();
    let dof = args.dof.settings(liu_hybrid)?;
    if args.coc_out.is_some() && dof.is_none() {
        bail!("--coc-out needs --dof <filter>");
    }
    let quality = args.frame.quality(Quality::Offline);
    let config = args.options.frame_config(quality)?;
    args.options.warn_inapplicable(&[method]);
    let tone = ToneCurve::from(args.tonemap);
    let shading_mode = shading(
        args.shading,
        quality,
        args.bounces,
        args.spp,
        args.seed,
        &args.env,
        EnvLightChoice::Occluded,
    )?;
    let both_eyes = args.eyes == Eyes::Both;
    let stereo_mode = fovea_render::stereo::StereoMode::from(args.stereo);
    if both_eyes
        && (args.depth_out.is_some() || args.density_out.is_some() || args.coc_out.is_some())
    {
        bail!("--depth-out, --density-out and --coc-out are for one eye (--eyes one)");
    }
    let lod_on = args.lod.is_on();
    if lod_on {
        fovea_render::lod::LodParams {
            keep_ratio: args.lod_keep,
            ..Default::default()
        }
        .validate()?;
    }
    let memory_limit = memory_limit(args.max_memory.as_deref())?;
    let prepared = prepare(
        &args.scene.within_memory(memory_limit),
        &args.display,
        Headset::VivePro,
    )?;
    let display = prepared.camera.display.clone();
    let gaze = args.gaze.resolve(&display, &prepared.camera)?;
    let mut settings = FrameSettings::new(method);
    settings.mapping = config;
    settings.shading = shading_mode;
    settings.aa = args.aa.into();
    args.frame.apply(&mut settings);
    settings.density_view = args.density_out.is_some();
    settings.memory_limit_bytes = memory_limit;
    settings.dof = dof;
    settings.validate()?;

    if both_eyes {
        let (lod_world, lod_stats) = if lod_on {
            let eye = EyeState::fixating(&prepared.world, &prepared.camera, gaze, None)?;
            let (w, st) = lod_world(&prepared, &settings, &eye, args.lod_keep)?;
            (Some(w), Some(st))
        } else {
            (None, None)
        };
        let world = lod_world.as_ref().unwrap_or(&prepared.world);
        return run_stereo(
            &args,
            &prepared,
            world,
            settings,
            gaze,
            stereo_mode,
            tone,
            lod_stats,
        );
    }
    // The eye state (focus estimated once, on the full scene) and the frame plan.
    let mut times = StageTimes::default();
    let t = Stopwatch::start();
    let eye = EyeState::fixating(
        &prepared.world,
        &prepared.camera,
        gaze,
        settings.dof.as_ref(),
    )?;
    times.add(Stage::Plan, &t);
    let (lod_world, lod_stats) = if lod_on {
        let (w, st) = lod_world(&prepared, &settings, &eye, args.lod_keep)?;
        (Some(w), Some(st))
    } else {
        (None, None)
    };
    let world = lod_world.as_ref().unwrap_or(&prepared.world);
    let t = Stopwatch::start();
    let plan = FramePlan::new(world, &prepared.camera, &settings, &eye, [0.0, 0.0])?;
    times.add(Stage::Plan, &t);
    let mut written: Vec<&Path> = Vec::new();
    if let Some(p) = &args.plan_out {
        crate::output::write_file(p, (plan.to_json()? + "\n").as_bytes())?;
        written.push(p);
    }
    // Which executors run the trace and reconstruct stages; refused here, before any ray is
    // traced.
    let mut backend = crate::backend::resolve(args.backend, world)?;
    // On a GPU, the resident frame when it takes the plan and what is asked for.
    let exposure = args.exposure.choose(prepared.world.scene.light_units)?;
    let staged_because = match crate::resident::render(
        &backend,
        world,
        &[&plan],
        &[&prepared.camera],
        exposure.0.fixed_stops(),
        tone,
        &args.out,
        resident_outputs(&args, settings.dof.is_some()),
    )? {
        Rendered::Resident { json, line } => {
            let stats = serde_json::json!({
                "scene": prepared.world.scene.name,
                "triangles": prepared.world.tris.len(),
                "lights": prepared.world.lights.len(),
                "display": display.name,
                "width": display.width_px,
                "height": display.height_px,
                "method": method.name(),
                "gaze": [gaze.point.x_px, gaze.point.y_px],
                "quality": quality.name(),
                "shading": settings.shading,
                "lod": lod_stats,
                "backend": json,
            });
            return write_resident(&args, &stats, &line, &written);
        }
        Rendered::Staged(why) => why,
    };
    let pb = progress_bar(args.quiet, method.name());
    let mut ctx = FrameContext::new();
    backend.install(&mut ctx);
    render_planned(
        &mut ctx,
        world,
        &prepared.camera,
        &plan,
        FrameInputs::default(),
        times,
        &|done, total| {
            pb.set_length(total);
            pb.set_position(done);
        },
    )?;
    let frame = ctx.take_frame().context("no frame rendered")?;
    pb.finish_and_clear();

    let exposed = expose(&frame.color, &frame.depth, exposure, tone);
    write_rgb_on(
        &args.out,
        &frame.color,
        exposed.stops,
        tone,
        backend.tone_map.as_deref_mut(),
    )?;
    written.insert(0, &args.out);
    if let Some(p) = &args.depth_out {
        write_scalar(p, &frame.depth, 0.1, 100.0)?;
        written.push(p);
    }
    if let (Some(p), Some(d)) = (&args.density_out, &frame.density) {
        write_scalar(p, d, 1e-3, 10.0)?;
        written.push(p);
    }
    if let (Some(p), Some(c)) = (&args.coc_out, &frame.coc) {
        if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            write_scalar(p, c, 0.0, 0.0)?;
        } else {
            write_scalar(p, &c.map(|v| v.abs().max(0.01)), 0.01, 64.0)?;
        }
        written.push(p);
    }
    let s = &frame.stats;
    let stats_path = args
        .stats
        .clone()
        .unwrap_or_else(|| args.out.with_extension("json"));
    let json = serde_json::json!({
        "scene": prepared.world.scene.name,
        "triangles": prepared.world.tris.len(),
        "lights": prepared.world.lights.len(),
        "bvh": prepared.world.caster.backend().name(),
        "bvh_build_ms": prepared.world.build_ms,
        "display": display.name,
        "gaze": [gaze.point.x_px, gaze.point.y_px],
        "quality": quality.name(),
        "shading": settings.shading,
        "pixel_samples": settings.pixel_samples,
        "periphery_rays": settings.periphery_rays,
        "denoise": settings.denoise,
        "reconstruct_filter": settings.reconstruct_filter,
        // The smoothing asked for; `frame.inset_smoothing` is the one applied.
        "inset_smoothing": (method == Method::Inset).then(|| settings.inset_smoothing.name()),
        "lod": lod_stats,
        "backend": with_route(backend.json(s), staged_because),
        "exposure": exposure_json(exposure.0, &exposed),
        "frame": s,
    });
    crate::output::write_file(
        &stats_path,
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;

    // Which boundary smoothing an inset frame got (none where its periphery is not an exact
    // 2× or 4× subsampling of the screen, whatever was asked).
    let smoothing = if method == Method::Inset {
        format!(
            " (boundary smoothing {})",
            s.inset_smoothing.as_deref().unwrap_or("none")
        )
    } else {
        String::new()
    };
    let per_sample = if settings.pixel_samples > 1 {
        format!(" × {} rays", settings.pixel_samples)
    } else {
        String::new()
    };
    println!(
        "{} {}x{} {}{smoothing} | {} samples{per_sample}, {} rays ({} primary, {} shadow, {} environment, {} bounce) | {:.0} ms",
        prepared.world.scene.name,
        s.width,
        s.height,
        s.method,
        thousands(s.samples),
        thousands(s.rays),
        thousands(s.rays_primary),
        thousands(s.rays_shadow),
        thousands(s.rays_environment),
        thousands(s.rays_bounce),
        s.total_ms
    );
    let stages: Vec<String> = [
        Stage::Plan,
        Stage::Trace,
        Stage::Shade,
        Stage::Denoise,
        Stage::Aa,
        Stage::Reconstruct,
    ]
    .iter()
    .map(|&k| match k {
        Stage::Reconstruct if s.reconstruct_backend != "cpu" => {
            format!("{k} {:.1} ({})", s.stages_ms.get(k), s.reconstruct_backend)
        }
        Stage::Trace if s.trace_backend != "cpu" => {
            format!("{k} {:.1} ({})", s.stages_ms.get(k), s.trace_backend)
        }
        Stage::Aa if s.aa_backend != "cpu" => {
            format!("{k} {:.1} ({})", s.stages_ms.get(k), s.aa_backend)
        }
        Stage::Shade if s.shadow_backend != "cpu" => format!(
            "{k} {:.1} (direct light {}, environment light {}, shadow rays {})",
            s.stages_ms.get(k),
            s.direct_light_backend,
            s.environment_light_backend,
            s.shadow_backend
        ),
        _ => format!("{k} {:.1}", s.stages_ms.get(k)),
    })
    .collect();
    println!("stages (ms): {}", stages.join(", "));
    println!("{}", backend_line(&backend, s));
    let (ppd_x, ppd_y) = display.centre_ppd_axes();
    println!(
        "display {} {:.1}°×{:.1}°: {ppd_x:.2} px/deg across, {ppd_y:.2} down at the centre",
        display.name, display.hfov.0, display.vfov.0
    );
    if let Some(note) = oversampling_note(method, s.samples, s.width, s.height) {
        eprintln!("{note}");
    }
    if !s.covers_screen {
        eprintln!(
            "warning: the {method} buffer stops short of the screen's corners at this gaze \
             (a fixed maximum eccentricity): the pixels beyond have no sample and are black; \
             leave --vafr-emax unset to cover the whole screen"
        );
    }
    if let Some(l) = &lod_stats {
        println!(
            "lod: {} of {} objects at full detail | {} of {} triangles traced ({:.1} % fewer)",
            l.full_detail,
            l.full_detail + l.simplified,
            thousands(l.triangles as u64),
            thousands(l.triangles_full as u64),
            100.0 * (1.0 - l.triangles as f64 / l.triangles_full.max(1) as f64)
        );
    }
    if let Some(d) = &settings.dof {
        let focus = s.eye.focus;
        let saved = if s.samples_shaded + s.samples_culled > 0 {
            100.0 * s.samples_culled as f64 / (s.samples_shaded + s.samples_culled) as f64
        } else {
            0.0
        };
        println!(
            "dof: {} | focus {} | pupil {:.2} mm | {} | culled {} of {} surface samples ({saved:.1} %) | dof {:.1} ms",
            d.filter.map_or("none", |k| k.name()),
            match focus {
                Some(FocusDistance::Metres(m)) => format!("{m:.3} m"),
                Some(FocusDistance::Infinity) => "inf".to_string(),
                None => "none".to_string(),
            },
            d.eye.pupil.0,
            d.coc_model.name(),
            thousands(s.samples_culled),
            thousands(s.samples_shaded + s.samples_culled),
            s.stages_ms.get(Stage::Dof),
        );
    }
    written.push(&stats_path);
    println!("{}", wrote_line(&written));
    Ok(())
}

/// A `note:` line when a method shades more samples than the display has pixels (VaFR at
/// low resolutions: its log-polar buffer is sized by the acuity model, not the display).
pub fn oversampling_note(method: Method, samples: u64, width: u32, height: u32) -> Option<String> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels == 0 || samples <= pixels {
        return None;
    }
    let why = if method == Method::Vafr {
        "VaFR's buffer is sized for visual acuity, not the display, so at low resolutions it \
         shades more than full resolution (use --method full or a higher --res)"
    } else {
        "the method's buffer is larger than the display at this resolution"
    };
    Some(format!(
        "note: {} shades {} samples, {:.1}× the {width}×{height} display's {} pixels: {why}",
        method.name(),
        thousands(samples),
        samples as f64 / pixels as f64,
        thousands(pixels),
    ))
}

/// `--eyes both`: each eye's gaze at the fixated point, the binocular frame, one side-by-side
/// image.
/// With `--lod on` the level of detail is chosen for the cyclopean gaze and shared by both
/// eyes.
#[allow(clippy::too_many_arguments)]
fn run_stereo(
    args: &RenderArgs,
    prepared: &crate::scene_args::Prepared,
    world: &fovea_render::world::World,
    settings: FrameSettings,
    gaze: fovea_core::display::Gaze,
    mode: fovea_render::stereo::StereoMode,
    tone: ToneCurve,
    lod_stats: Option<fovea_render::lod::LodStats>,
) -> Result<()> {
    use fovea_render::stereo::{fixating_eyes, render_stereo_in, SecondEye};
    let display = &prepared.camera.display;
    let (target, [(lc, lg), (rc, rg)]) = fixating_eyes(world, &prepared.rig, display, &gaze)?;
    let dof = settings.dof.as_ref();
    let eyes = [
        EyeState::fixating(world, &lc, lg, dof)?,
        EyeState::fixating(world, &rc, rg, dof)?,
    ];
    // Which executors run both eyes' stages (`--backend`), decided before any ray is traced.
    let mut backend = crate::backend::resolve(args.backend, world)?;
    let exposure = args.exposure.choose(prepared.world.scene.light_units)?;
    // On a GPU, Dup through the resident frame when it takes both plans.
    let staged_because = if !backend.on_gpu() {
        None
    } else if mode != fovea_render::stereo::StereoMode::Dup {
        Some("not served: reprojection (--stereo rep warps on the CPU)".to_string())
    } else {
        let plan = |cam: &EyeCamera, eye: &EyeState, k: u32| {
            FramePlan::new(world, cam, &settings, eye, [0.0, 0.0])
                .map(|p| p.with_noise(fovea_render::shade::FrameNoise::new(0, k)))
        };
        let plans = [plan(&lc, &eyes[0], 0)?, plan(&rc, &eyes[1], 1)?];
        match crate::resident::render(
            &backend,
            world,
            &[&plans[0], &plans[1]],
            &[&lc, &rc],
            exposure.0.fixed_stops(),
            tone,
            &args.out,
            resident_outputs(args, settings.dof.is_some()),
        )? {
            Rendered::Resident { json, line } => {
                let stats = serde_json::json!({
                    "scene": prepared.world.scene.name,
                    "display": display.name,
                    "width": 2 * display.width_px,
                    "height": display.height_px,
                    "method": settings.method.name(),
                    "ipd_m": prepared.rig.ipd_m,
                    "fixation": [target.x, target.y, target.z],
                    "gaze_left": [lg.point.x_px, lg.point.y_px],
                    "gaze_right": [rg.point.x_px, rg.point.y_px],
                    "quality": args.frame.quality(Quality::Offline).name(),
                    "shading": settings.shading,
                    "stereo": {"mode": mode.name()},
                    "lod": lod_stats,
                    "backend": json,
                });
                return write_resident(args, &stats, &line, &[]);
            }
            Rendered::Staged(why) => why,
        }
    };
    let mut ctx = FrameContext::new();
    backend.install(&mut ctx);
    // Dup on a GPU: the right eye in a context of its own, both eyes at the same time.
    let mut second = backend.second_eye(args.lockstep);
    let pair = SecondEye::of(&mut second);
    let pb = progress_bar(args.quiet, mode.name());
    let frame = render_stereo_in(
        &mut ctx,
        pair,
        world,
        &lc,
        &rc,
        &settings,
        eyes,
        mode,
        &|done, total| {
            pb.set_length(total);
            pb.set_position(done);
        },
    )?;
    pb.finish_and_clear();
    let (w, h) = (display.width_px, display.height_px);
    let both = crate::output::side_by_side(&frame.left.color, &frame.right.color)?;
    let both_depth = crate::output::side_by_side(&frame.left.depth, &frame.right.depth)?;
    let exposed = expose(&both, &both_depth, exposure, tone);
    write_rgb_on(
        &args.out,
        &both,
        exposed.stops,
        tone,
        backend.tone_map.as_deref_mut(),
    )?;
    let stats_path = args
        .stats
        .clone()
        .unwrap_or_else(|| args.out.with_extension("json"));
    let json = serde_json::json!({
        "scene": prepared.world.scene.name,
        "display": display.name,
        "ipd_m": prepared.rig.ipd_m,
        "fixation": [target.x, target.y, target.z],
        "gaze_left": [lg.point.x_px, lg.point.y_px],
        "gaze_right": [rg.point.x_px, rg.point.y_px],
        "quality": args.frame.quality(Quality::Offline).name(),
        "shading": settings.shading,
        "pixel_samples": settings.pixel_samples,
        "periphery_rays": settings.periphery_rays,
        "denoise": settings.denoise,
        "reconstruct_filter": settings.reconstruct_filter,
        "inset_smoothing": (settings.method == Method::Inset)
            .then(|| settings.inset_smoothing.name()),
        "stereo": frame.stats,
        "exposure": exposure_json(exposure.0, &exposed),
        "lod": lod_stats,
        "left": frame.left.stats,
        "right": frame.right.stats,
        // Whether the eyes rendered at the same time, their device work in shared submissions.
        "lockstep": second.is_some(),
        // Both eyes ran on the same device; the GPU's times are summed over both eyes.
        "backend": with_route(backend.json(&frame.left.stats), staged_because),
    });
    crate::output::write_file(
        &stats_path,
        (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
    )?;
    let st = &frame.stats;
    println!(
        "{} {w}x{h} ×2 {} {} | primary rays: left {}, right {} ({} warped, {} cracks filled, {} holes traced) | {:.0} ms",
        prepared.world.scene.name,
        settings.method,
        mode.name(),
        thousands(st.rays_primary_left),
        thousands(st.rays_primary_right),
        thousands(st.warped),
        thousands(st.cracks_filled),
        thousands(st.holes_traced),
        st.total_ms
    );
    println!("{}", wrote_line(&[&args.out, &stats_path]));
    println!("{}", backend_line(&backend, &frame.left.stats));
    Ok(())
}

/// Why the resident frame cannot write what was asked for besides the image (or `--staged`): it keeps no
/// depth, density or CoC image, and an EXR of a DOF frame needs the colour after the DOF (it
/// reads the linear colour before it).
fn resident_outputs(args: &RenderArgs, dof: bool) -> std::result::Result<(), String> {
    if args.staged {
        return Err("--staged asked for".into());
    }
    if args.depth_out.is_some() || args.density_out.is_some() || args.coc_out.is_some() {
        return Err("not served: --depth-out, --density-out or --coc-out".into());
    }
    let exr = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if exr && dof {
        return Err("not served: an EXR of a DOF frame (write a PNG)".into());
    }
    Ok(())
}

/// The backend's JSON with the route its frames took: `"staged"` and why, on a GPU.
fn with_route(mut json: serde_json::Value, staged_because: Option<String>) -> serde_json::Value {
    if let Some(why) = staged_because {
        json["route"] = "staged".into();
        json["staged_because"] = why.into();
    }
    json
}

/// Writes the stats JSON of a resident frame (`--stats` or beside `--out`) and prints what
/// was written and `line`.
fn write_resident(
    args: &RenderArgs,
    stats: &serde_json::Value,
    line: &str,
    written: &[&Path],
) -> Result<()> {
    let path = args
        .stats
        .clone()
        .unwrap_or_else(|| args.out.with_extension("json"));
    crate::output::write_file(
        &path,
        (serde_json::to_string_pretty(stats)? + "\n").as_bytes(),
    )?;
    let mut all: Vec<&Path> = vec![&args.out];
    all.extend_from_slice(written);
    all.push(&path);
    println!("{}", wrote_line(&all));
    println!("backend: {}", line);
    Ok(())
}

/// "backend: GPU: <adapter> | primary rays on the GPU, surfaces on the GPU, shadow rays on the GPU, direct light on
/// the GPU, environment light on the GPU, aa on the GPU, reconstruct on the GPU, every other stage on the CPU", or "backend: CPU (<why>)": where a frame's stages
/// ran.
fn backend_line(
    backend: &crate::backend::Backend,
    s: &fovea_render::pipeline::FrameStats,
) -> String {
    // The tone map ran on the GPU when its executor recorded a call.
    let toned = match backend.tone_mapped() {
        true => "gpu".to_string(),
        false => "cpu".to_string(),
    };
    let on_gpu: Vec<String> = [
        ("ray generation", &s.ray_generation_backend),
        ("primary rays", &s.trace_backend),
        ("surfaces", &s.surface_backend),
        ("shadow rays", &s.shadow_backend),
        ("direct light", &s.direct_light_backend),
        ("environment light", &s.environment_light_backend),
        ("aa", &s.aa_backend),
        ("reconstruct", &s.reconstruct_backend),
        ("depth of field", &s.dof_backend),
        ("tone map", &toned),
    ]
    .into_iter()
    .filter(|(_, b)| b.as_str() != "cpu")
    .map(|(stage, b)| format!("{stage} on the {}", b.to_uppercase()))
    .collect();
    let ran = if on_gpu.is_empty() {
        String::new()
    } else {
        format!(" | {}, every other stage on the CPU", on_gpu.join(", "))
    };
    format!("backend: {}{ran}", backend.describe)
}

/// "wrote a, b and c": every file a render wrote, in the order written.
fn wrote_line(paths: &[&Path]) -> String {
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    match names.split_last() {
        None => "wrote nothing".into(),
        Some((last, [])) => format!("wrote {last}"),
        Some((last, rest)) => format!("wrote {} and {last}", rest.join(", ")),
    }
}

/// The frame's world with gaze-contingent level of detail: the eye state's gaze and focus (the
/// depth around the gaze where the frame has no depth of field), Eq. 14 per object,
/// simplified meshes elsewhere.
fn lod_world(
    prepared: &crate::scene_args::Prepared,
    settings: &FrameSettings,
    eye_state: &EyeState,
    keep: f32,
) -> Result<(fovea_render::world::World, fovea_render::lod::LodStats)> {
    use fovea_render::lod::{LodParams, LodScene};
    let params = LodParams {
        keep_ratio: keep,
        ..Default::default()
    };
    let lod = LodScene::new(prepared.world.scene.clone(), params)?;
    let eye = settings
        .dof
        .as_ref()
        .map_or(fovea_core::optics::EyeModel::default(), |d| d.eye);
    Ok(lod.world_for(&prepared.world, &prepared.camera, &eye, eye_state)?)
}
