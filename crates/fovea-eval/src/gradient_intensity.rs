//! Gradient-intensity analysis of an inset boundary (Liu, Fan, Yan & Yan, "Inset Boundary
//! Smoothing for Foveated Rendering in Virtual Reality", Sec. 4).
//!
//! Taken from the paper: grey conversion (OpenCV `BGR2GRAY`, i.e. Rec.601 weights
//! `0.299 R + 0.587 G + 0.114 B` on the display-encoded image), a 3×3 Sobel filter in x and in
//! y, the result multiplied by 100, mean gradient intensity per area in x and y separately,
//! the high/low-resolution ratio (inset mean over periphery mean; the paper reports 1.78/1.74
//! for its resampled frame and 1.34/1.24 for the original), and four areas across the boundary:
//! Area1 and Area2 inside the inset, Area3 and Area4 outside, Area2/Area3 adjacent to the
//! boundary and Area1/Area4 away from it (Fig. 7), with the Area2 → Area3 slope as the measure
//! of boundary sharpness (Sec. 4, Fig. 8).
//!
//! Chosen here (Fig. 7 gives no sizes): Area2 is the ring of inset pixels at distance
//! `d < band_px` from the boundary and Area3 the ring of periphery pixels at `d < band_px`
//! (distances as in [`fovea_post::inset_smoothing::boundary_distance`]: whole pixels, 0 next to
//! the boundary, Chebyshev outside); Area1 and Area4 are the rest of the inset and of the
//! periphery. The default `band_px = 8` equals the paper's strip half-widths (alpha strip S = 8,
//! Gaussian strip 16 = 8 + 8), so Area1/Area4 are the pixels the smoothing does not write (their
//! first row still reads one strip pixel through the Sobel footprint). Inset edges on the screen
//! edge are not boundary. The image is linear RGB: it is clamped to [0, 1] and sRGB-encoded
//! before the grey conversion (unquantised), so values are on a [0, 1] scale, not OpenCV's
//! 0–255: the paper's absolute numbers are 2.55× ours, ratios are unaffected. The Sobel kernel is
//! OpenCV's unnormalised one (`[−1 0 1; −2 0 2; −1 0 1]`) with OpenCV's default border
//! (reflect-101); "gradient intensity" is `100·|G_x|` and `100·|G_y|`, and the magnitude
//! `100·√(G_x² + G_y²)` is reported as well.

use fovea_core::{FoveaError, Image, Result};
use fovea_post::inset_smoothing::{boundary_distance, Rect};
use fovea_post::tonemap::linear_to_srgb;
use fovea_post::Rgb;
use serde::Serialize;

/// Scale the paper applies to the Sobel output.
pub const GRADIENT_SCALE: f64 = 100.0;
/// Default width of Area2 and Area3 in pixels.
pub const DEFAULT_BAND_PX: u32 = 8;

/// Grey value of a linear RGB pixel: sRGB-encode, then Rec.601 weights.
pub fn grey(c: Rgb) -> f32 {
    0.299 * linear_to_srgb(c[0]) + 0.587 * linear_to_srgb(c[1]) + 0.114 * linear_to_srgb(c[2])
}

/// Unscaled 3×3 Sobel responses `(G_x, G_y)` of a `w × h` grey image (row-major), border
/// reflect-101. Errors if the sizes disagree or the image is empty.
pub fn sobel_xy(grey: &[f32], w: u32, h: u32) -> Result<(Vec<f32>, Vec<f32>)> {
    if w == 0 || h == 0 || grey.len() as u64 != w as u64 * h as u64 {
        return Err(FoveaError::invalid(
            "grey",
            format!("{} values for {w}×{h}", grey.len()),
            "a non-empty image with w·h values",
        ));
    }
    let (wi, hi) = (w as i64, h as i64);
    let refl = |i: i64, n: i64| -> usize {
        (if n == 1 {
            0
        } else if i < 0 {
            -i
        } else if i >= n {
            2 * n - 2 - i
        } else {
            i
        }) as usize
    };
    let at = |x: i64, y: i64| grey[refl(y, hi) * w as usize + refl(x, wi)];
    let mut gx = Vec::with_capacity(grey.len());
    let mut gy = Vec::with_capacity(grey.len());
    for y in 0..hi {
        for x in 0..wi {
            gx.push(
                (at(x + 1, y - 1) - at(x - 1, y - 1))
                    + 2.0 * (at(x + 1, y) - at(x - 1, y))
                    + (at(x + 1, y + 1) - at(x - 1, y + 1)),
            );
            gy.push(
                (at(x - 1, y + 1) - at(x - 1, y - 1))
                    + 2.0 * (at(x, y + 1) - at(x, y - 1))
                    + (at(x + 1, y + 1) - at(x + 1, y - 1)),
            );
        }
    }
    Ok((gx, gy))
}

/// Mean gradient intensity (×100) of one area.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct AreaGradient {
    /// Pixels in the area.
    pub pixels: u64,
    /// Mean `100·|G_x|` (0 for an empty area).
    pub mean_x: f64,
    /// Mean `100·|G_y|`.
    pub mean_y: f64,
    /// Mean `100·√(G_x² + G_y²)`.
    pub mean_magnitude: f64,
}

/// Gradient intensities around an inset boundary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GradientReport {
    /// Width of Area2 and Area3 in pixels.
    pub band_px: u32,
    /// Area1 (inset interior), Area2 (inset ring), Area3 (periphery ring), Area4 (periphery).
    pub areas: [AreaGradient; 4],
    /// The whole inset (high-resolution area).
    pub inset: AreaGradient,
    /// The whole periphery (low-resolution area).
    pub periphery: AreaGradient,
    /// Inset mean over periphery mean in x (the paper's high/low ratio); `None` if the
    /// periphery is empty or flat.
    pub ratio_x: Option<f64>,
    /// The same in y.
    pub ratio_y: Option<f64>,
    /// Area2 minus Area3 in x: the slope across the boundary in the paper's Fig. 8.
    pub slope_23_x: f64,
    /// The same in y.
    pub slope_23_y: f64,
}

#[derive(Default, Clone, Copy)]
struct Acc {
    n: u64,
    sx: f64,
    sy: f64,
    sm: f64,
}

impl Acc {
    fn add(&mut self, gx: f32, gy: f32) {
        let (gx, gy) = (gx as f64, gy as f64);
        self.n += 1;
        self.sx += GRADIENT_SCALE * gx.abs();
        self.sy += GRADIENT_SCALE * gy.abs();
        self.sm += GRADIENT_SCALE * (gx * gx + gy * gy).sqrt();
    }
    fn merge(self, o: Acc) -> Acc {
        Acc {
            n: self.n + o.n,
            sx: self.sx + o.sx,
            sy: self.sy + o.sy,
            sm: self.sm + o.sm,
        }
    }
    fn mean(self) -> AreaGradient {
        let d = self.n.max(1) as f64;
        AreaGradient {
            pixels: self.n,
            mean_x: self.sx / d,
            mean_y: self.sy / d,
            mean_magnitude: self.sm / d,
        }
    }
}

/// Mean gradient intensity of `img` in the four areas around the boundary of the inset
/// `boundary`, with Area2/Area3 `band_px` wide (≥ 1; the default is [`DEFAULT_BAND_PX`]).
pub fn gradient_areas(img: &Image<Rgb>, boundary: Rect, band_px: u32) -> Result<GradientReport> {
    let (w, h) = (img.width(), img.height());
    boundary.validate(w, h)?;
    if band_px == 0 {
        return Err(FoveaError::invalid("band_px", band_px, "≥ 1"));
    }
    let g: Vec<f32> = img.data().iter().map(|&c| grey(c)).collect();
    let (gx, gy) = sobel_xy(&g, w, h)?;
    let mut acc = [Acc::default(); 4];
    for y in 0..h {
        for x in 0..w {
            let bd = boundary_distance(boundary, w, h, x, y);
            let area = match (bd.inside, bd.d < band_px) {
                (true, false) => 0,
                (true, true) => 1,
                (false, true) => 2,
                (false, false) => 3,
            };
            let i = (y * w + x) as usize;
            acc[area].add(gx[i], gy[i]);
        }
    }
    let inset = acc[0].merge(acc[1]).mean();
    let periphery = acc[2].merge(acc[3]).mean();
    let areas = acc.map(Acc::mean);
    let ratio = |a: f64, b: f64| (b > 0.0).then(|| a / b);
    Ok(GradientReport {
        band_px,
        areas,
        inset,
        periphery,
        ratio_x: ratio(inset.mean_x, periphery.mean_x),
        ratio_y: ratio(inset.mean_y, periphery.mean_y),
        slope_23_x: areas[1].mean_x - areas[2].mean_x,
        slope_23_y: areas[1].mean_y - areas[2].mean_y,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_post::inset_smoothing::{composite, Smoothing};

    fn step_image(w: u32, h: u32, step_after_x: u32) -> Image<Rgb> {
        let data = (0..h)
            .flat_map(|_| (0..w).map(move |x| if x > step_after_x { [1.0; 3] } else { [0.0; 3] }))
            .collect();
        Image::from_vec(w, h, data).unwrap()
    }

    #[test]
    fn sobel_of_vertical_step() {
        // 0 0 0 1 1 1 per row: G_x = (1 − 0)·(1 + 2 + 1) = 4 at x = 2 and 3, else 0; G_y = 0.
        let img = step_image(6, 5, 2);
        let g: Vec<f32> = img.data().iter().map(|&c| grey(c)).collect();
        let (gx, gy) = sobel_xy(&g, 6, 5).unwrap();
        for y in 0..5 {
            for x in 0..6 {
                let want = if x == 2 || x == 3 { 4.0 } else { 0.0 };
                assert!((gx[y * 6 + x] - want).abs() < 1e-5, "({x},{y})");
                assert_eq!(gy[y * 6 + x], 0.0);
            }
        }
        // Grey weights sum to 1 and sRGB keeps 0 and 1.
        assert!((grey([1.0; 3]) - 1.0).abs() < 1e-6);
        assert!(sobel_xy(&g, 5, 5).is_err());
    }

    #[test]
    fn four_areas_hand_computed() {
        // 16×16, inset (4,4) 8×8, band 2; step between columns 7 and 8 → 100·|G_x| = 400 in
        // columns 7 and 8 of every row.
        let img = step_image(16, 16, 7);
        let rect = Rect {
            x0: 4,
            y0: 4,
            w: 8,
            h: 8,
        };
        let r = gradient_areas(&img, rect, 2).unwrap();
        let px: Vec<u64> = r.areas.iter().map(|a| a.pixels).collect();
        assert_eq!(px, vec![16, 48, 80, 112]);
        // Per area, 8 of its pixels lie on columns 7/8 (rows 6–9 / 4,5,10,11 / 2,3,12,13 /
        // 0,1,14,15).
        let want = [
            400.0 * 8.0 / 16.0,
            400.0 * 8.0 / 48.0,
            400.0 * 8.0 / 80.0,
            400.0 * 8.0 / 112.0,
        ];
        for (a, w) in r.areas.iter().zip(want) {
            assert!((a.mean_x - w).abs() < 1e-4, "{a:?} vs {w}");
            assert!((a.mean_magnitude - w).abs() < 1e-4);
            assert_eq!(a.mean_y, 0.0);
        }
        assert!((r.inset.mean_x - 100.0).abs() < 1e-4);
        assert!((r.ratio_x.unwrap() - 3.0).abs() < 1e-6);
        assert_eq!(r.ratio_y, None);
        assert!((r.slope_23_x - (want[1] - want[2])).abs() < 1e-4);
    }

    #[test]
    fn constant_image_has_no_gradient() {
        let img = Image::new(20, 12, [0.4f32, 0.2, 0.7]).unwrap();
        let rect = Rect {
            x0: 5,
            y0: 3,
            w: 10,
            h: 6,
        };
        let r = gradient_areas(&img, rect, 2).unwrap();
        for a in r.areas.iter().chain([&r.inset, &r.periphery]) {
            assert_eq!((a.mean_x, a.mean_y, a.mean_magnitude), (0.0, 0.0, 0.0));
        }
        assert_eq!((r.ratio_x, r.ratio_y), (None, None));
    }

    #[test]
    fn bad_inputs_are_errors() {
        let img = Image::new(8, 8, [0.0f32; 3]).unwrap();
        let ok = Rect {
            x0: 2,
            y0: 2,
            w: 4,
            h: 4,
        };
        assert!(gradient_areas(&img, ok, 0).is_err());
        assert!(gradient_areas(&img, Rect { w: 0, ..ok }, 2).is_err());
        assert!(gradient_areas(&img, Rect { x0: 6, ..ok }, 2).is_err());
        assert!(gradient_areas(&img, Rect { y0: u32::MAX, ..ok }, 2).is_err());
    }

    /// A sharp inset beside a blurred periphery (hard composite) has a steeper Area2 → Area3
    /// drop than the original frame and than the alpha-blended or Gaussian + alpha composite.
    #[test]
    fn hard_boundary_is_steeper_than_smooth_transitions() {
        let (w, h) = (128u32, 96u32);
        let rect = Rect {
            x0: 32,
            y0: 24,
            w: 64,
            h: 48,
        };
        // High-frequency texture: pseudo-random values in [0, 1].
        let frame: Vec<Rgb> = (0..w * h)
            .map(|i| {
                let v = ((i.wrapping_mul(2_654_435_761) >> 12) % 1000) as f32 / 1000.0;
                [v; 3]
            })
            .collect();
        let frame = Image::from_vec(w, h, frame).unwrap();
        // Periphery: 4×4 box average (the paper downsamples the full frame).
        let low: Vec<Rgb> = (0..h / 4)
            .flat_map(|y| (0..w / 4).map(move |x| (x, y)))
            .map(|(x, y)| {
                let mut c = [0.0f32; 3];
                for j in 0..4 {
                    for i in 0..4 {
                        let p = frame.get(4 * x + i, 4 * y + j);
                        for k in 0..3 {
                            c[k] += p[k] / 16.0;
                        }
                    }
                }
                c
            })
            .collect();
        let low = Image::from_vec(w / 4, h / 4, low).unwrap();
        let inset_data: Vec<Rgb> = (0..rect.h)
            .flat_map(|y| (0..rect.w).map(move |x| (x, y)))
            .map(|(x, y)| *frame.get(rect.x0 + x, rect.y0 + y))
            .collect();
        let inset = Image::from_vec(rect.w, rect.h, inset_data).unwrap();
        let report = |s: Smoothing| {
            let img = composite(&inset, rect, &low, w, h, s).unwrap();
            gradient_areas(&img, rect, DEFAULT_BAND_PX).unwrap()
        };
        let hard = report(Smoothing::None);
        let original = gradient_areas(&frame, rect, DEFAULT_BAND_PX).unwrap();
        let smooth = [
            report(Smoothing::ALPHA_BLEND),
            report(Smoothing::GaussianAlpha {
                kernel: fovea_post::inset_smoothing::GaussianKernel::TwoD,
            }),
        ];
        for s in [&original].into_iter().chain(smooth.iter()) {
            assert!(hard.slope_23_x > s.slope_23_x + 1.0, "{hard:?}\n{s:?}");
            assert!(hard.slope_23_y > s.slope_23_y + 1.0, "{hard:?}\n{s:?}");
        }
        // Resampling lowers the periphery's gradients: the high/low ratio rises (Sec. 4).
        assert!(hard.ratio_x.unwrap() > original.ratio_x.unwrap());
    }
}
