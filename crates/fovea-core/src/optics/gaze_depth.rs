//! Gaze-depth (focus distance) estimation from the depth buffer around the point of regard and
//! from binocular vergence (Weier et al. 2018, Sec. 3.2 "Gaze-Depth Estimation", Fig. 4).
//!
//! Reading the depth buffer at the single pixel under the measured point of regard (PoR) is
//! fragile: eye trackers are accurate to about 1° (Weier's Fove 0: 1°), so near an object's
//! silhouette the measured PoR falls on the background about as often as on the object and the
//! estimate jumps between the two depths. Weier et al. feed depths sampled at and around the
//! PoR (Fig. 4), their variances and the eyes' vergence into a trained SVM. We keep the
//! sampling pattern and replace the regression by a robust statistic with no training data:
//!
//! 1. **Pattern** (Fig. 4): the PoR plus `samples_per_ring` samples on each ring of radius
//!    `r_k` degrees of visual angle (default 0.5°, 1.0°, 1.5°, i.e. covering the tracker's
//!    accuracy), consecutive rings rotated by half a step so the pattern has no radial gaps.
//!    Degrees become pixels with the display's local pixels per degree at the PoR,
//!    `offset_px = r_deg · ppd` (the rectilinear scale changes by under 0.1 % within 1.5°).
//!    Each sample reads the pixel that contains it (no interpolation: interpolating depth
//!    across a silhouette invents surfaces that are not there).
//! 2. **Weights**: a sample at angle `r` from the PoR gets `w = exp(−r² / (2σ²))` with `σ` the
//!    tracker's accuracy (default 1°): the likelihood that the true PoR lies there.
//! 3. **Dioptres**: every depth `d` becomes `D = 1/d` dioptres; no-hit samples (+∞ or NaN
//!    depth: the background at infinity) become 0 D. Depths ≤ 0 or −∞ are invalid and skipped;
//!    samples outside the image are skipped.
//! 4. **Clusters**: the samples sorted by dioptres are split wherever two neighbours differ by
//!    more than `cluster_gap_dioptres` (default 0.25 D, about the half-width of the eye's depth
//!    of focus, Campbell 1957). Dioptres are the right space: the eye's blur is linear in them
//!    and a gap of 0.25 D means the same visible difference at 0.5 m and at 4 m.
//! 5. **Choice**: the cluster with the largest total weight wins (ties: the one holding the
//!    heaviest single sample, then the nearer one). With a *prior* (best: the accommodation
//!    filter's current focus; or the vergence distance) the cluster within `cluster_gap_dioptres` of the prior has its
//!    weight multiplied by `prior_weight_factor` (default 2): at a silhouette, where both depths
//!    are in the pattern, the focus only changes sides when the other side clearly dominates,
//!    while a real gaze shift to another object (the old depth leaves the pattern) switches at
//!    once. This is hysteresis in depth, not in time.
//! 6. **Focus**: the weighted lower median of the winning cluster (an actual sampled depth,
//!    never a blend of two surfaces); `focus_m = 1/D` (0 D → +∞).
//!
//! The result carries a confidence (the winning cluster's share of the total weight) and a
//! spread (the weighted median absolute deviation of the winning cluster, dioptres).
//!
//! **Vergence**: the two eyes' gaze rays `p_l + s·d_l`, `p_r + t·d_r` meet (or pass closest) at
//! `s = (b·e − c·d)/(a·c − b²)`, `t = (a·e − b·d)/(a·c − b²)` with `w = p_l − p_r`,
//! `a = d_l·d_l`, `b = d_l·d_r`, `c = d_r·d_r`, `d = d_l·w`, `e = d_r·w` (closest points of two
//! lines). The focus distance is the midpoint of the two closest points projected on the
//! cyclopean direction `d̂_l + d̂_r` from the cyclopean eye `(p_l + p_r)/2`. Parallel or
//! diverging rays (closest approach behind the eyes) fixate infinity.

use crate::error::{FoveaError, Result};
use crate::image::Image;
use crate::units::ScreenPoint;
use serde::{Deserialize, Serialize};

/// Fraction of the image's width/height by which a PoR may lie outside the image and still be
/// clamped onto it (the same margin as [`crate::display::GAZE_MARGIN_FRACTION`]); farther out is
/// a tracking failure and an error.
pub const POR_MARGIN_FRACTION: f64 = crate::display::GAZE_MARGIN_FRACTION;

/// Largest number of rings or samples per ring accepted (a guard against absurd patterns).
pub const MAX_PATTERN_SIZE: u32 = 64;

/// Parameters of the depth-buffer gaze-depth estimator (see the module header).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GazeDepthParams {
    /// Ring radii in degrees of visual angle around the PoR, each in (0, 10]. Default
    /// `[0.5, 1.0, 1.5]`: the pattern covers about 1.5× the tracker's accuracy.
    pub ring_radii_deg: Vec<f64>,
    /// Samples on each ring, in [1, 64]. Default 8 (25 samples with the PoR).
    pub samples_per_ring: u32,
    /// Standard deviation in degrees of the Gaussian weight `exp(−r²/2σ²)`, in (0, 10]: the eye
    /// tracker's accuracy. Default 1.0° (Weier's Fove 0 states 1°).
    pub weight_sigma_deg: f64,
    /// Largest gap in dioptres between neighbouring sorted samples of one cluster, in
    /// (0, 10]. Default 0.25 D (about half the eye's depth of focus).
    pub cluster_gap_dioptres: f64,
    /// Weight multiplier in [1, 100] of the cluster that contains the prior (see
    /// [`estimate_gaze_depth_with_prior`]); 1 disables the hysteresis. Default 2.
    pub prior_weight_factor: f64,
}

impl Default for GazeDepthParams {
    fn default() -> Self {
        Self {
            ring_radii_deg: vec![0.5, 1.0, 1.5],
            samples_per_ring: 8,
            weight_sigma_deg: 1.0,
            cluster_gap_dioptres: 0.25,
            prior_weight_factor: 2.0,
        }
    }
}

impl GazeDepthParams {
    /// Validates every field against the ranges documented on it.
    pub fn validate(&self) -> Result<()> {
        use crate::error::{check_range, check_range_open_lo};
        if self.ring_radii_deg.len() > MAX_PATTERN_SIZE as usize {
            return Err(FoveaError::invalid(
                "ring_radii_deg",
                format!("{} rings", self.ring_radii_deg.len()),
                format!("at most {MAX_PATTERN_SIZE} rings"),
            ));
        }
        for &r in &self.ring_radii_deg {
            check_range_open_lo("ring_radii_deg", r, 0.0, 10.0)?;
        }
        if self.samples_per_ring == 0 || self.samples_per_ring > MAX_PATTERN_SIZE {
            return Err(FoveaError::invalid(
                "samples_per_ring",
                self.samples_per_ring,
                format!("an integer in [1, {MAX_PATTERN_SIZE}]"),
            ));
        }
        check_range_open_lo("weight_sigma_deg", self.weight_sigma_deg, 0.0, 10.0)?;
        check_range_open_lo("cluster_gap_dioptres", self.cluster_gap_dioptres, 0.0, 10.0)?;
        check_range("prior_weight_factor", self.prior_weight_factor, 1.0, 100.0)?;
        Ok(())
    }

    /// The sampling pattern (Fig. 4): `(dx_deg, dy_deg, weight)` for the PoR and every ring
    /// sample, PoR first. Ring `k` starts at angle `k·π/n` so neighbouring rings interleave.
    pub fn pattern_deg(&self) -> Vec<(f64, f64, f64)> {
        let n = self.samples_per_ring.max(1);
        let s2 = 2.0 * self.weight_sigma_deg * self.weight_sigma_deg;
        let mut out = Vec::with_capacity(1 + self.ring_radii_deg.len() * n as usize);
        out.push((0.0, 0.0, 1.0));
        for (k, &r) in self.ring_radii_deg.iter().enumerate() {
            let w = (-r * r / s2).exp();
            for i in 0..n {
                let a = std::f64::consts::TAU * (i as f64 + 0.5 * k as f64) / n as f64;
                out.push((r * a.cos(), r * a.sin(), w));
            }
        }
        out
    }
}

/// A focus-distance estimate from the depth buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GazeDepth {
    /// Estimated focus distance in metres, > 0; `f64::INFINITY` when the winning samples are
    /// background (no hit) or nothing valid was sampled.
    pub focus_m: f64,
    /// The same in dioptres (`1/focus_m`, ≥ 0; 0 at infinity).
    pub focus_dioptres: f64,
    /// Share in [0, 1] of the pattern's (unbiased) weight that lies in the winning cluster;
    /// 0 when no valid sample was found.
    pub confidence: f64,
    /// Weighted median absolute deviation in dioptres of the winning cluster from the focus
    /// (≥ 0): how flat the fixated surface is in depth around the PoR.
    pub spread_dioptres: f64,
    /// Number of valid samples used (on the image, depth not invalid).
    pub sample_count: usize,
    /// Number of depth clusters found among them.
    pub cluster_count: usize,
}

impl GazeDepth {
    fn infinity() -> Self {
        Self {
            focus_m: f64::INFINITY,
            focus_dioptres: 0.0,
            confidence: 0.0,
            spread_dioptres: 0.0,
            sample_count: 0,
            cluster_count: 0,
        }
    }
}

/// Dioptres of a depth-buffer value: `1/d` for a finite `d > 0`, 0 for no hit (+∞ or NaN),
/// `None` for an invalid value (≤ 0 or −∞).
#[inline]
pub fn depth_to_dioptres(depth_m: f64) -> Option<f64> {
    if depth_m.is_nan() || depth_m == f64::INFINITY {
        Some(0.0)
    } else if depth_m > 0.0 {
        Some(1.0 / depth_m)
    } else {
        None
    }
}

/// Metres of a vergence/accommodation in dioptres: `1/D` for `D > 0`, +∞ for `D ≤ 0`.
#[inline]
pub fn dioptres_to_m(dioptres: f64) -> f64 {
    if dioptres > 0.0 {
        1.0 / dioptres
    } else {
        f64::INFINITY
    }
}

/// Validates the PoR and clamps it onto the image (see [`POR_MARGIN_FRACTION`]); returns the
/// clamped point.
fn clamp_por(depth: &Image<f32>, por: ScreenPoint) -> Result<ScreenPoint> {
    let (w, h) = (depth.width() as f64, depth.height() as f64);
    let (mx, my) = (w * POR_MARGIN_FRACTION, h * POR_MARGIN_FRACTION);
    let (x, y) = (por.x_px, por.y_px);
    if !(x.is_finite() && y.is_finite()) || x < -mx || x > w + mx || y < -my || y > h + my {
        return Err(FoveaError::invalid(
            "point of regard",
            format!("{x},{y}"),
            format!(
                "a finite point on the {}×{} depth image (x in [{:.0}, {:.0}], y in [{:.0}, {:.0}] px)",
                depth.width(),
                depth.height(),
                -mx,
                w + mx,
                -my,
                h + my
            ),
        ));
    }
    // Clamp onto the centres of the outermost pixels.
    Ok(ScreenPoint::new(
        x.clamp(0.5, w - 0.5),
        y.clamp(0.5, h - 0.5),
    ))
}

/// The naive estimate: the depth (metres) of the single pixel containing the PoR, +∞ for no
/// hit or an invalid value. Same PoR validation and clamping as [`estimate_gaze_depth`]. Kept
/// for comparison; it jumps whenever tracker noise crosses a silhouette.
pub fn single_pixel_depth(depth: &Image<f32>, por: ScreenPoint) -> Result<f64> {
    let p = clamp_por(depth, por)?;
    let d = *depth.get(p.x_px.floor() as u32, p.y_px.floor() as u32) as f64;
    Ok(depth_to_dioptres(d).map_or(f64::INFINITY, dioptres_to_m))
}

/// Robust focus distance from the depth buffer `depth` (view depth in metres; +∞/NaN = no hit)
/// around the PoR `por` (screen pixels, centre of pixel `(i, j)` at `(i + 0.5, j + 0.5)`), for a
/// display with `pixels_per_degree` in (0, 1000] near the PoR (e.g.
/// [`crate::display::DisplayProfile::ppd`]). See the module header for the algorithm.
///
/// Errors: a non-finite PoR, or one farther than [`POR_MARGIN_FRACTION`] of the image size
/// outside it (a PoR within the margin is clamped onto the image); invalid `pixels_per_degree`
/// or `params`. An image without any valid hit gives focus at infinity with confidence 0
/// (all no-hit: confidence 1, the eye looks at the background).
pub fn estimate_gaze_depth(
    depth: &Image<f32>,
    por: ScreenPoint,
    pixels_per_degree: f64,
    params: &GazeDepthParams,
) -> Result<GazeDepth> {
    estimate_impl(depth, por, pixels_per_degree, params, None)
}

/// [`estimate_gaze_depth`] with a prior focus distance `prior_focus_m` (metres, > 0, +∞ allowed;
/// NaN means no prior): best the current focus of the
/// [`super::accommodation::AccommodationFilter`] this estimate feeds (stable, because the filter
/// ignores isolated outliers), or the vergence distance of [`vergence_distance`]. Using the
/// previous raw estimate instead lets one outlier frame lock the estimate onto the wrong side
/// of a silhouette. Without a gaze shift, an ambiguous PoR keeps the side it started on. The cluster within `cluster_gap_dioptres` of the prior (the nearest
/// such cluster) has its weight multiplied by `prior_weight_factor`. Errors for a prior ≤ 0.
pub fn estimate_gaze_depth_with_prior(
    depth: &Image<f32>,
    por: ScreenPoint,
    pixels_per_degree: f64,
    params: &GazeDepthParams,
    prior_focus_m: f64,
) -> Result<GazeDepth> {
    if prior_focus_m.is_nan() {
        return estimate_impl(depth, por, pixels_per_degree, params, None);
    }
    if prior_focus_m <= 0.0 {
        return Err(FoveaError::invalid(
            "prior_focus_m",
            prior_focus_m,
            "a distance > 0 m (+inf allowed, NaN for no prior)",
        ));
    }
    estimate_impl(
        depth,
        por,
        pixels_per_degree,
        params,
        Some(1.0 / prior_focus_m),
    )
}

fn estimate_impl(
    depth: &Image<f32>,
    por: ScreenPoint,
    pixels_per_degree: f64,
    params: &GazeDepthParams,
    prior_dioptres: Option<f64>,
) -> Result<GazeDepth> {
    params.validate()?;
    crate::error::check_range_open_lo("pixels_per_degree", pixels_per_degree, 0.0, 1000.0)?;
    let p = clamp_por(depth, por)?;
    let (w, h) = (depth.width() as f64, depth.height() as f64);

    // 1–3: sample the pattern, convert to weighted dioptres.
    let mut samples: Vec<(f64, f64)> = Vec::with_capacity(1 + params.ring_radii_deg.len() * 8);
    for (dx_deg, dy_deg, wt) in params.pattern_deg() {
        let (x, y) = (
            p.x_px + dx_deg * pixels_per_degree,
            p.y_px + dy_deg * pixels_per_degree,
        );
        if !(x >= 0.0 && x < w && y >= 0.0 && y < h) {
            continue;
        }
        let d = *depth.get(x.floor() as u32, y.floor() as u32) as f64;
        if let Some(dpt) = depth_to_dioptres(d) {
            samples.push((dpt, wt));
        }
    }
    if samples.is_empty() {
        return Ok(GazeDepth::infinity());
    }
    let total: f64 = samples.iter().map(|s| s.1).sum();

    // 4: gap clustering on sorted dioptres.
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut clusters: Vec<std::ops::Range<usize>> = Vec::new();
    let mut start = 0;
    for i in 1..=samples.len() {
        if i == samples.len() || samples[i].0 - samples[i - 1].0 > params.cluster_gap_dioptres {
            clusters.push(start..i);
            start = i;
        }
    }

    // 5: the heaviest cluster, the prior's cluster boosted.
    let prior_cluster = prior_dioptres.and_then(|pd| {
        clusters
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let (lo, hi) = (samples[c.start].0, samples[c.end - 1].0);
                let dist = if pd < lo {
                    lo - pd
                } else if pd > hi {
                    pd - hi
                } else {
                    0.0
                };
                (k, dist)
            })
            .filter(|&(_, dist)| dist <= params.cluster_gap_dioptres)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    });
    let score = |k: usize| {
        let c = &samples[clusters[k].clone()];
        let sum: f64 = c.iter().map(|s| s.1).sum();
        let peak = c.iter().map(|s| s.1).fold(0.0, f64::max);
        let boost = if Some(k) == prior_cluster {
            params.prior_weight_factor
        } else {
            1.0
        };
        (sum * boost, peak, c[c.len() - 1].0)
    };
    let best = (0..clusters.len())
        .max_by(|&a, &b| {
            let (sa, sb) = (score(a), score(b));
            sa.0.total_cmp(&sb.0)
                .then(sa.1.total_cmp(&sb.1))
                .then(sa.2.total_cmp(&sb.2))
        })
        .unwrap_or(0);
    let c = &samples[clusters[best].clone()];
    let cluster_weight: f64 = c.iter().map(|s| s.1).sum();

    // 6: weighted lower median and weighted MAD.
    let focus_dioptres = weighted_lower_median(c.iter().copied());
    let spread_dioptres =
        weighted_lower_median(c.iter().map(|&(d, wt)| ((d - focus_dioptres).abs(), wt)));
    Ok(GazeDepth {
        focus_m: dioptres_to_m(focus_dioptres),
        focus_dioptres,
        confidence: if total > 0.0 {
            cluster_weight / total
        } else {
            0.0
        },
        spread_dioptres,
        sample_count: samples.len(),
        cluster_count: clusters.len(),
    })
}

/// Weighted lower median of `(value, weight)` pairs: the smallest value whose cumulative weight
/// (in ascending value order) reaches half the total. 0 for an empty input.
fn weighted_lower_median(items: impl Iterator<Item = (f64, f64)>) -> f64 {
    let mut v: Vec<(f64, f64)> = items.collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let half = 0.5 * v.iter().map(|s| s.1).sum::<f64>();
    let mut acc = 0.0;
    for &(x, wt) in &v {
        acc += wt;
        if acc >= half {
            return x;
        }
    }
    v[v.len() - 1].0
}

/// Focus distance from binocular vergence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vergence {
    /// Distance in metres from the cyclopean eye along the cyclopean gaze direction to the
    /// midpoint of the two rays' closest approach; `f64::INFINITY` for parallel or diverging rays.
    pub distance_m: f64,
    /// Angle in degrees between the two gaze directions, in [0, 180].
    pub vergence_deg: f64,
    /// Distance in metres between the two rays at their closest approach (0 when they
    /// intersect; a large value flags a vertical misalignment / bad tracking). 0 for parallel
    /// or diverging rays.
    pub miss_distance_m: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Binocular vergence distance (see the module header): eye positions `left_eye_m`,
/// `right_eye_m` (metres, any common frame) and gaze directions `left_dir`, `right_dir` (any
/// non-zero length). Rays whose directions differ by less than about 1e-6 rad (parallel, focus
/// beyond ~60 km at a 63 mm IPD) or whose closest approach lies behind either eye (diverging)
/// give `distance_m = +∞`. Errors for any non-finite component or a zero direction.
pub fn vergence_distance(
    left_eye_m: [f64; 3],
    left_dir: [f64; 3],
    right_eye_m: [f64; 3],
    right_dir: [f64; 3],
) -> Result<Vergence> {
    for (name, v) in [
        ("left_eye_m", left_eye_m),
        ("left_dir", left_dir),
        ("right_eye_m", right_eye_m),
        ("right_dir", right_dir),
    ] {
        if !v.iter().all(|c| c.is_finite()) {
            return Err(FoveaError::invalid(
                name,
                format!("{v:?}"),
                "three finite components",
            ));
        }
    }
    let (nl, nr) = (norm(left_dir), norm(right_dir));
    for (name, n, v) in [("left_dir", nl, left_dir), ("right_dir", nr, right_dir)] {
        if !(n > 1e-300 && n.is_finite()) {
            return Err(FoveaError::invalid(
                name,
                format!("{v:?}"),
                "a non-zero direction",
            ));
        }
    }
    let dl = [left_dir[0] / nl, left_dir[1] / nl, left_dir[2] / nl];
    let dr = [right_dir[0] / nr, right_dir[1] / nr, right_dir[2] / nr];
    let vergence_deg = dot(dl, dr).clamp(-1.0, 1.0).acos().to_degrees();
    let infinite = Vergence {
        distance_m: f64::INFINITY,
        vergence_deg,
        miss_distance_m: 0.0,
    };
    // Closest points of the two lines (unit directions: a = c = 1).
    let wv = [
        left_eye_m[0] - right_eye_m[0],
        left_eye_m[1] - right_eye_m[1],
        left_eye_m[2] - right_eye_m[2],
    ];
    let b = dot(dl, dr);
    let (d, e) = (dot(dl, wv), dot(dr, wv));
    let denom = 1.0 - b * b; // sin² of the angle between the rays
    if denom < 1e-12 {
        return Ok(infinite);
    }
    let s = (b * e - d) / denom;
    let t = (e - b * d) / denom;
    if s <= 0.0 || t <= 0.0 {
        return Ok(infinite);
    }
    let pl = [
        left_eye_m[0] + s * dl[0],
        left_eye_m[1] + s * dl[1],
        left_eye_m[2] + s * dl[2],
    ];
    let pr = [
        right_eye_m[0] + t * dr[0],
        right_eye_m[1] + t * dr[1],
        right_eye_m[2] + t * dr[2],
    ];
    let mid = [
        0.5 * (pl[0] + pr[0]),
        0.5 * (pl[1] + pr[1]),
        0.5 * (pl[2] + pr[2]),
    ];
    let cyc = [
        0.5 * (left_eye_m[0] + right_eye_m[0]),
        0.5 * (left_eye_m[1] + right_eye_m[1]),
        0.5 * (left_eye_m[2] + right_eye_m[2]),
    ];
    let dc = [dl[0] + dr[0], dl[1] + dr[1], dl[2] + dr[2]];
    let nc = norm(dc);
    if nc < 1e-12 {
        return Ok(infinite);
    }
    let along = dot(
        [mid[0] - cyc[0], mid[1] - cyc[1], mid[2] - cyc[2]],
        [dc[0] / nc, dc[1] / nc, dc[2] / nc],
    );
    if along <= 0.0 {
        return Ok(infinite);
    }
    let miss = norm([pl[0] - pr[0], pl[1] - pr[1], pl[2] - pr[2]]);
    Ok(Vergence {
        distance_m: along,
        vergence_deg,
        miss_distance_m: miss,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Left half at `near_m`, right half at `far_m`.
    fn edge_image(w: u32, h: u32, near_m: f32, far_m: f32) -> Image<f32> {
        let data = (0..w * h)
            .map(|i| if i % w < w / 2 { near_m } else { far_m })
            .collect();
        Image::from_vec(w, h, data).unwrap()
    }

    #[test]
    fn flat_depth_gives_that_depth_with_full_confidence() {
        let img = Image::new(64, 48, 2.0f32).unwrap();
        let g = estimate_gaze_depth(
            &img,
            ScreenPoint::new(32.0, 24.0),
            10.0,
            &GazeDepthParams::default(),
        )
        .unwrap();
        assert!((g.focus_m - 2.0).abs() < 1e-6);
        assert!((g.focus_dioptres - 0.5).abs() < 1e-6);
        assert!((g.confidence - 1.0).abs() < 1e-12);
        assert_eq!(g.spread_dioptres, 0.0);
        assert_eq!((g.sample_count, g.cluster_count), (25, 1));
    }

    #[test]
    fn no_hit_is_infinity_and_invalid_depths_are_skipped() {
        for v in [f32::INFINITY, f32::NAN] {
            let img = Image::new(32, 32, v).unwrap();
            let g = estimate_gaze_depth(
                &img,
                ScreenPoint::new(16.0, 16.0),
                5.0,
                &GazeDepthParams::default(),
            )
            .unwrap();
            assert_eq!(g.focus_m, f64::INFINITY);
            assert_eq!(g.focus_dioptres, 0.0);
            assert!((g.confidence - 1.0).abs() < 1e-12);
            assert_eq!(
                single_pixel_depth(&img, ScreenPoint::new(3.0, 3.0)).unwrap(),
                f64::INFINITY
            );
        }
        let bad = Image::new(32, 32, -1.0f32).unwrap();
        let g = estimate_gaze_depth(
            &bad,
            ScreenPoint::new(16.0, 16.0),
            5.0,
            &GazeDepthParams::default(),
        )
        .unwrap();
        assert_eq!(
            (g.focus_m, g.confidence, g.sample_count),
            (f64::INFINITY, 0.0, 0)
        );
    }

    #[test]
    fn por_validation_and_clamping() {
        let img = edge_image(100, 50, 0.5, 3.0);
        let p = GazeDepthParams::default();
        for por in [
            ScreenPoint::new(f64::NAN, 10.0),
            ScreenPoint::new(10.0, f64::INFINITY),
            ScreenPoint::new(-20.0, 10.0),
            ScreenPoint::new(10.0, 60.0),
        ] {
            assert!(matches!(
                estimate_gaze_depth(&img, por, 10.0, &p),
                Err(FoveaError::InvalidParameter { .. })
            ));
            assert!(single_pixel_depth(&img, por).is_err());
        }
        // Slightly off the left border: clamped onto the image, reads the near half.
        let g = estimate_gaze_depth(&img, ScreenPoint::new(-2.0, 25.0), 2.0, &p).unwrap();
        assert!((g.focus_m - 0.5).abs() < 1e-6);
        assert!(
            (single_pixel_depth(&img, ScreenPoint::new(102.0, -1.0)).unwrap() - 3.0).abs() < 1e-6
        );
        // Bad parameters are typed errors.
        assert!(estimate_gaze_depth(&img, ScreenPoint::new(5.0, 5.0), 0.0, &p).is_err());
        let bad = GazeDepthParams {
            samples_per_ring: 0,
            ..p.clone()
        };
        assert!(estimate_gaze_depth(&img, ScreenPoint::new(5.0, 5.0), 10.0, &bad).is_err());
        let bad = GazeDepthParams {
            ring_radii_deg: vec![f64::NAN],
            ..p.clone()
        };
        assert!(bad.validate().is_err());
        assert!(
            estimate_gaze_depth_with_prior(&img, ScreenPoint::new(5.0, 5.0), 10.0, &p, -1.0)
                .is_err()
        );
    }

    #[test]
    fn pattern_matches_its_definition() {
        let p = GazeDepthParams::default();
        let pat = p.pattern_deg();
        assert_eq!(pat.len(), 25);
        assert_eq!(pat[0], (0.0, 0.0, 1.0));
        for (k, &r) in p.ring_radii_deg.iter().enumerate() {
            for i in 0..8 {
                let (x, y, w) = pat[1 + 8 * k + i];
                assert!((x.hypot(y) - r).abs() < 1e-12);
                assert!((w - (-r * r / 2.0).exp()).abs() < 1e-12);
                // Interleaved rings: ring k starts at k·π/8.
                if i == 0 {
                    let a = y.atan2(x);
                    assert!((a - k as f64 * std::f64::consts::PI / 8.0).abs() < 1e-12);
                }
            }
        }
    }

    /// Brute force of the cluster choice: hand-computed weights for a PoR exactly `o` degrees
    /// left of a vertical edge (near on the left).
    #[test]
    fn edge_choice_matches_hand_count_and_prior_flips_close_calls() {
        let ppd = 20.0;
        let img = edge_image(400, 200, 0.6, 4.0);
        let p = GazeDepthParams::default();
        for off_deg in [-0.9, -0.3, -0.05, 0.05, 0.3, 0.9] {
            // PoR at off_deg degrees right of the edge (negative: on the near box).
            let x = 200.0 + off_deg * ppd;
            let por = ScreenPoint::new(x, 100.3);
            let mut near_w = 0.0;
            let mut far_w = 0.0;
            for (dx, _, w) in p.pattern_deg() {
                let px = (x + dx * ppd).floor();
                if px < 200.0 {
                    near_w += w
                } else {
                    far_w += w
                }
            }
            let g = estimate_gaze_depth(&img, por, ppd, &p).unwrap();
            let expect = if near_w >= far_w { 0.6 } else { 4.0 };
            assert!((g.focus_m - expect).abs() < 1e-6, "{off_deg}: {g:?}");
            let conf = near_w.max(far_w) / (near_w + far_w);
            assert!((g.confidence - conf).abs() < 1e-9);
            assert_eq!(g.cluster_count, 2);
            // With the prior on the losing side and the loser's weight > half the winner's,
            // the prior wins.
            let (lose_m, lose_w, win_w) = if near_w >= far_w {
                (4.0, far_w, near_w)
            } else {
                (0.6, near_w, far_w)
            };
            let gp = estimate_gaze_depth_with_prior(&img, por, ppd, &p, lose_m).unwrap();
            let expect = if 2.0 * lose_w > win_w {
                lose_m
            } else {
                1.0 / g.focus_dioptres
            };
            assert!((gp.focus_m - expect).abs() < 1e-6, "{off_deg}: {gp:?}");
        }
    }

    #[test]
    fn median_is_robust_to_a_few_odd_samples_and_spread_is_reported() {
        // A slanted surface: depth varies by column; the focus is the weighted median.
        let (w, h) = (200u32, 200u32);
        let data = (0..w * h)
            .map(|i| 1.0 / (1.0 + 0.001 * (i % w) as f32))
            .collect();
        let img = Image::from_vec(w, h, data).unwrap();
        let g = estimate_gaze_depth(
            &img,
            ScreenPoint::new(100.5, 100.5),
            20.0,
            &GazeDepthParams::default(),
        )
        .unwrap();
        // Symmetric pattern on a linear-in-dioptres ramp: the median is the PoR's column.
        assert!((g.focus_dioptres - 1.1).abs() < 0.005, "{g:?}");
        assert!(g.spread_dioptres > 0.0 && g.spread_dioptres < 0.03, "{g:?}");
        assert_eq!(g.cluster_count, 1);
    }

    #[test]
    fn weighted_median_brute_force() {
        let items = [(3.0, 1.0), (1.0, 1.0), (2.0, 5.0), (10.0, 0.5)];
        assert_eq!(weighted_lower_median(items.iter().copied()), 2.0);
        let items = [(1.0, 1.0), (2.0, 1.0)];
        assert_eq!(weighted_lower_median(items.iter().copied()), 1.0);
        assert_eq!(weighted_lower_median(std::iter::empty()), 0.0);
    }

    #[test]
    fn vergence_closed_form() {
        let ipd = 0.063;
        for dist in [0.25, 0.6, 1.0, 4.0, 100.0] {
            let target = [0.1, -0.05, dist];
            let le = [-ipd / 2.0, 0.0, 0.0];
            let re = [ipd / 2.0, 0.0, 0.0];
            let dir = |e: [f64; 3]| [target[0] - e[0], target[1] - e[1], target[2] - e[2]];
            let v = vergence_distance(le, dir(le), re, dir(re)).unwrap();
            // Cyclopean eye at the origin: the distance to the target along the cyclopean
            // direction; the target lies close to that direction (exactly for a target on the
            // midline), so compare with the projection.
            let dc = {
                let (a, b) = (dir(le), dir(re));
                let (na, nb) = (norm(a), norm(b));
                let c = [
                    a[0] / na + b[0] / nb,
                    a[1] / na + b[1] / nb,
                    a[2] / na + b[2] / nb,
                ];
                let n = norm(c);
                [c[0] / n, c[1] / n, c[2] / n]
            };
            let expect = dot(target, dc);
            assert!(
                (v.distance_m - expect).abs() < 1e-9 * dist.max(1.0),
                "{dist}: {v:?}"
            );
            assert!(v.miss_distance_m < 1e-9);
            let angle = dot(dir(le), dir(re)) / (norm(dir(le)) * norm(dir(re)));
            assert!((v.vergence_deg - angle.acos().to_degrees()).abs() < 1e-6);
        }
        // On the midline: the distance is exactly the target's depth, vergence 2·atan(ipd/2/d).
        let v = vergence_distance(
            [-0.03, 0.0, 0.0],
            [0.03, 0.0, 0.5],
            [0.03, 0.0, 0.0],
            [-0.03, 0.0, 0.5],
        )
        .unwrap();
        assert!((v.distance_m - 0.5).abs() < 1e-12);
        assert!((v.vergence_deg - 2.0 * (0.03f64 / 0.5).atan().to_degrees()).abs() < 1e-9);
    }

    #[test]
    fn vergence_skew_rays_use_the_midpoint() {
        // Left ray along +z at y = +0.01, right ray converging at z = 1 but at y = −0.01.
        let v = vergence_distance(
            [-0.03, 0.01, 0.0],
            [0.03, 0.0, 1.0],
            [0.03, -0.01, 0.0],
            [-0.03, 0.0, 1.0],
        )
        .unwrap();
        assert!((v.distance_m - 1.0).abs() < 1e-9, "{v:?}");
        assert!((v.miss_distance_m - 0.02).abs() < 1e-9, "{v:?}");
    }

    #[test]
    fn vergence_parallel_diverging_and_invalid() {
        let le = [-0.03, 0.0, 0.0];
        let re = [0.03, 0.0, 0.0];
        let v = vergence_distance(le, [0.0, 0.0, 1.0], re, [0.0, 0.0, 2.0]).unwrap();
        assert_eq!(v.distance_m, f64::INFINITY);
        assert_eq!(v.vergence_deg, 0.0);
        let v = vergence_distance(le, [-0.1, 0.0, 1.0], re, [0.1, 0.0, 1.0]).unwrap();
        assert_eq!(v.distance_m, f64::INFINITY);
        // Converging along −z: the frame's orientation does not matter, 0.3 m ahead of the eyes.
        let v = vergence_distance(le, [0.1, 0.0, -1.0], re, [-0.1, 0.0, -1.0]).unwrap();
        assert!((v.distance_m - 0.3).abs() < 1e-12, "{v:?}");
        assert!(vergence_distance(le, [f64::NAN, 0.0, 1.0], re, [0.0, 0.0, 1.0]).is_err());
        assert!(vergence_distance(
            [f64::INFINITY, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            re,
            [0.0, 0.0, 1.0]
        )
        .is_err());
        assert!(matches!(
            vergence_distance(le, [0.0; 3], re, [0.0, 0.0, 1.0]),
            Err(FoveaError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn vergence_as_prior_picks_the_matching_cluster() {
        let img = edge_image(400, 200, 0.6, 4.0);
        // PoR exactly on the edge: a close call; a vergence of 0.62 m tips it to the box.
        let por = ScreenPoint::new(200.5, 100.0);
        let v = vergence_distance(
            [-0.03, 0.0, 0.0],
            [0.03, 0.0, 0.62],
            [0.03, 0.0, 0.0],
            [-0.03, 0.0, 0.62],
        )
        .unwrap();
        let g = estimate_gaze_depth_with_prior(
            &img,
            por,
            20.0,
            &GazeDepthParams::default(),
            v.distance_m,
        )
        .unwrap();
        assert!((g.focus_m - 0.6).abs() < 1e-6, "{g:?}");
    }

    #[test]
    fn conversions() {
        assert_eq!(depth_to_dioptres(0.5), Some(2.0));
        assert_eq!(depth_to_dioptres(f64::INFINITY), Some(0.0));
        assert_eq!(depth_to_dioptres(f64::NAN), Some(0.0));
        assert_eq!(depth_to_dioptres(0.0), None);
        assert_eq!(depth_to_dioptres(f64::NEG_INFINITY), None);
        assert_eq!(dioptres_to_m(0.0), f64::INFINITY);
        assert_eq!(dioptres_to_m(4.0), 0.25);
    }
}
