//! `fovea flicker`: peripheral temporal flicker of foveation methods, with and without
//! temporal accumulation, against the full-resolution sequence (`fovea_eval::flicker`).
//!
//! One sequence — a gaze trajectory (synthesised saccades and pursuit by default, or an
//! eye-tracker CSV) and a moving camera — is rendered frame by frame at full resolution and
//! through every requested method and accumulation mode; each variant keeps its own temporal
//! history. Per eccentricity band the table gives the RMS of the temporal change the reference
//! does not make (`flicker`), and the mean luma PSNR of the frames against the reference
//! (where accumulation ghosted, this would drop).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use fovea_core::mapping::Method;
use fovea_core::optics::AccommodationParams;
use fovea_eval::flicker::{FlickerMeter, FlickerReport, PERIPHERY_DEG};
use fovea_eval::metrics::{luma_psnr, Region};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::FrameSettings;
use fovea_render::sequence::{Sequence, SequenceDriver, Track};
use fovea_render::shade::ShadingMode;
use fovea_render::thin_lens::{render_window, Window};

use crate::common::{DisplayArgs, MethodOptions};
use crate::output::write_rgb;
use crate::render::memory_limit;
use crate::scene_args::{parse_vec3, prepare, SceneArgs};
use crate::sequence::{gaze_trajectory, read_camera_path};
use crate::temporal_args::{parse_temporal_modes, TemporalArgs};

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
    /// Foveation methods to compare (comma-separated).
    #[arg(long, default_value = "vafr,kfr,visual-polar,inset,weier")]
    pub methods: String,
    /// Temporal accumulation: off, on or both (each method twice).
    #[arg(long, default_value = "both")]
    pub temporal: String,
    /// Frames.
    #[arg(long, default_value_t = 120)]
    pub frames: u32,
    /// Frames per second.
    #[arg(long, default_value_t = 90.0)]
    pub fps: f64,
    /// Synthesised gaze scenario.
    #[arg(long, default_value = "saccade-pursuit")]
    pub scenario: String,
    /// Gaze from an eye-tracker CSV instead.
    #[arg(long, conflicts_with = "scenario")]
    pub gaze_csv: Option<PathBuf>,
    /// Seed of the synthesised gaze.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Camera translation over the whole sequence, X,Y,Z metres in the camera's frame
    /// (right, up, back), looking in a fixed direction.
    #[arg(long, default_value = "0.04,0.01,0")]
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

/// One method × accumulation mode.
#[derive(Serialize)]
pub struct VariantReport {
    /// The method's name.
    pub method: String,
    /// Whether temporal accumulation was on.
    pub temporal: bool,
    /// Flicker by band and in the periphery.
    pub flicker: FlickerReport,
    /// Mean luma PSNR against the reference over the frames, whole screen, dB.
    pub mean_psnr_db: f64,
    /// The same within 10° of the gaze (a square of that radius), dB.
    pub mean_central_psnr_db: f64,
    /// Mean over frames 1… of the reused fraction of samples (accumulation on).
    pub mean_reused: Option<f64>,
    /// Per-frame luma PSNR, dB.
    #[serde(skip)]
    pub psnr: Vec<f64>,
}

struct Variant {
    method: Method,
    /// With temporal accumulation.
    temporal: bool,
    /// `METHOD-on` or `METHOD-off`: the folder of its frames.
    dir: String,
    psnr: Vec<f64>,
    meter: FlickerMeter,
    central_sum: f64,
    central_n: u64,
    reused_sum: f64,
}

/// Mean of the finite values (frames identical to the reference have an infinite PSNR and are
/// left out); 0 when there are none.
fn finite_mean(v: &[f64]) -> f64 {
    let (sum, n) = v
        .iter()
        .filter(|p| p.is_finite())
        .fold((0.0, 0u64), |(s, n), p| (s + p, n + 1));
    sum / n.max(1) as f64
}

/// The checked options of one flicker measurement.
pub struct Plan {
    display: fovea_core::display::DisplayProfile,
    methods: Vec<Method>,
    modes: Vec<bool>,
    temporal: fovea_render::temporal::TemporalSettings,
    contrast: Option<fovea_post::contrast::PeripheralContrast>,
    edges: Vec<f64>,
    config: fovea_core::mapping::MappingConfig,
    memory_limit: u64,
    gazes: Vec<fovea_core::gaze::GazeSample>,
}

pub fn run(args: FlickerArgs) -> Result<()> {
    let plan = plan(&args)?;
    let prepared = prepare(&args.scene, &plan.display)?;
    let outcome = measure(&args, &plan, &prepared.world, &prepared.camera)?;
    if args.json {
        print!("{}", outcome.json_text);
    } else {
        print!("{}", outcome.markdown);
        println!("wrote {}", args.out.display());
    }
    Ok(())
}

/// What [`measure`] found and wrote.
pub struct Outcome {
    /// Per method and accumulation mode.
    pub reports: Vec<VariantReport>,
    /// `flicker.json`.
    pub json: serde_json::Value,
    /// Its text.
    pub json_text: String,
    /// `flicker.md`.
    pub markdown: String,
}

/// Checks every option and builds the gaze trajectory, before the scene is loaded.
pub fn plan(args: &FlickerArgs) -> Result<Plan> {
    if !(2..=10_000).contains(&args.frames) {
        bail!(
            "invalid parameter `frames` = {}: expected 2 to 10000",
            args.frames
        );
    }
    if !(args.fps.is_finite() && (1.0..=1000.0).contains(&args.fps)) {
        bail!("invalid parameter `fps` = {}: expected 1 to 1000", args.fps);
    }
    if !(1..=256).contains(&args.reference_spp) {
        bail!(
            "invalid parameter `reference-spp` = {}: expected 1 to 256",
            args.reference_spp
        );
    }
    let display = args.display.display("vive-pro-eye")?;
    let methods: Vec<Method> = args
        .methods
        .split(',')
        .filter(|m| !m.trim().is_empty())
        .map(|m| Method::parse(m.trim()))
        .collect::<std::result::Result<_, _>>()?;
    if methods.is_empty() || methods.contains(&Method::Full) {
        bail!(
            "invalid parameter `methods` = {}: expected foveation methods (full is the reference)",
            args.methods
        );
    }
    let modes = parse_temporal_modes(&args.temporal)?;
    let temporal = args.temporal_opts.settings()?;
    let contrast = args.temporal_opts.contrast()?;
    let edges: Vec<f64> = args
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
    let config = args.options.frame_config()?;
    let memory_limit = memory_limit(args.max_memory.as_deref())?;
    let duration_s = args.frames as f64 / args.fps;
    let gazes = gaze_trajectory(
        args.gaze_csv.as_deref(),
        &args.scenario,
        args.seed,
        args.quiet,
        &display,
        duration_s,
    )?
    .resample(args.fps, args.frames as usize)?;
    Ok(Plan {
        display,
        methods,
        modes,
        temporal,
        contrast,
        edges,
        config,
        memory_limit,
        gazes,
    })
}

/// Renders the sequence on `world` from `base` (the camera at the first frame), every variant
/// beside the reference; writes `flicker.json`, `flicker-frames.csv` and `flicker.md` into
/// `args.out`.
pub fn measure(
    args: &FlickerArgs,
    plan: &Plan,
    world: &fovea_render::world::World,
    base: &EyeCamera,
) -> Result<Outcome> {
    let Plan {
        display,
        methods,
        modes,
        temporal,
        contrast,
        edges,
        config,
        memory_limit,
        gazes,
    } = plan;
    let (temporal, contrast, memory_limit) = (*temporal, *contrast, *memory_limit);
    let cameras: Vec<EyeCamera> = match &args.camera_path {
        Some(p) => {
            let (path, _) = read_camera_path(p)?;
            (0..args.frames as usize)
                .map(|i| {
                    let (pos, look, up) = path.at(i as f64 / args.fps);
                    Ok(EyeCamera::new(pos, look - pos, up, display)?)
                })
                .collect::<Result<_>>()?
        }
        None => {
            let m = parse_vec3("camera-move", &args.camera_move)?;
            let last = (args.frames - 1).max(1) as f32;
            (0..args.frames)
                .map(|i| {
                    let f = i as f32 / last;
                    let pos =
                        base.position + f * (m.x * base.right + m.y * base.up - m.z * base.forward);
                    Ok(EyeCamera::new(pos, base.forward, base.up, display)?)
                })
                .collect::<Result<_>>()?
        }
    };

    // One track per method and accumulation mode, each with its own history and buffers;
    // the metrics of each track beside it.
    let mut tracks = Vec::new();
    let mut variants = Vec::new();
    for &method in methods {
        for &on in modes {
            let mut s = FrameSettings::new(method);
            s.mapping = config.clone();
            s.memory_limit_bytes = memory_limit;
            s.contrast = contrast;
            let dir = format!("{}-{}", method.name(), if on { "on" } else { "off" });
            tracks.push(Track::new(dir.clone(), s, on.then_some(temporal))?);
            variants.push(Variant {
                method,
                temporal: on,
                dir,
                psnr: Vec::new(),
                meter: FlickerMeter::new(display, edges, args.periphery)?,
                central_sum: 0.0,
                central_n: 0,
                reused_sum: 0.0,
            });
        }
    }
    let seq = Sequence::plan(
        world,
        cameras,
        gazes.clone(),
        None,
        args.fps,
        AccommodationParams::default(),
        None,
    )?;
    let pb = if args.quiet {
        ProgressBar::hidden()
    } else {
        let pb = ProgressBar::new(args.frames as u64 * (1 + variants.len() as u64));
        pb.set_style(
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} renders, eta {eta}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        pb.set_message("flicker");
        pb
    };
    let full_region = Region::full(display.width_px, display.height_px);
    let r10 = display.radius_px(fovea_core::units::Degrees(10.0));
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create directory {}", args.out.display()))?;
    if args.save_frames {
        let dirs = std::iter::once("reference").chain(variants.iter().map(|v| v.dir.as_str()));
        for dir in dirs {
            let d = args.out.join("frames").join(dir);
            std::fs::create_dir_all(&d)
                .with_context(|| format!("cannot create directory {}", d.display()))?;
        }
    }
    let save = |dir: &str, i: usize, img: &fovea_core::Image<fovea_post::Rgb>| -> Result<()> {
        if !args.save_frames {
            return Ok(());
        }
        write_rgb(
            &args
                .out
                .join("frames")
                .join(dir)
                .join(format!("frame_{i:05}.png")),
            img,
            0.0,
            fovea_post::tonemap::ToneCurve::Reinhard,
        )
    };
    let log_progress = !std::io::IsTerminal::is_terminal(&std::io::stderr());
    let started = std::time::Instant::now();
    let n_frames = seq.len();
    let mut driver = SequenceDriver::new(world, &seq, tracks)?;
    driver.run(
        &|_| false,
        &mut |e| {
            let i = e.index;
            let gaze = e.eye.gaze;
            let reference = render_window(
                world,
                e.camera,
                Window::full(display.width_px, display.height_px),
                None,
                args.reference_spp,
                ShadingMode::Direct,
                &|_, _| {},
            )
            .with_context(|| format!("frame {i}, full resolution"))?;
            save("reference", i, &reference.color)?;
            pb.inc(1);
            let central = Region::around(
                gaze.point.x_px,
                gaze.point.y_px,
                r10,
                display.width_px,
                display.height_px,
            );
            for ((v, frame), track) in variants.iter_mut().zip(&e.frames).zip(e.tracks) {
                if let (Some(acc), true) = (track.accumulator(), i > 0) {
                    let t = acc.last_stats();
                    v.reused_sum += t.reused as f64 / (t.reused + t.fresh).max(1) as f64;
                }
                save(&v.dir, i, &frame.color)?;
                v.meter.push(&frame.color, &reference.color, &gaze)?;
                if let Some(p) = luma_psnr(&reference.color, &frame.color, central) {
                    if p.is_finite() {
                        v.central_sum += p;
                        v.central_n += 1;
                    }
                }
                if let Some(p) = luma_psnr(&reference.color, &frame.color, full_region) {
                    v.psnr.push(p);
                }
                pb.inc(1);
            }
            // The bar is hidden when stderr is a log file; a line per tenth of the run instead.
            let step = (n_frames / 10).max(1);
            if !args.quiet && log_progress && ((i + 1) % step == 0 || i + 1 == n_frames) {
                eprintln!(
                    "flicker: frame {}/{} after {:.0} s",
                    i + 1,
                    n_frames,
                    started.elapsed().as_secs_f64()
                );
            }
            Ok::<(), anyhow::Error>(())
        },
        &mut |_| {},
    )?;
    pb.finish_and_clear();

    let reports: Vec<VariantReport> = variants
        .into_iter()
        .map(|v| VariantReport {
            method: v.method.name().to_string(),
            temporal: v.temporal,
            flicker: v.meter.report(),
            mean_psnr_db: finite_mean(&v.psnr),
            mean_central_psnr_db: v.central_sum / v.central_n.max(1) as f64,
            mean_reused: v.temporal.then(|| v.reused_sum / (args.frames - 1) as f64),
            psnr: v.psnr,
        })
        .collect();
    let json = serde_json::json!({
        "scene": world.scene.name,
        "display": display,
        "frames": args.frames,
        "fps": args.fps,
        "scenario": if args.gaze_csv.is_some() { None } else { Some(&args.scenario) },
        "camera_move": if args.camera_path.is_some() { None } else { Some(&args.camera_move) },
        "temporal_settings": temporal,
        "peripheral_contrast": contrast,
        "variants": reports,
    });
    let text = serde_json::to_string_pretty(&json)? + "\n";
    std::fs::write(args.out.join("flicker.json"), &text)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let mut csv = String::from("method,temporal,frame,peripheral_flicker,psnr_db\n");
    for r in &reports {
        for (i, p) in r.psnr.iter().enumerate() {
            let flicker = r
                .flicker
                .frames
                .iter()
                .find(|f| f.frame == i as u64)
                .map_or(String::new(), |f| format!("{:.6e}", f.peripheral));
            csv += &format!(
                "{},{},{i},{flicker},{p:.3}\n",
                r.method,
                if r.temporal { "on" } else { "off" },
            );
        }
    }
    std::fs::write(args.out.join("flicker-frames.csv"), csv)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let md = table(
        &reports,
        edges,
        args.periphery,
        &display.name,
        &world.scene.name,
    );
    std::fs::write(args.out.join("flicker.md"), &md)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    Ok(Outcome {
        reports,
        json,
        json_text: text,
        markdown: md,
    })
}

fn table(
    reports: &[VariantReport],
    edges: &[f64],
    periphery: f64,
    display: &str,
    scene: &str,
) -> String {
    let frames = reports
        .first()
        .map_or(0, |r| r.flicker.periphery.frames + 1);
    let mut s = format!(
        "{scene}, {display}, {frames} frames: flicker = RMS of the temporal change the full-resolution sequence does not make, % of the display range, by eccentricity band; energy = mean squared frame-to-frame change over the reference's\n\n"
    );
    let bands: Vec<String> = edges
        .iter()
        .enumerate()
        .map(|(k, lo)| match edges.get(k + 1) {
            Some(hi) => format!("{lo}–{hi}°"),
            None => format!("≥ {lo}°"),
        })
        .collect();
    s += &format!(
        "| method | accumulation | {} | periphery ≥ {periphery}° | periphery energy / reference | PSNR ≤ 10° (dB) | PSNR (dB) | reused |\n",
        bands.join(" | ")
    );
    s += &format!(
        "|---|---|{}---|---|---|---|---|\n",
        "---|".repeat(bands.len())
    );
    for r in reports {
        let cells: Vec<String> = r
            .flicker
            .bands
            .iter()
            .map(|b| format!("{:.3}", b.flicker_rms_pct))
            .collect();
        let p = &r.flicker.periphery;
        s += &format!(
            "| {} | {} | {} | {:.3} | {:.2} | {:.2} | {:.2} | {} |\n",
            r.method,
            if r.temporal { "on" } else { "off" },
            cells.join(" | "),
            p.flicker_rms_pct,
            p.temporal_energy / p.reference_energy,
            r.mean_central_psnr_db,
            r.mean_psnr_db,
            r.mean_reused
                .map_or("—".to_string(), |f| format!("{:.0} %", 100.0 * f))
        );
    }
    let lines: Vec<String> = accumulation_lines(reports)
        .into_iter()
        .map(|l| format!("- {l}"))
        .collect();
    if !lines.is_empty() {
        s += "\n";
        s += &lines.join("\n");
        s += "\n";
    }
    s
}

/// One sentence per method measured both ways: what accumulation did to its peripheral
/// flicker, temporal energy and PSNR.
pub fn accumulation_lines(reports: &[VariantReport]) -> Vec<String> {
    let mut lines = Vec::new();
    for r in reports.iter().filter(|r| !r.temporal) {
        if let Some(on) = reports.iter().find(|o| o.temporal && o.method == r.method) {
            let (a, b) = (
                r.flicker.periphery.flicker_rms_pct,
                on.flicker.periphery.flicker_rms_pct,
            );
            let (ea, eb) = (
                r.flicker.periphery.temporal_energy,
                on.flicker.periphery.temporal_energy,
            );
            lines.push(format!(
                "{}: accumulation changes peripheral flicker RMS {a:.3} → {b:.3} % (×{:.2} lower), peripheral temporal energy ×{:.2} lower, PSNR ≤ 10° {:.2} → {:.2} dB, whole frame {:.2} → {:.2} dB",
                r.method,
                a / b,
                ea / eb,
                r.mean_central_psnr_db,
                on.mean_central_psnr_db,
                r.mean_psnr_db,
                on.mean_psnr_db
            ));
        }
    }
    lines
}
