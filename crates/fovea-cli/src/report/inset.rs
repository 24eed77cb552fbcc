//! The inset paper's gradient-intensity table (`fovea inset-analysis`): a full-resolution inset
//! over a 1/4-resolution periphery, every boundary smoothing, against the full frame.

use anyhow::Result;

use fovea_eval::gradient_intensity::DEFAULT_BAND_PX;

use crate::inset_analysis::{analyse, check_options, inset_rect};

use super::doc::{Cell, Section, Table};
use super::Ctx;

/// The paper's periphery: 1/4 resolution per side, upsampled by 4.
const PERIPHERY_FACTOR: u32 = 4;

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let band = DEFAULT_BAND_PX;
    check_options(&ctx.display, PERIPHERY_FACTOR, band)?;
    let rect = inset_rect(&ctx.display, &ctx.gaze, None, band)?;
    let dir = ctx.dir("inset")?;
    let (rows, json) = analyse(
        &ctx.loaded.world,
        &ctx.camera,
        &ctx.display,
        rect,
        PERIPHERY_FACTOR,
        band,
        &dir,
    )?;
    sec.text(format!(
        "Inset {}×{} at ({}, {}) around the gaze, periphery rendered at 1/{PERIPHERY_FACTOR} resolution per side; gradients ×100 of grey (Sobel), four areas of {band} px across the boundary: Area1 well inside, Area2 just inside, Area3 just outside, Area4 well outside. The full frame's Area2/Area3 is the target; Area1 should not change.",
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
    for r in &rows {
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
    if let Some(best) = rows
        .iter()
        .skip(1)
        .filter(|r| r.area2_over_area3.iter().all(|v| v.is_finite()))
        .min_by(|a, b| {
            let err = |r: &crate::inset_analysis::Row| {
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
        "Reproduce: fovea inset-analysis {}{} --gaze {:.0},{:.0}.",
        super::scene_flags(&ctx.args.scene),
        super::display_flags(&ctx.args.display),
        ctx.gaze.point.x_px,
        ctx.gaze.point.y_px
    ));
    sec.data = json;
    Ok(())
}
