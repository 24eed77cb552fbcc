//! `fovea curves`: shading rate against eccentricity for every mapping, as PNG and CSV.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use fovea_core::acuity::AcuityModel;
use fovea_core::analysis::{shading_rate_curves, MethodEntry};
use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;

use crate::choices::Headset;
use crate::common::{acuity, parse_gaze, DisplayArgs, MethodOptions};
use crate::plot::{line_plot, Series, Style};

#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct CurvesArgs {
    #[command(flatten)]
    display: DisplayArgs,
    /// Gaze point X,Y in pixels (default: screen centre).
    #[arg(long, allow_hyphen_values = true)]
    gaze: Option<String>,
    /// Methods to plot, comma-separated.
    #[arg(long, value_delimiter = ',',
          default_values_t = ["vafr", "kfr", "lafr", "visual-polar", "guenter", "inset", "weier", "full"].map(String::from))]
    methods: Vec<String>,
    /// Reproduce one of VaFR's figures instead (5, 8, 9, 10 or 21); overrides display, gaze
    /// and methods.
    #[arg(long)]
    figure: Option<u32>,
    /// Acuity pivots ECC:CPD,… for the acuity curve and VaFR (default 0:40,10:10,20:6,30:5,60:4).
    #[arg(long)]
    pivots: Option<String>,
    /// Largest eccentricity plotted, degrees.
    #[arg(long, default_value_t = PlotRange::DEFAULT.emax)]
    emax: f64,
    /// Top of the rate axis, cycles per degree.
    #[arg(long, default_value_t = PlotRange::DEFAULT.ymax)]
    ymax: f64,
    /// Eccentricities sampled per curve.
    #[arg(long, default_value_t = PlotRange::DEFAULT.samples)]
    samples: usize,
    /// Output folder.
    #[arg(long, default_value = "fovea-out/curves")]
    out: PathBuf,
    #[command(flatten)]
    options: MethodOptions,
    /// Do not list the files written.
    #[arg(long, short)]
    quiet: bool,
}

struct Spec {
    label: String,
    display: DisplayProfile,
    gaze: Gaze,
    entry: MethodEntry,
}

fn entry(method: Method, acuity: &AcuityModel) -> MethodEntry {
    entry_with_delta(method, acuity, 1.8)
}

fn entry_with_delta(method: Method, acuity: &AcuityModel, delta: f64) -> MethodEntry {
    let mut e = match method {
        Method::Kfr => MethodEntry::kfr(delta),
        Method::Lafr => MethodEntry::lafr(delta),
        m => MethodEntry::plain(m),
    };
    e.config.vafr.acuity = acuity.clone();
    e
}

fn flat(w: u32, h: u32) -> Result<DisplayProfile> {
    Ok(DisplayProfile::with_vertical_fov(
        format!("{w}x{h}"),
        w,
        h,
        Degrees(90.0),
    )?)
}

fn figure_specs(n: u32, acuity: &AcuityModel) -> Result<(String, Vec<Spec>)> {
    let spec = |label: &str, d: &DisplayProfile, g: Gaze, e: MethodEntry| Spec {
        label: label.to_string(),
        display: d.clone(),
        gaze: g,
        entry: e,
    };
    let lmfr = |delta: f64| {
        let mut e = MethodEntry::kfr(delta);
        e.label = format!("LMFR({delta})");
        e
    };
    let vafr = entry(Method::Vafr, acuity);
    Ok(match n {
        5 => {
            let d = DisplayProfile::preset("2k")?;
            let g = d.centre_gaze();
            (
                "Fig. 5: shading rate at 2560×1440, gaze at the centre".into(),
                vec![
                    spec("Guenter", &d, g, entry(Method::Guenter, acuity)),
                    spec("LMFR(1.8)", &d, g, lmfr(1.8)),
                    spec("LaFR(1.8)", &d, g, MethodEntry::lafr(1.8)),
                    spec("Visual-polar", &d, g, entry(Method::VisualPolar, acuity)),
                    spec("VaFR", &d, g, vafr),
                ],
            )
        }
        8 => {
            let mut v = Vec::new();
            for (w, h) in [(1920, 1080), (7680, 4320)] {
                let d = flat(w, h)?;
                let g = d.centre_gaze();
                v.push(spec(&format!("LMFR(1.8) {w}×{h}"), &d, g, lmfr(1.8)));
                v.push(spec(
                    &format!("LaFR(1.8) {w}×{h}"),
                    &d,
                    g,
                    MethodEntry::lafr(1.8),
                ));
                v.push(spec(&format!("VaFR {w}×{h}"), &d, g, vafr.clone()));
            }
            ("Fig. 8: 1920×1080 vs 7680×4320".into(), v)
        }
        9 => {
            let d = DisplayProfile::preset("retinal")?;
            let g = d.centre_gaze();
            let mut tuned = MethodEntry::lafr(8.0);
            tuned.config.lafr.alpha = 0.78;
            tuned.config.lafr.beta = 0.9;
            tuned.label = "LaFR(8, α=0.78, β=0.9)".into();
            (
                "Fig. 9: retinal 11520×6480, LMFR/LaFR tuned (δ = 8)".into(),
                vec![
                    spec("LMFR(8)", &d, g, lmfr(8.0)),
                    spec("LaFR tuned", &d, g, tuned),
                    spec("VaFR", &d, g, vafr),
                ],
            )
        }
        10 => {
            let d = DisplayProfile::preset("2k")?;
            let mut v = Vec::new();
            for (name, g) in [
                ("centre", d.centre_gaze()),
                ("corner", d.gaze(128.0, 72.0)?),
            ] {
                v.push(spec(&format!("LMFR(1.8) {name}"), &d, g, lmfr(1.8)));
                v.push(spec(
                    &format!("LaFR(1.8) {name}"),
                    &d,
                    g,
                    MethodEntry::lafr(1.8),
                ));
                v.push(spec(&format!("VaFR {name}"), &d, g, vafr.clone()));
            }
            (
                "Fig. 10: gaze at the centre vs near the corner (2560×1440)".into(),
                v,
            )
        }
        21 => {
            let d = DisplayProfile::preset("vive-pro-eye")?;
            let g = d.centre_gaze();
            (
                "Fig. 21: radial and tangential rate at 1440×1600".into(),
                vec![
                    spec("LMFR(1.8)", &d, g, lmfr(1.8)),
                    spec("LaFR(1.8)", &d, g, MethodEntry::lafr(1.8)),
                    spec("VaFR", &d, g, vafr),
                ],
            )
        }
        other => bail!("invalid parameter `figure` = {other}: expected 5, 8, 9, 10 or 21"),
    })
}

pub fn run(a: CurvesArgs) -> Result<()> {
    if !(a.emax.is_finite() && a.emax > 0.0 && a.emax <= 89.0) {
        bail!(
            "invalid parameter `emax` = {}: expected degrees in (0, 89]",
            a.emax
        );
    }
    if !(a.ymax.is_finite() && a.ymax > 0.0) {
        bail!(
            "invalid parameter `ymax` = {}: expected a positive rate",
            a.ymax
        );
    }
    if !(2..=100_000).contains(&a.samples) {
        bail!(
            "invalid parameter `samples` = {}: expected 2..=100000",
            a.samples
        );
    }
    let acuity = acuity(a.pivots.as_deref())?;
    let (title, specs, stem) = match a.figure {
        Some(n) => {
            let (t, s) = figure_specs(n, &acuity)?;
            (t, s, format!("fig{n}"))
        }
        None => {
            let d = a.display.display(Headset::K2)?;
            let g = parse_gaze(&d, a.gaze.as_deref())?;
            let methods = a
                .methods
                .iter()
                .map(|m| crate::common::parse_list_method(m))
                .collect::<Result<Vec<_>, _>>()?;
            let specs = method_specs(&d, g, &methods, &acuity, &a.options)?;
            if specs.is_empty() {
                bail!("invalid parameter `methods`: name at least one method");
            }
            (display_title(&d, g), specs, "curves".to_string())
        }
    };
    let plot = PlotRange {
        emax: a.emax,
        ymax: a.ymax,
        samples: a.samples,
    };
    for p in write_curves(&title, &specs, &stem, &acuity, plot, &a.out)? {
        if !a.quiet {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// The axes and sampling of a plot.
#[derive(Clone, Copy)]
struct PlotRange {
    emax: f64,
    ymax: f64,
    samples: usize,
}

impl PlotRange {
    /// The defaults of `fovea curves`: 0–60°, rates up to 45 cpd, 600 samples.
    const DEFAULT: PlotRange = PlotRange {
        emax: 60.0,
        ymax: 45.0,
        samples: 600,
    };
}

/// VaFR figure `n` (5, 8, 9, 10 or 21) with the default acuity curve and axes in `out`:
/// the radial and tangential plots (PNG) and the CSV, in that order.
pub fn write_figure(n: u32, out: &Path) -> Result<Vec<PathBuf>> {
    let acuity = AcuityModel::vafr_default();
    let (title, specs) = figure_specs(n, &acuity)?;
    write_curves(
        &title,
        &specs,
        &format!("fig{n}"),
        &acuity,
        PlotRange::DEFAULT,
        out,
    )
}

/// One curve per method on `display` with the gaze at `gaze`.
fn method_specs(
    display: &DisplayProfile,
    gaze: Gaze,
    methods: &[Method],
    acuity: &AcuityModel,
    options: &MethodOptions,
) -> Result<Vec<Spec>> {
    let mut specs = Vec::new();
    for &m in methods {
        let mut e = entry_with_delta(m, acuity, options.delta.unwrap_or(1.8));
        options.apply(&mut e.config)?;
        specs.push(Spec {
            label: e.label.clone(),
            display: display.clone(),
            gaze,
            entry: e,
        });
    }
    Ok(specs)
}

/// Every method's curves on `display` with the gaze at `gaze` (default parameters), named
/// `stem`: the radial and tangential plots (PNG) and the CSV.
pub fn write_display_curves(
    display: &DisplayProfile,
    gaze: Gaze,
    methods: &[Method],
    stem: &str,
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let acuity = AcuityModel::vafr_default();
    let specs = method_specs(display, gaze, methods, &acuity, &MethodOptions::default())?;
    let title = display_title(display, gaze);
    write_curves(&title, &specs, stem, &acuity, PlotRange::DEFAULT, out)
}

/// A plot title: the display (its resolution once, even when its name is the resolution,
/// as with `--res 1920x1080`) and the gaze.
fn display_title(d: &DisplayProfile, g: Gaze) -> String {
    let res = format!("{}×{}", d.width_px, d.height_px);
    let plain = format!("{}x{}", d.width_px, d.height_px);
    let name = if d.name.eq_ignore_ascii_case(&plain) || d.name == res {
        res
    } else {
        format!("{} {res}", d.name)
    };
    format!("{name}, gaze ({:.0}, {:.0})", g.point.x_px, g.point.y_px)
}

/// Radial and tangential plots and the CSV of `specs`.
fn write_curves(
    title: &str,
    specs: &[Spec],
    stem: &str,
    acuity: &AcuityModel,
    a: PlotRange,
    out: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("creating output folder {}", out.display()))?;
    let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
    let (mut radial, mut tangential) = (Vec::new(), Vec::new());
    let mut es = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        let c = shading_rate_curves(
            &s.display,
            s.gaze,
            std::slice::from_ref(&s.entry),
            acuity,
            Degrees(a.emax),
            a.samples,
        )?;
        if i == 0 {
            es = c.eccentricity_deg.clone();
            columns.push(("acuity_cpd".into(), c.acuity_cpd.clone()));
            columns.push((
                format!("display_{}_cpd", s.display.name),
                c.display_cpd.clone(),
            ));
            let pts = |v: &[f64]| {
                es.iter()
                    .copied()
                    .zip(v.iter().copied())
                    .collect::<Vec<_>>()
            };
            for set in [&mut radial, &mut tangential] {
                set.push(Series {
                    label: "acuity 1/ω(e)".into(),
                    points: pts(&c.acuity_cpd),
                    style: Style::Reference,
                });
                set.push(Series {
                    label: format!("full resolution {}", s.display.name),
                    points: pts(&c.display_cpd),
                    style: Style::Display,
                });
            }
        }
        let curve = &c.curves[0];
        let pts = |v: &[f64]| {
            es.iter()
                .copied()
                .zip(v.iter().copied())
                .collect::<Vec<_>>()
        };
        radial.push(Series {
            label: s.label.clone(),
            points: pts(&curve.radial_cpd),
            style: Style::Method(i),
        });
        tangential.push(Series {
            label: s.label.clone(),
            points: pts(&curve.tangential_cpd),
            style: Style::Method(i),
        });
        columns.push((format!("{} radial_cpd", s.label), curve.radial_cpd.clone()));
        columns.push((
            format!("{} tangential_cpd", s.label),
            curve.tangential_cpd.clone(),
        ));
    }
    let radial_png = out.join(format!("{stem}-radial.png"));
    let tangential_png = out.join(format!("{stem}-tangential.png"));
    let csv = out.join(format!("{stem}.csv"));
    let x_desc = "Eccentricity (degrees)";
    line_plot(
        &radial_png,
        &format!("Radial shading rate — {title}"),
        x_desc,
        "Radial shading rate (cycles/degree)",
        (0.0, a.emax),
        a.ymax,
        &radial,
    )?;
    line_plot(
        &tangential_png,
        &format!("Tangential shading rate — {title}"),
        x_desc,
        "Tangential shading rate (cycles/degree)",
        (0.0, a.emax),
        a.ymax,
        &tangential,
    )?;
    fovea_core::atomic_file::write_atomic_with(&csv, |f| {
        write!(f, "eccentricity_deg")?;
        for (name, _) in &columns {
            write!(f, ",\"{}\"", name.replace('"', "'"))?;
        }
        writeln!(f)?;
        for (k, e) in es.iter().enumerate() {
            write!(f, "{e}")?;
            for (_, v) in &columns {
                write!(f, ",{}", v[k])?;
            }
            writeln!(f)?;
        }
        Ok(())
    })?;
    Ok(vec![radial_png, tangential_png, csv])
}
