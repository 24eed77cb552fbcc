//! Visual acuity models as minimum angle of resolution (MAR) against eccentricity.
//!
//! * Linear MAR, VaFR Eq. 2: `ω(e) = m·e + ω₀` degrees per cycle; acuity `f = 1/ω` in cpd.
//! * Segmented MAR, VaFR Eq. 12: MAR linear between user-set pivots `(eᵢ, fᵢ)`; the default
//!   pivots are 40/10/6/5/4 cpd at 0/10/20/30/60° (VaFR Sec. 3.3). Beyond the last pivot the
//!   acuity stays at the last pivot's value.
//! * Headset cap, VaFR Sec. 3.3 / Fig. 3: every pivot's acuity is limited to what the display
//!   can show (its Nyquist rate, half its pixels per degree). With the VaFR pivots this saves
//!   18.8 % of the shading points at the Vive Pro Eye's 9 cpd and 9.6 % at the Pimax Crystal's
//!   18 cpd (the paper states 20 % and 8 %).
//! * The anisotropic tangential factor `Δ(e)` of VaFR Eq. 19 ([`TangentialFactor`]).
//!
//! The model also carries the integral the VaFR mapping is built on, Eq. 4–5:
//! `u(e) = ∫₀ᵉ 2/ω(e') de'`, which per segment is `2·ln(ω(e)/ω(eᵢ))/mᵢ` (or `2(e−eᵢ)/ωᵢ` when
//! the segment is flat), and its exact inverse, Eq. 10.

use serde::{Deserialize, Serialize};

use crate::error::{FoveaError, Result};
use crate::units::{CyclesPerDegree, Degrees};

/// One acuity pivot: acuity `cpd` at eccentricity `eccentricity_deg`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pivot {
    /// Eccentricity of the pivot in degrees.
    pub eccentricity_deg: f64,
    /// Acuity at the pivot in cycles per degree.
    pub cpd: f64,
}

/// VaFR's default pivots (Sec. 3.3): 40, 10, 6, 5, 4 cpd at 0, 10, 20, 30, 60°.
pub const VAFR_PIVOTS: [(f64, f64); 5] = [
    (0.0, 40.0),
    (10.0, 10.0),
    (20.0, 6.0),
    (30.0, 5.0),
    (60.0, 4.0),
];

/// A segment of piecewise-linear MAR: `ω(e) = omega_start + slope·(e − start_deg)` on
/// `[start_deg, end_deg)`, and `u(start_deg) = u_start`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Segment {
    start_deg: f64,
    end_deg: f64,
    omega_start: f64,
    slope: f64,
    u_start: f64,
}

impl Segment {
    fn omega(&self, e_deg: f64) -> f64 {
        self.omega_start + self.slope * (e_deg - self.start_deg)
    }

    /// `∫ 2/ω` from the segment start to `e_deg`.
    fn u_offset(&self, e_deg: f64) -> f64 {
        let de = e_deg - self.start_deg;
        let k = self.slope * de / self.omega_start;
        if k.abs() < 1e-9 {
            // Series of 2·ln(1+k)/m for small k; exact for a flat segment.
            2.0 * de / self.omega_start * (1.0 - k / 2.0 + k * k / 3.0)
        } else {
            2.0 * (1.0 + k).ln() / self.slope
        }
    }

    /// Inverse of [`Self::u_offset`] (VaFR Eq. 10 for one segment).
    fn e_from_u_offset(&self, du: f64) -> f64 {
        let x = self.slope * du / 2.0;
        if x.abs() < 1e-9 {
            self.start_deg + self.omega_start * du / 2.0 * (1.0 + x / 2.0 + x * x / 6.0)
        } else {
            self.start_deg + self.omega_start * x.exp_m1() / self.slope
        }
    }
}

/// Acuity as piecewise-linear MAR. Construct with [`AcuityModel::linear`],
/// [`AcuityModel::segmented`] or [`AcuityModel::vafr_default`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AcuityModel {
    pivots: Vec<Pivot>,
    segments: Vec<Segment>,
}

impl Default for AcuityModel {
    fn default() -> Self {
        Self::vafr_default()
    }
}

impl AcuityModel {
    /// VaFR Eq. 2: `ω(e) = m·e + ω₀` with `m` ≥ 0 (degrees per cycle per degree) and
    /// `ω₀ > 0` (degrees per cycle; `1/ω₀` is the foveal acuity in cpd).
    pub fn linear(m: f64, omega0: f64) -> Result<Self> {
        if !(0.0..10.0).contains(&m) {
            return Err(FoveaError::invalid(
                "mar_slope",
                m,
                "a finite MAR slope in [0, 10) degrees per cycle per degree",
            ));
        }
        if !(omega0.is_finite() && omega0 > 0.0 && omega0 <= 10.0) {
            return Err(FoveaError::invalid(
                "mar_foveal",
                omega0,
                "a foveal MAR in (0, 10] degrees per cycle",
            ));
        }
        let pivots = vec![
            Pivot {
                eccentricity_deg: 0.0,
                cpd: 1.0 / omega0,
            },
            Pivot {
                eccentricity_deg: 90.0,
                cpd: 1.0 / (omega0 + 90.0 * m),
            },
        ];
        Self::segmented(&pivots)
    }

    /// VaFR Eq. 12: MAR linear between pivots. Pivots must start at 0°, have strictly
    /// increasing eccentricities up to at most 90°, and positive finite acuity.
    pub fn segmented(pivots: &[Pivot]) -> Result<Self> {
        if pivots.len() < 2 {
            return Err(FoveaError::invalid(
                "pivots",
                format!("{} pivot(s)", pivots.len()),
                "at least two pivots ECC:CPD, the first at 0°",
            ));
        }
        if pivots[0].eccentricity_deg != 0.0 {
            return Err(FoveaError::invalid(
                "pivots",
                format!("first pivot at {}°", pivots[0].eccentricity_deg),
                "the first pivot at 0° eccentricity",
            ));
        }
        for (i, p) in pivots.iter().enumerate() {
            if !(p.cpd.is_finite() && p.cpd > 0.0 && p.cpd <= 200.0) {
                return Err(FoveaError::invalid(
                    format!("pivots[{i}].cpd"),
                    p.cpd,
                    "a finite acuity in (0, 200] cycles per degree",
                ));
            }
            if !(p.eccentricity_deg.is_finite() && p.eccentricity_deg <= 90.0) {
                return Err(FoveaError::invalid(
                    format!("pivots[{i}].eccentricity"),
                    p.eccentricity_deg,
                    "a finite eccentricity in [0, 90] degrees",
                ));
            }
            if i > 0 && p.eccentricity_deg <= pivots[i - 1].eccentricity_deg {
                return Err(FoveaError::invalid(
                    "pivots",
                    format!(
                        "{}° after {}°",
                        p.eccentricity_deg,
                        pivots[i - 1].eccentricity_deg
                    ),
                    "strictly increasing pivot eccentricities",
                ));
            }
        }
        let mut segments = Vec::with_capacity(pivots.len() - 1);
        let mut u = 0.0;
        for w in pivots.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (wa, wb) = (1.0 / a.cpd, 1.0 / b.cpd);
            let seg = Segment {
                start_deg: a.eccentricity_deg,
                end_deg: b.eccentricity_deg,
                omega_start: wa,
                slope: (wb - wa) / (b.eccentricity_deg - a.eccentricity_deg),
                u_start: u,
            };
            u += seg.u_offset(b.eccentricity_deg);
            segments.push(seg);
        }
        // Beyond the last pivot the acuity stays at the last pivot's value.
        let last = pivots[pivots.len() - 1];
        segments.push(Segment {
            start_deg: last.eccentricity_deg,
            end_deg: f64::INFINITY,
            omega_start: 1.0 / last.cpd,
            slope: 0.0,
            u_start: u,
        });
        Ok(Self {
            pivots: pivots.to_vec(),
            segments,
        })
    }

    /// The segmented model with VaFR's default pivots ([`VAFR_PIVOTS`]).
    pub fn vafr_default() -> Self {
        Self::segmented(&VAFR_PIVOTS.map(|(e, f)| Pivot {
            eccentricity_deg: e,
            cpd: f,
        }))
        .expect("default pivots are valid")
    }

    /// Parses pivots written as `ECC:CPD` pairs separated by commas, e.g.
    /// `0:40,10:10,20:6,30:5,60:4`.
    pub fn parse_pivots(text: &str) -> Result<Self> {
        let mut pivots = Vec::new();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (e, f) = item.split_once(':').ok_or_else(|| {
                FoveaError::invalid("pivots", item, "ECC:CPD pairs, e.g. 0:40,10:10,60:4")
            })?;
            let parse = |s: &str| {
                s.trim().parse::<f64>().map_err(|_| {
                    FoveaError::invalid("pivots", item, "ECC:CPD pairs of numbers, e.g. 0:40")
                })
            };
            pivots.push(Pivot {
                eccentricity_deg: parse(e)?,
                cpd: parse(f)?,
            });
        }
        Self::segmented(&pivots)
    }

    /// The pivots this model interpolates.
    pub fn pivots(&self) -> &[Pivot] {
        &self.pivots
    }

    /// VaFR's headset cap (Sec. 3.3, Fig. 3): each pivot's acuity limited to `cap` (the
    /// display's Nyquist rate, half its ppd), MAR still linear between the pivots.
    pub fn headset_capped(&self, cap: CyclesPerDegree) -> Result<Self> {
        if !(cap.0.is_finite() && cap.0 > 0.0) {
            return Err(FoveaError::invalid(
                "cap",
                cap.0,
                "a positive finite acuity cap in cpd",
            ));
        }
        let pivots: Vec<Pivot> = self
            .pivots
            .iter()
            .map(|p| Pivot {
                eccentricity_deg: p.eccentricity_deg,
                cpd: p.cpd.min(cap.0),
            })
            .collect();
        Self::segmented(&pivots)
    }

    /// The exact clamp `min(f(e), cap)`: like [`Self::headset_capped`] but with a new pivot
    /// where the curve crosses the cap, so it follows the uncapped curve wherever that is lower.
    pub fn clamped(&self, cap: CyclesPerDegree) -> Result<Self> {
        if !(cap.0.is_finite() && cap.0 > 0.0) {
            return Err(FoveaError::invalid(
                "cap",
                cap.0,
                "a positive finite acuity cap in cpd",
            ));
        }
        let cap_omega = 1.0 / cap.0;
        let mut out: Vec<Pivot> = Vec::new();
        for w in self.pivots.windows(2) {
            let (a, b) = (w[0], w[1]);
            if out.is_empty() {
                out.push(Pivot {
                    eccentricity_deg: a.eccentricity_deg,
                    cpd: a.cpd.min(cap.0),
                });
            }
            let (wa, wb) = (1.0 / a.cpd, 1.0 / b.cpd);
            if (wa - cap_omega) * (wb - cap_omega) < 0.0 {
                let t = (cap_omega - wa) / (wb - wa);
                out.push(Pivot {
                    eccentricity_deg: a.eccentricity_deg
                        + t * (b.eccentricity_deg - a.eccentricity_deg),
                    cpd: cap.0,
                });
            }
            out.push(Pivot {
                eccentricity_deg: b.eccentricity_deg,
                cpd: b.cpd.min(cap.0),
            });
        }
        Self::segmented(&out)
    }

    fn segment(&self, e_deg: f64) -> &Segment {
        let i = self
            .segments
            .partition_point(|s| s.end_deg <= e_deg)
            .min(self.segments.len() - 1);
        &self.segments[i]
    }

    /// MAR `ω(e)` in degrees per cycle at eccentricity `e_deg` ≥ 0.
    pub fn mar_deg(&self, e_deg: f64) -> f64 {
        self.segment(e_deg.max(0.0)).omega(e_deg.max(0.0))
    }

    /// MAR slope `dω/de` at `e_deg`.
    pub fn mar_slope(&self, e_deg: f64) -> f64 {
        self.segment(e_deg.max(0.0)).slope
    }

    /// Acuity `f(e) = 1/ω(e)` in cycles per degree.
    pub fn cpd(&self, e: Degrees) -> CyclesPerDegree {
        CyclesPerDegree(1.0 / self.mar_deg(e.0))
    }

    /// VaFR Eq. 5 / 12: LP-buffer column `u(e) = ∫₀ᵉ 2/ω`, continuous across pivots, `u(0) = 0`.
    pub fn u_of_e(&self, e_deg: f64) -> f64 {
        let e = e_deg.max(0.0);
        let s = self.segment(e);
        s.u_start + s.u_offset(e)
    }

    /// VaFR Eq. 10 (segmented): the eccentricity of LP column `u` ≥ 0, exact inverse of
    /// [`Self::u_of_e`].
    pub fn e_of_u(&self, u: f64) -> f64 {
        let u = u.max(0.0);
        let i = self
            .segments
            .partition_point(|s| s.u_start <= u)
            .saturating_sub(1);
        let s = &self.segments[i];
        s.e_from_u_offset(u - s.u_start)
    }
}

/// The ratio `Δ(e)` of tangential to radial shading rate in VaFR Eq. 19, piecewise linear
/// between `(eccentricity_deg, ratio)` pivots and constant beyond the last. `Δ ≡ 1` is the
/// paper's isotropic default (Eq. 6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TangentialFactor {
    pivots: Vec<(f64, f64)>,
}

impl Default for TangentialFactor {
    fn default() -> Self {
        Self::isotropic()
    }
}

impl TangentialFactor {
    /// `Δ(e) = 1`: tangential rate equal to radial (VaFR Eq. 6).
    pub fn isotropic() -> Self {
        Self {
            pivots: vec![(0.0, 1.0)],
        }
    }

    /// Radial acuity about twice the tangential at 30° (VaFR Sec. 9, after Thibos et al.):
    /// `Δ` falls linearly from 1 at 0° to 0.5 at 30° and stays at 0.5 beyond.
    pub fn radial_twice_at_30() -> Self {
        Self {
            pivots: vec![(0.0, 1.0), (30.0, 0.5)],
        }
    }

    /// A factor through user pivots `(eccentricity_deg, ratio)`: eccentricities strictly
    /// increasing from 0, ratios in (0, 1].
    pub fn from_pivots(pivots: &[(f64, f64)]) -> Result<Self> {
        if pivots.is_empty() || pivots[0].0 != 0.0 {
            return Err(FoveaError::invalid(
                "tangential",
                format!("{pivots:?}"),
                "pivots ECC:RATIO starting at 0°",
            ));
        }
        for (i, &(e, r)) in pivots.iter().enumerate() {
            if !(r.is_finite() && r > 0.0 && r <= 1.0) {
                return Err(FoveaError::invalid(
                    format!("tangential[{i}].ratio"),
                    r,
                    "a ratio in (0, 1]",
                ));
            }
            if !e.is_finite() || (i > 0 && e <= pivots[i - 1].0) {
                return Err(FoveaError::invalid(
                    "tangential",
                    format!("{e}°"),
                    "strictly increasing finite pivot eccentricities",
                ));
            }
        }
        Ok(Self {
            pivots: pivots.to_vec(),
        })
    }

    /// Parses `ECC:RATIO,…` or the names `isotropic` / `radial2x30`.
    pub fn parse(text: &str) -> Result<Self> {
        match text.trim() {
            "isotropic" | "1" => Ok(Self::isotropic()),
            "radial2x30" | "anisotropic" => Ok(Self::radial_twice_at_30()),
            t => {
                let mut v = Vec::new();
                for item in t.split(',').map(str::trim).filter(|s| !s.is_empty()) {
                    let bad = || {
                        FoveaError::invalid(
                            "tangential",
                            item,
                            "isotropic, radial2x30, or ECC:RATIO pairs like 0:1,30:0.5",
                        )
                    };
                    let (e, r) = item.split_once(':').ok_or_else(bad)?;
                    v.push((
                        e.trim().parse().map_err(|_| bad())?,
                        r.trim().parse().map_err(|_| bad())?,
                    ));
                }
                Self::from_pivots(&v)
            }
        }
    }

    /// The `(eccentricity_deg, ratio)` pivots `Δ` interpolates linearly (constant before the
    /// first and after the last), e.g. for an executor that uploads them to a shader.
    pub fn pivots(&self) -> &[(f64, f64)] {
        &self.pivots
    }

    /// True when `Δ ≡ 1`.
    pub fn is_isotropic(&self) -> bool {
        self.pivots.iter().all(|&(_, r)| r == 1.0)
    }

    /// `Δ(e)`.
    pub fn at(&self, e_deg: f64) -> f64 {
        let p = &self.pivots;
        if e_deg <= p[0].0 {
            return p[0].1;
        }
        for w in p.windows(2) {
            if e_deg < w[1].0 {
                let t = (e_deg - w[0].0) / (w[1].0 - w[0].0);
                return w[0].1 + t * (w[1].1 - w[0].1);
            }
        }
        p[p.len() - 1].1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_pivots_are_interpolated_in_mar() {
        let a = AcuityModel::vafr_default();
        for (e, f) in VAFR_PIVOTS {
            assert!((a.cpd(Degrees(e)).0 - f).abs() < 1e-12);
        }
        // Midway between 10 and 20° the MAR is the mean of 1/10 and 1/6.
        let mid = (0.1 + 1.0 / 6.0) / 2.0;
        assert!((a.mar_deg(15.0) - mid).abs() < 1e-12);
    }

    #[test]
    fn u_is_the_integral_of_two_over_mar() {
        let a = AcuityModel::vafr_default();
        // Closed form against a fine midpoint rule.
        let n = 200_000;
        let h = 60.0 / n as f64;
        let num: f64 = (0..n)
            .map(|i| 2.0 / a.mar_deg((i as f64 + 0.5) * h) * h)
            .sum();
        assert!(
            (a.u_of_e(60.0) - num).abs() < 1e-6,
            "{} {num}",
            a.u_of_e(60.0)
        );
        // DESIGN.md: u(60°) = 900.1 and u(64°) ≈ 932 (the paper's buffer width).
        assert!((a.u_of_e(60.0) - 900.09).abs() < 0.01);
        assert!((a.u_of_e(64.0) - 932.09).abs() < 0.01);
    }

    #[test]
    fn e_of_u_inverts_u_of_e() {
        let a = AcuityModel::vafr_default();
        for i in 0..=700 {
            let e = i as f64 * 0.1;
            assert!((a.e_of_u(a.u_of_e(e)) - e).abs() < 1e-9, "e={e}");
        }
    }

    #[test]
    fn linear_model_closed_form() {
        let (m, w0) = (0.022, 1.0 / 48.0);
        let a = AcuityModel::linear(m, w0).unwrap();
        for e in [0.0, 3.0, 30.0, 80.0] {
            let u = 2.0 * ((m * e + w0) / w0).ln() / m; // Eq. 5 with c₀ = −2 ln ω₀ / m
            assert!((a.u_of_e(e) - u).abs() < 1e-9);
            assert!((a.mar_deg(e) - (m * e + w0)).abs() < 1e-12);
        }
        assert!(AcuityModel::linear(-1.0, 0.02).is_err());
        assert!(AcuityModel::linear(0.02, 0.0).is_err());
    }

    #[test]
    fn pivots_must_increase() {
        let e = AcuityModel::parse_pivots("0:40,20:10,10:6").unwrap_err();
        assert!(e.to_string().contains("pivots"), "{e}");
        assert!(AcuityModel::parse_pivots("5:40,20:10").is_err());
        assert!(AcuityModel::parse_pivots("0:40,20:-1").is_err());
        assert!(AcuityModel::parse_pivots("0:40,20:nan").is_err());
        assert!(AcuityModel::parse_pivots("0:40,10:10,20:6,30:5,60:4").is_ok());
    }

    #[test]
    fn clamp_and_cap() {
        let a = AcuityModel::vafr_default();
        let c = a.clamped(CyclesPerDegree(9.0)).unwrap();
        for i in 0..600 {
            let e = i as f64 * 0.1;
            let want = a.cpd(Degrees(e)).0.min(9.0);
            assert!((c.cpd(Degrees(e)).0 - want).abs() < 1e-9, "e={e}");
        }
        let h = a.headset_capped(CyclesPerDegree(9.0)).unwrap();
        assert_eq!(h.pivots()[0].cpd, 9.0);
        assert_eq!(h.pivots()[1].cpd, 9.0);
        assert_eq!(h.pivots()[2].cpd, 6.0);
    }

    #[test]
    fn tangential_factor() {
        let t = TangentialFactor::radial_twice_at_30();
        assert_eq!(t.at(0.0), 1.0);
        assert!((t.at(15.0) - 0.75).abs() < 1e-12);
        assert_eq!(t.at(45.0), 0.5);
        assert!(TangentialFactor::parse("0:1,30:2").is_err());
        assert!(TangentialFactor::isotropic().is_isotropic());
    }
}
