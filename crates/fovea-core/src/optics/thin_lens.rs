//! The thin-lens eye (Liu et al. Sec. 3.2, Eq. 4–9 and 12–13).
//!
//! Depth-of-field limits for focus distance `F`, focal length `f`, pupil (aperture) diameter
//! `τ` and CoC criterion `c` (Eq. 4–5):
//! `D_F = f²F / (f² + c·f²/τ − c·f·F/τ)`, `D_N = f²F / (f² − c·f²/τ + c·f·F/τ)`.
//! With the standard eye `f = 22.3 mm`, `c = f·tan(1′) ≈ 0.0065 mm` and `τ = 4.49 mm` these are
//! Liu's Eq. 8–9, `D_F = 497.29F/(498.01 − 0.032F)` and `D_N = 497.29F/(496.57 + 0.032F)` (mm);
//! the far limit reaches infinity at the hyperfocal distance `(f² + c·f²/τ)/(c·f/τ)` ≈ 15.6 m.
//!
//! Circle of confusion on the retina (the quantity Liu's Eq. 12 denotes; as printed that
//! equation multiplies two lengths and cannot be a diameter, so we use the thin-lens form it
//! derives from): an object at `D` images at `v_D = fD/(D − f)`, the retina sits at
//! `v_F = fF/(F − f)`, so the blur diameter is `τ·(v_F − v_D)/v_D = τ·f·(D − F)/(D·(F − f))`
//! (signed: far positive). Its visual angle is `c/v_F = τ·(1/F − 1/D)` radians, the familiar
//! defocus-in-dioptres times pupil. Eq. 13's stabilised CoC is `(D − F)/(D_F − D_N)`.

use serde::{Deserialize, Serialize};

use crate::error::{check_range_open_lo, Result};
use crate::units::{Degrees, Metres, Millimetres};

/// Far and near limits of the depth of field.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DofLimits {
    /// Nearest distance in acceptable focus.
    pub near: Metres,
    /// Farthest distance in acceptable focus; `f64::INFINITY` beyond the hyperfocal distance.
    pub far: Metres,
}

impl DofLimits {
    /// Whether `depth` lies inside the limits.
    pub fn contains(&self, depth: Metres) -> bool {
        depth.0 >= self.near.0 && depth.0 <= self.far.0
    }
}

/// The coefficients of Liu's Eq. 6–9: `D_F = a·F/(b_far − k·F)`, `D_N = a·F/(b_near + k·F)`
/// with `F` and `D` in millimetres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LiuDofCoefficients {
    /// `f²` (497.29 for f = 22.3 mm).
    pub a: f64,
    /// `f² + c·f²/τ` (498.01).
    pub b_far: f64,
    /// `f² − c·f²/τ` (496.57).
    pub b_near: f64,
    /// `c·f/τ` (0.032).
    pub k: f64,
}

/// A thin-lens eye.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EyeModel {
    /// Image focal length (22.3 mm for the standard European adult, Liu Sec. 3.2).
    pub focal_length: Millimetres,
    /// Circle-of-confusion criterion on the retina (0.0065 mm = f·tan 1′).
    pub coc_criterion: Millimetres,
    /// Pupil diameter (4.49 mm in an HMD at about 300 lx, Liu Sec. 3.2).
    pub pupil: Millimetres,
}

impl Default for EyeModel {
    fn default() -> Self {
        Self {
            focal_length: Millimetres(22.3),
            coc_criterion: Millimetres(0.0065),
            pupil: Millimetres(4.49),
        }
    }
}

impl EyeModel {
    /// A validated eye: focal length in (0, 100] mm, criterion in (0, 1] mm, pupil in
    /// (0, 12] mm.
    pub fn new(
        focal_length: Millimetres,
        coc_criterion: Millimetres,
        pupil: Millimetres,
    ) -> Result<Self> {
        check_range_open_lo("focal_length", focal_length.0, 0.0, 100.0)?;
        check_range_open_lo("coc_criterion", coc_criterion.0, 0.0, 1.0)?;
        check_range_open_lo("pupil", pupil.0, 0.0, 12.0)?;
        Ok(Self {
            focal_length,
            coc_criterion,
            pupil,
        })
    }

    /// The same eye with another pupil (validated).
    pub fn with_pupil(self, pupil: Millimetres) -> Result<Self> {
        Self::new(self.focal_length, self.coc_criterion, pupil)
    }

    /// The CoC criterion for an angular resolution: `c = f·tan(angle)` (Liu: 1′ → 0.0065 mm).
    pub fn criterion_for_angle(focal_length: Millimetres, angle: Degrees) -> Millimetres {
        Millimetres(focal_length.0 * angle.to_radians().tan())
    }

    /// Liu's Eq. 6–9 coefficients for this eye.
    pub fn liu_coefficients(&self) -> LiuDofCoefficients {
        let (f, c, t) = (self.focal_length.0, self.coc_criterion.0, self.pupil.0);
        LiuDofCoefficients {
            a: f * f,
            b_far: f * f + c * f * f / t,
            b_near: f * f - c * f * f / t,
            k: c * f / t,
        }
    }

    /// Eq. 4–5: the DOF limits when focused at `focus` (> focal length).
    pub fn dof_limits(&self, focus: Metres) -> Result<DofLimits> {
        let f_mm = check_focus(focus, self.focal_length)?;
        let q = self.liu_coefficients();
        let near = q.a * f_mm / (q.b_near + q.k * f_mm);
        let den = q.b_far - q.k * f_mm;
        let far = if den <= 0.0 {
            f64::INFINITY
        } else {
            q.a * f_mm / den
        };
        Ok(DofLimits {
            near: Millimetres(near).to_metres(),
            far: if far.is_finite() {
                Millimetres(far).to_metres()
            } else {
                Metres(f64::INFINITY)
            },
        })
    }

    /// Focus distance beyond which the far limit is infinite.
    pub fn hyperfocal(&self) -> Metres {
        let q = self.liu_coefficients();
        Millimetres(q.b_far / q.k).to_metres()
    }

    /// Signed retinal CoC diameter for an object at `depth` when focused at `focus`
    /// (thin lens; far positive, near negative).
    pub fn coc_retina(&self, focus: Metres, depth: Metres) -> Result<Millimetres> {
        let f_mm = check_focus(focus, self.focal_length)?;
        let d_mm = check_focus(depth, self.focal_length)?;
        let f = self.focal_length.0;
        Ok(Millimetres(
            self.pupil.0 * f * (d_mm - f_mm) / (d_mm * (f_mm - f)),
        ))
    }

    /// Signed angular CoC diameter, `τ·(1/F − 1/D)` radians, in degrees.
    pub fn coc_angle(&self, focus: Metres, depth: Metres) -> Result<Degrees> {
        check_focus(focus, self.focal_length)?;
        check_focus(depth, self.focal_length)?;
        let rad = self.pupil.to_metres().0 * (1.0 / focus.0 - 1.0 / depth.0);
        Ok(Degrees(rad.to_degrees()))
    }

    /// Signed CoC diameter in screen pixels for a display of `ppd` pixels per degree.
    pub fn coc_pixels(&self, focus: Metres, depth: Metres, ppd: f64) -> Result<f64> {
        check_range_open_lo("ppd", ppd, 0.0, 1000.0)?;
        Ok(self.coc_angle(focus, depth)?.0 * ppd)
    }

    /// Liu's Eq. 13, the stabilised CoC `(D − F)/(D_F − D_N)` (dimensionless; 0 when the far
    /// limit is infinite).
    pub fn coc_stabilised(&self, focus: Metres, depth: Metres) -> Result<f64> {
        let lim = self.dof_limits(focus)?;
        if !depth.0.is_finite() || depth.0 <= 0.0 {
            return Err(crate::FoveaError::invalid(
                "depth",
                depth.0,
                "a positive finite distance in metres",
            ));
        }
        let span = lim.far.0 - lim.near.0;
        Ok(if span.is_finite() {
            (depth.0 - focus.0) / span
        } else {
            0.0
        })
    }
}

/// Validates a distance and returns it in millimetres.
fn check_focus(d: Metres, focal: Millimetres) -> Result<f64> {
    let mm = d.to_mm().0;
    if !(mm.is_finite() && mm > focal.0 * 1.001) {
        return Err(crate::FoveaError::invalid(
            "distance",
            d.0,
            format!(
                "a finite distance in metres greater than the eye's focal length ({} mm)",
                focal.0
            ),
        ));
    }
    Ok(mm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::pupil::pupil_liu_linear;
    use crate::units::Lux;

    #[test]
    fn liu_eq8_9_from_general_formulas() {
        let eye = EyeModel {
            pupil: pupil_liu_linear(Lux(300.0)).unwrap(),
            ..Default::default()
        };
        assert!((eye.pupil.0 - 4.49).abs() < 0.01);
        let q = eye.liu_coefficients();
        assert!((q.a - 497.29).abs() < 1e-9);
        assert!((q.b_far - 498.01).abs() < 0.01, "{}", q.b_far);
        assert!((q.b_near - 496.57).abs() < 0.01, "{}", q.b_near);
        assert!((q.k - 0.032).abs() < 0.0005, "{}", q.k);
        // The far limit reaches infinity at 498.01/0.032 mm ≈ 15.6 m with Liu's rounded
        // coefficients; unrounded (k = 0.03232) it is 15.41 m.
        assert!((498.01f64 / 0.032 / 1000.0 - 15.56).abs() < 0.01);
        assert!((eye.hyperfocal().0 - q.b_far / q.k / 1000.0).abs() < 1e-12);
        assert!(
            (eye.hyperfocal().0 - 15.41).abs() < 0.01,
            "{}",
            eye.hyperfocal().0
        );
        // Eq. 8–9 evaluated by hand at F = 1 m.
        let l = eye.dof_limits(Metres(1.0)).unwrap();
        let far = 497.29 * 1000.0 / (498.01 - 0.032 * 1000.0) / 1000.0;
        let near = 497.29 * 1000.0 / (496.57 + 0.032 * 1000.0) / 1000.0;
        assert!((l.far.0 - far).abs() < 2e-3 && (l.near.0 - near).abs() < 2e-3);
        assert!(eye.dof_limits(Metres(20.0)).unwrap().far.0.is_infinite());
    }

    #[test]
    fn coc_is_zero_at_the_limits_criterion() {
        // At the DOF limits the retinal CoC equals the criterion (that defines the limits).
        let eye = EyeModel::default();
        for focus in [0.3, 1.0, 3.0] {
            let l = eye.dof_limits(Metres(focus)).unwrap();
            let c_near = eye.coc_retina(Metres(focus), l.near).unwrap().0;
            let c_far = eye.coc_retina(Metres(focus), l.far).unwrap().0;
            // The criterion is measured on the image plane of the object; at the retina the
            // blur differs by v_F/v_D, well under 1 %.
            assert!((c_near.abs() - 0.0065).abs() < 1e-4, "{c_near}");
            assert!((c_far.abs() - 0.0065).abs() < 1e-4, "{c_far}");
            assert!(c_near < 0.0 && c_far > 0.0);
        }
        assert_eq!(eye.coc_retina(Metres(2.0), Metres(2.0)).unwrap().0, 0.0);
    }

    #[test]
    fn angular_coc_is_pupil_times_dioptres() {
        let eye = EyeModel::default();
        let a = eye.coc_angle(Metres(0.5), Metres(2.0)).unwrap();
        let want = (0.00449f64 * (2.0 - 0.5)).to_degrees();
        assert!((a.0 - want).abs() < 1e-12);
        // Retinal diameter over retina distance gives the same angle.
        let c = eye.coc_retina(Metres(0.5), Metres(2.0)).unwrap().0;
        let v_f = 22.3 * 500.0 / (500.0 - 22.3);
        assert!(((c / v_f).to_degrees() - a.0).abs() < 1e-9);
    }

    #[test]
    fn invalid_distances() {
        let eye = EyeModel::default();
        assert!(eye.dof_limits(Metres(f64::NAN)).is_err());
        assert!(eye.dof_limits(Metres(-1.0)).is_err());
        assert!(eye.coc_retina(Metres(1.0), Metres(0.0)).is_err());
        assert!(EyeModel::new(Millimetres(22.3), Millimetres(0.0065), Millimetres(-1.0)).is_err());
    }
}
