//! Reprojection-based temporal anti-aliasing of Weier et al.'s sparse pipeline (Weier, Roth,
//! Hinkenjann, Slusallek 2018, Sec. 3.1 "Reprojection", Fig. 1 and 3).
//!
//! The previous frame is kept as the mip pyramid of its pull-push reconstruction with the
//! depth in the alpha channel ("an image pyramid, similar to a mipmap with depths stored in the
//! alpha channel", which lets occluded cache values be eliminated). Every ray-cast pixel of the
//! new frame:
//!
//! 1. reprojects its world point into the previous frame (`super::reproject`);
//! 2. evaluates the pyramid in a Quincunx pattern — centre weight ½, four corners ⅛ at
//!    `(±b/2, ±b/2)` — at the level of its footprint `b`: the sample spacing at its
//!    eccentricity, `1/√ρ(e)` pixels for the sampling probability `ρ` (1 inside `r₀`, `p_min`
//!    beyond `r₁`), the paper's "pixel footprint adapted based on the eccentricity-dependent
//!    sampling probabilities" (level `round(log₂ b)`, bilinear within the level). Where the
//!    footprint is one pixel (inside `r₀`) the five taps coincide: one bilinear tap of level
//!    0 (ours; the spread pattern would blur the fovea a little more every frame);
//! 3. weights each tap by its depth agreement with the new sample's reprojected depth and
//!    folds the weighted mean into the running estimate with the user-set minimum weight
//!    (`super::running_estimate`).
//!
//! The pull-push reconstruction then fills the screen from the smoothed samples, and its
//! result becomes the next frame's pyramid. Choices (the paper does not say): the age of a
//! pixel's history is the largest age within the footprint around `q`; with the history
//! clamp on (default), the history colour is clamped to the range of this frame's cast
//! samples within the footprint (`⌈b⌉` pixels) around the pixel, as in the sample-space path.

use rayon::prelude::*;

use fovea_core::display::Gaze;
use fovea_core::mapping::FoveationMapping;
use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::mip::MipPyramid;
use fovea_post::Rgb;

use super::{
    depth_weight, reproject, resolution_weight, running_estimate, shaded_count, SpacingLut,
    TemporalSettings, TemporalStats, SKY_DEPTH_M,
};
use crate::camera::EyeCamera;
use crate::error::{RenderError, Result};

/// The previous reconstructed frame: RGB + depth pyramid, camera, ages at full resolution.
pub struct PyramidHistory {
    camera: EyeCamera,
    gaze: Gaze,
    spacing: SpacingLut,
    pyramid: MipPyramid<4>,
    age: Image<u16>,
}

impl PyramidHistory {
    /// Keeps the reconstruction (`color`, `depth`) of a frame with the samples' `ages` (0 where no
    /// sample was cast), its gaze and sample spacing. Levels cover the widest spacing.
    pub fn new(
        camera: &EyeCamera,
        color: &Image<Rgb>,
        depth: &Image<f32>,
        ages: Image<u16>,
        spacing: SpacingLut,
        gaze: Gaze,
    ) -> Result<Self> {
        let max_spacing_px = spacing.max();
        let (w, h) = (color.width() as usize, color.height() as usize);
        let texels: Vec<[f32; 4]> = color
            .data()
            .par_iter()
            .zip(depth.data())
            .map(|(c, &d)| {
                let d = if d.is_finite() {
                    d.min(SKY_DEPTH_M)
                } else {
                    SKY_DEPTH_M
                };
                [c[0], c[1], c[2], d]
            })
            .collect();
        let top = max_spacing_px.max(1.0).log2().ceil() as usize + 1;
        Ok(Self {
            camera: camera.clone(),
            gaze,
            spacing,
            pyramid: MipPyramid::new(w, h, &texels, top),
            age: ages,
        })
    }

    /// Largest age in the `(2r + 1)²` window around `q`.
    fn age_near(&self, q: ScreenPoint, r: i64) -> u16 {
        let (w, h) = (self.age.width() as i64, self.age.height() as i64);
        let (x, y) = (q.x_px.floor() as i64, q.y_px.floor() as i64);
        let mut n = 0;
        for yy in (y - r).max(0)..=(y + r).min(h - 1) {
            for xx in (x - r).max(0)..=(x + r).min(w - 1) {
                n = n.max(*self.age.get(xx as u32, yy as u32));
            }
        }
        n
    }
}

/// First frame: ages 1 at the cast pixels.
pub(crate) fn first_frame(
    mapping: &dyn FoveationMapping,
    buffers: &SampleBuffers,
) -> Result<(TemporalStats, Image<u16>)> {
    let c = buffers
        .color
        .first()
        .ok_or_else(|| RenderError::Unsupported("a Weier frame without a buffer".into()))?;
    let (w, h) = (c.width(), c.height());
    let mut ages = Image::new(w, h, 0u16)?;
    for j in 0..h {
        for i in 0..w {
            if mapping.is_shaded(0, i, j) {
                *ages.get_mut(i, j) = 1;
            }
        }
    }
    Ok((
        TemporalStats {
            fresh: shaded_count(mapping, 0, w, h),
            ..Default::default()
        },
        ages,
    ))
}

/// Folds the previous frame's pyramid into the cast pixels of `buffers`.
pub(crate) fn blend(
    history: &PyramidHistory,
    settings: &TemporalSettings,
    mapping: &dyn FoveationMapping,
    camera: &EyeCamera,
    gaze: Gaze,
    lut: &SpacingLut,
    buffers: &mut SampleBuffers,
) -> Result<(TemporalStats, Image<u16>)> {
    let (Some(color), Some(depth)) = (buffers.color.first_mut(), buffers.depth.first()) else {
        return Err(RenderError::Unsupported(
            "a Weier frame without a buffer".into(),
        ));
    };
    let (w, h) = (color.width(), color.height());
    let display = &camera.display;
    let levels = history.pyramid.len();
    let src = color.clone();
    type Out = ([f32; 3], u16, u8);
    let results: Vec<Out> = (0..w as usize * h as usize)
        .into_par_iter()
        .map(|k| {
            let (i, j) = ((k % w as usize) as u32, (k / w as usize) as u32);
            let c = *src.get(i, j);
            if !mapping.is_shaded(0, i, j) {
                return (c, 0, 0);
            }
            let p = ScreenPoint::new(i as f64 + 0.5, j as f64 + 0.5);
            let z = *depth.get(i, j);
            let Some((q, z_prev)) = reproject(camera, &history.camera, p, z) else {
                return (c, 1, 1);
            };
            let (qx, qy) = (q.x_px as f32, q.y_px as f32);
            if !(qx >= 0.0 && qy >= 0.0 && qx <= w as f32 && qy <= h as f32) {
                return (c, 1, 1);
            }
            let b = lut.at(display.eccentricity(p, &gaze).0);
            let level = (b.max(1.0).log2().round() as usize).min(levels - 1);
            // Fully sampled pixels (footprint one pixel) read one bilinear tap of level 0: the
            // Quincunx spread would blur the fovea a little more every frame.
            let o = if b > 1.01 { 0.5 * b } else { 0.0 };
            let mut acc = [0.0f32; 3];
            let (mut wsum, mut v) = (0.0f32, 0.0f32);
            for (dx, dy, qw) in [
                (0.0, 0.0, 0.5),
                (-o, -o, 0.125),
                (o, -o, 0.125),
                (-o, o, 0.125),
                (o, o, 0.125),
            ] {
                let t = history.pyramid.bilinear(level, qx + dx, qy + dy);
                let dw = depth_weight(t[3], z_prev, settings.depth_tolerance);
                let wt = qw * dw;
                for ch in 0..3 {
                    acc[ch] += wt * t[ch];
                }
                wsum += wt;
                v += wt;
            }
            if wsum <= 1e-3 {
                return (c, 1, 1);
            }
            let mut hc = acc.map(|a| a / wsum);
            if settings.clamp {
                // The range of this frame's cast samples within the footprint around.
                let r = b.ceil().max(1.0) as i64;
                let (mut lo, mut hi) = (c, c);
                for yy in (j as i64 - r).max(0)..=(j as i64 + r).min(h as i64 - 1) {
                    for xx in (i as i64 - r).max(0)..=(i as i64 + r).min(w as i64 - 1) {
                        let (xu, yu) = (xx as u32, yy as u32);
                        if mapping.is_shaded(0, xu, yu) {
                            let q = src.get(xu, yu);
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
            let n = history.age_near(q, b.ceil() as i64);
            let b_prev = history.spacing.at(display.eccentricity(q, &history.gaze).0);
            let (v, n) = resolution_weight(v, n, b, b_prev);
            let (out, age) = running_estimate(c, hc, v, n, settings.alpha_min);
            (out, age, if n > 0 && v > 1e-3 { 2 } else { 1 })
        })
        .collect();
    let mut ages = Image::new(w, h, 0u16)?;
    let mut stats = TemporalStats::default();
    for (k, (out, age, state)) in results.into_iter().enumerate() {
        color.data_mut()[k] = out;
        ages.data_mut()[k] = age;
        match state {
            1 => stats.fresh += 1,
            2 => stats.reused += 1,
            _ => {}
        }
    }
    Ok((stats, ages))
}
