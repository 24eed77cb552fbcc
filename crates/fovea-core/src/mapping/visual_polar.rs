//! Visual-polar sampling of Liu, Mantel and Forchhammer (hybrid foveated DOF, Sec. 3.1,
//! Eq. 1–3).
//!
//! Samples are distributed over eccentricity `α` by the PDF of Eq. 1, `g(α) = 2πα` for
//! `α ≤ α_F = 5.79°` and `14.98πα/(0.3α + 1)²` beyond, whose CDF (Eq. 2) is
//! `G(α) = πα²` in the fovea and `A·(1/(0.3α+1) + ln(0.3α+1)) − C` beyond, with
//! `A = 14.98π/0.3² ≈ 166.4π` and `C ≈ 612.3` fixed by continuity at `α_F`. The polar buffer
//! column is `u = w·G(α)/G(α_M)` and the row `v = h·φ/360°`; every buffer pixel is shaded.
//!
//! The exact inverse of Eq. 2 exists: with `y = (G + C)/A` and `t = 1/(0.3α + 1)`,
//! `t − ln t = y`, so `t = −W₀(−e^{−y})` (Lambert W). The paper instead inverts with the
//! least-squares polynomial of Eq. 3, `α(ρ) = 25.09ρ⁴ + 0.1680ρ³ + 27.61ρ² + 23.87ρ + 3.232`
//! on the normalised CDF `ρ` (it reaches 79.97° at ρ = 1 and 5.79° at ρ_F = G(5.79)/G(80), so
//! it was fitted for `α_M = 80°`), and maps the fovea linearly. [`VisualPolarInverse::PaperFit`]
//! selects it; [`fit_error`] reports how far it is from the exact inverse.

use serde::{Deserialize, Serialize};

use super::{
    polar_deg, tangential_denominator, BufferSize, Coverage, FoveationMapping, Method, SamplePoint,
    MAX_COVERAGE_DEG,
};
use crate::display::{eccentricity_deg, DisplayProfile, Gaze};
use crate::error::{check_range_open_lo, FoveaError, Result};
use crate::math::lambert_w0;
use crate::units::ScreenPoint;

/// Foveal boundary of Eq. 1, degrees.
pub const FOVEA_DEG: f64 = 5.79;
/// Coefficient of Eq. 1's peripheral PDF (`14.98π·α/(0.3α+1)²`).
const PDF_COEFF: f64 = 14.98;
/// The eccentricity range the paper's polynomial (Eq. 3) was fitted for.
pub const FIT_MAX_ECCENTRICITY_DEG: f64 = 80.0;
/// Eq. 3's coefficients, highest power first.
pub const EQ3_COEFFS: [f64; 5] = [25.09, 0.1680, 27.61, 23.87, 3.232];

/// Which inverse CDF maps buffer columns back to eccentricity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VisualPolarInverse {
    /// The exact inverse of Eq. 2 (Lambert W) and `√(G/π)` in the fovea.
    Exact,
    /// The paper's polynomial (Eq. 3) beyond the fovea and a linear map inside it; the forward
    /// map is the polynomial's inverse so the mapping stays a bijection.
    PaperFit,
}

/// Parameters of visual-polar sampling.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisualPolarParams {
    /// Polar buffer size; `None` = the display resolution (Liu's Algorithm 1 transforms the
    /// G-buffer into a P-buffer of the same size).
    pub buffer: Option<BufferSize>,
    /// Largest eccentricity `α_M` the buffer covers: by default the farthest screen corner
    /// from the gaze, so every pixel has samples at every gaze; the paper normalises to a fixed
    /// 80° (see module docs), and its polynomial inverse always uses 80°. Screen points beyond
    /// `α_M` have no sample.
    pub max_eccentricity: Coverage,
    /// Inverse CDF used.
    pub inverse: VisualPolarInverse,
}

impl Default for VisualPolarParams {
    fn default() -> Self {
        Self {
            buffer: None,
            max_eccentricity: Coverage::Screen,
            inverse: VisualPolarInverse::Exact,
        }
    }
}

/// Eq. 2's constants: `A` and `C` (exact, from Eq. 1 and continuity at α_F).
pub fn cdf_constants() -> (f64, f64) {
    let a = PDF_COEFF * std::f64::consts::PI / 0.09;
    let x_f = 0.3 * FOVEA_DEG + 1.0;
    let c = a * (1.0 / x_f + x_f.ln()) - std::f64::consts::PI * FOVEA_DEG * FOVEA_DEG;
    (a, c)
}

/// Eq. 1, the PDF over eccentricity (per degree).
pub fn pdf(alpha_deg: f64) -> f64 {
    if alpha_deg <= FOVEA_DEG {
        2.0 * std::f64::consts::PI * alpha_deg
    } else {
        let x = 0.3 * alpha_deg + 1.0;
        PDF_COEFF * std::f64::consts::PI * alpha_deg / (x * x)
    }
}

/// Eq. 2, the CDF `G(α)` (continuous at α_F).
pub fn cdf(alpha_deg: f64) -> f64 {
    let alpha = alpha_deg.max(0.0);
    if alpha <= FOVEA_DEG {
        std::f64::consts::PI * alpha * alpha
    } else {
        let (a, c) = cdf_constants();
        let x = 0.3 * alpha + 1.0;
        a * (1.0 / x + x.ln()) - c
    }
}

/// Exact inverse of [`cdf`] (Lambert W beyond the fovea).
pub fn inverse_cdf(g: f64) -> f64 {
    let g = g.max(0.0);
    let g_f = std::f64::consts::PI * FOVEA_DEG * FOVEA_DEG;
    if g <= g_f {
        (g / std::f64::consts::PI).sqrt()
    } else {
        let (a, c) = cdf_constants();
        let y = (g + c) / a;
        let t = -lambert_w0(-(-y).exp());
        (1.0 / t - 1.0) / 0.3
    }
}

/// Eq. 3 evaluated at normalised CDF `rho`.
pub fn eq3(rho: f64) -> f64 {
    EQ3_COEFFS.iter().fold(0.0, |acc, c| acc * rho + c)
}

fn eq3_derivative(rho: f64) -> f64 {
    let c = EQ3_COEFFS;
    ((4.0 * c[0] * rho + 3.0 * c[1]) * rho + 2.0 * c[2]) * rho + c[3]
}

/// Normalised CDF of the foveal boundary for α_M = 80°.
pub fn rho_fovea() -> f64 {
    cdf(FOVEA_DEG) / cdf(FIT_MAX_ECCENTRICITY_DEG)
}

/// The paper's inverse: linear in the fovea, Eq. 3 beyond.
pub fn paper_inverse(rho: f64) -> f64 {
    let rf = rho_fovea();
    if rho <= rf {
        FOVEA_DEG * rho / rf
    } else {
        eq3(rho)
    }
}

/// How far Eq. 3 is from the exact inverse over `ρ ∈ [ρ_F, 1]` at α_M = 80°.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitError {
    /// Largest |α_fit − α_exact|, degrees.
    pub max_abs_deg: f64,
    /// Where it occurs (normalised CDF).
    pub at_rho: f64,
    /// Root-mean-square error over a uniform grid in ρ, degrees.
    pub rms_deg: f64,
    /// Eq. 3 at ρ = 1 (the exact inverse gives 80°).
    pub at_one_deg: f64,
}

/// Compares Eq. 3 with the exact inverse on 10,001 points of `[ρ_F, 1]`.
pub fn fit_error() -> FitError {
    let g_m = cdf(FIT_MAX_ECCENTRICITY_DEG);
    let rf = rho_fovea();
    let n = 10_000;
    let (mut max, mut at, mut sq) = (0.0f64, rf, 0.0);
    for i in 0..=n {
        let rho = rf + (1.0 - rf) * i as f64 / n as f64;
        let d = eq3(rho) - inverse_cdf(rho * g_m);
        if d.abs() > max {
            max = d.abs();
            at = rho;
        }
        sq += d * d;
    }
    FitError {
        max_abs_deg: max,
        at_rho: at,
        rms_deg: (sq / (n + 1) as f64).sqrt(),
        at_one_deg: eq3(1.0),
    }
}

/// The visual-polar mapping for one display and gaze.
#[derive(Clone, Debug)]
pub struct VisualPolar {
    params: VisualPolarParams,
    buffer: BufferSize,
    c_r: f64,
    gaze: ScreenPoint,
    /// The resolved `α_M`, degrees.
    alpha_max: f64,
    g_max: f64,
}

impl VisualPolar {
    /// Builds the mapping. `PaperFit` needs `max_eccentricity` = 80° (or [`Coverage::Screen`],
    /// which it reads as 80°), the range Eq. 3 fits.
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: VisualPolarParams) -> Result<Self> {
        display.validate()?;
        let alpha_max = match (params.max_eccentricity, params.inverse) {
            (Coverage::Fixed(e), inverse) => {
                check_range_open_lo("max_eccentricity", e.0, FOVEA_DEG, MAX_COVERAGE_DEG)?;
                if inverse == VisualPolarInverse::PaperFit && e.0 != FIT_MAX_ECCENTRICITY_DEG {
                    return Err(FoveaError::invalid(
                        "max_eccentricity",
                        e.0,
                        "80 with the paper's polynomial inverse (Eq. 3 was fitted for α_M = 80°)",
                    ));
                }
                e.0
            }
            (Coverage::Screen, VisualPolarInverse::PaperFit) => FIT_MAX_ECCENTRICITY_DEG,
            // At least just beyond the fovea, so the peripheral branch of Eq. 1 exists.
            (Coverage::Screen, VisualPolarInverse::Exact) => params
                .max_eccentricity
                .resolve(display, &gaze)
                .max(FOVEA_DEG + 0.01),
        };
        let buffer = params.buffer.unwrap_or(BufferSize {
            width: display.width_px,
            height: display.height_px,
        });
        if buffer.width == 0
            || buffer.height == 0
            || buffer.width > 65_536
            || buffer.height > 65_536
        {
            return Err(FoveaError::invalid(
                "buffer",
                format!("{}x{}", buffer.width, buffer.height),
                "a polar buffer of 1..65536 pixels on each side",
            ));
        }
        Ok(Self {
            params,
            buffer,
            c_r: display.c_r(),
            gaze: gaze.point,
            alpha_max,
            g_max: cdf(alpha_max),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &VisualPolarParams {
        &self.params
    }

    /// The pole of the mapping: the gaze point, screen pixels.
    pub fn gaze(&self) -> ScreenPoint {
        self.gaze
    }

    /// The display constant `c_r` of VaFR Eq. 3 (`α = atan(c_r · r)`), per pixel.
    pub fn c_r(&self) -> f64 {
        self.c_r
    }

    /// The eccentricity `α_M` the buffer reaches, degrees.
    pub fn max_eccentricity_deg(&self) -> f64 {
        self.alpha_max
    }

    /// Normalised CDF `ρ(α)` used by the forward map.
    pub fn rho_of_alpha(&self, alpha_deg: f64) -> f64 {
        match self.params.inverse {
            VisualPolarInverse::Exact => cdf(alpha_deg) / self.g_max,
            VisualPolarInverse::PaperFit => {
                let rf = rho_fovea();
                if alpha_deg <= FOVEA_DEG {
                    return rf * alpha_deg / FOVEA_DEG;
                }
                // Eq. 3 is increasing on [ρ_F, 1]: bisection then Newton polish.
                let (mut lo, mut hi) = (rf, 1.0);
                if alpha_deg <= eq3(lo) {
                    return lo;
                }
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if eq3(mid) < alpha_deg {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                0.5 * (lo + hi)
            }
        }
    }

    /// Eccentricity of normalised CDF `rho` (the inverse map).
    pub fn alpha_of_rho(&self, rho: f64) -> f64 {
        match self.params.inverse {
            VisualPolarInverse::Exact => inverse_cdf(rho * self.g_max),
            VisualPolarInverse::PaperFit => paper_inverse(rho),
        }
    }

    fn drho_dalpha(&self, alpha_deg: f64) -> f64 {
        match self.params.inverse {
            VisualPolarInverse::Exact => pdf(alpha_deg) / self.g_max,
            VisualPolarInverse::PaperFit => {
                if alpha_deg <= FOVEA_DEG {
                    rho_fovea() / FOVEA_DEG
                } else {
                    1.0 / eq3_derivative(self.rho_of_alpha(alpha_deg))
                }
            }
        }
    }
}

impl FoveationMapping for VisualPolar {
    fn method(&self) -> Method {
        Method::VisualPolar
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "buffer_width": self.buffer.width, "buffer_height": self.buffer.height,
            "coverage": self.params.max_eccentricity.to_string(),
            "max_eccentricity_deg": self.alpha_max,
            "inverse": match self.params.inverse {
                VisualPolarInverse::Exact => "exact",
                VisualPolarInverse::PaperFit => "paper-fit",
            },
        })
    }
    fn buffers(&self) -> Vec<BufferSize> {
        vec![self.buffer]
    }
    fn sample_count(&self) -> u64 {
        self.buffer.pixels()
    }
    fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
        layer == 0 && i < self.buffer.width && j < self.buffer.height
    }
    fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
        if !(p.x_px.is_finite() && p.y_px.is_finite()) {
            return None;
        }
        let (r, phi) = polar_deg(p, self.gaze);
        let alpha = eccentricity_deg(self.c_r, r);
        if alpha > self.alpha_max {
            return None;
        }
        Some(SamplePoint::new(
            self.rho_of_alpha(alpha) * self.buffer.width as f64,
            phi / 360.0 * self.buffer.height as f64,
        ))
    }
    fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
        self.ring(s.layer, s.u)?.point(s.v)
    }
    fn ring(&self, layer: u32, u: f64) -> Option<super::Ring> {
        let w = self.buffer.width as f64;
        if layer != 0 || !(u >= 0.0 && u <= w) {
            return None;
        }
        let alpha = self.alpha_of_rho(u / w);
        Some(super::Ring {
            centre: self.gaze,
            r_px: alpha.to_radians().tan() / self.c_r,
            period: self.buffer.height as f64,
        })
    }
    fn polar_layout(&self) -> Option<super::PolarLayout> {
        Some(super::PolarLayout {
            centre: self.gaze,
            period: vec![self.buffer.height as f64; self.buffer.width as usize],
            rows: vec![self.buffer.height; self.buffer.width as usize],
        })
    }
    fn radial_rate_cpd(&self, e_deg: f64) -> f64 {
        if e_deg > self.alpha_max {
            return 0.0;
        }
        0.5 * self.buffer.width as f64 * self.drho_dalpha(e_deg)
    }
    fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
        let d = tangential_denominator(e_deg);
        if d <= 0.0 {
            return f64::INFINITY;
        }
        self.buffer.height as f64 / d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::Degrees;

    #[test]
    fn eq2_constants_match_the_paper() {
        let (a, c) = cdf_constants();
        assert!((a / std::f64::consts::PI - 166.4).abs() < 0.05, "{a}");
        assert!((c - 612.3).abs() < 0.5, "{c}");
        // Continuity at the foveal boundary and G' = g.
        let g_f = std::f64::consts::PI * FOVEA_DEG * FOVEA_DEG;
        let x_f = 0.3 * FOVEA_DEG + 1.0;
        assert!((a * (1.0 / x_f + x_f.ln()) - c - g_f).abs() < 1e-9);
        for alpha in [1.0, 5.0, 6.0, 20.0, 70.0] {
            let h = 1e-5;
            let d = (cdf(alpha + h) - cdf(alpha - h)) / (2.0 * h);
            assert!((d - pdf(alpha)).abs() / pdf(alpha) < 1e-6, "{alpha}");
        }
    }

    #[test]
    fn exact_inverse_inverts() {
        for i in 0..=890 {
            let alpha = i as f64 * 0.1;
            assert!((inverse_cdf(cdf(alpha)) - alpha).abs() < 1e-9, "{alpha}");
        }
    }

    #[test]
    fn eq3_against_exact_inverse() {
        let e = fit_error();
        // Eq. 3 reaches 79.97° at ρ = 1 and hits the foveal boundary at ρ_F.
        assert!((e.at_one_deg - 79.97).abs() < 0.01);
        assert!((eq3(rho_fovea()) - FOVEA_DEG).abs() < 0.05);
        // The fit is a few degrees off in mid-periphery: report, don't hide.
        assert!(e.max_abs_deg > 0.0 && e.max_abs_deg < 10.0, "{e:?}");
    }

    #[test]
    fn fit_needs_80_degrees() {
        let d = DisplayProfile::preset("2k").unwrap();
        let p = VisualPolarParams {
            max_eccentricity: Coverage::Fixed(Degrees(70.0)),
            inverse: VisualPolarInverse::PaperFit,
            ..Default::default()
        };
        assert!(VisualPolar::new(&d, d.centre_gaze(), p).is_err());
    }
}
