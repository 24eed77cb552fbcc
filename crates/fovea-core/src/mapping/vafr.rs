//! VaFR: visual-acuity-consistent log-polar foveation (Zhang, Gai, Li), Eq. 3–12 and 19.
//!
//! The LP buffer column of eccentricity `e` is `u(e) = ∫₀ᵉ 2/ω` (Eq. 4–5, segmented as Eq. 12),
//! so that the radial shading rate `½·du/de` (Eq. 13) equals the acuity `1/ω(e)` (Eq. 18) at
//! every eccentricity. The row of polar angle `θ` (degrees) is
//! `v(e, θ) = Δ(e)·θ·sin(2e)/ω(e)` (Eq. 8, with Eq. 19's tangential factor), so column `u` holds
//! only the variable shading height `l(e) = v(e, 360°)` (Eq. 9) of valid samples: the buffer is a
//! half-ellipse inside a constant-size rectangle, independent of display resolution and gaze.
//! Inverse mapping: Eq. 10 for `e(u)`, Eq. 11 for the screen point.
//!
//! Coverage: the paper sizes the buffer for `e_max = 60°` (Sec. 3.2.2), which leaves screen
//! points beyond 60° without a sample — the corners of most HMD targets even at a centred gaze,
//! and a large part of the screen at an off-centre one. By default the buffer therefore reaches
//! the farthest screen corner from the gaze ([`Coverage::Screen`]): `e_max` follows from the
//! gaze and the display, and the buffer's width from the acuity out to it. A fixed `e_max`
//! ([`Coverage::Fixed`]) reproduces the paper's buffer.
//!
//! Sample count: buffer pixel `(i, j)` is shaded when its centre lies in the shaded region,
//! i.e. `i + ½ ≤ u(e_max)` and `j + ½ < l(e(i + ½))`. With the default pivots and
//! `e_max = 60°` this is 1,061,7xx samples, within 0.01 % of the integral
//! `∫₀⁶⁰ l(e)·du/de de = 1,061,734` (the paper: 1,061,735). Covering the screen costs more:
//! 64° (a centred gaze on a 16:9 90°-vertical display, the paper's own figure) adds ~3.5 %.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::screen_arcs::{arcs_in_rect, runs_of_arcs, Rect};
use super::vafr_rings::{ColumnRays, RingProfile, RingTable, SCREEN_MARGIN_PX};
use super::{
    polar_deg, tangential_denominator, BufferSize, Coverage, FoveationMapping, Method, Ring,
    SamplePoint, MAX_COVERAGE_DEG,
};
use crate::acuity::{AcuityModel, TangentialFactor};
use crate::display::{eccentricity_deg, DisplayProfile, Gaze};
use crate::error::{check_range_open_lo, Result};
use crate::units::{Degrees, ScreenPoint};

/// Parameters of VaFR.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VafrParams {
    /// The acuity model the mapping follows (default: VaFR's segmented pivots).
    pub acuity: AcuityModel,
    /// Tangential-to-radial rate factor `Δ(e)` (Eq. 19); default isotropic.
    pub tangential: TangentialFactor,
    /// How far out the buffer reaches: the farthest screen corner from the gaze (default), or
    /// a fixed eccentricity (the paper's 60°, Sec. 3.2.2: screen points beyond it then have
    /// no sample and reconstruct black).
    pub max_eccentricity: Coverage,
    /// How the rings are sized: at the true eccentricity of every screen point they cross
    /// (default) or by the paper's Eq. 3 ([`VafrRings::Eq3`]).
    #[serde(default)]
    pub rings: VafrRings,
}

/// How VaFR sizes its rings (the buffer's columns) on the screen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VafrRings {
    /// The paper's Eq. 3, `e = atan(c_r·r)`: the gaze treated as the optical axis. Exact at a
    /// centred gaze; from a corner the far rings are up to 4× coarser than the acuity model.
    Eq3,
    /// Every ring sized by the worst point of its on-screen arc at that point's true
    /// eccentricity (`vafr_rings.rs`); texels off the screen are not shaded. Equal to
    /// [`VafrRings::Eq3`] at a centred gaze, but for those texels. The GPU mapping
    /// (`fovea_gpu::GpuMapping::vafr`) evaluates both: this one from the uploaded table
    /// ([`Vafr::ring_table`]).
    #[default]
    Exact,
    /// Eq. 3's rings in one buffer for every gaze on the screen: it reaches the screen's
    /// diagonal (the farthest corner of a gaze in the opposite corner; with
    /// [`Coverage::Screen`]), so its columns, rows and periods — and every table built from
    /// them — are the same at every such gaze and only the pole moves; the texels whose
    /// footprint lies off the screen are not shaded (`screen_arcs.rs`, found in closed form
    /// per column). What the resident GPU frame builds its tables from once per display
    /// (`fovea_gpu::frame`). Its rings are [`VafrRings::Eq3`]'s, so from a corner gaze the far
    /// rings are as coarse as Eq. 3's.
    Eq3AnyGaze,
}

impl VafrRings {
    /// The name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            VafrRings::Eq3 => "eq3",
            VafrRings::Exact => "exact",
            VafrRings::Eq3AnyGaze => "eq3-any-gaze",
        }
    }
}

impl Default for VafrParams {
    fn default() -> Self {
        Self {
            acuity: AcuityModel::vafr_default(),
            tangential: TangentialFactor::isotropic(),
            max_eccentricity: Coverage::Screen,
            rings: VafrRings::Exact,
        }
    }
}

impl VafrParams {
    /// The paper's configuration: default pivots, isotropic, Eq. 3's rings, a fixed 60° buffer.
    pub fn paper() -> Self {
        Self {
            max_eccentricity: Coverage::Fixed(Degrees(60.0)),
            ..Self::eq3()
        }
    }

    /// The defaults with the paper's Eq. 3 rings (the gaze taken as the optical axis): the
    /// buffer, and its sample count, the same at every gaze.
    pub fn eq3() -> Self {
        Self {
            rings: VafrRings::Eq3,
            ..Self::default()
        }
    }
}

/// The VaFR mapping for one display and gaze.
#[derive(Clone, Debug)]
pub struct Vafr {
    params: VafrParams,
    /// The resolved `e_max`, degrees.
    e_max: f64,
    c_r: f64,
    gaze: ScreenPoint,
    u_max: f64,
    /// Rows per buffer column (all shaded with [`VafrRings::Eq3`]).
    rows: Vec<u32>,
    /// Rows per turn at every column's centre ([`Vafr::period_at_u`] at `i + ½`), the
    /// angle axis of [`FoveationMapping::polar_layout`].
    periods: Vec<f64>,
    height: u32,
    count: u64,
    /// With [`VafrRings::Exact`]: the ring table.
    exact: Option<ExactRings>,
    /// Each column's shaded runs of rows `[j0, j1)`, where not every row is shaded
    /// ([`VafrRings::Exact`], [`VafrRings::Eq3AnyGaze`]).
    runs: Option<Vec<Vec<(u32, u32)>>>,
    /// With [`VafrRings::Eq3AnyGaze`]: each column's ring radius and reach
    /// ([`near_screen_reach`]), which do not depend on the gaze — shared by
    /// [`Vafr::at_gaze`]'s mappings, which only lay the shaded runs out again.
    reach: Option<std::sync::Arc<Vec<ColumnReach>>>,
}

/// One column's ring radius at its centre and how far beyond the screen its widened texels
/// reach ([`near_screen_runs`]), pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ColumnReach {
    r_c: f64,
    grow: f64,
}

#[derive(Clone, Debug)]
struct ExactRings {
    profile: RingProfile,
}

impl Vafr {
    /// Builds the mapping. Its buffer and sample count depend on `params` and, with
    /// [`Coverage::Screen`], on how far the farthest screen corner lies from the gaze.
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: VafrParams) -> Result<Self> {
        display.validate()?;
        if let Coverage::Fixed(e) = params.max_eccentricity {
            check_range_open_lo("max_eccentricity", e.0, 0.0, MAX_COVERAGE_DEG)?;
        }
        let e_max = match params.rings {
            VafrRings::Eq3AnyGaze => any_gaze_e_max(display, &gaze, params.max_eccentricity),
            _ => params.max_eccentricity.resolve(display, &gaze),
        };
        let profile = (params.rings == VafrRings::Exact).then(|| {
            // Out to the farthest corner; a fixed e_max (Eq. 3's radius) may stop short of it.
            let screen = display.farthest_corner_px(&gaze) + 1.0;
            let r_max = match params.max_eccentricity {
                Coverage::Screen => screen,
                Coverage::Fixed(_) => (e_max.to_radians().tan() / display.c_r()).min(screen),
            };
            RingProfile::new(display, &gaze, &params.acuity, &params.tangential, r_max)
        });
        let u_max = match &profile {
            Some(p) => p.u_max(),
            None => params.acuity.u_of_e(e_max),
        };
        let n_cols = if u_max >= 0.5 {
            (u_max - 0.5).floor() as u32 + 1
        } else {
            0
        };
        // Rows per turn at every column's centre, once: the rows and the shaded runs read them.
        let periods: Vec<f64> = (0..n_cols)
            .map(|i| period_at(profile.as_ref(), &params, i as f64 + 0.5))
            .collect();
        let rows: Vec<u32> = periods
            .iter()
            .map(|&l| if l > 0.5 { (l - 0.5).ceil() as u32 } else { 0 })
            .collect();
        let height = rows.iter().copied().max().unwrap_or(0);
        let reach = (profile.is_none() && params.rings == VafrRings::Eq3AnyGaze).then(|| {
            std::sync::Arc::new(near_screen_reach(display, &params.acuity, &rows, &periods))
        });
        let runs: Option<Vec<Vec<(u32, u32)>>> = match (&profile, &reach) {
            (Some(p), _) => {
                let rays = ColumnRays::new(display, &gaze);
                Some(
                    rows.par_iter()
                        .enumerate()
                        .map(|(i, &n)| p.shaded_runs(i as u32, n, periods[i], &rays))
                        .collect(),
                )
            }
            (None, Some(reach)) => Some(near_screen_runs(display, &gaze, reach, &rows, &periods)),
            _ => None,
        };
        let exact = profile.map(|profile| ExactRings { profile });
        let count = match &runs {
            Some(runs) => runs.iter().flatten().map(|&(a, b)| (b - a) as u64).sum(),
            None => rows.iter().map(|&r| r as u64).sum(),
        };
        if count == 0 {
            return Err(crate::error::FoveaError::invalid(
                "vafr samples",
                0,
                format!(
                    "at least one: the buffer reaches {e_max:.4}°, u(e_max) = {u_max:.3} texels \
                     (raise --vafr-emax or the cpd of --vafr-pivots)"
                ),
            ));
        }
        Ok(Self {
            params,
            e_max,
            c_r: display.c_r(),
            gaze: gaze.point,
            u_max,
            rows,
            periods,
            height,
            count,
            exact,
            runs,
            reach,
        })
    }

    /// The mapping at `gaze` on `display`, bit for bit what [`Vafr::new`]`(display, gaze,
    /// params)` builds, from this one's layout where it does not depend on the gaze
    /// ([`VafrRings::Eq3AnyGaze`], built for the same display, the new gaze needing the same
    /// `e_max`): only the shaded runs are laid out again (closed-form arcs per column), the
    /// rows, periods and rings' reach are shared. `None` otherwise (build it anew).
    pub fn at_gaze(&self, display: &DisplayProfile, gaze: Gaze) -> Option<Self> {
        let reach = self.reach.as_ref()?;
        let e_max = any_gaze_e_max(display, &gaze, self.params.max_eccentricity);
        if self.params.rings != VafrRings::Eq3AnyGaze
            || e_max.to_bits() != self.e_max.to_bits()
            || display.c_r().to_bits() != self.c_r.to_bits()
            || reach.len() != self.rows.len()
            || display.validate().is_err()
        {
            return None;
        }
        let runs = near_screen_runs(display, &gaze, reach, &self.rows, &self.periods);
        let count: u64 = runs.iter().flatten().map(|&(a, b)| (b - a) as u64).sum();
        if count == 0 {
            return None;
        }
        Some(Self {
            gaze: gaze.point,
            count,
            runs: Some(runs),
            ..self.clone()
        })
    }

    /// The parameters.
    pub fn params(&self) -> &VafrParams {
        &self.params
    }

    /// The eccentricity the buffer reaches, degrees (the resolved [`VafrParams::max_eccentricity`]).
    pub fn max_eccentricity_deg(&self) -> f64 {
        self.e_max
    }

    /// The pole of the mapping: the gaze point, screen pixels.
    pub fn gaze(&self) -> ScreenPoint {
        self.gaze
    }

    /// The display constant `c_r` of VaFR Eq. 3 (`e = atan(c_r · r)`), per pixel.
    pub fn c_r(&self) -> f64 {
        self.c_r
    }

    /// The screen radius of the buffer's edge, `tan(e_max)/c_r` pixels (Eq. 3 inverted; with
    /// [`VafrRings::Exact`] the ring table's last radius): [`FoveationMapping::forward`] has
    /// no sample farther than this from the gaze.
    pub fn max_radius_px(&self) -> f64 {
        match &self.exact {
            Some(x) => x.profile.r_max(),
            None => self.e_max.to_radians().tan() / self.c_r,
        }
    }

    /// How the rings are sized.
    pub fn rings(&self) -> VafrRings {
        self.params.rings
    }

    /// The exact rings' table ([`RingTable`]: `u`, `du/dr` and rows per turn every
    /// `step_px` of radius), `None` with [`VafrRings::Eq3`].
    pub fn ring_table(&self) -> Option<RingTable<'_>> {
        self.exact.as_ref().map(|x| RingTable::new(&x.profile))
    }

    /// Rows per turn of column coordinate `u ∈ [0, u_max]`, the period of the angle axis there
    /// (Eq. 9/19's `l(e)·Δ(e)` at Eq. 10's `e(u)`; with [`VafrRings::Exact`] the ring table's):
    /// [`FoveationMapping::inverse`] has samples for `v ∈ [0, period_at_u(u)]`.
    pub fn period_at_u(&self, u: f64) -> f64 {
        period_at(self.exact.as_ref().map(|x| &x.profile), &self.params, u)
    }

    /// `u(e_max)`: the continuous buffer width.
    pub fn u_max(&self) -> f64 {
        self.u_max
    }

    /// The shading height `l(e)·Δ(e)` of Eq. 9/19 at eccentricity `e_deg`, in buffer rows.
    pub fn shading_height(&self, e_deg: f64) -> f64 {
        shading_height(&self.params, e_deg)
    }

    /// The exact integral `∫₀^{e_max} l(e)·(du/de) de` that the pixel count approximates.
    pub fn sample_integral(&self) -> f64 {
        // Composite Simpson per acuity segment (the integrand is smooth inside each).
        let e_max = self.e_max;
        let mut knots: Vec<f64> = self
            .params
            .acuity
            .pivots()
            .iter()
            .map(|p| p.eccentricity_deg)
            .filter(|&e| e < e_max)
            .collect();
        knots.push(e_max);
        let f = |e: f64| self.shading_height(e) * 2.0 / self.params.acuity.mar_deg(e);
        let mut total = 0.0;
        for w in knots.windows(2) {
            let n = 2000;
            let h = (w[1] - w[0]) / n as f64;
            let mut s = f(w[0]) + f(w[1]);
            for k in 1..n {
                s += f(w[0] + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            total += s * h / 3.0;
        }
        total
    }
}

/// Rows per turn of column coordinate `u`: the ring table's with the exact rings, else Eq. 9/19's
/// `l(e)·Δ(e)` at Eq. 10's `e(u)`.
fn period_at(profile: Option<&RingProfile>, params: &VafrParams, u: f64) -> f64 {
    match profile {
        Some(p) => p.period_of_r(p.r_of_u(u)),
        None => shading_height(params, params.acuity.e_of_u(u)),
    }
}

fn shading_height(params: &VafrParams, e_deg: f64) -> f64 {
    params.tangential.at(e_deg) * 360.0 * (2.0 * e_deg).to_radians().sin()
        / params.acuity.mar_deg(e_deg)
}

/// [`VafrRings::Eq3AnyGaze`]'s `e_max`: with [`Coverage::Screen`], Eq. 3's eccentricity of
/// the screen's diagonal (the farthest corner of any gaze on the screen) or of this gaze's
/// farthest corner where it lies farther (a gaze off the screen), plus one pixel of radius as
/// [`Coverage::resolve`] adds; a fixed `e_max` as it is.
fn any_gaze_e_max(display: &DisplayProfile, gaze: &Gaze, coverage: Coverage) -> f64 {
    match coverage {
        Coverage::Fixed(e) => e.0,
        Coverage::Screen => {
            let diagonal = (display.width_px as f64).hypot(display.height_px as f64);
            let r = diagonal.max(display.farthest_corner_px(gaze)) + 1.0;
            crate::display::eccentricity_deg(display.c_r(), r).min(MAX_COVERAGE_DEG)
        }
    }
}

/// [`VafrRings::Eq3AnyGaze`]'s shaded runs: per column `i`, the rows whose texel, widened as
/// [`RingProfile::shaded_runs`] widens the exact rings' (one texel each way and
/// [`SCREEN_MARGIN_PX`] beyond), may touch the screen widened by that margin. The widened
/// texel lies within `radial + arc` pixels of the texel's centre (its farthest radius from
/// the centre's, plus the arc of its angular half-width at its outer radius), so the texel is
/// kept when its centre lies in the screen widened by `margin + radial + arc`
/// ([`near_screen_reach`], the same at every gaze): the closed-form arcs of that circle in
/// that rectangle (`screen_arcs.rs`), one row more either side.
fn near_screen_runs(
    display: &DisplayProfile,
    gaze: &Gaze,
    reach: &[ColumnReach],
    rows: &[u32],
    periods: &[f64],
) -> Vec<Vec<(u32, u32)>> {
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let g = gaze.point;
    rows.iter()
        .zip(periods)
        .zip(reach)
        .map(|((&n, &period), c)| {
            if n == 0 || period <= 0.0 {
                return Vec::new();
            }
            let rect = Rect::screen(w, h, c.grow);
            runs_of_arcs(&arcs_in_rect(g.x_px, g.y_px, c.r_c, &rect), n, period)
        })
        .collect()
}

/// Each column's ring radius at its centre `r_c` and the screen's widening `margin + radial +
/// arc` of [`near_screen_runs`]: Eq. 3 and Eq. 10 alone, no gaze (columns without rows
/// carry zeros, unread).
fn near_screen_reach(
    display: &DisplayProfile,
    acuity: &AcuityModel,
    rows: &[u32],
    periods: &[f64],
) -> Vec<ColumnReach> {
    let m = SCREEN_MARGIN_PX;
    let c_r = display.c_r();
    // Eq. 3 inverted at Eq. 10's e(u), the eccentricity kept below 90° (a column past the
    // last reads a radius only for its margin).
    let r_of_u = |u: f64| {
        acuity
            .e_of_u(u.max(0.0))
            .min(MAX_COVERAGE_DEG)
            .to_radians()
            .tan()
            / c_r
    };
    rows.iter()
        .zip(periods)
        .enumerate()
        .map(|(i, (&n, &period))| {
            if n == 0 || period <= 0.0 {
                return ColumnReach {
                    r_c: 0.0,
                    grow: 0.0,
                };
            }
            let i = i as f64;
            let r_c = r_of_u(i + 0.5);
            let r_lo = (r_of_u(i - 1.0) - m).max(0.0);
            let r_hi = r_of_u(i + 2.0) + m;
            let dilate = 1.0 + (m * period / (std::f64::consts::TAU * r_lo.max(1.0))).ceil();
            let arc = std::f64::consts::TAU * r_hi * (0.5 + dilate) / period;
            let radial = (r_hi - r_c).max(r_c - r_lo);
            ColumnReach {
                r_c,
                grow: m + radial + arc,
            }
        })
        .collect()
}

impl FoveationMapping for Vafr {
    fn method(&self) -> Method {
        Method::Vafr
    }

    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "pivots": self.params.acuity.pivots().iter()
                .map(|p| [p.eccentricity_deg, p.cpd]).collect::<Vec<_>>(),
            "coverage": self.params.max_eccentricity.to_string(),
            "max_eccentricity_deg": self.e_max,
            "tangential_isotropic": self.params.tangential.is_isotropic(),
            "rings": self.params.rings.name(),
        })
    }

    fn buffers(&self) -> Vec<BufferSize> {
        vec![BufferSize {
            width: self.rows.len() as u32,
            height: self.height,
        }]
    }

    fn sample_count(&self) -> u64 {
        self.count
    }

    fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
        if layer != 0 {
            return false;
        }
        match &self.runs {
            Some(runs) => runs
                .get(i as usize)
                .is_some_and(|runs| runs.iter().any(|&(a, b)| j >= a && j < b)),
            None => self.rows.get(i as usize).is_some_and(|&r| j < r),
        }
    }

    fn append_shaded_runs(&self, layer: u32, i: u32, out: &mut Vec<(u32, u32)>) -> bool {
        if layer != 0 {
            return true;
        }
        match &self.runs {
            Some(runs) => out.extend(runs.get(i as usize).into_iter().flatten()),
            None => out.extend(
                self.rows
                    .get(i as usize)
                    .filter(|&&r| r > 0)
                    .map(|&r| (0, r)),
            ),
        }
        true
    }

    fn at_gaze(&self, display: &DisplayProfile, gaze: Gaze) -> Option<Box<dyn FoveationMapping>> {
        Vafr::at_gaze(self, display, gaze).map(|m| Box::new(m) as Box<dyn FoveationMapping>)
    }

    fn layout_is_gaze_free(&self) -> bool {
        match self.params.rings {
            VafrRings::Eq3AnyGaze => true,
            VafrRings::Eq3 => matches!(self.params.max_eccentricity, Coverage::Fixed(_)),
            VafrRings::Exact => false,
        }
    }

    fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
        if !(p.x_px.is_finite() && p.y_px.is_finite()) {
            return None;
        }
        let (r, theta) = polar_deg(p, self.gaze);
        if let Some(x) = &self.exact {
            if r > x.profile.r_max() {
                return None;
            }
            let (u, l) = (x.profile.u_of_r(r), x.profile.period_of_r(r));
            return Some(SamplePoint::new(u, theta / 360.0 * l));
        }
        let e = eccentricity_deg(self.c_r, r); // Eq. 3
        if e > self.e_max {
            return None;
        }
        let u = self.params.acuity.u_of_e(e); // Eq. 5 / 12
        let v = theta / 360.0 * self.shading_height(e); // Eq. 8 / 19
        Some(SamplePoint::new(u, v))
    }

    fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
        self.ring(s.layer, s.u)?.point(s.v) // Eq. 11
    }

    fn ring(&self, layer: u32, u: f64) -> Option<Ring> {
        if layer != 0 || !(u >= 0.0 && u <= self.u_max) {
            return None;
        }
        // The ring's radius and rows per turn (the exact rings solve for the radius once).
        let (r_px, period) = match &self.exact {
            Some(x) => {
                let r = x.profile.r_of_u(u);
                (r, x.profile.period_of_r(r))
            }
            None => {
                let e = self.params.acuity.e_of_u(u); // Eq. 10
                (e.to_radians().tan() / self.c_r, self.shading_height(e)) // Eq. 3, 9
            }
        };
        Some(Ring {
            centre: self.gaze,
            r_px,
            period,
        })
    }

    fn polar_layout(&self) -> Option<super::PolarLayout> {
        Some(super::PolarLayout {
            centre: self.gaze,
            period: self.periods.clone(),
            rows: self.rows.clone(),
        })
    }

    fn radial_rate_cpd(&self, e_deg: f64) -> f64 {
        // Eq. 18: ½·du/de = 1/ω(e). With the exact rings this is the rate at each ring's worst
        // point, at its true eccentricity; elsewhere on the ring it is finer (`fovea fidelity`
        // measures both, tests/mappings.rs checks the worst against the acuity).
        1.0 / self.params.acuity.mar_deg(e_deg)
    }

    fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
        let d = tangential_denominator(e_deg);
        if d < 1e-9 {
            // Limit e → 0 of Δ·l(e)/(360·sin 2e).
            return self.params.tangential.at(e_deg) / self.params.acuity.mar_deg(e_deg);
        }
        self.shading_height(e_deg) / d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::display::VAFR_TEST_PRESETS;

    #[test]
    fn an_empty_buffer_is_a_typed_error() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let g = d.centre_gaze();
        let tiny = VafrParams {
            max_eccentricity: Coverage::Fixed(Degrees(0.001)),
            ..VafrParams::default()
        };
        let blind = VafrParams {
            acuity: AcuityModel::parse_pivots("0:0.001,60:0.001").unwrap(),
            ..VafrParams::default()
        };
        for p in [tiny, blind] {
            let e = Vafr::new(&d, g, p).unwrap_err().to_string();
            assert!(
                e.contains("`vafr samples` = 0") && e.contains("--vafr-pivots"),
                "{e}"
            );
        }
    }

    #[test]
    fn a_mapping_moved_to_a_gaze_is_the_one_built_there() {
        let any = VafrParams {
            rings: VafrRings::Eq3AnyGaze,
            ..VafrParams::default()
        };
        for name in ["vive-pro-eye", "8k"] {
            let d = DisplayProfile::preset(name).unwrap();
            let (w, h) = (d.width_px as f64, d.height_px as f64);
            let first = Vafr::new(&d, d.centre_gaze(), any.clone()).unwrap();
            let mut from = first.clone();
            // Corners, edges, the centre again, and a walk in between, each moved from the
            // last one's layout.
            for (fx, fy) in [
                (0.0, 0.0),
                (1.0, 1.0),
                (0.31, 0.77),
                (1.0, 0.0),
                (0.5, 0.5),
                (0.02, 0.5),
            ] {
                let g = d.gaze(fx * w, fy * h).unwrap();
                let built = Vafr::new(&d, g, any.clone()).unwrap();
                let moved = from.at_gaze(&d, g).expect("a gaze on the screen");
                // Debug prints every field, each f64 as the shortest string that reads back
                // to its bits: equal strings, equal mappings.
                assert_eq!(
                    format!("{moved:?}"),
                    format!("{built:?}"),
                    "{name} ({fx}, {fy})"
                );
                assert_eq!(moved.sample_count(), built.sample_count());
                from = moved;
            }
            // Another display, or the exact rings: built anew.
            let other =
                DisplayProfile::preset(if name == "8k" { "vive-pro-eye" } else { "8k" }).unwrap();
            assert!(
                first.at_gaze(&other, other.centre_gaze()).is_none(),
                "{name}"
            );
            let exact = Vafr::new(&d, d.centre_gaze(), VafrParams::default()).unwrap();
            assert!(
                exact.at_gaze(&d, d.gaze(0.0, 0.0).unwrap()).is_none(),
                "{name}"
            );
        }
    }

    #[test]
    fn sample_count_is_constant_across_resolutions_and_gazes() {
        for name in VAFR_TEST_PRESETS {
            let d = DisplayProfile::preset(name).unwrap();
            for (gx, gy) in [(0.5, 0.5), (0.0, 0.0), (1.0, 0.3), (0.1, 0.9)] {
                let g = d
                    .gaze(gx * d.width_px as f64, gy * d.height_px as f64)
                    .unwrap();
                let v = Vafr::new(&d, g, VafrParams::paper()).unwrap();
                let n = v.sample_count() as f64;
                assert!(
                    (n - 1_061_734.0).abs() / 1_061_734.0 < 1e-3,
                    "{name} gaze ({gx},{gy}): {n}"
                );
                assert_eq!(v.buffers()[0].width, 900);
            }
        }
    }

    #[test]
    fn integral_matches_design_figure() {
        let d = DisplayProfile::preset("2k").unwrap();
        let v = Vafr::new(&d, d.centre_gaze(), VafrParams::paper()).unwrap();
        let i = v.sample_integral();
        assert!((i - 1_061_734.0).abs() < 1.0, "{i}");
        // max l(e) = 1638 at e ≈ 38.7° (DESIGN.md).
        let (mut best, mut at) = (0.0, 0.0);
        for k in 0..6000 {
            let e = k as f64 * 0.01;
            let l = v.shading_height(e);
            if l > best {
                best = l;
                at = e;
            }
        }
        assert!(
            (best - 1638.0).abs() < 1.0 && (at - 38.7).abs() < 0.1,
            "{best} at {at}"
        );
        assert_eq!(v.buffers()[0].height, 1638);
    }

    #[test]
    fn radial_rate_equals_acuity_exactly() {
        let d = DisplayProfile::preset("8k").unwrap();
        let v = Vafr::new(&d, d.centre_gaze(), VafrParams::default()).unwrap();
        let a = AcuityModel::vafr_default();
        for k in 0..600 {
            let e = k as f64 * 0.1;
            let want = a.cpd(Degrees(e)).0;
            assert!((v.radial_rate_cpd(e) - want).abs() / want < 1e-6);
            assert!((v.tangential_rate_cpd(e) - want).abs() / want < 1e-6);
        }
    }

    #[test]
    fn wider_coverage_costs_more_samples() {
        let d = DisplayProfile::preset("2k").unwrap();
        let p = VafrParams {
            max_eccentricity: Coverage::Fixed(Degrees(64.0)),
            ..VafrParams::eq3()
        };
        let v = Vafr::new(&d, d.centre_gaze(), p).unwrap();
        assert_eq!(v.buffers()[0].width, 932);
        let extra = v.sample_count() as f64 / 1_061_734.0 - 1.0;
        assert!((extra - 0.035).abs() < 0.005, "{extra}");
    }

    #[test]
    fn headset_caps_save_what_vafr_fig3_states() {
        // VaFR Sec. 3.3: capping the foveal rate at the display's 9 cpd (Vive Pro Eye) saves
        // 20 % of the shading points, at 18 cpd (Pimax Crystal) 8 %. Capping each pivot
        // reproduces both within 2 percentage points.
        use crate::units::CyclesPerDegree;
        let d = DisplayProfile::preset("2k").unwrap();
        let base = Vafr::new(&d, d.centre_gaze(), VafrParams::paper())
            .unwrap()
            .sample_integral();
        for (cap, paper) in [(9.0, 0.20), (18.0, 0.08)] {
            let p = VafrParams {
                acuity: AcuityModel::vafr_default()
                    .headset_capped(CyclesPerDegree(cap))
                    .unwrap(),
                ..VafrParams::paper()
            };
            let v = Vafr::new(&d, d.centre_gaze(), p).unwrap();
            let saved = 1.0 - v.sample_integral() / base;
            assert!((saved - paper).abs() < 0.02, "cap {cap}: saved {saved}");
            let counted = 1.0 - v.sample_count() as f64 / 1_061_630.0;
            assert!((counted - saved).abs() < 1e-3);
        }
        // The presets' own Nyquist rates are those caps.
        assert_eq!(
            DisplayProfile::preset("vive-pro-eye")
                .unwrap()
                .nyquist_cpd(),
            9.0
        );
        assert_eq!(
            DisplayProfile::preset("pimax-crystal")
                .unwrap()
                .nyquist_cpd(),
            17.5
        );
    }

    #[test]
    fn screen_coverage_reaches_the_farthest_corner_at_every_gaze() {
        // A centred gaze on the 16:9 90°-vertical displays: the corners lie at 63.9°, the
        // paper's own 64° buffer (Sec. 3.2.2); the sample count is then ~3.5 % above the
        // paper's 1,061,735.
        let d = DisplayProfile::preset("8k").unwrap();
        let g = d.centre_gaze();
        let v = Vafr::new(&d, g, VafrParams::eq3()).unwrap();
        let corner = d.farthest_corner_eccentricity(&g).0;
        assert!((corner - 63.9).abs() < 0.05, "{corner}");
        assert!(v.max_eccentricity_deg() > corner && v.max_eccentricity_deg() < corner + 0.02);
        let extra = v.sample_count() as f64 / 1_061_735.0 - 1.0;
        assert!((extra - 0.035).abs() < 0.005, "{extra}");
        // A corner gaze reaches the opposite corner; the corner pixel has a column.
        for (gx, gy) in [(0.0, 0.0), (7680.0, 4320.0), (-300.0, 2000.0)] {
            let g = d.gaze(gx, gy).unwrap();
            let v = Vafr::new(&d, g, VafrParams::eq3()).unwrap();
            let far = d.farthest_corner_eccentricity(&g).0;
            assert!(v.max_eccentricity_deg() > far, "{gx},{gy}");
            let (w, h) = (d.width_px as f64, d.height_px as f64);
            for (x, y) in [
                (0.5, 0.5),
                (w - 0.5, 0.5),
                (0.5, h - 0.5),
                (w - 0.5, h - 0.5),
            ] {
                let s = v.forward(ScreenPoint::new(x, y)).expect("covered");
                assert!(s.u <= v.u_max() && (s.u - 0.5).floor() < v.buffers()[0].width as f64);
            }
        }
        // A fixed 60° buffer leaves the corner of an off-centre gaze uncovered.
        let g = d.gaze(1000.0, 800.0).unwrap();
        let v = Vafr::new(&d, g, VafrParams::paper()).unwrap();
        assert!(v.forward(ScreenPoint::new(7679.5, 4319.5)).is_none());
    }

    fn exact() -> VafrParams {
        VafrParams::default()
    }

    #[test]
    fn exact_rings_are_eq3_at_a_centred_gaze() {
        // A gaze on the optical axis of a square-pixel display: Eq. 3 is the true eccentricity,
        // so the ring table reproduces the closed form (to its trapezoid integration and
        // 1° sampling of the ring), and only the off-screen texels go unshaded.
        let d = DisplayProfile::preset("2k").unwrap();
        assert!((d.focal_x_px() - d.focal_y_px()).abs() < 1e-9);
        let g = d.centre_gaze();
        let eq3 = Vafr::new(&d, g, VafrParams::eq3()).unwrap();
        let ex = Vafr::new(&d, g, exact()).unwrap();
        let (bq, bx) = (eq3.buffers()[0], ex.buffers()[0]);
        assert!(bq.width.abs_diff(bx.width) <= 1, "{bq:?} {bx:?}");
        assert!(bq.height.abs_diff(bx.height) <= 2, "{bq:?} {bx:?}");
        for k in 0..200 {
            let t = k as f64 / 200.0;
            let p = ScreenPoint::new(
                g.point.x_px + (t * 37.0).sin() * t * 1000.0,
                g.point.y_px + (t * 37.0).cos() * t * 540.0,
            );
            let (a, b) = (eq3.forward(p).unwrap(), ex.forward(p).unwrap());
            assert!((a.u - b.u).abs() < 0.02, "{p:?}: u {} vs {}", a.u, b.u);
            assert!(
                (a.v - b.v).abs() < 1e-3 * a.v.max(1.0) + 0.02,
                "{p:?}: v {} {}",
                a.v,
                b.v
            );
        }
        let (nq, nx) = (eq3.sample_count() as f64, ex.sample_count() as f64);
        assert!(nx < nq && nx > 0.9 * nq, "{nq} {nx}");
    }

    #[test]
    fn exact_rings_forward_and_inverse_are_inverse() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        for (gx, gy) in [(101.0, 100.0), (1100.0, 1200.0), (-30.0, 800.0)] {
            let g = d.gaze(gx, gy).unwrap();
            let v = Vafr::new(&d, g, exact()).unwrap();
            for k in 0..500 {
                let p =
                    ScreenPoint::new((k * 37 % 1440) as f64 + 0.3, (k * 91 % 1600) as f64 + 0.7);
                let s = v.forward(p).expect("every screen point is covered");
                let q = v.inverse(s).unwrap();
                assert!(q.distance(p) < 1e-6, "({gx},{gy}) {p:?} -> {s:?} -> {q:?}");
            }
        }
    }

    #[test]
    fn shaded_runs_by_arcs_equal_marking_every_angle() {
        // The runs found from the rays' spans, a run of crossing angles marked at once, are
        // exactly those of clipping and marking every angle on its own, column by column, at
        // gazes in the middle, at and beyond the corners and edges.
        let small = DisplayProfile::with_vertical_fov("small", 320, 200, Degrees(100.0)).unwrap();
        let vive = DisplayProfile::preset("vive-pro-eye").unwrap();
        for d in [small, vive] {
            let (w, h) = (d.width_px as f64, d.height_px as f64);
            for (fx, fy) in [
                (0.5, 0.5),
                (0.0, 0.0),
                (1.0, 1.0),
                (1.0, 0.0),
                (0.13, 0.77),
                (-0.05, 0.4),
                (0.6, 1.04),
            ] {
                let g = d.gaze(fx * w, fy * h).unwrap();
                let v = Vafr::new(&d, g, exact()).unwrap();
                let x = v.exact.as_ref().unwrap();
                let runs = v.runs.as_ref().unwrap();
                let mut checked = 0;
                for (i, &rows) in v.rows.iter().enumerate() {
                    let want =
                        x.profile
                            .shaded_runs_per_angle(&d, &g, i as u32, rows, v.periods[i]);
                    assert_eq!(runs[i], want, "{} gaze ({fx},{fy}) column {i}", d.name);
                    checked += rows as usize;
                }
                assert!(checked > 1000, "{checked}");
            }
        }
    }

    #[test]
    fn exact_rings_skip_only_texels_off_the_screen() {
        // Brute force on a small display: every texel the bilinear lookup of an on-screen
        // pixel reads is shaded, and every shaded texel lies within a few pixels of the screen.
        let d = DisplayProfile::with_vertical_fov("small", 320, 200, Degrees(100.0)).unwrap();
        for (gx, gy) in [(0.0, 0.0), (160.0, 100.0), (319.0, 30.0), (-10.0, 210.0)] {
            let g = d.gaze(gx, gy).unwrap();
            let v = Vafr::new(&d, g, exact()).unwrap();
            let layout = v.polar_layout().unwrap();
            for y in 0..200 {
                for x in 0..320 {
                    let s = v
                        .forward(ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5))
                        .unwrap();
                    let i0 = (s.u - 0.5).floor() as i64;
                    for i in [i0, i0 + 1] {
                        let Some(&rows) = (i >= 0).then(|| layout.rows.get(i as usize)).flatten()
                        else {
                            continue;
                        };
                        if rows == 0 {
                            continue;
                        }
                        let turn = s.v / v.period_at_u(s.u);
                        let j0 = (turn * layout.period[i as usize] - 0.5).floor() as i64;
                        for j in [j0, j0 + 1] {
                            let j = j.rem_euclid(rows as i64) as u32;
                            assert!(
                                v.is_shaded(0, i as u32, j),
                                "({gx},{gy}) px ({x},{y}) texel ({i},{j})"
                            );
                        }
                    }
                }
            }
            let mut far = 0;
            for (i, &rows) in layout.rows.iter().enumerate() {
                for j in 0..rows {
                    if v.is_shaded(0, i as u32, j) {
                        let p = v
                            .inverse(SamplePoint::new(i as f64 + 0.5, j as f64 + 0.5))
                            .unwrap();
                        let out = (-p.x_px)
                            .max(p.x_px - 320.0)
                            .max(-p.y_px)
                            .max(p.y_px - 200.0);
                        far += (out > 30.0) as usize;
                    }
                }
            }
            assert_eq!(far, 0, "({gx},{gy}): shaded texels far off the screen");
        }
    }

    fn any_gaze() -> VafrParams {
        VafrParams {
            rings: VafrRings::Eq3AnyGaze,
            ..VafrParams::default()
        }
    }

    /// The 7×7 gaze grid of the coverage tests (`fovea-post/tests/coverage.rs`): corners,
    /// edges and five steps between.
    fn gaze_grid(d: &DisplayProfile) -> Vec<Gaze> {
        let (w, h) = (d.width_px as f64, d.height_px as f64);
        (0..49)
            .map(|k| {
                d.gaze(w * (k % 7) as f64 / 6.0, h * (k / 7) as f64 / 6.0)
                    .unwrap()
            })
            .collect()
    }

    #[test]
    fn any_gaze_layout_is_the_same_at_every_gaze_on_the_screen() {
        // Bit for bit: buffers, rows, periods and parameters; u(r) about the pole too (to
        // the rounding of a point's radius from the pole); the
        // buffer reaches the diagonal (the corner gazes' farthest corner) and is Eq. 3's
        // there; a gaze off the screen beyond the diagonal grows it.
        for name in ["vive-pro-eye", "8k"] {
            let d = DisplayProfile::preset(name).unwrap();
            let first = Vafr::new(&d, d.gaze(0.0, 0.0).unwrap(), any_gaze()).unwrap();
            let corner = Vafr::new(&d, d.gaze(0.0, 0.0).unwrap(), VafrParams::eq3()).unwrap();
            assert_eq!(first.buffers(), corner.buffers(), "{name}");
            assert!(first.layout_is_gaze_free());
            let l0 = first.polar_layout().unwrap();
            for g in gaze_grid(&d) {
                let v = Vafr::new(&d, g, any_gaze()).unwrap();
                let l = v.polar_layout().unwrap();
                assert_eq!(v.buffers(), first.buffers(), "{name} {g:?}");
                assert_eq!((&l.rows, &l.period), (&l0.rows, &l0.period), "{name} {g:?}");
                assert_eq!(v.params(), first.params());
                for k in 0..50 {
                    let r = k as f64 * 37.3;
                    let p = ScreenPoint::new(g.point.x_px + r, g.point.y_px);
                    let q = ScreenPoint::new(r, 0.0);
                    // The same u to the rounding of the radius (p's x less the pole's).
                    let (a, b) = (v.forward(p).unwrap().u, first.forward(q).unwrap().u);
                    assert!((a - b).abs() <= 1e-12 * b.max(1.0), "{name} r {r}: {a} {b}");
                }
                // Fewer shaded than the buffer's texels, more than the screen needs.
                assert!(v.sample_count() < v.buffers()[0].pixels());
            }
            let (w, h) = (d.width_px as f64, d.height_px as f64);
            let off = Vafr::new(&d, d.gaze(-0.05 * w, -0.05 * h).unwrap(), any_gaze()).unwrap();
            assert!(off.buffers()[0].width > first.buffers()[0].width);
        }
        // The exact rings' layout follows the gaze.
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        assert!(!Vafr::new(&d, d.centre_gaze(), exact())
            .unwrap()
            .layout_is_gaze_free());
    }

    #[test]
    fn any_gaze_forward_and_inverse_are_eq3s_and_inverse() {
        // Every screen point maps where Eq. 3 (with its own coverage) maps it, and back.
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        for (gx, gy) in [
            (101.0, 100.0),
            (1100.0, 1200.0),
            (-30.0, 800.0),
            (720.0, 800.0),
        ] {
            let g = d.gaze(gx, gy).unwrap();
            let v = Vafr::new(&d, g, any_gaze()).unwrap();
            let q3 = Vafr::new(&d, g, VafrParams::eq3()).unwrap();
            for k in 0..500 {
                let p =
                    ScreenPoint::new((k * 37 % 1440) as f64 + 0.3, (k * 91 % 1600) as f64 + 0.7);
                let s = v.forward(p).expect("every screen point is covered");
                assert_eq!(Some(s), q3.forward(p), "({gx},{gy}) {p:?}");
                let q = v.inverse(s).unwrap();
                assert!(q.distance(p) < 1e-6, "({gx},{gy}) {p:?} -> {s:?} -> {q:?}");
            }
        }
    }

    #[test]
    fn any_gaze_runs_are_listed_as_is_shaded_answers() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        for (gx, gy) in [(0.0, 0.0), (720.0, 800.0), (1300.0, 200.0)] {
            for p in [any_gaze(), exact(), VafrParams::eq3()] {
                let v = Vafr::new(&d, d.gaze(gx, gy).unwrap(), p).unwrap();
                let b = v.buffers()[0];
                let mut listed = 0u64;
                for i in 0..b.width {
                    let mut runs = Vec::new();
                    assert!(v.append_shaded_runs(0, i, &mut runs));
                    for w in runs.windows(2) {
                        assert!(w[0].1 < w[1].0);
                    }
                    for j in 0..b.height {
                        let listed_j = runs.iter().any(|&(a, e)| j >= a && j < e);
                        assert_eq!(listed_j, v.is_shaded(0, i, j), "({gx},{gy}) ({i},{j})");
                        listed += listed_j as u64;
                    }
                }
                assert_eq!(listed, v.sample_count());
            }
        }
    }

    #[test]
    fn any_gaze_skips_only_texels_off_the_screen() {
        // Brute force on a small display and at the Vive Pro Eye: every texel the bilinear
        // lookup of an on-screen pixel reads is shaded; every texel whose centre is on the
        // screen is shaded; and a shaded texel's centre lies within its column's margin
        // (2 px, one texel radially and the dilated rows along the ring: 2 px + 3 radial
        // spacings + 4 + 2·dilate row spacings) of the screen.
        let small = DisplayProfile::with_vertical_fov("small", 320, 200, Degrees(100.0)).unwrap();
        let vive = DisplayProfile::preset("vive-pro-eye").unwrap();
        for (d, stride) in [(small, 1), (vive, 7)] {
            let (w, h) = (d.width_px, d.height_px);
            let (wf, hf) = (w as f64, h as f64);
            for (fx, fy) in [(0.0, 0.0), (0.5, 0.5), (0.997, 0.15), (-0.03, 1.05)] {
                let g = d.gaze(fx * wf, fy * hf).unwrap();
                let v = Vafr::new(&d, g, any_gaze()).unwrap();
                let layout = v.polar_layout().unwrap();
                for y in (0..h).step_by(stride) {
                    for x in (0..w).step_by(stride) {
                        let s = v
                            .forward(ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5))
                            .unwrap();
                        let i0 = (s.u - 0.5).floor() as i64;
                        for i in [i0, i0 + 1] {
                            let Some(&rows) =
                                (i >= 0).then(|| layout.rows.get(i as usize)).flatten()
                            else {
                                continue;
                            };
                            if rows == 0 {
                                continue;
                            }
                            let turn = s.v / v.period_at_u(s.u);
                            let j0 = (turn * layout.period[i as usize] - 0.5).floor() as i64;
                            for j in [j0, j0 + 1] {
                                let j = j.rem_euclid(rows as i64) as u32;
                                assert!(
                                    v.is_shaded(0, i as u32, j),
                                    "{} ({fx},{fy}) px ({x},{y}) texel ({i},{j})",
                                    d.name
                                );
                            }
                        }
                    }
                }
                let r_of = |u: f64| v.ring(0, u.clamp(0.0, v.u_max())).unwrap().r_px;
                let mut shaded = 0u64;
                for (i, &rows) in layout.rows.iter().enumerate() {
                    let period = layout.period[i];
                    let u = i as f64 + 0.5;
                    let radial = r_of(u + 1.0) - r_of(u - 1.0);
                    let r_lo = (r_of(u - 1.5) - 2.0).max(1.0);
                    let dilate = 1.0 + (2.0 * period / (std::f64::consts::TAU * r_lo)).ceil();
                    let spacing = std::f64::consts::TAU * (r_of(u) + radial + 2.0) / period;
                    let bound = 2.0 + 3.0 * radial + (4.0 + 2.0 * dilate) * spacing;
                    for j in 0..rows {
                        let p = v.inverse(SamplePoint::new(u, j as f64 + 0.5)).unwrap();
                        let out = (-p.x_px).max(p.x_px - wf).max(-p.y_px).max(p.y_px - hf);
                        let on = v.is_shaded(0, i as u32, j);
                        shaded += on as u64;
                        if out <= 0.0 {
                            assert!(on, "{} ({fx},{fy}) texel ({i},{j}) on screen", d.name);
                        }
                        if on {
                            assert!(
                                out <= bound,
                                "{} ({fx},{fy}) texel ({i},{j}) {out:.1} px off (bound {bound:.1})",
                                d.name
                            );
                        }
                    }
                }
                assert_eq!(shaded, v.sample_count());
            }
        }
    }
}
