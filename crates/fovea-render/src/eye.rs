//! The eye state of a frame (DESIGN.md "How a frame flows", stage 1): where the eye looks,
//! where it focuses, how wide its pupil is and whether the tracker saw it — and the tracker
//! that carries that state from frame to frame.
//!
//! **Focus** comes, in this order, from
//! 1. the policy: [`FocusMode::Fixed`] gives its distance as it is;
//! 2. under [`FocusMode::Auto`], the tracker's vergence depth when the gaze sample has one
//!    (`depth_m` of a gaze CSV), converted to depth along the view axis;
//! 3. the binocular vergence of the two eyes' gaze rays when the sample has a right-eye gaze
//!    and the tracker knows both eyes' cameras ([`fovea_core::optics::vergence_distance`]);
//! 4. the depth buffer around the gaze (Weier's gaze-depth estimator on a traced depth patch,
//!    [`crate::dof::auto_focus_with_prior_m`]), with the current accommodation as the prior.
//!
//! In a sequence the target then goes through the accommodation filter (Liu Sec. 3.2; the eye
//! refocuses slowly), which the [`EyeTracker`] owns. During a blink or tracking gap
//! (`valid = false`) the gaze is a stand-in, so the tracker holds the last focus target instead
//! of estimating one there.
//!
//! Focus at infinity is [`FocusDistance::Infinity`], not a large number: JSON has no ∞, and a
//! sentinel would leak into arithmetic.

use serde::{Deserialize, Serialize};

use fovea_core::display::Gaze;
use fovea_core::gaze::GazeSample;
use fovea_core::optics::{vergence_distance, AccommodationFilter, AccommodationParams};

use crate::camera::EyeCamera;
use crate::dof::{auto_focus_with_prior_m, DofSettings, FocusMode};
use crate::error::{RenderError, Result};
use crate::world::World;

/// A focus distance along the view axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FocusDistance {
    /// A finite distance, metres (> 0).
    Metres(f64),
    /// Optical infinity (0 dioptres).
    Infinity,
}

impl FocusDistance {
    /// `+∞` → [`Infinity`](Self::Infinity); a finite distance > 0 → metres; anything else is
    /// an error.
    pub fn from_m(m: f64) -> Result<Self> {
        if m == f64::INFINITY {
            Ok(Self::Infinity)
        } else if m.is_finite() && m > 0.0 {
            Ok(Self::Metres(m))
        } else {
            Err(RenderError::invalid(
                "focus",
                m,
                "a distance > 0 m, or infinity",
            ))
        }
    }

    /// The distance in metres for the optics (`f64::INFINITY` at infinity).
    pub fn metres(self) -> f64 {
        match self {
            Self::Metres(m) => m,
            Self::Infinity => f64::INFINITY,
        }
    }

    /// The finite distance in metres, `None` at infinity.
    pub fn finite_m(self) -> Option<f64> {
        match self {
            Self::Metres(m) => Some(m),
            Self::Infinity => None,
        }
    }

    /// Dioptres (1/m; 0 at infinity).
    pub fn dioptres(self) -> f64 {
        match self {
            Self::Metres(m) => 1.0 / m,
            Self::Infinity => 0.0,
        }
    }
}

impl std::fmt::Display for FocusDistance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Metres(m) => write!(f, "{m:.3} m"),
            Self::Infinity => write!(f, "∞"),
        }
    }
}

/// Where a frame's focus came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FocusSource {
    /// [`FocusMode::Fixed`].
    Fixed,
    /// The tracker's vergence depth (a gaze CSV's depth column).
    TrackerDepth,
    /// The vergence of the left and right gaze rays.
    BinocularVergence,
    /// The depth buffer around the gaze.
    DepthBuffer,
    /// Held from the last valid sample (blink or tracking gap).
    Held,
}

/// One eye in one frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EyeState {
    /// Point of regard on this eye's screen.
    pub gaze: Gaze,
    /// Focus distance (after the accommodation filter in a sequence); `None` when the frame
    /// has no depth of field.
    pub focus: Option<FocusDistance>,
    /// Where the focus target came from.
    pub focus_source: Option<FocusSource>,
    /// Pupil diameter, mm (from the DOF settings' eye model; `None` without DOF).
    pub pupil_mm: Option<f64>,
    /// `false` during a blink or tracking gap: the gaze is then a stand-in.
    pub valid: bool,
    /// Vergence distance the tracker or the two gaze rays gave, along the view axis.
    pub vergence: Option<FocusDistance>,
}

impl EyeState {
    /// A valid eye looking at `gaze`, with no focus (a frame without depth of field).
    pub fn looking_at(gaze: Gaze) -> Self {
        Self {
            gaze,
            focus: None,
            focus_source: None,
            pupil_mm: None,
            valid: true,
            vergence: None,
        }
    }

    /// The eye of a single frame looking at `gaze`: focus from `dof`'s policy (fixed, or
    /// estimated from the depth around the gaze), no history.
    pub fn fixating(
        world: &World,
        camera: &EyeCamera,
        gaze: Gaze,
        dof: Option<&DofSettings>,
    ) -> Result<Self> {
        let mut s = Self::looking_at(gaze);
        if let Some(d) = dof {
            let (target, source) = match d.focus {
                FocusMode::Fixed(f) => (f, FocusSource::Fixed),
                FocusMode::Auto => (
                    auto_focus_with_prior_m(world, camera, &gaze, f64::NAN)?,
                    FocusSource::DepthBuffer,
                ),
            };
            s.focus = Some(FocusDistance::from_m(target)?);
            s.focus_source = Some(source);
            s.pupil_mm = Some(d.eye.pupil.0);
        }
        Ok(s)
    }
}

/// The two eyes' cameras, for the vergence of a binocular gaze sample.
#[derive(Clone, Copy, Debug)]
pub struct EyePair<'a> {
    /// The left eye (the sample's `x_px`, `y_px`).
    pub left: &'a EyeCamera,
    /// The right eye (the sample's `right`).
    pub right: &'a EyeCamera,
}

/// The eye state carried across the frames of a sequence: the accommodation filter, the focus
/// estimator's prior (the filter's current focus) and the last valid focus target (held
/// through blinks).
pub struct EyeTracker {
    params: AccommodationParams,
    accommodation: AccommodationFilter,
    last_target_m: Option<f64>,
}

impl EyeTracker {
    /// A tracker whose focus follows targets through an accommodation filter of `params`.
    pub fn new(params: AccommodationParams) -> Result<Self> {
        Ok(Self {
            params,
            accommodation: AccommodationFilter::new(params)?,
            last_target_m: None,
        })
    }

    /// Forgets the history (a cut).
    pub fn reset(&mut self) -> Result<()> {
        *self = Self::new(self.params)?;
        Ok(())
    }

    /// The eye state of the next frame, `dt_s` seconds after the previous one: `sample`'s gaze
    /// on `camera`'s screen, and the focus of `dof`'s policy (see the module header) through
    /// the accommodation filter. `pair` gives both eyes' cameras for a binocular sample.
    pub fn update(
        &mut self,
        world: &World,
        camera: &EyeCamera,
        sample: &GazeSample,
        dof: Option<&DofSettings>,
        pair: Option<EyePair<'_>>,
        dt_s: f64,
    ) -> Result<EyeState> {
        let display = &camera.display;
        let gaze = display.gaze(sample.x_px, sample.y_px)?;
        let mut state = EyeState::looking_at(gaze);
        state.valid = sample.valid;
        state.vergence = self.vergence(camera, sample, pair)?;
        let Some(d) = dof else {
            return Ok(state);
        };
        state.pupil_mm = Some(d.eye.pupil.0);
        let (focus_m, source) = match d.focus {
            FocusMode::Fixed(f) => (f, FocusSource::Fixed),
            FocusMode::Auto => {
                let (target, source) = match (sample.valid, self.last_target_m, state.vergence) {
                    (false, Some(t), _) => (t, FocusSource::Held),
                    (_, _, Some(v)) => (
                        v.metres(),
                        if sample.depth_m.is_some() {
                            FocusSource::TrackerDepth
                        } else {
                            FocusSource::BinocularVergence
                        },
                    ),
                    _ => {
                        let prior = self.accommodation.current_m().unwrap_or(f64::NAN);
                        let t = auto_focus_with_prior_m(world, camera, &gaze, prior)?;
                        (t, FocusSource::DepthBuffer)
                    }
                };
                self.last_target_m = Some(target);
                (self.accommodation.update(target, dt_s)?, source)
            }
        };
        state.focus = Some(FocusDistance::from_m(focus_m)?);
        state.focus_source = Some(source);
        Ok(state)
    }

    /// The vergence distance along `camera`'s view axis: the sample's tracker depth (a
    /// distance along the gaze ray), else the closest approach of the two eyes' gaze rays.
    fn vergence(
        &self,
        camera: &EyeCamera,
        sample: &GazeSample,
        pair: Option<EyePair<'_>>,
    ) -> Result<Option<FocusDistance>> {
        let dir = camera.direction(sample.x_px as f32, sample.y_px as f32);
        let along_axis = |d_m: f64| d_m * (dir.dot(camera.forward) as f64).max(1e-6);
        if let Some(d) = sample.depth_m {
            return Ok(Some(FocusDistance::from_m(along_axis(d))?));
        }
        let (Some((rx, ry)), Some(p)) = (sample.right, pair) else {
            return Ok(None);
        };
        let v3 = |v: glam::Vec3| [v.x as f64, v.y as f64, v.z as f64];
        let ld = p.left.direction(sample.x_px as f32, sample.y_px as f32);
        let rd = p.right.direction(rx as f32, ry as f32);
        let v = vergence_distance(v3(p.left.position), v3(ld), v3(p.right.position), v3(rd))?;
        Ok(Some(if v.distance_m.is_finite() {
            FocusDistance::from_m(along_axis(v.distance_m))?
        } else {
            FocusDistance::Infinity
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn focus_distance_round_trips_and_refuses_nonsense() {
        assert_eq!(
            FocusDistance::from_m(f64::INFINITY).unwrap(),
            FocusDistance::Infinity
        );
        assert_eq!(FocusDistance::from_m(2.0).unwrap().dioptres(), 0.5);
        assert_eq!(FocusDistance::Infinity.dioptres(), 0.0);
        assert_eq!(FocusDistance::Infinity.finite_m(), None);
        for bad in [0.0, -1.0, f64::NAN, f64::NEG_INFINITY] {
            assert!(FocusDistance::from_m(bad).is_err(), "{bad}");
        }
        let json = serde_json::to_string(&FocusDistance::Infinity).unwrap();
        assert_eq!(json, "\"infinity\"");
        let json = serde_json::to_string(&FocusDistance::Metres(1.5)).unwrap();
        assert_eq!(json, "{\"metres\":1.5}");
    }
}
