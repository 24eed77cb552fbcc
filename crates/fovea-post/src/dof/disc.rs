//! Building blocks the disc filters share ([`super::gather`], [`super::bokeh_lca`],
//! [`super::chromatic`], [`super::adaptive_coc`], [`super::bilateral`]): input sanitising,
//! the anti-aliased disc (coverage, offsets sorted by distance, discrete area), the per-tile
//! gather radius, and the row-parallel per-pixel loop with its image-clipped taps.
//!
//! The anti-aliased disc of radius `r` covers a pixel at distance `d` from its centre by
//! `cov(r, d) = clamp(r − d + ½, 0, 1)`, and its discrete area is `A(r) = Σ_o cov(r, |o|)`
//! over the integer offsets `o` (≈ π r², and exactly what makes a disc's weights sum to 1).

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use super::{sanitize_coc, sanitize_depth, DofInput};
use crate::Rgb;

/// Errors unless `max_radius_px` is in `[lowest_px, 256]` (the offset table grows as its
/// square). Filters that clamp radii to at least ½ px need `lowest_px = ½`; the others
/// accept 0 (no blur at all).
pub(crate) fn check_max_radius(max_radius_px: f32, lowest_px: f32) -> Result<()> {
    if (lowest_px..=256.0).contains(&max_radius_px) {
        Ok(())
    } else {
        Err(FoveaError::invalid(
            "max_radius_px",
            max_radius_px,
            format!("a radius in [{lowest_px}, 256] pixels"),
        ))
    }
}

/// Colour with non-finite components replaced by 0 (so one bad pixel cannot poison a disc).
pub(crate) fn sanitized_color(color: &Image<Rgb>) -> Vec<Rgb> {
    color
        .data()
        .iter()
        .map(|c| c.map(|v| if v.is_finite() { v } else { 0.0 }))
        .collect()
}

/// Depth with NaN / non-positive values mapped to `+∞`.
pub(crate) fn sanitized_depth(depth_m: &Image<f32>) -> Vec<f32> {
    depth_m.data().iter().map(|&d| sanitize_depth(d)).collect()
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
            depth_m: sanitized_depth(input.depth_m),
            radius_px: coc_px
                .iter()
                .map(|&c| radius_px(c, max_radius_px))
                .collect(),
            coc_px,
        }
    }
}

/// Anti-aliased disc coverage of a pixel at distance `d_px` from the centre of a disc of
/// radius `radius_px`: `clamp(r − d + ½, 0, 1)` (1 inside, 0 beyond `r + ½`, linear between).
#[inline]
pub(crate) fn coverage(radius_px: f32, d_px: f32) -> f32 {
    (radius_px - d_px + 0.5).clamp(0.0, 1.0)
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

    /// Every offset `(dx, dy, |o|)`, sorted by distance (the order the gather visits them).
    pub fn offsets(&self) -> &[(i32, i32, f32)] {
        &self.offsets
    }

    /// The offsets a disc of radius `radius_px` can cover (`|o| < r + ½`), centre first.
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

pub(crate) const LUT_STEPS_PER_PX: f32 = 16.0;

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

    /// The tabulated `1 / A(½ + k/16)`, `k = 0, 1, …`.
    pub fn table(&self) -> &[f32] {
        &self.inv_area
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

/// The CoC radii of one pixel: one for all three channels (`f32`) or one per channel
/// (`[f32; 3]`, [`super::chromatic`]).
pub(crate) trait Radii: Copy + Send + Sync {
    /// One radius for all channels.
    const MONO: bool;
    /// Radius of colour channel `c`.
    fn channel(self, c: usize) -> f32;
    /// The largest of the radii.
    fn largest(self) -> f32;
    /// Each radius mapped by `f`.
    fn map_each(self, f: impl Fn(f32) -> f32) -> Self;
}

impl Radii for f32 {
    const MONO: bool = true;
    #[inline]
    fn channel(self, _: usize) -> f32 {
        self
    }
    #[inline]
    fn largest(self) -> f32 {
        self
    }
    #[inline]
    fn map_each(self, f: impl Fn(f32) -> f32) -> Self {
        f(self)
    }
}

impl Radii for [f32; 3] {
    const MONO: bool = false;
    #[inline]
    fn channel(self, c: usize) -> f32 {
        self[c]
    }
    #[inline]
    fn largest(self) -> f32 {
        self[0].max(self[1]).max(self[2])
    }
    #[inline]
    fn map_each(self, f: impl Fn(f32) -> f32) -> Self {
        self.map(f)
    }
}

/// Per-tile gather radius: the largest radius `r_P` of any pixel `P` whose disc can reach
/// the tile (tile-max, dilated by each tile's own max), at least the tile's own max.
pub(crate) struct TileReach {
    tw: usize,
    reach_px: Vec<f32>,
}

pub(crate) const TILE: usize = 16;

impl TileReach {
    pub fn new<R: Radii>(radius_px: &[R], w: usize, h: usize, max_radius_px: f32) -> Self {
        let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let mut tile_max = vec![0.0f32; tw * th];
        for y in 0..h {
            for x in 0..w {
                let t = (y / TILE) * tw + x / TILE;
                tile_max[t] = tile_max[t].max(radius_px[y * w + x].largest());
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

/// `out(x, y) = f(x, y)` for every pixel of a `w × h` image, rows in parallel.
pub(crate) fn map_pixels(
    w: usize,
    h: usize,
    f: impl Fn(usize, usize) -> Rgb + Sync,
) -> Result<Image<Rgb>> {
    let mut out = vec![[0.0f32; 3]; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                *o = f(x, y);
            }
        });
    Image::from_vec(w as u32, h as u32, out)
}

/// Calls `f(j, dy, d)` for each offset `(dx, dy, d)` whose pixel `(x + dx, y + dy)` lies in
/// the `w × h` image; `j` is that pixel's row-major index.
#[inline]
pub(crate) fn for_each_tap(
    offsets: &[(i32, i32, f32)],
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    mut f: impl FnMut(usize, i32, f32),
) {
    for &(dx, dy, d) in offsets {
        let (px, py) = (x as i32 + dx, y as i32 + dy);
        if px < 0 || py < 0 || px >= w as i32 || py >= h as i32 {
            continue;
        }
        f(py as usize * w + px as usize, dy, d);
    }
}

/// Weighted colour sum `[Σ w r, Σ w g, Σ w b, Σ w]`.
pub(crate) type Acc = [f32; 4];

/// Adds colour `c` with weight `wt` to `acc`.
#[inline]
pub(crate) fn accumulate(acc: &mut Acc, wt: f32, c: Rgb) {
    acc[0] += wt * c[0];
    acc[1] += wt * c[1];
    acc[2] += wt * c[2];
    acc[3] += wt;
}

/// `acc` divided out, or `fallback` when `Σ w = 0`.
#[inline]
pub(crate) fn normalise(acc: Acc, fallback: Rgb) -> Rgb {
    if acc[3] > 0.0 {
        let inv = 1.0 / acc[3];
        [acc[0] * inv, acc[1] * inv, acc[2] * inv]
    } else {
        fallback
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_table_normalises_discs() {
        let disc = Disc::new(32.0);
        let lut = AreaLut::new(&disc, 32.0);
        for r in [0.5f32, 0.8, 1.0, 2.3, 5.5, 7.9, 16.0, 31.7] {
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
        // A sharp pixel covers itself only.
        assert_eq!(lut.inv(0.5), 1.0);
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
}
