//! Image-difference metrics on linear RGB frames.
//!
//! Every metric here (luma PSNR, ꟻLIP) and every one built on [`encoded_luma`] (SSIM, the
//! eccentricity bands, flicker) first encodes the frames for display exactly as `fovea render`,
//! `dof-compare` and the report write their PNGs: the output tone curve [`DISPLAY_CURVE`]
//! (Reinhard `x / (1 + x)`, no exposure) and then the 8-bit sRGB transfer function. So they
//! judge what a viewer sees. Linear values are *not* clipped at 1 first: clipping made every
//! highlight above 1 (a bright window, a light) the same white, so a pair differing only
//! there scored as identical. ꟻLIP gets the same 8-bit sRGB images: its LDR mode expects
//! display-encoded sRGB in [0, 1], which the tone-mapped frame is.

use fovea_core::Image;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_post::Rgb;

/// An axis-aligned pixel rectangle `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the right column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

impl Region {
    /// The whole `w × h` image.
    pub fn full(w: u32, h: u32) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        }
    }

    /// The square of half-side `half_px` around `(cx, cy)`, clipped to a `w × h` image.
    pub fn around(cx: f64, cy: f64, half_px: f64, w: u32, h: u32) -> Self {
        let c = |v: f64, hi: u32| v.round().clamp(0.0, hi as f64) as u32;
        Self {
            x0: c(cx - half_px, w),
            y0: c(cy - half_px, h),
            x1: c(cx + half_px, w),
            y1: c(cy + half_px, h),
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Whether the region holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.width() == 0 || self.height() == 0
    }
}

/// Crops `img` to `r`.
pub fn crop<T: Clone>(img: &Image<T>, r: Region) -> Option<Image<T>> {
    if r.is_empty() || r.x1 > img.width() || r.y1 > img.height() {
        return None;
    }
    let mut data = Vec::with_capacity((r.width() * r.height()) as usize);
    for y in r.y0..r.y1 {
        data.extend_from_slice(&img.row(y)[r.x0 as usize..r.x1 as usize]);
    }
    Image::from_vec(r.width(), r.height(), data).ok()
}

/// The tone curve every metric applies before sRGB encoding: the default of `fovea render
/// --tonemap` and the curve of the PNGs the experiments write.
pub const DISPLAY_CURVE: ToneCurve = ToneCurve::Reinhard;

/// `img` encoded for display as the metrics see it: [`DISPLAY_CURVE`], then 8-bit sRGB,
/// interleaved RGB bytes.
pub fn display_srgb8(img: &Image<Rgb>) -> Vec<u8> {
    to_srgb8(img, 0.0, DISPLAY_CURVE)
}

/// Display-encoded ([`display_srgb8`]: Reinhard tone curve, 8-bit sRGB) Rec. 601 luma in
/// [0, 1], per pixel.
pub(crate) fn encoded_luma(img: &Image<Rgb>) -> Vec<f64> {
    display_srgb8(img)
        .chunks_exact(3)
        .map(|c| (0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64) / 255.0)
        .collect()
}

/// Luma PSNR in dB over `region`: `10 log10(1 / MSE)` of display-encoded luma in [0, 1]
/// (through the tone curve, see the module header).
/// `None` when the sizes differ or the region is empty or outside; `f64::INFINITY` for
/// identical images.
pub fn luma_psnr(reference: &Image<Rgb>, test: &Image<Rgb>, region: Region) -> Option<f64> {
    if reference.width() != test.width() || reference.height() != test.height() {
        return None;
    }
    let (a, b) = (crop(reference, region)?, crop(test, region)?);
    let (la, lb) = (encoded_luma(&a), encoded_luma(&b));
    let mse = la
        .iter()
        .zip(&lb)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        / la.len() as f64;
    Some(if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    })
}

/// Mean ꟻLIP error over `region` (0 = identical, 1 = maximal), at `pixels_per_degree` of the
/// display. `None` when the sizes differ or the region is empty or outside.
pub fn flip_mean(
    reference: &Image<Rgb>,
    test: &Image<Rgb>,
    region: Region,
    pixels_per_degree: f32,
) -> Option<f64> {
    let map = flip_map(reference, test, region, pixels_per_degree)?;
    Some(map.data().iter().map(|&v| v as f64).sum::<f64>() / map.data().len() as f64)
}

/// The ꟻLIP error map over `region`.
pub fn flip_map(
    reference: &Image<Rgb>,
    test: &Image<Rgb>,
    region: Region,
    pixels_per_degree: f32,
) -> Option<Image<f32>> {
    if reference.width() != test.width() || reference.height() != test.height() {
        return None;
    }
    if !(pixels_per_degree.is_finite() && pixels_per_degree > 0.0) {
        return None;
    }
    let (a, b) = (crop(reference, region)?, crop(test, region)?);
    let (w, h) = (a.width(), a.height());
    let fa = nv_flip::FlipImageRgb8::with_data(w, h, &display_srgb8(&a));
    let fb = nv_flip::FlipImageRgb8::with_data(w, h, &display_srgb8(&b));
    let map = nv_flip::flip(fa, fb, pixels_per_degree);
    Image::from_vec(w, h, map.to_vec()).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: u32, h: u32, k: f32) -> Image<Rgb> {
        Image::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| [k * (i % w) as f32 / w as f32; 3])
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn psnr_of_a_known_offset() {
        // Every pixel's encoded value differs by exactly 10/255 → PSNR = 20 log10(25.5).
        // Encoded = sRGB(Reinhard(x)); Reinhard's inverse is y / (1 − y).
        let a = Image::new(16, 8, [0.2f32; 3]).unwrap();
        let enc = fovea_post::tonemap::linear_to_srgb(0.2 / 1.2);
        let target = ((enc * 255.0 + 0.5).floor() + 10.0) / 255.0;
        let y = srgb_to_linear(target);
        let lin = y / (1.0 - y);
        let b = Image::new(16, 8, [lin; 3]).unwrap();
        let p = luma_psnr(&a, &b, Region::full(16, 8)).unwrap();
        assert!((p - 20.0 * 25.5f64.log10()).abs() < 0.05, "{p}");
        assert_eq!(luma_psnr(&a, &a, Region::full(16, 8)), Some(f64::INFINITY));
        assert!(luma_psnr(&a, &ramp(8, 8, 1.0), Region::full(8, 8)).is_none());
    }

    #[test]
    fn highlights_above_one_are_scored_not_clipped() {
        // A grey wall with a bright window: the pair differs only in the window, at 3.0 vs
        // 4.0 linear. Clipping at 1 made both white (an infinite PSNR); through the tone
        // curve they are 0.75 vs 0.8 and score finite, below identical.
        let window = |v: f32| {
            Image::from_vec(
                32,
                32,
                (0..32 * 32)
                    .map(|i| {
                        let (x, y) = (i % 32, i / 32);
                        if (8..24).contains(&x) && (8..24).contains(&y) {
                            [v; 3]
                        } else {
                            [0.18; 3]
                        }
                    })
                    .collect(),
            )
            .unwrap()
        };
        let (a, b) = (window(3.0), window(4.0));
        let r = Region::full(32, 32);
        let p = luma_psnr(&a, &b, r).unwrap();
        assert!(p.is_finite() && p > 10.0, "{p}");
        assert_eq!(luma_psnr(&a, &a, r), Some(f64::INFINITY));
        // A larger highlight error scores lower.
        assert!(luma_psnr(&a, &window(8.0), r).unwrap() < p);
        // ꟻLIP sees it too (and SSIM: `ssim::tests`).
        assert!(flip_mean(&a, &b, r, 30.0).unwrap() > 0.0);
        // The encoding is the output's: Reinhard then sRGB, as the PNGs.
        assert_eq!(
            display_srgb8(&a),
            to_srgb8(&a, 0.0, ToneCurve::Reinhard),
            "metrics must encode like the PNGs"
        );
    }

    #[test]
    fn psnr_within_unit_range_is_monotone_in_the_error() {
        // Within [0, 1] linear the scores still order errors: a larger uniform offset of a
        // ramp scores a lower PSNR, and every score is finite.
        let a = ramp(64, 32, 0.8);
        let r = Region::full(64, 32);
        let shifted = |d: f32| {
            Image::from_vec(64, 32, a.data().iter().map(|p| p.map(|c| c + d)).collect()).unwrap()
        };
        let ps: Vec<f64> = [0.01f32, 0.03, 0.1, 0.2]
            .iter()
            .map(|&d| luma_psnr(&a, &shifted(d), r).unwrap())
            .collect();
        assert!(ps.iter().all(|p| p.is_finite()), "{ps:?}");
        assert!(ps.windows(2).all(|w| w[0] > w[1]), "{ps:?}");
        // And a dark frame against black is far from identical.
        let black = Image::new(64, 32, [0.0f32; 3]).unwrap();
        assert!(luma_psnr(&black, &a, r).unwrap() < ps[3]);
    }

    fn srgb_to_linear(c: f32) -> f32 {
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    }

    #[test]
    fn flip_is_zero_for_identical_and_grows_with_difference() {
        let a = ramp(64, 32, 1.0);
        let r = Region::full(64, 32);
        assert!(flip_mean(&a, &a, r, 30.0).unwrap() < 1e-6);
        let small = flip_mean(&a, &ramp(64, 32, 0.9), r, 30.0).unwrap();
        let large = flip_mean(&a, &ramp(64, 32, 0.3), r, 30.0).unwrap();
        assert!(small > 0.0 && large > small, "{small} {large}");
        let sub = Region::around(10.0, 10.0, 5.0, 64, 32);
        assert_eq!((sub.width(), sub.height()), (10, 10));
        assert!(flip_mean(&a, &a, Region::around(-50.0, -50.0, 5.0, 64, 32), 30.0).is_none());
    }
}
