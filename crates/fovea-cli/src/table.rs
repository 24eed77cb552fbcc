//! `fovea table`: samples per eye for every method at the VaFR test resolutions (Table 1).

use anyhow::Result;
use clap::Args;
use fovea_core::analysis::{default_entries, sample_table, MethodEntry};
use fovea_core::display::{DisplayProfile, VAFR_TEST_PRESETS};

use crate::common::{thousands, MethodOptions};

#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct TableArgs {
    /// Print a JSON array (one object per method and resolution) instead of a text table.
    #[arg(long)]
    json: bool,
    /// Displays (presets) to tabulate, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = VAFR_TEST_PRESETS.iter().map(|s| s.to_string()).collect::<Vec<_>>())]
    headsets: Vec<String>,
    /// Methods to include, comma-separated (default: every method; KFR at δ = 1.8 and LaFR at
    /// δ = 1.8 and 2.2 as in VaFR Table 1).
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
    /// Gaze position as a fraction of the screen, X,Y in [0, 1] (counts of gaze-following
    /// layers and insets depend on it; VaFR's does not).
    #[arg(long, default_value = "0.5,0.5")]
    gaze_frac: String,
    /// Extra rows with these parameters (e.g. --delta 8 adds kfr(8) and lafr(8)).
    #[command(flatten)]
    options: MethodOptions,
    /// Instead: VaFR's headset calibration for these headsets — the acuity curve capped at
    /// each display's Nyquist rate (ppd/2, VaFR Sec. 3.3, Fig. 3) and the anisotropic
    /// tangential factor (radial acuity twice tangential at 30°, Sec. 9), with the samples each
    /// saves.
    #[arg(long, value_delimiter = ',')]
    calibrate: Vec<String>,
    /// The table only, without the notes that compare it with the paper.
    #[arg(long, short)]
    quiet: bool,
}

pub fn run(a: TableArgs) -> Result<()> {
    if !a.calibrate.is_empty() {
        return calibrate(&a.calibrate, a.json, a.quiet);
    }
    let displays = a
        .headsets
        .iter()
        .map(|h| DisplayProfile::preset(h))
        .collect::<Result<Vec<_>, _>>()?;
    let wanted = a
        .methods
        .iter()
        .map(|m| crate::common::parse_list_method(m))
        .collect::<Result<Vec<_>, _>>()?;
    let mut entries = default_entries();
    // δ adds KFR/LaFR rows at that ratio beside Table 1's.
    if let Some(d) = a.options.delta {
        entries.extend([MethodEntry::kfr(d), MethodEntry::lafr(d)]);
    }
    entries.retain(|e| wanted.is_empty() || wanted.contains(&e.method));
    for e in entries.iter_mut() {
        a.options.apply(&mut e.config)?;
    }
    let gaze = parse_frac(&a.gaze_frac)?;
    let rows = sample_table(&displays, &entries, gaze)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    print_text(&displays, &entries, &rows, a.quiet);
    Ok(())
}

fn parse_frac(t: &str) -> Result<(f64, f64)> {
    let bad = || anyhow::anyhow!("invalid parameter `gaze-frac` = {t}: expected X,Y in [0, 1]");
    let v: Vec<f64> = t
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    if v.len() != 2 || v.iter().any(|x| !(0.0..=1.0).contains(x)) {
        return Err(bad());
    }
    Ok((v[0], v[1]))
}

/// A display's column header: its name and resolution, the resolution once when the name
/// is the resolution (`--res 1920x1080`).
fn display_label(d: &DisplayProfile) -> String {
    let res = format!("{}x{}", d.width_px, d.height_px);
    if d.name.eq_ignore_ascii_case(&res) {
        res
    } else {
        format!("{} {res}", d.name)
    }
}

fn print_text(
    displays: &[DisplayProfile],
    entries: &[MethodEntry],
    rows: &[fovea_core::analysis::TableRow],
    quiet: bool,
) {
    println!("Samples (rays) shaded per eye per frame");
    // Each column as wide as its header or its numbers, two spaces apart, so that long
    // headset names (`pimax-crystal 2880x2880`) never run into their neighbours.
    let heads: Vec<String> = displays.iter().map(display_label).collect();
    let label_w = entries
        .iter()
        .map(|e| e.label.chars().count())
        .max()
        .unwrap_or(0)
        .max("method".len());
    let cell = |d: &DisplayProfile| {
        let n = rows
            .iter()
            .filter(|r| r.display == d.name)
            .map(|r| thousands(r.samples).chars().count())
            .max()
            .unwrap_or(0);
        n.max(display_label(d).chars().count())
    };
    let widths: Vec<usize> = displays.iter().map(cell).collect();
    let mut header = format!("{:<label_w$}", "method");
    for (h, w) in heads.iter().zip(&widths) {
        header.push_str(&format!("  {h:>w$}"));
    }
    println!("{}", header.trim_end());
    for e in entries {
        let mut line = format!("{:<label_w$}", e.label);
        for (d, w) in displays.iter().zip(&widths) {
            let r = rows
                .iter()
                .find(|r| r.label == e.label && r.display == d.name)
                .expect("one row per entry and display");
            line.push_str(&format!("  {:>w$}", thousands(r.samples)));
        }
        println!("{line}");
    }
    if quiet {
        return;
    }
    println!();
    println!("Pixels per degree at the centre of the rectilinear target, across / down:");
    let name_w = displays
        .iter()
        .map(|d| d.name.chars().count())
        .max()
        .unwrap_or(0);
    for d in displays {
        let (x, y) = d.centre_ppd_axes();
        println!(
            "  {:<name_w$}  {x:>6.2} / {y:>6.2} px/deg ({:.1}°×{:.1}°)",
            d.name, d.hfov.0, d.vfov.0
        );
    }
    println!();
    println!("vafr covers the screen out to the farthest corner from the gaze; vafr(60°) is the");
    println!("paper's buffer (Sec. 3.2.2), whose pixels beyond 60° have no sample.");
    println!("VaFR Table 1 prints thousands truncated: VaFR_Dup 1,061K at every resolution;");
    println!("LaFR(2.2) 761K…15,423K; LaFR(1.8) 1,137K…23,040K; GT 3,686K…74,649K.");
}

/// VaFR samples per eye with the default curve, the headset-capped curve, the anisotropic
/// tangential factor, and both, per headset.
fn calibrate(headsets: &[String], json: bool, quiet: bool) -> Result<()> {
    use fovea_core::acuity::{AcuityModel, TangentialFactor};
    use fovea_core::mapping::{Vafr, VafrParams};
    use fovea_core::units::CyclesPerDegree;
    let mut rows = Vec::new();
    for h in headsets {
        let d = DisplayProfile::preset(h)?;
        let cap = d.nyquist_cpd();
        let capped = AcuityModel::vafr_default().headset_capped(CyclesPerDegree(cap))?;
        let count = |acuity: AcuityModel, tangential: TangentialFactor| -> Result<u64> {
            // The paper's Eq. 3 rings: the whole buffer, as Sec. 3.3 counts it.
            let p = VafrParams {
                acuity,
                tangential,
                ..VafrParams::eq3()
            };
            Ok(fovea_core::mapping::FoveationMapping::sample_count(
                &Vafr::new(&d, d.centre_gaze(), p)?,
            ))
        };
        let base = count(AcuityModel::vafr_default(), TangentialFactor::isotropic())?;
        let c = count(capped.clone(), TangentialFactor::isotropic())?;
        let t = count(
            AcuityModel::vafr_default(),
            TangentialFactor::radial_twice_at_30(),
        )?;
        let both = count(capped, TangentialFactor::radial_twice_at_30())?;
        let saved = |n: u64| 100.0 * (1.0 - n as f64 / base as f64);
        rows.push(serde_json::json!({
            "headset": d.name,
            "nyquist_cpd": cap,
            "vafr_default": base,
            "capped": c, "capped_saved_pct": saved(c),
            "anisotropic": t, "anisotropic_saved_pct": saved(t),
            "capped_anisotropic": both, "capped_anisotropic_saved_pct": saved(both),
        }));
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    println!("VaFR samples per eye: default curve, capped at the headset's Nyquist rate, anisotropic Δ(e), both");
    println!(
        "| headset | cap (cpd) | default | capped (saved) | radial2x30 (saved) | both (saved) |"
    );
    println!("|---|---|---|---|---|---|");
    for r in &rows {
        let n = |k: &str| thousands(r[k].as_u64().unwrap_or(0));
        let p = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        println!(
            "| {} | {:.1} | {} | {} ({:.1} %) | {} ({:.1} %) | {} ({:.1} %) |",
            r["headset"].as_str().unwrap_or(""),
            p("nyquist_cpd"),
            n("vafr_default"),
            n("capped"),
            p("capped_saved_pct"),
            n("anisotropic"),
            p("anisotropic_saved_pct"),
            n("capped_anisotropic"),
            p("capped_anisotropic_saved_pct"),
        );
    }
    if !quiet {
        println!(
            "VaFR Fig. 3: capping saves 20 % (Vive Pro Eye, 9 cpd) and 8 % (Pimax Crystal, 18 cpd)."
        );
    }
    Ok(())
}
