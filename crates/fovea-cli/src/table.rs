//! `fovea table`: samples per eye for every method at the VaFR test resolutions (Table 1).

use anyhow::Result;
use clap::Args;
use fovea_core::analysis::{default_entries, sample_table, MethodEntry};
use fovea_core::display::{DisplayProfile, VAFR_TEST_PRESETS};
use fovea_core::mapping::Method;

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
}

pub fn run(a: TableArgs) -> Result<()> {
    let displays = a
        .headsets
        .iter()
        .map(|h| DisplayProfile::preset(h))
        .collect::<Result<Vec<_>, _>>()?;
    let wanted = a
        .methods
        .iter()
        .map(|m| Method::parse(m))
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
    print_text(&displays, &entries, &rows);
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

fn print_text(
    displays: &[DisplayProfile],
    entries: &[MethodEntry],
    rows: &[fovea_core::analysis::TableRow],
) {
    println!("Samples (rays) shaded per eye per frame");
    let mut header = format!("{:<14}", "method");
    for d in displays {
        header.push_str(&format!(
            "{:>20}",
            format!("{} {}x{}", d.name, d.width_px, d.height_px)
        ));
    }
    println!("{header}");
    for e in entries {
        let mut line = format!("{:<14}", e.label);
        for d in displays {
            let r = rows
                .iter()
                .find(|r| r.label == e.label && r.display == d.name)
                .expect("one row per entry and display");
            line.push_str(&format!("{:>20}", thousands(r.samples)));
        }
        println!("{line}");
    }
    println!();
    println!("VaFR Table 1 prints thousands truncated: VaFR_Dup 1,061K at every resolution;");
    println!("LaFR(2.2) 761K…15,423K; LaFR(1.8) 1,137K…23,040K; GT 3,686K…74,649K.");
}
