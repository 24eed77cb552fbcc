//! Adaptive recursive DOF filter — Konrad, "Depth of Field Rendering Algorithms for Virtual
//! Reality", Sec. III-D, after Xu, Mei, Dong, Sun, Shen and Zhang (2014), "Depth of field
//! rendering via adaptive recursive filtering".
//!
//! ## Segmentation and pair weights
//!
//! Each pixel falls in one region by its signed CoC diameter `c` (pixels):
//! in-focus **IR** (`|c| ≤ in_focus_coc_px`), foreground out-of-focus **FOR** (`c < 0`
//! otherwise) or background out-of-focus **BOR** (`c > 0` otherwise). Each pair of adjacent
//! pixels `(p, q)` gets one feedback coefficient, by Konrad's four cases (`r = |c|/2`, clamped
//! to `max_radius_px`):
//!
//! | regions of p, q | coefficient | why |
//! |---|---|---|
//! | same region | `a(½(r_p + r_q))` | blur within a surface (IR: `r ≈ 0`, no blur) |
//! | IR – FOR | `a(r_FOR)` | a blurred foreground spreads over the in-focus pixel beside it |
//! | IR – BOR | `0` | a blurred background must not leak into an in-focus pixel (or get it) |
//! | FOR – BOR | `a(r_FOR)` | the foreground's blur dominates across the silhouette |
//!
//! The coefficients depend only on the CoC map, so they are computed once for the horizontal
//! pairs (used left→right and right→left) and once for the vertical pairs (top→bottom and
//! bottom→top), then reused by all three iterations.
//!
//! ## The recursion and the CoC → coefficient map
//!
//! Each direction runs the first-order recursive filter `y_n = (1 − a_n) x_n + a_n y_{n−1}`
//! with `a_n` the coefficient of the pair `(n−1, n)`; an iteration is left→right,
//! right→left, top→bottom, bottom→top, and the filter runs three iterations. For a constant
//! `a`, one causal pass has the impulse response `(1 − a) aᵏ` (variance `a/(1 − a)²`), so an
//! iteration is separable with per-axis variance `2a/(1 − a)²` and three iterations give
//! `6a/(1 − a)²`. A uniform disc of radius `r` has per-axis variance `r²/4`. Equating,
//!
//! ```text
//! a / (1 − a)² = s,  s = r² / 24     ⇒     a(r) = 2s / (2s + 1 + √(4s + 1))
//! ```
//!
//! (the root in `[0, 1)`, written so it is exact at `s = 0`: `a(0) = 0`, so zero CoC is the
//! identity). The result is a smooth, nearly Gaussian spread of the disc's second moment
//! (tested numerically below), not a hard-edged disc.
//!
//! ## Limits
//!
//! The recursion passes a blurred foreground into an in-focus neighbour through one IR–FOR
//! pair only; the next IR–IR pair has `a ≈ 0`. So a blurred foreground's silhouette over an
//! in-focus background spreads outward by one pixel, and softens only inward (the
//! background's colour diffuses into the foreground's blur through that pair): a 10–90 %
//! width of ~4 px where the thin lens gives ~8.6 px, off-centre. The filter cannot render
//! the foreground's blur spilling over the background. Each output costs 12 multiply-adds per channel
//! whatever the CoC; `max_radius_px` only clamps the radii.

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use super::disc::check_max_radius;
use super::{sanitize_coc, DofFilter, DofInput};
use crate::Rgb;

/// Xu et al.'s adaptive recursive filter with Konrad's four pair cases.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveRecursive {
    /// Largest CoC radius in pixels the coefficients follow. Default 32, valid `[0.5, 256]`.
    pub max_radius_px: f32,
    /// CoC diameters up to this many pixels count as in focus (IR). Default 1, valid `≥ 0`.
    pub in_focus_coc_px: f32,
    /// Iterations of the four directional passes. Default 3 (Konrad, Xu); valid `1..=8`.
    pub iterations: u32,
}

impl Default for AdaptiveRecursive {
    fn default() -> Self {
        Self {
            max_radius_px: 32.0,
            in_focus_coc_px: 1.0,
            iterations: 3,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Region {
    InFocus,
    Foreground,
    Background,
}

/// Feedback coefficient whose `iterations`-fold four-direction filter has the per-axis
/// variance `r²/4` of a disc of radius `radius_px`: `a/(1−a)² = r²/(8·iterations)`.
pub fn coefficient(radius_px: f32, iterations: u32) -> f32 {
    let s = radius_px * radius_px / (8.0 * iterations as f32);
    2.0 * s / (2.0 * s + 1.0 + (4.0 * s + 1.0).sqrt())
}

impl AdaptiveRecursive {
    /// Coefficient of the pair `(p, q)` from their signed CoCs (Konrad's four cases).
    fn pair(&self, cp: f32, cq: f32) -> f32 {
        let region = |c: f32| {
            if c.abs() <= self.in_focus_coc_px {
                Region::InFocus
            } else if c < 0.0 {
                Region::Foreground
            } else {
                Region::Background
            }
        };
        let r = |c: f32| (0.5 * c.abs()).min(self.max_radius_px);
        let a = |radius: f32| coefficient(radius, self.iterations);
        match (region(cp), region(cq)) {
            (x, y) if x == y => a(0.5 * (r(cp) + r(cq))),
            (Region::InFocus, Region::Background) | (Region::Background, Region::InFocus) => 0.0,
            (Region::Foreground, _) => a(r(cp)),
            (_, Region::Foreground) => a(r(cq)),
            _ => unreachable!("every mixed pair involves the foreground or IR–BOR"),
        }
    }
}

impl DofFilter for AdaptiveRecursive {
    fn name(&self) -> &'static str {
        "recursive"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        check_max_radius(self.max_radius_px, 0.5)?;
        if !(self.in_focus_coc_px >= 0.0 && self.in_focus_coc_px.is_finite()) {
            return Err(FoveaError::invalid(
                "in_focus_coc_px",
                self.in_focus_coc_px,
                "a finite diameter ≥ 0 px",
            ));
        }
        if !(1..=8).contains(&self.iterations) {
            return Err(FoveaError::invalid("iterations", self.iterations, "1 to 8"));
        }
        let (w, h) = input.size();
        let (w, h) = (w as usize, h as usize);
        let coc: Vec<f32> = input
            .coc_px
            .data()
            .iter()
            .map(|&c| sanitize_coc(c))
            .collect();
        // a_h[y·w + x]: pair (x, x+1); a_v[y·w + x]: pair (y, y+1). Computed once.
        let mut a_h = vec![0.0f32; w * h];
        a_h.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for x in 0..w - 1 {
                row[x] = self.pair(coc[y * w + x], coc[y * w + x + 1]);
            }
        });
        let mut a_v = vec![0.0f32; w * h];
        a_v.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            if y + 1 < h {
                for x in 0..w {
                    row[x] = self.pair(coc[y * w + x], coc[(y + 1) * w + x]);
                }
            }
        });
        let mut img = input.color.data().to_vec();
        for _ in 0..self.iterations {
            // Left→right then right→left, rows in parallel.
            img.par_chunks_mut(w)
                .zip(a_h.par_chunks(w))
                .for_each(|(row, a)| {
                    for x in 1..w {
                        row[x] = blend(row[x], row[x - 1], a[x - 1]);
                    }
                    for x in (0..w - 1).rev() {
                        row[x] = blend(row[x], row[x + 1], a[x]);
                    }
                });
            // Top→bottom then bottom→top, a row at a time (vectorises along x), columns
            // split across threads.
            let cols = w.div_ceil(rayon::current_num_threads().max(1)).max(64);
            let mut strips: Vec<Vec<Rgb>> = (0..w.div_ceil(cols))
                .map(|s| {
                    let x0 = s * cols;
                    let x1 = (x0 + cols).min(w);
                    (0..h)
                        .flat_map(|y| img[y * w + x0..y * w + x1].iter().copied())
                        .collect()
                })
                .collect();
            strips.par_iter_mut().enumerate().for_each(|(s, strip)| {
                let x0 = s * cols;
                let sw = (x0 + cols).min(w) - x0;
                for y in 1..h {
                    let (prev, cur) = strip.split_at_mut(y * sw);
                    let prev = &prev[(y - 1) * sw..];
                    for k in 0..sw {
                        cur[k] = blend(cur[k], prev[k], a_v[(y - 1) * w + x0 + k]);
                    }
                }
                for y in (0..h - 1).rev() {
                    let (cur, next) = strip.split_at_mut((y + 1) * sw);
                    let cur = &mut cur[y * sw..];
                    for k in 0..sw {
                        cur[k] = blend(cur[k], next[k], a_v[y * w + x0 + k]);
                    }
                }
            });
            for (s, strip) in strips.iter().enumerate() {
                let x0 = s * cols;
                let sw = (x0 + cols).min(w) - x0;
                for y in 0..h {
                    img[y * w + x0..y * w + x0 + sw].copy_from_slice(&strip[y * sw..(y + 1) * sw]);
                }
            }
        }
        Image::from_vec(w as u32, h as u32, img)
    }
}

/// `(1 − a) x + a y`, per channel.
#[inline]
fn blend(x: Rgb, y: Rgb, a: f32) -> Rgb {
    [
        x[0] + a * (y[0] - x[0]),
        x[1] + a * (y[1] - x[1]),
        x[2] + a * (y[2] - x[2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;

    fn f() -> AdaptiveRecursive {
        AdaptiveRecursive::default()
    }

    #[test]
    fn coefficient_solves_the_variance_equation() {
        assert_eq!(coefficient(0.0, 3), 0.0);
        for r in [0.5f32, 2.0, 8.0, 30.0] {
            let a = coefficient(r, 3);
            let var = 6.0 * a / ((1.0 - a) * (1.0 - a));
            assert!((var / (r * r / 4.0) - 1.0).abs() < 1e-4, "r {r}: {var}");
        }
    }

    #[test]
    fn impulse_spread_matches_a_disc() {
        // A single bright pixel on a uniformly blurred far plane: the filter's per-axis
        // variance must be the disc's r²/4 and its energy conserved.
        let (n, c) = (161u32, 80u32);
        let r = 8.0f32;
        let mut color = Image::new(n, n, [0.0f32; 3]).unwrap();
        *color.get_mut(c, c) = [1.0; 3];
        let depth = Image::new(n, n, 2.0f32).unwrap();
        let coc = Image::new(n, n, 2.0 * r).unwrap();
        let input = DofInput {
            color: &color,
            depth_m: &depth,
            coc_px: &coc,
            focus_m: 1.0,
            px_per_dioptre: 1.0,
            gaze_px: [0.0; 2],
            px_per_degree: 20.0,
        };
        let out = f().apply(&input).unwrap();
        let (mut sum, mut vx, mut vy, mut inside) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for y in 0..n {
            for x in 0..n {
                let v = out.get(x, y)[0] as f64;
                let (dx, dy) = (x as f64 - c as f64, y as f64 - c as f64);
                sum += v;
                vx += v * dx * dx;
                vy += v * dy * dy;
                if dx.hypot(dy) <= r as f64 {
                    inside += v;
                }
            }
        }
        let disc_var = (r * r / 4.0) as f64;
        eprintln!(
            "recursive impulse: energy {sum:.4}, var x {:.2} y {:.2} (disc {disc_var:.2}), \
             {:.1} % within r (disc 100 %)",
            vx / sum,
            vy / sum,
            100.0 * inside / sum
        );
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        assert!((vx / sum / disc_var - 1.0).abs() < 0.03, "{}", vx / sum);
        assert!((vy / sum / disc_var - 1.0).abs() < 0.03, "{}", vy / sum);
        // A Gaussian of that σ = r/2 holds 1 − e^{−2} ≈ 86 % within r.
        assert!(inside / sum > 0.8, "{}", inside / sum);
    }

    #[test]
    fn constant_plane_against_thin_lens() {
        let case = Case::new(&single_plane(64, 48, 2.0), 8.0, 0.5, 256);
        let p = case.psnr(&f(), 8);
        eprintln!("recursive plane: {p:.2} dB");
        assert!(p > 30.0, "{p:.2} dB");
    }

    #[test]
    fn occluder_scenes_psnr() {
        let k = 16.0 / 1.5;
        for edge in [Edge::Straight(40.0), Edge::Circle(40.0, 32.0, 18.0)] {
            let scene = occluder_scene(80, 64, edge, true);
            for focus in [0.5f32, 2.0] {
                let case = Case::new(&scene, k, focus, 400);
                let p = case.psnr(&f(), 8);
                eprintln!("recursive {edge:?} focus {focus} m: {p:.2} dB");
                assert!(p >= 22.0, "{edge:?} focus {focus}: {p:.2} dB");
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
        eprintln!("recursive sharp edge: {width:.2} px");
        assert!(width <= 1.5, "{width}");
    }

    #[test]
    fn blurred_foreground_edge_is_nearly_hard() {
        // Documented limitation: the IR–IR pairs stop the foreground's spread after one
        // pixel, so the rim softens only inward (the IR–FOR pair lets the background into
        // the foreground's blur). The thin lens gives ~8.6 px, centred on the silhouette.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(32.0), false),
            12.0 / 1.5,
            2.0,
            64,
        );
        let out = f().apply(&case.input()).unwrap();
        let width = edge_width(&column_profile(&out, 4, 20), 4);
        eprintln!("recursive blurred-foreground edge: {width:.2} px");
        assert!(width > 1.5 && width < 6.0, "{width}");
        // Outward: one pixel past the silhouette (x ≥ 32) is already the background.
        let p = column_profile(&out, 4, 20);
        let input = column_profile(&case.color, 4, 20);
        assert!((p[33] - input[33]).abs() < 1e-4, "{p:?}");
    }

    #[test]
    fn bad_parameters_are_errors() {
        let frame = nan_frame();
        for bad in [
            AdaptiveRecursive {
                iterations: 0,
                ..f()
            },
            AdaptiveRecursive {
                in_focus_coc_px: f32::NAN,
                ..f()
            },
        ] {
            assert!(bad.apply(&frame.input()).is_err());
        }
    }
}
