//! The inset paper's gradient-intensity table (`fovea inset-analysis`): a full-resolution inset
//! over a 1/4-resolution periphery, every boundary smoothing, against the full frame.

use anyhow::Result;

use fovea_eval::experiments::inset::{run as run_inset, InsetParams, Row};

use crate::inset_analysis::write_json;

use super::doc::{Cell, Section, Table};
use super::Ctx;

/// Rays per pixel of the inset section's reference with the viewer's shading and `--quick`.
pub const QUICK_INSET_REFERENCE_PIXEL_SAMPLES: u32 = 16;

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    // The paper's periphery: 1/4 resolution per side, upsampled by 4; the default band.
    let mut params = InsetParams {
        shading: ctx.args.shading.into(),
        ..InsetParams::default()
    };
    if ctx.args.quick {
        // CI: a lighter reference (its noise floor row says what that costs).
        params.reference_pixel_samples = QUICK_INSET_REFERENCE_PIXEL_SAMPLES;
    }
    params.validate()?;
    params.check_display(&ctx.display)?;
    let dir = ctx.dir("inset")?;
    params.images = Some(dir.clone());
    let analysis = run_inset(&ctx.loaded.world, &ctx.camera, &ctx.gaze, &params)?;
    let json = write_json(&analysis, &dir)?;
    let (rect, rows) = (analysis.inset, &analysis.rows);
    let (factor, band) = (params.periphery_factor, params.band_px);
    sec.text(format!(
        "Inset {}×{} at ({}, {}) around the gaze, periphery rendered at 1/{factor} resolution per side; gradients ×100 of grey (Sobel), four areas of {band} px across the boundary: Area1 well inside, Area2 just inside, Area3 just outside, Area4 well outside. The full frame's Area2/Area3 is the target; Area1 should not change.",
        rect.w, rect.h, rect.x0, rect.y0
    ));
    let mut t = Table::new(
        "inset-gradient",
        "Mean gradient intensity per area, x / y",
        &[
            "method",
            "Area1 x",
            "Area1 y",
            "Area2 x",
            "Area2 y",
            "Area3 x",
            "Area3 y",
            "Area4 x",
            "Area4 y",
            "slope 2→3 x",
            "slope 2→3 y",
            "Area2/Area3 x",
            "Area2/Area3 y",
            "Area1 change (%)",
        ],
    );
    // A ratio over an area without gradient is undefined, not a number.
    let ratio = |v: f64| {
        if v.is_finite() {
            Cell::Num(v, 2)
        } else {
            Cell::text("— (flat Area3)")
        }
    };
    for r in rows
        .iter()
        .take(1)
        .chain(&analysis.floor_row)
        .chain(rows.iter().skip(1))
    {
        let a = &r.report.areas;
        let mut cells = vec![Cell::text(r.method.clone())];
        for area in a.iter().take(4) {
            cells.push(Cell::Num(area.mean_x, 2));
            cells.push(Cell::Num(area.mean_y, 2));
        }
        cells.extend([
            Cell::Num(r.report.slope_23_x, 2),
            Cell::Num(r.report.slope_23_y, 2),
            ratio(r.area2_over_area3[0]),
            ratio(r.area2_over_area3[1]),
            Cell::Num(100.0 * r.area1_change, 2),
        ]);
        t.row(cells);
    }
    sec.table(t);
    sec.text(if params.shading.is_noisy() {
        format!(
            "Shading as a viewer gets it (`--shading viewer`): the inset and the periphery are denoised full-resolution frames of the real-time preset; the row `full` is the converged reference ({} rays per pixel, not denoised), and the row after it its twin of another seed: {}.",
            params.reference_pixel_samples,
            analysis.floor.describe()
        )
    } else {
        "Noise-free shading (`--shading noise-free`): the inset is the full frame's own pixels.".to_string()
    });
    if let Some(best) = rows
        .iter()
        .skip(1)
        .filter(|r| r.area2_over_area3.iter().all(|v| v.is_finite()))
        .min_by(|a, b| {
            let err = |r: &Row| {
                (0..2)
                    .map(|k| (r.area2_over_area3[k] - rows[0].area2_over_area3[k]).abs())
                    .sum::<f64>()
            };
            err(a).total_cmp(&err(b))
        })
    {
        sec.text(format!(
            "Closest to the full frame's Area2/Area3 ({:.2} / {:.2}): {} ({:.2} / {:.2}).",
            rows[0].area2_over_area3[0],
            rows[0].area2_over_area3[1],
            best.method,
            best.area2_over_area3[0],
            best.area2_over_area3[1]
        ));
    }
    for name in ["full", "none", "alpha-blend", "laplacian"] {
        sec.image(
            ctx.link(&dir.join(format!("{name}.png"))),
            format!("{name} (the inset is the quarter-size rectangle around the gaze)"),
        );
    }
    sec.text(format!(
        "Reproduce: fovea inset-analysis {}{} --gaze {:.0},{:.0} --shading {} --reference-pixel-samples {}.",
        super::scene_flags(&ctx.args.scene),
        super::display_flags(&ctx.args.display),
        ctx.gaze.point.x_px,
        ctx.gaze.point.y_px,
        params.shading.name(),
        params.reference_pixel_samples
    ));
    sec.data = json;
    Ok(())
}
