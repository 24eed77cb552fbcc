//! Scatter-as-gather depth of field with near/far layers — the game-engine baseline
//! (Jimenez 2014, "Next-generation post-processing in Call of Duty: Advanced Warfare";
//! the same idea drives UE4's circle DOF). None of the five papers: this is the filter the
//! others are compared with, and the one tuned against the exact thin-lens ground truth of
//! [`super::planes`].
//!
//! ## What it computes
//!
//! A thin lens spreads the light of a pinhole pixel `P` uniformly over its circle of
//! confusion, a disc of radius `r_P = |c_P|/2` pixels (`c_P` the signed CoC diameter of
//! [`DofInput::coc_px`]). Scattering is inverted into a gather: the output pixel `C` visits
//! every `P` within the largest CoC that can reach it and takes
//!
//! ```text
//! w(P→C) = cov(ρ, |P−C|) / A(ρ_w)      cov(ρ, d) = clamp(ρ − d + ½, 0, 1)   (anti-aliased disc)
//! ```
//!
//! where `A(ρ) = Σ_o cov(ρ, |o|)` is the discrete area of that disc (≈ π ρ², exactly the sum
//! of the coverage over integer offsets, so a disc's weights sum to 1) and every radius is
//! clamped to `[0.5, max_radius_px]` (a pixel covers at least itself). Which disc `P` uses
//! depends on its depth `z_P` relative to `z_C` (relative tolerance `depth_tolerance`):
//!
//! * **in front** (`z_P < z_C(1 − tol)`): the *near layer*; `ρ = ρ_w = r_P`. A blurred
//!   foreground spreads over whatever lies behind it, giving soft silhouettes.
//! * **same surface**: the *far layer*; `ρ = ρ_w = r_P`.
//! * **behind** (`z_P > z_C(1 + tol)`): the far layer, with the *leakage clamp*. Classic
//!   (`fill_behind = false`, Jimenez): `ρ = min(r_P, r_C)`, `ρ_w = r_P` — a sharp `C`
//!   (`r_C = ½`) receives nothing from behind, so an in-focus foreground keeps its edge.
//!   Default (`fill_behind = true`): `ρ = ρ_w = r_C` — the background seen *near* `C`
//!   stands in for the background the thin lens sees *through* the blurred rim of a
//!   foreground at `C` (hidden in the pinhole image). Its weights then sum to the fraction
//!   of `C`'s own disc that the background occupies, which is the fraction of the lens that
//!   looks past the foreground edge. With `r_C = ½` it is as leak-free as the classic clamp.
//!
//! The layers are composited front to back, the near layer acting as a coverage mask:
//!
//! ```text
//! α = min(1, Σ_near w)      out = α · (Σ_near w c / Σ_near w) + (1 − α) · (Σ_far w c / Σ_far w)
//! ```
//!
//! which is the thin-lens result wherever the pinhole image shows what the lens sees
//! (`separate_near = false` puts every sample in one normalised sum instead, as simple
//! gather filters do). `C` itself is always in the far layer with weight > 0, so nothing
//! divides by zero, and with every CoC ≤ 1 px the output is the input, bit for bit.
//!
//! ## Cost
//!
//! The gather radius of a pixel is the largest CoC radius among the 16×16 tiles whose
//! pixels can reach it (a dilated tile-max, as in Jimenez's tile pass), never more than
//! `max_radius_px`: `O(π R²)` taps per pixel, rows in parallel, no allocation per pixel.
//! The disc offsets (sorted by distance) and the area table are built once per call.

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use super::{sanitize_coc, sanitize_depth, DofFilter, DofInput};
use crate::Rgb;

/// Scatter-as-gather near/far DOF filter (see the module docs for the formulas).
#[derive(Clone, Debug, PartialEq)]
pub struct ScatterAsGather {
    /// Largest gather radius in pixels; CoC radii are clamped to it. Default 32, valid
    /// `[0.5, 256]`.
    pub max_radius_px: f32,
    /// Relative depth difference below which two pixels count as one surface. Default 0.02
    /// (2 %), valid `[0, 1)`.
    pub depth_tolerance: f32,
    /// Background samples behind `C` use `C`'s CoC (`true`, default) or the classic
    /// `min(r_P, r_C)` clamp with `P`'s weight (`false`).
    pub fill_behind: bool,
    /// Composite the near layer over the far one by its coverage (`true`, default) or
    /// normalise all samples together (`false`).
    pub separate_near: bool,
}

impl Default for ScatterAsGather {
    fn default() -> Self {
        Self {
            max_radius_px: 32.0,
            depth_tolerance: 0.02,
            fill_behind: true,
            separate_near: true,
        }
    }
}

impl DofFilter for ScatterAsGather {
    fn name(&self) -> &'static str {
        "gather"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        check_max_radius(self.max_radius_px)?;
        if !(self.depth_tolerance >= 0.0 && self.depth_tolerance < 1.0) {
            return Err(FoveaError::invalid(
                "depth_tolerance",
                self.depth_tolerance,
                "a relative tolerance in [0, 1)",
            ));
        }
        let prep = Prepared::new(input, self.max_radius_px);
        let disc = Disc::new(self.max_radius_px);
        let area = AreaLut::new(&disc, self.max_radius_px);
        let reach = TileReach::new(&prep.radius_px, prep.w, prep.h, self.max_radius_px);
        // [z_P, r_P, 1/A(r_P)] per pixel: one load per tap.
        let pix = prep.packed(&area);
        let (w, h) = (prep.w, prep.h);
        let front = 1.0 - self.depth_tolerance;
        let back = 1.0 + self.depth_tolerance;
        let mut out = vec![[0.0f32; 3]; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let reach_px = reach.at(x, y);
                if reach_px <= 0.5 {
                    *o = prep.color[i];
                    continue;
                }
                let zc = prep.depth_m[i];
                let rc = prep.radius_px[i];
                let inv_area_c = area.inv(rc);
                let mut near = [0.0f32; 4];
                let mut far = [0.0f32; 4];
                for &(dx, dy, d) in disc.within(reach_px) {
                    let (px, py) = (x as i32 + dx, y as i32 + dy);
                    if px < 0 || py < 0 || px >= w as i32 || py >= h as i32 {
                        continue;
                    }
                    let j = py as usize * w + px as usize;
                    let [zp, rp, inv_area_p, _] = pix[j];
                    let (wt, acc) = if zp < zc * front {
                        // In front of C: spreads over it with its own disc.
                        let acc = if self.separate_near {
                            &mut near
                        } else {
                            &mut far
                        };
                        (coverage(rp, d) * inv_area_p, acc)
                    } else if zp > zc * back {
                        // Behind C: never wider than C's own disc (leakage clamp).
                        if self.fill_behind {
                            (coverage(rc, d) * inv_area_c, &mut far)
                        } else {
                            (coverage(rp.min(rc), d) * inv_area_p, &mut far)
                        }
                    } else {
                        (coverage(rp, d) * inv_area_p, &mut far)
                    };
                    if wt > 0.0 {
                        let c = prep.color[j];
                        acc[0] += wt * c[0];
                        acc[1] += wt * c[1];
                        acc[2] += wt * c[2];
                        acc[3] += wt;
                    }
                }
                let far_c = normalise(far, prep.color[i]);
                *o = if near[3] > 0.0 {
                    let alpha = near[3].min(1.0);
                    let near_c = normalise(near, far_c);
                    [
                        alpha * near_c[0] + (1.0 - alpha) * far_c[0],
                        alpha * near_c[1] + (1.0 - alpha) * far_c[1],
                        alpha * near_c[2] + (1.0 - alpha) * far_c[2],
                    ]
                } else {
                    far_c
                };
            }
        });
        Image::from_vec(w as u32, h as u32, out)
    }
}

/// `acc = [Σ w r, Σ w g, Σ w b, Σ w]` divided out, or `fallback` when `Σ w = 0`.
#[inline]
pub(crate) fn normalise(acc: [f32; 4], fallback: Rgb) -> Rgb {
    if acc[3] > 0.0 {
        let inv = 1.0 / acc[3];
        [acc[0] * inv, acc[1] * inv, acc[2] * inv]
    } else {
        fallback
    }
}

/// Anti-aliased disc coverage of a pixel at distance `d_px` from the centre of a disc of
/// radius `radius_px`: `clamp(r − d + ½, 0, 1)` (1 inside, 0 beyond `r + ½`, linear between).
#[inline]
pub(crate) fn coverage(radius_px: f32, d_px: f32) -> f32 {
    (radius_px - d_px + 0.5).clamp(0.0, 1.0)
}

/// Errors unless `max_radius_px` is in `[0.5, 256]`.
pub(crate) fn check_max_radius(max_radius_px: f32) -> Result<()> {
    if (0.5..=256.0).contains(&max_radius_px) {
        Ok(())
    } else {
        Err(FoveaError::invalid(
            "max_radius_px",
            max_radius_px,
            "a radius in [0.5, 256] pixels",
        ))
    }
}

/// CoC radius of a signed CoC diameter: `clamp(|c|/2, ½, max)` pixels (NaN → ½).
#[inline]
pub(crate) fn radius_px(coc_px: f32, max_radius_px: f32) -> f32 {
    (0.5 * sanitize_coc(coc_px).abs()).clamp(0.5, max_radius_px)
}

/// Per-pixel planes a gather filter reads, sanitised once: colour, depth (NaN → +∞), signed
/// CoC (NaN → 0) and clamped CoC radius.
pub(crate) struct Prepared<'a> {
    pub w: usize,
    pub h: usize,
    pub color: &'a [Rgb],
    pub depth_m: Vec<f32>,
    pub coc_px: Vec<f32>,
    pub radius_px: Vec<f32>,
}

impl<'a> Prepared<'a> {
    pub fn new(input: &DofInput<'a>, max_radius_px: f32) -> Self {
        let (w, h) = input.size();
        let coc_px: Vec<f32> = input
            .coc_px
            .data()
            .iter()
            .map(|&c| sanitize_coc(c))
            .collect();
        Self {
            w: w as usize,
            h: h as usize,
            color: input.color.data(),
            depth_m: input
                .depth_m
                .data()
                .iter()
                .map(|&d| sanitize_depth(d))
                .collect(),
            radius_px: coc_px
                .iter()
                .map(|&c| radius_px(c, max_radius_px))
                .collect(),
            coc_px,
        }
    }

    /// `[z_P, r_P, 1/A(r_P), c_P]` per pixel, packed for the gather loops.
    pub fn packed(&self, area: &AreaLut) -> Vec<[f32; 4]> {
        (0..self.w * self.h)
            .map(|i| {
                let r = self.radius_px[i];
                [self.depth_m[i], r, area.inv(r), self.coc_px[i]]
            })
            .collect()
    }
}

/// Integer offsets of a disc, sorted by distance, with their distances.
pub(crate) struct Disc {
    offsets: Vec<(i32, i32, f32)>,
}

impl Disc {
    /// Every offset with `|o| ≤ max_radius_px + ½` (the support of [`coverage`]).
    pub fn new(max_radius_px: f32) -> Self {
        let r = max_radius_px + 0.5;
        let n = r.ceil() as i32;
        let mut offsets = Vec::with_capacity(((2 * n + 1) * (2 * n + 1)) as usize);
        for dy in -n..=n {
            for dx in -n..=n {
                let d = ((dx * dx + dy * dy) as f32).sqrt();
                if d <= r {
                    offsets.push((dx, dy, d));
                }
            }
        }
        offsets.sort_by(|a, b| a.2.total_cmp(&b.2));
        Self { offsets }
    }

    /// The offsets a disc of radius `radius_px` can cover (`|o| < r + ½`).
    #[inline]
    pub fn within(&self, radius_px: f32) -> &[(i32, i32, f32)] {
        let n = self.offsets.partition_point(|o| o.2 < radius_px + 0.5);
        &self.offsets[..n]
    }
}

/// `1 / A(r)` with `A(r) = Σ_o coverage(r, |o|)`, tabulated every 1/16 px from ½ to the
/// largest radius and linearly interpolated.
pub(crate) struct AreaLut {
    inv_area: Vec<f32>,
}

const LUT_STEPS_PER_PX: f32 = 16.0;

impl AreaLut {
    pub fn new(disc: &Disc, max_radius_px: f32) -> Self {
        let n = ((max_radius_px - 0.5) * LUT_STEPS_PER_PX).ceil() as usize + 2;
        let inv_area = (0..n)
            .map(|k| {
                let r = 0.5 + k as f32 / LUT_STEPS_PER_PX;
                let a: f32 = disc.within(r).iter().map(|o| coverage(r, o.2)).sum();
                1.0 / a.max(1.0)
            })
            .collect();
        Self { inv_area }
    }

    /// `1 / A(radius_px)`, `radius_px ≥ ½`.
    #[inline]
    pub fn inv(&self, radius_px: f32) -> f32 {
        let t = ((radius_px - 0.5) * LUT_STEPS_PER_PX).max(0.0);
        let k = (t as usize).min(self.inv_area.len() - 2);
        let f = (t - k as f32).min(1.0);
        self.inv_area[k] + f * (self.inv_area[k + 1] - self.inv_area[k])
    }
}

/// Per-tile gather radius: the largest radius `r_P` of any pixel `P` whose disc can reach
/// the tile (tile-max, dilated by each tile's own max), at least the tile's own max.
pub(crate) struct TileReach {
    tw: usize,
    reach_px: Vec<f32>,
}

const TILE: usize = 16;

impl TileReach {
    pub fn new(radius_px: &[f32], w: usize, h: usize, max_radius_px: f32) -> Self {
        let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let mut tile_max = vec![0.0f32; tw * th];
        for y in 0..h {
            for x in 0..w {
                let t = (y / TILE) * tw + x / TILE;
                tile_max[t] = tile_max[t].max(radius_px[y * w + x]);
            }
        }
        let span = ((max_radius_px + 0.5) / TILE as f32).ceil() as isize + 1;
        let mut reach_px = vec![0.0f32; tw * th];
        for ty in 0..th as isize {
            for tx in 0..tw as isize {
                let mut r = tile_max[ty as usize * tw + tx as usize];
                for sy in (ty - span).max(0)..=(ty + span).min(th as isize - 1) {
                    for sx in (tx - span).max(0)..=(tx + span).min(tw as isize - 1) {
                        let m = tile_max[sy as usize * tw + sx as usize];
                        if m <= r {
                            continue;
                        }
                        // Gap between the two tiles' pixel centres, in pixels.
                        let gx = ((sx - tx).abs() - 1).max(0) as f32 * TILE as f32;
                        let gy = ((sy - ty).abs() - 1).max(0) as f32 * TILE as f32;
                        let gx = if sx != tx { gx + 1.0 } else { 0.0 };
                        let gy = if sy != ty { gy + 1.0 } else { 0.0 };
                        if gx.hypot(gy) < m + 0.5 {
                            r = m;
                        }
                    }
                }
                reach_px[ty as usize * tw + tx as usize] = r;
            }
        }
        Self { tw, reach_px }
    }

    /// Gather radius at pixel `(x, y)`.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.reach_px[(y / TILE) * self.tw + x / TILE]
    }
}

/// Scenes, metrics and fixtures the DOF filter tests share.
#[cfg(test)]
pub(crate) mod testkit {
    use super::super::planes::{Plane, PlaneScene};
    use super::super::{DofFilter, DofInput};
    use crate::{luma, Rgb};
    use fovea_core::Image;

    /// Hash of an integer lattice point to `[0, 1)`.
    pub fn hash(ix: i32, iy: i32, seed: u32) -> f32 {
        let mut h = (ix as u32).wrapping_mul(0x8da6_b343)
            ^ (iy as u32).wrapping_mul(0xd816_3841)
            ^ seed.wrapping_mul(0xcb1a_b31f);
        h ^= h >> 13;
        h = h.wrapping_mul(0x5bd1_e995);
        h ^= h >> 15;
        (h >> 8) as f32 / (1u32 << 24) as f32
    }

    /// A pixel-constant texture: 8-px checker (±`checker`) plus per-pixel noise
    /// (±`noise`) around `base`.
    pub fn texture(base: Rgb, checker: f32, noise: f32, seed: u32) -> impl Fn(f32, f32) -> Rgb {
        move |x: f32, y: f32| {
            let (ix, iy) = (x.floor() as i32, y.floor() as i32);
            let ch = if ((ix >> 3) + (iy >> 3)) & 1 == 0 {
                1.0
            } else {
                -1.0
            };
            let s = 1.0 + checker * ch;
            let mut c = [0.0; 3];
            for k in 0..3 {
                let n = noise * (2.0 * hash(ix, iy, seed + k as u32) - 1.0);
                c[k] = (base[k] * s + n).clamp(0.0, 1.0);
            }
            c
        }
    }

    /// Shape of the near occluder.
    #[derive(Clone, Copy, Debug)]
    pub enum Edge {
        /// Opaque for `x < x0` (a vertical edge).
        Straight(f32),
        /// Opaque inside a disc `(cx, cy, radius)`.
        Circle(f32, f32, f32),
    }

    /// Near plane at 0.5 m (occluder of shape `edge`) over a far plane at 2 m filling the
    /// frame. `textured_near` selects a textured or a flat bright occluder.
    pub fn occluder_scene(w: u32, h: u32, edge: Edge, textured_near: bool) -> PlaneScene {
        let near_tex = texture([0.85, 0.7, 0.5], 0.15, 0.08, 11);
        let far_tex = texture([0.25, 0.35, 0.45], 0.35, 0.12, 23);
        PlaneScene {
            width: w,
            height: h,
            planes: vec![
                Plane {
                    depth_m: 0.5,
                    color: if textured_near {
                        Box::new(near_tex)
                    } else {
                        Box::new(|_, _| [0.9, 0.85, 0.8])
                    },
                    opaque: match edge {
                        Edge::Straight(x0) => Box::new(move |x, _| x < x0),
                        Edge::Circle(cx, cy, r) => Box::new(move |x, y| (x - cx).hypot(y - cy) < r),
                    },
                },
                Plane {
                    depth_m: 2.0,
                    color: Box::new(far_tex),
                    opaque: Box::new(|_, _| true),
                },
            ],
            background: [0.0; 3],
        }
    }

    /// One textured plane at `depth_m` filling the frame.
    pub fn single_plane(w: u32, h: u32, depth_m: f32) -> PlaneScene {
        PlaneScene {
            width: w,
            height: h,
            planes: vec![Plane {
                depth_m,
                color: Box::new(texture([0.4, 0.5, 0.3], 0.4, 0.15, 5)),
                opaque: Box::new(|_, _| true),
            }],
            background: [0.0; 3],
        }
    }

    /// A scene's pinhole image, depth, thin-lens CoC map (`k·(1/F − 1/D)`) and ground truth.
    pub struct Case {
        pub color: Image<Rgb>,
        pub depth: Image<f32>,
        pub coc: Image<f32>,
        pub truth: Image<Rgb>,
        pub focus_m: f32,
        pub k: f32,
    }

    impl Case {
        pub fn new(scene: &PlaneScene, px_per_dioptre: f32, focus_m: f32, lens: u32) -> Self {
            let (color, depth) = scene.pinhole().unwrap();
            let coc = depth.map(|&d| px_per_dioptre * (1.0 / focus_m - 1.0 / d));
            let truth = scene.thin_lens(px_per_dioptre, focus_m, lens).unwrap();
            Self {
                color,
                depth,
                coc,
                truth,
                focus_m,
                k: px_per_dioptre,
            }
        }

        pub fn input(&self) -> DofInput<'_> {
            DofInput {
                color: &self.color,
                depth_m: &self.depth,
                coc_px: &self.coc,
                focus_m: self.focus_m,
                px_per_dioptre: self.k,
                gaze_px: [0.0, 0.0],
                px_per_degree: 20.0,
            }
        }

        /// Luma PSNR of `filter`'s output against the thin-lens truth, `margin` px border
        /// excluded (the truth sees texture beyond the frame).
        pub fn psnr(&self, filter: &dyn DofFilter, margin: u32) -> f64 {
            let out = filter.apply(&self.input()).unwrap();
            luma_psnr(&out, &self.truth, margin)
        }
    }

    /// Luma PSNR (peak 1) over the frame less a `margin`-pixel border.
    pub fn luma_psnr(a: &Image<Rgb>, b: &Image<Rgb>, margin: u32) -> f64 {
        let (w, h) = (a.width(), a.height());
        let mut se = 0.0f64;
        let mut n = 0usize;
        for y in margin..h - margin {
            for x in margin..w - margin {
                let e = (luma(*a.get(x, y)) - luma(*b.get(x, y))) as f64;
                se += e * e;
                n += 1;
            }
        }
        10.0 * (1.0 / (se / n as f64).max(1e-12)).log10()
    }

    /// Mean luma of each column over rows `y0..y1`.
    pub fn column_profile(img: &Image<Rgb>, y0: u32, y1: u32) -> Vec<f32> {
        (0..img.width())
            .map(|x| (y0..y1).map(|y| luma(*img.get(x, y))).sum::<f32>() / (y1 - y0) as f32)
            .collect()
    }

    /// 10–90 % rise distance (pixels) of a profile between its plateaus: the mean of the
    /// first and last `plateau` samples. The crossings are linearly interpolated; the
    /// distance is between the first 10 % and the last 90 % crossing (a bump or ringing
    /// widens it).
    pub fn edge_width(profile: &[f32], plateau: usize) -> f32 {
        let n = profile.len();
        let a = profile[..plateau].iter().sum::<f32>() / plateau as f32;
        let b = profile[n - plateau..].iter().sum::<f32>() / plateau as f32;
        // Normalised 0 (left plateau) … 1 (right plateau).
        let t: Vec<f32> = profile.iter().map(|&v| (v - a) / (b - a)).collect();
        let crossing = |level: f32, first: bool| -> f32 {
            let idx: Vec<usize> = (0..n - 1)
                .filter(|&i| (t[i] - level) * (t[i + 1] - level) <= 0.0 && t[i] != t[i + 1])
                .collect();
            let i = if first { idx[0] } else { *idx.last().unwrap() };
            i as f32 + (level - t[i]) / (t[i + 1] - t[i])
        };
        // From the last sample still below 10 % to the first above 90 %, measured outward:
        // the 10 % crossing nearest the left plateau and the 90 % crossing nearest the right.
        (crossing(0.9, false) - crossing(0.1, true)).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::testkit::*;
    use super::*;

    fn f() -> ScatterAsGather {
        ScatterAsGather::default()
    }

    #[test]
    fn zero_coc_is_identity() {
        let case = Case::new(
            &occluder_scene(48, 32, Edge::Straight(20.0), true),
            0.0,
            1.0,
            1,
        );
        let out = f().apply(&case.input()).unwrap();
        assert_eq!(out, case.color);
    }

    #[test]
    fn area_table_normalises_discs() {
        let disc = Disc::new(32.0);
        let lut = AreaLut::new(&disc, 32.0);
        for r in [0.5f32, 0.8, 1.0, 2.3, 7.9, 16.0, 31.7] {
            let s: f32 = disc.within(r).iter().map(|o| coverage(r, o.2)).sum();
            assert!(
                (s * lut.inv(r) - 1.0).abs() < 0.02,
                "r {r}: {}",
                s * lut.inv(r)
            );
            // And close to π r² (the anti-aliased disc has the right area).
            if r >= 2.0 {
                let pi_r2 = std::f32::consts::PI * r * r;
                assert!((s / pi_r2 - 1.0).abs() < 0.05, "r {r}: {s} vs {pi_r2}");
            }
        }
    }

    #[test]
    fn tile_reach_covers_every_disc() {
        // One pixel with a 20 px radius: every pixel its disc covers must gather ≥ 20.
        let (w, h) = (80usize, 60usize);
        let mut r = vec![0.5f32; w * h];
        r[30 * w + 40] = 20.0;
        let reach = TileReach::new(&r, w, h, 32.0);
        for y in 0..h {
            for x in 0..w {
                let d = ((x as f32 - 40.0).powi(2) + (y as f32 - 30.0).powi(2)).sqrt();
                if d < 20.5 {
                    assert!(reach.at(x, y) >= 20.0, "({x},{y})");
                }
            }
        }
    }

    #[test]
    fn constant_plane_matches_thin_lens() {
        // Plane at 2 m, focus 0.5 m: c = 8·1.5 = 12 px.
        let case = Case::new(&single_plane(64, 48, 2.0), 8.0, 0.5, 256);
        let p = case.psnr(&f(), 8);
        eprintln!("gather plane: {p:.2} dB");
        assert!(p > 40.0, "gather on a plane: {p:.2} dB");
    }

    #[test]
    fn occluder_scenes_reach_33_db() {
        // |c| = 16 px for the blurred plane in each configuration.
        let k = 16.0 / 1.5;
        for edge in [Edge::Straight(40.0), Edge::Circle(40.0, 32.0, 18.0)] {
            let scene = occluder_scene(80, 64, edge, true);
            for focus in [0.5f32, 2.0] {
                let case = Case::new(&scene, k, focus, 400);
                let p = case.psnr(&f(), 8);
                let classic = case.psnr(
                    &ScatterAsGather {
                        fill_behind: false,
                        ..f()
                    },
                    8,
                );
                let one = case.psnr(
                    &ScatterAsGather {
                        separate_near: false,
                        ..f()
                    },
                    8,
                );
                eprintln!(
                    "gather {edge:?} focus {focus} m: {p:.2} dB (classic clamp {classic:.2}, one layer {one:.2})"
                );
                assert!(p >= 33.0, "{edge:?} focus {focus}: {p:.2} dB");
            }
        }
    }

    #[test]
    fn sharp_foreground_keeps_its_edge() {
        // Focus on the flat near occluder (x < 30); textured far plane blurred to c = 20 px.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(30.0), false),
            20.0 / 1.5,
            0.5,
            64,
        );
        let out = f().apply(&case.input()).unwrap();
        let width = edge_width(&column_profile(&out, 4, 20), 6);
        let truth = edge_width(&column_profile(&case.truth, 4, 20), 6);
        eprintln!("gather sharp edge: {width:.2} px (thin lens {truth:.2} px)");
        assert!(width <= 1.5, "{width}");
    }

    #[test]
    fn blurred_foreground_has_soft_edges() {
        // Focus on the far plane; the flat near occluder blurred to c = −12 px.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(32.0), false),
            12.0 / 1.5,
            2.0,
            256,
        );
        let out = f().apply(&case.input()).unwrap();
        let width = edge_width(&column_profile(&out, 4, 20), 4);
        let truth = edge_width(&column_profile(&case.truth, 4, 20), 4);
        eprintln!("gather soft edge: {width:.2} px (thin lens {truth:.2} px)");
        assert!(
            width > 5.0 && (width - truth).abs() < 2.0,
            "{width} vs {truth}"
        );
    }

    /// Cost report, not a check (`cargo test … -- --ignored --nocapture`): the four
    /// filters on a 960×540 frame whose CoC runs from −`c` to +`c` px across it.
    #[test]
    #[ignore]
    fn timing_960x540() {
        use super::super::{adaptive_coc, bilateral, recursive};
        let (w, h) = (960u32, 540u32);
        let tex = texture([0.4, 0.5, 0.3], 0.4, 0.15, 5);
        let color = Image::from_vec(
            w,
            h,
            (0..w * h)
                .map(|k| tex((k % w) as f32, (k / w) as f32))
                .collect(),
        )
        .unwrap();
        let depth = Image::new(w, h, 1.0f32).unwrap();
        for c in [16.0f32, 32.0] {
            let coc = Image::from_vec(
                w,
                h,
                (0..w * h)
                    .map(|k| c * (2.0 * (k % w) as f32 / w as f32 - 1.0))
                    .collect(),
            )
            .unwrap();
            let input = DofInput {
                color: &color,
                depth_m: &depth,
                coc_px: &coc,
                focus_m: 1.0,
                px_per_dioptre: 1.0,
                gaze_px: [0.0; 2],
                px_per_degree: 20.0,
            };
            let filters: [Box<dyn DofFilter>; 4] = [
                Box::new(f()),
                Box::new(adaptive_coc::AdaptiveCoc::default()),
                Box::new(bilateral::DepthBilateral::default()),
                Box::new(recursive::AdaptiveRecursive::default()),
            ];
            for filt in &filters {
                let t = std::time::Instant::now();
                filt.apply(&input).unwrap();
                eprintln!(
                    "TIMING {} |c| ≤ {c} px: {:.3} s",
                    filt.name(),
                    t.elapsed().as_secs_f64()
                );
            }
        }
    }

    #[test]
    fn nan_inputs_give_finite_output() {
        let case = Case::new(
            &occluder_scene(40, 30, Edge::Straight(20.0), true),
            8.0,
            0.5,
            1,
        );
        let mut depth = case.depth.clone();
        let mut coc = case.coc.clone();
        for k in (0..depth.data().len()).step_by(7) {
            depth.data_mut()[k] = f32::NAN;
        }
        for k in (0..coc.data().len()).step_by(5) {
            coc.data_mut()[k] = if k % 2 == 0 { f32::NAN } else { f32::INFINITY };
        }
        let input = DofInput {
            depth_m: &depth,
            coc_px: &coc,
            ..case.input()
        };
        let out = f().apply(&input).unwrap();
        assert!(out.data().iter().all(|c| c.iter().all(|v| v.is_finite())));
        assert!(ScatterAsGather {
            max_radius_px: f32::NAN,
            ..f()
        }
        .apply(&input)
        .is_err());
    }
}
