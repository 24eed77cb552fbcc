//! Sparse foveated ray sampling of Weier et al. 2018 (Sec. 3.1, Eq. 1–2).
//!
//! A pixel is ray-cast when its bit is set in one of two binary tables:
//! * `S_in`, centred on the point of regard and moving with it, covers angular distance
//!   `d < r₁`: every pixel with `d < r₀` is set; in the transition `r₀ ≤ d < r₁` samples are
//!   placed by importance sampling in polar coordinates, Eq. 1
//!   `r = r₀ + (r₁ − r₀)·(√((p_min² − 1)·u + 1) − 1)/(p_min − 1)` and Eq. 2 `φ = 2πv`, with
//!   `(u, v)` from a low-discrepancy (Halton 2,3) sequence. Eq. 1 inverts the density
//!   `f(x) = 1 − x·(1 − p_min)` over the normalised radius `x`; it has no `r` Jacobian, so per
//!   unit *area* it concentrates samples towards `r₀` (near `r₀` it asks for more than one
//!   sample per pixel). The number of transition samples is the acuity model's expectation
//!   `Σ_{pixels in the ring} f(x)`; draws continue until that many distinct pixels are set.
//!   [`RadialDensity::AreaCorrected`] instead sets each ring pixel whose R2-lattice dither
//!   value is below `f(x)`, so the per-pixel probability is exactly the acuity model's.
//! * `S_out`, static in screen space, marks a uniform pattern of density `p_min`
//!   (an R2-lattice dither, so any window of the screen gets `p_min` of its pixels).
//!
//! Sample space is screen space: forward and inverse are the identity on shaded pixels.

use serde::{Deserialize, Serialize};

use super::{screen_rate_cpd, BufferSize, FoveationMapping, Method, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::error::{check_range, FoveaError, Result};
use crate::math::{halton2, unit_from_seed};
use crate::units::{Degrees, ScreenPoint};

/// How the transition radius is distributed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RadialDensity {
    /// Eq. 1 as printed (radial density `f`, no area Jacobian).
    PaperEq1,
    /// Per-pixel probability `f` (ordered R2 dither against the acuity probability).
    AreaCorrected,
}

/// Parameters of Weier's sparse sampling.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WeierParams {
    /// Radius of full sampling, degrees (10°).
    pub r0: Degrees,
    /// Outer radius of the transition, degrees (20°).
    pub r1: Degrees,
    /// Peripheral sampling probability (0.2).
    pub p_min: f64,
    /// Seed of the Halton rotation and the S_out dither.
    pub seed: u64,
    /// Radial distribution in the transition.
    pub radial: RadialDensity,
}

impl Default for WeierParams {
    fn default() -> Self {
        Self {
            r0: Degrees(10.0),
            r1: Degrees(20.0),
            p_min: 0.2,
            seed: 0,
            radial: RadialDensity::PaperEq1,
        }
    }
}

/// R2-lattice constants (powers of the inverse plastic number).
const R2_A1: f64 = 0.754_877_666_246_693;
const R2_A2: f64 = 0.569_840_290_998_053;

/// Weier's sparse sampling for one display and gaze.
pub struct WeierSparse {
    params: WeierParams,
    width: u32,
    height: u32,
    c_r: f64,
    anchor: (i64, i64),
    /// Half-size of S_in in pixels; S_in is `(2R+1)²`.
    half: i64,
    s_in: Vec<bool>,
    r0_px: f64,
    r1_px: f64,
    transition_target: u64,
    out_shift: f64,
    count: u64,
}

impl WeierSparse {
    /// Builds the tables. `r0 < r1` in (0, 60]°, `p_min` in (0, 1].
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: WeierParams) -> Result<Self> {
        display.validate()?;
        check_range("r0", params.r0.0, 0.0, 60.0)?;
        check_range("r1", params.r1.0, 0.0, 60.0)?;
        if params.r1.0 <= params.r0.0 {
            return Err(FoveaError::invalid(
                "r1",
                params.r1.0,
                format!("an angle greater than r0 = {}°", params.r0.0),
            ));
        }
        crate::error::check_range_open_lo("p_min", params.p_min, 0.0, 1.0)?;
        let c_r = display.c_r();
        let r0_px = params.r0.to_radians().tan() / c_r;
        let r1_px = params.r1.to_radians().tan() / c_r;
        let half = r1_px.ceil() as i64 + 1;
        let side = (2 * half + 1) as usize;
        let mut s_in = vec![false; side * side];
        let mut target = 0.0;
        for dy in -half..=half {
            for dx in -half..=half {
                let d_px = (dx as f64).hypot(dy as f64);
                let idx = (dy + half) as usize * side + (dx + half) as usize;
                if d_px < r0_px {
                    s_in[idx] = true;
                } else if d_px < r1_px {
                    target += acuity_probability(&params, px_to_deg(c_r, d_px));
                }
            }
        }
        let transition_target = target.round() as u64;
        let out_shift = unit_from_seed(params.seed.wrapping_add(7));
        if params.radial == RadialDensity::AreaCorrected {
            for dy in -half..=half {
                for dx in -half..=half {
                    let d_px = (dx as f64).hypot(dy as f64);
                    if d_px >= r0_px && d_px < r1_px {
                        let p = acuity_probability(&params, px_to_deg(c_r, d_px));
                        let x = out_shift + 0.5 + dx as f64 * R2_A1 + dy as f64 * R2_A2;
                        if x - x.floor() < p {
                            s_in[(dy + half) as usize * side + (dx + half) as usize] = true;
                        }
                    }
                }
            }
        }
        let shift = halton_shift(params.seed);
        let mut set = 0u64;
        let max_draws = 64 * transition_target + 1024;
        let mut index = 1u64;
        while params.radial == RadialDensity::PaperEq1
            && set < transition_target
            && index <= max_draws
        {
            let (u, v) = halton2(index, shift);
            index += 1;
            let r_deg = transition_radius(&params, u);
            let r_px = r_deg.to_radians().tan() / c_r;
            let phi = std::f64::consts::TAU * v; // Eq. 2
            let (dx, dy) = (
                (r_px * phi.cos()).round() as i64,
                (r_px * phi.sin()).round() as i64,
            );
            let d_px = (dx as f64).hypot(dy as f64);
            if d_px < r0_px || d_px >= r1_px || dx.abs() > half || dy.abs() > half {
                continue;
            }
            let idx = (dy + half) as usize * side + (dx + half) as usize;
            if !s_in[idx] {
                s_in[idx] = true;
                set += 1;
            }
        }
        let mut m = Self {
            params,
            width: display.width_px,
            height: display.height_px,
            c_r,
            anchor: (
                gaze.point.x_px.floor() as i64,
                gaze.point.y_px.floor() as i64,
            ),
            half,
            s_in,
            r0_px,
            r1_px,
            transition_target,
            out_shift,
            count: 0,
        };
        m.count = (0..m.height)
            .map(|j| (0..m.width).filter(|&i| m.selected(i, j)).count() as u64)
            .sum();
        Ok(m)
    }

    /// Whether screen pixel `(i, j)` is ray-cast.
    pub fn selected(&self, i: u32, j: u32) -> bool {
        let (dx, dy) = (i as i64 - self.anchor.0, j as i64 - self.anchor.1);
        let d2 = (dx * dx + dy * dy) as f64;
        if d2 < self.r1_px * self.r1_px {
            self.s_in_bit(dx, dy)
        } else {
            self.s_out_bit(i, j)
        }
    }

    /// `S_in` at pixel offset `(dx, dy)` from the point of regard.
    pub fn s_in_bit(&self, dx: i64, dy: i64) -> bool {
        if dx.abs() > self.half || dy.abs() > self.half {
            return false;
        }
        let side = (2 * self.half + 1) as usize;
        self.s_in[(dy + self.half) as usize * side + (dx + self.half) as usize]
    }

    /// `S_out` at screen pixel `(i, j)`: set with density `p_min`.
    pub fn s_out_bit(&self, i: u32, j: u32) -> bool {
        let x = self.out_shift + i as f64 * R2_A1 + j as f64 * R2_A2;
        x - x.floor() < self.params.p_min
    }

    /// Side of the square `S_in` table in pixels.
    pub fn s_in_side(&self) -> u32 {
        (2 * self.half + 1) as u32
    }

    /// Transition samples the acuity model asks for (`Σ f` over the ring's pixels).
    pub fn transition_target(&self) -> u64 {
        self.transition_target
    }

    /// The radii in degrees of the first `n` transition draws (before de-duplication), for
    /// checking the distribution of Eq. 1.
    pub fn transition_draws_deg(&self, n: usize) -> Vec<f64> {
        let shift = halton_shift(self.params.seed);
        (1..=n as u64)
            .map(|i| transition_radius(&self.params, halton2(i, shift).0))
            .collect()
    }

    /// Expected fraction of shaded pixels at angular distance `d_deg` from the gaze.
    pub fn density(&self, d_deg: f64) -> f64 {
        let p = &self.params;
        if d_deg < p.r0.0 {
            1.0
        } else if d_deg >= p.r1.0 {
            p.p_min
        } else {
            match p.radial {
                RadialDensity::AreaCorrected => acuity_probability(p, d_deg),
                RadialDensity::PaperEq1 => {
                    let span = p.r1.0 - p.r0.0;
                    let x = (d_deg - p.r0.0) / span;
                    let pdf_deg = (1.0 - x * (1.0 - p.p_min)) / ((1.0 + p.p_min) / 2.0) / span;
                    let rho = d_deg.to_radians().tan() / self.c_r;
                    let deg_per_px = px_to_deg_derivative(self.c_r, rho);
                    let per_px2 = self.transition_target as f64 * pdf_deg * deg_per_px
                        / (std::f64::consts::TAU * rho);
                    per_px2.min(1.0)
                }
            }
        }
    }

    /// Inner and outer radius in pixels.
    pub fn radii_px(&self) -> (f64, f64) {
        (self.r0_px, self.r1_px)
    }

    /// The pixel `S_in` is centred on: the point of regard, floored.
    pub fn anchor_px(&self) -> (i64, i64) {
        self.anchor
    }

    /// Half the side of `S_in`, pixels: `S_in` holds offsets up to `±half` both ways.
    pub fn s_in_half(&self) -> i64 {
        self.half
    }

    /// The parameters the tables were built from.
    pub fn sparse_params(&self) -> WeierParams {
        self.params
    }

    /// The screen the pattern covers, pixels.
    pub fn screen_px(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}

/// Weier's acuity probability: 1 inside r₀, linear to `p_min` at r₁, `p_min` beyond.
pub fn acuity_probability(p: &WeierParams, d_deg: f64) -> f64 {
    if d_deg < p.r0.0 {
        1.0
    } else if d_deg >= p.r1.0 {
        p.p_min
    } else {
        let x = (d_deg - p.r0.0) / (p.r1.0 - p.r0.0);
        1.0 - x * (1.0 - p.p_min)
    }
}

/// Transition radius in degrees for uniform `u` (Eq. 1, or its area-corrected variant).
pub fn transition_radius(p: &WeierParams, u: f64) -> f64 {
    let (r0, r1, pm) = (p.r0.0, p.r1.0, p.p_min);
    let x = match p.radial {
        RadialDensity::PaperEq1 => {
            if (pm - 1.0).abs() < 1e-12 {
                u
            } else {
                (((pm * pm - 1.0) * u + 1.0).sqrt() - 1.0) / (pm - 1.0)
            }
        }
        RadialDensity::AreaCorrected => {
            // Draws with radial density f(x)·r (the area-correct importance sampling; the
            // tables use a per-pixel dither in this mode, these draws are for analysis).
            // CDF of f(x)·(r0 + x·span) on [0, 1], inverted by bisection.
            let span = r1 - r0;
            let k = 1.0 - pm;
            let cdf = |x: f64| {
                // ∫ (1 − kx)(r0 + span·x) dx
                r0 * x + (span - k * r0) * x * x / 2.0 - k * span * x * x * x / 3.0
            };
            let total = cdf(1.0);
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if cdf(mid) < u * total {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        }
    };
    r0 + (r1 - r0) * x
}

/// Cranley–Patterson rotation of the transition's Halton sequence for `seed`.
fn halton_shift(seed: u64) -> (f64, f64) {
    (unit_from_seed(seed), unit_from_seed(seed ^ 0xA5A5_A5A5))
}

fn px_to_deg(c_r: f64, r_px: f64) -> f64 {
    (c_r * r_px).atan().to_degrees()
}

/// `d(deg)/d(px)` at radius `r_px` (VaFR Eq. 7).
fn px_to_deg_derivative(c_r: f64, r_px: f64) -> f64 {
    c_r / (1.0 + (c_r * r_px).powi(2)) * 180.0 / std::f64::consts::PI
}

impl FoveationMapping for WeierSparse {
    fn method(&self) -> Method {
        Method::Weier
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "r0_deg": self.params.r0.0, "r1_deg": self.params.r1.0,
            "p_min": self.params.p_min, "seed": self.params.seed,
            "radial": match self.params.radial {
                RadialDensity::PaperEq1 => "paper-eq1",
                RadialDensity::AreaCorrected => "area-corrected",
            },
        })
    }
    fn buffers(&self) -> Vec<BufferSize> {
        vec![BufferSize {
            width: self.width,
            height: self.height,
        }]
    }
    fn sample_count(&self) -> u64 {
        self.count
    }
    fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
        layer == 0 && i < self.width && j < self.height && self.selected(i, j)
    }
    fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
        if !(p.x_px >= 0.0 && p.y_px >= 0.0) {
            return None;
        }
        let (i, j) = (p.x_px.floor() as u32, p.y_px.floor() as u32);
        self.is_shaded(0, i, j)
            .then_some(SamplePoint::new(p.x_px, p.y_px))
    }
    fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
        if s.layer != 0 || !(s.u >= 0.0 && s.v >= 0.0) {
            return None;
        }
        self.is_shaded(0, s.u.floor() as u32, s.v.floor() as u32)
            .then_some(ScreenPoint::new(s.u, s.v))
    }
    fn radial_rate_cpd(&self, e_deg: f64) -> f64 {
        screen_rate_cpd(self.c_r, e_deg) * self.density(e_deg).sqrt()
    }
    fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
        self.radial_rate_cpd(e_deg)
    }
    fn weier_sparse(&self) -> Option<&WeierSparse> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fove() -> DisplayProfile {
        // Weier et al.'s FOVE 0: 1280×1440 per eye.
        DisplayProfile::with_vertical_fov("fove", 1280, 1440, Degrees(100.0)).unwrap()
    }

    #[test]
    fn eq1_draws_follow_their_density() {
        // Chi-square of the first 20,000 draws against Eq. 1's CDF in 10 equal-width bins.
        let d = fove();
        let m = WeierSparse::new(&d, d.centre_gaze(), WeierParams::default()).unwrap();
        let p = WeierParams::default();
        let n = 20_000;
        let draws = m.transition_draws_deg(n);
        let cdf = |r: f64| {
            let x = (r - p.r0.0) / (p.r1.0 - p.r0.0);
            (x - x * x * (1.0 - p.p_min) / 2.0) / ((1.0 + p.p_min) / 2.0)
        };
        let bins = 10;
        let mut counts = vec![0f64; bins];
        for r in &draws {
            let b = (((r - 10.0) / 10.0) * bins as f64).floor() as usize;
            counts[b.min(bins - 1)] += 1.0;
        }
        let mut chi2 = 0.0;
        for (b, c) in counts.iter().enumerate() {
            let lo = 10.0 + b as f64;
            let e = n as f64 * (cdf(lo + 1.0) - cdf(lo));
            chi2 += (c - e) * (c - e) / e;
        }
        // 9 degrees of freedom: 21.67 is the 1 % critical value.
        assert!(chi2 < 21.67, "chi2 = {chi2}, counts {counts:?}");
    }

    #[test]
    fn area_corrected_pixels_follow_acuity_probability() {
        let d = fove();
        let p = WeierParams {
            radial: RadialDensity::AreaCorrected,
            ..Default::default()
        };
        let m = WeierSparse::new(&d, d.centre_gaze(), p).unwrap();
        // Fraction of set S_in pixels per annulus of 2° against f at the annulus centre.
        let half = m.half;
        for k in 0..5 {
            let (lo, hi) = (10.0 + 2.0 * k as f64, 12.0 + 2.0 * k as f64);
            let (mut set, mut all) = (0.0, 0.0);
            for dy in -half..=half {
                for dx in -half..=half {
                    let deg = px_to_deg(m.c_r, (dx as f64).hypot(dy as f64));
                    if deg >= lo && deg < hi {
                        all += 1.0;
                        if m.s_in_bit(dx, dy) {
                            set += 1.0;
                        }
                    }
                }
            }
            let want = acuity_probability(&p, (lo + hi) / 2.0);
            assert!(
                (set / all - want).abs() < 0.04,
                "{lo}-{hi}°: {} vs {want}",
                set / all
            );
        }
    }

    #[test]
    fn periphery_density_is_p_min() {
        let d = fove();
        let m =
            WeierSparse::new(&d, d.gaze(100.0, 100.0).unwrap(), WeierParams::default()).unwrap();
        let mut n = 0;
        for j in 1000..1400 {
            for i in 800..1200 {
                n += m.s_out_bit(i, j) as u32;
            }
        }
        let frac = n as f64 / 160_000.0;
        assert!((frac - 0.2).abs() < 0.002, "{frac}");
    }

    #[test]
    fn bad_radii_are_rejected() {
        let d = fove();
        let p = WeierParams {
            r0: Degrees(20.0),
            r1: Degrees(10.0),
            ..Default::default()
        };
        let e = WeierSparse::new(&d, d.centre_gaze(), p).err().unwrap();
        assert!(e.to_string().contains("r1"));
    }
}
