//! `fovea fidelity`: how coarse each method's texels are against the acuity model, per band of
//! true eccentricity, at several gazes (`fovea_core::fidelity`).

use anyhow::{bail, Result};
use clap::Args;
use fovea_core::fidelity::{coarseness_by_band, BandCoarseness};
use fovea_core::mapping::{build, Method};
use serde::Serialize;

use crate::choices::Headset;
use crate::common::{acuity, parse_gaze, DisplayArgs, MethodOptions};

#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct FidelityArgs {
    #[command(flatten)]
    display: DisplayArgs,
    /// Methods, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = ["full", "vafr", "kfr", "lafr", "visual-polar"].map(String::from))]
    methods: Vec<String>,
    /// Gaze points X,Y in pixels, separated by spaces or semicolons. Default: the centre, 25°
    /// right of it (Eq. 3) and near the top-left corner (7 % of the width, 6.25 % of the
    /// height in).
    #[arg(long)]
    gazes: Option<String>,
    /// Band edges of true eccentricity in degrees, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 5.0, 15.0, 30.0, 60.0, 180.0])]
    bands: Vec<f64>,
    /// Visit every Nth pixel (at most about a million are visited; the stride grows to fit).
    #[arg(long, default_value_t = 4)]
    stride: u32,
    /// The acuity model the texels are compared with, ECC:CPD pivots (default: VaFR's).
    #[arg(long)]
    pivots: Option<String>,
    /// The methods' own parameters (e.g. --vafr-pivots to sample VaFR more densely).
    #[command(flatten)]
    options: MethodOptions,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Only the table (or the JSON): without the paragraph that explains it.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Serialize)]
struct Row {
    method: String,
    gaze: [f64; 2],
    samples: u64,
    bands: Vec<BandCoarseness>,
}

pub fn run(a: FidelityArgs) -> Result<()> {
    let display = a.display.display(Headset::VivePro)?;
    let reference = acuity(a.pivots.as_deref())?;
    let methods = a
        .methods
        .iter()
        .map(|m| crate::common::parse_list_method(m))
        .collect::<Result<Vec<Method>>>()?;
    if methods.is_empty() {
        bail!("invalid parameter `methods`: name at least one method");
    }
    a.options.warn_inapplicable(&methods);
    // Sample plans only, no shading: the offline preset's (the mapping's default) rings.
    let config = a
        .options
        .frame_config(fovea_render::quality::Quality::Offline)?;
    let gazes = match &a.gazes {
        Some(text) => text
            .split([' ', ';'])
            .filter(|s| !s.trim().is_empty())
            .map(|g| parse_gaze(&display, Some(g.trim())))
            .collect::<Result<Vec<_>>>()?,
        None => {
            let c = display.centre_gaze().point;
            let right = c.x_px + display.radius_px(fovea_core::units::Degrees(25.0));
            let (w, h) = (display.width_px as f64, display.height_px as f64);
            vec![
                display.centre_gaze(),
                display.gaze(right.min(w), c.y_px)?,
                display.gaze(0.07 * w, 0.0625 * h)?,
            ]
        }
    };
    if gazes.is_empty() {
        bail!("invalid parameter `gazes`: name at least one gaze X,Y");
    }
    let mut rows = Vec::new();
    for &m in &methods {
        for g in &gazes {
            let mapping = build(m, &display, *g, &config)?;
            let bands = coarseness_by_band(
                mapping.as_ref(),
                &display,
                g,
                &reference,
                &a.bands,
                a.stride,
            )?;
            rows.push(Row {
                method: m.name().to_string(),
                gaze: [g.point.x_px, g.point.y_px],
                samples: mapping.sample_count(),
                bands,
            });
        }
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    if !a.quiet {
        println!(
            "Texel spacing against the acuity's Nyquist spacing ω(e)/2 at each pixel's true \
             eccentricity, {}×{} ({:.1}°×{:.1}°); 1 = acuity-consistent, above 1 = coarser than \
             the eye resolves. u: between rings (radial) for polar buffers, v: along them \
             (tangential).",
            display.width_px, display.height_px, display.hfov.0, display.vfov.0
        );
        println!();
    }
    println!(
        "| method | gaze | samples | band | pixels | unsampled | u median (p90) | v median (p90) |"
    );
    println!("|---|---|---:|---|---:|---:|---:|---:|");
    for r in &rows {
        for b in &r.bands {
            println!(
                "| {} | {:.0},{:.0} | {} | {}–{}° | {:.1} % | {:.1} % | {:.2} ({:.2}) | {:.2} ({:.2}) |",
                r.method,
                r.gaze[0],
                r.gaze[1],
                crate::common::thousands(r.samples),
                b.lo_deg,
                b.hi_deg,
                b.pixel_fraction * 100.0,
                b.unsampled_fraction * 100.0,
                b.u_median,
                b.u_p90,
                b.v_median,
                b.v_p90
            );
        }
    }
    Ok(())
}
