//! LaFR: locomotion-aware foveated rendering (Shi et al.), in the form VaFR gives it (Eq. 15,
//! shading rate Eq. 17). A two-part kernel on `z = ln r / ln L`:
//!
//! * inside the foveal boundary `e_f` (4.89°): `U(z) = (z·(1 − F))^{1/F}`, the inverse of
//!   LaFR's kernel `K_f(z) = z^F/(1 − F)` with `F = f'(a, α) = 1 − log_{Z_ef}(α·Z_ef^{1−a}/(1−a))`;
//! * outside: `U(z) = ((2·arccos(Z_a) − π)/π)^{β/0.7}·(1 − U_ef) + U_ef`,
//!
//! where `Z_ef = z(e_f)` and `U_ef = U(Z_ef)`. The text of VaFR Eq. 15 prints
//! `Z_a = 1/(z/Z_ef − 1)`, which leaves arccos's domain just past the boundary; the derivative
//! in Eq. 17 (factor `1/(Z_ef − 1)`) and continuity at both ends (`U = U_ef` at `Z_ef`, `U = 1`
//! at `z = 1`) give `Z_a = (z − Z_ef)/(Z_ef − 1)`, which is what we implement.
//!
//! `a` is LMFR's kernel exponent in LaFR's convention (`K(z) = z^a` applied from buffer to
//! screen), so LMFR's `u = z⁴` is `a = 1/4`; with α = 0.85 and β = 0.7 (VaFR Sec. 4.5) this
//! gives `F ≈ 0.47`, a foveal rate below acuity and a jump at 4.89°, as VaFR Fig. 5–7 show.
//! The buffer is `W/δ × H/δ` like KFR.

use serde::{Deserialize, Serialize};

use super::log_polar::delegate_to_log_polar_frame;
use super::log_polar::{LogPolarFrame, RadialKernel};
use super::{BufferSize, FoveationMapping, Method, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::error::{check_range, FoveaError, Result};
use crate::units::{Degrees, ScreenPoint};

/// Parameters of LaFR.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LafrParams {
    /// Reduction ratio δ ≥ 1 (1.8 or 2.2 in VaFR's comparisons).
    pub delta: f64,
    /// LMFR's kernel exponent in LaFR's convention, in (0, 1); 1/4 for LMFR's `z⁴`.
    pub kernel_a: f64,
    /// LaFR's α in (0, 1] (0.85 in the original paper, 0.78 tuned for retinal, VaFR Sec. 4.5).
    pub alpha: f64,
    /// LaFR's β > 0 (0.7 originally, 0.9 tuned for retinal).
    pub beta: f64,
    /// Foveal boundary `e_f` (4.89°).
    pub foveal_boundary: Degrees,
}

impl Default for LafrParams {
    fn default() -> Self {
        Self {
            delta: 1.8,
            kernel_a: 0.25,
            alpha: 0.85,
            beta: 0.7,
            foveal_boundary: Degrees(4.89),
        }
    }
}

struct LafrKernel {
    f: f64,
    z_ef: f64,
    u_ef: f64,
    k: f64,
}

impl RadialKernel for LafrKernel {
    fn u_of_z(&self, z: f64) -> f64 {
        let z = z.clamp(0.0, 1.0);
        if z <= self.z_ef {
            (z * (1.0 - self.f)).powf(1.0 / self.f)
        } else {
            let za = (z - self.z_ef) / (self.z_ef - 1.0);
            let q =
                (2.0 * za.clamp(-1.0, 1.0).acos() - std::f64::consts::PI) / std::f64::consts::PI;
            q.max(0.0).powf(self.k) * (1.0 - self.u_ef) + self.u_ef
        }
    }

    fn du_dz(&self, z: f64) -> f64 {
        if z <= self.z_ef {
            (1.0 - self.f) / self.f * (z * (1.0 - self.f)).powf(1.0 / self.f - 1.0)
        } else {
            let za = (z - self.z_ef) / (self.z_ef - 1.0);
            let q =
                (2.0 * za.clamp(-1.0, 1.0).acos() - std::f64::consts::PI) / std::f64::consts::PI;
            let dq_dza = -2.0 / (std::f64::consts::PI * (1.0 - za * za).max(1e-300).sqrt());
            let dqk = if self.k == 1.0 {
                1.0
            } else {
                self.k * q.max(1e-300).powf(self.k - 1.0)
            };
            dqk * dq_dza / (self.z_ef - 1.0) * (1.0 - self.u_ef)
        }
    }

    fn z_of_u(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        if u <= self.u_ef {
            u.powf(self.f) / (1.0 - self.f)
        } else {
            let q = ((u - self.u_ef) / (1.0 - self.u_ef)).powf(1.0 / self.k);
            let za = ((q * std::f64::consts::PI + std::f64::consts::PI) / 2.0).cos();
            self.z_ef + za * (self.z_ef - 1.0)
        }
    }
}

/// The LaFR mapping for one display and gaze.
pub struct Lafr {
    params: LafrParams,
    frame: LogPolarFrame,
    kernel: LafrKernel,
}

impl Lafr {
    /// Builds the mapping. Fails with a typed error when a parameter is out of range or the
    /// combination makes LaFR's exponent `F` leave (0, 1).
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: LafrParams) -> Result<Self> {
        check_range("kernel_a", params.kernel_a, 1e-3, 0.999)?;
        check_range("alpha", params.alpha, 1e-3, 1.0)?;
        check_range("beta", params.beta, 1e-3, 10.0)?;
        check_range("foveal_boundary", params.foveal_boundary.0, 0.1, 45.0)?;
        let frame = LogPolarFrame::new(display, gaze, params.delta)?;
        let defaults = LafrParams::default();
        // What the display is, for messages: the user chose the resolution, usually not the
        // kernel's parameters, so a refusal caused by the display names the display.
        let screen = format!(
            "{}x{} display with a {}° vertical field of view",
            display.width_px, display.height_px, display.vfov.0
        );
        let z_ef = frame.z_of_e(params.foveal_boundary.0);
        if !(z_ef > 0.0 && z_ef < 1.0) {
            let one_px_deg = display.c_r().atan().to_degrees();
            let corner_deg = display.farthest_corner_eccentricity(&gaze).0;
            let expected = format!(
                "an eccentricity between one pixel from the gaze ({one_px_deg:.2}°) and the \
                 farthest screen corner ({corner_deg:.1}°) on this {screen}"
            );
            if params.foveal_boundary != defaults.foveal_boundary {
                return Err(FoveaError::invalid(
                    "foveal_boundary",
                    params.foveal_boundary.0,
                    expected,
                ));
            }
            return Err(FoveaError::Unsupported(format!(
                "LaFR on a {screen}: its foveal region ({}° around the gaze) must span more \
                 than one pixel ({one_px_deg:.2}° here) and end before the farthest screen \
                 corner ({corner_deg:.1}° from this gaze); use a higher resolution, a wider \
                 field of view or another method",
                params.foveal_boundary.0
            )));
        }
        let a = params.kernel_a;
        let f = 1.0 - (params.alpha * z_ef.powf(1.0 - a) / (1.0 - a)).ln() / z_ef.ln();
        if !(f > 0.0 && f < 1.0) {
            if params.kernel_a == defaults.kernel_a && params.alpha == defaults.alpha {
                return Err(FoveaError::Unsupported(format!(
                    "LaFR on a {screen}: its foveal region ({}° around the gaze) covers too \
                     much of the screen for the kernel (exponent F = {f:.3}, outside (0, 1)); \
                     use a higher resolution, a wider field of view or another method",
                    params.foveal_boundary.0
                )));
            }
            return Err(FoveaError::invalid(
                "kernel_a",
                a,
                format!(
                    "a value that keeps LaFR's exponent F = f'(a, α) in (0, 1) on this \
                     {screen}; got F = {f:.3}"
                ),
            ));
        }
        let u_ef = (z_ef * (1.0 - f)).powf(1.0 / f);
        Ok(Self {
            kernel: LafrKernel {
                f,
                z_ef,
                u_ef,
                k: params.beta / 0.7,
            },
            frame,
            params,
        })
    }

    /// LaFR's exponent `F = f'(a, α)`.
    pub fn exponent_f(&self) -> f64 {
        self.kernel.f
    }

    /// Where the buffer lies on the screen (for an executor that evaluates the mapping
    /// elsewhere, e.g. a shader).
    pub fn geometry(&self) -> super::LogPolarGeometry {
        self.frame.geometry()
    }

    /// The kernel's constants (module header), for an executor that evaluates it elsewhere.
    pub fn kernel_constants(&self) -> LafrKernelConstants {
        let k = &self.kernel;
        LafrKernelConstants {
            f: k.f,
            z_ef: k.z_ef,
            u_ef: k.u_ef,
            k: k.k,
        }
    }
}

/// The numbers of LaFR's kernel `U(z)` (module header), computed once in f64 by [`Lafr::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LafrKernelConstants {
    /// LaFR's exponent `F` of the foveal part, in (0, 1).
    pub f: f64,
    /// `Z_ef = z(e_f)`, the foveal boundary's `z`, in (0, 1).
    pub z_ef: f64,
    /// `U_ef = U(Z_ef)`.
    pub u_ef: f64,
    /// The peripheral part's exponent `β/0.7`.
    pub k: f64,
}

impl FoveationMapping for Lafr {
    fn method(&self) -> Method {
        Method::Lafr
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "delta": self.params.delta, "kernel_a": self.params.kernel_a,
            "alpha": self.params.alpha, "beta": self.params.beta,
            "foveal_boundary_deg": self.params.foveal_boundary.0,
        })
    }
    delegate_to_log_polar_frame!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table1_counts() {
        // VaFR Table 1 (thousands, truncated): LaFR(2.2) and LaFR(1.8).
        let want = [
            ("2k", 761, 1137),
            ("4k", 1713, 2560),
            ("6k", 3855, 5760),
            ("8k", 6854, 10240),
            ("retinal", 15423, 23040),
        ];
        for (name, k22, k18) in want {
            let d = DisplayProfile::preset(name).unwrap();
            for (delta, k) in [(2.2, k22), (1.8, k18)] {
                let p = LafrParams {
                    delta,
                    ..Default::default()
                };
                let m = Lafr::new(&d, d.centre_gaze(), p).unwrap();
                let n = (d.pixel_count() as f64 / (delta * delta)) as u64 / 1000;
                assert_eq!(n, k, "{name} δ={delta}");
                assert!((m.sample_count() as i64 / 1000 - k as i64).abs() <= 1);
            }
        }
    }

    #[test]
    fn kernel_is_continuous_and_monotone() {
        let d = DisplayProfile::preset("2k").unwrap();
        let m = Lafr::new(&d, d.centre_gaze(), LafrParams::default()).unwrap();
        assert!(
            m.exponent_f() > 0.3 && m.exponent_f() < 0.6,
            "{}",
            m.exponent_f()
        );
        let k = &m.kernel;
        let eps = 1e-9;
        assert!((k.u_of_z(k.z_ef - eps) - k.u_of_z(k.z_ef + eps)).abs() < 1e-6);
        assert!((k.u_of_z(1.0) - 1.0).abs() < 1e-12);
        let mut prev = -1.0;
        for i in 0..=1000 {
            let u = k.u_of_z(i as f64 / 1000.0);
            assert!(u >= prev);
            prev = u;
            assert!((k.z_of_u(u) - i as f64 / 1000.0).abs() < 1e-6 || u == 0.0);
        }
    }

    #[test]
    fn displays_too_small_for_the_foveal_region_are_named_not_the_kernel() {
        // One pixel spans more than the 4.89° foveal boundary, or the boundary reaches the
        // farthest corner (a 2° field of view): the error names the display.
        for (w, h, vfov) in [(1, 1, 90.0), (16, 9, 90.0), (100, 1, 90.0), (64, 64, 2.0)] {
            let d = DisplayProfile::with_vertical_fov("t", w, h, Degrees(vfov)).unwrap();
            let e = match Lafr::new(&d, d.centre_gaze(), LafrParams::default()) {
                Ok(_) => continue,
                Err(e) => e.to_string(),
            };
            assert!(e.contains(&format!("{w}x{h}")), "{e}");
            assert!(
                !e.contains("foveal_boundary") && !e.contains("kernel_a"),
                "{e}"
            );
        }
        // A parameter the caller did set is named.
        let d = DisplayProfile::with_vertical_fov("t", 16, 9, Degrees(90.0)).unwrap();
        let p = LafrParams {
            foveal_boundary: Degrees(2.0),
            ..Default::default()
        };
        let e = Lafr::new(&d, d.centre_gaze(), p).err().unwrap().to_string();
        assert!(e.contains("foveal_boundary") && e.contains("16x9"), "{e}");
    }
}
