//! `fovea flicker`: peripheral temporal flicker of foveation methods, with and without
//! temporal accumulation, against the full-resolution sequence. The measurement is
//! [`fovea_eval::experiments::flicker`]; this file parses the options, builds the sequence
//! (gaze trajectory and camera motion), shows progress and writes `flicker.json`,
//! `flicker.md` and `flicker-frames.csv`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::optics::AccommodationParams;
use fovea_eval::experiments::flicker::{
    check_sequence, run as run_flicker, FlickerParams, FlickerResult,
};
use fovea_eval::experiments::scenario::camera_slide;
use fovea_eval::flicker::PERIPHERY_DEG;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::FrameSettings;
use fovea_render::sequence::Sequence;
use fovea_render::shade::ShadingMode;
use fovea_render::world::World;

use crate::choices::{self, AccumulationChoice, EnvLightChoice, Headset, Scenario, Shading};
use crate::common::{DenoiseArgs, DisplayArgs, InsetSmoothingArgs, MethodOptions};
use crate::render::{memory_limit, shading, EnvLightArgs};
use crate::scene_args::{parse_vec3, prepare, SceneArgs};
use crate::sequence::{gaze_trajectory, path_cameras, read_camera_path, read_gaze_csv};
use crate::temporal_args::TemporalArgs;

/// The default camera slide over the sequence (`--camera-move`).
pub const DEFAULT_CAMERA_MOVE: &str = "0.04,0.01,0";

/// Options of `fovea flicker`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct FlickerArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    #[command(flatten)]
    pub options: MethodOptions,
    #[command(flatten)]
    pub temporal_opts: TemporalArgs,
    #[command(flatten)]
    pub inset: InsetSmoothingArgs,
    /// Foveation methods to compare (comma-separated).
    #[arg(long, default_value = "vafr,kfr,visual-polar,inset,weier")]
    pub methods: String,
    /// Shading of every frame and of the reference. Without it: noise-free (the unshadowed
    /// environment; the flicker of the method alone; no denoiser). `indirect`, `direct` or
    /// `path`: the shading a viewer gets, with its Monte Carlo noise (issue 38) and the
    /// denoiser (--denoise), which the reference then carries too (raise --reference-spp).
    #[arg(long, value_enum, ignore_case = true)]
    pub shading: Option<Shading>,
    /// Indirect bounces of --shading indirect (default 3) or path (default 2), 1 to 16.
    #[arg(long)]
    pub bounces: Option<u32>,
    #[command(flatten)]
    pub env: EnvLightArgs,
    #[command(flatten)]
    pub denoise: DenoiseArgs,
    /// Temporal accumulation: off, on or both (each method twice).
    #[arg(long, value_enum, ignore_case = true, default_value_t = AccumulationChoice::Both)]
    pub temporal: AccumulationChoice,
    /// Frames.
    #[arg(long, default_value_t = 120)]
    pub frames: u32,
    /// Frames per second.
    #[arg(long, default_value_t = 90.0)]
    pub fps: f64,
    /// Synthesised gaze scenario.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Scenario::SaccadePursuit)]
    pub scenario: Scenario,
    /// Gaze from an eye-tracker CSV instead.
    #[arg(long, conflicts_with = "scenario")]
    pub gaze_csv: Option<PathBuf>,
    /// Seed of the synthesised gaze.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Camera translation over the whole sequence, X,Y,Z metres in the camera's frame
    /// (right, up, back), looking in a fixed direction.
    #[arg(long, default_value = DEFAULT_CAMERA_MOVE)]
    pub camera_move: String,
    /// Camera path CSV (as `fovea sequence`) instead of --camera-move.
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// Band edges in degrees of eccentricity (the last band is open).
    #[arg(long, default_value = "0,5,10,20,30")]
    pub bands: String,
    /// Pixel samples of the full-resolution reference (stratified over the pixel area): a
    /// one-sample reference aliases and flickers itself.
    #[arg(long, default_value_t = 4)]
    pub reference_spp: u32,
    /// Eccentricity where the periphery starts, degrees.
    #[arg(long, default_value_t = PERIPHERY_DEG)]
    pub periphery: f64,
    /// Output folder: flicker.json, flicker.md, flicker-frames.csv.
    #[arg(long, default_value = "fovea-out/flicker")]
    pub out: PathBuf,
    /// Refuse frames needing more memory than this (e.g. 8G).
    #[arg(long)]
    pub max_memory: Option<String>,
    /// Also write every frame of every variant as PNG (out/frames/METHOD-on|off/, and
    /// out/frames/reference/).
    #[arg(long)]
    pub save_frames: bool,
    /// Print the JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The measurement's parameters from the options, checked.
pub fn params(args: &FlickerArgs) -> Result<FlickerParams> {
    let methods: Vec<Method> = args
        .methods
        .split(',')
        .filter(|m| !m.trim().is_empty())
        .map(|m| crate::common::parse_list_method(m.trim()))
        .collect::<std::result::Result<_, _>>()?;
    let bands_deg: Vec<f64> = args
        .bands
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| {
            format!(
                "invalid parameter `bands` = {}: expected degrees, e.g. 0,5,10,20,30",
                args.bands
            )
        })?;
    let mut frame = FrameSettings::new(Method::Vafr);
    // Flicker of the method alone between frames whose samples move: without Monte Carlo
    // noise, unless a shading is asked for (then with the viewer's noise and denoiser).
    frame.shading = match args.shading {
        None => ShadingMode::NOISE_FREE,
        Some(kind) => shading(
            Some(kind),
            fovea_render::quality::Quality::Offline,
            args.bounces,
            1,
            args.seed,
            &args.env,
            EnvLightChoice::Occluded,
        )?,
    };
    // The denoiser has nothing to filter in noise-free frames (they would come back bit for
    // bit): it runs with a shading asked for.
    if args.shading.is_some() {
        args.denoise.apply(&mut frame);
    }
    frame.mapping = args
        .options
        .frame_config(fovea_render::quality::Quality::Offline)?;
    args.options.warn_inapplicable(&methods);
    frame.memory_limit_bytes = memory_limit(args.max_memory.as_deref())?;
    frame.contrast = args.temporal_opts.contrast()?;
    args.inset.apply(&mut frame);
    let params = FlickerParams {
        methods,
        accumulation: args.temporal.into(),
        temporal: args.temporal_opts.settings()?,
        bands_deg,
        periphery_deg: args.periphery,
        reference_spp: args.reference_spp,
        frame,
        save_frames: args.save_frames.then(|| args.out.join("frames")),
    };
    params.validate()?;
    Ok(params)
}

pub fn run(args: FlickerArgs) -> Result<()> {
    check_sequence(args.frames as usize, args.fps)?;
    let params = params(&args)?;
    let prepared = prepare(
        &args.scene.within_memory(params.frame.memory_limit_bytes),
        &args.display,
        Headset::VivePro,
    )?;
    let display = prepared.camera.display.clone();
    let duration_s = args.frames as f64 / args.fps;
    let gaze_csv_text = read_gaze_csv(args.gaze_csv.as_deref())?;
    let gazes = gaze_trajectory(
        args.gaze_csv.as_deref().zip(gaze_csv_text.as_deref()),
        args.scenario.into(),
        args.seed,
        args.quiet,
        &display,
        duration_s,
    )?
    .resample(args.fps, args.frames as usize)?;
    let cameras: Vec<EyeCamera> = match &args.camera_path {
        Some(p) => path_cameras(
            &read_camera_path(p)?.0,
            args.frames as usize,
            args.fps,
            &display,
        )?,
        None => {
            let m = parse_vec3("camera-move", &args.camera_move)?;
            camera_slide(&prepared.camera, m.to_array(), args.frames as usize)?
        }
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create directory {}", args.out.display()))?;
    let seq = Sequence::plan(
        &prepared.world,
        cameras,
        gazes,
        None,
        args.fps,
        AccommodationParams::default(),
        None,
    )?;
    let result = measure(&prepared.world, &seq, &params, args.quiet)?;
    let scenario = choices::name(&args.scenario);
    let written = write_outputs(
        &result,
        &display,
        args.gaze_csv.is_none().then_some(scenario.as_str()),
        args.camera_path
            .is_none()
            .then_some(args.camera_move.as_str()),
        &args.out,
    )?;
    if args.json {
        print!("{}", written.json_text);
    } else {
        print!("{}", written.markdown);
        println!("wrote {}", args.out.display());
    }
    Ok(())
}

/// Runs the measurement with a progress bar on a terminal (a line per tenth of the run when
/// stderr is a log file), unless `quiet`.
pub fn measure(
    world: &World,
    seq: &Sequence,
    params: &FlickerParams,
    quiet: bool,
) -> Result<FlickerResult> {
    let variants = params.methods.len() * params.accumulation.modes().len();
    let pb = if quiet {
        ProgressBar::hidden()
    } else {
        let pb = ProgressBar::new(seq.len() as u64 * (1 + variants as u64));
        pb.set_style(
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} renders, eta {eta}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        pb.set_message("flicker");
        pb
    };
    let log_progress = !std::io::IsTerminal::is_terminal(&std::io::stderr());
    let started = std::time::Instant::now();
    let result = run_flicker(world, seq, params, &mut |p| {
        pb.set_position(p.renders_done);
        // The bar is hidden when stderr is a log file; a line per tenth of the run instead.
        let (i, n) = (p.frame, p.frames);
        let step = (n / 10).max(1);
        if p.frame_done && !quiet && log_progress && ((i + 1) % step == 0 || i + 1 == n) {
            eprintln!(
                "flicker: frame {}/{} after {:.0} s",
                i + 1,
                n,
                started.elapsed().as_secs_f64()
            );
        }
    })?;
    pb.finish_and_clear();
    Ok(result)
}

/// What [`write_outputs`] wrote.
pub struct Written {
    /// `flicker.json`.
    pub json: serde_json::Value,
    /// Its text.
    pub json_text: String,
    /// `flicker.md`.
    pub markdown: String,
}

/// Writes `flicker.json`, `flicker-frames.csv` and `flicker.md` into `out`. `scenario` and
/// `camera_move` say how the sequence was made (`None`: a gaze CSV, a camera path).
pub fn write_outputs(
    result: &FlickerResult,
    display: &DisplayProfile,
    scenario: Option<&str>,
    camera_move: Option<&str>,
    out: &Path,
) -> Result<Written> {
    let json = serde_json::json!({
        "scene": result.scene,
        "display": display,
        "frames": result.frames,
        "fps": result.fps,
        "scenario": scenario,
        "camera_move": camera_move,
        "temporal_settings": result.params.temporal,
        "peripheral_contrast": result.params.frame.contrast,
        "variants": result.variants,
    });
    let text = serde_json::to_string_pretty(&json)? + "\n";
    let write = |name: &str, text: &str| {
        let p = out.join(name);
        crate::output::write_file(&p, text.as_bytes())
    };
    write("flicker.json", &text)?;
    write("flicker-frames.csv", &result.frames_csv())?;
    let markdown = result.markdown();
    write("flicker.md", &markdown)?;
    Ok(Written {
        json,
        json_text: text,
        markdown,
    })
}
