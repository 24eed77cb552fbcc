//! The rows of a polar buffer's column whose texels lie near the screen, in closed form: where
//! a circle around the pole crosses a rectangle (the screen widened by a margin), as arcs of
//! the polar angle, then as runs of rows (VaFR Eq. 8/11's angle axis: texel `j` of a column of
//! `period` rows per turn lies at the turn `(j + ½)/period`).
//!
//! The point `c + r·(cos φ, sin φ)` lies in `[x0, x1] × [y0, y1]` exactly when
//! `cos φ ∈ [(x0 − cx)/r, (x1 − cx)/r]` and `sin φ ∈ [(y0 − cy)/r, (y1 − cy)/r]`; each is at
//! most two arcs (`acos`, `asin`), and their intersection at most four. A column's texels whose
//! centre angle falls in one of them, widened by [`ROW_SLACK`] rows either side for rounding,
//! form its runs: a handful of arithmetic per column instead of a test per texel, so a mapping
//! whose layout does not move with the gaze can find its shaded texels at every gaze in
//! microseconds (`VafrRings::Eq3AnyGaze`, `vafr.rs`).

use std::f64::consts::{PI, TAU};

/// Rows added at either end of every run: the texels whose centre angle lies within one row
/// of an arc's end are included, so an angle rounded the other way never drops a texel.
pub(crate) const ROW_SLACK: i64 = 1;

/// An axis-aligned rectangle, screen pixels: `[x0, x1] × [y0, y1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    /// The `w × h` screen widened by `m` pixels on every side.
    pub(crate) fn screen(w: f64, h: f64, m: f64) -> Self {
        Self {
            x0: -m,
            y0: -m,
            x1: w + m,
            y1: h + m,
        }
    }

    /// Whether `(x, y)` lies in the rectangle (edges included).
    pub(crate) fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }
}

/// The angles, as turns in `[0, 1]`, where `lo ≤ cos φ ≤ hi` (`cosine`) or `lo ≤ sin φ ≤ hi`,
/// as at most two intervals (an interval crossing turn 0 is split there).
fn band(lo: f64, hi: f64, cosine: bool) -> Vec<(f64, f64)> {
    let (lo, hi) = (lo.max(-1.0), hi.min(1.0));
    if lo > hi {
        return Vec::new();
    }
    // In radians on (−π, π]: cos φ ∈ [lo, hi] ⇔ |φ| ∈ [acos hi, acos lo];
    // sin φ ∈ [lo, hi] ⇔ φ ∈ [asin lo, asin hi] ∪ [π − asin hi, π − asin lo].
    let arcs: [(f64, f64); 2] = if cosine {
        let (a, b) = (hi.acos(), lo.acos());
        [(a, b), (-b, -a)]
    } else {
        let (a, b) = (lo.asin(), hi.asin());
        [(a, b), (PI - b, PI - a)]
    };
    let mut out = Vec::with_capacity(3);
    for (a, b) in arcs {
        // To turns, then into [0, 1) by whole turns; one crossing turn 0 is split.
        let (mut t0, mut t1) = (a / TAU, b / TAU);
        let k = t0.floor();
        t0 -= k;
        t1 -= k;
        if t1 <= 1.0 {
            out.push((t0, t1));
        } else {
            out.push((t0, 1.0));
            out.push((0.0, t1 - 1.0));
        }
    }
    out
}

/// The turns in `[0, 1]` at which the circle of radius `r` around `(cx, cy)` lies in `rect`,
/// as intervals (not merged; empty when it misses). A circle of radius 0 is its centre.
pub(crate) fn arcs_in_rect(cx: f64, cy: f64, r: f64, rect: &Rect) -> Vec<(f64, f64)> {
    if r <= 0.0 {
        return if rect.contains(cx, cy) {
            vec![(0.0, 1.0)]
        } else {
            Vec::new()
        };
    }
    let xs = band((rect.x0 - cx) / r, (rect.x1 - cx) / r, true);
    let ys = band((rect.y0 - cy) / r, (rect.y1 - cy) / r, false);
    let mut out = Vec::new();
    for &(a0, a1) in &xs {
        for &(b0, b1) in &ys {
            let (t0, t1) = (a0.max(b0), a1.min(b1));
            if t0 <= t1 {
                out.push((t0, t1));
            }
        }
    }
    out
}

/// The rows of a column of `rows` rows and `period` rows per turn whose centre angle lies in
/// one of `arcs` (turns), each run widened by [`ROW_SLACK`] rows either side, as sorted,
/// disjoint half-open runs `[j0, j1)` (the angle axis wraps: row `rows` is row 0).
pub(crate) fn runs_of_arcs(arcs: &[(f64, f64)], rows: u32, period: f64) -> Vec<(u32, u32)> {
    if rows == 0 || period <= 0.0 || arcs.is_empty() {
        return Vec::new();
    }
    let n = i64::from(rows);
    // Row j's centre is at turn (j + ½)/period: in [t0, t1] for j ∈ [t0·P − ½, t1·P − ½].
    let mut spans: Vec<(i64, i64)> = Vec::with_capacity(2 * arcs.len());
    for &(t0, t1) in arcs {
        let j0 = (t0 * period - 0.5).ceil() as i64 - ROW_SLACK;
        let j1 = (t1 * period - 0.5).floor() as i64 + ROW_SLACK + 1;
        if j1 - j0 >= n {
            return vec![(0, rows)];
        }
        if j1 <= j0 {
            continue;
        }
        // Into [0, n) by whole turns of rows; a span crossing the wrap is split there.
        let a = j0.rem_euclid(n);
        let b = a + (j1 - j0);
        if b <= n {
            spans.push((a, b));
        } else {
            spans.push((a, n));
            spans.push((0, b - n));
        }
    }
    spans.sort_unstable();
    let mut runs: Vec<(u32, u32)> = Vec::with_capacity(spans.len());
    for (a, b) in spans {
        match runs.last_mut() {
            Some(last) if a <= i64::from(last.1) => last.1 = last.1.max(b as u32),
            _ => runs.push((a as u32, b as u32)),
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift) for the brute-force cases.
    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed.max(1);
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn arcs_hold_exactly_the_angles_whose_point_lies_in_the_rectangle() {
        // Brute force: 20,000 angles per circle, against the point test; an angle counts as
        // in an arc within 1e-9 turns of its ends.
        let mut r = rng(7);
        let rect = Rect::screen(320.0, 200.0, 3.0);
        for case in 0..300 {
            let (cx, cy) = (r() * 500.0 - 90.0, r() * 400.0 - 100.0);
            let rad = if case % 50 == 0 { 0.0 } else { r() * 600.0 };
            let arcs = arcs_in_rect(cx, cy, rad, &rect);
            for k in 0..20_000 {
                let t = k as f64 / 20_000.0;
                let (s, c) = (TAU * t).sin_cos();
                let inside = rect.contains(cx + rad * c, cy + rad * s);
                let near = |e: f64| arcs.iter().any(|&(a, b)| t >= a - e && t <= b + e);
                if inside {
                    assert!(near(1e-9), "case {case}: turn {t} inside, not in {arcs:?}");
                } else {
                    assert!(!near(-1e-9), "case {case}: turn {t} outside, in {arcs:?}");
                }
            }
        }
    }

    #[test]
    fn runs_hold_every_row_whose_centre_is_in_an_arc_and_little_else() {
        // Brute force over every row: a row whose centre angle lies in an arc is in a run;
        // a row in a run lies within ROW_SLACK + 1 rows of an arc.
        let mut r = rng(11);
        for case in 0..2000 {
            let period = 1.0 + r() * 900.0;
            let rows = ((period - 0.5).ceil() as u32).max(1);
            let arcs: Vec<(f64, f64)> = (0..(case % 4))
                .map(|_| {
                    let a = r();
                    (a, (a + r() * 0.3).min(1.0))
                })
                .collect();
            let runs = runs_of_arcs(&arcs, rows, period);
            for w in runs.windows(2) {
                assert!(
                    w[0].1 < w[1].0,
                    "case {case}: runs {runs:?} overlap or touch"
                );
            }
            let in_run = |j: u32| runs.iter().any(|&(a, b)| j >= a && j < b);
            for j in 0..rows {
                let t = (j as f64 + 0.5) / period;
                let in_arc = arcs.iter().any(|&(a, b)| t >= a && t <= b);
                if in_arc {
                    assert!(in_run(j), "case {case}: row {j} (turn {t}) not in {runs:?}");
                }
                if in_run(j) {
                    // Within ROW_SLACK + 1 rows of an arc, the turn wrapping at `rows`.
                    let slack = (ROW_SLACK + 1) as f64 / period;
                    let near = arcs.iter().any(|&(a, b)| {
                        [t, t - rows as f64 / period, t + rows as f64 / period]
                            .iter()
                            .any(|&u| u >= a - slack && u <= b + slack)
                    });
                    assert!(near, "case {case}: row {j} in {runs:?} far from {arcs:?}");
                }
            }
        }
    }
}
