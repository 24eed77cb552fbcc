//! Synthesised viewing for the sequence experiments: named gaze scenarios (fixations,
//! saccades on the main sequence and smooth pursuit, from [`fovea_core::gaze::synth`]) and a
//! camera sliding in a straight line.

use serde::Serialize;

use fovea_core::display::DisplayProfile;
use fovea_core::gaze::synth::{RandomWalkParams, Scenario, SynthDisplay};
use fovea_core::gaze::GazeTrajectory;
use fovea_core::units::Degrees;
use fovea_render::camera::EyeCamera;

use crate::error::{EvalError, Result};

/// A synthesised gaze scenario.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum GazeScenario {
    /// Fixate the centre, saccade left, pursue right, saccade back, fixate.
    Demo,
    /// Saccades and pursuit in about 1.3 s (120 frames at 90 Hz): fixate 10° left of centre,
    /// pursue right at 15°/s to the centre, saccade up-right, fixate, saccade back to the start.
    SaccadePursuit,
    /// A random walk of fixations and saccades ([`RandomWalkParams::default`]).
    RandomWalk,
    /// The screen centre, held.
    Fixation,
}

/// Names accepted by [`GazeScenario::parse`].
pub const SCENARIOS: &str = "demo, saccade-pursuit, random-walk or fixation";

impl GazeScenario {
    /// Every scenario.
    pub const ALL: [GazeScenario; 4] = [
        GazeScenario::Demo,
        GazeScenario::SaccadePursuit,
        GazeScenario::RandomWalk,
        GazeScenario::Fixation,
    ];

    /// The name (`--scenario`).
    pub fn name(self) -> &'static str {
        match self {
            GazeScenario::Demo => "demo",
            GazeScenario::SaccadePursuit => "saccade-pursuit",
            GazeScenario::RandomWalk => "random-walk",
            GazeScenario::Fixation => "fixation",
        }
    }

    /// Parses a name.
    pub fn parse(text: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == text)
            .ok_or_else(|| EvalError::invalid("scenario", text, SCENARIOS))
    }

    /// The trajectory on `display` (sampled at 1 kHz) lasting at least `duration_s` seconds;
    /// `seed` drives fixational jitter and the random walk.
    pub fn trajectory(
        self,
        display: &DisplayProfile,
        seed: u64,
        duration_s: f64,
    ) -> Result<GazeTrajectory> {
        let (w, h) = (display.width_px as f64, display.height_px as f64);
        let sd = SynthDisplay::from_profile(display);
        let centre = (w / 2.0, h / 2.0);
        let s = match self {
            GazeScenario::Demo => Scenario::new(sd, centre, 1000.0, seed)
                .fixation(0.25)
                .saccade_to((0.3 * w, 0.55 * h))
                .fixation(0.2)
                .pursuit_to((0.65 * w, 0.55 * h), 12.0)
                .saccade_to(centre)
                .fixation(duration_s.max(0.1)),
            GazeScenario::SaccadePursuit => {
                let step = display.radius_px(Degrees(10.0));
                let start = (w / 2.0 - step, h / 2.0);
                Scenario::new(sd, start, 1000.0, seed)
                    .fixation(0.12)
                    .pursuit_to(centre, 15.0)
                    .saccade_to((w / 2.0 + 1.2 * step, h / 2.0 - 0.5 * step))
                    .fixation(0.2)
                    .saccade_to(start)
                    .fixation(duration_s.max(0.1))
            }
            GazeScenario::RandomWalk => {
                Scenario::new(sd, centre, 1000.0, seed).random_walk(RandomWalkParams {
                    duration_s: duration_s.max(0.01),
                    ..RandomWalkParams::default()
                })
            }
            GazeScenario::Fixation => {
                Scenario::new(sd, centre, 1000.0, seed).fixation(duration_s.max(0.01))
            }
        };
        Ok(s.build()?)
    }
}

/// `frames` cameras sliding from `base` by `slide_m` (metres in the camera's frame: right, up,
/// back) over the sequence, looking in `base`'s direction: frame `i` is moved by
/// `i / (frames − 1)` of the slide.
pub fn camera_slide(base: &EyeCamera, slide_m: [f32; 3], frames: usize) -> Result<Vec<EyeCamera>> {
    if slide_m.iter().any(|v| !v.is_finite()) {
        return Err(EvalError::invalid(
            "camera-move",
            format!("{},{},{}", slide_m[0], slide_m[1], slide_m[2]),
            "X,Y,Z (three finite numbers)",
        ));
    }
    let last = (frames.saturating_sub(1)).max(1) as f32;
    let [x, y, z] = slide_m;
    (0..frames)
        .map(|i| {
            let f = i as f32 / last;
            let pos = base.position + f * (x * base.right + y * base.up - z * base.forward);
            Ok(EyeCamera::new(pos, base.forward, base.up, &base.display)?)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenarios_parse_and_last_long_enough() {
        let d = DisplayProfile::with_vertical_fov("t", 96, 96, Degrees(90.0)).unwrap();
        for s in GazeScenario::ALL {
            assert_eq!(GazeScenario::parse(s.name()).unwrap(), s);
            let t = s.trajectory(&d, 1, 0.5).unwrap();
            assert_eq!(t.resample(90.0, 45).unwrap().len(), 45);
        }
        let e = GazeScenario::parse("sideways").unwrap_err();
        assert_eq!(e.parameter(), Some("scenario"));
    }
}
