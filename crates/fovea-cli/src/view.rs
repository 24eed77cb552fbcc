//! `fovea view`: a window where the mouse or an eye tracker is the gaze (the `fovea-viewer`
//! crate, in builds with `--features view`). This file parses the options, loads the scene,
//! resolves the backend and hands everything to `fovea_viewer::run`.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};

use crate::choices::{BackendArg, Eyes, LockstepArg, MethodChoice};
use crate::common::{DisplayArgs, FrameOptions, MethodOptions};
use crate::dof_args::DofArgs;
use crate::exposure_args::ExposureArgs;
use crate::scene_args::SceneArgs;

/// Most frames of a headless run.
#[cfg_attr(not(feature = "view"), allow(dead_code))]
const MAX_FRAMES: u64 = 100_000;

/// How a replayed gaze CSV advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Replay {
    /// At the recorded times (looping).
    RealTime,
    /// One sample per press of N (per frame with --frames).
    Stepped,
}

/// Options of `fovea view`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ViewArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    /// The method to open with (keys 1–9 and the panel switch it).
    #[arg(long, value_enum, ignore_case = true, default_value_t = MethodChoice::Vafr)]
    pub method: MethodChoice,
    #[command(flatten)]
    pub options: MethodOptions,
    #[command(flatten)]
    pub frame: FrameOptions,
    #[command(flatten)]
    pub env: crate::render::EnvLightArgs,
    #[command(flatten)]
    pub dof: DofArgs,
    #[command(flatten)]
    pub exposure: ExposureArgs,
    /// Which executor renders: cpu, gpu or auto (the stages `fovea render --backend` runs on
    /// a GPU, on a hardware GPU when there is one: rays, lights, AA, reconstruction, gather
    /// DOF, the tone map).
    #[arg(long, value_enum, ignore_case = true, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// One eye, or both side by side (V switches).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Eyes::One)]
    pub eyes: Eyes,
    /// Both eyes on a GPU: on renders them at the same time, each eye's device work waiting
    /// for the other's so that both go to the GPU in one submission; off renders them one
    /// after the other; auto (default): on for a hardware GPU, off on a CPU-emulated one
    /// (lavapipe), where it measured slower.
    #[arg(long, value_enum, ignore_case = true, default_value_t = LockstepArg::Auto)]
    pub lockstep: LockstepArg,
    /// Render scale of the display, 0.05 to 1 (default: 1 on the GPU and headless; 0.5 on
    /// the CPU path, which refines a still view to full scale).
    #[arg(long)]
    pub scale: Option<f32>,
    /// Gaze from an eye-tracker CSV (the formats `fovea sequence --gaze-csv` reads) instead
    /// of the mouse.
    #[arg(long, alias = "gaze-script", conflicts_with = "gaze_udp")]
    pub gaze_csv: Option<PathBuf>,
    /// How the CSV is replayed: real-time (at its times, looping) or stepped (key N; with
    /// --frames, one sample per frame at the CSV's times is real-time's).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Replay::RealTime)]
    pub replay: Replay,
    /// Gaze from an eye tracker streaming JSON lines over UDP to 127.0.0.1:PORT (the README
    /// has the protocol).
    #[arg(long)]
    pub gaze_udp: Option<u16>,
    /// Camera path CSV to follow (`t,x,y,z,look_x,look_y,look_z[,up_x,up_y,up_z]`, as
    /// `fovea sequence --camera-path`) instead of the keys.
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// Headless: render N frames (frame i at i/fps seconds of the gaze and the camera path),
    /// write --screenshot, and exit.
    #[arg(long)]
    pub frames: Option<u64>,
    /// Frames per second of --frames (and of the recording's times).
    #[arg(long, default_value_t = 90.0)]
    pub fps: f64,
    /// With --frames: write the last frame here (PNG, with its statistics as .json beside).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// Write every frame shown as frame_00000.png … into this folder.
    #[arg(long)]
    pub frames_out: Option<PathBuf>,
    /// Record the gaze and camera of every frame shown into this folder (gaze.csv,
    /// camera.csv: what `fovea sequence --gaze-csv … --camera-path …` reads back).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Where the screenshot key (P) writes shot_0001.png ….
    #[arg(long, default_value = "fovea-out/view")]
    pub shots: PathBuf,
    /// Camera speed of W A S D Q E, metres per second.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f32,
    /// Refuse frames needing more memory than this (e.g. 8G).
    #[arg(long)]
    pub max_memory: Option<String>,
    /// No progress lines.
    #[arg(long, short)]
    pub quiet: bool,
}

#[cfg(not(feature = "view"))]
pub fn run(_args: ViewArgs) -> Result<()> {
    anyhow::bail!(
        "this fovea was built without the viewer; run `cargo run --release --features view -- view` \
         (Rust 1.95 or later; wgpu, winit and egui add a few minutes to the first build)"
    )
}

#[cfg(feature = "view")]
pub fn run(args: ViewArgs) -> Result<()> {
    use anyhow::bail;
    use fovea_render::pipeline::FrameSettings;
    use fovea_viewer::controls::{EyesChoice, FocusChoice, PupilChoice, ViewMethod};
    use fovea_viewer::gaze_input::{GazeReplay, ReplayMode};
    use fovea_viewer::{GazeSource, Pose, ViewSettings, ViewerConfig};

    use crate::choices::{EnvLightChoice, Headset};
    use crate::scene_args::prepare;

    if let Some(n) = args.frames {
        if !(1..=MAX_FRAMES).contains(&n) {
            bail!("invalid parameter `frames` = {n}: expected 1 to {MAX_FRAMES}");
        }
    } else if args.screenshot.is_some() {
        bail!("--screenshot is for headless runs (--frames N); in the window, press P");
    }
    if !(args.fps.is_finite() && (1.0..=1000.0).contains(&args.fps)) {
        bail!("invalid parameter `fps` = {}: expected 1 to 1000", args.fps);
    }
    if let Some(s) = args.scale {
        if !(s.is_finite() && (0.05..=1.0).contains(&s)) {
            bail!("invalid parameter `scale` = {s}: expected 0.05 to 1");
        }
    }
    if !(args.speed.is_finite() && args.speed > 0.0 && args.speed <= 1000.0) {
        bail!(
            "invalid parameter `speed` = {}: expected 0 to 1000 m/s",
            args.speed
        );
    }
    if let Some(p) = &args.screenshot {
        crate::output::check_image_path(p)?;
    }
    // Before the scene loads: no window, no point loading it. The connection is made before
    // the GPU is probed (a Vulkan layer's own connect and disconnect would otherwise reset
    // the X server just before the window connects) and held until the window's is open.
    fovea_viewer::check_display_server()?;
    let display_hold = fovea_viewer::connect_display_server(args.quiet)?;
    args.display.display(Headset::VivePro)?;
    let liu_hybrid = args.method.is_liu_hybrid();
    let method = args.method.method();
    let dof = args.dof.settings(liu_hybrid)?;
    let config = args
        .options
        .frame_config(args.frame.quality(fovea_render::quality::Quality::Realtime))?;
    args.options.warn_inapplicable(&[method]);
    args.exposure.asked()?;
    let memory_limit = crate::render::memory_limit(args.max_memory.as_deref())?;
    let prepared = prepare(
        &args.scene.within_memory(memory_limit),
        &args.display,
        Headset::VivePro,
    )?;
    let display = prepared.camera.display.clone();
    let mut base = FrameSettings::new(method);
    base.mapping = config;
    base.memory_limit_bytes = memory_limit;
    base.dof = dof.clone();
    args.frame.apply(&mut base);
    base.shading = crate::render::shading(
        None,
        args.frame.quality(fovea_render::quality::Quality::Realtime),
        None,
        1,
        0,
        &args.env,
        EnvLightChoice::Occluded,
    )?;
    base.validate()?;
    let stops = crate::exposure_args::metered_stops(
        &args.exposure,
        &prepared.world,
        &prepared.camera,
        &base,
    )?;

    // The GPU executors serve every method; switching methods in the window keeps them (a
    // stage a device cannot take for a method runs on the CPU).
    let mut backend = crate::backend::resolve(args.backend, &prepared.world)?;
    let cpu_path = !backend.on_gpu();
    let headless = args.frames.is_some();
    let scale = args
        .scale
        .unwrap_or(if cpu_path && !headless { 0.5 } else { 1.0 });
    if cpu_path && !args.quiet {
        eprintln!(
            "note: rendering on the CPU ({}){}",
            backend.describe,
            if scale < 1.0 {
                format!(
                    ", at {:.0} % scale while the view moves and full scale when it is still",
                    scale * 100.0
                )
            } else {
                String::new()
            }
        );
    }

    let gaze = if let Some(p) = &args.gaze_csv {
        let text = crate::common::read_text_input(p, "gaze CSV")?;
        let t = crate::sequence::csv_trajectory(p, &text, args.quiet, &display)?;
        let mode = match args.replay {
            Replay::RealTime => ReplayMode::RealTime,
            Replay::Stepped => ReplayMode::Stepped,
        };
        GazeSource::Replay(GazeReplay::new(t, mode))
    } else if let Some(port) = args.gaze_udp {
        GazeSource::Udp(port)
    } else {
        GazeSource::Mouse
    };
    let camera_path = args
        .camera_path
        .as_deref()
        .map(crate::sequence::read_camera_path)
        .transpose()?
        .map(|(p, _)| p);

    let view_method = if liu_hybrid {
        ViewMethod::LiuHybrid
    } else {
        ViewMethod::Method(method)
    };
    let mut view = ViewSettings::new(view_method, dof.as_ref().and_then(|d| d.filter), scale);
    view.eyes = match args.eyes {
        Eyes::One => EyesChoice::One,
        Eyes::Both => EyesChoice::Both,
    };
    view.exposure_stops = stops;
    if let Some(d) = &dof {
        view.focus = match d.focus {
            fovea_render::dof::FocusMode::Auto => FocusChoice::Auto,
            fovea_render::dof::FocusMode::Fixed(m) => FocusChoice::FixedM(m),
        };
        view.pupil = PupilChoice::Mm(d.eye.pupil.0);
    }
    let summary = fovea_viewer::run(ViewerConfig {
        display,
        pose: Pose::of(&prepared.camera),
        ipd_m: args.scene.ipd,
        world: prepared.world,
        base,
        view,
        gaze,
        camera_path,
        frames: args.frames,
        fps: args.fps,
        screenshot: args.screenshot.clone(),
        shots_dir: args.shots.clone(),
        frames_out: args.frames_out.clone(),
        record: args.record.clone(),
        second_eye: backend.second_eye(args.lockstep).map(|(mut ctx, device)| {
            fovea_viewer::SecondEyeExecutors {
                executors: ctx.take_executors(),
                lockstep: device,
            }
        }),
        executors: backend.take_executors(),
        tone_map: backend.tone_map.take(),
        resident: backend.gpu.clone(),
        backend: backend.describe.clone(),
        cpu_path,
        move_speed_m_s: args.speed,
        quiet: args.quiet,
        display_hold,
    })?;
    println!(
        "{} frames in {:.1} s: {:.2} fps, {:.0} ms a frame | window: {} | frames: {}",
        summary.frames,
        summary.frames as f64 / summary.fps.max(1e-9),
        summary.fps,
        summary.mean_frame_ms,
        summary.adapter,
        summary.backend
    );
    if let Some(c) = &summary.stream {
        println!(
            "gaze stream: {} lines, {} valid, {} gaps, {} clamped, {} malformed (skipped)",
            c.lines, c.valid, c.gaps, c.clamped, c.malformed
        );
    }
    if let Some(r) = &args.record {
        println!(
            "recorded into {}: replay with `fovea sequence --gaze-csv {0}/gaze.csv --camera-path {0}/camera.csv --fps {} ...`",
            r.display(),
            args.fps
        );
    }
    for p in &summary.written {
        println!("wrote {}", p.display());
    }
    Ok(())
}
