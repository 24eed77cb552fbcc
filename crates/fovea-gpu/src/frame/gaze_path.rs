//! The gaze a benchmark moves from frame to frame (issue 37: "with the gaze moving every frame
//! by a saccade-sized step"): still, a square of saccade-sized jumps, or a circle walked in
//! saccade-sized arcs.
//!
//! Degrees convert to pixels with the display's rectilinear pixels per degree at the centre,
//! `π/(180·c_r)` (`fovea_core::gaze::synth::SynthDisplay::from_profile`, the small-angle
//! constant of the gaze synthesiser), so a step of `a` degrees is `a · ppd` pixels anywhere on
//! the screen. The default step, [`SACCADE_STEP_DEG`] = 8°, is a small saccade: most saccades
//! of natural viewing are under 15° (Bahill, Adler and Stark 1975, *Investigative
//! Ophthalmology* 14), and 8° is the step of `examples/binocular_frame.rs` and the resident
//! frame's tests.
//!
//! * [`GazePath::Still`]: the start point every frame (the plan cache's best case).
//! * [`GazePath::Saccade`]: jumps of one step, right, down, left, up, around a square whose
//!   first corner is the start point, so every frame's gaze is one step from the last one's.
//! * [`GazePath::Circle`]: a circle of radius a fifth of the screen's height around the start
//!   point, `step` of arc a frame (the gaze of a circle changes VaFR's screen coverage every
//!   frame).
//!
//! Points are clamped to the screen.

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::gaze::synth::SynthDisplay;

use crate::error::{GpuError, Result};

/// The step of [`GazePath::Saccade`] and [`GazePath::Circle`], degrees of visual angle.
pub const SACCADE_STEP_DEG: f64 = 8.0;

/// How the gaze moves from frame to frame (see the module).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GazePath {
    /// The start point every frame.
    Still,
    /// One saccade-sized jump a frame around a square.
    Saccade,
    /// Saccade-sized arcs of a circle a fifth of the screen's height in radius.
    Circle,
}

impl GazePath {
    /// Every path, in the order the CLI lists them.
    pub const ALL: [GazePath; 3] = [GazePath::Saccade, GazePath::Circle, GazePath::Still];

    /// The path's name (`saccade`, `circle`, `still`).
    pub fn name(self) -> &'static str {
        match self {
            GazePath::Still => "still",
            GazePath::Saccade => "saccade",
            GazePath::Circle => "circle",
        }
    }

    /// The path named `name`, or an `Input` error listing the names.
    pub fn parse(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(name.trim()))
            .ok_or_else(|| {
                GpuError::Input(format!(
                    "gaze path `{name}` (expected saccade, circle or still)"
                ))
            })
    }

    /// The gaze of frame `frame` on `display`, starting at `start` and moving `step_deg`
    /// degrees a frame.
    pub fn gaze(
        self,
        display: &DisplayProfile,
        start: Gaze,
        frame: usize,
        step_deg: f64,
    ) -> Result<Gaze> {
        if !(step_deg.is_finite() && step_deg >= 0.0) {
            return Err(GpuError::Input(format!(
                "gaze step {step_deg}° (a finite angle ≥ 0)"
            )));
        }
        let step_px = step_deg * SynthDisplay::from_profile(display).px_per_deg;
        let (x0, y0) = (start.point.x_px, start.point.y_px);
        let (w, h) = (display.width_px as f64, display.height_px as f64);
        let (x, y) = match self {
            GazePath::Still => (x0, y0),
            GazePath::Saccade => {
                let (dx, dy) = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)][frame % 4];
                (x0 + dx * step_px, y0 + dy * step_px)
            }
            GazePath::Circle => {
                let r = 0.2 * h;
                let a = frame as f64 * step_px / r;
                (x0 + r * (a.cos() - 1.0), y0 + r * a.sin())
            }
        };
        display
            .gaze(x.clamp(0.0, w), y.clamp(0.0, h))
            .map_err(|e| GpuError::Input(format!("gaze of frame {frame}: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::units::Degrees;

    fn display() -> DisplayProfile {
        DisplayProfile::new("t", 1440, 1600, Degrees(100.0), Degrees(110.0)).unwrap()
    }

    fn dist(a: Gaze, b: Gaze) -> f64 {
        (a.point.x_px - b.point.x_px).hypot(a.point.y_px - b.point.y_px)
    }

    #[test]
    fn every_frame_moves_one_step_and_still_does_not_move() {
        let d = display();
        let start = d.centre_gaze();
        let step_px = 8.0 * SynthDisplay::from_profile(&d).px_per_deg;
        for path in [GazePath::Saccade, GazePath::Circle] {
            for f in 1..12 {
                let a = path.gaze(&d, start, f - 1, 8.0).unwrap();
                let b = path.gaze(&d, start, f, 8.0).unwrap();
                let moved = dist(a, b);
                // The circle's chord is a little shorter than its arc.
                let lo = if path == GazePath::Circle { 0.95 } else { 1.0 };
                assert!(
                    moved >= lo * step_px - 1e-9 && moved <= step_px + 1e-9,
                    "{} frame {f}: moved {moved} px, step {step_px} px",
                    path.name()
                );
            }
        }
        for f in 0..5 {
            assert_eq!(GazePath::Still.gaze(&d, start, f, 8.0).unwrap(), start);
        }
        assert_eq!(GazePath::Circle.gaze(&d, start, 0, 8.0).unwrap(), start);
    }

    #[test]
    fn names_parse_and_bad_input_is_an_error() {
        for p in GazePath::ALL {
            assert_eq!(GazePath::parse(p.name()).unwrap(), p);
        }
        assert!(GazePath::parse("zigzag").is_err());
        let d = display();
        assert!(GazePath::Saccade
            .gaze(&d, d.centre_gaze(), 1, f64::NAN)
            .is_err());
        // Clamped to the screen from a corner.
        let corner = d.gaze(1440.0, 1600.0).unwrap();
        let g = GazePath::Saccade.gaze(&d, corner, 2, 8.0).unwrap();
        assert_eq!((g.point.x_px, g.point.y_px), (1440.0, 1600.0));
    }
}
