//! `fovea inset-analysis`: the inset paper's gradient-intensity table (Liu et al., inset
//! boundary smoothing, Sec. 4). The analysis is [`fovea_eval::experiments::inset`]; this file
//! parses the options, prints the table and writes `inset-analysis.json` beside the images.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;

use fovea_eval::experiments::inset::{run as run_inset, InsetAnalysis, InsetParams};
use fovea_eval::gradient_intensity::DEFAULT_BAND_PX;

use crate::choices::{Headset, MeasuredShadingChoice};
use crate::common::DisplayArgs;
use crate::scene_args::{prepare, GazeArgs, SceneArgs};

/// Options of `fovea inset-analysis`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct InsetAnalysisArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
    #[command(flatten)]
    pub gaze: GazeArgs,
    /// Inset size WxH in pixels (default: 1/4 of each side, the paper's "1/4 × 1/4 the size
    /// of the entire frame").
    #[arg(long)]
    pub inset_size: Option<String>,
    /// The periphery's resolution divisor per side: 4 (the paper's "1/4 resolution, upsampled
    /// by 4×") or 2.
    #[arg(long, default_value_t = 4)]
    pub periphery_factor: u32,
    /// Width in pixels of Area2 and Area3 on either side of the boundary.
    #[arg(long, default_value_t = DEFAULT_BAND_PX)]
    pub band: u32,
    /// The shading of every image: `viewer` (the default: the real-time preset with the
    /// denoiser, as `fovea view`; the row `full` is then a converged reference of the same
    /// shading, printed beside its twin of another seed, the noise floor) or `noise-free` (the
    /// table before issue 38: no Monte Carlo noise, the reference the inset's own frame).
    #[arg(long, value_enum, ignore_case = true, default_value_t = MeasuredShadingChoice::Viewer)]
    pub shading: MeasuredShadingChoice,
    /// Rays per pixel of the reference with the viewer's shading, 2 to 1024.
    #[arg(long, default_value_t = fovea_eval::experiments::inset::DEFAULT_INSET_REFERENCE_PIXEL_SAMPLES)]
    pub reference_pixel_samples: u32,
    /// Output folder: one PNG per composite and inset-analysis.json.
    #[arg(long, default_value = "fovea-out/inset-analysis")]
    pub out: PathBuf,
    /// Print the JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Do not say where the files went.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parses `--inset-size WxH`.
fn parse_size(text: &str) -> Result<[u32; 2]> {
    let v: Vec<u32> = text
        .split(['x', 'X'])
        .map(|p| p.trim().parse().ok())
        .collect::<Option<_>>()
        .unwrap_or_default();
    match v.as_slice() {
        [a, b] => Ok([*a, *b]),
        _ => anyhow::bail!(
            "invalid parameter `inset-size` = {text}: expected WxH smaller than the screen and at least 4 × band"
        ),
    }
}

pub fn run(args: InsetAnalysisArgs) -> Result<()> {
    let display = args.display.display(Headset::VivePro)?;
    let params = InsetParams {
        inset_size: args.inset_size.as_deref().map(parse_size).transpose()?,
        periphery_factor: args.periphery_factor,
        band_px: args.band,
        images: Some(args.out.clone()),
        shading: args.shading.into(),
        reference_pixel_samples: args.reference_pixel_samples,
    };
    params.validate()?;
    params.check_display(&display)?;
    // The file camera's field of view (see `Loaded::display`) may change the display's field
    // of view, not the size checked above.
    let prepared = prepare(&args.scene, &args.display, Headset::VivePro)?;
    let display = prepared.camera.display.clone();
    let g = args.gaze.resolve(&display, &prepared.camera)?;
    let analysis = run_inset(&prepared.world, &prepared.camera, &g, &params)?;
    let json = write_json(&analysis, &args.out)?;
    if args.json {
        print!("{}", serde_json::to_string_pretty(&json)? + "\n");
        return Ok(());
    }
    let (w, h) = (display.width_px, display.height_px);
    let [pw, ph] = analysis.periphery_px;
    let rect = analysis.inset;
    println!(
        "{}, {} {w}x{h}, inset {}x{} at ({}, {}), periphery {pw}x{ph}, bands of {} px; gradient ×100 of grey",
        analysis.scene, display.name, rect.w, rect.h, rect.x0, rect.y0, args.band
    );
    println!("| method | Area1 x / y | Area2 x / y | Area3 x / y | Area4 x / y | slope 2→3 x / y | Area2/Area3 x / y | high/low x / y |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in analysis
        .rows
        .iter()
        .take(1)
        .chain(&analysis.floor_row)
        .chain(analysis.rows.iter().skip(1))
    {
        let a = &r.report.areas;
        let ratio = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.2}"));
        println!(
            "| {} | {:.2} / {:.2} | {:.2} / {:.2} | {:.2} / {:.2} | {:.2} / {:.2} | {:.2} / {:.2} | {:.2} / {:.2} | {} / {} |",
            r.method,
            a[0].mean_x,
            a[0].mean_y,
            a[1].mean_x,
            a[1].mean_y,
            a[2].mean_x,
            a[2].mean_y,
            a[3].mean_x,
            a[3].mean_y,
            r.report.slope_23_x,
            r.report.slope_23_y,
            r.area2_over_area3[0],
            r.area2_over_area3[1],
            ratio(r.report.ratio_x),
            ratio(r.report.ratio_y)
        );
    }
    println!(
        "{} shading; {}",
        analysis.params.shading.name(),
        analysis.floor.describe()
    );
    if !args.quiet {
        println!("wrote {}", args.out.display());
    }
    Ok(())
}

/// Writes `inset-analysis.json` into `out`; the JSON.
pub fn write_json(analysis: &InsetAnalysis, out: &Path) -> Result<serde_json::Value> {
    let json = analysis.to_json();
    let text = serde_json::to_string_pretty(&json)? + "\n";
    let p = out.join("inset-analysis.json");
    crate::output::write_file(&p, text.as_bytes())?;
    Ok(json)
}
