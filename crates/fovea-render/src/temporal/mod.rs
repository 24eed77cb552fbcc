//! Temporal accumulation across the frames of a sequence: the previous frame's shading is
//! reprojected to the current frame and folded into a running estimate, so that peripheral
//! samples, which are few and change with every gaze or camera move, stop flickering.
//!
//! Two paths, chosen by the method:
//!
//! * [`sample_space`] — log-polar and other buffer methods (VaFR's stated limitation is
//!   flicker): each frame's samples are jittered by a sub-texel Halton offset in sample space,
//!   and every texel of the new buffer fetches the previous *buffer* (its own mapping, gaze and
//!   camera) at the reprojected position, bilinearly, with depth rejection and a clamp to the
//!   new neighbourhood's colour range.
//! * [`weier_taa`] — Weier et al. 2018, Sec. 3.1: each ray-cast pixel of the sparse pattern
//!   fetches the previous frame's *reconstructed* image, stored as a mip pyramid with depth in
//!   the alpha channel, at its reprojected position with five Quincunx taps at the mip level of
//!   the sample's footprint; each tap's weight falls with its depth difference to the new
//!   sample. The pull-push reconstruction then fills the screen from the smoothed samples.
//!
//! **Reprojection.** A texel's screen point `p` (its centre through the inverse mapping) and
//! its depth `z` give the world point `P = o + d·z/(d·f)` (`d` the ray direction, `f` the view
//! axis); `P` seen from the previous camera is the previous screen point `q` and the expected
//! previous depth `z' = (P − o')·f'`. Misses (sky) reproject as directions, with `z' = ∞`.
//!
//! **Running estimate** (shared by both paths). The history colour `h` is the depth-weighted
//! mean of the taps and `v ∈ [0, 1]` their total weight (bilinear or Quincunx weight × depth
//! agreement, 1 when `|Δz| ≤ τ·z'`, 0 from `2τ·z'`, linear between). With `n` the number of
//! frames the history already holds, the new sample's weight is
//! `α = 1 − (1 − max(α_min, 1/(n + 1)))·v`: a plain average while the history is young, an
//! exponential average with the user-set minimum weight `α_min` after that, and the new sample
//! alone where the history was rejected. `n` restarts at 1 where `v < ½`.

pub mod sample_space;
pub mod weier_taa;

use serde::Serialize;

use fovea_core::display::Gaze;
use fovea_core::mapping::{FoveationMapping, Method};
use fovea_core::math::halton2;
use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;
use glam::Vec3;

use crate::camera::EyeCamera;
use crate::error::{RenderError, Result};
use crate::plan::FramePlan;

pub use fovea_core::mapping::footprint::SpacingLut;

/// Depth stored for misses where a finite value is needed (mip averages, comparisons).
pub(crate) const SKY_DEPTH_M: f32 = 1.0e9;

/// Jitter cycle length (Halton 2, 3 points).
pub const JITTER_PERIOD: u64 = 16;

/// Frames a texel's history must hold before its temporal variance replaces the denoiser's
/// spatial estimate (SVGF, Sec. 4.2: 4).
pub const VARIANCE_MIN_AGE: u16 = 4;

/// What the variance estimate reads and writes in [`TemporalAccumulator::accumulate`], per
/// layer: the fresh frame's exact part (its colour less the Monte Carlo part; NaN where the
/// part is unknown: the whole colour is Monte Carlo) and albedo (which demodulates the light,
/// `fovea_post::denoise::demodulate`), and the variance written for the denoiser
/// (`fovea_post::denoise::DenoiseGuides::variance`: NaN where the history is too short).
pub struct MonteCarloPart<'a> {
    /// The fresh frame's exact part per layer.
    pub exact: &'a [Image<Rgb>],
    /// The albedo per layer.
    pub albedo: &'a [Image<Rgb>],
    /// Output: the accumulated Monte Carlo luminance's variance per layer.
    pub variance: &'a mut Vec<Image<f32>>,
}

/// Options of the temporal accumulation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TemporalSettings {
    /// Smallest weight of the new sample in the running estimate (Weier's user-set minimum);
    /// `1/α_min` is about the number of frames averaged.
    pub alpha_min: f32,
    /// Relative depth difference `τ` up to which a history tap counts fully (rejected from
    /// `2τ`).
    pub depth_tolerance: f32,
    /// Sub-texel Halton jitter of the samples in sample space (not for Weier's pattern, whose
    /// `S_out` is static by design). Off by default: it anti-aliases a still frame over the
    /// jitter cycle, but in motion the per-frame change it adds to the large peripheral
    /// texels outweighs what accumulation removes (docs/sequences.md has the measurements).
    pub jitter: bool,
    /// Clamp the history colour to the range of the new sample's 3×3 neighbourhood (in sample
    /// space), which removes ghosts of changed shading.
    pub clamp: bool,
    /// Keep the temporal moments of the Monte Carlo part's luminance and give the denoiser
    /// their per-sample variance (SVGF Sec. 4.2) where a texel's history holds at least
    /// [`VARIANCE_MIN_AGE`] frames (buffer methods, with the denoiser on); off: the
    /// denoiser's spatial estimate everywhere.
    pub variance: bool,
}

impl Default for TemporalSettings {
    fn default() -> Self {
        Self {
            alpha_min: 0.1,
            depth_tolerance: 0.03,
            jitter: false,
            clamp: true,
            variance: true,
        }
    }
}

impl TemporalSettings {
    /// Checks the ranges: `α_min` in (0, 1], `τ` in (0, 1].
    pub fn validate(&self) -> Result<()> {
        if !(self.alpha_min > 0.0 && self.alpha_min <= 1.0) {
            return Err(RenderError::invalid(
                "alpha-min",
                self.alpha_min,
                "a weight in (0, 1], e.g. 0.1",
            ));
        }
        if !(self.depth_tolerance > 0.0 && self.depth_tolerance <= 1.0) {
            return Err(RenderError::invalid(
                "depth-tolerance",
                self.depth_tolerance,
                "a relative depth difference in (0, 1], e.g. 0.03",
            ));
        }
        Ok(())
    }

    /// The sample-space jitter of the frame accumulated after `frame` others, in buffer
    /// texels (zero for Weier's pattern and when jitter is off): the Halton (2, 3) point
    /// `frame mod 16 + 1`, centred — what [`TemporalAccumulator::jitter`] gives at its
    /// `frame()`, for an accumulator kept elsewhere (the resident GPU frame's).
    pub fn jitter_at(&self, method: Method, frame: u64) -> [f64; 2] {
        if !self.jitter || method == Method::Weier {
            return [0.0, 0.0];
        }
        let (a, b) = halton2(frame % JITTER_PERIOD + 1, (0.0, 0.0));
        [a - 0.5, b - 0.5]
    }
}

/// What the accumulation did in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TemporalStats {
    /// Samples blended with a history value.
    pub reused: u64,
    /// Samples whose history was rejected (off screen, outside the previous buffer, depth
    /// mismatch) or that had none (first frame).
    pub fresh: u64,
    /// The jitter used, buffer texels.
    pub jitter: [f64; 2],
}

/// The previous frame, as each path needs it.
enum History {
    Samples(sample_space::SampleHistory),
    Pyramid(weier_taa::PyramidHistory),
}

/// Temporal state carried from frame to frame of one sequence (one per method and eye).
pub struct TemporalAccumulator {
    settings: TemporalSettings,
    frame: u64,
    history: Option<History>,
    /// Method of the history; a change of method resets.
    method: Option<Method>,
    /// Weier path: ages of this frame's samples, until [`finish`](Self::finish) stores them.
    weier_ages: Option<(fovea_core::Image<u16>, SpacingLut, Gaze)>,
    last: TemporalStats,
}

impl TemporalAccumulator {
    /// A fresh accumulator.
    pub fn new(settings: TemporalSettings) -> Result<Self> {
        settings.validate()?;
        Ok(Self {
            settings,
            frame: 0,
            history: None,
            method: None,
            weier_ages: None,
            last: TemporalStats::default(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &TemporalSettings {
        &self.settings
    }

    /// Forgets the history (a cut in the sequence).
    pub fn reset(&mut self) {
        self.history = None;
        self.method = None;
    }

    /// The previous frame of a buffer method, if the accumulator holds one (for analysis:
    /// [`sample_space::SampleHistory::lookup`]).
    pub fn sample_history(&self) -> Option<&sample_space::SampleHistory> {
        match &self.history {
            Some(History::Samples(h)) => Some(h),
            _ => None,
        }
    }

    /// Frames accumulated so far (the index of the next frame).
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Statistics of the last frame.
    pub fn last_stats(&self) -> TemporalStats {
        self.last
    }

    /// The sample-space jitter of the next frame, in buffer texels (zero for Weier's pattern
    /// and when jitter is off): the Halton (2, 3) point `frame mod 16 + 1`, centred.
    pub fn jitter(&self, method: Method) -> [f64; 2] {
        self.settings.jitter_at(method, self.frame)
    }

    /// Blends the previous frame into this frame's freshly shaded samples (before AA) of the
    /// frame `plan` (its mapping, gaze, spacing table and jitter), seen by `camera`.
    ///
    /// With `part` (the denoiser is on) and [`TemporalSettings::variance`], buffer methods
    /// keep the temporal moments of the Monte Carlo part's demodulated luminance in the
    /// history and write its variance into `part.variance` ([`moments_variance`], NaN where
    /// a texel's history holds fewer than [`VARIANCE_MIN_AGE`] frames); otherwise
    /// `part.variance` is emptied (the denoiser's spatial estimate everywhere).
    pub(crate) fn accumulate(
        &mut self,
        plan: &FramePlan,
        camera: &EyeCamera,
        buffers: &mut SampleBuffers,
        part: Option<MonteCarloPart<'_>>,
    ) -> Result<TemporalStats> {
        let mapping = plan.mapping();
        let (gaze, lut) = (plan.eye.gaze, &plan.spacing);
        let method = mapping.method();
        if self.method != Some(method) {
            self.history = None;
        }
        let mut part = part;
        let estimate = self.settings.variance && method != Method::Weier;
        if let Some(p) = part.as_mut().filter(|_| !estimate) {
            p.variance.clear();
        }
        let mut stats = if method == Method::Weier {
            let (stats, ages) = match &self.history {
                Some(History::Pyramid(h)) => {
                    weier_taa::blend(h, &self.settings, mapping, camera, gaze, lut, buffers)?
                }
                _ => weier_taa::first_frame(mapping, buffers)?,
            };
            self.weier_ages = Some((ages, lut.clone(), gaze));
            stats
        } else {
            // The fresh frame's Monte Carlo luminance per texel, before the blend.
            let fresh = part
                .as_ref()
                .filter(|_| estimate)
                .map(|p| sample_space::monte_carlo_luma(buffers, p.exact, p.albedo))
                .transpose()?;
            let (stats, ages, moments) = match &self.history {
                Some(History::Samples(h)) => sample_space::blend(
                    h,
                    &self.settings,
                    mapping,
                    camera,
                    gaze,
                    lut,
                    buffers,
                    fresh.as_deref(),
                )?,
                _ => sample_space::first_frame(mapping, buffers, fresh.as_deref())?,
            };
            if let Some(p) = part.as_mut().filter(|_| estimate) {
                sample_space::variance_of(&moments, &ages, p.variance)?;
            }
            self.history = Some(History::Samples(sample_space::SampleHistory::new(
                plan.shared_mapping(),
                camera.clone(),
                gaze,
                lut.clone(),
                buffers,
                ages,
                moments,
            )));
            stats
        };
        stats.jitter = plan.jitter_texels;
        self.method = Some(method);
        self.last = stats;
        Ok(stats)
    }

    /// Keeps the reconstructed frame (`color`, `depth`) as Weier's history pyramid (other
    /// methods keep their sample buffers in [`accumulate`](Self::accumulate)), and advances
    /// the frame counter.
    pub(crate) fn finish(
        &mut self,
        plan: &FramePlan,
        camera: &EyeCamera,
        color: &Image<Rgb>,
        depth: &Image<f32>,
    ) -> Result<()> {
        if plan.method() == Method::Weier {
            if let Some((ages, lut, gaze)) = self.weier_ages.take() {
                let next = weier_taa::PyramidHistory::new(camera, color, depth, ages, lut, gaze)?;
                self.history = Some(History::Pyramid(next));
            }
        }
        self.frame += 1;
        Ok(())
    }
}

/// Number of shaded texels of `layer`.
pub(crate) fn shaded_count(mapping: &dyn FoveationMapping, layer: u32, w: u32, h: u32) -> u64 {
    let mut n = 0;
    for j in 0..h {
        for i in 0..w {
            n += mapping.is_shaded(layer, i, j) as u64;
        }
    }
    n
}

/// A texel's world point seen from the previous camera: `(q, z')`, the previous screen point
/// and the expected previous view depth (`∞` for misses). `None` behind the previous camera.
#[inline]
pub(crate) fn reproject(
    camera: &EyeCamera,
    previous: &EyeCamera,
    p: ScreenPoint,
    depth_m: f32,
) -> Option<(ScreenPoint, f32)> {
    let dir = camera.direction(p.x_px as f32, p.y_px as f32);
    if !depth_m.is_finite() || depth_m >= SKY_DEPTH_M {
        return previous.screen_point_of(dir).map(|q| (q, f32::INFINITY));
    }
    let cos = dir.dot(camera.forward);
    if cos <= 1e-6 {
        return None;
    }
    let world: Vec3 = camera.position + dir * (depth_m / cos);
    let rel = world - previous.position;
    let z = rel.dot(previous.forward);
    previous.screen_point_of(rel).map(|q| (q, z))
}

/// Agreement of a history depth with the expected one: 1 within `τ·z'`, 0 from `2τ·z'`.
#[inline]
pub(crate) fn depth_weight(history_m: f32, expected_m: f32, tau: f32) -> f32 {
    let h_sky = !history_m.is_finite() || history_m >= SKY_DEPTH_M * 0.5;
    let e_sky = !expected_m.is_finite();
    match (h_sky, e_sky) {
        (true, true) => 1.0,
        (true, false) | (false, true) => 0.0,
        (false, false) => {
            let rel = (history_m - expected_m).abs() / expected_m.max(1e-4);
            (2.0 - rel / tau).clamp(0.0, 1.0)
        }
    }
}

/// Trust in a history sampled coarser than the new samples (after a saccade the new fovea
/// reads the old periphery): `v` and the age scale by `(b/b_prev)²` (≤ 1), the ratio of
/// sample densities, `b` and `b_prev` being the new and the previous sample spacing.
#[inline]
pub(crate) fn resolution_weight(v: f32, n: u16, b: f32, b_prev: f32) -> (f32, u16) {
    if !(b_prev > b && b > 0.0) {
        return (v, n);
    }
    let r = (b / b_prev) * (b / b_prev);
    (v * r, ((n as f32 * r).floor() as u16).max(1))
}

/// The running estimate: `(colour, new age)` from the new sample `c`, the history `h` with
/// total weight `v` and age `n`.
#[inline]
pub(crate) fn running_estimate(c: Rgb, h: Rgb, v: f32, n: u16, alpha_min: f32) -> (Rgb, u16) {
    if v <= 1e-3 || n == 0 {
        return (c, 1);
    }
    let a = new_weight(v, n, alpha_min);
    let out = [
        a * c[0] + (1.0 - a) * h[0],
        a * c[1] + (1.0 - a) * h[1],
        a * c[2] + (1.0 - a) * h[2],
    ];
    let age = if v >= 0.5 { n.saturating_add(1) } else { 1 };
    (out, age)
}

/// The new sample's weight in the running estimate of [`running_estimate`] (1 where the
/// history is rejected).
#[inline]
pub(crate) fn new_weight(v: f32, n: u16, alpha_min: f32) -> f32 {
    if v <= 1e-3 || n == 0 {
        return 1.0;
    }
    let a_hist = alpha_min.max(1.0 / (n as f32 + 1.0));
    1.0 - (1.0 - a_hist) * v.min(1.0)
}

/// Temporal moments of a luminance `y` folded with the new sample's weight `a` into the
/// history's `[m₁, m₂, s]` (the first and second moments of the per-frame luminance, and
/// `s = Σ wₖ²`, the sum of the squared weights the running estimate gave the frames):
/// `m₁' = a·y + (1 − a)·m₁`, `m₂' = a·y² + (1 − a)·m₂`, `s' = a² + (1 − a)²·s` (SVGF
/// Sec. 4.2 keeps m₁ and m₂ the same way).
#[inline]
pub(crate) fn fold_moments(y: f32, history: [f32; 3], a: f32) -> [f32; 3] {
    let b = 1.0 - a;
    [
        a * y + b * history[0],
        a * y * y + b * history[1],
        a * a + b * b * history[2],
    ]
}

/// The variance of the running estimate of a luminance from its moments `[m₁, m₂, s]`: for
/// frames of independent noise of variance σ² the weighted mean `Σ wₖ yₖ` (weights summing
/// to 1) has variance `σ² s`, and `m₂ − m₁²` estimates `σ² (1 − s)`, so the estimate is
/// `(m₂ − m₁²)·s/(1 − s)` — unbiased, `σ²/n` for a plain average of n frames. NaN for a
/// single frame (`s = 1`: no spread to measure).
#[inline]
pub fn moments_variance(m: [f32; 3]) -> f32 {
    let rest = 1.0 - m[2];
    if rest <= 1e-6 {
        return f32::NAN;
    }
    (m[1] - m[0] * m[0]).max(0.0) * m[2] / rest
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_moments_variance_falls_as_one_over_n_for_independent_noise() {
        // Luminance y = 1 + σ·noise, σ = 0.5, folded frame by frame as the running estimate
        // folds colour (a plain average while n + 1 < 1/α_min): over many texels the mean
        // variance estimate and the running estimate's actual variance across texels are
        // both σ²/n.
        let texels = 20_000;
        let sigma = 0.5f32;
        let mut seed = 0x1234_5678_9abc_def0u64;
        let mut gauss = || {
            let mut u = || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (u().max(1e-12), u());
            ((-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()) as f32
        };
        let mut m = vec![[0.0f32; 3]; texels];
        let mut mean = vec![0.0f32; texels];
        let mut age = vec![0u16; texels];
        for n in 1..=8u16 {
            for t in 0..texels {
                let y = 1.0 + sigma * gauss();
                let a = new_weight(1.0, age[t], 0.05);
                m[t] = fold_moments(y, m[t], a);
                mean[t] = a * y + (1.0 - a) * mean[t];
                age[t] = n;
            }
            let est = m.iter().map(|&m| moments_variance(m) as f64).sum::<f64>() / texels as f64;
            let mu = mean.iter().map(|&v| v as f64).sum::<f64>() / texels as f64;
            let actual = mean.iter().map(|&v| (v as f64 - mu).powi(2)).sum::<f64>() / texels as f64;
            let s2 = (sigma * sigma) as f64;
            let nf = n as f64;
            let want = s2 / nf;
            eprintln!("n {n}: variance estimate {est:.5}, actual {actual:.5}, σ²/n {want:.5}");
            assert!(
                (actual - want).abs() < 0.05 * want,
                "n {n}: actual {actual}"
            );
            if n > 1 {
                assert!(
                    (est - want).abs() < 0.05 * want,
                    "n {n}: estimate {est}, closed form {want}"
                );
            } else {
                assert!(est.is_nan(), "one frame has no spread: {est}");
            }
        }
    }

    #[test]
    fn depth_weight_ramps() {
        assert_eq!(depth_weight(1.0, 1.0, 0.05), 1.0);
        assert_eq!(depth_weight(1.05, 1.0, 0.05), 1.0);
        assert!((depth_weight(1.075, 1.0, 0.05) - 0.5).abs() < 1e-5);
        assert_eq!(depth_weight(1.2, 1.0, 0.05), 0.0);
        assert_eq!(depth_weight(SKY_DEPTH_M, f32::INFINITY, 0.05), 1.0);
        assert_eq!(depth_weight(2.0, f32::INFINITY, 0.05), 0.0);
        assert_eq!(depth_weight(f32::INFINITY, 2.0, 0.05), 0.0);
    }

    #[test]
    fn running_estimate_averages_then_decays() {
        // Constant history weight 1: frames 1..=4 average uniformly.
        let mut acc = [1.0f32, 0.0, 0.0];
        let mut n = 1u16;
        for k in 2..=4 {
            let (c, a) = running_estimate([k as f32, 0.0, 0.0], acc, 1.0, n, 0.1);
            acc = c;
            n = a;
        }
        assert!((acc[0] - 2.5).abs() < 1e-5, "{acc:?}");
        assert_eq!(n, 4);
        // Old history: weight of the new sample is α_min.
        let (c, _) = running_estimate([1.0; 3], [0.0; 3], 1.0, 100, 0.1);
        assert!((c[0] - 0.1).abs() < 1e-6);
        // Rejected history: the new sample alone, age restarts.
        let (c, a) = running_estimate([1.0; 3], [0.0; 3], 0.0, 100, 0.1);
        assert_eq!((c[0], a), (1.0, 1));
        // Half-trusted history.
        let (c, a) = running_estimate([1.0; 3], [0.0; 3], 0.4, 100, 0.1);
        assert!((c[0] - (1.0 - 0.9 * 0.4)).abs() < 1e-6);
        assert_eq!(a, 1);
    }

    #[test]
    fn jitter_cycles_through_centred_halton_points() {
        let mut acc = TemporalAccumulator::new(TemporalSettings {
            jitter: true,
            ..Default::default()
        })
        .unwrap();
        let mut seen = Vec::new();
        for _ in 0..JITTER_PERIOD {
            let j = acc.jitter(Method::Vafr);
            assert!(j[0].abs() < 0.5 && j[1].abs() < 0.5);
            seen.push(j);
            acc.frame += 1;
        }
        assert_eq!(acc.jitter(Method::Vafr), seen[0]);
        let mean = seen
            .iter()
            .fold([0.0; 2], |m, j| [m[0] + j[0], m[1] + j[1]]);
        assert!(mean[0].abs() / 16.0 < 0.05 && mean[1].abs() / 16.0 < 0.05);
        assert_eq!(acc.jitter(Method::Weier), [0.0, 0.0]);
    }

    #[test]
    fn bad_settings_are_errors() {
        for s in [
            TemporalSettings {
                alpha_min: 0.0,
                ..Default::default()
            },
            TemporalSettings {
                alpha_min: f32::NAN,
                ..Default::default()
            },
            TemporalSettings {
                depth_tolerance: -1.0,
                ..Default::default()
            },
        ] {
            assert!(TemporalAccumulator::new(s).is_err());
        }
    }
}
