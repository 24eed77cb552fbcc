//! Tone mapping and display encoding: exposure (a linear scale, in stops), an optional
//! Reinhard curve `x/(1+x)` per channel, then the sRGB transfer function (IEC 61966-2-1).

use fovea_core::Image;

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

/// Encodes a linear image to 8-bit sRGB RGB bytes.
pub fn to_srgb8(img: &Image<Rgb>, exposure_stops: f32, curve: ToneCurve) -> Vec<u8> {
    let k = 2f32.powf(exposure_stops);
    let mut out = Vec::with_capacity(img.data().len() * 3);
    for c in img.data() {
        for &v in c {
            let x = (v * k).max(0.0);
            let x = match curve {
                ToneCurve::Clamp => x,
                ToneCurve::Reinhard => x / (1.0 + x),
            };
            let x = if x.is_finite() { x } else { 0.0 };
            out.push((linear_to_srgb(x) * 255.0 + 0.5) as u8);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_matches_the_standard() {
        assert!((linear_to_srgb(0.214_041) - 0.5).abs() < 1e-5);
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert!((linear_to_srgb(2.0) - 1.0).abs() < 1e-6);
        let img = Image::new(1, 1, [0.0, 1.0, f32::NAN]).unwrap();
        assert_eq!(to_srgb8(&img, 0.0, ToneCurve::Clamp), vec![0, 255, 0]);
    }
}
