//! Disc bokeh with Liu's row-wise longitudinal chromatic aberration (Liu, Mantel & Forchhammer,
//! "Perception-driven hybrid foveated depth of field rendering", Sec. 3.3.1–3.3.2, Alg. 2).
//!
//! **Bokeh (Sec. 3.3.1).** The kernel is a disc of constant weight whose diameter is the
//! pixel's circle of confusion `C_e(p)` (Eq. 12; here the signed `coc_px` of [`DofInput`],
//! `|coc_px| = px_per_dioptre · |1/F − 1/D|` for the thin-lens eye). Algorithm 2 gathers, per
//! pixel, `color = sampler(uv, coc, kernel)`. Pixels inside the DOF (`|coc_px| <
//! in_focus_coc_px`, default 1 px) get no blur, as the paper says ("for `D_p` within DOF, no
//! Bokeh kernel applies").
//!
//! The disc's edge is anti-aliased: a sample at distance `d` from the centre has coverage
//! `clamp(r + ½ − d, 0, 1)` for a disc of radius `r = |coc_px|/2`, so the blur grows
//! continuously with the CoC instead of in integer steps.
//!
//! **Choice: occlusion-aware gather.** A plain gather with the centre pixel's CoC (the literal
//! Alg. 2, available as `occlusion_aware: false`) pulls sharp foreground colour into the
//! blurred background next to it (intensity leakage) and cannot spread a blurred near object
//! over a sharp background. The bokeh shaders Liu builds on (the Catlike Coding / Unity disc
//! kernels, Liu's refs. [1], [63]) split the gathered samples by depth, and so do we by
//! default. For the centre `p` and a neighbour `q` at distance `d`:
//!
//! * `q` **in front** of `p` (`depth_q < depth_p`) scatters: it covers `p` if `d` is within
//!   *its own* disc `r_q`, with weight `coverage(d, r_q) / A(r_q)` (`A(r)` the discrete area
//!   of the anti-aliased disc, so each source spreads unit energy). The summed weight is the
//!   front layer's coverage `α` of `p`. A sharp foreground (`r_q = 0`) therefore never
//!   reaches a blurred background pixel: no intensity leakage.
//! * `q` **behind or level** with `p` is gathered with Liu's constant-weight disc of the
//!   *centre's* radius `r_p`, normalised to the mean `B̄`. A sharp centre thus gathers
//!   nothing from a blurred background behind it. For a thin-lens CoC (monotone in depth)
//!   this is `min(r_p, r_q)` except where `p` is a blurred *near* pixel over a
//!   less-blurred background, and there `r_p` is the physically right reach: the
//!   near object's silhouette is seen through for part of the aperture, so its blurred edge
//!   becomes semi-transparent on both sides of the silhouette (`min` would keep the
//!   foreground opaque up to its silhouette and halve the edge width).
//! * Composite: `out = F + (1 − α)·B̄` (`F` the front sum), or `F/α` where `α > 1`.
//!
//! For a constant CoC every sample is level with the centre and this is exactly Liu's
//! constant-weight disc gather.
//!
//! **LCA (Sec. 3.3.2).** "If `D_p > D_F`, the top 2 rows of the kernel filter out blue, and
//! the bottom 2 rows filter out red. The other way around if `D_p < D_N`." We zero that
//! channel's weight in the top/bottom rows (`dy < 0` is *up*, i.e. smaller image `y`) and
//! normalise each channel over its own weights, so flat regions keep their colour and only
//! edges and highlights get coloured fringes. Which side is "far" follows the sign of the
//! CoC that defines the kernel (the sample's, in the scatter-style gather).
//!
//! **Choice: how many rows.** Liu's kernel is a fixed sample pattern (the paper does not say
//! its size); read literally, "2 rows" is a large part of a 3-px kernel and invisible in a
//! 60-px one. We scale the band with the kernel: `h = clamp(lca_band_fraction · diameter,
//! 1, r − ½)` rows, with `lca_band_fraction = 2/9` (two rows of a 9-row kernel). A sample is
//! in the top band if `dy < −r + h` and in the bottom band if `dy > r − h`. So a 3-px kernel
//! has 1 row at each side, 9 px → 2 rows, 18 px → 4 rows, 64 px → 14 rows; the centre row
//! always keeps all three channels.
//!
//! Cost: one pass, rayon over rows; the disc offsets are precomputed and sorted by distance,
//! and each 8×8 tile only visits the offsets that the largest CoC within reach can cover.

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use super::{sanitize_depth, DofFilter, DofInput};
use crate::Rgb;

/// Liu's disc bokeh, optionally with the row-wise chromatic filter.
#[derive(Clone, Debug, PartialEq)]
pub struct BokehLca {
    /// Apply Liu's row-wise LCA colour filter (default `true`).
    pub lca: bool,
    /// Largest blur radius, pixels; CoCs are clamped to twice this diameter (default 32).
    pub max_radius_px: f32,
    /// CoC diameters below this many pixels count as inside the DOF and get no blur
    /// (default 1 px).
    pub in_focus_coc_px: f32,
    /// Height of the LCA band at the top and bottom of the kernel, as a fraction of the
    /// kernel's diameter, at least one row (default `2/9`: Liu's "2 rows" of a 9-row kernel).
    pub lca_band_fraction: f32,
    /// Depth-split occlusion-aware gather (default `true`, see the module header); `false` is
    /// the literal Algorithm 2: a constant-weight disc gather with the centre pixel's CoC.
    pub occlusion_aware: bool,
}

impl Default for BokehLca {
    fn default() -> Self {
        Self {
            lca: true,
            max_radius_px: 32.0,
            in_focus_coc_px: 1.0,
            lca_band_fraction: 2.0 / 9.0,
            occlusion_aware: true,
        }
    }
}

impl BokehLca {
    fn check(&self) -> Result<()> {
        check_max_radius(self.max_radius_px)?;
        if !(self.in_focus_coc_px.is_finite() && self.in_focus_coc_px >= 0.0) {
            return Err(FoveaError::invalid(
                "in_focus_coc_px",
                self.in_focus_coc_px,
                "a finite number ≥ 0 px",
            ));
        }
        if !(0.0..=0.5).contains(&self.lca_band_fraction) {
            return Err(FoveaError::invalid(
                "lca_band_fraction",
                self.lca_band_fraction,
                "a fraction of the kernel diameter in [0, 0.5]",
            ));
        }
        Ok(())
    }
}

impl DofFilter for BokehLca {
    fn name(&self) -> &'static str {
        if self.lca {
            "bokeh-lca"
        } else {
            "bokeh"
        }
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        self.check()?;
        let (w, h) = input.size();
        let max_r = self.max_radius_px;
        // Signed radius per pixel (same for all channels): 0 inside the DOF.
        let radius_px: Vec<[f32; 3]> = input
            .coc_px
            .data()
            .iter()
            .map(|&c| {
                let c = super::sanitize_coc(c);
                let r = if c.abs() < self.in_focus_coc_px.max(f32::MIN_POSITIVE) {
                    0.0
                } else {
                    (0.5 * c.abs()).min(max_r).copysign(c)
                };
                [r; 3]
            })
            .collect();
        if radius_px.iter().all(|r| r[0].abs() < 0.5) {
            // Nothing is blurred by more than the pixel itself.
            return Ok(input.color.clone());
        }
        let opts = GatherOptions {
            max_radius_px: max_r,
            occlusion_aware: self.occlusion_aware,
            lca_band_fraction: self.lca.then_some(self.lca_band_fraction),
        };
        let out = disc_gather(
            w as usize,
            h as usize,
            &sanitized_color(input.color),
            &sanitized_depth(input.depth_m),
            &radius_px,
            &opts,
        );
        Image::from_vec(w, h, out)
    }
}

/// `max_radius_px` must be finite, ≥ 0 and ≤ 256 (the kernel table grows as its square).
pub(crate) fn check_max_radius(max_radius_px: f32) -> Result<()> {
    if !(max_radius_px.is_finite() && (0.0..=256.0).contains(&max_radius_px)) {
        return Err(FoveaError::invalid(
            "max_radius_px",
            max_radius_px,
            "a radius in [0, 256] px",
        ));
    }
    Ok(())
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

/// Options of [`disc_gather`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct GatherOptions {
    /// Largest radius any pixel has, pixels (the kernel table's extent).
    pub max_radius_px: f32,
    /// Depth-split occlusion-aware gather (see the module header), else a plain gather.
    pub occlusion_aware: bool,
    /// Liu's row-wise LCA band as a fraction of the kernel diameter; `None` for no LCA.
    pub lca_band_fraction: Option<f32>,
}

/// Side of the tiles over which the reach of neighbouring CoCs is bounded.
const TILE: usize = 8;
/// Steps per pixel of the disc-area table.
const AREA_STEPS_PER_PX: f32 = 16.0;

/// Coverage of an anti-aliased disc of radius `r_px` at distance `d_px`; the centre always 1.
#[inline]
fn coverage(d_px: f32, r_px: f32) -> f32 {
    if d_px == 0.0 {
        1.0
    } else {
        (r_px + 0.5 - d_px).clamp(0.0, 1.0)
    }
}

/// Precomputed disc offsets: for every integer search radius `S ≤ ⌈max_radius_px⌉`, the
/// offsets other than the centre with distance `< S + ½` in row-major order (so a gather walks
/// memory row by row),
/// and the discrete area of the anti-aliased disc of every radius (table in 1/16 px).
pub(crate) struct DiscKernel {
    buckets: Vec<Vec<(i32, i32, f32)>>,
    area: Vec<f32>,
}

impl DiscKernel {
    pub(crate) fn new(max_radius_px: f32) -> Self {
        let rmax = max_radius_px.max(0.0);
        let smax = rmax.ceil() as i32;
        let buckets: Vec<Vec<(i32, i32, f32)>> = (0..=smax)
            .map(|s| {
                let mut v = Vec::new();
                for dy in -s..=s {
                    for dx in -s..=s {
                        let d = ((dx * dx + dy * dy) as f32).sqrt();
                        if d < s as f32 + 0.5 && (dx, dy) != (0, 0) {
                            v.push((dx, dy, d));
                        }
                    }
                }
                v
            })
            .collect();
        let mut all: Vec<f32> = buckets[smax as usize].iter().map(|o| o.2).collect();
        all.push(0.0);
        all.sort_by(f32::total_cmp);
        let steps = (rmax * AREA_STEPS_PER_PX).ceil() as usize + 2;
        let area = (0..steps)
            .map(|k| {
                let r = k as f32 / AREA_STEPS_PER_PX;
                all.iter()
                    .take_while(|&&d| d < r + 0.5)
                    .map(|&d| coverage(d, r))
                    .sum::<f32>()
            })
            .collect();
        Self { buckets, area }
    }

    /// Offsets a disc of radius `r_px` can cover (a superset: the bucket of `⌈r_px⌉`).
    #[inline]
    fn offsets(&self, r_px: f32) -> &[(i32, i32, f32)] {
        let s = (r_px.max(0.0).ceil() as usize).min(self.buckets.len() - 1);
        &self.buckets[s]
    }

    /// Discrete area (sum of coverages) of the disc of radius `r_px`, linearly interpolated.
    #[inline]
    pub(crate) fn area(&self, r_px: f32) -> f32 {
        let t = (r_px * AREA_STEPS_PER_PX).max(0.0);
        let i = (t as usize).min(self.area.len() - 2);
        let f = (t - i as f32).min(1.0);
        self.area[i] + (self.area[i + 1] - self.area[i]) * f
    }
}

/// Per-tile search radius: the largest radius (any channel) within reach of the tile.
fn tile_reach(w: usize, h: usize, radius_px: &[[f32; 3]]) -> (usize, Vec<f32>) {
    let tx = w.div_ceil(TILE);
    let ty = h.div_ceil(TILE);
    let mut tmax = vec![0.0f32; tx * ty];
    for y in 0..h {
        for x in 0..w {
            let r = radius_px[y * w + x];
            let m = r[0].abs().max(r[1].abs()).max(r[2].abs());
            let t = &mut tmax[(y / TILE) * tx + x / TILE];
            *t = t.max(m);
        }
    }
    let global = tmax.iter().fold(0.0f32, |a, &b| a.max(b));
    let k = ((global + 0.5) / TILE as f32).ceil() as usize;
    // Separable max over ±k tiles.
    let mut hor = vec![0.0f32; tx * ty];
    for j in 0..ty {
        for i in 0..tx {
            let lo = i.saturating_sub(k);
            let hi = (i + k).min(tx - 1);
            hor[j * tx + i] = tmax[j * tx + lo..=j * tx + hi]
                .iter()
                .fold(0.0f32, |a, &b| a.max(b));
        }
    }
    let mut reach = vec![0.0f32; tx * ty];
    for j in 0..ty {
        for i in 0..tx {
            let lo = j.saturating_sub(k);
            let hi = (j + k).min(ty - 1);
            reach[j * tx + i] = (lo..=hi).fold(0.0f32, |a, jj| a.max(hor[jj * tx + i]));
        }
    }
    (tx, reach)
}

/// Everything the gather reads about one pixel, packed for locality.
#[derive(Clone, Copy)]
struct GatherPx {
    color: Rgb,
    depth_m: f32,
    /// Signed radius per channel, pixels.
    radius_px: [f32; 3],
    /// `1 / A(|r|)` per channel: the scatter weight per unit coverage.
    inv_area: [f32; 3],
}

/// Disc gather with per-channel signed radii `radius_px` (pixels; positive = behind the
/// focus, negative = in front, `|r| < ½` = sharp). Radii must be ≤ `max_radius_px`; colour
/// and depth must be finite / sanitised. Returns the filtered image, row-major.
pub(crate) fn disc_gather(
    w: usize,
    h: usize,
    color: &[Rgb],
    depth_m: &[f32],
    radius_px: &[[f32; 3]],
    opts: &GatherOptions,
) -> Vec<Rgb> {
    let kernel = DiscKernel::new(opts.max_radius_px);
    let (tx, reach) = tile_reach(w, h, radius_px);
    let mono = radius_px.iter().all(|r| r[0] == r[1] && r[1] == r[2]);
    let px: Vec<GatherPx> = (0..w * h)
        .into_par_iter()
        .map(|i| GatherPx {
            color: color[i],
            depth_m: depth_m[i],
            radius_px: radius_px[i],
            inv_area: radius_px[i].map(|r| 1.0 / kernel.area(r.abs())),
        })
        .collect();
    let mut out = vec![[0.0f32; 3]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let p = &px[i];
            let search = if opts.occlusion_aware {
                reach[(y / TILE) * tx + x / TILE]
            } else {
                let r = p.radius_px;
                r[0].abs().max(r[1].abs()).max(r[2].abs())
            };
            if search < 0.5 {
                *o = p.color;
                continue;
            }
            let g = Gather {
                x,
                y,
                w,
                h,
                px: &px,
                kernel: &kernel,
                opts,
            };
            *o = if mono && opts.occlusion_aware {
                g.mono_occlusion(search)
            } else {
                g.general(search)
            };
        }
    });
    out
}

/// One output pixel's gather.
struct Gather<'a> {
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    px: &'a [GatherPx],
    kernel: &'a DiscKernel,
    opts: &'a GatherOptions,
}

impl Gather<'_> {
    /// Offsets of the search disc clipped to the image: row-major, with the flat index.
    #[inline]
    fn for_each_neighbour(&self, search_px: f32, mut f: impl FnMut(i32, f32, &GatherPx)) {
        let (x, y) = (self.x as i32, self.y as i32);
        let (w, h) = (self.w as i32, self.h as i32);
        for &(dx, dy, d) in self.kernel.offsets(search_px) {
            let (qx, qy) = (x + dx, y + dy);
            if qx < 0 || qy < 0 || qx >= w || qy >= h {
                continue;
            }
            f(dy, d, &self.px[(qy * w + qx) as usize]);
        }
    }

    /// Liu's row-wise LCA: does the kernel of radius `reff` (sign `far`) drop channel `c`
    /// (0 red, 2 blue) at row offset `dy`?
    #[inline]
    fn lca_drops(frac: f32, reff: f32, far: bool, dy: i32, c: usize) -> bool {
        let band = (frac * 2.0 * reff).max(1.0).min(reff - 0.5);
        if band <= 0.0 {
            return false;
        }
        let dyf = dy as f32;
        let top = dyf < -reff + band;
        let bottom = dyf > reff - band;
        // Far: top rows drop blue, bottom rows drop red; near: the other way round.
        let (drop_blue, drop_red) = if far { (top, bottom) } else { (bottom, top) };
        (c == 2 && drop_blue) || (c == 0 && drop_red)
    }

    /// Same radius in all channels, occlusion-aware (see [`Layers::finish`]).
    fn mono_occlusion(&self, search_px: f32) -> Rgb {
        let p = &self.px[self.y * self.w + self.x];
        let rp = p.radius_px[0].abs();
        let far_p = p.radius_px[0] > 0.0;
        let dp = p.depth_m;
        let lca = self.opts.lca_band_fraction;
        let mut l = Layers::new(p.color);
        self.for_each_neighbour(search_px, |dy, d, q| {
            let front = q.depth_m < dp;
            let (reff, far) = if front {
                (q.radius_px[0].abs(), q.radius_px[0] > 0.0)
            } else {
                (rp, far_p)
            };
            let cov = coverage(d, reff);
            if cov <= 0.0 {
                return;
            }
            let wgt = if front { cov * q.inv_area[0] } else { cov };
            for c in 0..3 {
                if c != 1 {
                    if let Some(frac) = lca {
                        if Self::lca_drops(frac, reff, far, dy, c) {
                            continue;
                        }
                    }
                }
                l.add(front, c, wgt, q.color[c]);
            }
        });
        l.finish(p.color)
    }

    /// Per-channel radii (or the plain centre-CoC gather when not occlusion-aware).
    fn general(&self, search_px: f32) -> Rgb {
        let p = &self.px[self.y * self.w + self.x];
        let rp = p.radius_px;
        let rpa = rp.map(f32::abs);
        let dp = p.depth_m;
        let occl = self.opts.occlusion_aware;
        let lca = self.opts.lca_band_fraction;
        let mut l = Layers::new(p.color);
        self.for_each_neighbour(search_px, |dy, d, q| {
            let front = occl && q.depth_m < dp;
            for c in 0..3 {
                let (reff, far) = if front {
                    (q.radius_px[c].abs(), q.radius_px[c] > 0.0)
                } else {
                    (rpa[c], rp[c] > 0.0)
                };
                let cov = coverage(d, reff);
                if cov <= 0.0 {
                    continue;
                }
                if c != 1 {
                    if let Some(frac) = lca {
                        if Self::lca_drops(frac, reff, far, dy, c) {
                            continue;
                        }
                    }
                }
                let wgt = if front { cov * q.inv_area[c] } else { cov };
                l.add(front, c, wgt, q.color[c]);
            }
        });
        l.finish(p.color)
    }
}

/// The two sample groups of one gather.
///
/// * *In front* of the centre (`depth_q < depth_p`): scatter-style, each neighbour covers
///   the disc of its own radius with weight `coverage / A(r_q)` (unit energy per source);
///   the summed weight is the front layer's coverage `α`.
/// * *Behind or level*: Liu's constant-weight disc of the centre's own radius, normalised.
///
/// Composite: `out = F + (1 − α)·B̄` for `α ≤ 1`, else `F/α`.
struct Layers {
    front: [f32; 3],
    front_w: [f32; 3],
    back: [f32; 3],
    back_w: [f32; 3],
}

impl Layers {
    /// Starts with the centre pixel (full coverage, behind-or-level group).
    #[inline]
    fn new(own: Rgb) -> Self {
        Self {
            front: [0.0; 3],
            front_w: [0.0; 3],
            back: own,
            back_w: [1.0; 3],
        }
    }

    #[inline]
    fn add(&mut self, front: bool, c: usize, wgt: f32, v: f32) {
        if front {
            self.front[c] += wgt * v;
            self.front_w[c] += wgt;
        } else {
            self.back[c] += wgt * v;
            self.back_w[c] += wgt;
        }
    }

    #[inline]
    fn finish(&self, own: Rgb) -> Rgb {
        std::array::from_fn(|c| {
            let alpha = self.front_w[c];
            let back = if self.back_w[c] > 0.0 {
                self.back[c] / self.back_w[c]
            } else {
                own[c]
            };
            if alpha <= 1.0 {
                self.front[c] + (1.0 - alpha) * back
            } else {
                self.front[c] / alpha
            }
        })
    }
}

/// Shared scenes and measurements for the DOF filter tests in this module and its siblings.
#[cfg(test)]
pub(crate) mod testkit {
    use super::super::planes::{Plane, PlaneScene};
    use super::super::DofInput;
    use crate::{luma, Rgb};
    use fovea_core::Image;

    /// Thin-lens signed CoC in pixels.
    pub fn thin_lens_coc(k: f32, focus_m: f32, depth_m: f32) -> f32 {
        let inv_f = if focus_m.is_finite() {
            1.0 / focus_m
        } else {
            0.0
        };
        let inv_d = if depth_m.is_finite() {
            1.0 / depth_m
        } else {
            0.0
        };
        k * (inv_f - inv_d)
    }

    /// A smooth-and-sharp test texture: 6-px checker mixed with a slow colour wave.
    pub fn texture(x: f32, y: f32) -> Rgb {
        let chk = if ((x / 6.0).floor() + (y / 6.0).floor()) as i32 % 2 == 0 {
            0.85
        } else {
            0.15
        };
        let s = 0.5 + 0.5 * (0.21 * x + 0.13 * y).sin();
        [0.7 * chk + 0.3 * s, 0.8 * chk + 0.2 * (1.0 - s), chk]
    }

    /// One textured plane filling the frame.
    pub fn plane_scene(w: u32, h: u32, depth_m: f32) -> PlaneScene {
        PlaneScene {
            width: w,
            height: h,
            planes: vec![Plane {
                depth_m,
                color: Box::new(texture),
                opaque: Box::new(|_, _| true),
            }],
            background: [0.0; 3],
        }
    }

    /// A textured near plane (0.5 m, `x < 32`) over a textured far plane (2 m), 64×32.
    pub fn two_textured_planes() -> PlaneScene {
        PlaneScene {
            width: 64,
            height: 32,
            planes: vec![
                Plane {
                    depth_m: 0.5,
                    color: Box::new(|x, y| texture(x, y).map(|v| 0.3 + 0.7 * v)),
                    opaque: Box::new(|x, _| x < 32.0),
                },
                Plane {
                    depth_m: 2.0,
                    color: Box::new(|x, y| texture(y, x).map(|v| 0.6 * v)),
                    opaque: Box::new(|_, _| true),
                },
            ],
            background: [0.0; 3],
        }
    }

    /// A uniform plane of colour `left` at `near_m` covering `x < edge_x`, in front of a
    /// uniform plane of colour `right` at `far_m` filling the frame.
    pub fn edge_scene(
        w: u32,
        h: u32,
        edge_x: f32,
        near_m: f32,
        far_m: f32,
        left: Rgb,
        right: Rgb,
    ) -> PlaneScene {
        PlaneScene {
            width: w,
            height: h,
            planes: vec![
                Plane {
                    depth_m: near_m,
                    color: Box::new(move |_, _| left),
                    opaque: Box::new(move |x, _| x < edge_x),
                },
                Plane {
                    depth_m: far_m,
                    color: Box::new(move |_, _| right),
                    opaque: Box::new(|_, _| true),
                },
            ],
            background: [0.0; 3],
        }
    }

    /// Owned buffers a [`DofInput`] borrows.
    pub struct Frame {
        pub color: Image<Rgb>,
        pub depth: Image<f32>,
        pub coc: Image<f32>,
        pub focus_m: f32,
        pub k: f32,
        pub gaze: [f32; 2],
        pub ppd: f32,
    }

    impl Frame {
        /// Pinhole frame of `scene` with thin-lens CoCs for `k` px/D and focus `focus_m`.
        pub fn from_scene(scene: &PlaneScene, k: f32, focus_m: f32) -> Frame {
            let (color, depth) = scene.pinhole().unwrap();
            let coc = depth.map(|&d| thin_lens_coc(k, focus_m, d));
            Frame {
                color,
                depth,
                coc,
                focus_m,
                k,
                gaze: [scene.width as f32 / 2.0, scene.height as f32 / 2.0],
                ppd: 1000.0,
            }
        }

        pub fn input(&self) -> DofInput<'_> {
            DofInput {
                color: &self.color,
                depth_m: &self.depth,
                coc_px: &self.coc,
                focus_m: self.focus_m,
                px_per_dioptre: self.k,
                gaze_px: self.gaze,
                px_per_degree: self.ppd,
            }
        }
    }

    /// Luma PSNR (peak 1) over the pixels at least `margin` from the border.
    pub fn luma_psnr(a: &Image<Rgb>, b: &Image<Rgb>, margin: u32) -> f64 {
        let (w, h) = (a.width(), a.height());
        let mut se = 0.0f64;
        let mut n = 0usize;
        for y in margin..h - margin {
            for x in margin..w - margin {
                let d = (luma(*a.get(x, y)) - luma(*b.get(x, y))) as f64;
                se += d * d;
                n += 1;
            }
        }
        let mse = se / n as f64;
        if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (1.0 / mse).log10()
        }
    }

    /// 10–90 % luma rise distance in pixels along row `y` (profile monotone enough; linear
    /// interpolation between pixel centres).
    pub fn rise_10_90(img: &Image<Rgb>, y: u32) -> f32 {
        let p: Vec<f32> = (0..img.width()).map(|x| luma(*img.get(x, y))).collect();
        let (lo, hi) = (p[0], p[p.len() - 1]);
        let at = |t: f32| -> f32 {
            let v = lo + (hi - lo) * t;
            // First crossing from the left.
            for x in 1..p.len() {
                let (a, b) = (p[x - 1] - v, p[x] - v);
                if (a <= 0.0) != (b <= 0.0) || b == 0.0 {
                    let f = if a == b { 0.0 } else { a / (a - b) };
                    return (x - 1) as f32 + f;
                }
            }
            f32::NAN
        };
        (at(0.9) - at(0.1)).abs()
    }

    /// Frame with NaN depth and CoC sprinkled in, for robustness tests.
    pub fn nan_frame() -> Frame {
        let scene = plane_scene(32, 24, 2.0);
        let mut f = Frame::from_scene(&scene, 8.0, 0.5);
        for (i, d) in f.depth.data_mut().iter_mut().enumerate() {
            if i % 7 == 0 {
                *d = f32::NAN;
            }
        }
        for (i, c) in f.coc.data_mut().iter_mut().enumerate() {
            if i % 5 == 0 {
                *c = f32::NAN;
            } else if i % 11 == 0 {
                *c = f32::INFINITY;
            } else if i % 13 == 0 {
                *c = -1e9;
            }
        }
        f
    }

    pub fn all_finite(img: &Image<Rgb>) -> bool {
        img.data().iter().all(|p| p.iter().all(|v| v.is_finite()))
    }
}

#[cfg(test)]
mod tests {
    use super::testkit::*;
    use super::*;
    use crate::dof::FilterKind;

    fn plain() -> BokehLca {
        BokehLca {
            lca: false,
            ..Default::default()
        }
    }

    #[test]
    fn names_and_defaults() {
        assert_eq!(BokehLca::default().name(), "bokeh-lca");
        assert_eq!(plain().name(), "bokeh");
        assert_eq!(FilterKind::Bokeh.build().name(), "bokeh");
        assert_eq!(FilterKind::BokehLca.build().name(), "bokeh-lca");
        assert!(BokehLca::default().lca);
    }

    #[test]
    fn zero_coc_is_identity() {
        let scene = plane_scene(40, 30, 1.0);
        let mut f = Frame::from_scene(&scene, 10.0, 1.0);
        f.coc = f.coc.map(|_| 0.0);
        for filt in [plain(), BokehLca::default()] {
            assert_eq!(filt.apply(&f.input()).unwrap(), f.color);
        }
        // Sub-threshold CoCs are in the DOF too.
        f.coc = f.coc.map(|_| -0.9);
        assert_eq!(BokehLca::default().apply(&f.input()).unwrap(), f.color);
    }

    #[test]
    fn disc_kernel_area_is_the_disc_area() {
        let k = DiscKernel::new(16.0);
        for r in [2.0f32, 5.5, 10.0, 16.0] {
            let a = k.area(r);
            let pi_r2 = std::f32::consts::PI * r * r;
            assert!((a - pi_r2).abs() / pi_r2 < 0.05, "r {r}: {a} vs {pi_r2}");
        }
        assert_eq!(k.area(0.0), 1.0);
    }

    #[test]
    fn constant_plane_matches_thin_lens() {
        // Focus near (plane behind → far blur, +10 px) and focus far (plane in front, −7.5 px).
        for (focus, k) in [(0.5f32, 10.0f32), (4.0, 10.0)] {
            let scene = plane_scene(64, 48, 1.0);
            let f = Frame::from_scene(&scene, k, focus);
            let gt = scene.thin_lens(k, focus, 400).unwrap();
            let c = thin_lens_coc(k, focus, 1.0);
            for filt in [plain(), BokehLca::default()] {
                let out = filt.apply(&f.input()).unwrap();
                let psnr = luma_psnr(&out, &gt, (c.abs() / 2.0).ceil() as u32 + 1);
                eprintln!(
                    "{} focus {focus} coc {c}: luma PSNR {psnr:.2} dB",
                    filt.name()
                );
                let tol = if filt.lca { 30.0 } else { 38.0 };
                assert!(psnr > tol, "{} focus {focus}: {psnr}", filt.name());
            }
        }
    }

    #[test]
    fn two_textured_planes_match_thin_lens_roughly() {
        // Textured near plane (0.5 m, left of x = 32) over a textured far plane (2 m); focus
        // on either. Occlusion boundaries are where gather filters differ from the lens.
        for focus in [0.5f32, 2.0] {
            let scene = two_textured_planes();
            let f = Frame::from_scene(&scene, 8.0, focus);
            let gt = scene.thin_lens(8.0, focus, 400).unwrap();
            for filt in [plain(), BokehLca::default()] {
                let out = filt.apply(&f.input()).unwrap();
                let psnr = luma_psnr(&out, &gt, 8);
                eprintln!(
                    "{} two textured planes focus {focus}: luma PSNR {psnr:.2} dB",
                    filt.name()
                );
                assert!(psnr > 32.0, "{focus}: {psnr}");
            }
        }
    }

    #[test]
    fn sharp_foreground_edge_does_not_leak_into_blurred_background() {
        // Bright foreground at the focus (0.5 m) left of x = 30, dark background at 4 m
        // (CoC 17.5 px) right of it.
        let scene = edge_scene(64, 16, 30.0, 0.5, 4.0, [1.0; 3], [0.0; 3]);
        let f = Frame::from_scene(&scene, 10.0, 0.5);
        let gt = scene.thin_lens(10.0, 0.5, 256).unwrap();
        let out = plain().apply(&f.input()).unwrap();
        let (wo, wg) = (rise_10_90(&out, 8), rise_10_90(&gt, 8));
        eprintln!("sharp fg edge: 10-90 rise {wo:.2} px (thin lens {wg:.2} px)");
        assert!(wo < 1.0, "{wo}");
        // The literal centre-CoC gather leaks the foreground into the background.
        let literal = BokehLca {
            occlusion_aware: false,
            ..plain()
        };
        let wl = rise_10_90(&literal.apply(&f.input()).unwrap(), 8);
        eprintln!("literal Alg. 2 gather: 10-90 rise {wl:.2} px");
        assert!(wl > 3.0, "{wl}");
    }

    #[test]
    fn blurred_foreground_over_sharp_background_is_soft() {
        // Bright foreground at 0.25 m (CoC −20 px with focus 1 m, k = 20/3) over a dark
        // in-focus background.
        let k = 20.0 / 3.0;
        let scene = edge_scene(64, 16, 32.0, 0.25, 1.0, [1.0; 3], [0.0; 3]);
        let f = Frame::from_scene(&scene, k, 1.0);
        let gt = scene.thin_lens(k, 1.0, 256).unwrap();
        let out = plain().apply(&f.input()).unwrap();
        let (wo, wg) = (rise_10_90(&out, 8), rise_10_90(&gt, 8));
        eprintln!("blurred fg edge: 10-90 rise {wo:.2} px (thin lens {wg:.2} px)");
        assert!(wo > 0.7 * wg && wo < 1.3 * wg, "{wo} vs {wg}");
        // Soft on both sides of the silhouette (x = 32): the background next to it picks up
        // foreground light, the foreground's edge shows the background.
        let (l31, l32) = (crate::luma(*out.get(31, 8)), crate::luma(*out.get(32, 8)));
        eprintln!(
            "luma at the silhouette {l31:.2}/{l32:.2} (thin lens {:.2}/{:.2})",
            crate::luma(*gt.get(31, 8)),
            crate::luma(*gt.get(32, 8))
        );
        assert!(l31 < 0.7 && l32 > 0.3, "{l31} {l32}");
        // The literal Alg. 2 gather cannot spread the foreground over the sharp background.
        let literal = BokehLca {
            occlusion_aware: false,
            ..plain()
        };
        assert_eq!(*literal.apply(&f.input()).unwrap().get(33, 8), [0.0; 3]);
    }

    #[test]
    fn nan_inputs_give_finite_output() {
        let f = nan_frame();
        for filt in [plain(), BokehLca::default()] {
            let out = filt.apply(&f.input()).unwrap();
            assert!(all_finite(&out));
        }
        // Non-finite colour is tolerated too.
        let mut g = nan_frame();
        g.color.data_mut()[37] = [f32::NAN, f32::INFINITY, 1.0];
        assert!(all_finite(&BokehLca::default().apply(&g.input()).unwrap()));
    }

    #[test]
    fn bad_parameters_are_errors() {
        let f = nan_frame();
        for bad in [
            BokehLca {
                max_radius_px: f32::NAN,
                ..Default::default()
            },
            BokehLca {
                lca_band_fraction: 0.7,
                ..Default::default()
            },
            BokehLca {
                in_focus_coc_px: -1.0,
                ..Default::default()
            },
        ] {
            assert!(bad.apply(&f.input()).is_err());
        }
    }

    /// A white point on a black plane at 2 m with a constant CoC.
    fn point_frame(coc: f32) -> Frame {
        let (w, h) = (21u32, 21u32);
        let mut color = vec![[0.0f32; 3]; (w * h) as usize];
        color[(10 * w + 10) as usize] = [1.0; 3];
        Frame {
            color: Image::from_vec(w, h, color).unwrap(),
            depth: Image::new(w, h, 2.0).unwrap(),
            coc: Image::new(w, h, coc).unwrap(),
            focus_m: 1.0,
            k: 1.0,
            gaze: [10.0, 10.0],
            ppd: 1000.0,
        }
    }

    #[test]
    fn lca_rows_follow_liu() {
        // Far (CoC +9 px, r 4.5, 2-row bands). The point at (10,10) reaches pixel (10, 10+dy')
        // through kernel row dy = −dy'. Pixels below the point see it in their top rows.
        let out = BokehLca::default()
            .apply(&point_frame(9.0).input())
            .unwrap();
        let below = *out.get(10, 14); // point in this pixel's top row → no blue
        let above = *out.get(10, 6); // point in this pixel's bottom row → no red
        let mid = *out.get(10, 10);
        assert!(
            below[2] == 0.0 && below[0] > 0.0 && below[1] > 0.0,
            "{below:?}"
        );
        assert!(
            above[0] == 0.0 && above[2] > 0.0 && above[1] > 0.0,
            "{above:?}"
        );
        assert!(mid.iter().all(|&v| v > 0.0));
        assert_eq!(out.get(10, 13)[2], 0.0); // second row of the band
        assert!(out.get(10, 12)[2] > 0.0); // third row is outside it
                                           // Near: the other way round.
        let out = BokehLca::default()
            .apply(&point_frame(-9.0).input())
            .unwrap();
        assert!(out.get(10, 14)[0] == 0.0 && out.get(10, 14)[2] > 0.0);
        assert!(out.get(10, 6)[2] == 0.0 && out.get(10, 6)[0] > 0.0);
        // Flat regions keep their colour: a grey plane stays grey.
        let mut f = point_frame(9.0);
        f.color = f.color.map(|_| [0.3, 0.5, 0.7]);
        let out = BokehLca::default().apply(&f.input()).unwrap();
        for p in out.data() {
            for c in 0..3 {
                assert!((p[c] - [0.3, 0.5, 0.7][c]).abs() < 1e-5, "{p:?}");
            }
        }
    }

    #[test]
    fn lca_band_scales_with_the_kernel() {
        // CoC 36 px (r 18): band = 2/9·36 = 8 rows.
        let mut f = point_frame(36.0);
        let (w, h) = (41u32, 41u32);
        let mut color = vec![[0.0f32; 3]; (w * h) as usize];
        color[(20 * w + 20) as usize] = [1.0; 3];
        f.color = Image::from_vec(w, h, color).unwrap();
        f.depth = Image::new(w, h, 2.0).unwrap();
        f.coc = Image::new(w, h, 36.0).unwrap();
        let out = BokehLca::default().apply(&f.input()).unwrap();
        // Kernel rows dy < −18 + 8 = −10 drop blue → pixels 11..18 below the point.
        assert_eq!(out.get(20, 31)[2], 0.0);
        assert_eq!(out.get(20, 38)[2], 0.0);
        assert!(out.get(20, 30)[2] > 0.0);
        assert!(out.get(20, 31)[0] > 0.0);
    }
}
