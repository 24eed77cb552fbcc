//! FXAA inside a sample buffer, after Lottes' FXAA 3.11 "quality" variant, as VaFR Sec. 6
//! applies it in the LP buffer before the inverse mapping (so one pass of a cheap screen-space
//! filter on ~1 M LP pixels anti-aliases what becomes the whole screen).
//!
//! Per pixel: local luma contrast of the 4-neighbourhood against
//! `max(edge_threshold_min, edge_threshold · max luma)`; below it the pixel is left alone.
//! Otherwise the edge orientation is chosen from second differences of the 3×3 luma
//! neighbourhood, the edge is followed both ways (up to `search_steps` pixels) until the mean
//! luma of the pixel pair leaves the edge, and the pixel is blended towards its neighbour
//! across the edge by `½ − (distance to the nearer end)/(edge length)`, or by the
//! sub-pixel aliasing estimate if larger (`subpix` scales that term, 0.75 by default).
//!
//! The neighbourhood comes from a [`Grid`], so in a polar buffer the filter wraps across the
//! angular seam and compares columns at equal angles.
//!
//! Luma is computed on tone-mapped linear luminance, `√(Y/(1+Y))`, the perceptual-ish space
//! FXAA's thresholds assume.

use rayon::prelude::*;

use fovea_core::Image;

use crate::grid::Grid;
use crate::{lerp3, luma, Rgb};

/// FXAA settings (defaults: Lottes' "default quality" preset).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FxaaParams {
    /// Relative contrast threshold (0.166 default; 0.063–0.333).
    pub edge_threshold: f32,
    /// Absolute contrast threshold for dark areas (0.0833 default).
    pub edge_threshold_min: f32,
    /// Amount of sub-pixel aliasing removal in [0, 1] (0.75 default).
    pub subpix: f32,
    /// Maximum steps of the edge search each way (12 default).
    pub search_steps: u32,
}

impl Default for FxaaParams {
    fn default() -> Self {
        Self {
            edge_threshold: 0.166,
            edge_threshold_min: 0.0833,
            subpix: 0.75,
            search_steps: 12,
        }
    }
}

#[inline]
fn perceptual(c: Rgb) -> f32 {
    let y = luma(c).max(0.0);
    (y / (1.0 + y)).sqrt()
}

/// Applies FXAA to `img` (only the pixels the grid marks valid), returning the filtered image.
pub fn fxaa(img: &Image<Rgb>, grid: &Grid, params: &FxaaParams) -> Image<Rgb> {
    let (w, h) = (img.width(), img.height());
    let lum: Vec<f32> = img.data().par_iter().map(|&c| perceptual(c)).collect();
    let mut out = img.clone();
    let l = |p: (u32, u32)| lum[(p.1 * w + p.0) as usize];
    let px = |p: (u32, u32)| *img.get(p.0, p.1);
    out.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(j, row)| {
            let j = j as u32;
            for (i, o) in row.iter_mut().enumerate() {
                let i = i as u32;
                if !grid.valid(i, j) {
                    continue;
                }
                // `nb[dj + 1][di + 1]`: the texel one step `(di, dj)` away.
                let nb = grid.neighbourhood(i, j);
                let m = l((i, j));
                let n = l(nb[0][1]);
                let s = l(nb[2][1]);
                let wv = l(nb[1][0]);
                let e = l(nb[1][2]);
                let hi = m.max(n).max(s).max(wv).max(e);
                let lo = m.min(n).min(s).min(wv).min(e);
                let range = hi - lo;
                if range < params.edge_threshold_min.max(hi * params.edge_threshold) {
                    continue;
                }
                let nw = l(nb[0][0]);
                let ne = l(nb[0][2]);
                let sw = l(nb[2][0]);
                let se = l(nb[2][2]);
                // Sub-pixel aliasing estimate.
                let avg = (2.0 * (n + s + wv + e) + nw + ne + sw + se) / 12.0;
                let sub = ((avg - m).abs() / range).clamp(0.0, 1.0);
                let sub = (-2.0 * sub + 3.0) * sub * sub;
                let sub = sub * sub * params.subpix;
                // Edge orientation: "horizontal" = the edge runs along i (columns), so the
                // neighbour across it is in j.
                let edge_h = (n + s - 2.0 * m).abs() * 2.0
                    + (ne + se - 2.0 * e).abs()
                    + (nw + sw - 2.0 * wv).abs();
                let edge_v = (wv + e - 2.0 * m).abs() * 2.0
                    + (ne + nw - 2.0 * n).abs()
                    + (se + sw - 2.0 * s).abs();
                let horizontal = edge_h >= edge_v;
                let (l_neg, l_pos) = if horizontal { (n, s) } else { (wv, e) };
                let (g_neg, g_pos) = ((l_neg - m).abs(), (l_pos - m).abs());
                let toward_pos = g_pos >= g_neg;
                let (across, l_across, grad) = if toward_pos {
                    (if horizontal { (0, 1) } else { (1, 0) }, l_pos, g_pos)
                } else {
                    (if horizontal { (0, -1) } else { (-1, 0) }, l_neg, g_neg)
                };
                let edge_luma = 0.5 * (m + l_across);
                let along = if horizontal { (1, 0) } else { (0, 1) };
                let limit = grad * 0.25;
                // Walk along the edge both ways until the pair's mean luma leaves the edge.
                let walk = |dir: i32| -> (u32, bool) {
                    let (mut ci, mut cj) = (i, j);
                    for k in 1..=params.search_steps {
                        let p = grid.step(ci, cj, along.0 * dir, along.1 * dir);
                        if p == (ci, cj) {
                            return (k - 1, false);
                        }
                        (ci, cj) = p;
                        let q = grid.step(ci, cj, across.0, across.1);
                        let pair = 0.5 * (l(p) + l(q));
                        if (pair - edge_luma).abs() >= limit {
                            return (k, true);
                        }
                    }
                    (params.search_steps, false)
                };
                let (d_neg, _) = walk(-1);
                let (d_pos, _) = walk(1);
                let span = (d_neg + d_pos) as f32 + 1.0;
                let nearer = d_neg.min(d_pos) as f32 + 0.5;
                // Only blend when the centre lies on the side of the edge whose end is nearer
                // (FXAA's sign test): the pixel's luma differs from the edge mean in the
                // direction of the end's luma.
                let end_luma = {
                    let dir = if d_neg <= d_pos { -1 } else { 1 };
                    let steps = d_neg.min(d_pos) as i32 + 1;
                    let mut p = (i, j);
                    for _ in 0..steps {
                        p = grid.step(p.0, p.1, along.0 * dir, along.1 * dir);
                    }
                    let q = grid.step(p.0, p.1, across.0, across.1);
                    0.5 * (l(p) + l(q))
                };
                let good = ((m - edge_luma) < 0.0) != ((end_luma - edge_luma) < 0.0);
                let edge_blend = if good { 0.5 - nearer / span } else { 0.0 };
                let blend = edge_blend.max(sub).clamp(0.0, 0.5);
                if blend > 0.0 {
                    let q = grid.step(i, j, across.0, across.1);
                    *o = lerp3(px((i, j)), px(q), blend);
                }
            }
        });
    let _ = h;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn staircase(w: u32, h: u32) -> Image<Rgb> {
        // A slightly slanted black/white edge: y < x/8 + h/2 is white.
        let mut img = Image::new(w, h, [0.0; 3]).unwrap();
        for y in 0..h {
            for x in 0..w {
                if (y as f32) < x as f32 / 8.0 + h as f32 / 4.0 {
                    *img.get_mut(x, y) = [1.0; 3];
                }
            }
        }
        img
    }

    #[test]
    fn flat_and_smooth_regions_are_untouched() {
        let mut img = Image::new(16, 16, [0.3; 3]).unwrap();
        for (k, p) in img.data_mut().iter_mut().enumerate() {
            let v = 0.3 + 0.001 * (k % 16) as f32;
            *p = [v; 3];
        }
        let grid = Grid::Rect {
            width: 16,
            height: 16,
        };
        assert_eq!(fxaa(&img, &grid, &FxaaParams::default()), img);
    }

    #[test]
    fn a_jagged_edge_gets_intermediate_values_only_next_to_it() {
        let img = staircase(64, 32);
        let grid = Grid::Rect {
            width: 64,
            height: 32,
        };
        let out = fxaa(&img, &grid, &FxaaParams::default());
        let mut blended = 0;
        for y in 0..32 {
            for x in 0..64 {
                let v = out.get(x, y)[0];
                if v > 0.01 && v < 0.99 {
                    blended += 1;
                    let edge = x as f32 / 8.0 + 8.0;
                    assert!(
                        (y as f32 - edge).abs() < 2.0,
                        "blend far from edge at {x},{y}"
                    );
                }
            }
        }
        assert!(blended >= 32, "only {blended} pixels were anti-aliased");
        // Mass is (nearly) conserved: FXAA moves colour across the edge, it does not add any.
        let sum = |im: &Image<Rgb>| im.data().iter().map(|c| c[0] as f64).sum::<f64>();
        assert!((sum(&out) - sum(&img)).abs() / sum(&img) < 0.02);
    }

    #[test]
    fn polar_buffers_filter_across_the_angular_seam() {
        // One column of 8 rows wrapping: an edge between row 7 and row 0 must be treated
        // like any other (rows 7 and 0 are neighbours), and none at rows 3/4 where the colour
        // is uniform... use two columns so the grid has an "along" direction.
        let mut img = Image::new(2, 8, [0.0; 3]).unwrap();
        for i in 0..2 {
            for j in 1..7 {
                *img.get_mut(i, j) = [1.0; 3];
            }
        }
        let grid = Grid::Polar {
            rows: vec![8, 8],
            period: vec![8.0, 8.0],
        };
        let out = fxaa(&img, &grid, &FxaaParams::default());
        // Pixels at the seam see their wrapped neighbours: row 0 (black) next to row 7
        // (black) and row 1 (white) is an edge pixel; a rect grid clamps instead.
        assert!(out.get(0, 4)[0] == 1.0);
        for j in [0, 7] {
            let v = out.get(0, j)[0];
            assert!(v < 0.5, "seam row {j} {v}");
        }
        // Symmetry across the seam: rows 0 and 7 (mirror images around the seam) match.
        assert!((out.get(0, 0)[0] - out.get(0, 7)[0]).abs() < 1e-6);
    }
}
