//! Scenes, fixtures and measurements the DOF filter tests share: plane scenes with their
//! exact thin-lens image ([`super::planes`]), the owned buffers a [`DofInput`] borrows, luma
//! PSNR with a border left out, 10–90 % edge width, and a frame with NaN depth and CoC.

use std::ops::Deref;

use fovea_core::Image;

use super::planes::{Plane, PlaneScene};
use super::{DofFilter, DofInput};
use crate::{luma, Rgb};

/// Thin-lens signed CoC in pixels: `k·(1/F − 1/D)`, `1/∞ = 0`.
pub fn thin_lens_coc(k: f32, focus_m: f32, depth_m: f32) -> f32 {
    let inv = |m: f32| if m.is_finite() { 1.0 / m } else { 0.0 };
    k * (inv(focus_m) - inv(depth_m))
}

// ---- Textures ----

/// A smooth-and-sharp texture: 6-px checker mixed with a slow colour wave.
pub fn checker_wave(x: f32, y: f32) -> Rgb {
    let chk = if ((x / 6.0).floor() + (y / 6.0).floor()) as i32 % 2 == 0 {
        0.85
    } else {
        0.15
    };
    let s = 0.5 + 0.5 * (0.21 * x + 0.13 * y).sin();
    [0.7 * chk + 0.3 * s, 0.8 * chk + 0.2 * (1.0 - s), chk]
}

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

/// A pixel-constant texture: 8-px checker (±`checker`) plus per-pixel noise (±`noise`)
/// around `base`.
pub fn noisy_checker(
    base: Rgb,
    checker: f32,
    noise: f32,
    seed: u32,
) -> impl Fn(f32, f32) -> Rgb + Send + Sync + 'static {
    move |x: f32, y: f32| {
        let (ix, iy) = (x.floor() as i32, y.floor() as i32);
        let ch = if ((ix >> 3) + (iy >> 3)) & 1 == 0 {
            1.0
        } else {
            -1.0
        };
        let s = 1.0 + checker * ch;
        std::array::from_fn(|k| {
            let n = noise * (2.0 * hash(ix, iy, seed + k as u32) - 1.0);
            (base[k] * s + n).clamp(0.0, 1.0)
        })
    }
}

// ---- Scenes ----

/// A plane at `depth_m` with colour `color`, opaque where `opaque` says.
pub fn plane(
    depth_m: f32,
    color: impl Fn(f32, f32) -> Rgb + Send + Sync + 'static,
    opaque: impl Fn(f32, f32) -> bool + Send + Sync + 'static,
) -> Plane {
    Plane {
        depth_m,
        color: Box::new(color),
        opaque: Box::new(opaque),
    }
}

/// `planes` on a black background.
pub fn scene(w: u32, h: u32, planes: Vec<Plane>) -> PlaneScene {
    PlaneScene {
        width: w,
        height: h,
        planes,
        background: [0.0; 3],
    }
}

/// One plane of texture `color` at `depth_m` filling the frame.
pub fn plane_scene(
    w: u32,
    h: u32,
    depth_m: f32,
    color: impl Fn(f32, f32) -> Rgb + Send + Sync + 'static,
) -> PlaneScene {
    scene(w, h, vec![plane(depth_m, color, |_, _| true)])
}

/// One plane of a noisy 8-px checker at `depth_m` filling the frame.
pub fn single_plane(w: u32, h: u32, depth_m: f32) -> PlaneScene {
    plane_scene(w, h, depth_m, noisy_checker([0.4, 0.5, 0.3], 0.4, 0.15, 5))
}

/// A textured near plane (0.5 m, `x < 32`) over a textured far plane (2 m), 64×32.
pub fn two_textured_planes() -> PlaneScene {
    scene(
        64,
        32,
        vec![
            plane(
                0.5,
                |x, y| checker_wave(x, y).map(|v| 0.3 + 0.7 * v),
                |x, _| x < 32.0,
            ),
            plane(2.0, |x, y| checker_wave(y, x).map(|v| 0.6 * v), |_, _| true),
        ],
    )
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
    scene(
        w,
        h,
        vec![
            plane(near_m, move |_, _| left, move |x, _| x < edge_x),
            plane(far_m, move |_, _| right, |_, _| true),
        ],
    )
}

/// Shape of the near occluder of [`occluder_scene`].
#[derive(Clone, Copy, Debug)]
pub enum Edge {
    /// Opaque for `x < x0` (a vertical edge).
    Straight(f32),
    /// Opaque inside a disc `(cx, cy, radius)`.
    Circle(f32, f32, f32),
}

/// Near plane at 0.5 m (occluder of shape `edge`) over a textured far plane at 2 m filling
/// the frame. `textured_near` selects a textured or a flat bright occluder.
pub fn occluder_scene(w: u32, h: u32, edge: Edge, textured_near: bool) -> PlaneScene {
    let near_tex = noisy_checker([0.85, 0.7, 0.5], 0.15, 0.08, 11);
    let near_color: Box<dyn Fn(f32, f32) -> Rgb + Send + Sync> = if textured_near {
        Box::new(near_tex)
    } else {
        Box::new(|_, _| [0.9, 0.85, 0.8])
    };
    let near = Plane {
        depth_m: 0.5,
        color: near_color,
        opaque: match edge {
            Edge::Straight(x0) => Box::new(move |x, _| x < x0),
            Edge::Circle(cx, cy, r) => Box::new(move |x, y| (x - cx).hypot(y - cy) < r),
        },
    };
    let far = plane(
        2.0,
        noisy_checker([0.25, 0.35, 0.45], 0.35, 0.12, 23),
        |_, _| true,
    );
    scene(w, h, vec![near, far])
}

// ---- Frames ----

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
    /// Pinhole frame of `scene` with thin-lens CoCs for `k` px/D and focus `focus_m`, gaze
    /// at the centre, 1000 px/deg (everything foveal).
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

    /// `filter` applied to this frame.
    pub fn filtered(&self, filter: &dyn DofFilter) -> Image<Rgb> {
        filter.apply(&self.input()).unwrap()
    }
}

/// A [`Frame`] with its thin-lens ground truth.
pub struct Case {
    pub frame: Frame,
    pub truth: Image<Rgb>,
}

impl Case {
    /// The pinhole frame of `scene` and its thin-lens image from `lens` aperture samples.
    pub fn new(scene: &PlaneScene, k: f32, focus_m: f32, lens: u32) -> Self {
        Self {
            frame: Frame::from_scene(scene, k, focus_m),
            truth: scene.thin_lens(k, focus_m, lens).unwrap(),
        }
    }

    /// Luma PSNR of `filter`'s output against the thin-lens truth, `margin` px border
    /// excluded (the truth sees texture beyond the frame).
    pub fn psnr(&self, filter: &dyn DofFilter, margin: u32) -> f64 {
        luma_psnr(&self.filtered(filter), &self.truth, margin)
    }
}

impl Deref for Case {
    type Target = Frame;
    fn deref(&self) -> &Frame {
        &self.frame
    }
}

/// Frame with NaN depth and NaN / ±∞ / huge CoCs sprinkled in, for robustness tests.
pub fn nan_frame() -> Frame {
    let mut f = Frame::from_scene(&plane_scene(32, 24, 2.0, checker_wave), 8.0, 0.5);
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
        } else if i % 17 == 0 {
            *c = f32::NEG_INFINITY;
        }
    }
    f
}

pub fn all_finite(img: &Image<Rgb>) -> bool {
    img.data().iter().all(|p| p.iter().all(|v| v.is_finite()))
}

// ---- Measurements ----

/// Luma PSNR (peak 1) over the pixels at least `margin` from the border (`+∞` if equal).
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
    10.0 * (n as f64 / se).log10()
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
    (crossing(0.9, false) - crossing(0.1, true)).abs()
}

/// [`edge_width`] of row `y` of `img`, plateaus its end pixels.
pub fn row_edge_width(img: &Image<Rgb>, y: u32) -> f32 {
    edge_width(&column_profile(img, y, y + 1), 1)
}
