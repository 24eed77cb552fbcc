//! Peripheral contrast enhancement (Weier et al. 2018, Sec. 3.2 "DoF Combine", after Patney
//! et al. 2016): "the quality degradation for peripheral vision can be counteracted by contrast
//! enhancement … achieved by weighting each pixel's color with a blurred version of its
//! surrounding with a kernel width adapted to the eccentricity", the blur read from the mip
//! pyramid with Quincunx taps.
//!
//! `out = c + k(e)·(c − blur_σ(e)(c))`, clamped at 0, with the gain
//! `k(e) = gain · clamp((e − start)/(full − start), 0, 1)` (0 in the fovea, where the frame is
//! fully sampled, rising over Weier's transition `r₀ = 10° … r₁ = 20°`) and `σ(e)` the caller's
//! footprint — in the pipeline the sample spacing of the foveation method at `e`, the scale of
//! the detail the sparse sampling smoothed away. Weier and Patney give no gain; the default
//! 0.5 is ours.

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use crate::mip::MipPyramid;
use crate::Rgb;

/// Parameters of the peripheral contrast enhancement.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PeripheralContrast {
    /// Gain beyond `full_deg`.
    pub gain: f32,
    /// Eccentricity where the enhancement starts, degrees.
    pub start_deg: f32,
    /// Eccentricity from which the full gain applies, degrees.
    pub full_deg: f32,
}

impl Default for PeripheralContrast {
    fn default() -> Self {
        Self {
            gain: 0.5,
            start_deg: 10.0,
            full_deg: 20.0,
        }
    }
}

impl PeripheralContrast {
    /// Checks `gain` in [0, 4] and `0 ≤ start < full ≤ 180`.
    pub fn validate(&self) -> Result<()> {
        if !(0.0..=4.0).contains(&self.gain) {
            return Err(FoveaError::invalid(
                "contrast gain",
                self.gain,
                "a gain in [0, 4], e.g. 0.5",
            ));
        }
        if !(self.start_deg >= 0.0 && self.start_deg < self.full_deg && self.full_deg <= 180.0) {
            return Err(FoveaError::invalid(
                "contrast eccentricities",
                format!("{}..{}", self.start_deg, self.full_deg),
                "0 ≤ start < full ≤ 180 degrees",
            ));
        }
        Ok(())
    }

    /// Gain at eccentricity `e_deg`.
    pub fn gain_at(&self, e_deg: f32) -> f32 {
        let t = ((e_deg - self.start_deg) / (self.full_deg - self.start_deg)).clamp(0.0, 1.0);
        self.gain * t
    }
}

/// Enhances `img`: `ecc_deg(x, y)` is pixel `(x, y)`'s eccentricity, `sigma_px(e)` the blur
/// footprint at eccentricity `e` (standard deviation, pixels).
pub fn enhance(
    img: &Image<Rgb>,
    params: &PeripheralContrast,
    ecc_deg: &(dyn Fn(u32, u32) -> f32 + Sync),
    sigma_px: &(dyn Fn(f32) -> f32 + Sync),
) -> Result<Image<Rgb>> {
    params.validate()?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    // Deep enough for footprints up to 64 px.
    let pyr = MipPyramid::for_sigma(w, h, img.data(), 64.0);
    let mut out = img.clone();
    out.data_mut()
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let e = ecc_deg(x as u32, y as u32);
                let k = params.gain_at(e);
                if k.is_nan() || k <= 0.0 {
                    continue;
                }
                let s = sigma_px(e).clamp(0.0, 64.0);
                if s.is_nan() || s <= 0.0 {
                    continue;
                }
                let b = pyr.quincunx(x as f32 + 0.5, y as f32 + 0.5, s);
                let c = *o;
                *o = std::array::from_fn(|ch| {
                    let v = c[ch] + k * (c[ch] - b[ch]);
                    if v.is_finite() {
                        v.max(0.0)
                    } else {
                        c[ch]
                    }
                });
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grating(w: u32, h: u32, period: f32) -> Image<Rgb> {
        let data = (0..w * h)
            .map(|k| {
                let x = (k % w) as f32;
                let v = 0.5 + 0.25 * (std::f32::consts::TAU * x / period).sin();
                [v, v, v]
            })
            .collect();
        Image::from_vec(w, h, data).unwrap()
    }

    #[test]
    fn fovea_is_untouched_and_periphery_gains_contrast() {
        let (w, h) = (256u32, 32u32);
        let img = grating(w, h, 8.0);
        // Eccentricity = x / 8 degrees: the fovea is x < 80, full gain from x = 160.
        let ecc = |x: u32, _y: u32| x as f32 / 8.0;
        let out = enhance(&img, &PeripheralContrast::default(), &ecc, &|_| 4.0).unwrap();
        for x in 0..80 {
            assert_eq!(out.get(x, 16), img.get(x, 16));
        }
        let amp = |im: &Image<Rgb>, x0: u32| {
            let (mut lo, mut hi) = (f32::MAX, f32::MIN);
            for x in x0..x0 + 16 {
                lo = lo.min(im.get(x, 16)[0]);
                hi = hi.max(im.get(x, 16)[0]);
            }
            hi - lo
        };
        let (a_in, a_out) = (amp(&img, 200), amp(&out, 200));
        // A grating much finer than the blur keeps its mean and gains ≈ 1 + gain.
        assert!(
            a_out > 1.35 * a_in && a_out < 1.6 * a_in,
            "{a_in} → {a_out}"
        );
    }

    #[test]
    fn constant_image_is_unchanged() {
        let img = Image::new(64, 64, [0.3f32, 0.2, 0.1]).unwrap();
        let out = enhance(&img, &PeripheralContrast::default(), &|_, _| 45.0, &|_| 3.0).unwrap();
        for (a, b) in img.data().iter().zip(out.data()) {
            for ch in 0..3 {
                assert!((a[ch] - b[ch]).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let img = Image::new(8, 8, [0.0f32; 3]).unwrap();
        for p in [
            PeripheralContrast {
                gain: -1.0,
                ..Default::default()
            },
            PeripheralContrast {
                gain: f32::NAN,
                ..Default::default()
            },
            PeripheralContrast {
                start_deg: 30.0,
                full_deg: 20.0,
                ..Default::default()
            },
        ] {
            assert!(enhance(&img, &p, &|_, _| 0.0, &|_| 1.0).is_err());
        }
    }
}
