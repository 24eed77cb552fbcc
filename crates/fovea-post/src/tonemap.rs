//! Tone mapping and display encoding: exposure (a linear scale, in stops), an optional
//! Reinhard curve `x/(1+x)` per channel, then the sRGB transfer function (IEC 61966-2-1).

use fovea_core::Image;
use rayon::prelude::*;

use crate::Rgb;

/// Tone curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ToneCurve {
    /// Clip at 1 (what a display without tone mapping shows).
    #[default]
    Clamp,
    /// Reinhard `x / (1 + x)`.
    Reinhard,
}

/// Linear → sRGB-encoded value in [0, 1].
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB-encoded value in [0, 1] → linear (the inverse of [`linear_to_srgb`]).
#[inline]
pub fn srgb_to_linear(e: f32) -> f32 {
    let e = e.clamp(0.0, 1.0);
    if e <= 0.040_45 {
        e / 12.92
    } else {
        ((e + 0.055) / 1.055).powf(2.4)
    }
}

/// Another executor of the output's display encoding ([`to_srgb8`]), e.g. the GPU's: the
/// same bytes from the same image, exposure and curve.
pub trait ToneMapExecutor: Send {
    /// The backend's short name in stats and JSON, e.g. `gpu`.
    fn backend(&self) -> &str;
    /// `img` encoded as [`to_srgb8`] does. An error is one line saying what to do.
    fn to_srgb8(
        &mut self,
        img: &Image<Rgb>,
        exposure_stops: f32,
        curve: ToneCurve,
    ) -> Result<Vec<u8>, String>;
}

/// Encodes a linear image to 8-bit sRGB RGB bytes, rows in parallel.
pub fn to_srgb8(img: &Image<Rgb>, exposure_stops: f32, curve: ToneCurve) -> Vec<u8> {
    let k = 2f32.powf(exposure_stops);
    let table = Srgb8Table::new();
    let width = img.width() as usize;
    let mut out = vec![0u8; img.data().len() * 3];
    out.par_chunks_mut(width * 3)
        .zip(img.data().par_chunks(width))
        .for_each(|(dst, row)| {
            for (d, &v) in dst.iter_mut().zip(row.iter().flatten()) {
                let x = (v * k).max(0.0);
                let x = match curve {
                    ToneCurve::Clamp => x,
                    ToneCurve::Reinhard => x / (1.0 + x),
                };
                *d = table.encode(if x.is_finite() { x } else { 0.0 });
            }
        });
    out
}

/// The 255 linear thresholds of the 8-bit sRGB encoding [`to_srgb8`] uses: the code of a
/// linear value `x ∈ [0, ∞)` is the number of thresholds `≤ x` (the same byte as
/// `(linear_to_srgb(x)·255 + ½) as u8`). For another executor of the encoding (the GPU's).
pub fn srgb8_thresholds() -> [f32; 255] {
    Srgb8Table::new().thresholds
}

/// 8-bit sRGB encoding without `powf` per value: `thresholds[c]` is the linear value where
/// the rounded code steps from `c` to `c + 1`, so a code is the number of thresholds at or
/// below the value (a binary search over 255 entries). It gives the same bytes as
/// `(linear_to_srgb(x)·255 + ½) as u8` (tested over the whole range).
struct Srgb8Table {
    thresholds: [f32; 255],
}

impl Srgb8Table {
    fn new() -> Self {
        let mut thresholds = [0.0f32; 255];
        for (c, t) in thresholds.iter_mut().enumerate() {
            // The smallest x with linear_to_srgb(x)·255 + ½ ≥ c + 1, by bisection on the
            // monotone encoder itself (so the table agrees with it bit for bit).
            let (mut lo, mut hi) = (0.0f32, 1.0f32);
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if (linear_to_srgb(mid) * 255.0 + 0.5) as u32 > c as u32 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *t = hi;
        }
        Self { thresholds }
    }

    #[inline]
    fn encode(&self, x: f32) -> u8 {
        self.thresholds.partition_point(|&t| t <= x) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips() {
        for k in 0..=100 {
            let v = k as f32 / 100.0;
            assert!((srgb_to_linear(linear_to_srgb(v)) - v).abs() < 1e-5, "{v}");
        }
    }

    #[test]
    fn table_encoding_equals_the_transfer_function() {
        let table = Srgb8Table::new();
        let direct = |x: f32| (linear_to_srgb(x) * 255.0 + 0.5) as u8;
        // Every float bit pattern from 0 up to 1.5 in steps of 16 ulps, and a fine linear scan.
        let mut bits = 0u32;
        while f32::from_bits(bits) < 1.5 {
            let x = f32::from_bits(bits);
            assert_eq!(table.encode(x), direct(x), "{x}");
            bits += 16;
        }
        for k in 0..=200_000 {
            let x = k as f32 / 100_000.0;
            assert_eq!(table.encode(x), direct(x), "{x}");
        }
    }

    #[test]
    fn srgb_encoding_matches_the_standard() {
        assert!((linear_to_srgb(0.214_041) - 0.5).abs() < 1e-5);
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert!((linear_to_srgb(2.0) - 1.0).abs() < 1e-6);
        let img = Image::new(1, 1, [0.0, 1.0, f32::NAN]).unwrap();
        assert_eq!(to_srgb8(&img, 0.0, ToneCurve::Clamp), vec![0, 255, 0]);
    }
}
