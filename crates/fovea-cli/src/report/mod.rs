//! `fovea report`: one page that reproduces the papers' tables and figures for any scene — VaFR
//! Table 1 and the shading-rate figures, the speed table with per-stage timings, the DOF
//! comparison and its contact sheet, the inset gradient table, the flicker table, and every
//! method's image quality against full resolution by eccentricity band — as HTML, Markdown
//! and JSON, with what is needed to reproduce it.
//!
//! Each section runs on its own: an error (or a panic) in one is written into that section
//! and the others still run. `--quick` is the small version CI runs; `--verify DIR` checks a
//! written report (every table present, every number finite, every check passed).

mod doc;
mod dof;
mod flicker;
mod inset;
mod provenance;
mod quality;
mod samples;
mod speed;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_render::camera::EyeCamera;

use crate::backend::Preflight;
use crate::choices::BackendArg;
use crate::choices::{self, EyeChoice, Headset, MeasuredShadingChoice};
use crate::common::DisplayArgs;
use crate::scene_args::{load, GazeArgs, Loaded, SceneArgs};
use doc::{Report, Section};

/// Options of `fovea report`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ReportArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    #[command(flatten)]
    pub gaze: GazeArgs,
    /// The small version (what CI runs, a few minutes on 2 cores): the speed table at the
    /// headset's resolution only, a 128×128 DOF window with fewer lens samples, 6 flicker
    /// frames of VaFR and Weier.
    #[arg(long)]
    pub quick: bool,
    /// Sections to run, comma-separated, or `all`: samples, speed, dof, inset, flicker,
    /// quality.
    #[arg(long, default_value = "all")]
    pub sections: String,
    /// Seed of the flicker section's synthesised gaze (every other stage is deterministic).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Frames of the flicker sequence (default 120; 6 with --quick).
    #[arg(long)]
    pub flicker_frames: Option<u32>,
    /// The flicker sequence's gaze from an eye-tracker CSV (as `fovea sequence --gaze-csv`,
    /// e.g. the gaze.csv of `fovea view --record`) instead of synthesised saccades and pursuit.
    #[arg(long)]
    pub gaze_csv: Option<PathBuf>,
    /// The flicker sequence's camera path CSV (as `fovea sequence --camera-path`, e.g. the
    /// camera.csv of `fovea view --record`) instead of the camera slide.
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// Resolutions of the speed table, comma-separated (default: the headset, 2k and 4k; the
    /// headset only with --quick).
    #[arg(long)]
    pub bench_res: Option<String>,
    /// The shading the quality, DOF and inset sections score: `viewer` (the default: what
    /// `fovea view` renders — the real-time preset, direct light with one environment ray per
    /// sample and one bounce of indirect light, and the sample-space denoiser — against a converged full-resolution reference
    /// of the same shading without the denoiser, beside that reference's noise floor: a twin
    /// of another seed scored like the methods) or `noise-free` (the unshadowed environment,
    /// no Monte Carlo noise, no denoiser: the foveation's error alone, the tables before
    /// issue 38).
    #[arg(long, value_enum, ignore_case = true, default_value_t = MeasuredShadingChoice::Viewer)]
    pub shading: MeasuredShadingChoice,
    /// Primary rays per pixel of the quality section's full-resolution reference, 1 to 1024,
    /// stratified over the pixel (as `fovea render --method full --pixel-samples N`); default
    /// 256 with the viewer's shading (32 with --quick, as CI runs it), 16 noise-free (4 with
    /// --quick). The foveated frames keep one ray per sample, and a one-ray full
    /// frame is scored beside them: a one-ray frame aliases, so it is a poor reference itself.
    #[arg(long,
          value_parser = clap::value_parser!(u32).range(1..=i64::from(fovea_render::settings::MAX_PIXEL_SAMPLES)))]
    pub reference_pixel_samples: Option<u32>,
    /// Which executor runs the speed section's frames: cpu (the default: a report does not
    /// change what it measures with the machine), gpu (any adapter, lavapipe included; an
    /// error before any work without one or in a build without the `gpu` feature) or auto (a
    /// hardware GPU when there is one). On the GPU every method casts its primary and shadow
    /// rays there and polar methods reconstruct there, as with `fovea bench --backend`; the
    /// section says where each stage ran and the GPU passes' own times. Every other section
    /// runs on the CPU.
    #[arg(long, value_enum, ignore_case = true, default_value_t = BackendArg::Cpu)]
    pub backend: BackendArg,
    /// Output folder: report.html, report.md, report.json and each section's files.
    #[arg(long, default_value = "fovea-out/report")]
    pub out: PathBuf,
    /// Instead of running: check the report in this folder (every table present, every number
    /// finite, every check passed); exits non-zero listing the problems.
    #[arg(long, value_name = "DIR")]
    pub verify: Option<PathBuf>,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The sections in page order, with the tables each must hold.
const SECTIONS: [(&str, &[&str]); 6] = [
    ("samples", &["table1"]),
    ("speed", &["speed", "bvh"]),
    ("dof", &["dof-mean"]),
    ("inset", &["inset-gradient"]),
    ("flicker", &["flicker"]),
    ("quality", &["quality-whole", "quality-bands"]),
];

/// What every section works on: the scene loaded once, the display, the eye and the gaze.
pub struct Ctx<'a> {
    /// The options.
    pub args: &'a ReportArgs,
    /// The headset.
    pub display: DisplayProfile,
    /// The scene, its BVH and lights.
    pub loaded: Loaded,
    /// The eye's camera on `display`.
    pub camera: EyeCamera,
    /// The gaze.
    pub gaze: Gaze,
    /// The report folder.
    pub out: PathBuf,
    /// What `--backend` found before any work (the speed section's frames).
    pub backend: Preflight,
}

impl Ctx<'_> {
    /// A section's own folder inside the report folder.
    fn dir(&self, name: &str) -> Result<PathBuf> {
        let d = self.out.join(name);
        std::fs::create_dir_all(&d)
            .with_context(|| format!("cannot create directory {}", d.display()))?;
        Ok(d)
    }

    /// `path` relative to the report folder, with forward slashes (for links).
    fn link(&self, path: &Path) -> String {
        path.strip_prefix(&self.out)
            .unwrap_or(path)
            .to_string_lossy()
            .replace('\\', "/")
    }

    /// Sets the world's lights back to the report's display after a section viewed the scene
    /// on other displays (the speed table).
    fn restore_view(&mut self) -> Result<()> {
        self.camera = self.loaded.view(&self.args.scene, &self.display)?;
        Ok(())
    }
}

/// The scene options as they would be typed, for the "Reproduce" lines.
pub fn scene_flags(s: &SceneArgs) -> String {
    let mut f = format!("--scene {}", s.scene);
    if let Some(v) = s.scene_scale {
        f += &format!(" --scene-scale {v}");
    }
    if let Some(v) = &s.camera_pos {
        f += &format!(" --camera-pos={v}");
    }
    if let Some(v) = &s.look_at {
        f += &format!(" --look-at={v}");
    }
    if s.camera_index != 0 {
        f += &format!(" --camera-index {}", s.camera_index);
    }
    if s.eye != EyeChoice::Centre {
        f += &format!(" --eye {} --ipd {}", choices::name(&s.eye), s.ipd);
    }
    if let Some(n) = s.lights {
        f += &format!(" --lights {n}");
    }
    if let Some(b) = &s.bvh {
        f += &format!(" --bvh {}", choices::name(b));
    }
    if s.allow_inside {
        f += " --allow-inside";
    }
    f
}

/// The display options as they would be typed, with a leading space (empty for the default
/// headset).
pub fn display_flags(d: &DisplayArgs) -> String {
    match (&d.res, &d.headset) {
        (Some(r), _) => match d.vfov {
            Some(v) => format!(" --res {r} --vfov {v}"),
            None => format!(" --res {r}"),
        },
        (None, Some(h)) => format!(" --headset {}", choices::name(h)),
        (None, None) => String::new(),
    }
}

fn parse_sections(text: &str) -> Result<Vec<&'static str>> {
    if text.trim() == "all" {
        return Ok(SECTIONS.iter().map(|s| s.0).collect());
    }
    let mut out = Vec::new();
    for t in text.split(',').map(str::trim) {
        let Some((id, _)) = SECTIONS.iter().find(|s| s.0 == t) else {
            bail!(
                "invalid parameter `sections` = {text}: unknown section `{t}`; expected all or some of {}",
                SECTIONS.map(|s| s.0).join(", ")
            );
        };
        if !out.contains(id) {
            out.push(*id);
        }
    }
    // Page order, whatever the order given.
    out.sort_by_key(|id| SECTIONS.iter().position(|s| s.0 == *id));
    Ok(out)
}

fn title_of(id: &str) -> &'static str {
    match id {
        "samples" => "Samples per eye (VaFR Table 1) and shading rates (VaFR Figs. 5, 8, 21)",
        "speed" => "Speed: full resolution against foveated methods, per stage (Weier Table 1)",
        "dof" => "Depth-of-field filters against the thin-lens reference",
        "inset" => "Inset boundary: gradient intensity across the boundary",
        "flicker" => "Peripheral flicker with and without temporal accumulation",
        "quality" => "Image quality of every method against full resolution, by eccentricity",
        _ => "Section",
    }
}

pub fn run(args: ReportArgs) -> Result<()> {
    if let Some(dir) = &args.verify {
        return verify_dir(dir);
    }
    let wanted = parse_sections(&args.sections)?;
    // Checked before the scene loads; the view's display may take the file camera's field of
    // view (see `Loaded::display`).
    args.display.display(Headset::VivePro)?;
    if let Some(n) = args.flicker_frames {
        if !(2..=10_000).contains(&n) {
            bail!("invalid parameter `flicker-frames` = {n}: expected 2 to 10000");
        }
    }
    if let Some(r) = &args.bench_res {
        for t in r.split(',') {
            crate::common::display_of(t, args.display.vfov_deg())?;
        }
    }
    // `gpu` without an adapter or the feature fails here, before any work.
    let backend = crate::backend::preflight(args.backend)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create directory {}", args.out.display()))?;
    let t0 = Instant::now();
    let say = |m: &str| {
        if !args.quiet {
            eprintln!("[{:>6.1} s] {m}", t0.elapsed().as_secs_f64());
        }
    };
    say(&format!("loading {}", args.scene.scene));
    let mut loaded = load(&args.scene)?;
    let display = loaded.display(&args.display, Headset::VivePro)?;
    let camera = loaded.view(&args.scene, &display)?;
    let gaze = args.gaze.resolve(&display, &camera)?;
    let mut ctx = Ctx {
        args: &args,
        display,
        loaded,
        camera,
        gaze,
        out: args.out.clone(),
        backend,
    };
    let mut sections = Vec::new();
    for (k, id) in wanted.iter().enumerate() {
        say(&format!(
            "[{}/{}] {}",
            k + 1,
            wanted.len(),
            title_of(id).split(':').next().unwrap_or(id)
        ));
        let mut sec = Section::new(id, title_of(id));
        let start = Instant::now();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match *id {
            "samples" => samples::run(&mut ctx, &mut sec),
            "speed" => speed::run(&mut ctx, &mut sec),
            "dof" => dof::run(&mut ctx, &mut sec),
            "inset" => inset::run(&mut ctx, &mut sec),
            "flicker" => flicker::run(&mut ctx, &mut sec),
            "quality" => quality::run(&mut ctx, &mut sec),
            _ => Ok(()),
        }));
        sec.error = match outcome {
            Ok(Ok(())) => None,
            Ok(Err(e)) => Some(format!("{e:#}").replace('\n', " ")),
            Err(p) => Some(format!(
                "internal error (panic): {}",
                p.downcast_ref::<String>()
                    .map(String::as_str)
                    .or_else(|| p.downcast_ref::<&str>().copied())
                    .unwrap_or("unknown")
            )),
        };
        sec.seconds = start.elapsed().as_secs_f64();
        if let Some(e) = &sec.error {
            say(&format!("section {id} failed: {e}"));
        }
        sections.push(sec);
    }
    let report = Report {
        title: format!(
            "fovea report — {} on {}",
            ctx.loaded.world.scene.name, ctx.display.name
        ),
        provenance: provenance::collect(&ctx),
        sections,
    };
    let mut json = report.json();
    json["requested"] = serde_json::json!(wanted);
    let files = [
        ("report.html", report.html()),
        ("report.md", report.markdown()),
        ("report.json", serde_json::to_string_pretty(&json)? + "\n"),
    ];
    for (name, text) in &files {
        let p = args.out.join(name);
        crate::output::write_file(&p, text.as_bytes())?;
    }
    let failed: Vec<String> = report
        .sections
        .iter()
        .filter_map(|s| s.error.as_ref().map(|e| format!("{}: {e}", s.id)))
        .collect();
    if !args.quiet {
        eprintln!(
            "wrote {} (and report.md, report.json) in {:.0} s",
            args.out.join("report.html").display(),
            t0.elapsed().as_secs_f64()
        );
    }
    if !failed.is_empty() {
        bail!(
            "{} of {} sections failed ({}); the rest of the report was written to {}",
            failed.len(),
            wanted.len(),
            failed.join("; "),
            args.out.display()
        );
    }
    Ok(())
}

/// `--verify DIR`.
fn verify_dir(dir: &Path) -> Result<()> {
    let path = dir.join("report.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a fovea report", path.display()))?;
    let requested: Vec<String> = json["requested"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    if requested.is_empty() {
        bail!(
            "{} names no sections; is it a fovea report?",
            path.display()
        );
    }
    let expected: Vec<(&str, &[&str])> = SECTIONS
        .iter()
        .filter(|(id, _)| requested.iter().any(|r| r == id))
        .copied()
        .collect();
    let problems = doc::verify(&json, &expected, dir);
    if problems.is_empty() {
        println!(
            "{}: {} sections, every table present, every number finite, every check passed",
            path.display(),
            expected.len()
        );
        return Ok(());
    }
    for p in &problems {
        println!("{p}");
    }
    bail!("{} problem(s) in {}", problems.len(), path.display())
}
