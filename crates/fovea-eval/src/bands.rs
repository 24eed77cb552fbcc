//! Image quality of a foveated frame against the full-resolution frame by eccentricity band:
//! luma PSNR, SSIM and ꟻLIP over the pixels whose eccentricity (VaFR Eq. 3, from the gaze)
//! falls in each band, and the method's samples per pixel there. Foveation is meant to lose
//! quality with eccentricity more slowly than it loses samples; this is where that shows.
//!
//! PSNR is computed from the band's pixels only; SSIM (11×11 Gaussian window, σ = 1.5 px) and
//! ꟻLIP (at the display's pixels per degree) are computed over the whole frame, so windows see
//! their full neighbourhood, and their maps are averaged over the band's pixels. All three see
//! the frames through the output's tone curve (Reinhard, then sRGB), as [`crate::metrics`].

use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::units::ScreenPoint;
use fovea_core::{FoveaError, Image, Result};
use fovea_post::Rgb;

use crate::metrics::{encoded_luma, flip_map, Region};
use crate::ssim::ssim_map;

/// The bands of the report (issue 7): 0–5°, 5–15°, 15–30°, beyond 30°.
pub const REPORT_BANDS_DEG: [f64; 4] = [0.0, 5.0, 15.0, 30.0];

/// Checks band edges: ascending, finite, starting at 0.
pub fn check_edges(edges: &[f64]) -> Result<()> {
    if edges.is_empty()
        || edges[0] != 0.0
        || edges.windows(2).any(|p| p[1] <= p[0])
        || edges.iter().any(|e| !e.is_finite())
    {
        return Err(FoveaError::invalid(
            "bands",
            format!("{edges:?}"),
            "ascending finite eccentricities starting at 0",
        ));
    }
    Ok(())
}

/// Eccentricity of every pixel centre (row-major), degrees.
pub fn pixel_eccentricities(display: &DisplayProfile, gaze: &Gaze) -> Vec<f64> {
    let (w, h) = (display.width_px, display.height_px);
    (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            display
                .eccentricity(ScreenPoint::new(i as f64 + 0.5, j as f64 + 0.5), gaze)
                .0
        })
        .collect()
}

/// Index of the band of `edges` holding eccentricity `e`.
#[inline]
pub fn band_index(edges: &[f64], e: f64) -> usize {
    edges.partition_point(|&lo| lo <= e).saturating_sub(1)
}

/// Which pixels (row-major) lie in the band of eccentricity `[lo_deg, hi_deg)` from `gaze`
/// (`hi_deg = None`: no upper edge), eccentricity as [`pixel_eccentricities`] (VaFR Eq. 3 at
/// the pixel centre). "Beyond 30°" is `band_mask(display, gaze, 30.0, None)`.
pub fn band_mask(
    display: &DisplayProfile,
    gaze: &Gaze,
    lo_deg: f64,
    hi_deg: Option<f64>,
) -> Vec<bool> {
    pixel_eccentricities(display, gaze)
        .into_iter()
        .map(|e| e >= lo_deg && hi_deg.is_none_or(|hi| e < hi))
        .collect()
}

/// Mean ꟻLIP (at the display's pixels per degree, computed over the whole frame so its
/// filters see every neighbour) of `test` against `reference` over the pixels of `mask`
/// ([`band_mask`]), with their count; `None` for an empty mask.
pub fn masked_flip(
    reference: &Image<Rgb>,
    test: &Image<Rgb>,
    display: &DisplayProfile,
    mask: &[bool],
) -> Result<Option<(f64, u64)>> {
    let (w, h) = (display.width_px, display.height_px);
    for (name, im) in [("reference", reference), ("test", test)] {
        if im.width() != w || im.height() != h {
            return Err(FoveaError::invalid(
                name,
                format!("{}×{}", im.width(), im.height()),
                format!("the display's {w}×{h}"),
            ));
        }
    }
    if mask.len() != (w as usize) * (h as usize) {
        return Err(FoveaError::invalid(
            "mask",
            mask.len(),
            format!("one flag per pixel of the display's {w}×{h}"),
        ));
    }
    let flip = flip_map(reference, test, Region::full(w, h), display.ppd() as f32)
        .ok_or_else(|| FoveaError::Unsupported("ꟻLIP of an empty frame".into()))?;
    let (mut sum, mut n) = (0.0f64, 0u64);
    for (&v, _) in flip.data().iter().zip(mask).filter(|(_, &m)| m) {
        sum += f64::from(v);
        n += 1;
    }
    Ok((n > 0).then(|| (sum / n as f64, n)))
}

/// One band.
#[derive(Clone, Debug, Serialize)]
pub struct BandQuality {
    /// Lower edge, degrees.
    pub lo_deg: f64,
    /// Upper edge, degrees (`None` for the open last band).
    pub hi_deg: Option<f64>,
    /// Pixels in the band.
    pub pixels: u64,
    /// Luma PSNR over the band, dB (`inf` where identical; `None` for an empty band).
    pub psnr_db: Option<f64>,
    /// Mean SSIM over the band.
    pub ssim: Option<f64>,
    /// Mean ꟻLIP over the band.
    pub flip: Option<f64>,
    /// Mean samples per pixel over the band (when a density view was given).
    pub samples_per_pixel: Option<f64>,
}

/// Metrics of `test` against `reference` for every band starting at `edges` (ascending, first
/// 0), eccentricity from `gaze` on `display`; `density` is the method's samples per pixel.
pub fn band_quality(
    reference: &Image<Rgb>,
    test: &Image<Rgb>,
    density: Option<&Image<f32>>,
    display: &DisplayProfile,
    gaze: &Gaze,
    edges: &[f64],
) -> Result<Vec<BandQuality>> {
    let (w, h) = (display.width_px, display.height_px);
    for (name, im) in [("reference", reference), ("test", test)] {
        if im.width() != w || im.height() != h {
            return Err(FoveaError::invalid(
                name,
                format!("{}×{}", im.width(), im.height()),
                format!("the display's {w}×{h}"),
            ));
        }
    }
    if density.is_some_and(|d| d.width() != w || d.height() != h) {
        return Err(FoveaError::invalid(
            "density",
            "another size",
            format!("the display's {w}×{h}"),
        ));
    }
    check_edges(edges)?;
    let whole = Region::full(w, h);
    let metric_error = || FoveaError::Unsupported("metrics of an empty frame".into());
    let ssim = ssim_map(reference, test, whole).ok_or_else(metric_error)?;
    let flip = flip_map(reference, test, whole, display.ppd() as f32).ok_or_else(metric_error)?;
    let (ya, yb) = (encoded_luma(reference), encoded_luma(test));
    let nb = edges.len();
    // Per band: pixels, squared luma error, SSIM, FLIP, density.
    let mut acc = vec![[0.0f64; 5]; nb];
    for (k, e) in pixel_eccentricities(display, gaze).into_iter().enumerate() {
        let b = band_index(edges, e);
        let d = ya[k] - yb[k];
        acc[b][0] += 1.0;
        acc[b][1] += d * d;
        acc[b][2] += ssim.data()[k] as f64;
        acc[b][3] += flip.data()[k] as f64;
        acc[b][4] += density.map_or(0.0, |dd| dd.data()[k] as f64);
    }
    Ok((0..nb)
        .map(|b| {
            let n = acc[b][0];
            let mean = |v: f64| (n > 0.0).then(|| v / n);
            BandQuality {
                lo_deg: edges[b],
                hi_deg: edges.get(b + 1).copied(),
                pixels: n as u64,
                psnr_db: mean(acc[b][1]).map(|mse| {
                    if mse == 0.0 {
                        f64::INFINITY
                    } else {
                        10.0 * (1.0 / mse).log10()
                    }
                }),
                ssim: mean(acc[b][2]),
                flip: mean(acc[b][3]),
                samples_per_pixel: density.and_then(|_| mean(acc[b][4])),
            }
        })
        .collect())
}

/// The whole frame from its bands (one pass over the frame gives both): pixel-weighted means of
/// SSIM, ꟻLIP and samples per pixel, and the PSNR of the pooled squared error. `None` when the
/// bands hold no pixel.
pub fn whole_frame(bands: &[BandQuality]) -> Option<BandQuality> {
    let n: u64 = bands.iter().map(|b| b.pixels).sum();
    if n == 0 {
        return None;
    }
    let filled = || bands.iter().filter(|b| b.pixels > 0);
    let mean = |f: &dyn Fn(&BandQuality) -> Option<f64>| -> Option<f64> {
        filled()
            .map(|b| f(b).map(|v| v * b.pixels as f64))
            .sum::<Option<f64>>()
            .map(|s| s / n as f64)
    };
    // PSNR = 10·log10(1/MSE) per band; an infinite one is a band with no error.
    let mse = mean(&|b| b.psnr_db.map(|p| 10f64.powf(-p / 10.0)))?;
    Some(BandQuality {
        lo_deg: bands.first()?.lo_deg,
        hi_deg: None,
        pixels: n,
        psnr_db: Some(if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (1.0 / mse).log10()
        }),
        ssim: mean(&|b| b.ssim),
        flip: mean(&|b| b.flip),
        samples_per_pixel: mean(&|b| b.samples_per_pixel),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn display() -> DisplayProfile {
        DisplayProfile::with_vertical_fov("t", 96, 64, fovea_core::units::Degrees(90.0)).unwrap()
    }

    #[test]
    fn identical_frames_are_perfect_in_every_band() {
        let d = display();
        let img = Image::from_vec(
            96,
            64,
            (0..96 * 64).map(|k| [(k % 7) as f32 / 7.0; 3]).collect(),
        )
        .unwrap();
        let q = band_quality(&img, &img, None, &d, &d.centre_gaze(), &REPORT_BANDS_DEG).unwrap();
        assert_eq!(q.len(), 4);
        let total: u64 = q.iter().map(|b| b.pixels).sum();
        assert_eq!(total, 96 * 64);
        for b in q.iter().filter(|b| b.pixels > 0) {
            assert_eq!(b.psnr_db, Some(f64::INFINITY));
            assert!((b.ssim.unwrap() - 1.0).abs() < 1e-6);
            assert!(b.flip.unwrap() < 1e-6);
            assert!(b.samples_per_pixel.is_none());
        }
    }

    #[test]
    fn an_error_in_the_periphery_shows_only_there() {
        // Corrupt every pixel beyond 30°: the inner bands stay perfect for PSNR, the outer one
        // matches the hand-computed MSE.
        let d = display();
        let g = d.centre_gaze();
        let reference = Image::new(96, 64, [0.2f32; 3]).unwrap();
        let mut test = reference.clone();
        let mut n = 0u64;
        for j in 0..64u32 {
            for i in 0..96u32 {
                let e = d
                    .eccentricity(ScreenPoint::new(i as f64 + 0.5, j as f64 + 0.5), &g)
                    .0;
                if e >= 30.0 {
                    *test.get_mut(i, j) = [0.8; 3];
                    n += 1;
                }
            }
        }
        let density = Image::new(96, 64, 0.25f32).unwrap();
        let q = band_quality(&reference, &test, Some(&density), &d, &g, &REPORT_BANDS_DEG).unwrap();
        assert_eq!(q[0].psnr_db, Some(f64::INFINITY));
        assert_eq!(q[3].pixels, n);
        // Encoded as the metrics see it: Reinhard tone curve, then 8-bit sRGB.
        let enc = |v: f32| {
            (fovea_post::tonemap::linear_to_srgb(v / (1.0 + v)) * 255.0).round() as f64 / 255.0
        };
        let d2 = (enc(0.8) - enc(0.2)).powi(2);
        assert!((q[3].psnr_db.unwrap() - 10.0 * (1.0 / d2).log10()).abs() < 1e-9);
        assert!(q[3].flip.unwrap() > q[0].flip.unwrap());
        assert!((q[2].samples_per_pixel.unwrap() - 0.25).abs() < 1e-9);
    }

    #[test]
    fn the_whole_frame_from_the_bands_equals_one_band_over_everything() {
        let d = display();
        let g = d.gaze(30.0, 20.0).unwrap();
        let reference = Image::from_vec(
            96,
            64,
            (0..96 * 64).map(|k| [(k % 11) as f32 / 11.0; 3]).collect(),
        )
        .unwrap();
        let test = Image::from_vec(
            96,
            64,
            (0..96 * 64)
                .map(|k| [((k * 7) % 13) as f32 / 13.0; 3])
                .collect(),
        )
        .unwrap();
        let density =
            Image::from_vec(96, 64, (0..96 * 64).map(|k| (k % 5) as f32).collect()).unwrap();
        let bands =
            band_quality(&reference, &test, Some(&density), &d, &g, &REPORT_BANDS_DEG).unwrap();
        let one = band_quality(&reference, &test, Some(&density), &d, &g, &[0.0]).unwrap();
        let w = whole_frame(&bands).unwrap();
        assert_eq!(w.pixels, one[0].pixels);
        for (a, b) in [
            (w.psnr_db, one[0].psnr_db),
            (w.ssim, one[0].ssim),
            (w.flip, one[0].flip),
            (w.samples_per_pixel, one[0].samples_per_pixel),
        ] {
            assert!((a.unwrap() - b.unwrap()).abs() < 1e-9, "{a:?} {b:?}");
        }
        let same = band_quality(&reference, &reference, None, &d, &g, &REPORT_BANDS_DEG).unwrap();
        let w = whole_frame(&same).unwrap();
        assert_eq!(w.psnr_db, Some(f64::INFINITY));
        assert!(w.samples_per_pixel.is_none());
        assert!(whole_frame(&[]).is_none());
    }

    #[test]
    fn the_band_mask_matches_a_brute_force_eccentricity() {
        // Eq. 3 from scratch: e = atan(r / f_y), r the pixel centre's distance from the gaze.
        for (d, g) in [
            (display(), (48.0, 32.0)),
            (display(), (7.0, 4.0)),
            (
                DisplayProfile::with_vertical_fov("u", 120, 90, fovea_core::units::Degrees(110.0))
                    .unwrap(),
                (90.3, 20.7),
            ),
        ] {
            let gaze = d.gaze(g.0, g.1).unwrap();
            let f = d.focal_y_px();
            for (lo, hi) in [(30.0, None), (5.0, Some(15.0)), (0.0, Some(5.0))] {
                let mask = band_mask(&d, &gaze, lo, hi);
                let mut n = 0;
                for j in 0..d.height_px {
                    for i in 0..d.width_px {
                        let r = (i as f64 + 0.5 - g.0).hypot(j as f64 + 0.5 - g.1);
                        let e = (r / f).atan().to_degrees();
                        let want = e >= lo && hi.is_none_or(|h| e < h);
                        assert_eq!(mask[(j * d.width_px + i) as usize], want, "{i},{j} e={e}");
                        n += usize::from(want);
                    }
                }
                assert!(n > 0, "band {lo}–{hi:?} empty at gaze {g:?}");
            }
        }
    }

    #[test]
    fn masked_flip_averages_the_map_over_the_band_only() {
        // An error beyond 30° only: the masked ꟻLIP beyond 30° equals the mean of the map over
        // those pixels (brute force), and the band within 5° (far from the error) is ~0.
        let d = display();
        let g = d.centre_gaze();
        let reference = Image::new(96, 64, [0.2f32; 3]).unwrap();
        let mut test = reference.clone();
        let outer = band_mask(&d, &g, 30.0, None);
        for (k, &m) in outer.iter().enumerate() {
            if m {
                *test.get_mut(k as u32 % 96, k as u32 / 96) = [0.9; 3];
            }
        }
        let (f, n) = masked_flip(&reference, &test, &d, &outer).unwrap().unwrap();
        let map = flip_map(&reference, &test, Region::full(96, 64), d.ppd() as f32).unwrap();
        let want: Vec<f64> = map
            .data()
            .iter()
            .zip(&outer)
            .filter(|(_, &m)| m)
            .map(|(&v, _)| f64::from(v))
            .collect();
        assert_eq!(n as usize, want.len());
        assert!((f - want.iter().sum::<f64>() / want.len() as f64).abs() < 1e-12);
        assert!(f > 0.1, "{f}");
        let inner = band_mask(&d, &g, 0.0, Some(5.0));
        let (fi, _) = masked_flip(&reference, &test, &d, &inner).unwrap().unwrap();
        assert!(fi < 1e-6, "{fi}");
        let none = vec![false; outer.len()];
        assert!(masked_flip(&reference, &test, &d, &none).unwrap().is_none());
        assert!(masked_flip(&reference, &test, &d, &outer[1..]).is_err());
    }

    #[test]
    fn bad_input_is_an_error() {
        let d = display();
        let img = Image::new(96, 64, [0.0f32; 3]).unwrap();
        let small = Image::new(8, 8, [0.0f32; 3]).unwrap();
        let g = d.centre_gaze();
        assert!(band_quality(&img, &small, None, &d, &g, &REPORT_BANDS_DEG).is_err());
        assert!(band_quality(&img, &img, None, &d, &g, &[5.0, 1.0]).is_err());
        let bad_density = Image::new(8, 8, 1.0f32).unwrap();
        assert!(band_quality(&img, &img, Some(&bad_density), &d, &g, &REPORT_BANDS_DEG).is_err());
    }
}
