//! Temporal accumulation in sample space, for log-polar and other buffer methods (VaFR's
//! stated limitation is flicker: Zhang et al., Sec. 8).
//!
//! Every shaded texel `(i, j)` of the new buffer takes its centre `(i + ½, j + ½)` through the
//! inverse mapping to the screen point `p`, reprojects `p` and its depth into the previous
//! frame (`super::reproject`), maps the previous screen point `q` through the *previous*
//! mapping's forward map (its own gaze: a saccade moves the whole log-polar grid) and reads the
//! previous buffer there bilinearly. A tap counts in proportion to its bilinear weight times its
//! depth agreement; taps the previous mapping did not shade count zero. Polar buffers wrap
//! along the angle axis. The history colour is clamped to the min/max of the new sample's 3×3
//! neighbourhood (neighbours from [`fovea_post::grid::Grid`], so the angular seam is no edge)
//! and folded in by [`super::running_estimate`].
//!
//! The new samples were traced at the texel centre plus the frame's jitter, so over the
//! jitter cycle the running estimate integrates each texel's footprint: sub-texel detail that
//! made single frames alias shows as its average.

use rayon::prelude::*;

use fovea_core::mapping::{FoveationMapping, SamplePoint};
use fovea_core::Image;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;

use super::{
    depth_weight, fold_moments, moments_variance, new_weight, reproject, resolution_weight,
    running_estimate, shaded_count, SpacingLut, TemporalSettings, TemporalStats, VARIANCE_MIN_AGE,
};
use crate::camera::EyeCamera;
use crate::error::Result;
use fovea_core::display::Gaze;
use fovea_core::units::ScreenPoint;

/// A history lookup: colour, weight, age, the previous sample spacing (pixels) and the
/// moments (`None` when not kept).
type Looked = (Rgb, f32, u16, f32, Option<[f32; 3]>);

/// The previous frame of a buffer method: its mapping and camera, the accumulated colour
/// (before AA), depth and the age of each texel's history.
pub struct SampleHistory {
    mapping: std::sync::Arc<dyn FoveationMapping>,
    camera: EyeCamera,
    gaze: Gaze,
    spacing: SpacingLut,
    color: Vec<Image<Rgb>>,
    depth: Vec<Image<f32>>,
    age: Vec<Image<u16>>,
    /// Temporal moments `[m₁, m₂, Σw²]` of the Monte Carlo part's demodulated luminance
    /// (`super::fold_moments`); empty when not kept.
    moments: Vec<Image<[f32; 3]>>,
    grids: Vec<Grid>,
    /// For screen-aligned layered mappings (Guenter, inset): per layer the affine map screen →
    /// layer `(u, v) = ((x − x₀)/s_x, (y − y₀)/s_y)`, so a texel reads the history of its own
    /// layer rather than the finest layer covering the point.
    affine: Vec<Option<[f64; 4]>>,
}

impl SampleHistory {
    /// Keeps a frame: `mapping` must be the mapping `buffers` were shaded with; `moments`
    /// per layer, or empty.
    pub fn new(
        mapping: std::sync::Arc<dyn FoveationMapping>,
        camera: EyeCamera,
        gaze: Gaze,
        spacing: SpacingLut,
        buffers: &SampleBuffers,
        age: Vec<Image<u16>>,
        moments: Vec<Image<[f32; 3]>>,
    ) -> Self {
        let grids = grids_of(mapping.as_ref(), buffers);
        let layered = buffers.color.len() > 1 && mapping.polar_layout().is_none();
        let affine = buffers
            .color
            .iter()
            .enumerate()
            .map(|(l, c)| {
                if !layered {
                    return None;
                }
                let at = |u: f64, v: f64| {
                    mapping.inverse(SamplePoint {
                        layer: l as u32,
                        u,
                        v,
                    })
                };
                let (w, h) = (c.width() as f64, c.height() as f64);
                let (a, b) = (at(0.5, 0.5)?, at(w - 0.5, h - 0.5)?);
                let sx = (b.x_px - a.x_px) / (w - 1.0).max(1.0);
                let sy = (b.y_px - a.y_px) / (h - 1.0).max(1.0);
                (sx > 0.0 && sy > 0.0).then_some([a.x_px - 0.5 * sx, a.y_px - 0.5 * sy, sx, sy])
            })
            .collect();
        Self {
            mapping,
            camera,
            gaze,
            spacing,
            color: buffers.color.clone(),
            depth: buffers.depth.clone(),
            age,
            moments,
            grids,
            affine,
        }
    }

    /// The history seen from texel centre `s` of `mapping` (depth `depth_m`, camera
    /// `camera`): `(colour, weight, age)`, `None` where it reprojects off the previous screen
    /// or outside the previous buffer.
    pub fn lookup(
        &self,
        mapping: &dyn FoveationMapping,
        camera: &EyeCamera,
        s: SamplePoint,
        depth_m: f32,
        tau: f32,
    ) -> Option<(Rgb, f32, u16)> {
        let p = mapping.inverse(s)?;
        self.lookup_at(camera, p, depth_m, s.layer, tau)
            .map(|(c, v, n, _, _)| (c, v, n))
    }

    /// [`lookup`](Self::lookup) from screen point `p`: also the previous sample spacing at
    /// the reprojected point, pixels, and the moments there (bilinear; `None` when not kept).
    fn lookup_at(
        &self,
        camera: &EyeCamera,
        p: ScreenPoint,
        depth_m: f32,
        layer: u32,
        tau: f32,
    ) -> Option<Looked> {
        let (q, z_prev) = reproject(camera, &self.camera, p, depth_m)?;
        let d = &self.camera.display;
        if !(q.x_px >= 0.0
            && q.y_px >= 0.0
            && q.x_px <= d.width_px as f64
            && q.y_px <= d.height_px as f64)
        {
            return None;
        }
        let prev = match self.affine.get(layer as usize) {
            Some(Some([x0, y0, sx, sy])) => SamplePoint {
                layer,
                u: (q.x_px - x0) / sx,
                v: (q.y_px - y0) / sy,
            },
            _ => self.mapping.forward(q)?,
        };
        let (c, v, n, m) = self.fetch(prev, z_prev, tau);
        let b = self.spacing.at(d.eccentricity(q, &self.gaze).0);
        Some((c, v, n, b, m))
    }

    /// Bilinear fetch at sample point `s`: `(colour, weight, age, moments)`; the weight is
    /// the sum of the valid taps' bilinear weights × depth agreement with `expected_m`; the
    /// moments are the bilinear ones of the same taps (`None` when not kept).
    fn fetch(
        &self,
        s: SamplePoint,
        expected_m: f32,
        tau: f32,
    ) -> (Rgb, f32, u16, Option<[f32; 3]>) {
        let l = s.layer as usize;
        let (Some(color), Some(depth), Some(age), Some(grid)) = (
            self.color.get(l),
            self.depth.get(l),
            self.age.get(l),
            self.grids.get(l),
        ) else {
            return ([0.0; 3], 0.0, 0, None);
        };
        let moments = self.moments.get(l);
        let (w, h) = (color.width() as i64, color.height() as i64);
        let (u, v) = (s.u - 0.5, s.v - 0.5);
        if !(u.is_finite() && v.is_finite()) {
            return ([0.0; 3], 0.0, 0, None);
        }
        let (i0, j0) = (u.floor() as i64, v.floor() as i64);
        let (fu, fv) = ((u - i0 as f64) as f32, (v - j0 as f64) as f32);
        // One tap: colour, depth agreement, age and moments, `None` outside the shaded buffer.
        let tap = |di: i64, dj: i64| -> Option<(Rgb, f32, u16, [f32; 3])> {
            let i = i0 + di;
            if i < 0 || i >= w {
                return None;
            }
            let j = match grid {
                Grid::Polar { rows, period } => {
                    let r = rows[i as usize] as i64;
                    let full_turn = r > 0 && (period[i as usize] - r as f64).abs() < 0.5;
                    if full_turn {
                        (j0 + dj).rem_euclid(r)
                    } else {
                        j0 + dj
                    }
                }
                Grid::Rect { .. } => j0 + dj,
            };
            if j < 0 || j >= h || !self.mapping.is_shaded(s.layer, i as u32, j as u32) {
                return None;
            }
            let (iu, ju) = (i as u32, j as u32);
            let dw = depth_weight(*depth.get(iu, ju), expected_m, tau);
            let m = moments.map_or([0.0; 3], |m| *m.get(iu, ju));
            Some((*color.get(iu, ju), dw, *age.get(iu, ju), m))
        };
        // Bilinear over the four nearest taps, weighted by depth agreement.
        let mut acc = [0.0f32; 3];
        let mut macc = [0.0f32; 3];
        let (mut valid, mut n) = (0.0f32, 0u16);
        for (di, dj, bw) in [
            (0, 0, (1.0 - fu) * (1.0 - fv)),
            (1, 0, fu * (1.0 - fv)),
            (0, 1, (1.0 - fu) * fv),
            (1, 1, fu * fv),
        ] {
            if bw <= 0.0 {
                continue;
            }
            let Some((c, dw, a, m)) = tap(di, dj).filter(|t| t.1 > 0.0) else {
                continue;
            };
            let q = bw * dw;
            for k in 0..3 {
                acc[k] += q * c[k];
                macc[k] += q * m[k];
            }
            valid += q;
            n = n.max(a);
        }
        if valid <= 0.0 {
            return ([0.0; 3], 0.0, 0, None);
        }
        let bilinear = acc.map(|a| a / valid);
        let moments = moments.map(|_| macc.map(|m| m / valid));
        // Where all 16 taps around agree in depth, Catmull-Rom instead: bilinear history
        // lookups blur a little every frame, and the blur accumulates.
        let (wx, wy) = (catmull_rom(fu), catmull_rom(fv));
        let mut cr = [0.0f32; 3];
        for (dj, wyj) in (-1..=2).zip(wy) {
            for (di, wxi) in (-1..=2).zip(wx) {
                match tap(di, dj) {
                    Some((c, dw, _, _)) if dw >= 1.0 => {
                        for k in 0..3 {
                            cr[k] += wxi * wyj * c[k];
                        }
                    }
                    _ => return (bilinear, valid, n, moments),
                }
            }
        }
        (cr.map(|v| v.max(0.0)), valid, n, moments)
    }
}

/// Catmull-Rom weights of the taps at −1, 0, 1, 2 for a fractional position `t`.
#[inline]
fn catmull_rom(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// The neighbourhood topology of each layer.
fn grids_of(mapping: &dyn FoveationMapping, buffers: &SampleBuffers) -> Vec<Grid> {
    let polar = mapping.polar_layout();
    buffers
        .color
        .iter()
        .map(|c| Grid::of_layer(polar.as_ref(), c.width(), c.height()))
        .collect()
}

/// Moments per layer, ages and statistics of a frame.
type Blended = (TemporalStats, Vec<Image<u16>>, Vec<Image<[f32; 3]>>);

/// The moments of a single frame of luminance `y`: `[y, y², 1]` (`[0, 0, 1]` where `y` is
/// not finite: nothing to carry on).
#[inline]
fn single(y: f32) -> [f32; 3] {
    if y.is_finite() {
        [y, y * y, 1.0]
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// First frame: every shaded texel is fresh, with age 1; the moments of `fresh` (the
/// frame's Monte Carlo luminance per layer, [`monte_carlo_luma`]) where given.
pub(crate) fn first_frame(
    mapping: &dyn FoveationMapping,
    buffers: &SampleBuffers,
    fresh_luma: Option<&[Image<f32>]>,
) -> Result<Blended> {
    let mut fresh = 0;
    let mut ages = Vec::with_capacity(buffers.color.len());
    for (l, c) in buffers.color.iter().enumerate() {
        fresh += shaded_count(mapping, l as u32, c.width(), c.height());
        ages.push(Image::new(c.width(), c.height(), 1u16)?);
    }
    let moments = match fresh_luma {
        Some(y) => y
            .iter()
            .map(|y| {
                Image::from_vec(
                    y.width(),
                    y.height(),
                    y.data().iter().map(|&v| single(v)).collect(),
                )
            })
            .collect::<fovea_core::Result<Vec<_>>>()?,
        None => Vec::new(),
    };
    Ok((
        TemporalStats {
            fresh,
            ..Default::default()
        },
        ages,
        moments,
    ))
}

/// The luminance of each sample's Monte Carlo part, demodulated by its albedo
/// (`fovea_post::denoise::demodulate`, as the denoiser filters it): the colour less `exact`
/// (NaN there: the whole colour). A layer without a matching `exact` or `albedo` image is NaN
/// throughout (no moments kept there).
pub(crate) fn monte_carlo_luma(
    buffers: &SampleBuffers,
    exact: &[Image<Rgb>],
    albedo: &[Image<Rgb>],
) -> Result<Vec<Image<f32>>> {
    let mut out = Vec::with_capacity(buffers.color.len());
    for (l, c) in buffers.color.iter().enumerate() {
        let size = (c.width(), c.height());
        let (Some(e), Some(a)) = (
            exact.get(l).filter(|e| (e.width(), e.height()) == size),
            albedo.get(l).filter(|a| (a.width(), a.height()) == size),
        ) else {
            out.push(Image::new(size.0, size.1, f32::NAN)?);
            continue;
        };
        let y: Vec<f32> = c
            .data()
            .par_iter()
            .zip(e.data().par_iter())
            .zip(a.data().par_iter())
            .map(|((c, e), a)| {
                let part = if e.iter().all(|v| v.is_finite()) {
                    [c[0] - e[0], c[1] - e[1], c[2] - e[2]]
                } else {
                    *c
                };
                fovea_post::luma(fovea_post::denoise::demodulate(part, *a))
            })
            .collect();
        out.push(Image::from_vec(size.0, size.1, y)?);
    }
    Ok(out)
}

/// The denoiser's variance per layer from the moments and ages of a frame
/// ([`moments_variance`] where the age is at least [`VARIANCE_MIN_AGE`], NaN elsewhere),
/// written into `out` (resized to the layers).
pub(crate) fn variance_of(
    moments: &[Image<[f32; 3]>],
    ages: &[Image<u16>],
    out: &mut Vec<Image<f32>>,
) -> Result<()> {
    out.truncate(moments.len());
    for (l, (m, a)) in moments.iter().zip(ages).enumerate() {
        let fits = out
            .get(l)
            .is_some_and(|v| (v.width(), v.height()) == (m.width(), m.height()));
        if !fits {
            let img = Image::new(m.width(), m.height(), f32::NAN)?;
            if l < out.len() {
                out[l] = img;
            } else {
                out.push(img);
            }
        }
        out[l]
            .data_mut()
            .par_iter_mut()
            .zip(m.data().par_iter().zip(a.data().par_iter()))
            .for_each(|(v, (m, &age))| {
                *v = if age >= VARIANCE_MIN_AGE {
                    moments_variance(*m)
                } else {
                    f32::NAN
                };
            });
    }
    Ok(())
}

/// Folds `history` into `buffers` (this frame's shaded samples of `mapping` seen by
/// `camera`); returns the statistics, the new ages and, with `fresh_luma` (the frame's Monte
/// Carlo luminance per layer, [`monte_carlo_luma`]), the moments folded with the same
/// weights as the colour (empty without).
#[allow(clippy::too_many_arguments)]
pub(crate) fn blend(
    history: &SampleHistory,
    settings: &TemporalSettings,
    mapping: &dyn FoveationMapping,
    camera: &EyeCamera,
    gaze: Gaze,
    spacing: &SpacingLut,
    buffers: &mut SampleBuffers,
    fresh_luma: Option<&[Image<f32>]>,
) -> Result<Blended> {
    let grids = grids_of(mapping, buffers);
    let mut stats = TemporalStats::default();
    let mut ages = Vec::with_capacity(buffers.color.len());
    let mut moments = Vec::new();
    for (l, (color, depth)) in buffers.color.iter_mut().zip(&buffers.depth).enumerate() {
        let layer = l as u32;
        let (w, h) = (color.width(), color.height());
        let grid = &grids[l];
        let src = color.clone();
        let luma = fresh_luma.and_then(|y| y.get(l));
        let y_of = |k: usize| luma.map_or(f32::NAN, |y| y.data()[k]);
        type Out = (Rgb, u16, bool, bool, [f32; 3]);
        let results: Vec<Out> = (0..w as usize * h as usize)
            .into_par_iter()
            .map(|k| {
                let (i, j) = ((k % w as usize) as u32, (k / w as usize) as u32);
                let c = *src.get(i, j);
                if !mapping.is_shaded(layer, i, j) {
                    return (c, 0, false, false, [0.0, 0.0, 1.0]);
                }
                let s = SamplePoint {
                    layer,
                    u: i as f64 + 0.5,
                    v: j as f64 + 0.5,
                };
                let z = *depth.get(i, j);
                let fetched = mapping.inverse(s).and_then(|p| {
                    let (hc, v, n, b_prev, hm) =
                        history.lookup_at(camera, p, z, layer, settings.depth_tolerance)?;
                    let (v, n) = resolution_weight(
                        v,
                        n,
                        spacing.at(camera.display.eccentricity(p, &gaze).0),
                        b_prev,
                    );
                    Some((hc, v, n, hm))
                });
                let y = y_of(k);
                let Some((mut hc, v, n, hm)) = fetched.filter(|f| f.1 > 1e-3) else {
                    return (c, 1, true, false, single(y));
                };
                if settings.clamp {
                    let (mut lo, mut hi) = (c, c);
                    for dj in -1..=1 {
                        for di in -1..=1 {
                            let (ni, nj) = grid.step(i, j, di, dj);
                            if mapping.is_shaded(layer, ni, nj) {
                                let q = src.get(ni, nj);
                                for ch in 0..3 {
                                    lo[ch] = lo[ch].min(q[ch]);
                                    hi[ch] = hi[ch].max(q[ch]);
                                }
                            }
                        }
                    }
                    for ch in 0..3 {
                        hc[ch] = hc[ch].clamp(lo[ch], hi[ch]);
                    }
                }
                let (out, age) = running_estimate(c, hc, v, n, settings.alpha_min);
                // The moments with the colour's weights; a history without them (or a
                // texel without a finite luminance) starts over.
                let m = match hm {
                    Some(hm) if y.is_finite() && hm.iter().all(|v| v.is_finite()) => {
                        fold_moments(y, hm, new_weight(v, n, settings.alpha_min))
                    }
                    _ => single(y),
                };
                (out, age, true, true, m)
            })
            .collect();
        let mut age_img = Image::new(w, h, 0u16)?;
        let mut m_img = match luma {
            Some(_) => Some(Image::new(w, h, [0.0f32, 0.0, 1.0])?),
            None => None,
        };
        for (k, (out, age, shaded, reused, m)) in results.into_iter().enumerate() {
            color.data_mut()[k] = out;
            age_img.data_mut()[k] = age;
            if let Some(mi) = m_img.as_mut() {
                mi.data_mut()[k] = m;
            }
            if shaded {
                if reused {
                    stats.reused += 1;
                } else {
                    stats.fresh += 1;
                }
            }
        }
        ages.push(age_img);
        if let Some(mi) = m_img {
            moments.push(mi);
        }
    }
    // Every layer or none.
    if moments.len() != ages.len() {
        moments.clear();
    }
    Ok((stats, ages, moments))
}
