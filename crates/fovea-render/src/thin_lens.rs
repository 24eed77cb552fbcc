//! The reference depth of field: distributed ray tracing through a thin-lens eye
//! (Konrad Sec. III-A; Cook et al. 1984), rendered by the same tracer and shader as every
//! other frame.
//!
//! The eye is a thin lens of aperture `τ` (the pupil) at the pinhole camera's position,
//! focused at view depth `F`. For screen point `p`, the pinhole ray meets the focus plane
//! (`view depth = F`) at `P_F = o + d·F/(d·forward)`; a lens sample `u` in the unit disc
//! moves the ray origin to `o + (τ/2)(u_x·right + u_y·up)` and aims it at `P_F`. A point at
//! depth `D` is then spread over a disc of visual angle `τ·|1/F − 1/D|` radians — the CoC of
//! [`fovea_post::dof::coc`]'s thin-lens model, so filters and reference agree on the blur.
//! Focus at infinity aims every lens sample along the pinhole direction.
//!
//! **Pixel sampling.** With one pixel sample, every lens sample goes through the pixel centre
//! (as Konrad's 55 re-projected renders do), so in-focus surfaces match the pinhole image
//! exactly. That also makes the pinhole image aliased where the reference is not: defocus
//! averages each out-of-focus edge over the aperture, so a 1-pixel CoC already looks
//! anti-aliased, and no filter can recover that from an aliased input. With more than one
//! pixel sample both renders integrate over the pixel's area instead: the pinhole frame traces that many
//! rays at R2 low-discrepancy offsets in the pixel (Roberts 2018), and the `s`-th lens sample
//! of the reference goes through the `s`-th offset of the same sequence (which is
//! decorrelated from the stratified lens grid), so in focus both converge to the same
//! box-filtered pixel and the comparison isolates the blur. Lens samples are stratified over the disc (concentric map,
//! [`fovea_post::dof::planes::disc_samples`]); Konrad used 55, we default to 128 and accept
//! up to 4096. The even and odd samples are also accumulated apart: the luma PSNR between the
//! two half-estimates, plus 6.02 dB, estimates the reference's own noise floor
//! ([`WindowRender::noise_floor_psnr_db`]), so one can tell whether it has converged.
//!
//! Rendering works on a screen window (a crop of the display at full resolution), because
//! the reference costs `lens_samples` full frames.

use rayon::prelude::*;

use fovea_core::Image;
use fovea_post::dof::planes::disc_samples;
use fovea_post::Rgb;

use crate::bvh::Ray;
use crate::camera::EyeCamera;
use crate::error::{RenderError, Result};
use crate::shade::{shade, RayCounts, ShadingMode};
use crate::trace::trace_sample;
use crate::world::World;

/// Most lens samples per pixel.
pub const MAX_LENS_SAMPLES: u32 = 4096;

/// A rectangle of screen pixels `[x0, x0 + width) × [y0, y0 + height)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Window {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

impl Window {
    /// The whole `w × h` screen.
    pub fn full(w: u32, h: u32) -> Self {
        Self {
            x0: 0,
            y0: 0,
            width: w,
            height: h,
        }
    }

    /// A `w × h` window centred on `(cx, cy)`, shifted to lie inside a `sw × sh` screen and
    /// shrunk if the screen is smaller.
    pub fn centred(cx: f64, cy: f64, w: u32, h: u32, sw: u32, sh: u32) -> Self {
        let (w, h) = (w.min(sw).max(1), h.min(sh).max(1));
        let x0 = (cx - w as f64 / 2.0).round().clamp(0.0, (sw - w) as f64) as u32;
        let y0 = (cy - h as f64 / 2.0).round().clamp(0.0, (sh - h) as f64) as u32;
        Self {
            x0,
            y0,
            width: w,
            height: h,
        }
    }

    /// Pixels in the window.
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }
}

/// The thin-lens eye of the reference.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ThinLens {
    /// Pupil (aperture) diameter, metres (0 gives the pinhole image).
    pub pupil_m: f64,
    /// Focus distance along the view axis, metres (`+∞` allowed).
    pub focus_m: f64,
    /// Lens samples per pixel, 1 to [`MAX_LENS_SAMPLES`].
    pub lens_samples: u32,
}

impl ThinLens {
    /// Checks the ranges: pupil in [0, 12 mm], focus > 0 (or +∞), samples 1–4096.
    pub fn validate(&self) -> Result<()> {
        if !(self.pupil_m.is_finite() && (0.0..=0.012).contains(&self.pupil_m)) {
            return Err(RenderError::invalid(
                "pupil",
                format!("{} mm", self.pupil_m * 1e3),
                "0 to 12 mm",
            ));
        }
        if self.focus_m.is_nan() || self.focus_m <= 0.0 {
            return Err(RenderError::invalid(
                "focus",
                format!("{} m", self.focus_m),
                "a distance > 0 m, or infinity",
            ));
        }
        if !(1..=MAX_LENS_SAMPLES).contains(&self.lens_samples) {
            return Err(RenderError::invalid(
                "lens-samples",
                self.lens_samples,
                format!("1 to {MAX_LENS_SAMPLES}"),
            ));
        }
        Ok(())
    }
}

/// A rendered window.
#[derive(Clone, Debug)]
pub struct WindowRender {
    /// Linear RGB.
    pub color: Image<Rgb>,
    /// View depth of the pinhole ray through each pixel centre, metres (`∞` on a miss).
    pub depth: Image<f32>,
    /// Half-estimates from the even and the odd lens samples (thin lens with ≥ 2 samples).
    pub halves: Option<(Image<Rgb>, Image<Rgb>)>,
    /// Rays cast (primary + shadow + environment + bounce).
    pub rays: u64,
    /// Wall time, milliseconds.
    pub ms: f64,
}

impl WindowRender {
    /// Luma PSNR of the full estimate against the truth, estimated from the two halves: the
    /// halves' difference has twice the variance of one half, which has twice the variance of
    /// the whole, so `PSNR(whole) ≈ PSNR(half, half) + 10·log10(4)`. Computed on linear luma
    /// clamped to [0, 1]. `None` without halves; `∞` when the halves agree exactly.
    pub fn noise_floor_psnr_db(&self) -> Option<f64> {
        let (a, b) = self.halves.as_ref()?;
        let mse = a
            .data()
            .iter()
            .zip(b.data())
            .map(|(x, y)| {
                let d = fovea_post::luma(*x).clamp(0.0, 1.0) as f64
                    - fovea_post::luma(*y).clamp(0.0, 1.0) as f64;
                d * d
            })
            .sum::<f64>()
            / a.data().len().max(1) as f64;
        Some(if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (1.0 / mse).log10() + 10.0 * 4f64.log10()
        })
    }
}

/// Most pixel samples of a pinhole window.
pub const MAX_PIXEL_SAMPLES: u32 = 1024;

/// The `s`-th point of the R2 sequence in the unit square (Roberts 2018), starting at the
/// centre.
#[inline]
fn r2(s: usize) -> [f32; 2] {
    const A1: f64 = 0.754_877_666_246_692_8;
    const A2: f64 = 0.569_840_290_998_053_3;
    let s = s as f64;
    [(0.5 + A1 * s).fract() as f32, (0.5 + A2 * s).fract() as f32]
}

/// Renders `window` of `camera`'s display: the pinhole image (`lens = None`) or the thin-lens
/// reference, with `pixel_samples` (1 to [`MAX_PIXEL_SAMPLES`]) rays per pixel for the pinhole
/// image and pixel-area sampling of the lens samples when it is above 1 (see the module
/// header). `progress(done_rows, total_rows)` is called as rows finish.
pub fn render_window(
    world: &World,
    camera: &EyeCamera,
    window: Window,
    lens: Option<&ThinLens>,
    pixel_samples: u32,
    shading: ShadingMode,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<WindowRender> {
    let t0 = std::time::Instant::now();
    let d = &camera.display;
    if window.width == 0
        || window.height == 0
        || window.x0 as u64 + window.width as u64 > d.width_px as u64
        || window.y0 as u64 + window.height as u64 > d.height_px as u64
    {
        return Err(RenderError::invalid(
            "window",
            format!(
                "{}x{}+{}+{}",
                window.width, window.height, window.x0, window.y0
            ),
            format!(
                "a non-empty rectangle inside {}x{}",
                d.width_px, d.height_px
            ),
        ));
    }
    if let Some(l) = lens {
        l.validate()?;
    }
    if !(1..=MAX_PIXEL_SAMPLES).contains(&pixel_samples) {
        return Err(RenderError::invalid(
            "pixel-samples",
            pixel_samples,
            format!("1 to {MAX_PIXEL_SAMPLES}"),
        ));
    }
    let aa = pixel_samples > 1;
    // Footprint of one screen pixel, as at full resolution.
    let spread = (1.0 / d.focal_y_px()) as f32;
    let lens_pts: Vec<[f32; 2]> = match lens {
        Some(l) if l.pupil_m > 0.0 => disc_samples(l.lens_samples),
        Some(l) if aa => vec![[0.0, 0.0]; l.lens_samples as usize],
        None if aa => vec![[0.0, 0.0]; pixel_samples as usize],
        _ => vec![[0.0, 0.0]],
    };
    let radius_m = lens.map_or(0.0, |l| l.pupil_m as f32 / 2.0);
    let focus_m = lens.map_or(f32::INFINITY, |l| l.focus_m as f32);
    let split = lens_pts.len() >= 2;
    let (w, h) = (window.width as usize, window.height as usize);
    let color = Image::new(window.width, window.height, [0.0f32; 3])?;
    let mut color = color.into_vec();
    let mut depth = vec![f32::INFINITY; w * h];
    let mut half_a = if split {
        vec![[0.0f32; 3]; w * h]
    } else {
        Vec::new()
    };
    let mut half_b = if split {
        vec![[0.0f32; 3]; w * h]
    } else {
        Vec::new()
    };
    let done = std::sync::atomic::AtomicU64::new(0);
    let rays = std::sync::atomic::AtomicU64::new(0);
    let n_even = lens_pts.len().div_ceil(2) as f32;
    let n_odd = (lens_pts.len() / 2).max(1) as f32;
    let rows: Vec<_> = color
        .chunks_mut(w)
        .zip(depth.chunks_mut(w))
        .enumerate()
        .collect();
    let mut halves_rows: Vec<(&mut [Rgb], &mut [Rgb])> = if split {
        half_a.chunks_mut(w).zip(half_b.chunks_mut(w)).collect()
    } else {
        Vec::new()
    };
    let mut work: Vec<_> = rows.into_iter().map(|r| (r, None)).collect();
    for (k, hr) in halves_rows.drain(..).enumerate() {
        work[k].1 = Some(hr);
    }
    work.into_par_iter()
        .for_each(|((j, (crow, drow)), mut hrow)| {
            let y = (window.y0 as usize + j) as f32 + 0.5;
            let mut counts = RayCounts::default();
            let mut primary = 0u64;
            for i in 0..w {
                let x = (window.x0 as usize + i) as f32 + 0.5;
                let dir = camera.direction(x, y);
                // Pinhole depth of the pixel centre.
                let g0 = trace_sample(
                    world,
                    &Ray {
                        origin: camera.position,
                        dir,
                        t_min: 0.0,
                        t_max: f32::INFINITY,
                    },
                    spread,
                );
                primary += 1;
                drow[i] = camera.view_depth(dir, g0.t);
                let key = crate::shade::texel_key(0, window.x0 + i as u32, window.y0 + j as u32);
                let mut acc = [[0.0f32; 3]; 2];
                for (s, u) in lens_pts.iter().enumerate() {
                    let c = if u[0] == 0.0 && u[1] == 0.0 && !aa {
                        shade(world, &g0, shading, key, &mut counts)
                    } else {
                        // The pinhole direction through this sample's point of the pixel.
                        let dir = if aa {
                            let o = r2(s);
                            camera.direction(x - 0.5 + o[0], y - 0.5 + o[1])
                        } else {
                            dir
                        };
                        let origin =
                            camera.position + radius_m * (u[0] * camera.right + u[1] * camera.up);
                        let target = if focus_m.is_finite() {
                            camera.position + dir * (focus_m / dir.dot(camera.forward))
                        } else {
                            origin + dir
                        };
                        let ray = Ray {
                            origin,
                            dir: (target - origin).normalize(),
                            t_min: 0.0,
                            t_max: f32::INFINITY,
                        };
                        let g = trace_sample(world, &ray, spread);
                        primary += 1;
                        shade(
                            world,
                            &g,
                            shading,
                            // Each lens sample shades as its own frame: the frames' rotations
                            // stratify the samples' random numbers (`frame_noise`).
                            crate::shade::frame_noise::with_frame(
                                key,
                                crate::shade::FrameNoise::new(s as u64 + 1, 0),
                            ),
                            &mut counts,
                        )
                    };
                    let a = &mut acc[s % 2];
                    a[0] += c.x;
                    a[1] += c.y;
                    a[2] += c.z;
                }
                let n = lens_pts.len() as f32;
                crow[i] = [0, 1, 2].map(|ch| (acc[0][ch] + acc[1][ch]) / n);
                if let Some((ha, hb)) = hrow.as_mut() {
                    ha[i] = acc[0].map(|v| v / n_even);
                    hb[i] = acc[1].map(|v| v / n_odd);
                }
            }
            rays.fetch_add(
                primary + counts.total(),
                std::sync::atomic::Ordering::Relaxed,
            );
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(d, h as u64);
        });
    let halves = if split {
        Some((
            Image::from_vec(window.width, window.height, half_a)?,
            Image::from_vec(window.width, window.height, half_b)?,
        ))
    } else {
        None
    };
    Ok(WindowRender {
        color: Image::from_vec(window.width, window.height, color)?,
        depth: Image::from_vec(window.width, window.height, depth)?,
        halves,
        rays: rays.into_inner(),
        ms: t0.elapsed().as_secs_f64() * 1e3,
    })
}
