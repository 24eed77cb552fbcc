//! Gaze-contingent layered depth-of-field filter (Weier et al. 2018, "Foveated Depth-of-Field
//! Filtering in Head-Mounted Displays", Sec. 3.2 "DoF Filtering" and "DoF Combine", Fig. 2;
//! layering after Bukowski et al. 2013).
//!
//! **Layers.** Pixels are split by the signed CoC into a *near* field (`coc_px ≤
//! −in_focus_coc_px`), a focused *mid* field and a *far* field (`coc_px ≥ in_focus_coc_px`).
//! Each blurred layer is a premultiplied RGBA buffer whose alpha is the layer's coverage
//! (1 where the pixel belongs to the layer, 0 elsewhere), so a blur of the layer never mixes
//! in pixels of another layer: "blurry distant objects should not bleed over closer objects
//! in the focused field".
//!
//! **Blur (fovea vs periphery).** With eccentricity `e = |p − gaze_px| / px_per_degree`
//! (degrees, small-angle), the *central* region `e < fovea_radius_deg` uses a separable
//! Gaussian, the *periphery* `e ≥ transition_end_deg` samples a mip pyramid of the layer
//! (2×2 box reduction) trilinearly, five times in a Quincunx pattern (Weier Fig. 3), and the
//! *transition* region computes both and blends them linearly,
//! `t = (e − r₀)/(r₁ − r₀)`: `layer = (1 − t)·gauss + t·mip`. Defaults `r₀ = 10°`,
//! `r₁ = 20°` are the central/transition radii of Weier Sec. 4.1.
//!
//! * Gaussian: `σ = sigma_per_radius · r` with `r = |coc_px|/2` (default `sigma_per_radius =
//!   ½`, which gives the Gaussian the second moment of the thin-lens disc of radius `r`),
//!   truncated at `3σ`, per-pixel σ in both passes (kernels precomputed in 1/8-px steps of σ),
//!   renormalised at the image border.
//! * Mip: the level is chosen so that the sample's footprint has the same σ: a level-`L`
//!   texel of side `b = 2^L` (box, variance `b²/12`), bilinear reconstruction (tent, `b²/6`)
//!   and the Quincunx taps (centre ½, four corners ⅛ at `(±b/2, ±b/2)`, `b²/8`) add up to
//!   `σ² ≈ 0.375·b²`, so `b = σ / 0.612`, `L = log₂ b`, fractional `L` blended trilinearly.
//!
//! **Combine.** Far: the far layer is blurred with the pixel's own CoC and normalised by its
//! coverage (only far pixels take the far result; mid pixels keep their sharp colour, so far
//! blur never leaks over them). This gives the background image `B`. Near: the near layer
//! (premultiplied colour + coverage α) is blurred with the *dilated* near CoC (the largest
//! near radius within `3σ`, Bukowski's near-field "spread"), so its blur reaches past the
//! object's silhouette onto what lies behind, and composited over `B`:
//! `out = N + (1 − α)·B`. Where a near pixel is only partly covered after the blur (its
//! silhouette), `B` there is unknown (hidden); it is filled with the same blur of `B`
//! restricted to non-near pixels (premultiplied by `1 − a_near`, normalised).
//!
//! **Choices where the paper is vague.** Weier gives no formula for the coverage: we use a
//! binary layer membership and let the blur produce the soft alpha (Bukowski's CoC-scaled
//! coverage would mostly matter for near pixels barely outside the DOF, where the blur is
//! ≤ 1 px anyway). Weier blurs the foveal near field "using the mipmap or a simple box blur";
//! we use the same Gaussian as for the far field (one code path, Gaussian quality for both).
//! The paper reuses the mip pyramid from its pull-push reconstruction; we build one per layer
//! from the full-resolution frame. The far layer's separable passes use each pixel's own CoC
//! (constant CoC regions are exact; near layer boundaries the separable approximation is
//! not, which Weier and Bukowski accept as "blurring inconsistencies within each layer").
//! The eccentricity uses `px_per_degree` as constant over the screen.

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use super::disc::{check_max_radius, sanitized_color};
use super::{sanitize_coc, DofFilter, DofInput};
use crate::mip::MipPyramid;
use crate::Rgb;

/// Weier et al.'s layered near/mid/far filter: Gaussian in the fovea, mip blur outside.
#[derive(Clone, Debug, PartialEq)]
pub struct Layered {
    /// Radius of the central (foveal) region around the gaze, degrees (default 10, Weier's
    /// `r₀`).
    pub fovea_radius_deg: f32,
    /// Outer radius of the transition region, degrees; beyond it the periphery (default 20,
    /// Weier's `r₁`). Must be ≥ `fovea_radius_deg`.
    pub transition_end_deg: f32,
    /// Gaussian σ per pixel of CoC radius (default 0.5: the disc's second moment).
    pub sigma_per_radius: f32,
    /// Largest blur radius, pixels; CoCs are clamped to twice this diameter (default 32).
    pub max_radius_px: f32,
    /// CoC diameters below this many pixels are the focused mid field (default 1 px).
    pub in_focus_coc_px: f32,
}

impl Default for Layered {
    fn default() -> Self {
        Self {
            fovea_radius_deg: 10.0,
            transition_end_deg: 20.0,
            sigma_per_radius: 0.5,
            max_radius_px: 32.0,
            in_focus_coc_px: 1.0,
        }
    }
}

/// σ table resolution, steps per pixel.
const SIGMA_STEPS_PER_PX: f32 = 8.0;

impl Layered {
    fn check(&self) -> Result<()> {
        check_max_radius(self.max_radius_px, 0.0)?;
        if !(self.fovea_radius_deg.is_finite() && self.fovea_radius_deg >= 0.0) {
            return Err(FoveaError::invalid(
                "fovea_radius_deg",
                self.fovea_radius_deg,
                "a finite angle ≥ 0°",
            ));
        }
        if !(self.transition_end_deg.is_finite()
            && self.transition_end_deg >= self.fovea_radius_deg)
        {
            return Err(FoveaError::invalid(
                "transition_end_deg",
                self.transition_end_deg,
                format!(
                    "a finite angle ≥ fovea_radius_deg = {}",
                    self.fovea_radius_deg
                ),
            ));
        }
        if !(self.sigma_per_radius.is_finite() && (0.0..=2.0).contains(&self.sigma_per_radius)) {
            return Err(FoveaError::invalid(
                "sigma_per_radius",
                self.sigma_per_radius,
                "a number in [0, 2]",
            ));
        }
        if !(self.in_focus_coc_px.is_finite() && self.in_focus_coc_px >= 0.0) {
            return Err(FoveaError::invalid(
                "in_focus_coc_px",
                self.in_focus_coc_px,
                "a finite number ≥ 0 px",
            ));
        }
        Ok(())
    }

    /// Periphery weight `t ∈ [0, 1]` at a pixel: 0 in the fovea, 1 in the periphery.
    fn periphery_weight(&self, x: usize, y: usize, input: &DofInput) -> f32 {
        let dx = x as f32 + 0.5 - input.gaze_px[0];
        let dy = y as f32 + 0.5 - input.gaze_px[1];
        let e = dx.hypot(dy) / input.px_per_degree;
        let (r0, r1) = (self.fovea_radius_deg, self.transition_end_deg);
        if e < r0 {
            0.0
        } else if e >= r1 {
            1.0
        } else {
            (e - r0) / (r1 - r0)
        }
    }
}

impl DofFilter for Layered {
    fn name(&self) -> &'static str {
        "layered"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        self.check()?;
        let (wu, hu) = input.size();
        let (w, h) = (wu as usize, hu as usize);
        let thr = self.in_focus_coc_px.max(f32::MIN_POSITIVE);
        // Signed radius per pixel, 0 in the mid field.
        let radius: Vec<f32> = input
            .coc_px
            .data()
            .iter()
            .map(|&c| {
                let c = sanitize_coc(c);
                if c.abs() < thr {
                    0.0
                } else {
                    (0.5 * c.abs()).min(self.max_radius_px).copysign(c)
                }
            })
            .collect();
        if radius.iter().all(|&r| r == 0.0) {
            return Ok(input.color.clone());
        }
        let color = sanitized_color(input.color);
        let spr = self.sigma_per_radius;
        let t: Vec<f32> = (0..w * h)
            .map(|i| self.periphery_weight(i % w, i / w, input))
            .collect();
        let table = GaussTable::new(spr * self.max_radius_px);

        // ---- Far field: premultiplied RGBA, blurred with each pixel's own CoC. ----
        let far: Vec<[f32; 4]> = (0..w * h)
            .map(|i| {
                let a = if radius[i] > 0.0 { 1.0 } else { 0.0 };
                let c = color[i];
                [c[0] * a, c[1] * a, c[2] * a, a]
            })
            .collect();
        let sigma_far: Vec<f32> = radius
            .iter()
            .map(|&r| if r > 0.0 { spr * r } else { 0.0 })
            .collect();
        let far_blur = blur_layer(w, h, &far, &sigma_far, &t, &table);
        // Background image B: far pixels take the normalised far blur, others stay sharp.
        let background: Vec<Rgb> = (0..w * h)
            .map(|i| {
                let f = far_blur[i];
                if radius[i] > 0.0 && f[3] > 1e-6 {
                    [f[0] / f[3], f[1] / f[3], f[2] / f[3]]
                } else {
                    color[i]
                }
            })
            .collect();

        // ---- Near field: premultiplied colour + coverage, plus the hole-fill of B. ----
        let near_r: Vec<f32> = radius.iter().map(|&r| (-r).max(0.0)).collect();
        let max_near = near_r.iter().fold(0.0f32, |a, &b| a.max(b));
        if max_near == 0.0 {
            return Image::from_vec(wu, hu, background);
        }
        let reach = (3.0 * spr * max_near).ceil() as usize;
        let sigma_near: Vec<f32> = max_filter(w, h, &near_r, reach)
            .into_iter()
            .map(|r| spr * r)
            .collect();
        let near: Vec<[f32; 7]> = (0..w * h)
            .map(|i| {
                let a = if near_r[i] > 0.0 { 1.0 } else { 0.0 };
                let (c, b) = (color[i], background[i]);
                [
                    c[0] * a,
                    c[1] * a,
                    c[2] * a,
                    a,
                    b[0] * (1.0 - a),
                    b[1] * (1.0 - a),
                    b[2] * (1.0 - a),
                ]
            })
            .collect();
        let near_blur = blur_layer(w, h, &near, &sigma_near, &t, &table);

        // ---- Combine: out = N + (1 − α)·B. ----
        let out: Vec<Rgb> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let n = near_blur[i];
                let alpha = n[3].clamp(0.0, 1.0);
                if alpha <= 0.0 {
                    return background[i];
                }
                let behind = if near_r[i] == 0.0 {
                    background[i]
                } else if 1.0 - n[3] > 1e-4 {
                    // Hole fill: B blurred over the non-near pixels around.
                    let k = 1.0 / (1.0 - n[3]);
                    [n[4] * k, n[5] * k, n[6] * k]
                } else if n[3] > 1e-6 {
                    [n[0] / n[3], n[1] / n[3], n[2] / n[3]]
                } else {
                    color[i]
                };
                std::array::from_fn(|c| n[c] + (1.0 - alpha) * behind[c])
            })
            .collect();
        Image::from_vec(wu, hu, out)
    }
}

/// Blurs a premultiplied layer with per-pixel `sigma_px`: separable Gaussian where the
/// periphery weight `t < 1`, Quincunx-sampled trilinear mip where `t > 0`, blended by `t`.
fn blur_layer<const C: usize>(
    w: usize,
    h: usize,
    layer: &[[f32; C]],
    sigma_px: &[f32],
    t: &[f32],
    table: &GaussTable,
) -> Vec<[f32; C]> {
    let any_fovea = t.iter().any(|&v| v < 1.0);
    let any_periphery = t.iter().any(|&v| v > 0.0);
    // Gaussian, horizontal pass wherever a vertical pass (at t < 1) may read it.
    let gauss = if any_fovea {
        let max_half = sigma_px
            .iter()
            .fold(0usize, |a, &s| a.max(table.half_width(s)));
        // Rows/columns each vertical pass can reach: mark columns' needed row ranges.
        let mut need_h = vec![false; w * h];
        for x in 0..w {
            let mut last_fovea: Option<usize> = None;
            // Forward sweep: rows within max_half after a foveal row.
            for y in 0..h {
                if t[y * w + x] < 1.0 {
                    last_fovea = Some(y);
                }
                if last_fovea.is_some_and(|f| y - f <= max_half) {
                    need_h[y * w + x] = true;
                }
            }
            let mut next_fovea: Option<usize> = None;
            for y in (0..h).rev() {
                if t[y * w + x] < 1.0 {
                    next_fovea = Some(y);
                }
                if next_fovea.is_some_and(|f| f - y <= max_half) {
                    need_h[y * w + x] = true;
                }
            }
        }
        let mut hor = vec![[0.0f32; C]; w * h];
        hor.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if !need_h[i] {
                    continue;
                }
                let k = table.kernel(sigma_px[i]);
                let half = (k.len() / 2) as isize;
                if half == 0 {
                    *o = layer[i];
                    continue;
                }
                let mut acc = [0.0f32; C];
                let mut ws = 0.0f32;
                for (j, &g) in k.iter().enumerate() {
                    let qx = x as isize + j as isize - half;
                    if qx < 0 || qx >= w as isize {
                        continue;
                    }
                    let q = &layer[y * w + qx as usize];
                    for c in 0..C {
                        acc[c] += g * q[c];
                    }
                    ws += g;
                }
                *o = acc.map(|v| v / ws);
            }
        });
        let mut ver = vec![[0.0f32; C]; w * h];
        ver.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if t[i] >= 1.0 {
                    continue;
                }
                let k = table.kernel(sigma_px[i]);
                let half = (k.len() / 2) as isize;
                if half == 0 {
                    *o = hor[i];
                    continue;
                }
                let mut acc = [0.0f32; C];
                let mut ws = 0.0f32;
                for (j, &g) in k.iter().enumerate() {
                    let qy = y as isize + j as isize - half;
                    if qy < 0 || qy >= h as isize {
                        continue;
                    }
                    let q = &hor[qy as usize * w + x];
                    for c in 0..C {
                        acc[c] += g * q[c];
                    }
                    ws += g;
                }
                *o = acc.map(|v| v / ws);
            }
        });
        ver
    } else {
        Vec::new()
    };
    if !any_periphery {
        return gauss;
    }
    let max_sigma = sigma_px.iter().fold(0.0f32, |a, &s| a.max(s));
    let pyr = MipPyramid::for_sigma(w, h, layer, max_sigma);
    let mut out = vec![[0.0f32; C]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let ti = t[i];
            if ti <= 0.0 {
                *o = gauss[i];
                continue;
            }
            let m = if sigma_px[i] <= 0.0 {
                layer[i]
            } else {
                pyr.quincunx(x as f32 + 0.5, y as f32 + 0.5, sigma_px[i])
            };
            *o = if ti >= 1.0 {
                m
            } else {
                std::array::from_fn(|c| gauss[i][c] + (m[c] - gauss[i][c]) * ti)
            };
        }
    });
    out
}

/// Truncated (±3σ) Gaussian kernels for σ in 1/8-px steps, unnormalised (`exp(−x²/2σ²)`).
struct GaussTable {
    kernels: Vec<Vec<f32>>,
}

impl GaussTable {
    fn new(max_sigma_px: f32) -> Self {
        let n = (max_sigma_px.max(0.0) * SIGMA_STEPS_PER_PX).ceil() as usize + 1;
        let kernels = (0..n)
            .map(|k| {
                let s = k as f32 / SIGMA_STEPS_PER_PX;
                let half = (3.0 * s).ceil() as i32;
                if half == 0 {
                    return vec![1.0];
                }
                (-half..=half)
                    .map(|x| (-(x * x) as f32 / (2.0 * s * s)).exp())
                    .collect()
            })
            .collect();
        Self { kernels }
    }

    #[inline]
    fn kernel(&self, sigma_px: f32) -> &[f32] {
        let k =
            ((sigma_px * SIGMA_STEPS_PER_PX).round().max(0.0) as usize).min(self.kernels.len() - 1);
        &self.kernels[k]
    }

    fn half_width(&self, sigma_px: f32) -> usize {
        self.kernel(sigma_px).len() / 2
    }
}

/// Square max filter of half-width `reach` (separable).
fn max_filter(w: usize, h: usize, v: &[f32], reach: usize) -> Vec<f32> {
    if reach == 0 {
        return v.to_vec();
    }
    let mut hor = vec![0.0f32; w * h];
    hor.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let src = &v[y * w..(y + 1) * w];
        for (x, o) in row.iter_mut().enumerate() {
            let lo = x.saturating_sub(reach);
            let hi = (x + reach).min(w - 1);
            *o = src[lo..=hi].iter().fold(0.0f32, |a, &b| a.max(b));
        }
    });
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let lo = y.saturating_sub(reach);
        let hi = (y + reach).min(h - 1);
        for (x, o) in row.iter_mut().enumerate() {
            *o = (lo..=hi).fold(0.0f32, |a, yy| a.max(hor[yy * w + x]));
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;
    use crate::luma;

    /// Everything within the fovea.
    fn foveal(f: &mut Frame) {
        f.ppd = 1000.0;
    }

    /// Everything in the periphery (gaze far off-screen).
    fn peripheral(f: &mut Frame) {
        f.ppd = 1.0;
        f.gaze = [-1000.0, -1000.0];
    }

    #[test]
    fn zero_coc_is_identity() {
        let scene = plane_scene(40, 30, 1.0, checker_wave);
        let mut f = Frame::from_scene(&scene, 10.0, 1.0);
        f.coc = f.coc.map(|_| 0.0);
        assert_eq!(Layered::default().apply(&f.input()).unwrap(), f.color);
        let k = crate::dof::FilterKind::Layered;
        assert_eq!(k.build().name(), k.name());
        peripheral(&mut f);
        f.coc = f.coc.map(|_| 0.5);
        assert_eq!(Layered::default().apply(&f.input()).unwrap(), f.color);
    }

    #[test]
    fn constant_plane_matches_thin_lens() {
        for (focus, k) in [(0.5f32, 10.0f32), (4.0, 10.0)] {
            let scene = plane_scene(64, 48, 1.0, checker_wave);
            let gt = scene.thin_lens(k, focus, 400).unwrap();
            let c = thin_lens_coc(k, focus, 1.0);
            let margin = (0.75 * c.abs()).ceil() as u32 + 1;
            for (region, set, tol) in [
                ("fovea", foveal as fn(&mut Frame), 27.0),
                ("periphery", peripheral, 22.0),
            ] {
                let mut f = Frame::from_scene(&scene, k, focus);
                set(&mut f);
                let out = Layered::default().apply(&f.input()).unwrap();
                let psnr = luma_psnr(&out, &gt, margin);
                eprintln!("layered {region} focus {focus} coc {c}: luma PSNR {psnr:.2} dB");
                assert!(psnr > tol, "{region} focus {focus}: {psnr}");
            }
        }
    }

    #[test]
    fn two_textured_planes_match_thin_lens_roughly() {
        for focus in [0.5f32, 2.0] {
            let scene = two_textured_planes();
            let gt = scene.thin_lens(8.0, focus, 400).unwrap();
            for (region, set) in [
                ("fovea", foveal as fn(&mut Frame)),
                ("periphery", peripheral),
            ] {
                let mut f = Frame::from_scene(&scene, 8.0, focus);
                set(&mut f);
                let out = Layered::default().apply(&f.input()).unwrap();
                let psnr = luma_psnr(&out, &gt, 8);
                eprintln!(
                    "layered two textured planes {region} focus {focus}: luma PSNR {psnr:.2} dB"
                );
                assert!(psnr > 22.0, "{region} {focus}: {psnr}");
            }
        }
    }

    #[test]
    fn transition_band_blends_without_seams() {
        // Gaze at the left edge, 3 px/deg: fovea x < 30, transition 30–60, periphery beyond.
        let scene = plane_scene(96, 24, 1.0, checker_wave);
        let gt = scene.thin_lens(10.0, 0.5, 400).unwrap();
        let mut f = Frame::from_scene(&scene, 10.0, 0.5);
        f.ppd = 3.0;
        f.gaze = [0.0, 12.0];
        let out = Layered::default().apply(&f.input()).unwrap();
        let psnr = luma_psnr(&out, &gt, 8);
        eprintln!("layered across fovea/transition/periphery: luma PSNR {psnr:.2} dB");
        assert!(psnr > 22.0, "{psnr}");
    }

    #[test]
    fn sharp_foreground_edge_does_not_leak_into_blurred_background() {
        let scene = edge_scene(64, 16, 30.0, 0.5, 4.0, [1.0; 3], [0.0; 3]);
        for set in [foveal as fn(&mut Frame), peripheral] {
            let mut f = Frame::from_scene(&scene, 10.0, 0.5);
            set(&mut f);
            let out = Layered::default().apply(&f.input()).unwrap();
            let wo = row_edge_width(&out, 8);
            eprintln!(
                "layered sharp fg edge (ppd {}): 10-90 rise {wo:.2} px",
                f.ppd
            );
            assert!(wo < 1.0, "{wo}");
            // Far blur does not leak over the in-focus mid field either.
            for x in 0..30 {
                assert_eq!(*out.get(x, 8), [1.0; 3]);
            }
        }
    }

    #[test]
    fn far_field_does_not_leak_over_mid() {
        // Dark in-focus foreground (mid) next to a bright blurred background.
        let scene = edge_scene(64, 16, 30.0, 0.5, 4.0, [0.0; 3], [1.0; 3]);
        let f = Frame::from_scene(&scene, 10.0, 0.5);
        let out = Layered::default().apply(&f.input()).unwrap();
        for x in 0..30 {
            assert_eq!(*out.get(x, 8), [0.0; 3]);
        }
        assert_eq!(*out.get(30, 8), [1.0; 3]);
    }

    #[test]
    fn blurred_foreground_over_sharp_background_is_soft() {
        let k = 20.0 / 3.0;
        let scene = edge_scene(64, 16, 32.0, 0.25, 1.0, [1.0; 3], [0.0; 3]);
        let gt = scene.thin_lens(k, 1.0, 256).unwrap();
        for set in [foveal as fn(&mut Frame), peripheral] {
            let mut f = Frame::from_scene(&scene, k, 1.0);
            set(&mut f);
            let out = Layered::default().apply(&f.input()).unwrap();
            let (wo, wg) = (row_edge_width(&out, 8), row_edge_width(&gt, 8));
            eprintln!(
                "layered blurred fg edge (ppd {}): 10-90 rise {wo:.2} px (thin lens {wg:.2} px), \
                 luma at edge {:.2}/{:.2} (thin lens {:.2}/{:.2})",
                f.ppd,
                luma(*out.get(31, 8)),
                luma(*out.get(32, 8)),
                luma(*gt.get(31, 8)),
                luma(*gt.get(32, 8))
            );
            assert!(wo > 6.0 && wo < 2.0 * wg, "{wo} vs {wg}");
            // Soft on both sides of the silhouette.
            assert!(luma(*out.get(31, 8)) < 0.8 && luma(*out.get(32, 8)) > 0.2);
            let psnr = luma_psnr(&out, &gt, 2);
            eprintln!("layered near-over-sharp scene: luma PSNR {psnr:.2} dB");
            assert!(psnr > 22.0, "{psnr}");
        }
    }

    #[test]
    fn nan_inputs_give_finite_output() {
        let mut f = nan_frame();
        assert!(all_finite(&Layered::default().apply(&f.input()).unwrap()));
        peripheral(&mut f);
        f.color.data_mut()[40] = [f32::NAN, f32::INFINITY, 0.0];
        assert!(all_finite(&Layered::default().apply(&f.input()).unwrap()));
        let bad = Layered {
            transition_end_deg: 5.0,
            ..Default::default()
        };
        assert!(bad.apply(&f.input()).is_err());
    }
}
