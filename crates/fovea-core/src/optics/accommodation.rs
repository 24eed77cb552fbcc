//! Temporal filtering of the focus distance with a model of accommodation dynamics
//! (Weier et al. 2018, Sec. 3.2: gaze-depth estimates are noisy and need temporal filters).
//!
//! The eye does not refocus instantly, and a depth-of-field effect that snaps to every noisy
//! gaze-depth sample flickers. [`AccommodationFilter`] works in dioptres (`D = 1/m`), the space
//! in which the eye's blur and its accommodation response are linear, with four stages per
//! update of `dt` seconds:
//!
//! 1. **Latency** `L`: the stimulus is the target as it was `L` seconds ago. Human
//!    accommodation starts to respond about 0.3–0.4 s after a step in target vergence
//!    (Campbell & Westheimer 1960, J. Physiol. 151:285; Heron, Charman & Schor 2001, Vision
//!    Res. 41:507). Off by default (a renderer already adds tracker and frame latency); the
//!    [`AccommodationParams::physiological`] preset turns it on.
//! 2. **Median** over the last `median_window_s` of delayed targets (lower median, so the
//!    stimulus is always a depth that was actually estimated, never a blend of two surfaces):
//!    isolated outlier estimates, e.g. one frame where tracker noise put the point of regard on
//!    the background, never reach the response. Not a physiological stage; it stands for the
//!    eye's insensitivity to blur stimuli much shorter than its reaction time.
//! 3. **Dead zone with hysteresis** (a Schmitt trigger on the error `e = stimulus − current`):
//!    the response starts when `|e| > dead_zone_dioptres` and stops once
//!    `|e| ≤ release_dioptres`, so jitter smaller than the dead zone never moves the focus and
//!    the focus still settles close to the target. The eye's depth of focus is about ±0.3 D
//!    (Campbell 1957), so a 0.1 D dead zone is invisible.
//! 4. **First-order response with a speed limit**: `current += clamp(e·(1 − exp(−dt/τ)),
//!    ±v_max·dt)`, the exact step of `dD/dt = e/τ` for a stimulus constant over the step, with
//!    the rate capped at the peak accommodation velocity. Accommodation steps follow roughly an
//!    exponential with a time constant of about 0.2–0.3 s, and peak velocities reach about
//!    10 D/s for large steps (Bharadwaj & Schor 2005, Vision Res. 45:17; approximate values,
//!    they vary with age, step size and direction).
//!
//! The first valid target snaps the filter (there is no earlier state to filter from). A NaN
//! target (tracking lost, blink) holds the previous target: time passes and the response keeps
//! converging to the last valid target.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::gaze_depth::dioptres_to_m;
use crate::error::{check_range, check_range_open_lo, FoveaError, Result};

/// Most target samples the filter keeps for its latency and median stages (older ones are
/// dropped first): 4096 frames, 45 s at 90 Hz.
pub const MAX_HISTORY: usize = 4096;

/// Parameters of [`AccommodationFilter`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccommodationParams {
    /// Reaction latency in seconds, in [0, 2]. Default 0 (see the module header); human ≈ 0.3–0.4 s.
    pub latency_s: f64,
    /// Length in seconds of the median window over delayed targets, in [0, 2]; 0 uses the
    /// latest delayed target alone. Default 0.1 s (9 frames at 90 Hz).
    pub median_window_s: f64,
    /// Time constant τ in seconds of the first-order response, in [0, 10]; 0 follows the
    /// stimulus at the speed limit. Default 0.25 s.
    pub time_constant_s: f64,
    /// Peak accommodation velocity in dioptres per second, in (0, 1000]. Default 10 D/s.
    pub max_speed_dioptres_per_s: f64,
    /// Error in dioptres above which the response starts, in [0, 5]. Default 0.1 D.
    pub dead_zone_dioptres: f64,
    /// Error in dioptres at or below which a running response stops, in
    /// [0, `dead_zone_dioptres`]. Default 0.02 D.
    pub release_dioptres: f64,
}

impl Default for AccommodationParams {
    fn default() -> Self {
        Self {
            latency_s: 0.0,
            median_window_s: 0.1,
            time_constant_s: 0.25,
            max_speed_dioptres_per_s: 10.0,
            dead_zone_dioptres: 0.1,
            release_dioptres: 0.02,
        }
    }
}

impl AccommodationParams {
    /// The default with a human reaction latency of 0.3 s: a simulation of what the viewer's eye
    /// would do, rather than a responsive rendering control.
    pub fn physiological() -> Self {
        Self {
            latency_s: 0.3,
            ..Self::default()
        }
    }

    /// No filtering at all: the output is the latest valid target (for comparisons).
    pub fn passthrough() -> Self {
        Self {
            latency_s: 0.0,
            median_window_s: 0.0,
            time_constant_s: 0.0,
            max_speed_dioptres_per_s: 1000.0,
            dead_zone_dioptres: 0.0,
            release_dioptres: 0.0,
        }
    }

    /// Validates every field against the ranges documented on it.
    pub fn validate(&self) -> Result<()> {
        check_range("latency_s", self.latency_s, 0.0, 2.0)?;
        check_range("median_window_s", self.median_window_s, 0.0, 2.0)?;
        check_range("time_constant_s", self.time_constant_s, 0.0, 10.0)?;
        check_range_open_lo(
            "max_speed_dioptres_per_s",
            self.max_speed_dioptres_per_s,
            0.0,
            1000.0,
        )?;
        check_range("dead_zone_dioptres", self.dead_zone_dioptres, 0.0, 5.0)?;
        check_range(
            "release_dioptres",
            self.release_dioptres,
            0.0,
            self.dead_zone_dioptres,
        )?;
        Ok(())
    }
}

/// Focus state across frames (see the module header). Create one per viewer; call
/// [`AccommodationFilter::update`] once per frame with the estimated focus distance.
#[derive(Clone, Debug)]
pub struct AccommodationFilter {
    params: AccommodationParams,
    /// Seconds since the filter was created or reset.
    time_s: f64,
    /// `(time_s, target_dioptres)` of recent updates, oldest first.
    history: VecDeque<(f64, f64)>,
    last_target_dioptres: Option<f64>,
    current_dioptres: Option<f64>,
    engaged: bool,
    scratch: Vec<f64>,
}

impl AccommodationFilter {
    /// A filter with no state yet. Errors for invalid `params`.
    pub fn new(params: AccommodationParams) -> Result<Self> {
        params.validate()?;
        Ok(Self {
            params,
            time_s: 0.0,
            history: VecDeque::new(),
            last_target_dioptres: None,
            current_dioptres: None,
            engaged: false,
            scratch: Vec::new(),
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &AccommodationParams {
        &self.params
    }

    /// Forgets all state: the next valid target snaps the focus again.
    pub fn reset(&mut self) {
        self.time_s = 0.0;
        self.history.clear();
        self.last_target_dioptres = None;
        self.current_dioptres = None;
        self.engaged = false;
    }

    /// Forgets all state and sets the focus to `focus_m` (metres, > 0, +∞ allowed), as if the
    /// eye had been fixating that distance for a long time. Errors for NaN or ≤ 0.
    pub fn reset_to(&mut self, focus_m: f64) -> Result<()> {
        let d = target_dioptres("focus_m", focus_m)?.ok_or_else(|| {
            FoveaError::invalid("focus_m", focus_m, "a distance > 0 m (+inf allowed)")
        })?;
        self.reset();
        self.snap(d);
        Ok(())
    }

    /// The current focus distance in metres (+∞ at 0 D), `None` before the first valid target.
    pub fn current_m(&self) -> Option<f64> {
        self.current_dioptres.map(dioptres_to_m)
    }

    /// The current focus in dioptres (≥ 0), `None` before the first valid target.
    pub fn current_dioptres(&self) -> Option<f64> {
        self.current_dioptres
    }

    /// Advances the filter by `dt_s` seconds (finite, > 0) towards the estimated focus distance
    /// `target_m` (metres, > 0; +∞ = infinity; NaN = no estimate this frame, hold the previous
    /// target) and returns the filtered focus distance in metres (+∞ at 0 D, and before the
    /// first valid target). Errors for `dt_s` ≤ 0 or non-finite, and for `target_m` ≤ 0 or −∞.
    pub fn update(&mut self, target_m: f64, dt_s: f64) -> Result<f64> {
        let t = target_dioptres("target_m", target_m)?;
        self.step(t, dt_s)
            .map(|d| d.map_or(f64::INFINITY, dioptres_to_m))
    }

    /// [`Self::update`] in dioptres: `target_dioptres` ≥ 0 and finite (NaN holds), returns the
    /// filtered focus in dioptres (0 before the first valid target).
    pub fn update_dioptres(&mut self, target_dioptres: f64, dt_s: f64) -> Result<f64> {
        let t = if target_dioptres.is_nan() {
            None
        } else {
            Some(check_range(
                "target_dioptres",
                target_dioptres,
                0.0,
                f64::INFINITY,
            )?)
        };
        self.step(t, dt_s).map(|d| d.unwrap_or(0.0))
    }

    fn snap(&mut self, d: f64) {
        self.current_dioptres = Some(d);
        self.last_target_dioptres = Some(d);
        self.engaged = false;
        self.history.clear();
        self.history.push_back((self.time_s, d));
    }

    fn step(&mut self, target: Option<f64>, dt_s: f64) -> Result<Option<f64>> {
        check_range_open_lo("dt_s", dt_s, 0.0, f64::INFINITY)?;
        self.time_s += dt_s;
        let target = match target.or(self.last_target_dioptres) {
            Some(t) => t,
            None => return Ok(None),
        };
        let Some(current) = self.current_dioptres else {
            self.snap(target);
            return Ok(Some(target));
        };
        self.last_target_dioptres = Some(target);
        self.history.push_back((self.time_s, target));
        while self.history.len() > MAX_HISTORY {
            self.history.pop_front();
        }

        // 1–2: delayed, median-filtered stimulus.
        let p = self.params;
        let t_delayed = self.time_s - p.latency_s;
        let t_start = t_delayed - p.median_window_s;
        while self.history.len() >= 2
            && self.history[0].0 <= t_start
            && self.history[1].0 <= t_delayed
        {
            self.history.pop_front();
        }
        self.scratch.clear();
        let mut latest = None;
        for &(ts, d) in &self.history {
            if ts <= t_delayed {
                latest = Some(d);
                if ts > t_start {
                    self.scratch.push(d);
                }
            }
        }
        let Some(latest) = latest else {
            return Ok(Some(current)); // still within the latency of the first target
        };
        let stimulus = if self.scratch.is_empty() {
            latest
        } else {
            self.scratch.sort_by(f64::total_cmp);
            self.scratch[(self.scratch.len() - 1) / 2]
        };

        // 3: dead zone with hysteresis.
        let err = stimulus - current;
        if !self.engaged && err.abs() > p.dead_zone_dioptres {
            self.engaged = true;
        }
        if !self.engaged {
            return Ok(Some(current));
        }
        // 4: first-order step, speed-limited.
        let gain = if p.time_constant_s > 0.0 {
            -(-dt_s / p.time_constant_s).exp_m1()
        } else {
            1.0
        };
        let max_step = p.max_speed_dioptres_per_s * dt_s;
        let next = (current + (err * gain).clamp(-max_step, max_step)).max(0.0);
        self.current_dioptres = Some(next);
        if (stimulus - next).abs() <= p.release_dioptres {
            self.engaged = false;
        }
        Ok(Some(next))
    }
}

/// A target distance in metres as dioptres: `None` for NaN (no estimate), 0 for +∞, error for
/// ≤ 0 or −∞.
fn target_dioptres(name: &str, target_m: f64) -> Result<Option<f64>> {
    if target_m.is_nan() {
        Ok(None)
    } else if target_m > 0.0 {
        Ok(Some(if target_m.is_infinite() {
            0.0
        } else {
            1.0 / target_m
        }))
    } else {
        Err(FoveaError::invalid(
            name,
            target_m,
            "a distance > 0 m (+inf for infinity, NaN for no estimate)",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(tau: f64) -> AccommodationParams {
        AccommodationParams {
            time_constant_s: tau,
            ..AccommodationParams::passthrough()
        }
    }

    #[test]
    fn defaults_validate_and_round_trip_through_json() {
        for p in [
            AccommodationParams::default(),
            AccommodationParams::physiological(),
            AccommodationParams::passthrough(),
        ] {
            p.validate().unwrap();
            let s = serde_json::to_string(&p).unwrap();
            assert_eq!(serde_json::from_str::<AccommodationParams>(&s).unwrap(), p);
        }
        let bad = AccommodationParams {
            release_dioptres: 0.2,
            ..AccommodationParams::default()
        };
        assert!(matches!(
            AccommodationFilter::new(bad),
            Err(FoveaError::InvalidParameter { .. })
        ));
        for bad in [
            AccommodationParams {
                time_constant_s: f64::NAN,
                ..Default::default()
            },
            AccommodationParams {
                max_speed_dioptres_per_s: 0.0,
                ..Default::default()
            },
            AccommodationParams {
                latency_s: -0.1,
                ..Default::default()
            },
        ] {
            assert!(bad.validate().is_err());
        }
    }

    #[test]
    fn step_response_is_the_exponential() {
        // 0.5 m (2 D) → 4 m (0.25 D), τ = 0.25 s, no other stage.
        let tau = 0.25;
        let mut f = AccommodationFilter::new(linear(tau)).unwrap();
        assert_eq!(f.update(0.5, 0.01).unwrap(), 0.5); // snap
        let dt = 1.0 / 90.0;
        for n in 1..=90 {
            let m = f.update(4.0, dt).unwrap();
            let t = n as f64 * dt;
            let expect = 0.25 + (2.0 - 0.25) * (-t / tau).exp();
            assert!((1.0 / m - expect).abs() < 1e-12, "{n}: {m}");
        }
    }

    #[test]
    fn speed_limit_ramps_at_the_peak_velocity() {
        let p = AccommodationParams {
            time_constant_s: 0.0,
            max_speed_dioptres_per_s: 10.0,
            ..AccommodationParams::passthrough()
        };
        let mut f = AccommodationFilter::new(p).unwrap();
        f.update_dioptres(0.0, 0.01).unwrap();
        for n in 1..=30 {
            let d = f.update_dioptres(5.0, 0.01).unwrap();
            assert!((d - (0.1 * n as f64).min(5.0)).abs() < 1e-12, "{n}: {d}");
        }
        // With τ as well: never faster than the limit, monotone, converges.
        let mut f = AccommodationFilter::new(AccommodationParams {
            dead_zone_dioptres: 0.0,
            release_dioptres: 0.0,
            median_window_s: 0.0,
            ..AccommodationParams::default()
        })
        .unwrap();
        let mut prev = f.update_dioptres(0.25, 0.01).unwrap();
        for _ in 0..300 {
            let d = f.update_dioptres(4.0, 0.01).unwrap();
            assert!(d >= prev && d - prev <= 0.1 + 1e-12);
            prev = d;
        }
        assert!((prev - 4.0).abs() < 1e-3, "{prev}");
    }

    #[test]
    fn latency_delays_the_start() {
        let p = AccommodationParams {
            latency_s: 0.3,
            ..linear(0.2)
        };
        let mut f = AccommodationFilter::new(p).unwrap();
        f.update_dioptres(1.0, 0.01).unwrap();
        let dt = 0.01;
        let mut first_move = None;
        for n in 1..=100 {
            let d = f.update_dioptres(3.0, dt).unwrap();
            if d != 1.0 && first_move.is_none() {
                first_move = Some(n);
            }
        }
        // The target at step 1 (t = 0.02 s) is seen at t ≥ 0.32 s: step 31.
        assert_eq!(first_move, Some(31));
    }

    #[test]
    fn dead_zone_and_hysteresis() {
        let mut f = AccommodationFilter::new(AccommodationParams {
            median_window_s: 0.0,
            ..AccommodationParams::default()
        })
        .unwrap();
        f.update_dioptres(1.0, 0.01).unwrap();
        // Jitter within ±0.09 D never moves the focus.
        for n in 0..200 {
            let j = 0.09 * ((n as f64) * 1.7).sin();
            assert_eq!(f.update_dioptres(1.0 + j, 0.01).unwrap(), 1.0);
        }
        // A 0.5 D step moves it and it settles within the release band, then stays put.
        let mut d = 0.0;
        for _ in 0..300 {
            d = f.update_dioptres(1.5, 0.01).unwrap();
        }
        assert!((d - 1.5).abs() <= 0.02 && (d - 1.5).abs() > 0.0, "{d}");
        for _ in 0..100 {
            assert_eq!(f.update_dioptres(1.5 + 0.05, 0.01).unwrap(), d);
        }
    }

    #[test]
    fn median_rejects_isolated_outliers() {
        let mut f = AccommodationFilter::new(AccommodationParams::default()).unwrap();
        f.update(0.6, 1.0 / 90.0).unwrap();
        for n in 0..300 {
            let target = if n % 7 == 3 { 4.0 } else { 0.6 };
            let m = f.update(target, 1.0 / 90.0).unwrap();
            assert!((m - 0.6).abs() < 1e-12, "{n}: {m}");
        }
    }

    #[test]
    fn nan_target_holds_the_previous_target() {
        let mut f = AccommodationFilter::new(linear(0.25)).unwrap();
        assert_eq!(f.update(f64::NAN, 0.01).unwrap(), f64::INFINITY);
        assert_eq!(f.current_m(), None);
        f.update(1.0, 0.01).unwrap();
        f.update(0.5, 0.01).unwrap();
        let mut g = AccommodationFilter::new(linear(0.25)).unwrap();
        g.update(1.0, 0.01).unwrap();
        g.update(0.5, 0.01).unwrap();
        for _ in 0..50 {
            let a = f.update(f64::NAN, 0.01).unwrap();
            let b = g.update(0.5, 0.01).unwrap();
            assert_eq!(a, b);
        }
    }

    #[test]
    fn invalid_inputs_are_errors_and_reset_forgets() {
        let mut f = AccommodationFilter::new(AccommodationParams::default()).unwrap();
        for dt in [0.0, -0.01, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                f.update(1.0, dt),
                Err(FoveaError::InvalidParameter { .. })
            ));
        }
        for t in [0.0, -1.0, f64::NEG_INFINITY] {
            assert!(f.update(t, 0.01).is_err());
        }
        assert!(f.update_dioptres(-1.0, 0.01).is_err());
        assert_eq!(f.update(f64::INFINITY, 0.01).unwrap(), f64::INFINITY);
        assert_eq!(f.current_dioptres(), Some(0.0));
        f.update(0.5, 0.01).unwrap();
        f.reset();
        assert_eq!(f.current_m(), None);
        assert_eq!(f.update(2.0, 0.01).unwrap(), 2.0);
        f.reset_to(0.25).unwrap();
        assert_eq!(f.current_dioptres(), Some(4.0));
        assert!(f.reset_to(f64::NAN).is_err());
        assert!(f.reset_to(-2.0).is_err());
    }
}
