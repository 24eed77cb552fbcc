//! `fovea inset-analysis`: the inset paper's gradient-intensity table. A scene is rendered at
//! full resolution (the reference), as a full-resolution inset around the gaze, and as a
//! periphery at reduced resolution (by default 1/4 per side as in the paper's "rendered at
//! 1/4 normal resolution and then upsampled by 4×"; `--periphery-factor 2` for a quarter of
//! the pixels), rendered, not down-sampled; the two are composited with each boundary-smoothing method and every composite gets the
//! gradient analysis (grey, 3×3 Sobel ×100, four areas across the inset boundary).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::Image;
use fovea_eval::gradient_intensity::{gradient_areas, GradientReport, DEFAULT_BAND_PX};
use fovea_post::inset_smoothing::{composite, GaussianKernel, Rect, Smoothing};
use fovea_post::Rgb;
use fovea_render::camera::EyeCamera;
use fovea_render::shade::ShadingMode;
use fovea_render::thin_lens::{render_window, Window};

use crate::common::DisplayArgs;
use crate::output::write_rgb;
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
    /// Output folder: one PNG per composite and inset-analysis.json.
    #[arg(long, default_value = "fovea-out/inset-analysis")]
    pub out: PathBuf,
    /// Print the JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `full` (the reference), `none` (hard composite) or the smoothing.
    pub method: String,
    /// The analysis.
    pub report: GradientReport,
    /// Mean gradient of Area2 over Area3 (just inside over just outside the boundary), x
    /// and y: the full frame's is the target.
    pub area2_over_area3: [f64; 2],
    /// Area1 mean gradient magnitude relative to the full frame's, minus 1.
    pub area1_change: f64,
}

fn methods() -> Vec<(&'static str, Smoothing)> {
    vec![
        ("none", Smoothing::None),
        ("alpha-blend", Smoothing::ALPHA_BLEND),
        ("gaussian-1d", Smoothing::Gaussian1d),
        ("gaussian-2d", Smoothing::Gaussian2d),
        (
            "gaussian-1d-alpha",
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::OneD,
            },
        ),
        (
            "gaussian-2d-alpha",
            Smoothing::GaussianAlpha {
                kernel: GaussianKernel::TwoD,
            },
        ),
        ("laplacian", Smoothing::LAPLACIAN),
    ]
}

pub fn run(args: InsetAnalysisArgs) -> Result<()> {
    let display = args.display.display("vive-pro-eye")?;
    check_options(&display, args.periphery_factor, args.band)?;
    let prepared = prepare(&args.scene, &display)?;
    let g = args.gaze.resolve(&display, &prepared.camera)?;
    let rect = inset_rect(&display, &g, args.inset_size.as_deref(), args.band)?;
    let (rows, json) = analyse(
        &prepared.world,
        &prepared.camera,
        &display,
        rect,
        args.periphery_factor,
        args.band,
        &args.out,
    )?;
    if args.json {
        print!("{}", serde_json::to_string_pretty(&json)? + "\n");
        return Ok(());
    }
    let (w, h, f) = (display.width_px, display.height_px, args.periphery_factor);
    println!(
        "{}, {} {w}x{h}, inset {}x{} at ({}, {}), periphery {}x{}, bands of {} px; gradient ×100 of grey",
        prepared.world.scene.name, display.name, rect.w, rect.h, rect.x0, rect.y0, w / f, h / f, args.band
    );
    println!("| method | Area1 x / y | Area2 x / y | Area3 x / y | Area4 x / y | slope 2→3 x / y | Area2/Area3 x / y | high/low x / y |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
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
    println!("wrote {}", args.out.display());
    Ok(())
}

/// Checks the periphery factor and the band width against the display.
pub fn check_options(display: &DisplayProfile, f: u32, band: u32) -> Result<()> {
    let (w, h) = (display.width_px, display.height_px);
    if f != 2 && f != 4 {
        bail!("invalid parameter `periphery-factor` = {f}: expected 2 or 4");
    }
    if w % f != 0 || h % f != 0 || w < 32 || h < 32 {
        bail!(
            "invalid parameter `display` = {w}x{h}: expected sides of at least 32 px divisible by the periphery factor {f}"
        );
    }
    if !(1..=256).contains(&band) {
        bail!("invalid parameter `band` = {}: expected 1 to 256", band);
    }
    Ok(())
}

/// The inset rectangle around the gaze: `size` WxH, default 1/4 of each side.
pub fn inset_rect(
    display: &DisplayProfile,
    g: &Gaze,
    size: Option<&str>,
    band: u32,
) -> Result<Rect> {
    let (w, h) = (display.width_px, display.height_px);
    let (iw, ih) = match size {
        None => (w / 4, h / 4),
        Some(t) => {
            let v: Vec<u32> = t
                .split(['x', 'X'])
                .map(|p| p.trim().parse().ok())
                .collect::<Option<_>>()
                .unwrap_or_default();
            match v.as_slice() {
                [a, b] if *a >= 4 * band && *b >= 4 * band && *a < w && *b < h => {
                    (*a, *b)
                }
                _ => bail!(
                    "invalid parameter `inset-size` = {t}: expected WxH smaller than the screen and at least 4 × band"
                ),
            }
        }
    };
    let win = Window::centred(g.point.x_px, g.point.y_px, iw, ih, w, h);
    let rect = Rect {
        x0: win.x0,
        y0: win.y0,
        w: win.width,
        h: win.height,
    };
    Ok(rect)
}

/// Renders the full frame and the periphery, composites them with every smoothing, writes one
/// PNG per composite and `inset-analysis.json` into `out`; the rows and the JSON.
pub fn analyse(
    world: &fovea_render::world::World,
    camera: &EyeCamera,
    display: &DisplayProfile,
    rect: Rect,
    f: u32,
    band: u32,
    out: &std::path::Path,
) -> Result<(Vec<Row>, serde_json::Value)> {
    let (w, h) = (display.width_px, display.height_px);
    let shading = ShadingMode::Direct;
    // The reference, and the periphery on a display of 1/f of the pixels per side with the
    // same field of view.
    let full = render_window(
        world,
        camera,
        Window::full(w, h),
        None,
        1,
        shading,
        &|_, _| {},
    )?;
    // The inset's rays are the full frame's pixel-centre rays inside the rectangle.
    let inset = fovea_eval::metrics::crop(
        &full.color,
        fovea_eval::metrics::Region {
            x0: rect.x0,
            y0: rect.y0,
            x1: rect.x0 + rect.w,
            y1: rect.y0 + rect.h,
        },
    )
    .context("inset rectangle outside the screen")?;
    let low_display = DisplayProfile {
        name: format!("{}-div{f}", display.name),
        width_px: w / f,
        height_px: h / f,
        lens_centre_px: display
            .lens_centre_px
            .map(|p| fovea_core::units::ScreenPoint::new(p.x_px / f as f64, p.y_px / f as f64)),
        ..display.clone()
    };
    let low_camera = EyeCamera::new(camera.position, camera.forward, camera.up, &low_display)?;
    let low = render_window(
        world,
        &low_camera,
        Window::full(w / f, h / f),
        None,
        1,
        shading,
        &|_, _| {},
    )?;

    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create directory {}", out.display()))?;
    let reference = gradient_areas(&full.color, rect, band)?;
    let mut rows = vec![row("full", reference.clone(), &reference)];
    write_rgb(
        &out.join("full.png"),
        &full.color,
        0.0,
        fovea_post::tonemap::ToneCurve::Reinhard,
    )?;
    for (name, m) in methods() {
        let img: Image<Rgb> = composite(&inset, rect, &low.color, w, h, m)?;
        write_rgb(
            &out.join(format!("{name}.png")),
            &img,
            0.0,
            fovea_post::tonemap::ToneCurve::Reinhard,
        )?;
        rows.push(row(name, gradient_areas(&img, rect, band)?, &reference));
    }
    let json = serde_json::json!({
        "scene": world.scene.name,
        "display": display.name,
        "inset": rect,
        "band_px": band,
        "periphery_factor": f,
        "rows": rows,
    });
    let text = serde_json::to_string_pretty(&json)? + "\n";
    std::fs::write(out.join("inset-analysis.json"), &text)
        .with_context(|| format!("cannot write {}", out.display()))?;
    Ok((rows, json))
}

fn row(method: &str, report: GradientReport, full: &GradientReport) -> Row {
    let rel = |a: f64, b: f64| {
        if b.abs() > 1e-12 {
            (a - b) / b.abs()
        } else {
            0.0
        }
    };
    let div = |a: f64, b: f64| if b.abs() > 1e-12 { a / b } else { f64::NAN };
    let a = &report.areas;
    Row {
        method: method.to_string(),
        area2_over_area3: [div(a[1].mean_x, a[2].mean_x), div(a[1].mean_y, a[2].mean_y)],
        area1_change: rel(report.areas[0].mean_magnitude, full.areas[0].mean_magnitude),
        report,
    }
}
