//! `fovea sequence`: N frames of a gaze trajectory (an eye-tracker CSV or a synthesised
//! scenario) through a foveation method, with depth of field whose focus follows the gaze
//! through the accommodation filter, written as a numbered PNG series (and an MP4 when `ffmpeg`
//! is installed). Interrupted runs resume: the eye state of every frame is planned first (it
//! costs a few thousand rays per frame), and frames whose PNG is already there are not
//! rendered again. Each file is written to a temporary name, synced and renamed
//! ([`fovea_core::atomic_file`]), so a killed run or a full disk leaves no half-written frame
//! under a frame's name; a frame that cannot be written stops the run (exit 2) and a rerun
//! resumes from it. Frames are reused only where `sequence.json` (written before the first
//! frame) holds this run's settings: a folder with other settings, or with frames and no
//! manifest, is refused unless `--overwrite`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use serde::Serialize;

use fovea_core::display::DisplayProfile;
use fovea_core::gaze::csv::{parse_csv, CsvOptions};
use fovea_core::gaze::GazeTrajectory;
use fovea_core::optics::AccommodationParams;
use fovea_eval::experiments::scenario::GazeScenario;
use fovea_post::tonemap::ToneCurve;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::camera_path::CameraPath;
use fovea_render::eye::FocusDistance;
use fovea_render::pipeline::FrameSettings;
use fovea_render::plan::FramePlan;
use fovea_render::sequence::{Sequence, SequenceDriver, Track};
use fovea_render::temporal::TemporalSettings;

use crate::choices::{self, BackendArg, Headset, MethodChoice, Scenario, Switch, Video};
use crate::common::{read_text_input, DisplayArgs, FrameOptions, MethodOptions};
use crate::dof_args::DofArgs;
use crate::exposure_args::ExposureArgs;
use crate::output::write_file;
use crate::render::memory_limit;
use crate::resident::SequenceImage;
use crate::scene_args::{prepare, SceneArgs};
use crate::temporal_args::TemporalArgs;

/// Most frames of one sequence.
const MAX_FRAMES: u32 = 100_000;

/// Options of `fovea sequence`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct SequenceArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    /// Foveation method (as `fovea render`), or liu-hybrid.
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
    /// Which executor casts the primary rays and reconstructs polar frames: cpu, gpu or auto,
    /// as `fovea render --backend` (the GPU needs a fovea built with `--features gpu`).
    #[arg(long, value_enum, ignore_case = true, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// With a GPU backend: the staged path (the CPU pipeline with its stages lent to the GPU
    /// call by call) even where the resident frame (the whole frame on the device, one
    /// submission, the image read back for its file) serves the sequence; for comparison.
    #[arg(long)]
    pub staged: bool,
    /// Frames to render.
    #[arg(long, default_value_t = 120)]
    pub frames: u32,
    /// Temporal accumulation (reprojection of the previous frame): on (default) or off. Each
    /// frame's shading draws its own random numbers (issue 38), so a still view converges
    /// towards the many-ray frame. A resumed run
    /// rebuilds the history from the (up to) 32 frames before the first missing one, without
    /// writing them: identical frames when it falls within the first 32, otherwise history
    /// older than 32 frames (weight ≤ (1 − α_min)³² ≈ 3 %) is lost.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Switch::On)]
    pub temporal: Switch,
    /// Shading: indirect (direct light plus three bounces of indirect light), direct, or path
    /// (path tracing, two bounces, one path per sample).
    #[arg(long, value_enum, ignore_case = true)]
    pub shading: Option<crate::choices::Shading>,
    #[command(flatten)]
    pub temporal_opts: TemporalArgs,
    /// Frames per second (the gaze trajectory is sampled at these times).
    #[arg(long, default_value_t = 90.0)]
    pub fps: f64,
    /// Gaze from an eye-tracker CSV (see docs: time + gaze in pixels or normalised, e.g. a
    /// Pupil Labs gaze_positions.csv); gaps (blinks) hold the last valid gaze.
    #[arg(long, conflicts_with = "scenario")]
    pub gaze_csv: Option<PathBuf>,
    /// Synthesised gaze: demo (fixations, saccades and a pursuit), saccade-pursuit (120
    /// frames' worth of both), random-walk, or fixation (the screen centre).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Scenario::Demo)]
    pub scenario: Scenario,
    /// Camera path CSV (`t,x,y,z,look_x,look_y,look_z[,up_x,up_y,up_z]`, seconds and metres,
    /// interpolated linearly); default: the scene's camera, still. Lights stay where they were
    /// set for the first frame.
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// Seed of the synthesised gaze.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder: frame_00000.png …, frames.csv (gaze and focus per frame),
    /// sequence.json (settings), sequence.mp4 (with ffmpeg).
    #[arg(long, default_value = "fovea-out/sequence")]
    pub out: PathBuf,
    /// Video: auto (when ffmpeg is installed), on (fail without ffmpeg) or off.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Video::Auto)]
    pub video: Video,
    /// Render the frames again when the folder holds frames of other settings, or frames
    /// without a sequence.json to vouch for them (otherwise an error).
    #[arg(long)]
    pub overwrite: bool,
    /// Refuse frames needing more memory than this (e.g. 8G).
    #[arg(long)]
    pub max_memory: Option<String>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The gaze of a sequence: an eye-tracker CSV (its path, for messages, and its text, see
/// [`read_gaze_csv`]), or a synthesised scenario of `duration_s`.
pub fn gaze_trajectory(
    gaze_csv: Option<(&Path, &str)>,
    scenario: GazeScenario,
    seed: u64,
    quiet: bool,
    d: &DisplayProfile,
    duration_s: f64,
) -> Result<GazeTrajectory> {
    if let Some((p, text)) = gaze_csv {
        return csv_trajectory(p, text, quiet, d);
    }
    Ok(scenario.trajectory(d, seed, duration_s)?)
}

/// The gaze of an eye-tracker CSV (its path, for messages, and its text) on `d`'s screen; a
/// line on stderr counts its rows, gaps and clamps unless `quiet`.
pub fn csv_trajectory(
    p: &Path,
    text: &str,
    quiet: bool,
    d: &DisplayProfile,
) -> Result<GazeTrajectory> {
    let (w, h) = (d.width_px as f64, d.height_px as f64);
    let (t, report) = parse_csv(text, w, h, &CsvOptions::default())
        .with_context(|| format!("gaze CSV {}", p.display()))?;
    if !quiet {
        eprintln!(
            "gaze CSV: {} rows, {} valid, {} held (gaps), {} clamped to the screen",
            report.rows, report.valid, report.held, report.clamped
        );
    }
    Ok(t)
}

/// The text of `--gaze-csv`, read once (it decides the gaze and, hashed, whether a folder
/// resumes).
pub fn read_gaze_csv(p: Option<&Path>) -> Result<Option<String>> {
    p.map(|p| {
        // The row limit first, one line at a time, so an oversized recording is refused
        // without holding its text (a regular file only; read_text_input names the rest).
        if std::fs::metadata(p).is_ok_and(|m| m.is_file()) {
            if let Ok(f) = std::fs::File::open(p) {
                fovea_core::gaze::csv::check_row_count(
                    std::io::BufReader::new(f),
                    CsvOptions::default().max_rows,
                )
                .with_context(|| format!("gaze CSV {}", p.display()))?;
            }
        }
        read_text_input(p, "gaze CSV")
    })
    .transpose()
}

pub fn run(args: SequenceArgs) -> Result<()> {
    if !(1..=MAX_FRAMES).contains(&args.frames) {
        bail!(
            "invalid parameter `frames` = {}: expected 1 to {MAX_FRAMES}",
            args.frames
        );
    }
    if !(args.fps.is_finite() && (1.0..=1000.0).contains(&args.fps)) {
        bail!("invalid parameter `fps` = {}: expected 1 to 1000", args.fps);
    }
    // Checked before the scene loads; the view's display may take the file camera's field of
    // view (see `Loaded::display`).
    args.display.display(Headset::VivePro)?;
    let liu_hybrid = args.method.is_liu_hybrid();
    let method = args.method.method();
    let config = args
        .options
        .frame_config(args.frame.quality(fovea_render::quality::Quality::Offline))?;
    args.options.warn_inapplicable(&[method]);
    let dof = args.dof.settings(liu_hybrid)?;
    args.exposure.asked()?;
    let temporal = if args.temporal.is_on() {
        Some(args.temporal_opts.settings()?)
    } else {
        None
    };
    let contrast = args.temporal_opts.contrast()?;
    let memory_limit = memory_limit(args.max_memory.as_deref())?;
    let prepared = prepare(
        &args.scene.within_memory(memory_limit),
        &args.display,
        Headset::VivePro,
    )?;
    let display = prepared.camera.display.clone();
    let duration_s = args.frames as f64 / args.fps;
    let gaze_csv_text = read_gaze_csv(args.gaze_csv.as_deref())?;
    let traj = gaze_trajectory(
        args.gaze_csv.as_deref().zip(gaze_csv_text.as_deref()),
        args.scenario.into(),
        args.seed,
        args.quiet,
        &display,
        duration_s,
    )?;
    let (camera_path, camera_path_text) = match &args.camera_path {
        Some(p) => {
            let (path, text) = read_camera_path(p)?;
            (Some(path), text)
        }
        None => (None, String::new()),
    };
    let gazes = traj.resample(args.fps, args.frames as usize)?;
    // The CSV's contents, not only its path, decide the frames.
    let gaze_csv_hash = gaze_csv_text
        .as_ref()
        .map(|t| format!("{:016x}", fnv1a(t.as_bytes())));
    let mut settings = FrameSettings::new(method);
    settings.mapping = config;
    settings.memory_limit_bytes = memory_limit;
    settings.contrast = contrast;
    settings.dof = dof;
    args.frame.apply(&mut settings);
    settings.shading = crate::render::shading(
        args.shading,
        args.frame.quality(fovea_render::quality::Quality::Offline),
        None,
        1,
        0,
        &args.env,
        crate::choices::EnvLightChoice::Occluded,
    )?;
    settings.validate()?;
    let exposure_stops = sequence_exposure(&args, &prepared, camera_path.as_ref(), &settings)?;

    let world = &prepared.world;
    // The head pose of each frame: the scene's, or the path's at the frame's time.
    let rigs: Vec<HmdRig> = (0..args.frames as usize)
        .map(|i| match &camera_path {
            Some(p) => {
                let (pos, look, up) = p.at(i as f64 / args.fps);
                Ok(HmdRig::new(pos, look - pos, up, args.scene.ipd)?)
            }
            None => Ok(prepared.rig.clone()),
        })
        .collect::<Result<_>>()?;
    let cameras: Vec<EyeCamera> = match &camera_path {
        Some(p) => path_cameras(p, args.frames as usize, args.fps, &display)?,
        None => vec![prepared.camera.clone(); args.frames as usize],
    };
    // Both eyes' cameras, for the vergence of a tracker's binocular gaze.
    let pairs: Option<Vec<(EyeCamera, EyeCamera)>> = if gazes.iter().any(|g| g.right.is_some()) {
        Some(
            rigs.iter()
                .map(|r| Ok((r.eye(Eye::Left, &display)?, r.eye(Eye::Right, &display)?)))
                .collect::<Result<_>>()?,
        )
    } else {
        None
    };

    // Plan the eye state of every frame: gaze, and the focus through the accommodation
    // filter (auto focus from the tracker's vergence, else the depth around the gaze).
    let seq = Sequence::plan(
        world,
        cameras,
        gazes,
        settings.dof.as_ref(),
        args.fps,
        AccommodationParams::default(),
        pairs.as_deref(),
    )?;
    // The first frame's plan, checked before anything is written (settings that no frame
    // can have fail here). Which executors cast the primary rays and reconstruct (`--backend`)
    // is decided here too; frames of another backend differ in the last bits, so the
    // backend is part of what a resumed folder must match.
    FramePlan::new(world, &seq.cameras[0], &settings, &seq.eyes[0], [0.0, 0.0])?;
    let mut backend = crate::backend::resolve(args.backend, world)?;
    let backend_name = if backend.on_gpu() { "gpu" } else { "cpu" };
    // On a GPU, the resident frame when it serves the settings (decided once, on frame 0's
    // plan), else the staged path; its frames differ from the staged ones in the last bits,
    // so the route is part of the manifest too.
    let inputs = crate::resident::SequenceInputs {
        world,
        seq: &seq,
        settings: &settings,
        temporal,
        exposure_stops,
    };
    let gpu_route = crate::resident::sequence_route(&backend, args.staged, &inputs)?;
    if let Some(why) = gpu_route
        .as_ref()
        .and_then(|r| r.staged_because())
        .filter(|_| !args.staged)
    {
        eprintln!(
            "note: the resident GPU frame does not render this sequence ({why}); rendering it \
             with the staged GPU path"
        );
    }
    // The settings the frames depend on: a folder rendered with others is not resumed.
    let method_name = choices::name(&args.method);
    let scenario_name = choices::name(&args.scenario);
    let manifest = Manifest {
        scene: &args.scene,
        display: &display,
        method: &method_name,
        settings: &settings,
        temporal,
        frames: args.frames,
        fps: args.fps,
        gaze_csv: args.gaze_csv.as_deref(),
        gaze_csv_fnv1a: gaze_csv_hash,
        scenario: if args.gaze_csv.is_some() {
            None
        } else {
            Some(&scenario_name)
        },
        seed: args.seed,
        camera_path: &camera_path_text,
        exposure_stops,
        backend: backend_name,
        route: gpu_route.as_ref().map(|r| r.name()),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create directory {}", args.out.display()))?;
    let manifest_path = args.out.join("sequence.json");
    let manifest_text = serde_json::to_string_pretty(&manifest)? + "\n";
    check_folder(&args.out, &manifest_path, &manifest_text, args.overwrite)?;
    write_file(&manifest_path, manifest_text.as_bytes())?;
    write_file(&args.out.join("frames.csv"), eye_csv(&seq).as_bytes())?;

    let pb = if args.quiet {
        ProgressBar::hidden()
    } else {
        let pb = ProgressBar::new(args.frames as u64);
        pb.set_style(
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} frames, eta {eta}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        pb.set_message("sequence");
        pb
    };
    let mut track = Track::new(method.name(), settings.clone(), temporal)?;
    backend.install(track.context_mut());
    let out = &args.out;
    let mut tone_map = backend.tone_map.take();
    // A frame that cannot be written (a full disk) stops the run: the frames before it are
    // complete under their names, and a rerun resumes from it.
    let mut write = |i: usize, image: SequenceImage<'_>| -> Result<()> {
        let path = frame_path(out, i);
        match image {
            SequenceImage::Srgb8(img) => {
                let bytes: Vec<u8> = img.data().iter().flatten().copied().collect();
                let png = crate::output::png_bytes(&path, img.width(), img.height(), bytes)?;
                write_file(&path, &png)
            }
            SequenceImage::Linear(frame) => {
                write_png(&path, &frame.color, exposure_stops, tone_map.as_deref_mut())
            }
        }
    };
    let skip = |i: usize| frame_is_complete(&frame_path(out, i), &display);
    let done = match gpu_route {
        Some(run) => crate::resident::run_sequence(
            run,
            &backend,
            &inputs,
            &mut track,
            &skip,
            &mut write,
            &mut |_| pb.inc(1),
        )
        .map(|d| (d.counts, Some((d.json, d.line)))),
        None => SequenceDriver::new(world, &seq, vec![track])
            .map_err(anyhow::Error::from)
            .and_then(|mut driver| {
                driver.run(
                    &skip,
                    &mut |e| write(e.index, SequenceImage::Linear(e.frames[0])),
                    &mut |_| pb.inc(1),
                )
            })
            .map(|counts| (counts, None)),
    };
    pb.finish_and_clear();
    let (counts, gpu) = done?;
    // On a GPU, which route each written frame took and what it moved (`stats.json`; not
    // part of the manifest, which decides what a rerun resumes).
    if let Some((json, _)) = &gpu {
        let stats = serde_json::json!({ "backend": json });
        write_file(
            &args.out.join("stats.json"),
            (serde_json::to_string_pretty(&stats)? + "\n").as_bytes(),
        )?;
    }
    println!(
        "{} frames in {}: {} rendered, {} already there",
        args.frames,
        args.out.display(),
        counts.rendered,
        counts.skipped
    );
    if !args.quiet {
        match &gpu {
            Some((_, line)) => println!("backend: {}: {line}", backend.describe),
            None => println!("backend: {}", backend.describe),
        }
    }
    make_video(&args.out, args.fps, args.video)?;
    Ok(())
}

/// What a sequence folder's frames depend on (`sequence.json`): rerunning with the same
/// manifest resumes, with another needs `--overwrite`.
#[derive(Serialize)]
struct Manifest<'a> {
    scene: &'a SceneArgs,
    display: &'a DisplayProfile,
    method: &'a str,
    settings: &'a FrameSettings,
    temporal: Option<TemporalSettings>,
    frames: u32,
    fps: f64,
    gaze_csv: Option<&'a Path>,
    gaze_csv_fnv1a: Option<String>,
    scenario: Option<&'a str>,
    seed: u64,
    camera_path: &'a str,
    /// The exposure of every frame's PNG, in stops.
    exposure_stops: f32,
    /// Where the primary rays and the reconstruction ran: `cpu` or `gpu`.
    backend: &'a str,
    /// On a GPU, the route decided before the first frame: `resident` or `staged`.
    #[serde(skip_serializing_if = "Option::is_none")]
    route: Option<&'a str>,
}

/// The one exposure of a sequence's frames (a per-frame auto exposure would flicker): the
/// stops asked for, or, for `auto` (the default for photometric lights), the auto exposure of
/// a full-resolution frame of the first camera, metered before any frame is rendered, so a
/// resumed sequence gets the same.
fn sequence_exposure(
    args: &SequenceArgs,
    prepared: &crate::scene_args::Prepared,
    camera_path: Option<&CameraPath>,
    settings: &FrameSettings,
) -> Result<f32> {
    let display = &prepared.camera.display;
    let camera = match camera_path {
        Some(p) => {
            let (pos, look, up) = p.at(0.0);
            EyeCamera::new(pos, look - pos, up, display)?
        }
        None => prepared.camera.clone(),
    };
    crate::exposure_args::metered_stops(&args.exposure, &prepared.world, &camera, settings)
}

/// `frames.csv`: the eye state of every frame.
pub fn eye_csv(seq: &Sequence) -> String {
    let mut csv =
        String::from("frame,t_s,gaze_x_px,gaze_y_px,gaze_valid,focus_source,vergence_m,focus_m\n");
    for (i, (g, e)) in seq.gazes.iter().zip(&seq.eyes).enumerate() {
        let metres = |f: Option<FocusDistance>| {
            f.map_or(String::new(), |f| match f {
                FocusDistance::Metres(m) => format!("{m:.5}"),
                FocusDistance::Infinity => "inf".to_string(),
            })
        };
        let source = e.focus_source.map_or(String::new(), |s| {
            serde_json::to_value(s)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default()
        });
        csv += &format!(
            "{i},{:.6},{:.3},{:.3},{},{source},{},{}\n",
            g.t_s,
            g.x_px,
            g.y_px,
            g.valid,
            metres(e.vergence),
            metres(e.focus)
        );
    }
    csv
}

/// The eye camera of each of `frames` frames at `fps` along `path`, rendering `display`.
pub fn path_cameras(
    path: &CameraPath,
    frames: usize,
    fps: f64,
    display: &DisplayProfile,
) -> Result<Vec<EyeCamera>> {
    (0..frames)
        .map(|i| {
            let (pos, look, up) = path.at(i as f64 / fps);
            Ok(EyeCamera::new(pos, look - pos, up, display)?)
        })
        .collect()
}

/// A camera path CSV and its text.
pub fn read_camera_path(p: &Path) -> Result<(CameraPath, String)> {
    let text = read_text_input(p, "camera path")?;
    let path = CameraPath::parse(&text).with_context(|| format!("camera path {}", p.display()))?;
    Ok((path, text))
}

/// 64-bit FNV-1a hash (stable across Rust versions, unlike `DefaultHasher`).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// `out/frame_00042.png`.
fn frame_path(out: &Path, i: usize) -> PathBuf {
    out.join(format!("frame_{i:05}.png"))
}

/// A frame counts as done when its header gives the display's size and the whole PNG
/// decodes (a frame cut short, e.g. by a full disk, has an intact header but truncated
/// data and is rendered again). Frames are display-sized, so decoding them is cheap.
fn frame_is_complete(path: &Path, d: &DisplayProfile) -> bool {
    image::image_dimensions(path).is_ok_and(|(w, h)| (w, h) == (d.width_px, d.height_px))
        && image::open(path)
            .is_ok_and(|img| (img.width(), img.height()) == (d.width_px, d.height_px))
}

/// Writes 8-bit sRGB PNG (Reinhard tone curve, as `fovea render`) whatever the extension,
/// encoded on `tone_map` when given, complete or not at all ([`write_file`]).
fn write_png(
    path: &Path,
    img: &fovea_core::Image<fovea_post::Rgb>,
    stops: f32,
    tone_map: Option<&mut (dyn fovea_post::tonemap::ToneMapExecutor + 'static)>,
) -> Result<()> {
    let bytes = crate::output::encode_srgb8(img, stops, ToneCurve::Reinhard, tone_map)?;
    let png = crate::output::png_bytes(path, img.width(), img.height(), bytes)?;
    write_file(path, &png)
}

/// Decides whether `out` may take this run's frames. Frames are reused only when
/// `sequence.json` vouches for them: its text is this run's `manifest` (the manifest is
/// written before the first frame, so every frame of a folder was rendered under the
/// manifest it holds). A folder whose manifest differs, or that holds frames (or a video)
/// without a manifest (deleted, or unreadable), is refused; with `overwrite` its frames are
/// removed and rendered again.
fn check_folder(out: &Path, manifest_path: &Path, manifest: &str, overwrite: bool) -> Result<()> {
    let old = match std::fs::read(manifest_path) {
        Ok(bytes) => Some(bytes),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => bail!("cannot read {}: {e}", manifest_path.display()),
    };
    if old.as_deref() == Some(manifest.as_bytes()) {
        return Ok(());
    }
    let frames = earlier_outputs(out)?;
    if old.is_none() && frames == 0 {
        return Ok(());
    }
    if !overwrite {
        match old {
            Some(_) => bail!(
                "{} holds frames rendered with other settings (its sequence.json differs); pass --overwrite to render them again or choose another --out",
                out.display()
            ),
            None => bail!(
                "{} holds {frames} frame file(s) but no sequence.json to say which settings rendered them; pass --overwrite to render them again or choose another --out",
                out.display()
            ),
        }
    }
    remove_frames(out)
}

/// The frames (`frame_*.png`) and video of an earlier run in `out`.
fn earlier_outputs(out: &Path) -> Result<usize> {
    let mut n = 0;
    for e in std::fs::read_dir(out).with_context(|| format!("cannot read {}", out.display()))? {
        let e = e.with_context(|| format!("cannot read {}", out.display()))?;
        let name = e.file_name();
        let name = name.to_string_lossy();
        let frame =
            (name.starts_with("frame_") && name.ends_with(".png")) || name == "sequence.mp4";
        if frame && e.path().is_file() {
            n += 1;
        }
    }
    Ok(n)
}

/// Removes the frames (and video) of an earlier run, with the temporary files of a run that
/// was killed while writing one.
fn remove_frames(out: &Path) -> Result<()> {
    for e in std::fs::read_dir(out).with_context(|| format!("cannot read {}", out.display()))? {
        let p = e?.path();
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let temporary = fovea_core::atomic_file::is_temporary_name(name)
            && (name.starts_with(".frame_") || name.starts_with(".sequence.mp4."));
        if (name.starts_with("frame_") && (name.ends_with(".png") || name.ends_with(".tmp")))
            || name == "sequence.mp4"
            || temporary
        {
            std::fs::remove_file(&p).with_context(|| format!("cannot remove {}", p.display()))?;
        }
    }
    Ok(())
}

/// Encodes `frame_%05d.png` to `sequence.mp4` with ffmpeg when asked and available.
fn make_video(out: &Path, fps: f64, video: Video) -> Result<()> {
    if video == Video::Off {
        return Ok(());
    }
    let have = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have {
        if video == Video::On {
            bail!("--video on needs ffmpeg on the PATH (Debian: apt-get install ffmpeg)");
        }
        println!("no ffmpeg on the PATH: PNG frames only (install ffmpeg for sequence.mp4)");
        return Ok(());
    }
    let mp4 = out.join("sequence.mp4");
    // ffmpeg writes a temporary name (hence `-f mp4`), renamed into place when it succeeds.
    fovea_core::atomic_file::write_atomic_via(&mp4, |tmp| {
        let status = std::process::Command::new("ffmpeg")
            .args([
                "-y",
                "-loglevel",
                "error",
                "-framerate",
                &format!("{fps}"),
                "-i",
            ])
            .arg(out.join("frame_%05d.png"))
            .args([
                "-c:v",
                "libx264",
                "-pix_fmt",
                "yuv420p",
                "-vf",
                "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                "-f",
                "mp4",
            ])
            .arg(tmp)
            .status()
            .map_err(|e| std::io::Error::other(format!("cannot run ffmpeg: {e}")))?;
        if status.success() {
            Ok(())
        } else {
            Err(std::io::Error::other(format!("ffmpeg failed ({status})")))
        }
    })?;
    println!("wrote {}", mp4.display());
    Ok(())
}
