//! Weier et al.'s tracking-aware circle of confusion (Sec. 3.2, Eq. 3).
//!
//! The eye is a thin lens with a fixed image distance `d_i` = 22.4 mm. The estimated focus
//! distance `d_o` is widened by the mean gaze-depth error `t` to `d_n = d_o − t` and
//! `d_f = d_o + t`; each gives a focal length from `1/f = 1/d + 1/d_i`. With
//! `V(F, G) = F·G/(G − F)` (image distance of an object at `G` through a lens of focal length
//! `F`), an object at `g` gets
//!
//! * `g < d_n`: `CoC = k·(V(f_n, g) − V(f_n, d_n))/V(f_n, g)·E` (near field),
//! * `g > d_f`: the same with `f_f`, `d_f` (far field),
//! * otherwise 0,
//!
//! where `k` is the pupil diameter and `E` the retinal resolution in pixels per millimetre of
//! retina. The printed Eq. 3 reads `(…)·(k·V_d)·E`; the thin-lens blur it is built from divides
//! by the image distance, `k·Δv/v`, which is what we use. `V(f_n, d_n) = d_i` by construction.
//! The result is signed here (near negative, far positive), as Weier's kernel stores it.

use serde::{Deserialize, Serialize};

use crate::error::{check_range, check_range_open_lo, Result};
use crate::units::{Metres, Millimetres};

/// Parameters of Eq. 3.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackingAwareCoc {
    /// Fixed image distance `d_i` (22.4 mm, after Gross 2005).
    pub image_distance: Millimetres,
    /// Mean gaze-depth estimation error `t` (0.2 m in Weier et al.).
    pub depth_uncertainty: Metres,
    /// Pupil diameter `k`.
    pub pupil: Millimetres,
    /// Retinal resolution `E` in screen pixels per millimetre of retina.
    pub pixels_per_retinal_mm: f64,
}

impl TrackingAwareCoc {
    /// Eq. 3's `E` for a display of `ppd` pixels per degree: one retinal millimetre subtends
    /// `1/d_i` radians.
    pub fn pixels_per_retinal_mm_for(ppd: f64, image_distance: Millimetres) -> f64 {
        ppd * (1.0 / image_distance.0).to_degrees()
    }

    /// Validates the parameters.
    pub fn validate(&self) -> Result<()> {
        check_range_open_lo("image_distance", self.image_distance.0, 0.0, 100.0)?;
        check_range("depth_uncertainty", self.depth_uncertainty.0, 0.0, 100.0)?;
        check_range_open_lo("pupil", self.pupil.0, 0.0, 12.0)?;
        check_range_open_lo(
            "pixels_per_retinal_mm",
            self.pixels_per_retinal_mm,
            0.0,
            1e6,
        )?;
        Ok(())
    }

    /// Signed CoC in pixels for an object at `g` with estimated focus distance `d_o`.
    pub fn coc_pixels(&self, focus: Metres, g: Metres) -> Result<f64> {
        self.validate()?;
        check_range_open_lo("focus", focus.0, 0.0, 1e6)?;
        check_range_open_lo("depth", g.0, 0.0, f64::INFINITY)?;
        let di = self.image_distance.0;
        let g_mm = g.to_mm().0;
        let t_mm = self.depth_uncertainty.to_mm().0;
        let d_n = (focus.to_mm().0 - t_mm).max(di * 1.01);
        let d_f = focus.to_mm().0 + t_mm;
        let v = |f: f64, d: f64| f * d / (d - f);
        let focal = |d: f64| 1.0 / (1.0 / d + 1.0 / di);
        let coc = |f: f64, d: f64| {
            let vg = v(f, g_mm);
            (vg - v(f, d)) / vg * self.pupil.0 * self.pixels_per_retinal_mm
        };
        Ok(if g_mm < d_n {
            let f_n = focal(d_n);
            if g_mm <= f_n {
                return Err(crate::FoveaError::invalid(
                    "depth",
                    g.0,
                    "a distance beyond the eye's focal length",
                ));
            }
            -coc(f_n, d_n).abs()
        } else if g_mm > d_f {
            coc(focal(d_f), d_f).abs()
        } else {
            0.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(t: f64) -> TrackingAwareCoc {
        TrackingAwareCoc {
            image_distance: Millimetres(22.4),
            depth_uncertainty: Metres(t),
            pupil: Millimetres(4.0),
            pixels_per_retinal_mm: TrackingAwareCoc::pixels_per_retinal_mm_for(
                15.0,
                Millimetres(22.4),
            ),
        }
    }

    #[test]
    fn zero_inside_widened_focus_and_signed_outside() {
        let m = model(0.2);
        assert_eq!(m.coc_pixels(Metres(2.0), Metres(2.15)).unwrap(), 0.0);
        assert_eq!(m.coc_pixels(Metres(2.0), Metres(1.85)).unwrap(), 0.0);
        assert!(m.coc_pixels(Metres(2.0), Metres(0.5)).unwrap() < 0.0);
        assert!(m.coc_pixels(Metres(2.0), Metres(10.0)).unwrap() > 0.0);
    }

    #[test]
    fn t_zero_matches_the_thin_lens_eye() {
        // With t = 0 Eq. 3 is k·(1 − d_i/V(f, g))·E = k·d_i·|1/d_o − 1/g|·E (retinal mm → px).
        let m = model(0.0);
        let (d_o, g) = (1.0, 4.0);
        let want = 4.0 * 22.4 * (1.0 / 1000.0 - 1.0 / 4000.0) * m.pixels_per_retinal_mm;
        let got = m.coc_pixels(Metres(d_o), Metres(g)).unwrap();
        assert!((got - want).abs() / want < 1e-9, "{got} {want}");
        // Larger t: a smaller blur for the same object.
        assert!(model(0.5).coc_pixels(Metres(d_o), Metres(g)).unwrap() < got);
    }
}
