//! `fovea optics`: DOF limits and circles of confusion of the thin-lens eye.

use anyhow::{bail, Result};
use clap::Args;
use fovea_core::optics::{
    dof_weight, pupil_de_groot_gebhard, pupil_liu_linear, EyeModel, TrackingAwareCoc,
    DEFAULT_MAX_DEPTH_M,
};
use fovea_core::units::{CandelasPerSquareMetre, Lux, Metres, Millimetres};
use serde_json::json;

use crate::choices::Headset;
use crate::common::DisplayArgs;

#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct OpticsArgs {
    /// Focus (accommodation) distance in metres.
    #[arg(long, default_value_t = 1.0)]
    focus: f64,
    /// Pupil diameter in mm (default: from --lux or --luminance, else 4.49 mm).
    #[arg(long, conflicts_with_all = ["lux", "luminance"])]
    pupil: Option<f64>,
    /// Ambient illuminance in lux: pupil from Liu's linear fit (150 lx → 5.22 mm,
    /// 350 lx → 4.24 mm).
    #[arg(long, conflicts_with = "luminance")]
    lux: Option<f64>,
    /// Display luminance in cd/m²: pupil from de Groot & Gebhard (1952).
    #[arg(long)]
    luminance: Option<f64>,
    /// Eye focal length in mm.
    #[arg(long, default_value_t = 22.3)]
    focal_length: f64,
    /// CoC criterion on the retina in mm (f·tan 1′ ≈ 0.0065).
    #[arg(long, default_value_t = 0.0065)]
    coc_criterion: f64,
    /// Object distances in metres at which to report the CoC.
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.3, 0.5, 1.0, 2.0, 5.0, 50.0])]
    depth: Vec<f64>,
    /// Gaze-depth uncertainty t in metres for Weier's tracking-aware CoC.
    #[arg(long, default_value_t = 0.2)]
    depth_uncertainty: f64,
    #[command(flatten)]
    display: DisplayArgs,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Accepted as by every command; `optics` prints only the numbers asked for, so there is
    /// nothing to leave out.
    #[arg(long, short)]
    quiet: bool,
}

pub fn run(a: OpticsArgs) -> Result<()> {
    let display = a.display.display(Headset::VivePro)?;
    let (pupil, source) = match (a.pupil, a.lux, a.luminance) {
        (Some(p), _, _) => (Millimetres(p), "given".to_string()),
        (_, Some(lx), _) => (
            pupil_liu_linear(Lux(lx))?,
            format!("Liu linear fit at {lx} lx"),
        ),
        (_, _, Some(l)) => (
            pupil_de_groot_gebhard(CandelasPerSquareMetre(l))?,
            format!("de Groot & Gebhard at {l} cd/m²"),
        ),
        _ => (Millimetres(4.49), "Liu's HMD default (300 lx)".to_string()),
    };
    let eye = EyeModel::new(
        Millimetres(a.focal_length),
        Millimetres(a.coc_criterion),
        pupil,
    )?;
    let focus = Metres(a.focus);
    let lim = eye.dof_limits(focus)?;
    let q = eye.liu_coefficients();
    let ppd = display.ppd();
    let weier = TrackingAwareCoc {
        image_distance: Millimetres(22.4),
        depth_uncertainty: Metres(a.depth_uncertainty),
        pupil,
        pixels_per_retinal_mm: TrackingAwareCoc::pixels_per_retinal_mm_for(ppd, Millimetres(22.4)),
    };
    if a.depth.is_empty() {
        bail!("invalid parameter `depth`: give at least one distance in metres");
    }
    let mut rows = Vec::new();
    for &d in &a.depth {
        let depth = Metres(d);
        let retina = eye.coc_retina(focus, depth)?;
        let angle = eye.coc_angle(focus, depth)?;
        rows.push(json!({
            "depth_m": d,
            "coc_retina_mm": retina.0,
            "coc_arcmin": angle.0 * 60.0,
            "coc_px": angle.0 * ppd,
            "coc_stabilised": eye.coc_stabilised(focus, depth)?,
            "coc_tracking_aware_px": weier.coc_pixels(focus, depth)?,
            "dof_weight": dof_weight(depth, &lim, Metres(DEFAULT_MAX_DEPTH_M)),
        }));
    }
    if a.json {
        let out = json!({
            "focal_length_mm": eye.focal_length.0,
            "coc_criterion_mm": eye.coc_criterion.0,
            "pupil_mm": pupil.0,
            "pupil_source": source,
            "focus_m": a.focus,
            "near_m": lim.near.0,
            "far_m": if lim.far.0.is_finite() { json!(lim.far.0) } else { json!("infinity") },
            "hyperfocal_m": eye.hyperfocal().0,
            "liu_coefficients": {"a": q.a, "b_far": q.b_far, "b_near": q.b_near, "k": q.k},
            "display": display.name, "ppd": ppd,
            "depths": rows,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!(
        "Eye: f = {} mm, c = {} mm, pupil τ = {:.3} mm ({source})",
        eye.focal_length.0, eye.coc_criterion.0, pupil.0
    );
    println!(
        "Liu Eq. 8–9 form: D_F = {:.2}F/({:.2} − {:.4}F), D_N = {:.2}F/({:.2} + {:.4}F)  (mm)",
        q.a, q.b_far, q.k, q.a, q.b_near, q.k
    );
    let far = if lim.far.0.is_finite() {
        format!("{:.4} m", lim.far.0)
    } else {
        "infinity".into()
    };
    println!(
        "Focus {:.3} m: depth of field {:.4} m … {far}; far limit infinite beyond {:.2} m",
        a.focus,
        lim.near.0,
        eye.hyperfocal().0
    );
    println!(
        "Display {} at {:.1} ppd; signed CoC (near −, far +):",
        display.name, ppd
    );
    println!(
        "{:>9} {:>12} {:>10} {:>9} {:>12} {:>14} {:>8}",
        "depth m", "retina mm", "arcmin", "px", "Eq.13", "Weier Eq.3 px", "w_d"
    );
    for r in rows {
        println!(
            "{:>9.3} {:>12.5} {:>10.2} {:>9.2} {:>12.4} {:>14.2} {:>8.3}",
            r["depth_m"].as_f64().unwrap_or(f64::NAN),
            r["coc_retina_mm"].as_f64().unwrap_or(f64::NAN),
            r["coc_arcmin"].as_f64().unwrap_or(f64::NAN),
            r["coc_px"].as_f64().unwrap_or(f64::NAN),
            r["coc_stabilised"].as_f64().unwrap_or(f64::NAN),
            r["coc_tracking_aware_px"].as_f64().unwrap_or(f64::NAN),
            r["dof_weight"].as_f64().unwrap_or(f64::NAN),
        );
    }
    Ok(())
}
