//! Line plots with plotters, drawn with the DejaVu Sans font shipped in `assets/fonts` so the
//! binary depends on no system font library.

use std::path::Path;
use std::sync::Once;

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use plotters::style::FontStyle;

static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

pub(crate) fn register_font() {
    REGISTER.call_once(|| {
        // The bytes are a valid TrueType font shipped with the crate.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Style {
    /// The acuity model: thick black.
    Reference,
    /// The display's own rate: grey.
    Display,
    /// A method, coloured by index.
    Method(usize),
}

/// One line of a plot.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
}

const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
    RGBColor(188, 189, 34),
    RGBColor(127, 127, 127),
];

/// Draws `series` into a PNG at `path`. Values above `y_max` are left out (the line breaks)
/// rather than clipped flat, so nothing drawn is misleading.
pub fn line_plot(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    x_range: (f64, f64),
    y_max: f64,
    series: &[Series],
) -> Result<()> {
    register_font();
    let err = |e: &dyn std::fmt::Display| anyhow!("drawing {}: {e}", path.display());
    // Drawn in memory, then written complete or not at all (plotters' file backend saves
    // through the image crate's `save`, which does not report the last buffered write).
    const W: u32 = 1280;
    const H: u32 = 800;
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 28))
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(80)
            .build_cartesian_2d(x_range.0..x_range.1, 0.0..y_max)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .axis_desc_style(("sans-serif", 22))
            .label_style(("sans-serif", 18))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| err(&e))?;
        for s in series {
            let (color, width) = match s.style {
                Style::Reference => (BLACK, 4),
                Style::Display => (RGBColor(150, 150, 150), 2),
                Style::Method(i) => (PALETTE[i % PALETTE.len()], 3),
            };
            let mut first = true;
            for run in runs(&s.points, y_max) {
                let anno = chart
                    .draw_series(LineSeries::new(run, color.stroke_width(width)))
                    .map_err(|e| err(&e))?;
                if first {
                    anno.label(s.label.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(width))
                    });
                    first = false;
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 18))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let png = crate::output::png_bytes(path, W, H, buf)?;
    crate::output::write_file(path, &png)
}

/// Splits a polyline into runs of finite points with `y ≤ y_max`.
fn runs(points: &[(f64, f64)], y_max: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for &(x, y) in points {
        if x.is_finite() && y.is_finite() && y <= y_max && y >= 0.0 {
            cur.push((x, y));
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_break_at_out_of_range_points() {
        let p = [
            (0.0, 1.0),
            (1.0, 99.0),
            (2.0, 2.0),
            (3.0, f64::NAN),
            (4.0, 3.0),
        ];
        let r = runs(&p, 10.0);
        assert_eq!(r.len(), 3);
        assert_eq!(r[1], vec![(2.0, 2.0)]);
    }
}
