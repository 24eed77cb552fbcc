//! The screen footprint of a mapping's samples (DESIGN.md "What quality depends on: the
//! sample footprint"): how far apart a mapping's samples lie at each eccentricity. It is a
//! property of the mapping alone, so it is computed here, once per frame plan, and read by the
//! stages that need it — the trace (ray-cone width for texture filtering), temporal
//! accumulation and peripheral contrast (sample spacing in pixels).
//!
//! * [`sample_spread_rad`]: the angle one sample spans, `1/(2√(ρ_r ρ_t))` degrees from the
//!   radial and tangential shading rates `ρ_r`, `ρ_t` (cycles per degree, VaFR Eq. 13 and
//!   20), clamped to `[1 screen pixel, 10°]` (one pixel where a pixel spans more than 10°,
//!   as on a 1x1 display).
//! * [`SampleFootprint`]: that angle per polar buffer column (a column lies at one
//!   eccentricity, VaFR Eq. 3) or one pixel for full resolution, and the fallback per sample.
//! * [`SpacingLut`]: sample spacing in screen pixels against eccentricity, the full-resolution
//!   shading rate over the mapping's, tabulated every 0.1°.

use serde::Serialize;

use super::{screen_rate_cpd, FoveationMapping, Method, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::units::ScreenPoint;

/// Largest angle one sample may span, degrees.
pub const MAX_SPREAD_DEG: f64 = 10.0;

/// Angle a sample of `mapping` spans at screen point `p`: its spacing `1/(2√(ρ_r ρ_t))`
/// degrees from the shading rates, at least one screen pixel (the full-resolution ray's
/// footprint, `1/f_px` rad) and at most [`MAX_SPREAD_DEG`] (unless one pixel is wider: then
/// one pixel). The lower bound matters where a mapping samples more densely than the screen
/// (VaFR near the gaze on low-resolution displays): detail finer than a pixel would be
/// resampled onto the pixel grid by the inverse mapping and alias into moiré, so textures
/// are filtered to the screen's Nyquist rate there, as in the full frame.
pub fn sample_spread_rad(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
    p: ScreenPoint,
) -> f32 {
    spread_with_floor_rad(mapping, display, gaze, p, 1.0 / display.focal_y_px())
}

/// [`sample_spread_rad`] with the lower bound `floor_rad` instead of one pixel: where the
/// reconstruction averages every texel a pixel covers (`ReconstructFilter::Footprint` of
/// `fovea-post`), a sample denser than the screen keeps its own, narrower cone, and the
/// reconstruction's box filters the detail to the pixel instead.
pub fn spread_with_floor_rad(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
    p: ScreenPoint,
    floor_rad: f64,
) -> f32 {
    let e = display.eccentricity(p, gaze).0;
    let rr = mapping.radial_rate_cpd(e);
    let rt = mapping.tangential_rate_cpd(e);
    let rate = (rr.max(0.0) * rt.max(0.0)).sqrt();
    let spacing_deg = if rate.is_finite() && rate > 0.0 {
        0.5 / rate
    } else if rr.is_finite() && rr > 0.0 {
        0.5 / rr
    } else {
        0.0
    };
    // `min` then `max` rather than `clamp`: on a tiny display one pixel spans more than
    // `MAX_SPREAD_DEG` (a 1x1 display with a 90° field of view: 1 pixel = 2 rad), and the pixel
    // wins. Wherever pixel ≤ 10° this is exactly `clamp(pixel_rad, 10°)`.
    spacing_deg
        .to_radians()
        .min(MAX_SPREAD_DEG.to_radians())
        .max(floor_rad) as f32
}

/// The ray-cone angle of every sample of one frame: one pixel at full resolution, one value
/// per column of a polar buffer, otherwise [`sample_spread_rad`] per sample.
#[derive(Clone, Debug, Serialize)]
pub struct SampleFootprint {
    /// One screen pixel, `1/f_y` rad.
    pub pixel_rad: f32,
    /// Full resolution: every sample spans one pixel.
    pub full: bool,
    /// Per column of a polar buffer, radians (`NaN` where the column's centre maps off the
    /// screen: those samples fall back to [`sample_spread_rad`]).
    pub column_rad: Option<Vec<f32>>,
    /// The narrowest cone, radians: one pixel ([`SampleFootprint::new`]) or less
    /// ([`SampleFootprint::with_floor`]).
    pub floor_rad: f32,
}

impl SampleFootprint {
    /// The footprint table of `mapping` on `display` at `gaze`.
    pub fn new(mapping: &dyn FoveationMapping, display: &DisplayProfile, gaze: &Gaze) -> Self {
        Self::with_floor(mapping, display, gaze, 1.0)
    }

    /// The footprint table with cones no narrower than `floor_px` screen pixels (1 in
    /// [`SampleFootprint::new`]; less where the reconstruction filters dense buffers to the
    /// pixel itself). Full resolution keeps one pixel.
    pub fn with_floor(
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        gaze: &Gaze,
        floor_px: f64,
    ) -> Self {
        let full = mapping.method() == Method::Full;
        let floor_rad = floor_px / display.focal_y_px();
        let column_rad = match (full, mapping.polar_layout()) {
            (false, Some(layout)) => Some(
                (0..layout.rows.len())
                    .map(|i| {
                        let s = SamplePoint {
                            layer: 0,
                            u: i as f64 + 0.5,
                            v: 0.5,
                        };
                        mapping.inverse(s).map_or(f32::NAN, |p| {
                            spread_with_floor_rad(mapping, display, gaze, p, floor_rad)
                        })
                    })
                    .collect(),
            ),
            _ => None,
        };
        Self {
            pixel_rad: (1.0 / display.focal_y_px()) as f32,
            full,
            column_rad,
            floor_rad: floor_rad as f32,
        }
    }

    /// The cone angle of the sample in column `column` whose screen point is `p`.
    #[inline]
    pub fn spread_rad(
        &self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        gaze: &Gaze,
        column: u32,
        p: ScreenPoint,
    ) -> f32 {
        self.column_spread_rad(column).unwrap_or_else(|| {
            spread_with_floor_rad(mapping, display, gaze, p, self.floor_rad as f64)
        })
    }

    /// The cone angle every sample of column `column` shares, where the table has it (or the
    /// pixel's at full resolution); `None`: ask [`Self::spread_rad`] with the sample's point.
    #[inline]
    pub fn column_spread_rad(&self, column: u32) -> Option<f32> {
        if self.full {
            return Some(self.pixel_rad);
        }
        self.column_rad
            .as_ref()
            .and_then(|c| c.get(column as usize))
            .copied()
            .filter(|s| s.is_finite())
    }
}

/// Sample spacing in screen pixels as a function of eccentricity: the full-resolution
/// shading rate over the mapping's (`1` where the mapping samples at least as densely as the
/// screen), tabulated every 0.1° out to 1° beyond the farthest screen corner.
#[derive(Clone, Debug, Serialize)]
pub struct SpacingLut {
    step_deg: f64,
    values: Vec<f32>,
}

impl SpacingLut {
    /// The table of `mapping` on `display` at `gaze`.
    pub fn new(mapping: &dyn FoveationMapping, display: &DisplayProfile, gaze: Gaze) -> Self {
        let c_r = display.c_r();
        let step_deg = 0.1;
        let e_max = display.farthest_corner_eccentricity(&gaze).0 + 1.0;
        let n = (e_max / step_deg).ceil() as usize + 2;
        let values = (0..n)
            .map(|k| {
                let e = k as f64 * step_deg;
                // The full-resolution mapping's radial and tangential rates are both the
                // screen's.
                let screen = screen_rate_cpd(c_r, e);
                let full_rate = (screen * screen).max(0.0).sqrt();
                let rate = (mapping.radial_rate_cpd(e) * mapping.tangential_rate_cpd(e))
                    .max(0.0)
                    .sqrt();
                if rate > 0.0 && full_rate.is_finite() && rate.is_finite() {
                    (full_rate / rate).max(1.0) as f32
                } else {
                    1.0
                }
            })
            .collect();
        Self { step_deg, values }
    }

    /// The largest spacing in the table, pixels.
    pub fn max(&self) -> f32 {
        self.values.iter().fold(1.0f32, |a, &b| a.max(b))
    }

    /// Spacing at eccentricity `e_deg`, pixels (linear interpolation, clamped).
    pub fn at(&self, e_deg: f64) -> f32 {
        let x = (e_deg.max(0.0) / self.step_deg).min((self.values.len() - 1) as f64);
        let k = (x.floor() as usize).min(self.values.len() - 2);
        let f = (x - k as f64) as f32;
        self.values[k] + (self.values[k + 1] - self.values[k]) * f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{build, MappingConfig};
    use crate::units::Degrees;

    fn display() -> DisplayProfile {
        DisplayProfile::new("t", 1440, 1600, Degrees(100.0), Degrees(110.0)).unwrap()
    }

    #[test]
    fn full_resolution_spacing_is_one_pixel_everywhere() {
        let d = display();
        let g = d.centre_gaze();
        let m = build(Method::Full, &d, g, &MappingConfig::default()).unwrap();
        let lut = SpacingLut::new(m.as_ref(), &d, g);
        for e in [0.0, 10.0, 30.0, 60.0] {
            assert!((lut.at(e) - 1.0).abs() < 1e-5, "{e}: {}", lut.at(e));
        }
        let f = SampleFootprint::new(m.as_ref(), &d, &g);
        assert!(f.full && f.column_rad.is_none());
        assert_eq!(f.pixel_rad, (1.0 / d.focal_y_px()) as f32);
    }

    #[test]
    fn vafr_columns_spread_like_the_per_sample_formula_and_grow_outward() {
        let d = display();
        let g = d.gaze(500.0, 900.0).unwrap();
        let m = build(Method::Vafr, &d, g, &MappingConfig::default()).unwrap();
        let f = SampleFootprint::new(m.as_ref(), &d, &g);
        let cols = f.column_rad.as_ref().unwrap();
        // Brute force: every column's value equals the per-sample formula at its centre.
        for (i, &c) in cols.iter().enumerate().step_by(37) {
            let p = m.inverse(SamplePoint::new(i as f64 + 0.5, 0.5)).unwrap();
            assert_eq!(c, sample_spread_rad(m.as_ref(), &d, &g, p));
        }
        // Clamped between one pixel and 10°; wider at the last column than at the first.
        assert!(cols
            .iter()
            .all(|&c| c >= f.pixel_rad && c <= 10f32.to_radians()));
        assert!(cols[cols.len() - 1] > cols[0]);
        // The spacing table agrees: ≥ 1 pixel, growing with eccentricity beyond the fovea.
        let lut = SpacingLut::new(m.as_ref(), &d, g);
        assert!(lut.at(40.0) > lut.at(20.0) && lut.at(20.0) >= 1.0);
        assert!(lut.max() >= lut.at(40.0));
    }
}
