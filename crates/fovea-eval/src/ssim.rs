//! Structural similarity, SSIM (Wang, Bovik, Sheikh & Simoncelli 2004, "Image quality
//! assessment: from error visibility to structural similarity", IEEE TIP 13(4), Eq. 13 and
//! Sec. III-C).
//!
//! For two images `x`, `y` and a pixel `p`, with local statistics under a Gaussian window `w`
//! centred on `p` (11×11, σ = 1.5 px, normalised to sum 1, as in the paper's reference code):
//!
//! ```text
//! μ_x = Σ w·x,  σ_x² = Σ w·x² − μ_x²,  σ_xy = Σ w·x·y − μ_x·μ_y
//! SSIM(p) = (2μ_xμ_y + C1)(2σ_xy + C2) / ((μ_x² + μ_y² + C1)(σ_x² + σ_y² + C2))
//! C1 = (K1·L)², C2 = (K2·L)², K1 = 0.01, K2 = 0.03, L = 1
//! ```
//!
//! and the reported value is the mean of `SSIM(p)` over the pixels of a [`Region`] (MSSIM,
//! Eq. 17). The images are compared as display-encoded luma in [0, 1], exactly as
//! [`crate::metrics::luma_psnr`] does: the output tone curve (Reinhard `x / (1 + x)`, not a
//! clip at 1; see [`crate::metrics`]), sRGB transfer function to 8 bits, then Rec.601 weights
//! `0.299 R' + 0.587 G' + 0.114 B'` over 255.
//!
//! Border handling: the window of a pixel reads the full image, not just the region, so a small
//! foveal region is judged with its real surroundings. Where the window sticks out of the
//! image it is truncated and renormalised to sum 1 (the paper's code instead drops pixels
//! within 5 px of the border). The window is separable and the truncated domain a rectangle,
//! so two 1-D passes with renormalised 1-D weights give exactly the renormalised 2-D window.
//! No automatic down-sampling is applied (the paper's code down-samples images larger than
//! 256 px by `round(min(w, h)/256)` to approximate a viewing distance; pass a down-sampled
//! image to get that).

use fovea_core::Image;
use fovea_post::Rgb;

use crate::metrics::Region;

/// `K1` of Wang et al. (2004).
pub const SSIM_K1: f64 = 0.01;
/// `K2` of Wang et al. (2004).
pub const SSIM_K2: f64 = 0.03;
/// Dynamic range `L` of the luma values (they lie in [0, 1]).
pub const SSIM_DYNAMIC_RANGE: f64 = 1.0;
/// Standard deviation of the Gaussian window in pixels.
pub const SSIM_WINDOW_SIGMA_PX: f64 = 1.5;
/// Half-width of the window in pixels (11×11).
pub const SSIM_WINDOW_RADIUS_PX: usize = 5;

/// Mean SSIM in [−1, 1] (1 = identical) over `region` of the display-encoded luma of two
/// linear-RGB frames. `None` when the sizes differ or the region is empty or not inside the
/// image (the same rules as [`crate::metrics::luma_psnr`]).
pub fn ssim(reference: &Image<Rgb>, test: &Image<Rgb>, region: Region) -> Option<f64> {
    if reference.width() != test.width() || reference.height() != test.height() {
        return None;
    }
    check_region(reference.width(), reference.height(), region)?;
    ssim_luma(&encoded_luma(reference)?, &encoded_luma(test)?, region)
}

/// The per-pixel SSIM map over `region` (`region.width() × region.height()`), values in
/// [−1, 1]. `None` under the same conditions as [`ssim`].
pub fn ssim_map(reference: &Image<Rgb>, test: &Image<Rgb>, region: Region) -> Option<Image<f32>> {
    if reference.width() != test.width() || reference.height() != test.height() {
        return None;
    }
    check_region(reference.width(), reference.height(), region)?;
    ssim_luma_map(&encoded_luma(reference)?, &encoded_luma(test)?, region)
}

/// Mean SSIM over `region` of two luma planes; values are clamped to [0, 1] first (non-finite
/// values count as 0). `None` when the sizes differ or the region is empty or not inside.
pub fn ssim_luma(reference: &Image<f32>, test: &Image<f32>, region: Region) -> Option<f64> {
    let map = ssim_luma_map(reference, test, region)?;
    let n = map.data().len() as f64;
    Some(map.data().iter().map(|&v| v as f64).sum::<f64>() / n)
}

/// The per-pixel SSIM map over `region` of two luma planes (see [`ssim_luma`]).
pub fn ssim_luma_map(
    reference: &Image<f32>,
    test: &Image<f32>,
    region: Region,
) -> Option<Image<f32>> {
    let (w, h) = (reference.width(), reference.height());
    if test.width() != w || test.height() != h {
        return None;
    }
    check_region(w, h, region)?;
    let clamp = |v: f32| {
        if v.is_finite() {
            (v as f64).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let (w, h) = (w as usize, h as usize);
    let r = SSIM_WINDOW_RADIUS_PX;
    let kernel: Vec<f64> = (0..=2 * r)
        .map(|i| {
            let d = i as f64 - r as f64;
            (-d * d / (2.0 * SSIM_WINDOW_SIGMA_PX * SSIM_WINDOW_SIGMA_PX)).exp()
        })
        .collect();
    let (x0, x1) = (region.x0 as usize, region.x1 as usize);
    let (y0, y1) = (region.y0 as usize, region.y1 as usize);
    // Rows the vertical pass needs.
    let (ey0, ey1) = (y0.saturating_sub(r), (y1 + r).min(h));
    let rw = x1 - x0;
    // Horizontal pass: five moments (x, y, x², y², xy) per pixel, rows ey0..ey1, cols x0..x1.
    let mut horiz = vec![[0.0f64; 5]; (ey1 - ey0) * rw];
    let (a, b) = (reference.data(), test.data());
    for yy in ey0..ey1 {
        for x in x0..x1 {
            let (lo, hi) = (x.saturating_sub(r), (x + r + 1).min(w));
            let mut m = [0.0f64; 5];
            let mut wsum = 0.0;
            for xx in lo..hi {
                let k = kernel[xx + r - x];
                let (p, q) = (clamp(a[yy * w + xx]), clamp(b[yy * w + xx]));
                m[0] += k * p;
                m[1] += k * q;
                m[2] += k * p * p;
                m[3] += k * q * q;
                m[4] += k * p * q;
                wsum += k;
            }
            horiz[(yy - ey0) * rw + (x - x0)] = m.map(|v| v / wsum);
        }
    }
    let c1 = (SSIM_K1 * SSIM_DYNAMIC_RANGE).powi(2);
    let c2 = (SSIM_K2 * SSIM_DYNAMIC_RANGE).powi(2);
    let mut out = Vec::with_capacity(rw * (y1 - y0));
    for y in y0..y1 {
        let (lo, hi) = (y.saturating_sub(r), (y + r + 1).min(h));
        for x in 0..rw {
            let mut m = [0.0f64; 5];
            let mut wsum = 0.0;
            for yy in lo..hi {
                let k = kernel[yy + r - y];
                let hm = &horiz[(yy - ey0) * rw + x];
                for (acc, v) in m.iter_mut().zip(hm) {
                    *acc += k * v;
                }
                wsum += k;
            }
            let [mx, my, mxx, myy, mxy] = m.map(|v| v / wsum);
            out.push(ssim_from_moments(mx, my, mxx, myy, mxy, c1, c2) as f32);
        }
    }
    Image::from_vec(rw as u32, (y1 - y0) as u32, out).ok()
}

/// Eq. 13 from the window's weighted moments `E[x]`, `E[y]`, `E[x²]`, `E[y²]`, `E[xy]`.
#[inline]
fn ssim_from_moments(mx: f64, my: f64, mxx: f64, myy: f64, mxy: f64, c1: f64, c2: f64) -> f64 {
    // Clamp tiny negative variances from rounding.
    let vx = (mxx - mx * mx).max(0.0);
    let vy = (myy - my * my).max(0.0);
    let cxy = mxy - mx * my;
    ((2.0 * mx * my + c1) * (2.0 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))
}

fn check_region(w: u32, h: u32, r: Region) -> Option<()> {
    if r.is_empty() || r.x1 > w || r.y1 > h {
        None
    } else {
        Some(())
    }
}

/// Display-encoded luma in [0, 1], as `metrics::luma_psnr` computes it.
fn encoded_luma(img: &Image<Rgb>) -> Option<Image<f32>> {
    let data = crate::metrics::encoded_luma(img)
        .into_iter()
        .map(|v| v as f32)
        .collect();
    Image::from_vec(img.width(), img.height(), data).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn highlights_above_one_are_not_clipped_away() {
        // A 0.18 wall with a window at 3.0 or 4.0 linear: different once tone-mapped.
        let window = |v: f32| {
            let data = (0..32 * 32)
                .map(|i| {
                    let (x, y) = (i % 32, i / 32);
                    if (8..24).contains(&x) && (8..24).contains(&y) {
                        [v; 3]
                    } else {
                        [0.18; 3]
                    }
                })
                .collect();
            Image::from_vec(32, 32, data).unwrap()
        };
        let r = Region::full(32, 32);
        assert!(ssim(&window(3.0), &window(4.0), r).unwrap() < 1.0 - 1e-6);
        assert!((ssim(&window(3.0), &window(3.0), r).unwrap() - 1.0).abs() < 1e-9);
    }

    /// Deterministic texture in [0, 1].
    fn texture(w: u32, h: u32, seed: u32) -> Image<f32> {
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let s = seed as f32;
                0.5 + 0.25 * (0.7 * x + 0.3 * s).sin() * (0.45 * y - s).cos()
                    + 0.2 * ((x * 12.9898 + y * 78.233 + s).sin() * 43758.547).fract()
                    - 0.1
            })
            .collect();
        Image::from_vec(w, h, data).unwrap()
    }

    /// Straightforward SSIM: the 2-D window at every pixel, truncated and renormalised.
    fn brute_force(a: &Image<f32>, b: &Image<f32>, reg: Region) -> f64 {
        let (w, h) = (a.width() as i64, a.height() as i64);
        let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
        let mut total = 0.0;
        for y in reg.y0 as i64..reg.y1 as i64 {
            for x in reg.x0 as i64..reg.x1 as i64 {
                let (mut ws, mut mx, mut my) = (0.0, 0.0, 0.0);
                let mut pts = Vec::new();
                for dy in -5i64..=5 {
                    for dx in -5i64..=5 {
                        let (xx, yy) = (x + dx, y + dy);
                        if xx < 0 || yy < 0 || xx >= w || yy >= h {
                            continue;
                        }
                        let k = (-((dx * dx + dy * dy) as f64) / (2.0 * 1.5 * 1.5)).exp();
                        let p = (*a.get(xx as u32, yy as u32) as f64).clamp(0.0, 1.0);
                        let q = (*b.get(xx as u32, yy as u32) as f64).clamp(0.0, 1.0);
                        ws += k;
                        mx += k * p;
                        my += k * q;
                        pts.push((k, p, q));
                    }
                }
                mx /= ws;
                my /= ws;
                // Two-pass (centred) variances: a different route from the moment formula.
                let (mut vx, mut vy, mut cxy) = (0.0, 0.0, 0.0);
                for (k, p, q) in pts {
                    vx += k * (p - mx) * (p - mx);
                    vy += k * (q - my) * (q - my);
                    cxy += k * (p - mx) * (q - my);
                }
                let (vx, vy, cxy) = (vx / ws, vy / ws, cxy / ws);
                total += ((2.0 * mx * my + c1) * (2.0 * cxy + c2))
                    / ((mx * mx + my * my + c1) * (vx + vy + c2));
            }
        }
        total / (reg.width() as f64 * reg.height() as f64)
    }

    #[test]
    fn identical_images_score_one() {
        let a = texture(40, 30, 1);
        assert!((ssim_luma(&a, &a, Region::full(40, 30)).unwrap() - 1.0).abs() < 1e-12);
        let rgb = Image::from_vec(
            40,
            30,
            a.data().iter().map(|&v| [v, v * 0.5, 0.3]).collect(),
        )
        .unwrap();
        assert!((ssim(&rgb, &rgb, Region::full(40, 30)).unwrap() - 1.0).abs() < 1e-12);
        let map = ssim_map(&rgb, &rgb, Region::around(20.0, 15.0, 4.0, 40, 30)).unwrap();
        assert_eq!((map.width(), map.height()), (8, 8));
        assert!(map.data().iter().all(|&v| (v - 1.0).abs() < 1e-6));
    }

    #[test]
    fn matches_brute_force() {
        let (w, h) = (23, 17);
        let a = texture(w, h, 2);
        let b = texture(w, h, 5);
        for reg in [
            Region::full(w, h),
            Region {
                x0: 3,
                y0: 2,
                x1: 9,
                y1: 16,
            },
            Region {
                x0: 22,
                y0: 0,
                x1: 23,
                y1: 1,
            },
        ] {
            let fast = ssim_luma(&a, &b, reg).unwrap();
            let slow = brute_force(&a, &b, reg);
            assert!((fast - slow).abs() < 1e-6, "{reg:?}: {fast} vs {slow}");
            assert!(fast < 0.9, "{fast}");
        }
        // Out-of-range values are clamped the same way in both.
        let c = Image::from_vec(w, h, a.data().iter().map(|v| 1.6 * v - 0.3).collect()).unwrap();
        let reg = Region::full(w, h);
        assert!((ssim_luma(&a, &c, reg).unwrap() - brute_force(&a, &c, reg)).abs() < 1e-6);
    }

    #[test]
    fn constant_images_follow_the_luminance_term() {
        // σ = 0 everywhere: SSIM = (2pq + C1)/(p² + q² + C1).
        let c1 = 1e-4;
        for (p, q) in [(0.5f32, 0.5f32), (0.2, 0.3), (0.9, 0.1), (0.0, 1.0)] {
            let a = Image::new(16, 16, p).unwrap();
            let b = Image::new(16, 16, q).unwrap();
            let (p, q) = (p as f64, q as f64);
            let expect = (2.0 * p * q + c1) / (p * p + q * q + c1);
            let got = ssim_luma(&a, &b, Region::full(16, 16)).unwrap();
            assert!((got - expect).abs() < 1e-6, "{p} {q}: {got} vs {expect}");
        }
    }

    #[test]
    fn offset_costs_only_the_luminance_term() {
        // Adding δ (without clipping) leaves σ and σ_xy unchanged, so every pixel's SSIM is the
        // luminance term l = (2μ(μ+δ) + C1)/(μ² + (μ+δ)² + C1): close to 1, below 1.
        let a = texture(32, 32, 3).map(|v| 0.2 + 0.5 * v);
        let delta = 0.05f32;
        let b = a.map(|v| v + delta);
        let s = ssim_luma(&a, &b, Region::full(32, 32)).unwrap();
        assert!(s < 1.0 && s > 0.98, "{s}");
        // Brute-force check of the claim at one interior pixel.
        let reg = Region {
            x0: 10,
            y0: 10,
            x1: 11,
            y1: 11,
        };
        let (mut ws, mut m) = (0.0, 0.0);
        for dy in -5i32..=5 {
            for dx in -5i32..=5 {
                let k = (-((dx * dx + dy * dy) as f64) / 4.5).exp();
                ws += k;
                m += k * *a.get((10 + dx) as u32, (10 + dy) as u32) as f64;
            }
        }
        let mu = m / ws;
        let d = delta as f64;
        let l = (2.0 * mu * (mu + d) + 1e-4) / (mu * mu + (mu + d) * (mu + d) + 1e-4);
        assert!((ssim_luma(&a, &b, reg).unwrap() - l).abs() < 1e-5);
    }

    #[test]
    fn noise_lowers_it_monotonically_and_inversion_is_negative() {
        let a = texture(48, 48, 4);
        let noise = texture(48, 48, 9).map(|v| v - 0.5);
        let mut prev = 1.0;
        for amp in [0.02f32, 0.05, 0.1, 0.2, 0.4] {
            let data = a
                .data()
                .iter()
                .zip(noise.data())
                .map(|(x, n)| x + amp * n)
                .collect();
            let b = Image::from_vec(48, 48, data).unwrap();
            let s = ssim_luma(&a, &b, Region::full(48, 48)).unwrap();
            assert!(s < prev, "{amp}: {s} ≥ {prev}");
            // Symmetric.
            assert!((s - ssim_luma(&b, &a, Region::full(48, 48)).unwrap()).abs() < 1e-12);
            prev = s;
        }
        let inv = a.map(|v| 1.0 - v);
        assert!(ssim_luma(&a, &inv, Region::full(48, 48)).unwrap() < 0.0);
    }

    #[test]
    fn rgb_path_uses_the_psnr_luma() {
        let lin = Image::from_vec(
            20,
            10,
            (0..200)
                .map(|i| [(i % 20) as f32 / 20.0, 0.3, (i / 20) as f32 / 10.0 * 1.5])
                .collect(),
        )
        .unwrap();
        let other = lin.map(|c| [c[0] * 0.8, c[1], c[2]]);
        let reg = Region::full(20, 10);
        let via_rgb = ssim(&lin, &other, reg).unwrap();
        let via_luma = ssim_luma(
            &encoded_luma(&lin).unwrap(),
            &encoded_luma(&other).unwrap(),
            reg,
        )
        .unwrap();
        assert_eq!(via_rgb, via_luma);
        // The encoded luma is the Rec.601 value of the tone-mapped (Reinhard), sRGB-encoded
        // channels.
        let px = encoded_luma(&lin).unwrap();
        let enc = |v: f32| {
            let v = v.max(0.0);
            (fovea_post::tonemap::linear_to_srgb(v / (1.0 + v)) * 255.0).round()
        };
        let c = lin.get(7, 3);
        let expect = (0.299 * enc(c[0]) + 0.587 * enc(c[1]) + 0.114 * enc(c[2])) / 255.0;
        assert!((*px.get(7, 3) - expect).abs() < 1.5 / 255.0);
    }

    #[test]
    fn size_mismatch_and_bad_regions_are_none() {
        let a = Image::new(16, 8, [0.2f32; 3]).unwrap();
        let b = Image::new(8, 8, [0.2f32; 3]).unwrap();
        assert!(ssim(&a, &b, Region::full(8, 8)).is_none());
        assert!(ssim_map(&a, &b, Region::full(8, 8)).is_none());
        assert!(ssim(&a, &a, Region::full(17, 8)).is_none());
        assert!(ssim(&a, &a, Region::around(-50.0, -50.0, 5.0, 16, 8)).is_none());
        let la = Image::new(16, 8, 0.5f32).unwrap();
        let lb = Image::new(16, 9, 0.5f32).unwrap();
        assert!(ssim_luma(&la, &lb, Region::full(16, 8)).is_none());
        // NaN luma counts as 0, never panics.
        let ln = Image::new(16, 8, f32::NAN).unwrap();
        let s = ssim_luma(&la, &ln, Region::full(16, 8)).unwrap();
        assert!(s.is_finite() && s < 0.01);
    }
}
