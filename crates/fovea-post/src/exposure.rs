//! Exposure for display output (screen post, DESIGN.md stage 7): a scale in stops applied
//! before the tone curve, chosen three ways.
//!
//! * **Manual**: a number of stops (`2^stops` times the frame's values).
//! * **EV100** (photographic exposure value at ISO 100): a saturation-based camera maps
//!   luminance `L` (cd/m²) to `L / (1.2 · 2^EV100)` — Lagarde & de Rousiers, "Moving
//!   Frostbite to Physically Based Rendering" (SIGGRAPH 2014 course notes, the camera's
//!   saturation-based exposure), after ISO 12232: the saturating luminance is
//!   `78 / (S · q) · N² / t` with `q = 0.65`, which is `1.2 · 2^EV100` at `S = 100`. So
//!   `stops = −EV100 − log₂ 1.2`. The frame's values are read as cd/m²: the unit of a glTF
//!   scene, whose lights are photometric (`KHR_lights_punctual`: candela, lux).
//! * **Auto**: Reinhard et al., "Photographic Tone Reproduction for Digital Images"
//!   (SIGGRAPH 2002), eqs. 1–2: the log-average luminance `L̄ = exp(mean(ln(δ + L)))` over the
//!   pixels that see the scene is mapped to the key `a = 0.18` (middle grey):
//!   `stops = log₂(a / L̄)`. Pixels that see only the background are left out, so a small
//!   object against a dark sky is exposed for itself.
//!
//! [`FrameExposure`] also counts what a viewer would call a failed picture: the share of pixels
//! whose brightest channel encodes to the top 8-bit code (clipped to white) and the share that
//! see no geometry.

use fovea_core::Image;

use crate::tonemap::{linear_to_srgb, ToneCurve};
use crate::Rgb;

/// The key of the auto exposure: middle grey (Reinhard et al. 2002, Sec. 3.1).
pub const AUTO_KEY: f32 = 0.18;

/// The largest exposure magnitude in stops (±20 stops is a factor of about 10⁶); auto and
/// EV100 exposures are clamped to it.
pub const MAX_STOPS: f32 = 20.0;

/// `δ` of the log-average (Reinhard et al. 2002, eq. 1): keeps black pixels finite.
const LOG_AVERAGE_DELTA: f64 = 1e-6;

/// Luminance of linear sRGB / Rec. 709 RGB (ITU-R BT.709 coefficients): what a photometer
/// reads, unlike the Rec. 601 luma the metrics use.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// How the exposure is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exposure {
    /// A fixed scale, `2^stops`.
    Stops(f32),
    /// A camera's exposure value at ISO 100, the frame read as luminance in cd/m².
    Ev100(f32),
    /// Middle grey at the log-average luminance of the pixels that see the scene.
    Auto,
}

impl Exposure {
    /// The stops of a manual or EV100 exposure; `None` for auto, which needs a frame.
    pub fn fixed_stops(self) -> Option<f32> {
        match self {
            Exposure::Stops(s) => Some(s),
            Exposure::Ev100(ev) => Some(ev100_to_stops(ev).clamp(-MAX_STOPS, MAX_STOPS)),
            Exposure::Auto => None,
        }
    }
}

/// Stops for a saturation-based camera at `ev100` (Lagarde & de Rousiers 2014):
/// `−EV100 − log₂ 1.2`.
pub fn ev100_to_stops(ev100: f32) -> f32 {
    -ev100 - 1.2f32.log2()
}

/// The inverse of [`ev100_to_stops`].
pub fn stops_to_ev100(stops: f32) -> f32 {
    -stops - 1.2f32.log2()
}

/// The log-average luminance `exp(mean(ln(δ + L)))` over the pixels where `sees(i)` holds
/// (row-major index); `None` when there are none.
pub fn log_average_luminance(img: &Image<Rgb>, sees: impl Fn(usize) -> bool) -> Option<f32> {
    let (mut sum, mut n) = (0.0f64, 0u64);
    for (i, &c) in img.data().iter().enumerate() {
        let l = luminance(c);
        if sees(i) && l.is_finite() {
            sum += (LOG_AVERAGE_DELTA + f64::from(l.max(0.0))).ln();
            n += 1;
        }
    }
    (n > 0).then(|| (sum / n as f64).exp() as f32)
}

/// What an exposure decided for one displayed image: its stops and what it did to the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameExposure {
    /// The scale applied, in stops.
    pub stops: f32,
    /// Share of pixels whose brightest channel encodes to 255 after the exposure and curve.
    pub clipped_fraction: f32,
    /// Share of pixels that see no geometry (infinite depth).
    pub background_fraction: f32,
}

impl FrameExposure {
    /// Chooses the exposure of `color` (with its `depth`, ∞ where nothing was hit) as
    /// `exposure` asks and measures the result under `curve`.
    ///
    /// Auto: the log-average of the pixels that see geometry, or of all pixels when none
    /// does; 0 stops for a black frame. Auto and EV100 are clamped to ±[`MAX_STOPS`].
    pub fn measure(
        color: &Image<Rgb>,
        depth: &Image<f32>,
        exposure: Exposure,
        curve: ToneCurve,
    ) -> Self {
        let hit = |i: usize| depth.data().get(i).is_some_and(|d| d.is_finite());
        let stops = match exposure.fixed_stops() {
            Some(s) => s,
            None => {
                let avg = log_average_luminance(color, hit)
                    .or_else(|| log_average_luminance(color, |_| true));
                match avg {
                    Some(l) if l > 1e-5 => (AUTO_KEY / l).log2().clamp(-MAX_STOPS, MAX_STOPS),
                    _ => 0.0,
                }
            }
        };
        let k = 2f32.powf(stops);
        let n = color.data().len().max(1) as f32;
        let clipped = color
            .data()
            .iter()
            .filter(|c| encodes_to_white(c[0].max(c[1]).max(c[2]) * k, curve))
            .count();
        let background = (0..depth.data().len()).filter(|&i| !hit(i)).count();
        FrameExposure {
            stops,
            clipped_fraction: clipped as f32 / n,
            background_fraction: background as f32 / depth.data().len().max(1) as f32,
        }
    }
}

/// Whether an exposed linear value encodes to the top 8-bit sRGB code under `curve`.
fn encodes_to_white(x: f32, curve: ToneCurve) -> bool {
    if !x.is_finite() {
        return x > 0.0;
    }
    let x = x.max(0.0);
    let y = match curve {
        ToneCurve::Clamp => x,
        ToneCurve::Reinhard => x / (1.0 + x),
    };
    linear_to_srgb(y) * 255.0 + 0.5 >= 255.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[Rgb], w: u32) -> Image<Rgb> {
        Image::from_vec(w, values.len() as u32 / w, values.to_vec()).unwrap()
    }

    #[test]
    fn ev100_forward_and_inverse() {
        // Sunny 16 (EV100 = 15): 1 / (1.2 · 2^15) = 2.543e-5.
        assert!((2f32.powf(ev100_to_stops(15.0)) - 1.0 / (1.2 * 32768.0)).abs() < 1e-9);
        // EV100 = 0: 1/1.2.
        assert!((2f32.powf(ev100_to_stops(0.0)) - 1.0 / 1.2).abs() < 1e-6);
        for ev in [-6.0f32, 0.0, 9.5, 15.0, 20.0] {
            assert!((stops_to_ev100(ev100_to_stops(ev)) - ev).abs() < 1e-5);
        }
    }

    #[test]
    fn auto_exposure_puts_the_log_average_at_middle_grey() {
        // Luminances 1 and 100 (grey pixels): log-average 10 → stops log2(0.018).
        let img = image(&[[1.0; 3], [100.0; 3], [1.0; 3], [100.0; 3]], 2);
        let depth = Image::new(2, 2, 1.0f32).unwrap();
        let e = FrameExposure::measure(&img, &depth, Exposure::Auto, ToneCurve::Reinhard);
        let expected = (0.18f32 / 10.0).log2();
        assert!((e.stops - expected).abs() < 1e-4, "{e:?}");
        assert_eq!(e.background_fraction, 0.0);
        // 100 · 0.018 = 1.8 → Reinhard 0.64: nothing clips.
        assert_eq!(e.clipped_fraction, 0.0);
    }

    #[test]
    fn auto_exposure_ignores_the_background() {
        // A dim object (0.01) in front of a bright sky (1000): exposed for the object.
        let img = image(&[[0.01; 3], [1000.0; 3], [1000.0; 3], [1000.0; 3]], 2);
        let mut depth = Image::new(2, 2, f32::INFINITY).unwrap();
        depth.data_mut()[0] = 2.0;
        let e = FrameExposure::measure(&img, &depth, Exposure::Auto, ToneCurve::Clamp);
        assert!((e.stops - (0.18f32 / 0.01).log2()).abs() < 1e-3, "{e:?}");
        assert_eq!(e.background_fraction, 0.75);
        assert_eq!(e.clipped_fraction, 0.75);
    }

    #[test]
    fn clipping_counts_pixels_at_the_top_code() {
        let img = image(&[[0.5; 3], [0.999; 3], [2.0, 0.0, 0.0], [1e30; 3]], 2);
        let depth = Image::new(2, 2, 1.0f32).unwrap();
        let clamp = FrameExposure::measure(&img, &depth, Exposure::Stops(0.0), ToneCurve::Clamp);
        // 0.999 encodes to 255 (the top code starts at 0.99615), 2 and 1e30 clip too.
        assert_eq!(clamp.clipped_fraction, 0.75);
        let reinhard =
            FrameExposure::measure(&img, &depth, Exposure::Stops(0.0), ToneCurve::Reinhard);
        // Under Reinhard only values ≥ ~255 reach the top code.
        assert_eq!(reinhard.clipped_fraction, 0.25);
    }

    #[test]
    fn black_or_empty_frames_get_zero_stops() {
        let img = image(&[[0.0; 3]; 4], 2);
        let depth = Image::new(2, 2, f32::INFINITY).unwrap();
        let e = FrameExposure::measure(&img, &depth, Exposure::Auto, ToneCurve::Reinhard);
        assert_eq!(e.stops, 0.0);
        assert_eq!(e.background_fraction, 1.0);
    }

    #[test]
    fn luminance_of_white_is_one() {
        assert!((luminance([1.0; 3]) - 1.0).abs() < 1e-6);
    }
}
