//! Per-pixel circles of confusion from depth, focus and the eye model.
//!
//! Three models, each giving a signed diameter in screen pixels (near negative, far positive):
//!
//! * [`CocModel::ThinLens`] — the thin-lens eye that Liu et al.'s Eq. 12 is derived from. An
//!   eye of pupil `τ` focused at `F` sees a point at depth `D` as a disc of visual angle
//!   `τ·(1/F − 1/D)` radians (defocus in dioptres times the pupil); on a display whose
//!   focal length is `f_px` pixels that is `τ·f_px·(1/F − 1/D)` pixels. In retinal
//!   millimetres it is [`fovea_core::optics::EyeModel::coc_retina`]. A thin-lens camera of
//!   aperture `τ` at the eye (the reference renderer) produces exactly this blur.
//! * [`CocModel::Stabilised`] — Liu's Eq. 13, `C′ = (D − F)/(D_F − D_N)` with the DOF limits of
//!   Eq. 4–5. The equation is dimensionless; we scale it so that it agrees with the thin-lens
//!   CoC at the far DOF limit, which makes it the thin-lens blur there and a blur growing
//!   linearly (not as `1/D`) beyond — the "expanded kernel" Liu describes. Where the far limit
//!   is infinite (focus beyond the hyperfocal distance) it is 0, as Eq. 13 is.
//! * [`CocModel::TrackingAware`] — Weier et al.'s Eq. 3 ([`TrackingAwareCoc`]) with the
//!   focus range widened by the gaze-depth uncertainty `t`, `E` from the display's pixels per
//!   degree.
//!
//! Every model clamps the magnitude to `max_coc_px` so that filters stay bounded; NaN or
//! non-positive depths count as "no hit" (infinitely far). Focus at `+∞` is valid (everything
//! nearer is blurred), as is a zero pupil (everything sharp).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use fovea_core::optics::{EyeModel, TrackingAwareCoc};
use fovea_core::units::{Metres, Millimetres};
use fovea_core::{FoveaError, Image, Result};

use super::sanitize_depth;

/// Which CoC model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "model")]
pub enum CocModel {
    /// Thin-lens eye (Liu Eq. 12's physical form).
    ThinLens,
    /// Liu Eq. 13, scaled to the thin-lens CoC at the far DOF limit.
    Stabilised,
    /// Weier Eq. 3 with gaze-depth uncertainty `t` in metres.
    TrackingAware {
        /// Mean gaze-depth error `t`, metres (Weier: 0.2).
        uncertainty_m: f64,
    },
}

impl CocModel {
    /// Parses `thin-lens`, `stabilised` (or `stabilized`), `tracking-aware[:t]`.
    pub fn parse(s: &str) -> Result<Self> {
        let t = s.trim().to_ascii_lowercase();
        let (name, arg) = t.split_once(':').unwrap_or((t.as_str(), ""));
        match name {
            "thin-lens" | "thinlens" | "liu12" => Ok(CocModel::ThinLens),
            "stabilised" | "stabilized" | "liu13" => Ok(CocModel::Stabilised),
            "tracking-aware" | "weier" => {
                let u = if arg.is_empty() {
                    0.2
                } else {
                    arg.parse::<f64>().map_err(|_| {
                        FoveaError::invalid("coc model uncertainty", arg, "metres, e.g. 0.2")
                    })?
                };
                if !(u.is_finite() && u >= 0.0) {
                    return Err(FoveaError::invalid(
                        "coc model uncertainty",
                        u,
                        "a finite distance ≥ 0 m",
                    ));
                }
                Ok(CocModel::TrackingAware { uncertainty_m: u })
            }
            _ => Err(FoveaError::invalid(
                "coc model",
                s,
                "thin-lens, stabilised or tracking-aware[:t]",
            )),
        }
    }

    /// The CLI name.
    pub fn name(&self) -> &'static str {
        match self {
            CocModel::ThinLens => "thin-lens",
            CocModel::Stabilised => "stabilised",
            CocModel::TrackingAware { .. } => "tracking-aware",
        }
    }
}

/// The eye and display quantities a CoC map needs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocParams {
    /// The eye (pupil, focal length, CoC criterion).
    pub eye: EyeModel,
    /// Focal length of the display's pinhole camera in pixels (`f_y`): pixels per radian near
    /// the optical axis.
    pub focal_px: f64,
    /// Largest CoC diameter produced, pixels.
    pub max_coc_px: f64,
    /// Model.
    pub model: CocModel,
}

impl CocParams {
    /// Thin-lens CoC for `eye` on a display of focal length `focal_px`, clamped at 64 px.
    pub fn thin_lens(eye: EyeModel, focal_px: f64) -> Self {
        Self {
            eye,
            focal_px,
            max_coc_px: 64.0,
            model: CocModel::ThinLens,
        }
    }

    /// Pixels of CoC diameter per dioptre of defocus, `τ (m) · f_px`.
    pub fn px_per_dioptre(&self) -> f64 {
        self.eye.pupil.to_metres().0 * self.focal_px
    }

    fn validate(&self, focus: Metres) -> Result<()> {
        if !(self.focal_px.is_finite() && self.focal_px > 0.0) {
            return Err(FoveaError::invalid(
                "focal_px",
                self.focal_px,
                "a finite number > 0",
            ));
        }
        if !(self.max_coc_px.is_finite() && self.max_coc_px >= 0.0) {
            return Err(FoveaError::invalid(
                "max_coc_px",
                self.max_coc_px,
                "a finite number ≥ 0",
            ));
        }
        if focus.0.is_nan() || focus.0 <= 0.0 {
            return Err(FoveaError::invalid(
                "focus",
                focus.0,
                "a distance > 0 m, or +∞",
            ));
        }
        Ok(())
    }
}

/// Signed CoC in pixels of one depth. `depth_m` ≤ 0 or NaN counts as `+∞`.
pub fn coc_px(params: &CocParams, focus: Metres, depth_m: f64) -> Result<f64> {
    let f = CocFn::new(params, focus)?;
    Ok(f.eval(depth_m) as f64)
}

/// The CoC map of a depth image.
pub fn coc_map(params: &CocParams, focus: Metres, depth_m: &Image<f32>) -> Result<Image<f32>> {
    let f = CocFn::new(params, focus)?;
    let mut out = Image::new(depth_m.width(), depth_m.height(), 0.0f32)?;
    out.data_mut()
        .par_iter_mut()
        .zip(depth_m.data().par_iter())
        .for_each(|(o, &d)| *o = f.eval(d as f64));
    Ok(out)
}

/// The constants of a CoC map for one focus, for another executor of [`coc_map`] (the
/// GPU's): with `d` the depth in metres (NaN or ≤ 0 counting as `+∞`), the map is
/// `clamp(c(d), −max_coc_px, max_coc_px)`, NaN → 0, with `c(+∞) = no_hit_coc_px` and for
/// finite `d`:
///
/// * [`CocForm::ThinLens`]: `c = px_per_dioptre · (inv_focus_per_m − 1/d)`;
/// * [`CocForm::Linear`]: `c = (d − focus_m) · px_per_m` (Eq. 13, scaled);
/// * [`CocForm::Zero`]: `c = 0`;
/// * [`CocForm::Other`]: a model with no closed form here (tracking-aware).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CocConstants {
    /// The form of the model at this focus.
    pub form: CocForm,
    /// Largest CoC magnitude, pixels.
    pub max_coc_px: f64,
    /// The clamped CoC of a pixel with no hit (`d = +∞`), pixels.
    pub no_hit_coc_px: f32,
}

/// The closed form of a CoC model at one focus (see [`CocConstants`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CocForm {
    /// `px_per_dioptre · (inv_focus_per_m − 1/d)`.
    ThinLens {
        /// `τ·f_px`, pixels per dioptre.
        px_per_dioptre: f64,
        /// `1/F`, dioptres (0 for focus at infinity).
        inv_focus_per_m: f64,
    },
    /// `(d − focus_m) · px_per_m`.
    Linear {
        /// Pixels per metre beyond the focus.
        px_per_m: f64,
        /// The focus, metres.
        focus_m: f64,
    },
    /// Everything in focus.
    Zero,
    /// No closed form exported.
    Other,
}

/// The constants of `params`' CoC map focused at `focus` (errors as [`coc_map`]).
pub fn coc_constants(params: &CocParams, focus: Metres) -> Result<CocConstants> {
    let f = CocFn::new(params, focus)?;
    let form = match &f.kind {
        CocKind::ThinLens { k, inv_f } => CocForm::ThinLens {
            px_per_dioptre: *k,
            inv_focus_per_m: *inv_f,
        },
        CocKind::Stabilised { scale, focus } => CocForm::Linear {
            px_per_m: *scale,
            focus_m: *focus,
        },
        CocKind::Zero => CocForm::Zero,
        CocKind::Tracking(..) => CocForm::Other,
    };
    Ok(CocConstants {
        form,
        max_coc_px: f.max,
        no_hit_coc_px: f.eval(f64::INFINITY),
    })
}

/// A CoC model evaluated for one focus: precomputed constants.
enum CocKind {
    ThinLens { k: f64, inv_f: f64 },
    Stabilised { scale: f64, focus: f64 },
    Tracking(TrackingAwareCoc, Metres),
    Zero,
}

struct CocFn {
    kind: CocKind,
    max: f64,
}

impl CocFn {
    fn new(p: &CocParams, focus: Metres) -> Result<Self> {
        p.validate(focus)?;
        let k = p.px_per_dioptre();
        let inv_f = if focus.0.is_finite() {
            1.0 / focus.0
        } else {
            0.0
        };
        let kind = match p.model {
            CocModel::ThinLens => CocKind::ThinLens { k, inv_f },
            CocModel::Stabilised => {
                // The DOF limits need a focus beyond the eye's focal length; nearer (or
                // infinite) focus has no finite span, so Eq. 13 gives 0 there.
                let span = if focus.0.is_finite() && focus.0 > 0.05 {
                    p.eye
                        .dof_limits(focus)
                        .ok()
                        .map(|l| (l.far.0 - l.near.0, l.far.0))
                } else {
                    None
                };
                match span {
                    Some((span, far)) if span.is_finite() && span > 0.0 => {
                        // Agree with the thin lens at the far limit.
                        let thin_at_far = k * (inv_f - 1.0 / far);
                        let eq13_at_far = (far - focus.0) / span;
                        CocKind::Stabilised {
                            scale: thin_at_far / eq13_at_far * 1.0 / span,
                            focus: focus.0,
                        }
                    }
                    _ => CocKind::Zero,
                }
            }
            CocModel::TrackingAware { uncertainty_m } => {
                let ppd = p.focal_px * std::f64::consts::PI / 180.0;
                let m = TrackingAwareCoc {
                    image_distance: Millimetres(22.4),
                    depth_uncertainty: Metres(uncertainty_m),
                    pupil: p.eye.pupil,
                    pixels_per_retinal_mm: TrackingAwareCoc::pixels_per_retinal_mm_for(
                        ppd,
                        Millimetres(22.4),
                    ),
                };
                m.validate()?;
                CocKind::Tracking(m, Metres(focus.0.min(1e5)))
            }
        };
        Ok(Self {
            kind,
            max: p.max_coc_px,
        })
    }

    #[inline]
    fn eval(&self, depth_m: f64) -> f32 {
        let d = sanitize_depth(depth_m as f32) as f64;
        let c = match &self.kind {
            CocKind::ThinLens { k, inv_f } => k * (inv_f - 1.0 / d),
            CocKind::Stabilised { scale, focus } => {
                // (D − F)·scale, with D = ∞ mapped to the clamp.
                if d.is_finite() {
                    (d - focus) * scale
                } else {
                    f64::INFINITY
                }
            }
            CocKind::Tracking(m, focus) => {
                // Depths at or inside the eye's focal length blur as much as allowed.
                m.coc_pixels(*focus, Metres(d.min(1e6)))
                    .unwrap_or(-f64::INFINITY)
            }
            CocKind::Zero => 0.0,
        };
        if c.is_nan() {
            0.0
        } else {
            c.clamp(-self.max, self.max) as f32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(model: CocModel) -> CocParams {
        CocParams {
            model,
            ..CocParams::thin_lens(EyeModel::default(), 1000.0)
        }
    }

    #[test]
    fn thin_lens_matches_the_eye_model() {
        let p = params(CocModel::ThinLens);
        for (f, d) in [(0.5, 2.0), (2.0, 0.4), (1.0, 1.0), (0.3, 50.0)] {
            let got = coc_px(&p, Metres(f), d).unwrap();
            let want = EyeModel::default()
                .coc_pixels(Metres(f), Metres(d), 1000.0f64.to_radians())
                .unwrap();
            // coc_pixels uses degrees × ppd, i.e. radians × f_px.
            assert!(
                (got - want).abs() < 1e-6 * want.abs().max(1.0),
                "{got} {want}"
            );
        }
        // Signs: near negative, far positive, in focus zero.
        assert!(coc_px(&p, Metres(1.0), 0.5).unwrap() < 0.0);
        assert!(coc_px(&p, Metres(1.0), 5.0).unwrap() > 0.0);
        assert_eq!(coc_px(&p, Metres(1.0), 1.0).unwrap(), 0.0);
    }

    #[test]
    fn degenerate_inputs_have_defined_results() {
        let p = params(CocModel::ThinLens);
        // Focus at infinity: far objects sharp, near ones blurred.
        assert_eq!(
            coc_px(&p, Metres(f64::INFINITY), f64::INFINITY).unwrap(),
            0.0
        );
        assert!(coc_px(&p, Metres(f64::INFINITY), 0.5).unwrap() < 0.0);
        // NaN and negative depths are "no hit".
        let far = coc_px(&p, Metres(1.0), f64::INFINITY).unwrap();
        assert_eq!(coc_px(&p, Metres(1.0), f64::NAN).unwrap(), far);
        assert_eq!(coc_px(&p, Metres(1.0), -3.0).unwrap(), far);
        // Focus closer than any object (1 cm): clamped, finite.
        let c = coc_px(&p, Metres(0.01), 0.3).unwrap();
        assert_eq!(c, 64.0);
        // Zero pupil: everything sharp. (EyeModel refuses 0 through `new`, not by field.)
        let mut z = p;
        z.eye.pupil = Millimetres(0.0);
        assert_eq!(coc_px(&z, Metres(1.0), 10.0).unwrap(), 0.0);
        // Invalid focus.
        assert!(coc_px(&p, Metres(f64::NAN), 1.0).is_err());
        assert!(coc_px(&p, Metres(0.0), 1.0).is_err());
        assert!(coc_px(&p, Metres(-1.0), 1.0).is_err());
    }

    #[test]
    fn stabilised_agrees_with_thin_lens_at_the_far_limit_and_grows_linearly() {
        let thin = params(CocModel::ThinLens);
        let stab = CocParams {
            max_coc_px: 1e9,
            ..params(CocModel::Stabilised)
        };
        let focus = Metres(1.0);
        let lim = EyeModel::default().dof_limits(focus).unwrap();
        let a = coc_px(&thin, focus, lim.far.0).unwrap();
        let b = coc_px(&stab, focus, lim.far.0).unwrap();
        assert!((a - b).abs() < 1e-9 * a.abs(), "{a} {b}");
        // Linear in D − F: Eq. 13 up to the scale.
        let s1 = coc_px(&stab, focus, 2.0).unwrap();
        let s2 = coc_px(&stab, focus, 3.0).unwrap();
        assert!((s2 / s1 - 2.0).abs() < 1e-9);
        let eq13 = EyeModel::default()
            .coc_stabilised(focus, Metres(2.0))
            .unwrap();
        let eq13b = EyeModel::default()
            .coc_stabilised(focus, Metres(3.0))
            .unwrap();
        assert!((s2 / s1 - eq13b / eq13).abs() < 1e-9);
        // Beyond the hyperfocal distance Eq. 13 is 0.
        assert_eq!(coc_px(&stab, Metres(20.0), 1.0).unwrap(), 0.0);
    }

    #[test]
    fn tracking_aware_widens_the_focus() {
        let t = params(CocModel::TrackingAware { uncertainty_m: 0.2 });
        assert_eq!(coc_px(&t, Metres(2.0), 2.15).unwrap(), 0.0);
        assert!(coc_px(&t, Metres(2.0), 0.5).unwrap() < 0.0);
        assert!(coc_px(&t, Metres(2.0), 10.0).unwrap() > 0.0);
        // With t = 0 it is the thin-lens CoC up to d_i vs the eye's image distance.
        let t0 = params(CocModel::TrackingAware { uncertainty_m: 0.0 });
        let thin = params(CocModel::ThinLens);
        let a = coc_px(&t0, Metres(1.0), 4.0).unwrap();
        let b = coc_px(&thin, Metres(1.0), 4.0).unwrap();
        assert!((a - b).abs() / b < 1e-6, "{a} {b}");
        assert!(CocModel::parse("tracking-aware:0.3").is_ok());
        assert!(CocModel::parse("tracking-aware:-1").is_err());
        assert!(CocModel::parse("gauss").is_err());
    }

    #[test]
    fn exported_constants_reproduce_the_map() {
        // What another executor evaluates from `coc_constants` is the CPU's CoC.
        for model in [CocModel::ThinLens, CocModel::Stabilised] {
            for focus in [0.4, 1.0, 3.0, f64::INFINITY] {
                let p = params(model);
                let k = coc_constants(&p, Metres(focus)).unwrap();
                let eval = |d: f64| -> f64 {
                    let c = match k.form {
                        CocForm::ThinLens {
                            px_per_dioptre,
                            inv_focus_per_m,
                        } => px_per_dioptre * (inv_focus_per_m - 1.0 / d),
                        CocForm::Linear { px_per_m, focus_m } => (d - focus_m) * px_per_m,
                        CocForm::Zero => 0.0,
                        CocForm::Other => panic!("{model:?} has a closed form"),
                    };
                    c.clamp(-k.max_coc_px, k.max_coc_px)
                };
                for d in [0.05, 0.3, 0.9, 2.0, 7.5, 100.0] {
                    let want = coc_px(&p, Metres(focus), d).unwrap();
                    // Depths are f32 images: the CPU rounds them first.
                    let got = eval(d as f32 as f64) as f32 as f64;
                    assert_eq!(got, want, "{model:?} focus {focus} depth {d}");
                }
                let no_hit = coc_px(&p, Metres(focus), f64::INFINITY).unwrap();
                assert_eq!(k.no_hit_coc_px as f64, no_hit, "{model:?} focus {focus}");
            }
        }
        let t = params(CocModel::TrackingAware { uncertainty_m: 0.2 });
        assert_eq!(coc_constants(&t, Metres(1.0)).unwrap().form, CocForm::Other);
        assert!(coc_constants(&t, Metres(f64::NAN)).is_err());
    }

    #[test]
    fn map_matches_pointwise() {
        let p = params(CocModel::ThinLens);
        let depth = Image::from_vec(3, 1, vec![0.5f32, f32::NAN, 3.0]).unwrap();
        let m = coc_map(&p, Metres(1.0), &depth).unwrap();
        for (i, &d) in depth.data().iter().enumerate() {
            let want = coc_px(&p, Metres(1.0), d as f64).unwrap() as f32;
            assert_eq!(m.data()[i], want);
        }
    }
}
