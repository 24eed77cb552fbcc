//! VaFR's rings sized at the true eccentricity of every screen point they cross (an extension
//! of Zhang, Gai, Li, Eq. 3–9, for gazes away from the optical axis).
//!
//! VaFR's Eq. 3, `e = atan(c_r·r)`, is the eccentricity of a point `r` pixels from the gaze
//! only when the gaze lies on the optical axis. From a gaze near a screen corner the rings far
//! from it cross the screen's middle, where a pixel subtends up to 4× the angle Eq. 3
//! assumes, so the buffer lands on the screen 3.5–4.3× coarser than the acuity model asks
//! (`fovea fidelity`, docs/rendering.md). This profile keeps VaFR's layout (rings are circles
//! around the gaze on the screen, rows uniform in the polar angle, Eq. 8) and sizes every ring
//! by the worst point of its on-screen arc instead:
//!
//! * a point `p` at true eccentricity `e(p)` (the angle between the eye's rays through `p` and
//!   the gaze), where the eye's ray turns `a(p)` radians per pixel as `p` moves away from the
//!   gaze, needs texels no wider than `s(p) = (ω(e(p))/2) / a(p)` pixels — at a centred gaze
//!   (`a = c_r·cos² e`) exactly VaFR's Eq. 4–6: square texels in screen pixels, radially at
//!   the acuity;
//! * the ring of radius `r` gets `du/dr = max 1/s(p)` columns per pixel and
//!   `period = max Δ(e(p))·2πr/s(p)` rows per turn over its on-screen points (Eq. 8 and 19
//!   with `2πr/s` in place of `360·sin 2e/ω`, equal to it at a centred gaze).
//!
//! Rings are tabulated every [`RING_STEP_DEG`] of radius at the principal point (at most a
//! pixel), their worst point found among [`ANGLES_PER_RING`] angles, `u(r)` integrated by the
//! trapezoid rule and read through a cubic Hermite of `u` and `du/dr` (smooth, strictly
//! increasing); the inverse solves that cubic by safeguarded Newton, to 1e-13 of a texel, and
//! the rows per turn are read linearly. At a centred gaze on a square-pixel display the columns
//! are Eq. 3's within 0.02 texel and the buffer's width within one column (tested). Texels
//! whose footprint lies off the screen are not shaded ([`RingProfile::shaded_runs`]): from a
//! corner three quarters of every far ring are off the screen, so the rays the screen needs
//! cost about what Eq. 3 spends.

use rayon::prelude::*;

use crate::acuity::{AcuityModel, TangentialFactor};
use crate::display::{DisplayProfile, Gaze};

/// Radius step of the ring table as the angle it spans at the principal point, degrees (at
/// most one pixel: 0.98 px at the Vive Pro Eye, finer on displays of few pixels).
pub const RING_STEP_DEG: f64 = 0.1;

/// Polar angles sampled around each ring when taking its worst point.
const ANGLES_PER_RING: usize = 360;

/// Polar angles sampled per column when finding its on-screen rows (besides the corners').
const ANGLES_PER_COLUMN: usize = 1024;

/// The turn between the polar angles a column tries.
fn column_step() -> f64 {
    1.0 / ANGLES_PER_COLUMN as f64
}

/// Where the rays from the gaze at the polar angles every column tries in
/// [`RingProfile::shaded_runs`] enter and leave the screen widened by [`SCREEN_MARGIN_PX`]:
/// per ray the distances `(t_in, t_out)` from the gaze (`t_in > t_out` for a ray that misses
/// it), found once per mapping rather than once per column.
#[derive(Clone, Debug)]
pub(crate) struct ColumnRays {
    /// The [`ANGLES_PER_COLUMN`] uniform angles, turn `k / ANGLES_PER_COLUMN`.
    uniform: Vec<(f64, f64)>,
    /// The angles of the widened screen's four corners: their turn in `[0, 1)` and span.
    corners: [(f64, (f64, f64)); 4],
}

impl ColumnRays {
    /// The rays from `gaze` on `display`.
    pub(crate) fn new(display: &DisplayProfile, gaze: &Gaze) -> Self {
        let m = SCREEN_MARGIN_PX;
        let (x0, y0) = (-m, -m);
        let (x1, y1) = (display.width_px as f64 + m, display.height_px as f64 + m);
        let g = gaze.point;
        // The ray's parameter interval inside the widened screen, clipped slab by slab as
        // the per-angle test clips `[r_lo, r_hi]` (max and min are exact, so clipping the
        // column's radii against this interval later gives the same comparison).
        let span = |(sn, cs): (f64, f64)| {
            let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
            for (o, d, lo, hi) in [(g.x_px, cs, x0, x1), (g.y_px, sn, y0, y1)] {
                if d.abs() < 1e-12 {
                    if o < lo || o > hi {
                        return (f64::INFINITY, f64::NEG_INFINITY);
                    }
                } else {
                    let (a, b) = ((lo - o) / d, (hi - o) / d);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
            }
            (t0, t1)
        };
        let step = column_step();
        let uniform = (0..ANGLES_PER_COLUMN)
            .map(|k| span((std::f64::consts::TAU * (k as f64 * step)).sin_cos()))
            .collect();
        let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| {
            let turn = ((y - g.y_px).atan2(x - g.x_px) / std::f64::consts::TAU).rem_euclid(1.0);
            (turn, span((std::f64::consts::TAU * turn).sin_cos()))
        });
        Self { uniform, corners }
    }
}

/// The rows a column's crossing angles mark, as a difference array over the rows (wrapping
/// around the turn): the angles from `turn0` to `turn1` mark the rows from
/// `(turn0 − step)·period − dilate` to `(turn1 + step)·period + dilate`.
struct RowMarks {
    diff: Vec<i32>,
    rows: u32,
    period: f64,
    dilate: f64,
    step: f64,
    all: bool,
}

impl RowMarks {
    fn new(rows: u32, period: f64, dilate: f64, step: f64) -> Self {
        Self {
            diff: vec![0; rows as usize + 1],
            rows,
            period,
            dilate,
            step,
            all: false,
        }
    }

    fn mark(&mut self, turn0: f64, turn1: f64) {
        let n = self.rows as i64;
        let j0 = ((turn0 - self.step) * self.period - self.dilate).floor() as i64;
        let j1 = ((turn1 + self.step) * self.period + self.dilate).floor() as i64 + 1;
        if j1 - j0 >= n {
            self.all = true;
            return;
        }
        let (a, b) = (j0.rem_euclid(n), j1.rem_euclid(n));
        let d = &mut self.diff;
        if a < b {
            d[a as usize] += 1;
            d[b as usize] -= 1;
        } else {
            d[a as usize] += 1;
            d[n as usize] -= 1;
            d[0] += 1;
            d[b as usize] -= 1;
        }
    }

    /// The marked rows as half-open runs.
    fn runs(self) -> Vec<(u32, u32)> {
        let rows = self.rows;
        if self.all {
            return vec![(0, rows)];
        }
        let mut runs = Vec::new();
        let mut level = 0;
        let mut start = None;
        for (j, d) in self.diff.iter().take(rows as usize).enumerate() {
            level += d;
            match (level > 0, start) {
                (true, None) => start = Some(j as u32),
                (false, Some(s0)) => {
                    runs.push((s0, j as u32));
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s0) = start {
            runs.push((s0, rows));
        }
        runs
    }
}

/// Margin, in pixels, around the screen within which a texel counts as on the screen, and the
/// pixel footprint the reconstruction may read beyond a texel's neighbours.
pub(crate) const SCREEN_MARGIN_PX: f64 = 2.0;

/// `u(r)` and the rows per turn of every ring, tabulated in radius.
#[derive(Clone, Debug)]
pub(crate) struct RingProfile {
    /// Radius step of the table, pixels.
    step: f64,
    /// `u` at `r = k·step`.
    u: Vec<f64>,
    /// `du/dr` at `r = k·step` (the ring's worst point), columns per pixel.
    dudr: Vec<f64>,
    /// Rows per turn at `r = k·step` (`Δ` included).
    period: Vec<f64>,
    /// The radius the buffer reaches, pixels (the table runs to the next whole step).
    r_max: f64,
}

/// A read-only view of the exact rings' table (this module's ring profile), for executors
/// that evaluate the mapping themselves (the GPU's mapping shader uploads it): entry `k`
/// describes the ring of radius `r_k = k·step_px` pixels.
///
/// The mapping reads it as follows (`Vafr`'s forward and inverse do exactly this): with
/// `x = r/step_px`, `k = ⌊x⌋`, `t = x − k`, the column is the cubic Hermite through
/// `(u[k], du_dr[k]·step_px)` and `(u[k+1], du_dr[k+1]·step_px)` at `t`, and the rows per turn
/// `period[k] + (period[k+1] − period[k])·t`; past the last entry both stay at its value. The
/// inverse solves the same cubic for `t` in the step whose `u[k] ≤ u < u[k+1]`.
#[derive(Clone, Copy, Debug)]
pub struct RingTable<'a> {
    profile: &'a RingProfile,
}

impl<'a> RingTable<'a> {
    pub(crate) fn new(profile: &'a RingProfile) -> Self {
        Self { profile }
    }

    /// Radius step between entries, pixels (at most 1).
    pub fn step_px(&self) -> f64 {
        self.profile.step
    }

    /// The column coordinate `u(r_k)` of every entry, buffer pixels (`u[0] = 0`, increasing).
    pub fn u(&self) -> &'a [f64] {
        &self.profile.u
    }

    /// `du/dr` at every entry (its ring's worst point), columns per pixel.
    pub fn du_dr(&self) -> &'a [f64] {
        &self.profile.dudr
    }

    /// Rows per turn at every entry (`Δ` included).
    pub fn period(&self) -> &'a [f64] {
        &self.profile.period
    }

    /// The radius the buffer reaches, pixels (inside the table's last step).
    pub fn r_max_px(&self) -> f64 {
        self.profile.r_max
    }
}

impl RingProfile {
    /// The profile out to `r_max` pixels from `gaze` on `display`.
    pub(crate) fn new(
        display: &DisplayProfile,
        gaze: &Gaze,
        acuity: &AcuityModel,
        tangential: &TangentialFactor,
        r_max: f64,
    ) -> Self {
        let (w, h) = (display.width_px as f64, display.height_px as f64);
        let g = gaze.point;
        let dg = display.eye_direction(g);
        let pp = display.principal_point();
        let (fx, fy) = (display.focal_x_px(), display.focal_y_px());
        let step = (RING_STEP_DEG.to_radians().tan() / display.c_r()).min(1.0);
        let n = (r_max / step).ceil() as usize + 1;
        let trig: Vec<(f64, f64)> = (0..ANGLES_PER_RING)
            .map(|a| (std::f64::consts::TAU * a as f64 / ANGLES_PER_RING as f64).sin_cos())
            .collect();
        // Worst texel density (1/s) and rows per turn on the ring of radius r; `None` when
        // the ring misses the screen.
        let ring = |r: f64, on_screen_only: bool| -> Option<(f64, f64)> {
            let mut worst: Option<(f64, f64)> = None;
            for &(sn, cs) in &trig {
                let (x, y) = (g.x_px + r * cs, g.y_px + r * sn);
                if on_screen_only && !(x >= 0.0 && x <= w && y >= 0.0 && y <= h) {
                    continue;
                }
                // The eye's ray through p, and how fast it turns as p moves away from the
                // gaze: |(I − d·dᵀ)·∂v/∂r| / |v| radians per pixel.
                let v = [(x - pp.x_px) / fx, (y - pp.y_px) / fy, 1.0];
                let len = crate::math::norm3(v);
                let d = [v[0] / len, v[1] / len, v[2] / len];
                let dv = [cs / fx, sn / fy, 0.0];
                let along = d[0] * dv[0] + d[1] * dv[1];
                let a =
                    crate::math::norm3([dv[0] - d[0] * along, dv[1] - d[1] * along, -d[2] * along])
                        / len;
                let e = crate::math::angle_between_deg(d, dg);
                let inv_s = a / (0.5 * acuity.mar_deg(e)).to_radians();
                let per = tangential.at(e) * std::f64::consts::TAU * r * inv_s;
                let (du, pe) = worst.unwrap_or((0.0, 0.0));
                worst = Some((du.max(inv_s), pe.max(per)));
            }
            worst
        };
        // Every ring's worst point (in parallel: ~10⁶ rays at a headset's resolution).
        let rings: Vec<Option<(f64, f64)>> = (0..n)
            .into_par_iter()
            .map(|k| ring(k as f64 * step, true))
            .collect();
        let mut dudr: Vec<f64> = Vec::with_capacity(n);
        let mut period: Vec<f64> = Vec::with_capacity(n);
        // A gaze just off the screen: the rings closer than the screen's nearest point.
        let nearest = (-g.x_px)
            .max(g.x_px - w)
            .max(0.0)
            .hypot((-g.y_px).max(g.y_px - h).max(0.0));
        for (k, on_screen) in rings.into_iter().enumerate() {
            let r = k as f64 * step;
            let (du, per) = on_screen
                // A ring that misses the screen: short of it, the whole ring; beyond the
                // farthest corner (the table's last pixel), the ring inside it.
                .or_else(|| (r <= nearest).then(|| ring(r, false)).flatten())
                .or_else(|| (k > 0).then(|| (dudr[k - 1], period[k - 1])))
                .unwrap_or((0.0, 0.0));
            dudr.push(du);
            period.push(per);
        }
        let mut u = Vec::with_capacity(n);
        u.push(0.0);
        for k in 1..n {
            u.push(u[k - 1] + 0.5 * step * (dudr[k - 1] + dudr[k]));
        }
        Self {
            step,
            u,
            dudr,
            period,
            r_max,
        }
    }

    /// The radius the buffer reaches, pixels (the table runs to the next whole step).
    pub(crate) fn r_max(&self) -> f64 {
        self.r_max
    }

    /// `u(r_max)`.
    pub(crate) fn u_max(&self) -> f64 {
        self.u_of_r(self.r_max)
    }

    fn at(&self, table: &[f64], r: f64) -> f64 {
        let x = (r / self.step).max(0.0);
        let k = (x.floor() as usize).min(table.len() - 1);
        if k + 1 >= table.len() {
            return table[table.len() - 1];
        }
        let f = x - k as f64;
        table[k] + (table[k + 1] - table[k]) * f
    }

    /// `u` at the fraction `t ∈ [0, 1]` of table step `k`, and `du/dt`: the cubic Hermite
    /// through the two entries' `u` and `du/dr`, so `u(r)` is smooth (C¹) rather than
    /// bending at every entry. The trapezoid rule makes each step's rise the mean of its end
    /// slopes, so the cubic increases strictly (Fritsch–Carlson: `α + β = 2`).
    fn hermite(&self, k: usize, t: f64) -> (f64, f64) {
        let (u0, u1) = (self.u[k], self.u[k + 1]);
        let (m0, m1) = (self.dudr[k] * self.step, self.dudr[k + 1] * self.step);
        let (t2, t3) = (t * t, t * t * t);
        let u = (2.0 * t3 - 3.0 * t2 + 1.0) * u0
            + (t3 - 2.0 * t2 + t) * m0
            + (-2.0 * t3 + 3.0 * t2) * u1
            + (t3 - t2) * m1;
        let du = (6.0 * t2 - 6.0 * t) * (u0 - u1)
            + (3.0 * t2 - 4.0 * t + 1.0) * m0
            + (3.0 * t2 - 2.0 * t) * m1;
        (u, du)
    }

    /// The buffer column coordinate of the ring of radius `r` pixels.
    pub(crate) fn u_of_r(&self, r: f64) -> f64 {
        let x = (r / self.step).max(0.0);
        let k = x.floor() as usize;
        if k + 1 >= self.u.len() {
            return self.u[self.u.len() - 1];
        }
        self.hermite(k, x - k as f64).0
    }

    /// Rows per turn of the ring of radius `r` pixels.
    pub(crate) fn period_of_r(&self, r: f64) -> f64 {
        self.at(&self.period, r)
    }

    /// The radius of column coordinate `u`, the inverse of [`Self::u_of_r`] on `0..=u_max`
    /// (to 1e-12 of a step: Newton's method on the step's cubic, kept inside its bracket).
    pub(crate) fn r_of_u(&self, u: f64) -> f64 {
        let k = self.u.partition_point(|&x| x <= u);
        if k == 0 {
            return 0.0;
        }
        if k >= self.u.len() {
            return (self.u.len() - 1) as f64 * self.step;
        }
        let k = k - 1;
        let (u0, u1) = (self.u[k], self.u[k + 1]);
        if u1 <= u0 {
            return k as f64 * self.step;
        }
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut t = (u - u0) / (u1 - u0);
        for _ in 0..60 {
            let (v, dv) = self.hermite(k, t);
            if (v - u).abs() <= 1e-13 * (1.0 + u.abs()) || hi - lo < 1e-14 {
                break;
            }
            if v < u {
                lo = t;
            } else {
                hi = t;
            }
            let next = if dv > 0.0 { t - (v - u) / dv } else { f64::NAN };
            t = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        (k as f64 + t) * self.step
    }

    /// The shaded rows of column `i` (its texels at `u ∈ [i, i+1)`, `rows` rows of
    /// `period` per turn) as half-open runs `[j0, j1)`: the rows whose texel, widened by one
    /// texel each way and by the [`SCREEN_MARGIN_PX`] a pixel's footprint may reach, touches
    /// the screen. Every texel the reconstruction of an on-screen pixel reads is in a run.
    ///
    /// The widened texels of the column span the radii `[r_lo, r_hi]`; the polar angles whose
    /// ray from the gaze crosses the widened screen within them form at most a few arcs. They
    /// are found at [`ANGLES_PER_COLUMN`] uniform angles plus the angles of the screen's four
    /// corners (every arc holds a corner angle or is wider than the uniform step: the ray's
    /// exit distance from the screen peaks at the corners), each marking the rows within one
    /// angular step of it.
    ///
    /// `rays` is [`ColumnRays::new`] of the same display and gaze: where each of those rays
    /// enters and leaves the widened screen, computed once per mapping. A run of consecutive
    /// crossing angles marks the union of its angles' rows at once (their row ranges overlap,
    /// and each range's ends grow with the angle), so the runs are those of marking every
    /// angle on its own (tested against that, [`Self::shaded_runs_per_angle`]).
    pub(crate) fn shaded_runs(
        &self,
        i: u32,
        rows: u32,
        period: f64,
        rays: &ColumnRays,
    ) -> Vec<(u32, u32)> {
        if rows == 0 || period <= 0.0 {
            return Vec::new();
        }
        let m = SCREEN_MARGIN_PX;
        let r_lo = (self.r_of_u((i as f64 - 1.0).max(0.0)) - m).max(0.0);
        let r_hi = self.r_of_u(i as f64 + 2.0) + m;
        // Rows reached by a footprint of `m` pixels along the arc, plus one texel.
        let dilate = 1.0 + (m * period / (std::f64::consts::TAU * r_lo.max(1.0))).ceil();
        let crosses = |&(t_in, t_out): &(f64, f64)| r_lo.max(t_in) <= r_hi.min(t_out);
        let step = column_step();
        let mut marks = RowMarks::new(rows, period, dilate, step);
        let mut k = 0;
        let n = rays.uniform.len();
        while k < n {
            if !crosses(&rays.uniform[k]) {
                k += 1;
                continue;
            }
            let k0 = k;
            while k + 1 < n && crosses(&rays.uniform[k + 1]) {
                k += 1;
            }
            marks.mark(k0 as f64 * step, k as f64 * step);
            k += 1;
        }
        for (turn, span) in &rays.corners {
            if crosses(span) {
                marks.mark(*turn, *turn);
            }
        }
        marks.runs()
    }

    /// [`Self::shaded_runs`] the way it was first written: every angle's ray clipped against
    /// the widened screen and its rows marked on their own. The reference the faster one is
    /// tested against.
    #[cfg(test)]
    pub(crate) fn shaded_runs_per_angle(
        &self,
        display: &DisplayProfile,
        gaze: &Gaze,
        i: u32,
        rows: u32,
        period: f64,
    ) -> Vec<(u32, u32)> {
        if rows == 0 || period <= 0.0 {
            return Vec::new();
        }
        let m = SCREEN_MARGIN_PX;
        let (x0, y0) = (-m, -m);
        let (x1, y1) = (display.width_px as f64 + m, display.height_px as f64 + m);
        let g = gaze.point;
        let r_lo = (self.r_of_u((i as f64 - 1.0).max(0.0)) - m).max(0.0);
        let r_hi = self.r_of_u(i as f64 + 2.0) + m;
        let dilate = 1.0 + (m * period / (std::f64::consts::TAU * r_lo.max(1.0))).ceil();
        let crosses = |(sn, cs): (f64, f64)| {
            let (mut t0, mut t1) = (r_lo, r_hi);
            for (o, d, lo, hi) in [(g.x_px, cs, x0, x1), (g.y_px, sn, y0, y1)] {
                if d.abs() < 1e-12 {
                    if o < lo || o > hi {
                        return false;
                    }
                } else {
                    let (a, b) = ((lo - o) / d, (hi - o) / d);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
            }
            t0 <= t1
        };
        let step = column_step();
        let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
            .map(|(x, y)| (y - g.y_px).atan2(x - g.x_px) / std::f64::consts::TAU);
        let mut marks = RowMarks::new(rows, period, dilate, step);
        for k in 0..ANGLES_PER_COLUMN {
            let turn = k as f64 * step;
            if crosses((std::f64::consts::TAU * turn).sin_cos()) {
                marks.mark(turn, turn);
            }
        }
        for t in corners {
            let turn = t.rem_euclid(1.0);
            if crosses((std::f64::consts::TAU * turn).sin_cos()) {
                marks.mark(turn, turn);
            }
        }
        marks.runs()
    }
}
