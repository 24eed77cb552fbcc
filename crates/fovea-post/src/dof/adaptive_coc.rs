//! Adaptive circle-of-confusion gather filter with intensity-leakage control — Konrad,
//! "Depth of Field Rendering Algorithms for Virtual Reality", Sec. III-B, after Zhou, Chen,
//! Pan and Shi (2007), "Accurate depth of field simulation in real time".
//!
//! Konrad builds the weight of a sample pixel `P` for the centre pixel `C` from three
//! factors, and (unlike Zhou, who approximated it by two 1-D passes) evaluates the filter
//! non-separably. In our units (signed CoC diameter `c` in pixels, radius `r = |c|/2`):
//!
//! ```text
//! w(P→C) = cov(r_P, |P−C|)         1. P contributes only if its CoC disc covers C
//!        · 1 / A(r_P)              2. uniform intensity over the disc, A(r) ≈ π r²
//!        · λ(P, C)                 3. leakage control
//! λ(P, C) = min(1, r̂_C / r_P)  if c_P > 0 (P behind the focal plane), else 1
//! out(C)  = Σ w c_P / Σ w
//! ```
//!
//! `cov(r, d) = clamp(r − d + ½, 0, 1)` is the anti-aliased disc indicator and `A(r)` its
//! discrete area (so a disc's weights sum to 1, "the reciprocal of the square of the radius"
//! up to π). Radii are clamped to `[½, max_radius_px]` for factors 1–2. In factor 3, `r̂_C` is
//! `C`'s *unclamped* radius `|c_C|/2`: Konrad scales a background sample "by a factor
//! proportional to the radius of the circle of confusion of the centre pixel", so an
//! in-focus `C` (`r̂_C = 0`) receives nothing from behind the focal plane. We choose the
//! proportionality constant `1/r_P` (and cap at 1), so a background sample counts fully on
//! pixels at least as blurred as itself — on a blurred background plane the filter is the
//! plain disc gather. `C` itself always has weight `1/A(r_C)`, so the sum is never 0. Samples
//! in front of the focal plane keep their weight: a blurred foreground spreads over an
//! in-focus background, but it is normalised together with the background rather than
//! composited over it, so its rim is fainter than the thin lens's (the gather filter,
//! [`super::gather`], composites layers instead).
//!
//! Zero CoC everywhere returns the input unchanged. The gather radius is bounded by
//! `max_radius_px` (a dilated 16×16 tile-max of the radii), rows run in parallel.

use fovea_core::{Image, Result};

use super::disc::{
    accumulate, check_max_radius, coverage, for_each_tap, map_pixels, normalise, AreaLut, Disc,
    Prepared, TileReach,
};
use super::{DofFilter, DofInput};
use crate::Rgb;

/// Zhou et al.'s adaptive CoC filter as Konrad evaluates it (non-separable gather).
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveCoc {
    /// Largest gather radius in pixels; CoC radii are clamped to it. Default 32, valid
    /// `[0.5, 256]`.
    pub max_radius_px: f32,
    /// Apply factor 3 (leakage control). Default `true`; `false` gives a plain
    /// scatter-as-gather that lets a blurred background bleed over a sharp foreground.
    pub leakage_control: bool,
}

impl Default for AdaptiveCoc {
    fn default() -> Self {
        Self {
            max_radius_px: 32.0,
            leakage_control: true,
        }
    }
}

impl DofFilter for AdaptiveCoc {
    fn name(&self) -> &'static str {
        "adaptive-coc"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        check_max_radius(self.max_radius_px, 0.5)?;
        let prep = Prepared::new(input, self.max_radius_px);
        let (w, h) = (prep.w, prep.h);
        let disc = Disc::new(self.max_radius_px);
        let area = AreaLut::new(&disc, self.max_radius_px);
        let reach = TileReach::new(&prep.radius_px, w, h, self.max_radius_px);
        // [r_P, 1/A(r_P), c_P] per pixel: one load per tap.
        let pix: Vec<[f32; 3]> = (prep.radius_px.iter().zip(&prep.coc_px))
            .map(|(&r, &c)| [r, area.inv(r), c])
            .collect();
        map_pixels(w, h, |x, y| {
            let i = y * w + x;
            let reach_px = reach.at(x, y);
            if reach_px <= 0.5 {
                return prep.color[i];
            }
            // Unclamped radius of C for the leakage factor.
            let rc_hat = 0.5 * prep.coc_px[i].abs();
            let mut acc = [0.0f32; 4];
            for_each_tap(disc.within(reach_px), x, y, w, h, |j, _, d| {
                let [rp, inv_area_p, cp] = pix[j];
                // Factor 1 (covers C) and factor 2 (uniform intensity, 1/A(r)).
                let mut wt = coverage(rp, d);
                if wt <= 0.0 {
                    return;
                }
                wt *= inv_area_p;
                // Factor 3: a sample behind the focal plane fades on sharp centres.
                if self.leakage_control && cp > 0.0 && j != i {
                    wt *= (rc_hat / rp).min(1.0);
                }
                accumulate(&mut acc, wt, prep.color[j]);
            });
            normalise(acc, prep.color[i])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;

    fn f() -> AdaptiveCoc {
        AdaptiveCoc::default()
    }

    #[test]
    fn constant_plane_matches_thin_lens() {
        // Far plane (c = +12 px): leakage control must not change a uniform blur.
        let case = Case::new(&single_plane(64, 48, 2.0), 8.0, 0.5, 256);
        let p = case.psnr(&f(), 8);
        eprintln!("adaptive-coc plane: {p:.2} dB");
        assert!(p > 40.0, "{p:.2} dB");
        // Near plane (c = −12 px).
        let case = Case::new(&single_plane(64, 48, 0.5), 8.0, 2.0, 256);
        let p = case.psnr(&f(), 8);
        assert!(p > 40.0, "{p:.2} dB");
    }

    #[test]
    fn occluder_scenes_psnr() {
        let k = 16.0 / 1.5;
        for edge in [Edge::Straight(40.0), Edge::Circle(40.0, 32.0, 18.0)] {
            let scene = occluder_scene(80, 64, edge, true);
            for focus in [0.5f32, 2.0] {
                let case = Case::new(&scene, k, focus, 400);
                let p = case.psnr(&f(), 8);
                let plain = case.psnr(
                    &AdaptiveCoc {
                        leakage_control: false,
                        ..f()
                    },
                    8,
                );
                eprintln!(
                    "adaptive-coc {edge:?} focus {focus} m: {p:.2} dB (no leakage control {plain:.2})"
                );
                // Focus far: the blurred foreground is normalised with the sharp background
                // instead of composited over it (a fainter rim), ~24–28 dB; focus near:
                // the leakage control makes it the exact-as-possible gather, > 40 dB.
                let floor = if focus == 0.5 { 40.0 } else { 22.0 };
                assert!(p >= floor, "{edge:?} focus {focus}: {p:.2} dB");
                if focus == 0.5 {
                    assert!(
                        p > plain + 3.0,
                        "leakage control should pay: {p} vs {plain}"
                    );
                }
            }
        }
    }

    #[test]
    fn sharp_foreground_keeps_its_edge() {
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(30.0), false),
            20.0 / 1.5,
            0.5,
            64,
        );
        let out = f().apply(&case.input()).unwrap();
        let width = edge_width(&column_profile(&out, 4, 20), 6);
        let leaky = AdaptiveCoc {
            leakage_control: false,
            ..f()
        }
        .apply(&case.input())
        .unwrap();
        let leaky = edge_width(&column_profile(&leaky, 4, 20), 6);
        eprintln!("adaptive-coc sharp edge: {width:.2} px (without leakage control {leaky:.2})");
        assert!(width <= 1.5, "{width}");
        assert!(leaky > 3.0, "{leaky}");
    }

    #[test]
    fn blurred_foreground_has_soft_edges() {
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(32.0), false),
            12.0 / 1.5,
            2.0,
            256,
        );
        let out = f().apply(&case.input()).unwrap();
        let width = edge_width(&column_profile(&out, 4, 20), 4);
        let truth = edge_width(&column_profile(&case.truth, 4, 20), 4);
        eprintln!("adaptive-coc soft edge: {width:.2} px (thin lens {truth:.2} px)");
        assert!(width > 4.0, "{width} vs {truth}");
    }
}
