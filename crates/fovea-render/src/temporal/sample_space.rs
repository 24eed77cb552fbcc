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
    depth_weight, reproject, resolution_weight, running_estimate, shaded_count, SpacingLut,
    TemporalSettings, TemporalStats,
};
use crate::camera::EyeCamera;
use crate::error::Result;
use fovea_core::display::Gaze;
use fovea_core::units::ScreenPoint;

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
    grids: Vec<Grid>,
    /// For screen-aligned layered mappings (Guenter, inset): per layer the affine map screen →
    /// layer `(u, v) = ((x − x₀)/s_x, (y − y₀)/s_y)`, so a texel reads the history of its own
    /// layer rather than the finest layer covering the point.
    affine: Vec<Option<[f64; 4]>>,
}

impl SampleHistory {
    /// Keeps a frame: `mapping` must be the mapping `buffers` were shaded with.
    pub fn new(
        mapping: std::sync::Arc<dyn FoveationMapping>,
        camera: EyeCamera,
        gaze: Gaze,
        spacing: SpacingLut,
        buffers: &SampleBuffers,
        age: Vec<Image<u16>>,
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
            .map(|(c, v, n, _)| (c, v, n))
    }

    /// [`lookup`](Self::lookup) from screen point `p`: also the previous sample spacing at
    /// the reprojected point, pixels.
    fn lookup_at(
        &self,
        camera: &EyeCamera,
        p: ScreenPoint,
        depth_m: f32,
        layer: u32,
        tau: f32,
    ) -> Option<(Rgb, f32, u16, f32)> {
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
        let (c, v, n) = self.fetch(prev, z_prev, tau);
        let b = self.spacing.at(d.eccentricity(q, &self.gaze).0);
        Some((c, v, n, b))
    }

    /// Bilinear fetch at sample point `s`: `(colour, weight, age)`; the weight is the sum of
    /// the valid taps' bilinear weights × depth agreement with `expected_m`.
    fn fetch(&self, s: SamplePoint, expected_m: f32, tau: f32) -> (Rgb, f32, u16) {
        let l = s.layer as usize;
        let (Some(color), Some(depth), Some(age), Some(grid)) = (
            self.color.get(l),
            self.depth.get(l),
            self.age.get(l),
            self.grids.get(l),
        ) else {
            return ([0.0; 3], 0.0, 0);
        };
        let (w, h) = (color.width() as i64, color.height() as i64);
        let (u, v) = (s.u - 0.5, s.v - 0.5);
        if !(u.is_finite() && v.is_finite()) {
            return ([0.0; 3], 0.0, 0);
        }
        let (i0, j0) = (u.floor() as i64, v.floor() as i64);
        let (fu, fv) = ((u - i0 as f64) as f32, (v - j0 as f64) as f32);
        // One tap: colour, depth agreement and age, `None` outside the shaded buffer.
        let tap = |di: i64, dj: i64| -> Option<(Rgb, f32, u16)> {
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
            Some((*color.get(iu, ju), dw, *age.get(iu, ju)))
        };
        // Bilinear over the four nearest taps, weighted by depth agreement.
        let mut acc = [0.0f32; 3];
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
            let Some((c, dw, a)) = tap(di, dj).filter(|t| t.1 > 0.0) else {
                continue;
            };
            let q = bw * dw;
            for k in 0..3 {
                acc[k] += q * c[k];
            }
            valid += q;
            n = n.max(a);
        }
        if valid <= 0.0 {
            return ([0.0; 3], 0.0, 0);
        }
        let bilinear = acc.map(|a| a / valid);
        // Where all 16 taps around agree in depth, Catmull-Rom instead: bilinear history
        // lookups blur a little every frame, and the blur accumulates.
        let (wx, wy) = (catmull_rom(fu), catmull_rom(fv));
        let mut cr = [0.0f32; 3];
        for (dj, wyj) in (-1..=2).zip(wy) {
            for (di, wxi) in (-1..=2).zip(wx) {
                match tap(di, dj) {
                    Some((c, dw, _)) if dw >= 1.0 => {
                        for k in 0..3 {
                            cr[k] += wxi * wyj * c[k];
                        }
                    }
                    _ => return (bilinear, valid, n),
                }
            }
        }
        (cr.map(|v| v.max(0.0)), valid, n)
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
        .map(|c| match &polar {
            Some(l) => Grid::polar(l),
            None => Grid::Rect {
                width: c.width(),
                height: c.height(),
            },
        })
        .collect()
}

/// First frame: every shaded texel is fresh, with age 1.
pub(crate) fn first_frame(
    mapping: &dyn FoveationMapping,
    buffers: &SampleBuffers,
) -> Result<(TemporalStats, Vec<Image<u16>>)> {
    let mut fresh = 0;
    let mut ages = Vec::with_capacity(buffers.color.len());
    for (l, c) in buffers.color.iter().enumerate() {
        fresh += shaded_count(mapping, l as u32, c.width(), c.height());
        ages.push(Image::new(c.width(), c.height(), 1u16)?);
    }
    Ok((
        TemporalStats {
            fresh,
            ..Default::default()
        },
        ages,
    ))
}

/// Folds `history` into `buffers` (this frame's shaded samples of `mapping` seen by
/// `camera`); returns the statistics and the new ages.
pub(crate) fn blend(
    history: &SampleHistory,
    settings: &TemporalSettings,
    mapping: &dyn FoveationMapping,
    camera: &EyeCamera,
    gaze: Gaze,
    spacing: &SpacingLut,
    buffers: &mut SampleBuffers,
) -> Result<(TemporalStats, Vec<Image<u16>>)> {
    let grids = grids_of(mapping, buffers);
    let mut stats = TemporalStats::default();
    let mut ages = Vec::with_capacity(buffers.color.len());
    for (l, (color, depth)) in buffers.color.iter_mut().zip(&buffers.depth).enumerate() {
        let layer = l as u32;
        let (w, h) = (color.width(), color.height());
        let grid = &grids[l];
        let src = color.clone();
        type Out = (Rgb, u16, bool, bool);
        let results: Vec<Out> = (0..w as usize * h as usize)
            .into_par_iter()
            .map(|k| {
                let (i, j) = ((k % w as usize) as u32, (k / w as usize) as u32);
                let c = *src.get(i, j);
                if !mapping.is_shaded(layer, i, j) {
                    return (c, 0, false, false);
                }
                let s = SamplePoint {
                    layer,
                    u: i as f64 + 0.5,
                    v: j as f64 + 0.5,
                };
                let z = *depth.get(i, j);
                let fetched = mapping.inverse(s).and_then(|p| {
                    let (hc, v, n, b_prev) =
                        history.lookup_at(camera, p, z, layer, settings.depth_tolerance)?;
                    let (v, n) = resolution_weight(
                        v,
                        n,
                        spacing.at(camera.display.eccentricity(p, &gaze).0),
                        b_prev,
                    );
                    Some((hc, v, n))
                });
                let Some((mut hc, v, n)) = fetched.filter(|f| f.1 > 1e-3) else {
                    return (c, 1, true, false);
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
                (out, age, true, true)
            })
            .collect();
        let mut age_img = Image::new(w, h, 0u16)?;
        for (k, (out, age, shaded, reused)) in results.into_iter().enumerate() {
            color.data_mut()[k] = out;
            age_img.data_mut()[k] = age;
            if shaded {
                if reused {
                    stats.reused += 1;
                } else {
                    stats.fresh += 1;
                }
            }
        }
        ages.push(age_img);
    }
    Ok((stats, ages))
}
