//! Samples per eye of every method at 2K…retinal (VaFR Table 1), beside the paper's numbers,
//! and the shading-rate figures (VaFR Figs. 5, 8 and 21, and every method on the report's
//! headset).

use anyhow::Result;

use fovea_core::analysis::{default_entries, sample_table};
use fovea_core::display::{DisplayProfile, VAFR_TEST_PRESETS};
use fovea_core::mapping::Method;

use super::doc::{Cell, Section, Table};
use super::Ctx;

/// VaFR Table 1 (thousands of pixels per eye, truncated as printed): label, then 2K, 4K, 6K,
/// 8K, retinal.
const PAPER_TABLE1_K: [(&str, [u64; 5]); 4] = [
    ("vafr(60°)", [1_061, 1_061, 1_061, 1_061, 1_061]),
    ("lafr(2.2)", [761, 1_713, 3_855, 6_854, 15_423]),
    ("lafr(1.8)", [1_137, 2_560, 5_760, 10_240, 23_040]),
    ("full", [3_686, 8_294, 18_662, 33_177, 74_649]),
];

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let mut displays = VAFR_TEST_PRESETS
        .iter()
        .map(|p| DisplayProfile::preset(p))
        .collect::<Result<Vec<_>, _>>()?;
    if !displays.iter().any(|d| d.name == ctx.display.name) {
        displays.push(ctx.display.clone());
    }
    let entries = default_entries();
    let rows = sample_table(&displays, &entries, (0.5, 0.5))?;
    let mut cols = vec!["method".to_string()];
    cols.extend(
        displays
            .iter()
            .map(|d| format!("{} {}×{}", d.name, d.width_px, d.height_px)),
    );
    let col_refs: Vec<&str> = cols.iter().map(String::as_str).collect();
    let mut t = Table::new(
        "table1",
        "Samples (rays) shaded per eye per frame, gaze at the screen centre",
        &col_refs,
    );
    let count = |label: &str, display: &str| {
        rows.iter()
            .find(|r| r.label == label && r.display == display)
            .map(|r| r.samples)
    };
    for e in &entries {
        let mut cells = vec![Cell::text(e.label.clone())];
        for d in &displays {
            cells.push(count(&e.label, &d.name).map_or(Cell::text("—"), Cell::Int));
        }
        t.row(cells);
    }
    sec.table(t);

    // Ours beside the paper's, in thousands.
    let mut p = Table::new(
        "table1-paper",
        "Beside VaFR Table 1 (thousands of samples per eye; the paper truncates)",
        &[
            "method",
            "resolution",
            "VaFR Table 1 (K)",
            "fovea (K)",
            "difference (%)",
        ],
    );
    for (label, paper) in PAPER_TABLE1_K {
        for (k, preset) in VAFR_TEST_PRESETS.iter().enumerate() {
            let Some(ours) = count(label, preset) else {
                continue;
            };
            let ours_k = ours as f64 / 1000.0;
            p.row(vec![
                Cell::text(label),
                Cell::text(*preset),
                Cell::Int(paper[k]),
                Cell::Num(ours_k, 1),
                Cell::Num(100.0 * (ours_k - paper[k] as f64) / paper[k] as f64, 2),
            ]);
        }
    }
    sec.table(p);

    let range = |label: &str| {
        let n: Vec<u64> = VAFR_TEST_PRESETS
            .iter()
            .filter_map(|d| count(label, d))
            .collect();
        (
            n.iter().copied().min().unwrap_or(0),
            n.iter().copied().max().unwrap_or(0),
        )
    };
    let (lo, hi) = range("vafr(60°)");
    sec.check(
        "VaFR's buffer (the paper's, 60°) shades the same number of samples at every \
         resolution, 2K to retinal",
        lo > 0 && lo == hi,
        format!("{lo} to {hi} samples per eye"),
    );
    // The default leaves the texels off the screen unshaded, found with a margin of a few
    // screen pixels: the count moves by a few hundred samples with the resolution.
    let (lo, hi) = range("vafr");
    sec.check(
        "VaFR covering the screen shades the same number of samples at every resolution \
         within 0.5 %",
        lo > 0 && (hi - lo) as f64 <= 0.005 * lo as f64,
        format!("{lo} to {hi} samples per eye"),
    );

    // Figures: the paper's, and every method on this headset with the report's gaze.
    let dir = ctx.dir("figures")?;
    for n in [5, 8, 21] {
        let files = crate::curves::write_figure(n, &dir)?;
        sec.image(
            ctx.link(&files[0]),
            format!("VaFR Fig. {n}: radial shading rate against eccentricity"),
        );
        sec.image(
            ctx.link(&files[1]),
            format!("VaFR Fig. {n}: tangential shading rate"),
        );
    }
    let methods: Vec<Method> = Method::ALL
        .into_iter()
        .filter(|&m| m != Method::Full)
        .collect();
    let files =
        crate::curves::write_display_curves(&ctx.display, ctx.gaze, &methods, "headset", &dir)?;
    sec.image(
        ctx.link(&files[0]),
        format!(
            "Every method's radial shading rate on {} with the report's gaze",
            ctx.display.name
        ),
    );
    sec.image(ctx.link(&files[1]), "… and tangential");
    sec.text(format!(
        "The curves as CSV: {} (and figN.csv for each figure).",
        ctx.link(&files[2])
    ));
    sec.data = serde_json::to_value(&rows)?;
    Ok(())
}
