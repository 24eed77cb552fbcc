//! KFR / LMFR: kernel log-polar foveated rendering (Meng et al.), in the form VaFR gives it:
//! Eq. 1 with the kernel `K(z) = z^α`, i.e. `u = z^α · W/δ` (Eq. 14 with α = 4), and its
//! radial shading rate Eq. 16, `SR = ½·α·z^{α−1}·LW(e)` with
//! `LW(e) = (W/δ)·π / (180·ln L·sin e·cos e)`; tangential rate Eq. 20.
//!
//! The buffer is `W/δ × H/δ` and its shading load `W·H/δ²` (VaFR Table 1), see
//! [`super::log_polar`].

use serde::{Deserialize, Serialize};

use super::log_polar::delegate_to_log_polar_frame;
use super::log_polar::{LogPolarFrame, LogPolarGeometry, RadialKernel};
use super::{BufferSize, FoveationMapping, Method, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::error::{check_range, Result};
use crate::units::ScreenPoint;

/// Parameters of KFR / LMFR.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct KfrParams {
    /// Reduction ratio δ ≥ 1: the buffer is `W/δ × H/δ`. LMFR used 1.8 (VaFR Sec. 4.5).
    pub delta: f64,
    /// Kernel exponent α of `K(z) = z^α` (VaFR Eq. 14 uses 4).
    pub alpha: f64,
}

impl Default for KfrParams {
    fn default() -> Self {
        Self {
            delta: 1.8,
            alpha: 4.0,
        }
    }
}

struct PowerKernel(f64);

impl RadialKernel for PowerKernel {
    fn u_of_z(&self, z: f64) -> f64 {
        z.max(0.0).powf(self.0)
    }
    fn du_dz(&self, z: f64) -> f64 {
        self.0 * z.max(0.0).powf(self.0 - 1.0)
    }
    fn z_of_u(&self, u: f64) -> f64 {
        u.max(0.0).powf(1.0 / self.0)
    }
}

/// The KFR / LMFR mapping for one display and gaze.
pub struct Kfr {
    params: KfrParams,
    frame: LogPolarFrame,
    kernel: PowerKernel,
}

impl Kfr {
    /// Builds the mapping; errors name `delta` (must be in [1, 64]) or `alpha` ((0, 16]).
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: KfrParams) -> Result<Self> {
        check_range("alpha", params.alpha, 0.05, 16.0)?;
        Ok(Self {
            frame: LogPolarFrame::new(display, gaze, params.delta)?,
            kernel: PowerKernel(params.alpha),
            params,
        })
    }

    /// The buffer's geometry (VaFR Eq. 1): pole, `ln L`, `W/δ × H/δ`, outer radius.
    pub fn geometry(&self) -> LogPolarGeometry {
        self.frame.geometry()
    }

    /// The kernel exponent α of `u = z^α · W/δ`.
    pub fn alpha(&self) -> f64 {
        self.params.alpha
    }
}

impl FoveationMapping for Kfr {
    fn method(&self) -> Method {
        Method::Kfr
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"delta": self.params.delta, "alpha": self.params.alpha})
    }
    delegate_to_log_polar_frame!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq16_closed_form() {
        let d = DisplayProfile::preset("2k").unwrap();
        let k = Kfr::new(&d, d.centre_gaze(), KfrParams::default()).unwrap();
        let w = 2560.0 / 1.8;
        let ln_l = (1280.0f64).hypot(720.0).ln();
        for e in [2.0f64, 10.0, 30.0, 50.0] {
            let z = (e.to_radians().tan() / d.c_r()).ln() / ln_l;
            let lw = w * std::f64::consts::PI
                / (180.0 * ln_l * e.to_radians().sin() * e.to_radians().cos());
            let want = 2.0 * z.powi(3) * lw; // Eq. 16
            let got = k.radial_rate_cpd(e);
            assert!((got - want).abs() / want < 1e-9, "{e}: {got} {want}");
        }
    }

    #[test]
    fn bad_delta_is_rejected() {
        let d = DisplayProfile::preset("2k").unwrap();
        let err = Kfr::new(
            &d,
            d.centre_gaze(),
            KfrParams {
                delta: 0.5,
                alpha: 4.0,
            },
        )
        .err()
        .unwrap();
        assert!(err.to_string().contains("delta") && err.to_string().contains("0.5"));
    }
}
