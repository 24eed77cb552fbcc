//! The kernel log-polar frame shared by KFR/LMFR and LaFR (VaFR Eq. 1).
//!
//! `z = ln r / ln L` with `r` the pixel distance to the gaze point and `L` the distance to the
//! farthest screen corner; the LP buffer column is `u = K(z)·w` and the row `v = θ/2π·h`, with
//! `(w, h) = (W/δ, H/δ)`. Points closer than one pixel to the gaze (`z < 0`) fall in column 0,
//! as in the paper's formula; the inverse of column 0 is the gaze point.
//!
//! Sample count: these methods shade the whole `W/δ × H/δ` buffer, `W·H/δ²` samples, which is
//! how VaFR Table 1 counts them (LaFR(2.2) at 2560×1440: 761,652, printed as 761K). When `W/δ`
//! is fractional the integer buffer that holds it is `⌈W/δ⌉ × ⌈H/δ⌉`, and a pixel is shaded
//! when its centre lies inside the `W/δ × H/δ` rectangle.

use super::{polar_deg, tangential_denominator, BufferSize, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::error::{check_range, Result};
use crate::units::ScreenPoint;

/// A radial kernel: normalised column `U(z)` in [0, 1] for `z` in [0, 1], its derivative and
/// its inverse.
pub(crate) trait RadialKernel: Send + Sync {
    fn u_of_z(&self, z: f64) -> f64;
    fn du_dz(&self, z: f64) -> f64;
    fn z_of_u(&self, u: f64) -> f64;
}

/// The numbers that place a kernel log-polar buffer (KFR, LaFR) on the screen, for an executor
/// that evaluates the mapping elsewhere (a shader): everything here is computed once, in f64,
/// by the mapping itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogPolarGeometry {
    /// The pole (the gaze point), screen pixels.
    pub gaze: ScreenPoint,
    /// `ln L`, `L` the distance from the gaze to the farthest screen corner (at least 2 px).
    pub ln_l: f64,
    /// Continuous buffer width `W/δ`, buffer pixels.
    pub width: f64,
    /// Continuous buffer height `H/δ`, buffer pixels.
    pub height: f64,
    /// The forward mapping has no sample farther than this from the gaze, pixels
    /// (`L` plus a relative 1e-9 for rounding).
    pub max_radius_px: f64,
}

/// Geometry of a kernel log-polar buffer for one display and gaze.
#[derive(Clone, Debug)]
pub(crate) struct LogPolarFrame {
    pub gaze: ScreenPoint,
    pub c_r: f64,
    /// `ln L`, L the farthest-corner distance in pixels.
    pub ln_l: f64,
    /// Continuous buffer width `W/δ`.
    pub w: f64,
    /// Continuous buffer height `H/δ`.
    pub h: f64,
    pub delta: f64,
    pub screen_pixels: u64,
}

impl LogPolarFrame {
    pub fn new(display: &DisplayProfile, gaze: Gaze, delta: f64) -> Result<Self> {
        display.validate()?;
        check_range("delta", delta, 1.0, 64.0)?;
        let l = display.farthest_corner_px(&gaze).max(2.0);
        Ok(Self {
            gaze: gaze.point,
            c_r: display.c_r(),
            ln_l: l.ln(),
            w: display.width_px as f64 / delta,
            h: display.height_px as f64 / delta,
            delta,
            screen_pixels: display.pixel_count(),
        })
    }

    /// The public view of this frame.
    pub fn geometry(&self) -> LogPolarGeometry {
        LogPolarGeometry {
            gaze: self.gaze,
            ln_l: self.ln_l,
            width: self.w,
            height: self.h,
            max_radius_px: self.max_radius_px(),
        }
    }

    /// Farthest radius with a sample, pixels.
    fn max_radius_px(&self) -> f64 {
        self.ln_l.exp() * (1.0 + 1e-9)
    }

    /// `z(r)`, clamped to [0, 1].
    pub fn z_of_r(&self, r_px: f64) -> f64 {
        if r_px <= 1.0 {
            0.0
        } else {
            (r_px.ln() / self.ln_l).min(1.0)
        }
    }

    /// `z(e)` for an eccentricity in degrees (VaFR's `z(e) = ln(tan e / c_r)/ln L`).
    pub fn z_of_e(&self, e_deg: f64) -> f64 {
        self.z_of_r(e_deg.to_radians().tan() / self.c_r)
    }

    pub fn buffers(&self) -> Vec<BufferSize> {
        vec![BufferSize {
            width: self.w.ceil() as u32,
            height: self.h.ceil() as u32,
        }]
    }

    /// `W·H/δ²`, rounded (VaFR Table 1).
    pub fn sample_count(&self) -> u64 {
        (self.screen_pixels as f64 / (self.delta * self.delta)).round() as u64
    }

    pub fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
        layer == 0 && (i as f64 + 0.5) <= self.w && (j as f64 + 0.5) <= self.h
    }

    pub fn forward(&self, k: &dyn RadialKernel, p: ScreenPoint) -> Option<SamplePoint> {
        if !(p.x_px.is_finite() && p.y_px.is_finite()) {
            return None;
        }
        let (r, theta) = polar_deg(p, self.gaze);
        if r > self.max_radius_px() {
            return None;
        }
        Some(SamplePoint::new(
            k.u_of_z(self.z_of_r(r)) * self.w,
            theta / 360.0 * self.h,
        ))
    }

    pub fn inverse(&self, k: &dyn RadialKernel, s: SamplePoint) -> Option<ScreenPoint> {
        self.ring(k, s.layer, s.u)?.point(s.v)
    }

    /// The ring of column coordinate `u`: radius `exp(z(u/w)·ln L)` (the pole at `u = 0`),
    /// `H/δ` rows per turn.
    pub fn ring(&self, k: &dyn RadialKernel, layer: u32, u: f64) -> Option<super::Ring> {
        if layer != 0 || !(u >= 0.0 && u <= self.w) {
            return None;
        }
        let r_px = if u == 0.0 {
            0.0
        } else {
            (k.z_of_u(u / self.w) * self.ln_l).exp()
        };
        Some(super::Ring {
            centre: self.gaze,
            r_px,
            period: self.h,
        })
    }

    /// `½·du/de` with `du/de = w·U'(z)·dz/de` and `dz/de = (π/180)/(ln L·sin e·cos e)`.
    pub fn radial_rate_cpd(&self, k: &dyn RadialKernel, e_deg: f64) -> f64 {
        let r = e_deg.to_radians().tan() / self.c_r;
        if r <= 1.0 || r > self.ln_l.exp() {
            return 0.0;
        }
        let z = self.z_of_r(r);
        let dz_de = std::f64::consts::PI
            / 180.0
            / (self.ln_l * e_deg.to_radians().sin() * e_deg.to_radians().cos());
        0.5 * self.w * k.du_dz(z) * dz_de
    }

    /// Every column wraps after `H/δ` rows; `⌈H/δ − ½⌉` of them are shaded.
    pub fn polar_layout(&self) -> super::PolarLayout {
        let b = self.buffers()[0];
        let rows = (0..b.height).filter(|&j| self.is_shaded(0, 0, j)).count() as u32;
        super::PolarLayout {
            centre: self.gaze,
            period: vec![self.h; b.width as usize],
            rows: (0..b.width)
                .map(|i| if self.is_shaded(0, i, 0) { rows } else { 0 })
                .collect(),
        }
    }

    /// VaFR Eq. 20: `(H/δ) / (720 sin e cos e)`.
    pub fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
        let d = tangential_denominator(e_deg);
        if d <= 0.0 {
            return f64::INFINITY;
        }
        self.h / d
    }
}

/// Implements the geometric part of [`super::FoveationMapping`] for a type with fields
/// `frame: LogPolarFrame` and `kernel: impl RadialKernel`.
macro_rules! delegate_to_log_polar_frame {
    () => {
        fn buffers(&self) -> Vec<BufferSize> {
            self.frame.buffers()
        }
        fn sample_count(&self) -> u64 {
            self.frame.sample_count()
        }
        fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
            self.frame.is_shaded(layer, i, j)
        }
        fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
            self.frame.forward(&self.kernel, p)
        }
        fn ring(&self, layer: u32, u: f64) -> Option<super::Ring> {
            self.frame.ring(&self.kernel, layer, u)
        }
        fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
            self.frame.inverse(&self.kernel, s)
        }
        fn radial_rate_cpd(&self, e_deg: f64) -> f64 {
            self.frame.radial_rate_cpd(&self.kernel, e_deg)
        }
        fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
            self.frame.tangential_rate_cpd(e_deg)
        }
        fn polar_layout(&self) -> Option<super::PolarLayout> {
            Some(self.frame.polar_layout())
        }
    };
}
pub(crate) use delegate_to_log_polar_frame;
