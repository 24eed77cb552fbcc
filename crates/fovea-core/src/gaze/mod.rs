//! Gaze trajectories: the point of regard on the screen over time, one sample per tracker
//! reading, queried per rendered frame.
//!
//! A [`GazeTrajectory`] is a validated list of [`GazeSample`]s with strictly increasing
//! timestamps on a `width_px × height_px` screen (pixels, x right, y down). It comes from an
//! eye-tracker export ([`csv::parse_csv`]) or is synthesised ([`synth`]: fixations, main-sequence
//! saccades, smooth pursuit, and the Gaussian-velocity random walk of Liu's inset paper).
//!
//! [`GazeTrajectory::at`] interpolates linearly between the two samples around `t` and holds
//! the first/last sample outside the recorded span; [`GazeTrajectory::resample`] gives one
//! sample per frame at a frame rate.

pub mod csv;
pub mod synth;

use serde::{Deserialize, Serialize};

use crate::error::{FoveaError, Result};

/// Most samples a trajectory (or a resampling) may hold: 10 million, about 560 MB of samples,
/// or 2.8 hours of 1 kHz tracking.
pub const MAX_SAMPLES: usize = 10_000_000;

/// One gaze reading.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GazeSample {
    /// Time in seconds (any origin; trajectories parsed from CSV start at 0 by default).
    pub t_s: f64,
    /// Gaze x on the screen, pixels (right).
    pub x_px: f64,
    /// Gaze y on the screen, pixels (down).
    pub y_px: f64,
    /// Gaze (vergence) depth in metres, when the tracker reports it.
    pub depth_m: Option<f64>,
    /// The second (right) eye's gaze point in pixels, when the tracker reports both eyes;
    /// `x_px`/`y_px` are then the left (or cyclopean) eye.
    pub right: Option<(f64, f64)>,
    /// `false` for a blink or tracking gap: the position is then a stand-in (the last valid gaze
    /// under [`csv::GapPolicy::HoldLast`]), not a measurement.
    pub valid: bool,
}

impl GazeSample {
    /// A valid sample with position only.
    pub fn new(t_s: f64, x_px: f64, y_px: f64) -> Self {
        GazeSample {
            t_s,
            x_px,
            y_px,
            depth_m: None,
            right: None,
            valid: true,
        }
    }
}

/// A validated gaze trajectory: at least one sample, finite values, strictly increasing times.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GazeTrajectory {
    samples: Vec<GazeSample>,
    width_px: f64,
    height_px: f64,
}

impl GazeTrajectory {
    /// Builds a trajectory after checking: `width_px`, `height_px` finite and > 0; 1 to
    /// [`MAX_SAMPLES`] samples; every `t_s`, `x_px`, `y_px` and right-eye coordinate finite;
    /// every depth finite and > 0; timestamps strictly increasing. Positions are not required
    /// to lie on the screen (the CSV reader and the synthesiser clamp them).
    pub fn new(samples: Vec<GazeSample>, width_px: f64, height_px: f64) -> Result<Self> {
        crate::error::check_range_open_lo("width_px", width_px, 0.0, f64::INFINITY)?;
        crate::error::check_range_open_lo("height_px", height_px, 0.0, f64::INFINITY)?;
        if samples.is_empty() {
            return Err(FoveaError::invalid(
                "gaze samples",
                "0 samples",
                "at least one sample",
            ));
        }
        if samples.len() > MAX_SAMPLES {
            return Err(FoveaError::ResourceLimit {
                what: "gaze trajectory".into(),
                needed: format!("{} samples", samples.len()),
                limit: format!("{MAX_SAMPLES} samples"),
            });
        }
        for (i, s) in samples.iter().enumerate() {
            let finite = s.t_s.is_finite()
                && s.x_px.is_finite()
                && s.y_px.is_finite()
                && s.right.is_none_or(|(x, y)| x.is_finite() && y.is_finite())
                && s.depth_m.is_none_or(|d| d.is_finite() && d > 0.0);
            if !finite {
                return Err(FoveaError::invalid(
                    format!("gaze sample {i}"),
                    format!("{s:?}"),
                    "finite time and position, and a finite depth > 0 m if any",
                ));
            }
            if i > 0 && s.t_s <= samples[i - 1].t_s {
                return Err(FoveaError::invalid(
                    format!("gaze sample {i} time t_s"),
                    s.t_s,
                    format!(
                        "strictly increasing timestamps (> {} s of sample {})",
                        samples[i - 1].t_s,
                        i - 1
                    ),
                ));
            }
        }
        Ok(GazeTrajectory {
            samples,
            width_px,
            height_px,
        })
    }

    /// The samples, in time order.
    pub fn samples(&self) -> &[GazeSample] {
        &self.samples
    }

    /// Screen width in pixels.
    pub fn width_px(&self) -> f64 {
        self.width_px
    }

    /// Screen height in pixels.
    pub fn height_px(&self) -> f64 {
        self.height_px
    }

    /// Time of the first sample, seconds.
    pub fn start_s(&self) -> f64 {
        self.samples[0].t_s
    }

    /// Time of the last sample, seconds.
    pub fn end_s(&self) -> f64 {
        self.samples[self.samples.len() - 1].t_s
    }

    /// `end_s − start_s` (0 for a single sample).
    pub fn duration_s(&self) -> f64 {
        self.end_s() - self.start_s()
    }

    /// Number of samples (≥ 1).
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Always `false`: a trajectory holds at least one sample.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The gaze at time `t_s` (seconds). Between samples `a` and `b` with `a.t ≤ t ≤ b.t`
    /// every coordinate is `a + (b − a)·(t − a.t)/(b.t − a.t)`; depth and right eye are
    /// interpolated when both samples have them, else taken from the nearer sample; the result
    /// is valid only if both are. Before the first sample and after the last the end sample is
    /// held. A NaN `t_s` gives the first sample. The returned `t_s` is the query time (the end
    /// sample's time for NaN).
    pub fn at(&self, t_s: f64) -> GazeSample {
        let s = &self.samples;
        let first = s[0];
        let last = s[s.len() - 1];
        if t_s.is_nan() || t_s <= first.t_s {
            return GazeSample {
                t_s: if t_s.is_nan() { first.t_s } else { t_s },
                ..first
            };
        }
        if t_s >= last.t_s {
            return GazeSample { t_s, ..last };
        }
        // First index with time > t: in 1..len because first.t < t < last.t.
        let j = s.partition_point(|p| p.t_s <= t_s);
        let (a, b) = (s[j - 1], s[j]);
        let w = (t_s - a.t_s) / (b.t_s - a.t_s);
        let lerp = |u: f64, v: f64| u + (v - u) * w;
        let nearer_b = w > 0.5;
        let depth_m = match (a.depth_m, b.depth_m) {
            (Some(u), Some(v)) => Some(lerp(u, v)),
            (u, v) => {
                if nearer_b {
                    v
                } else {
                    u
                }
            }
        };
        let right = match (a.right, b.right) {
            (Some(u), Some(v)) => Some((lerp(u.0, v.0), lerp(u.1, v.1))),
            (u, v) => {
                if nearer_b {
                    v
                } else {
                    u
                }
            }
        };
        GazeSample {
            t_s,
            x_px: lerp(a.x_px, b.x_px),
            y_px: lerp(a.y_px, b.y_px),
            depth_m,
            right,
            valid: a.valid && b.valid,
        }
    }

    /// One sample per frame: frame `i` (0-based, `i < n_frames`) is [`Self::at`]`(start_s +
    /// i / fps)`. `fps` must be finite and > 0; `n_frames` at most [`MAX_SAMPLES`].
    pub fn resample(&self, fps: f64, n_frames: usize) -> Result<Vec<GazeSample>> {
        crate::error::check_range_open_lo("fps", fps, 0.0, f64::INFINITY)?;
        if n_frames > MAX_SAMPLES {
            return Err(FoveaError::ResourceLimit {
                what: "gaze resampling".into(),
                needed: format!("{n_frames} frames"),
                limit: format!("{MAX_SAMPLES} frames"),
            });
        }
        let t0 = self.start_s();
        Ok((0..n_frames)
            .map(|i| self.at(t0 + i as f64 / fps))
            .collect())
    }

    /// Number of frames at `fps` that cover the trajectory: `floor(duration·fps) + 1`
    /// (0 if `fps` is not finite and > 0).
    pub fn frame_count(&self, fps: f64) -> usize {
        if !(fps.is_finite() && fps > 0.0) {
            return 0;
        }
        let n = (self.duration_s() * fps + 1e-9).floor() + 1.0;
        n.min(MAX_SAMPLES as f64) as usize
    }

    /// Fraction of samples marked valid, in [0, 1].
    pub fn valid_fraction(&self) -> f64 {
        self.samples.iter().filter(|s| s.valid).count() as f64 / self.samples.len() as f64
    }

    /// Shifts all times so the first sample is at `t = 0`.
    pub fn rebased(mut self) -> Self {
        let t0 = self.start_s();
        for s in &mut self.samples {
            s.t_s -= t0;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn traj() -> GazeTrajectory {
        let mut a = GazeSample::new(0.0, 100.0, 200.0);
        a.depth_m = Some(1.0);
        a.right = Some((110.0, 200.0));
        let mut b = GazeSample::new(1.0, 300.0, 100.0);
        b.depth_m = Some(3.0);
        b.right = Some((330.0, 100.0));
        let mut c = GazeSample::new(3.0, 300.0, 500.0);
        c.valid = false;
        GazeTrajectory::new(vec![a, b, c], 640.0, 480.0).unwrap()
    }

    #[test]
    fn interpolation_is_linear_and_holds_at_ends() {
        let t = traj();
        let m = t.at(0.25);
        assert!((m.x_px - 150.0).abs() < 1e-12 && (m.y_px - 175.0).abs() < 1e-12);
        assert!((m.depth_m.unwrap() - 1.5).abs() < 1e-12);
        let r = m.right.unwrap();
        assert!((r.0 - 165.0).abs() < 1e-12 && (r.1 - 175.0).abs() < 1e-12);
        assert!(m.valid);
        // Between b and the invalid c: position still interpolated, flagged invalid.
        let n = t.at(2.0);
        assert_eq!((n.x_px, n.y_px), (300.0, 300.0));
        assert!(!n.valid);
        assert_eq!(n.depth_m, Some(3.0)); // c has none; b is not nearer at w = 0.5 → a's side
        assert_eq!(t.at(2.5).depth_m, None);
        // Exactly on a sample.
        assert_eq!(t.at(1.0).x_px, 300.0);
        // Held outside.
        let before = t.at(-5.0);
        assert_eq!((before.x_px, before.y_px, before.t_s), (100.0, 200.0, -5.0));
        let after = t.at(10.0);
        assert_eq!((after.x_px, after.y_px), (300.0, 500.0));
        let nan = t.at(f64::NAN);
        assert_eq!((nan.x_px, nan.t_s), (100.0, 0.0));
        assert_eq!(t.duration_s(), 3.0);
        assert!((t.valid_fraction() - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn resample_gives_frames_from_start() {
        let t = traj();
        let f = t.resample(4.0, 5).unwrap();
        assert_eq!(f.len(), 5);
        assert_eq!(f[0].x_px, 100.0);
        assert!((f[1].x_px - 150.0).abs() < 1e-12);
        assert_eq!(f[4].x_px, 300.0);
        assert_eq!(t.frame_count(4.0), 13);
        assert_eq!(t.frame_count(0.0), 0);
        assert!(t.resample(0.0, 3).is_err());
        assert!(t.resample(f64::NAN, 3).is_err());
        assert!(t.resample(90.0, MAX_SAMPLES + 1).is_err());
    }

    #[test]
    fn validation_rejects_bad_samples() {
        let ok = GazeSample::new(0.0, 1.0, 1.0);
        assert!(GazeTrajectory::new(vec![], 10.0, 10.0).is_err());
        assert!(GazeTrajectory::new(vec![ok], 0.0, 10.0).is_err());
        assert!(GazeTrajectory::new(vec![ok], 10.0, f64::NAN).is_err());
        assert!(GazeTrajectory::new(vec![ok, ok], 10.0, 10.0).is_err()); // equal times
        let back = GazeSample::new(-1.0, 1.0, 1.0);
        assert!(GazeTrajectory::new(vec![ok, back], 10.0, 10.0).is_err());
        let nan = GazeSample::new(1.0, f64::NAN, 1.0);
        assert!(GazeTrajectory::new(vec![ok, nan], 10.0, 10.0).is_err());
        let mut neg_depth = GazeSample::new(1.0, 1.0, 1.0);
        neg_depth.depth_m = Some(-1.0);
        assert!(GazeTrajectory::new(vec![ok, neg_depth], 10.0, 10.0).is_err());
        let single = GazeTrajectory::new(vec![ok], 10.0, 10.0).unwrap();
        assert_eq!(single.at(5.0).x_px, 1.0);
        assert_eq!(single.duration_s(), 0.0);
        assert_eq!(single.frame_count(90.0), 1);
        let shifted = GazeTrajectory::new(vec![GazeSample::new(5.0, 1.0, 1.0)], 10.0, 10.0)
            .unwrap()
            .rebased();
        assert_eq!(shifted.start_s(), 0.0);
    }
}
