//! Synthesised gaze trajectories: fixations, main-sequence saccades, smooth pursuit, and the
//! Gaussian-velocity random walk of Liu's inset paper (`liu-inset-boundary-smoothing.txt`,
//! Sec. 4: "for adjacent frames, the inset center moves at a velocity that follows a 2D
//! Gaussian distribution"). Everything is seeded and deterministic (SplitMix64 built on
//! [`crate::math::mix64`], Box–Muller normals).
//!
//! # Geometry
//!
//! Angles convert to pixels with one constant, [`SynthDisplay::px_per_deg`]: a visual angle of
//! `a` degrees is `a · px_per_deg` pixels anywhere on the screen. This is the small-angle
//! (lens-centre) approximation; [`SynthDisplay::from_profile`] takes the display's
//! [`DisplayProfile::ppd`]. On a rectilinear target the true ppd grows as `1/cos²e` away from
//! the centre, so synthetic amplitudes and speeds are exact in screen pixels / ppd, not in
//! true visual angle far off-axis.
//!
//! # Saccades: the main sequence
//!
//! Duration (Carpenter 1988, *Movements of the Eyes*, linear fit): `D = 2.2 ms/° · A + 21 ms`.
//! Peak velocity (exponential main sequence, the form of Baloh et al. 1975, *Neurology* 25):
//! `V_p = V_max · (1 − e^{−A/C})`. Defaults `V_max = 600 °/s`, `C = 10°` are our choice within
//! the published range of such fits, made so that the two laws agree: a saccade's peak velocity
//! must exceed its mean velocity `A/D`. (With `V_max = 500 °/s`, `C = 14°` the laws contradict
//! each other below about 3°: at `A = 2°` they give `V_p = 66.6 °/s` but a mean of 78.7 °/s.)
//! The defaults give a peak-to-mean ratio `r = V_p·D/A` of 1.26 (A → 0) to 1.65 (A = 30°).
//!
//! The velocity profile is a symmetric bell on normalised time `τ = t/D`, a blend of the
//! polynomial bells `p_k(τ) = τ^k(1−τ)^k / B(k+1, k+1)` (`k = 0…4`, each of unit area, peak
//! ratios `P_k = 1, 1.5, 1.875, 2.1875, 2.4609`; `p_2` is the minimum-jerk profile). For the
//! required `r` in `[P_k, P_{k+1}]` it uses `(1−w)·p_k + w·p_{k+1}` with
//! `w = (r − P_k)/(P_{k+1} − P_k)`: unit area (the saccade lands exactly at its target after
//! exactly `D`) and peak `r·A/D = V_p` at `τ = ½`. Positions are the closed-form integrals
//! (smoothstep polynomials). A parameter set needing `r < 1` or `r > 2.4609` is an error.
//!
//! # Smooth pursuit, fixation, random walk
//!
//! Pursuit moves at constant angular speed along a line or a circular arc. A fixation holds a
//! point with optional drift (Brownian, diffusion coefficient `D_drift` in deg²/s: per-axis
//! step variance `2·D_drift·dt`) and tremor (independent Gaussian jitter). The random walk
//! draws, every step `dt`, a velocity `v ~ N(0, σ²·I₂)` in °/s and moves by `v·dt`, reflecting
//! at the screen edges. Liu's paper gives no σ or step; we use `σ = 10 °/s` per axis and
//! `dt = 1/90 s` (one frame of a 90 Hz HMD) by default, and state them in
//! [`RandomWalkParams::default`].

use crate::display::DisplayProfile;
use crate::error::{check_range, check_range_open_lo, FoveaError, Result};
use crate::math::mix64;

use super::{GazeSample, GazeTrajectory, MAX_SAMPLES};

/// Highest accepted sample rate, Hz.
pub const MAX_RATE_HZ: f64 = 1.0e6;

/// Screen size and the degrees-to-pixels constant used by the synthesiser.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SynthDisplay {
    /// Screen width, pixels.
    pub width_px: f64,
    /// Screen height, pixels.
    pub height_px: f64,
    /// Pixels per degree of visual angle (constant over the screen).
    pub px_per_deg: f64,
}

impl SynthDisplay {
    /// Checks that all three are finite and > 0.
    pub fn new(width_px: f64, height_px: f64, px_per_deg: f64) -> Result<Self> {
        check_range_open_lo("width_px", width_px, 0.0, f64::INFINITY)?;
        check_range_open_lo("height_px", height_px, 0.0, f64::INFINITY)?;
        check_range_open_lo("px_per_deg", px_per_deg, 0.0, f64::INFINITY)?;
        Ok(SynthDisplay {
            width_px,
            height_px,
            px_per_deg,
        })
    }

    /// The display's resolution and the pixels per degree of its rendered projection at the
    /// centre, `π/(180·c_r)` — the angle the eye turns through to move across the image (a
    /// headset's quoted optical ppd, [`DisplayProfile::ppd`], is another quantity).
    pub fn from_profile(d: &DisplayProfile) -> Self {
        SynthDisplay {
            width_px: d.width_px as f64,
            height_px: d.height_px as f64,
            px_per_deg: d.rectilinear_ppd(crate::units::Degrees(0.0)),
        }
    }

    fn check_point(&self, name: &str, p: (f64, f64)) -> Result<()> {
        if p.0.is_finite()
            && p.1.is_finite()
            && (0.0..=self.width_px).contains(&p.0)
            && (0.0..=self.height_px).contains(&p.1)
        {
            Ok(())
        } else {
            Err(FoveaError::invalid(
                name,
                format!("({}, {})", p.0, p.1),
                format!(
                    "a point on the {}×{} px screen",
                    self.width_px, self.height_px
                ),
            ))
        }
    }

    fn clamp(&self, p: (f64, f64)) -> (f64, f64) {
        (
            p.0.clamp(0.0, self.width_px),
            p.1.clamp(0.0, self.height_px),
        )
    }

    fn distance_deg(&self, a: (f64, f64), b: (f64, f64)) -> f64 {
        (b.0 - a.0).hypot(b.1 - a.1) / self.px_per_deg
    }
}

/// Deterministic SplitMix64 generator with Box–Muller normals.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A generator for `seed`.
    pub fn new(seed: u64) -> Self {
        Rng { state: seed }
    }

    /// Next 64 random bits (SplitMix64: `mix64` adds the golden-ratio increment itself).
    pub fn next_u64(&mut self) -> u64 {
        let z = mix64(self.state);
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller, one value per call).
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Sample times `0, 1/rate, …` strictly below `duration_s`, then `duration_s` itself.
fn time_grid(duration_s: f64, rate_hz: f64) -> Result<Vec<f64>> {
    check_range_open_lo("rate_hz", rate_hz, 0.0, MAX_RATE_HZ)?;
    check_range("duration_s", duration_s, 0.0, f64::INFINITY)?;
    let n = (duration_s * rate_hz - 1e-9).ceil().max(0.0);
    if n + 1.0 > MAX_SAMPLES as f64 {
        return Err(FoveaError::ResourceLimit {
            what: "synthetic gaze trajectory".into(),
            needed: format!("{} samples", n + 1.0),
            limit: format!("{MAX_SAMPLES} samples"),
        });
    }
    let n = n as usize;
    let mut t: Vec<f64> = (0..n).map(|k| k as f64 / rate_hz).collect();
    if duration_s > 0.0 || t.is_empty() {
        t.push(duration_s);
    }
    Ok(t)
}

fn trajectory(
    display: &SynthDisplay,
    times: &[f64],
    mut pos: impl FnMut(usize, f64) -> (f64, f64),
) -> Result<GazeTrajectory> {
    let samples = times
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let (x, y) = display.clamp(pos(i, t));
            GazeSample::new(t, x, y)
        })
        .collect();
    GazeTrajectory::new(samples, display.width_px, display.height_px)
}

/// Main-sequence parameters (see the module docs for sources and defaults).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MainSequence {
    /// Duration slope, ms per degree. Default 2.2 (Carpenter 1988).
    pub slope_ms_per_deg: f64,
    /// Duration intercept, ms. Default 21 (Carpenter 1988).
    pub intercept_ms: f64,
    /// Asymptotic peak velocity, °/s. Default 600.
    pub v_max_deg_s: f64,
    /// Amplitude constant of the exponential, degrees. Default 10.
    pub c_deg: f64,
}

impl Default for MainSequence {
    fn default() -> Self {
        MainSequence {
            slope_ms_per_deg: 2.2,
            intercept_ms: 21.0,
            v_max_deg_s: 600.0,
            c_deg: 10.0,
        }
    }
}

/// Peak-to-mean ratios of the bells `p_0 … p_4`.
const BELL_PEAKS: [f64; 5] = [1.0, 1.5, 1.875, 2.1875, 2.460_937_5];

/// `∫₀^τ p_k`, the smoothstep polynomials.
fn bell_position(k: usize, t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    match k {
        0 => t,
        1 => t * t * (3.0 - 2.0 * t),
        2 => t * t * t * (10.0 + t * (-15.0 + 6.0 * t)),
        3 => t.powi(4) * (35.0 + t * (-84.0 + t * (70.0 - 20.0 * t))),
        _ => t.powi(5) * (126.0 + t * (-420.0 + t * (540.0 + t * (-315.0 + 70.0 * t)))),
    }
}

impl MainSequence {
    fn validate(&self) -> Result<()> {
        check_range_open_lo("slope_ms_per_deg", self.slope_ms_per_deg, 0.0, 1e3)?;
        check_range_open_lo("intercept_ms", self.intercept_ms, 0.0, 1e4)?;
        check_range_open_lo("v_max_deg_s", self.v_max_deg_s, 0.0, 1e5)?;
        check_range_open_lo("c_deg", self.c_deg, 0.0, 1e3)?;
        Ok(())
    }

    /// `D = slope·A + intercept`, in seconds, for amplitude `A` in degrees.
    pub fn duration_s(&self, amplitude_deg: f64) -> f64 {
        (self.slope_ms_per_deg * amplitude_deg + self.intercept_ms) * 1e-3
    }

    /// `V_p = V_max·(1 − e^{−A/C})`, °/s.
    pub fn peak_velocity_deg_s(&self, amplitude_deg: f64) -> f64 {
        self.v_max_deg_s * -(-amplitude_deg / self.c_deg).exp_m1()
    }

    /// Peak-to-mean velocity ratio `r = V_p·D/A` (its limit `V_max·D(0)/C` at `A = 0`).
    pub fn peak_to_mean(&self, amplitude_deg: f64) -> f64 {
        if amplitude_deg < 1e-9 {
            self.v_max_deg_s * self.duration_s(0.0) / self.c_deg
        } else {
            self.peak_velocity_deg_s(amplitude_deg) * self.duration_s(amplitude_deg) / amplitude_deg
        }
    }

    /// The saccade's normalised position `s(τ)` in [0, 1] for `τ = t/D` in [0, 1]: the blended
    /// bell of the module docs. Errors if the ratio is outside `[1, 2.4609]`.
    pub fn profile(&self, amplitude_deg: f64) -> Result<impl Fn(f64) -> f64> {
        self.validate()?;
        check_range("saccade amplitude_deg", amplitude_deg, 0.0, 360.0)?;
        let r = self.peak_to_mean(amplitude_deg);
        let (lo, hi) = (BELL_PEAKS[0], BELL_PEAKS[4]);
        if !(lo..=hi).contains(&r) {
            return Err(FoveaError::invalid(
                format!("main sequence at A = {amplitude_deg}°: peak/mean velocity V_p·D/A"),
                r,
                format!(
                    "a ratio in [{lo}, {hi}]: V_p = V_max(1 − e^(−A/C)) must exceed the mean \
                     velocity A/D and not exceed {hi}× it; adjust v_max_deg_s / c_deg"
                ),
            ));
        }
        let k = (0..4).find(|&k| r <= BELL_PEAKS[k + 1]).unwrap_or(3);
        let w = (r - BELL_PEAKS[k]) / (BELL_PEAKS[k + 1] - BELL_PEAKS[k]);
        Ok(move |tau: f64| (1.0 - w) * bell_position(k, tau) + w * bell_position(k + 1, tau))
    }
}

/// A saccade from `from_px` to `to_px` (both on screen), sampled at `rate_hz` from `t = 0` to
/// exactly `t = D(A)`, with `A` the distance in degrees: starts exactly at `from_px`, ends
/// exactly at `to_px`, peak velocity `V_p(A)` at `D/2`.
pub fn saccade(
    display: &SynthDisplay,
    from_px: (f64, f64),
    to_px: (f64, f64),
    ms: &MainSequence,
    rate_hz: f64,
) -> Result<GazeTrajectory> {
    display.check_point("saccade from_px", from_px)?;
    display.check_point("saccade to_px", to_px)?;
    let a_deg = display.distance_deg(from_px, to_px);
    let s = ms.profile(a_deg)?;
    let d_s = ms.duration_s(a_deg);
    let times = time_grid(d_s, rate_hz)?;
    let last = times.len() - 1;
    trajectory(display, &times, |i, t| {
        if i == last {
            return to_px;
        }
        let f = s(t / d_s);
        (
            from_px.0 + (to_px.0 - from_px.0) * f,
            from_px.1 + (to_px.1 - from_px.1) * f,
        )
    })
}

/// Fixational eye movements (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixationParams {
    /// Drift diffusion coefficient, deg²/s, ≥ 0. Default 0.01 deg²/s (36 arcmin²/s, the order of
    /// published estimates of ocular drift; not tied to one study). 0 disables drift.
    pub drift_diffusion_deg2_s: f64,
    /// Tremor: per-sample Gaussian jitter, standard deviation in degrees per axis, ≥ 0. Default
    /// 0.005° (18 arcsec, below any display's pixel). 0 disables it.
    pub tremor_sigma_deg: f64,
}

impl Default for FixationParams {
    fn default() -> Self {
        FixationParams {
            drift_diffusion_deg2_s: 0.01,
            tremor_sigma_deg: 0.005,
        }
    }
}

impl FixationParams {
    /// No drift, no tremor: the gaze holds the point exactly.
    pub fn still() -> Self {
        FixationParams {
            drift_diffusion_deg2_s: 0.0,
            tremor_sigma_deg: 0.0,
        }
    }
}

/// A fixation at `point_px` (on screen) for `duration_s` (> 0), sampled at `rate_hz`.
pub fn fixation(
    display: &SynthDisplay,
    point_px: (f64, f64),
    duration_s: f64,
    params: &FixationParams,
    rate_hz: f64,
    seed: u64,
) -> Result<GazeTrajectory> {
    display.check_point("fixation point_px", point_px)?;
    check_range_open_lo("fixation duration_s", duration_s, 0.0, f64::INFINITY)?;
    check_range(
        "drift_diffusion_deg2_s",
        params.drift_diffusion_deg2_s,
        0.0,
        1e4,
    )?;
    check_range("tremor_sigma_deg", params.tremor_sigma_deg, 0.0, 1e3)?;
    let times = time_grid(duration_s, rate_hz)?;
    let mut rng = Rng::new(seed);
    let ppd = display.px_per_deg;
    let mut drift = (0.0, 0.0);
    let mut t_prev = 0.0;
    trajectory(display, &times, |i, t| {
        if i == 0 {
            return point_px;
        }
        let sd_px = (2.0 * params.drift_diffusion_deg2_s * (t - t_prev)).sqrt() * ppd;
        t_prev = t;
        drift.0 += sd_px * rng.normal();
        drift.1 += sd_px * rng.normal();
        let tremor_px = params.tremor_sigma_deg * ppd;
        (
            point_px.0 + drift.0 + tremor_px * rng.normal(),
            point_px.1 + drift.1 + tremor_px * rng.normal(),
        )
    })
}

/// The path of a smooth pursuit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PursuitPath {
    /// Straight from one on-screen point to another.
    Line {
        /// Start, pixels.
        from_px: (f64, f64),
        /// End, pixels.
        to_px: (f64, f64),
    },
    /// A circular arc `centre + radius·(cos θ, sin θ)` (pixels, y down, so positive sweep turns
    /// clockwise on screen), `θ` from `start_angle_deg` over `sweep_deg` (either sign).
    Circle {
        /// Centre, pixels.
        centre_px: (f64, f64),
        /// Radius in degrees of visual angle, > 0.
        radius_deg: f64,
        /// Start angle, degrees.
        start_angle_deg: f64,
        /// Swept angle, degrees (negative: counter-clockwise on screen).
        sweep_deg: f64,
    },
}

/// Smooth pursuit along `path` at constant angular speed `speed_deg_s` (> 0, ≤ 1000 °/s),
/// sampled at `rate_hz`, lasting `length_deg / speed`; positions off the screen are clamped.
pub fn smooth_pursuit(
    display: &SynthDisplay,
    path: &PursuitPath,
    speed_deg_s: f64,
    rate_hz: f64,
) -> Result<GazeTrajectory> {
    check_range_open_lo("pursuit speed_deg_s", speed_deg_s, 0.0, 1000.0)?;
    match *path {
        PursuitPath::Line { from_px, to_px } => {
            display.check_point("pursuit from_px", from_px)?;
            display.check_point("pursuit to_px", to_px)?;
            let d_s = display.distance_deg(from_px, to_px) / speed_deg_s;
            let times = time_grid(d_s, rate_hz)?;
            let last = times.len() - 1;
            trajectory(display, &times, |i, t| {
                if i == last {
                    return to_px;
                }
                let f = if d_s > 0.0 { t / d_s } else { 0.0 };
                (
                    from_px.0 + (to_px.0 - from_px.0) * f,
                    from_px.1 + (to_px.1 - from_px.1) * f,
                )
            })
        }
        PursuitPath::Circle {
            centre_px,
            radius_deg,
            start_angle_deg,
            sweep_deg,
        } => {
            if !(centre_px.0.is_finite() && centre_px.1.is_finite()) {
                return Err(FoveaError::invalid(
                    "pursuit centre_px",
                    format!("{centre_px:?}"),
                    "finite pixel coordinates",
                ));
            }
            check_range_open_lo("pursuit radius_deg", radius_deg, 0.0, 360.0)?;
            check_range("pursuit start_angle_deg", start_angle_deg, -1e6, 1e6)?;
            check_range("pursuit sweep_deg", sweep_deg, -1e6, 1e6)?;
            let d_s = radius_deg * sweep_deg.abs().to_radians() / speed_deg_s;
            let times = time_grid(d_s, rate_hz)?;
            let r_px = radius_deg * display.px_per_deg;
            trajectory(display, &times, |_, t| {
                let f = if d_s > 0.0 { t / d_s } else { 0.0 };
                let th = (start_angle_deg + sweep_deg * f).to_radians();
                (centre_px.0 + r_px * th.cos(), centre_px.1 + r_px * th.sin())
            })
        }
    }
}

/// Liu's Gaussian-velocity random walk (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RandomWalkParams {
    /// Standard deviation of each velocity component, °/s. Default 10 (our choice; the paper
    /// gives no value).
    pub sigma_deg_s: f64,
    /// Step between velocity draws (and samples), seconds. Default 1/90 (a 90 Hz frame).
    pub step_s: f64,
    /// Length of the walk, seconds. Default 10.
    pub duration_s: f64,
}

impl Default for RandomWalkParams {
    fn default() -> Self {
        RandomWalkParams {
            sigma_deg_s: 10.0,
            step_s: 1.0 / 90.0,
            duration_s: 10.0,
        }
    }
}

fn reflect(v: f64, hi: f64) -> f64 {
    // Fold onto [0, hi] (mirror at both edges, any number of times).
    let period = 2.0 * hi;
    let m = v.rem_euclid(period);
    if m > hi {
        period - m
    } else {
        m
    }
}

/// The random walk from `start_px` (on screen): every `step_s` a velocity
/// `v ~ N(0, sigma²)` per axis (°/s) moves the gaze by `v·step_s`, mirrored at the screen
/// edges. Samples at `k·step_s`, the last at `duration_s`.
pub fn random_walk(
    display: &SynthDisplay,
    start_px: (f64, f64),
    params: &RandomWalkParams,
    seed: u64,
) -> Result<GazeTrajectory> {
    display.check_point("random walk start_px", start_px)?;
    check_range("random walk sigma_deg_s", params.sigma_deg_s, 0.0, 1e4)?;
    check_range_open_lo("random walk step_s", params.step_s, 0.0, 10.0)?;
    check_range_open_lo("random walk duration_s", params.duration_s, 0.0, 1e7)?;
    let times = time_grid(params.duration_s, 1.0 / params.step_s)?;
    let mut rng = Rng::new(seed);
    let mut p = start_px;
    let mut t_prev = 0.0;
    let sd = params.sigma_deg_s * display.px_per_deg;
    trajectory(display, &times, |i, t| {
        if i > 0 {
            let dt = t - t_prev;
            p.0 = reflect(p.0 + sd * rng.normal() * dt, display.width_px);
            p.1 = reflect(p.1 + sd * rng.normal() * dt, display.height_px);
        }
        t_prev = t;
        p
    })
}

/// One part of a [`Scenario`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Segment {
    /// Hold the current point.
    Fixation {
        /// Seconds, > 0.
        duration_s: f64,
        /// Drift and tremor.
        params: FixationParams,
    },
    /// Main-sequence saccade to a point.
    SaccadeTo {
        /// Target, pixels.
        to_px: (f64, f64),
    },
    /// Straight pursuit to a point.
    PursuitTo {
        /// Target, pixels.
        to_px: (f64, f64),
        /// °/s.
        speed_deg_s: f64,
    },
    /// Circular pursuit around a centre, starting from the current point.
    PursuitCircle {
        /// Centre, pixels.
        centre_px: (f64, f64),
        /// Swept angle, degrees.
        sweep_deg: f64,
        /// °/s.
        speed_deg_s: f64,
    },
    /// Liu's random walk from the current point.
    RandomWalk {
        /// Walk parameters.
        params: RandomWalkParams,
    },
}

/// Builds one trajectory from fixations, saccades, pursuits and random walks, each starting
/// where the previous one ended, sampled at `rate_hz` (the random walk at its own step), kept on
/// the screen by clamping. Segment `i` draws from seed `mix64(seed ^ i)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Geometry.
    pub display: SynthDisplay,
    /// Starting gaze, pixels (on screen).
    pub start_px: (f64, f64),
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Seed of all random parts.
    pub seed: u64,
    /// Main-sequence parameters for the saccades.
    pub main_sequence: MainSequence,
    /// The parts, in order.
    pub segments: Vec<Segment>,
}

impl Scenario {
    /// An empty scenario (building it gives the single start sample).
    pub fn new(display: SynthDisplay, start_px: (f64, f64), rate_hz: f64, seed: u64) -> Self {
        Scenario {
            display,
            start_px,
            rate_hz,
            seed,
            main_sequence: MainSequence::default(),
            segments: Vec::new(),
        }
    }

    /// Appends a fixation with default drift and tremor.
    pub fn fixation(self, duration_s: f64) -> Self {
        self.fixation_with(duration_s, FixationParams::default())
    }

    /// Appends a fixation with the given fixational movements.
    pub fn fixation_with(mut self, duration_s: f64, params: FixationParams) -> Self {
        self.segments.push(Segment::Fixation { duration_s, params });
        self
    }

    /// Appends a saccade.
    pub fn saccade_to(mut self, to_px: (f64, f64)) -> Self {
        self.segments.push(Segment::SaccadeTo { to_px });
        self
    }

    /// Appends a straight pursuit.
    pub fn pursuit_to(mut self, to_px: (f64, f64), speed_deg_s: f64) -> Self {
        self.segments
            .push(Segment::PursuitTo { to_px, speed_deg_s });
        self
    }

    /// Appends a circular pursuit around `centre_px` (radius: the current distance to it).
    pub fn pursuit_circle(mut self, centre_px: (f64, f64), sweep_deg: f64, speed: f64) -> Self {
        self.segments.push(Segment::PursuitCircle {
            centre_px,
            sweep_deg,
            speed_deg_s: speed,
        });
        self
    }

    /// Appends a random walk.
    pub fn random_walk(mut self, params: RandomWalkParams) -> Self {
        self.segments.push(Segment::RandomWalk { params });
        self
    }

    /// Generates the trajectory (times from 0).
    pub fn build(&self) -> Result<GazeTrajectory> {
        let d = &self.display;
        d.check_point("scenario start_px", self.start_px)?;
        check_range_open_lo("rate_hz", self.rate_hz, 0.0, MAX_RATE_HZ)?;
        let mut out = vec![GazeSample::new(0.0, self.start_px.0, self.start_px.1)];
        let mut cur = self.start_px;
        for (i, seg) in self.segments.iter().enumerate() {
            let seed = mix64(self.seed ^ i as u64);
            let part = match *seg {
                Segment::Fixation { duration_s, params } => {
                    fixation(d, cur, duration_s, &params, self.rate_hz, seed)?
                }
                Segment::SaccadeTo { to_px } => {
                    saccade(d, cur, to_px, &self.main_sequence, self.rate_hz)?
                }
                Segment::PursuitTo { to_px, speed_deg_s } => smooth_pursuit(
                    d,
                    &PursuitPath::Line {
                        from_px: cur,
                        to_px,
                    },
                    speed_deg_s,
                    self.rate_hz,
                )?,
                Segment::PursuitCircle {
                    centre_px,
                    sweep_deg,
                    speed_deg_s,
                } => {
                    let radius_deg = d.distance_deg(centre_px, cur);
                    let start = (cur.1 - centre_px.1).atan2(cur.0 - centre_px.0);
                    smooth_pursuit(
                        d,
                        &PursuitPath::Circle {
                            centre_px,
                            radius_deg,
                            start_angle_deg: start.to_degrees(),
                            sweep_deg,
                        },
                        speed_deg_s,
                        self.rate_hz,
                    )?
                }
                Segment::RandomWalk { params } => random_walk(d, cur, &params, seed)?,
            };
            let t0 = out.last().map_or(0.0, |s| s.t_s);
            if out.len() + part.len() > MAX_SAMPLES {
                return Err(FoveaError::ResourceLimit {
                    what: "synthetic gaze scenario".into(),
                    needed: format!("{} samples", out.len() + part.len()),
                    limit: format!("{MAX_SAMPLES} samples"),
                });
            }
            // The part's first sample is the current point at the current time: skip it.
            out.extend(part.samples().iter().skip(1).map(|s| GazeSample {
                t_s: t0 + s.t_s,
                ..*s
            }));
            let last = out[out.len() - 1];
            cur = (last.x_px, last.y_px);
        }
        GazeTrajectory::new(out, d.width_px, d.height_px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disp() -> SynthDisplay {
        SynthDisplay::new(4000.0, 3000.0, 40.0).unwrap()
    }

    /// Largest speed between consecutive samples, in °/s.
    fn peak_speed_deg_s(t: &GazeTrajectory, ppd: f64) -> f64 {
        t.samples()
            .windows(2)
            .map(|w| {
                (w[1].x_px - w[0].x_px).hypot(w[1].y_px - w[0].y_px) / ppd / (w[1].t_s - w[0].t_s)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn main_sequence_numbers() {
        let ms = MainSequence::default();
        assert!((ms.duration_s(10.0) - 0.043).abs() < 1e-15);
        assert!((ms.peak_velocity_deg_s(10.0) - 600.0 * (1.0 - (-1.0f64).exp())).abs() < 1e-9);
        assert!((ms.peak_to_mean(0.0) - 1.26).abs() < 1e-12);
        // The example parameters contradict the duration law at small amplitudes.
        let slow = MainSequence {
            v_max_deg_s: 500.0,
            c_deg: 14.0,
            ..Default::default()
        };
        assert!(slow.peak_to_mean(2.0) < 1.0);
        assert!(slow.profile(2.0).is_err());
        assert!(slow.profile(20.0).is_ok());
        // Every bell blend has unit area and s(½) = ½ by symmetry.
        for (k, &peak) in BELL_PEAKS.iter().enumerate() {
            assert!((bell_position(k, 1.0) - 1.0).abs() < 1e-12);
            assert!((bell_position(k, 0.5) - 0.5).abs() < 1e-12);
            // Peak ratio: central difference of the position at τ = ½.
            let h = 1e-6;
            let v = (bell_position(k, 0.5 + h) - bell_position(k, 0.5 - h)) / (2.0 * h);
            assert!((v - peak).abs() < 1e-6, "k={k} v={v}");
        }
    }

    #[test]
    fn saccades_follow_the_main_sequence() {
        let d = disp();
        let ms = MainSequence::default();
        let from = (500.0, 1500.0);
        for &a_deg in &[2.0, 5.0, 10.0, 15.0, 20.0, 30.0] {
            // Diagonal saccade of a_deg degrees.
            let l = a_deg * d.px_per_deg / 2f64.sqrt();
            let to = (from.0 + l, from.1 - l);
            for &(rate, tol) in &[(1000.0, 0.03), (100_000.0, 1e-4)] {
                let s = saccade(&d, from, to, &ms, rate).unwrap();
                let first = s.samples()[0];
                let last = s.samples()[s.len() - 1];
                assert_eq!((first.x_px, first.y_px), from);
                assert_eq!((last.x_px, last.y_px), to);
                let d_expect = (2.2 * a_deg + 21.0) * 1e-3;
                assert!((s.duration_s() - d_expect).abs() < 1e-12, "A={a_deg}");
                let vp_expect = 600.0 * (1.0 - (-a_deg / 10.0).exp());
                let vp = peak_speed_deg_s(&s, d.px_per_deg);
                assert!(
                    vp <= vp_expect * (1.0 + 1e-9),
                    "A={a_deg}: {vp} > {vp_expect}"
                );
                assert!(
                    (vp - vp_expect).abs() < tol * vp_expect,
                    "A={a_deg} rate={rate}: peak {vp} vs {vp_expect}"
                );
                // Monotone progress towards the target.
                let prog: Vec<f64> = s.samples().iter().map(|p| p.x_px).collect();
                assert!(prog.windows(2).all(|w| w[1] >= w[0]));
            }
        }
        assert!(saccade(&d, from, (5000.0, 0.0), &ms, 1000.0).is_err());
        assert!(saccade(&d, from, from, &ms, 1000.0).unwrap().duration_s() > 0.0209);
        assert!(saccade(&d, from, (600.0, 1500.0), &ms, 0.0).is_err());
    }

    #[test]
    fn pursuit_speed_is_constant() {
        let d = disp();
        let line = PursuitPath::Line {
            from_px: (100.0, 100.0),
            to_px: (1300.0, 1000.0),
        };
        let p = smooth_pursuit(&d, &line, 15.0, 1000.0).unwrap();
        let len_deg = 1500.0 / 40.0;
        assert!((p.duration_s() - len_deg / 15.0).abs() < 1e-12);
        for w in p.samples().windows(2) {
            let v =
                (w[1].x_px - w[0].x_px).hypot(w[1].y_px - w[0].y_px) / 40.0 / (w[1].t_s - w[0].t_s);
            assert!((v - 15.0).abs() < 1e-6, "{v}");
        }
        let last = p.samples()[p.len() - 1];
        assert_eq!((last.x_px, last.y_px), (1300.0, 1000.0));
        let circle = PursuitPath::Circle {
            centre_px: (2000.0, 1500.0),
            radius_deg: 5.0,
            start_angle_deg: 0.0,
            sweep_deg: 360.0,
        };
        let c = smooth_pursuit(&d, &circle, 20.0, 1000.0).unwrap();
        assert!((c.duration_s() - 2.0 * std::f64::consts::PI * 5.0 / 20.0).abs() < 1e-12);
        for w in c.samples().windows(2) {
            let dt = w[1].t_s - w[0].t_s;
            let chord = (w[1].x_px - w[0].x_px).hypot(w[1].y_px - w[0].y_px) / 40.0;
            // Chord of an arc of angle θ: 2R·sin(θ/2) ≈ arc·(1 − θ²/24); θ ≤ 0.004 rad here.
            assert!((chord / dt - 20.0).abs() < 20.0 * 1e-5, "{}", chord / dt);
        }
        for s in c.samples() {
            let r = (s.x_px - 2000.0).hypot(s.y_px - 1500.0);
            assert!((r - 200.0).abs() < 1e-9);
        }
        assert!(smooth_pursuit(&d, &line, 0.0, 1000.0).is_err());
    }

    #[test]
    fn random_walk_velocity_std_matches_sigma() {
        // A screen big enough that the mirror at the edges never acts.
        let d = SynthDisplay::new(1.0e6, 1.0e6, 20.0).unwrap();
        let params = RandomWalkParams {
            sigma_deg_s: 10.0,
            step_s: 1.0 / 90.0,
            duration_s: 2000.0,
        };
        let w = random_walk(&d, (5.0e5, 5.0e5), &params, 42).unwrap();
        assert_eq!(w.len(), 180_001);
        let (mut n, mut sum, mut sum2) = (0.0, 0.0, 0.0);
        for p in w.samples().windows(2) {
            let dt = p[1].t_s - p[0].t_s;
            for v in [(p[1].x_px - p[0].x_px), (p[1].y_px - p[0].y_px)] {
                let v = v / 20.0 / dt;
                n += 1.0;
                sum += v;
                sum2 += v * v;
            }
        }
        let mean = sum / n;
        let std = (sum2 / n - mean * mean).sqrt();
        // n = 360 000 draws: the std estimate's own sd is σ/√(2n) ≈ 0.012 °/s; allow 1 %.
        assert!((std - 10.0).abs() < 0.1, "std {std}");
        assert!(mean.abs() < 0.1, "mean {mean}");
        // Same seed, same walk; another seed, another walk.
        let short = RandomWalkParams {
            duration_s: 1.0,
            ..params
        };
        assert_eq!(
            random_walk(&d, (5.0e5, 5.0e5), &short, 7).unwrap(),
            random_walk(&d, (5.0e5, 5.0e5), &short, 7).unwrap()
        );
        assert_ne!(
            random_walk(&d, (5.0e5, 5.0e5), &short, 7).unwrap(),
            random_walk(&d, (5.0e5, 5.0e5), &short, 8).unwrap()
        );
    }

    #[test]
    fn random_walk_stays_on_a_small_screen() {
        let d = SynthDisplay::new(100.0, 50.0, 20.0).unwrap();
        let w = random_walk(&d, (50.0, 25.0), &RandomWalkParams::default(), 3).unwrap();
        for s in w.samples() {
            assert!((0.0..=100.0).contains(&s.x_px) && (0.0..=50.0).contains(&s.y_px));
        }
        assert_eq!(reflect(-3.0, 10.0), 3.0);
        assert_eq!(reflect(13.0, 10.0), 7.0);
        assert_eq!(reflect(25.0, 10.0), 5.0);
    }

    #[test]
    fn fixation_drift_diffusion_and_still() {
        let d = disp();
        let still = fixation(&d, (10.0, 20.0), 0.5, &FixationParams::still(), 1000.0, 1).unwrap();
        assert_eq!(still.len(), 501);
        assert!(still
            .samples()
            .iter()
            .all(|s| s.x_px == 10.0 && s.y_px == 20.0));
        // Drift only: mean squared step per axis = 2·D·dt.
        let p = FixationParams {
            drift_diffusion_deg2_s: 0.01,
            tremor_sigma_deg: 0.0,
        };
        let f = fixation(&d, (2000.0, 1500.0), 100.0, &p, 1000.0, 9).unwrap();
        let (mut n, mut s2) = (0.0, 0.0);
        for w in f.samples().windows(2) {
            for dx in [w[1].x_px - w[0].x_px, w[1].y_px - w[0].y_px] {
                n += 1.0;
                s2 += (dx / 40.0).powi(2);
            }
        }
        let d_est = s2 / n / (2.0 * 1e-3);
        // 200 000 squared normals: relative sd √(2/n) ≈ 0.3 %; allow 2 %.
        assert!((d_est - 0.01).abs() < 2e-4, "{d_est}");
        assert!(fixation(&d, (10.0, 20.0), 0.0, &p, 1000.0, 1).is_err());
        assert!(fixation(&d, (-1.0, 20.0), 1.0, &p, 1000.0, 1).is_err());
    }

    #[test]
    fn scenario_concatenates_deterministically() {
        let d = disp();
        let sc = Scenario::new(d, (2000.0, 1500.0), 1000.0, 11)
            .fixation(0.3)
            .saccade_to((2400.0, 1500.0))
            .fixation_with(0.2, FixationParams::still())
            .pursuit_to((2800.0, 1500.0), 10.0)
            .pursuit_circle((2800.0, 1300.0), 90.0, 10.0)
            .random_walk(RandomWalkParams {
                duration_s: 1.0,
                ..Default::default()
            })
            .saccade_to((3999.0, 2999.0));
        let t = sc.build().unwrap();
        assert_eq!(t, sc.build().unwrap());
        let other = Scenario {
            seed: 12,
            ..sc.clone()
        }
        .build()
        .unwrap();
        assert_ne!(t, other);
        // Duration: 0.3 + D(10°) + 0.2 + 1 s pursuit + quarter circle of 5° at 10 °/s + 1 + D(…).
        let fixed = 0.3 + 0.043 + 0.2 + 1.0 + (5.0 * std::f64::consts::FRAC_PI_2) / 10.0 + 1.0;
        assert!(t.duration_s() > fixed + 0.021);
        let last = t.samples()[t.len() - 1];
        assert_eq!((last.x_px, last.y_px), (3999.0, 2999.0));
        // The saccade lands exactly; the still fixation holds exactly.
        let s = t.at(0.3 + 0.043 + 0.1);
        assert_eq!((s.x_px, s.y_px), (2400.0, 1500.0));
        for s in t.samples() {
            assert!((0.0..=4000.0).contains(&s.x_px) && (0.0..=3000.0).contains(&s.y_px));
        }
        assert!(Scenario::new(d, (-5.0, 0.0), 1000.0, 0).build().is_err());
        assert_eq!(
            Scenario::new(d, (5.0, 0.0), 1000.0, 0)
                .build()
                .unwrap()
                .len(),
            1
        );
        let from_profile =
            SynthDisplay::from_profile(&DisplayProfile::preset("vive-pro-eye").unwrap());
        assert!(from_profile.px_per_deg > 5.0);
    }
}
