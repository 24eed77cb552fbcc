//! Temporal flicker of a foveated sequence against the full-resolution sequence, by
//! eccentricity band.
//!
//! Peripheral vision is most sensitive to temporal change, so the visible artifact of sparse
//! or log-polar sampling in motion is the change from frame to frame that the scene itself does
//! not make. For frame `t ≥ 1` with display-encoded luma `Y` (Reinhard tone curve, 8-bit sRGB,
//! Rec. 601, in [0, 1]; see [`crate::metrics`]) of the test sequence and `R` of the full-resolution reference, the temporal
//! differences are `ΔY = Y_t − Y_{t−1}` and `ΔR = R_t − R_{t−1}`, and per band `b` of
//! eccentricity (from frame `t`'s gaze)
//!
//! * **flicker** `F_b(t) = mean_{b}((ΔY − ΔR)²)`: energy of the temporal change the reference
//!   does not have — shimmer, crawling, popping of the sampling pattern;
//! * **temporal energy** `E_b(t) = mean_{b}(ΔY²)` and the reference's `mean_{b}(ΔR²)`.
//!
//! Reports give per band the mean over frames and its root (`rms`, in luma units ×100, i.e.
//! percent of the display range). "Peripheral" means eccentricity ≥ 20° by default (beyond
//! Weier's transition region `r₁`).

use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::{FoveaError, Image, Result};
use fovea_post::Rgb;

use crate::bands::{band_index, check_edges, pixel_eccentricities};
use crate::metrics::encoded_luma;

/// Default band edges, degrees (the last band is open).
pub const DEFAULT_BANDS_DEG: [f64; 5] = [0.0, 5.0, 10.0, 20.0, 30.0];

/// Default start of the periphery, degrees.
pub const PERIPHERY_DEG: f64 = 20.0;

/// One band's totals.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BandFlicker {
    /// Lower edge, degrees.
    pub lo_deg: f64,
    /// Upper edge, degrees (`null` for the open last band).
    pub hi_deg: Option<f64>,
    /// Frame differences counted.
    pub frames: u64,
    /// Mean over frames of `mean((ΔY − ΔR)²)`.
    pub flicker: f64,
    /// `100·√flicker`, percent of the display range.
    pub flicker_rms_pct: f64,
    /// Mean over frames of `mean(ΔY²)`.
    pub temporal_energy: f64,
    /// Mean over frames of the reference's `mean(ΔR²)`.
    pub reference_energy: f64,
}

/// Flicker of one frame difference.
#[derive(Clone, Debug, Serialize)]
pub struct FrameFlicker {
    /// Frame index `t` (the difference `t − 1 → t`).
    pub frame: u64,
    /// `mean((ΔY − ΔR)²)` per band (`NaN` for empty bands).
    pub flicker: Vec<f64>,
    /// The same over the periphery.
    pub peripheral: f64,
}

/// The report of a sequence.
#[derive(Clone, Debug, Serialize)]
pub struct FlickerReport {
    /// Per band.
    pub bands: Vec<BandFlicker>,
    /// The periphery (eccentricity ≥ `periphery_deg`).
    pub periphery: BandFlicker,
    /// Start of the periphery, degrees.
    pub periphery_deg: f64,
    /// Per frame.
    pub frames: Vec<FrameFlicker>,
}

/// Accumulates flicker frame by frame.
pub struct FlickerMeter {
    display: DisplayProfile,
    edges: Vec<f64>,
    periphery_deg: f64,
    prev: Option<(Vec<f64>, Vec<f64>)>,
    sums: Vec<[f64; 3]>,
    periphery: [f64; 3],
    counts: Vec<u64>,
    periphery_count: u64,
    frame: u64,
    frames: Vec<FrameFlicker>,
}

impl FlickerMeter {
    /// A meter for `display` with band edges `edges` (ascending, starting at 0).
    pub fn new(display: &DisplayProfile, edges: &[f64], periphery_deg: f64) -> Result<Self> {
        display.validate()?;
        check_edges(edges)?;
        if !(periphery_deg.is_finite() && periphery_deg >= 0.0) {
            return Err(FoveaError::invalid(
                "periphery",
                periphery_deg,
                "an eccentricity ≥ 0 degrees",
            ));
        }
        Ok(Self {
            display: display.clone(),
            edges: edges.to_vec(),
            periphery_deg,
            prev: None,
            sums: vec![[0.0; 3]; edges.len()],
            periphery: [0.0; 3],
            counts: vec![0; edges.len()],
            periphery_count: 0,
            frame: 0,
            frames: Vec::new(),
        })
    }

    /// Adds the next frame of the test and reference sequences, seen with `gaze`.
    pub fn push(&mut self, test: &Image<Rgb>, reference: &Image<Rgb>, gaze: &Gaze) -> Result<()> {
        let (w, h) = (self.display.width_px, self.display.height_px);
        for (name, im) in [("test frame", test), ("reference frame", reference)] {
            if im.width() != w || im.height() != h {
                return Err(FoveaError::invalid(
                    name,
                    format!("{}×{}", im.width(), im.height()),
                    format!("the display's {w}×{h}"),
                ));
            }
        }
        let (y, r) = (encoded_luma(test), encoded_luma(reference));
        let frame = self.frame;
        self.frame += 1;
        let Some((py, pr)) = self.prev.replace((y, r)) else {
            return Ok(());
        };
        let (y, r) = self.prev.as_ref().expect("just set");
        let nb = self.edges.len();
        let mut acc = vec![[0.0f64; 3]; nb];
        let mut n = vec![0u64; nb];
        let mut pacc = [0.0f64; 3];
        let mut pn = 0u64;
        for (k, e) in pixel_eccentricities(&self.display, gaze)
            .into_iter()
            .enumerate()
        {
            let b = band_index(&self.edges, e);
            let (dy, dr) = (y[k] - py[k], r[k] - pr[k]);
            let v = [(dy - dr) * (dy - dr), dy * dy, dr * dr];
            for (a, x) in acc[b].iter_mut().zip(v) {
                *a += x;
            }
            n[b] += 1;
            if e >= self.periphery_deg {
                for (a, x) in pacc.iter_mut().zip(v) {
                    *a += x;
                }
                pn += 1;
            }
        }
        let mut per_band = Vec::with_capacity(nb);
        for b in 0..nb {
            if n[b] > 0 {
                for (s, a) in self.sums[b].iter_mut().zip(acc[b]) {
                    *s += a / n[b] as f64;
                }
                self.counts[b] += 1;
                per_band.push(acc[b][0] / n[b] as f64);
            } else {
                per_band.push(f64::NAN);
            }
        }
        let peripheral = if pn > 0 {
            for (s, a) in self.periphery.iter_mut().zip(pacc) {
                *s += a / pn as f64;
            }
            self.periphery_count += 1;
            pacc[0] / pn as f64
        } else {
            f64::NAN
        };
        self.frames.push(FrameFlicker {
            frame,
            flicker: per_band,
            peripheral,
        });
        Ok(())
    }

    /// The report so far.
    pub fn report(&self) -> FlickerReport {
        let band = |lo: f64, hi: Option<f64>, s: &[f64; 3], n: u64| {
            let m = |v: f64| if n > 0 { v / n as f64 } else { f64::NAN };
            BandFlicker {
                lo_deg: lo,
                hi_deg: hi,
                frames: n,
                flicker: m(s[0]),
                flicker_rms_pct: 100.0 * m(s[0]).sqrt(),
                temporal_energy: m(s[1]),
                reference_energy: m(s[2]),
            }
        };
        let bands = (0..self.edges.len())
            .map(|b| {
                band(
                    self.edges[b],
                    self.edges.get(b + 1).copied(),
                    &self.sums[b],
                    self.counts[b],
                )
            })
            .collect();
        FlickerReport {
            bands,
            periphery: band(
                self.periphery_deg,
                None,
                &self.periphery,
                self.periphery_count,
            ),
            periphery_deg: self.periphery_deg,
            frames: self.frames.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::units::ScreenPoint;

    fn display() -> DisplayProfile {
        DisplayProfile::with_vertical_fov("t", 64, 48, fovea_core::units::Degrees(90.0)).unwrap()
    }

    fn flat(v: f32) -> Image<Rgb> {
        Image::new(64, 48, [v; 3]).unwrap()
    }

    #[test]
    fn identical_sequences_do_not_flicker() {
        let d = display();
        let g = d.centre_gaze();
        let mut m = FlickerMeter::new(&d, &DEFAULT_BANDS_DEG, PERIPHERY_DEG).unwrap();
        for t in 0..4 {
            let f = flat(0.1 * t as f32);
            m.push(&f, &f, &g).unwrap();
        }
        let r = m.report();
        assert_eq!(r.periphery.frames, 3);
        assert_eq!(r.periphery.flicker, 0.0);
        assert!(r.periphery.temporal_energy > 0.0);
        assert_eq!(r.periphery.temporal_energy, r.periphery.reference_energy);
    }

    #[test]
    fn a_toggling_pixel_block_is_measured_in_its_band() {
        // Reference still; the test toggles the left 8 columns (far periphery) between two
        // grey levels: flicker = fraction of the band's pixels × Δ².
        let d = display();
        let g = d.centre_gaze();
        let mut m = FlickerMeter::new(&d, &[0.0, 30.0], 30.0).unwrap();
        let reference = flat(0.5);
        for t in 0..5 {
            let mut f = flat(0.5);
            if t % 2 == 1 {
                for y in 0..48 {
                    for x in 0..8 {
                        *f.get_mut(x, y) = [1.0; 3];
                    }
                }
            }
            m.push(&f, &reference, &g).unwrap();
        }
        let r = m.report();
        // Inner band: untouched.
        assert_eq!(r.bands[0].flicker, 0.0);
        // Outer band: Δ in encoded luma, fraction of the band's pixels.
        // Encoded as the metrics see it: Reinhard tone curve, then 8-bit sRGB.
        let enc = |v: f32| {
            (fovea_post::tonemap::linear_to_srgb(v / (1.0 + v)) * 255.0).round() as f64 / 255.0
        };
        let delta = enc(1.0) - enc(0.5);
        let mut outer = 0u64;
        for y in 0..48u32 {
            for x in 0..64u32 {
                let e = d
                    .eccentricity(ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5), &g)
                    .0;
                outer += (e >= 30.0) as u64;
            }
        }
        let expect = delta * delta * (8.0 * 48.0) / outer as f64;
        assert!(
            (r.bands[1].flicker - expect).abs() < 1e-9 * expect.max(1.0),
            "{} vs {expect}",
            r.bands[1].flicker
        );
        assert_eq!(r.periphery.flicker, r.bands[1].flicker);
        assert_eq!(r.frames.len(), 4);
    }

    #[test]
    fn bad_input_is_an_error() {
        let d = display();
        assert!(FlickerMeter::new(&d, &[1.0, 2.0], 20.0).is_err());
        assert!(FlickerMeter::new(&d, &[0.0, 0.0], 20.0).is_err());
        assert!(FlickerMeter::new(&d, &[0.0], f64::NAN).is_err());
        let mut m = FlickerMeter::new(&d, &DEFAULT_BANDS_DEG, 20.0).unwrap();
        let small = Image::new(8, 8, [0.0f32; 3]).unwrap();
        assert!(m.push(&small, &flat(0.0), &d.centre_gaze()).is_err());
    }
}
