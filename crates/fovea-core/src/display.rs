//! Display geometry: per-eye resolution, field of view, pixels per degree, and the conversion
//! between screen pixels and eccentricity for a gaze point (VaFR Eq. 3).
//!
//! The screen is modelled as a rectilinear (pinhole) image plane, which is what a renderer
//! draws before the HMD's lens-distortion pass. Its constant `c_r` (VaFR Sec. 3.2.1) is the
//! film height divided by the focal length, divided by the display height in pixels:
//! `c_r = 2·tan(vfov/2) / H`, so that a point `r` pixels from the gaze point lies at
//! eccentricity `e = atan(c_r·r)` (Eq. 3). Like the paper, Eq. 3 treats the gaze point as if it
//! were on the optical axis; [`DisplayProfile::eccentricity_exact`] gives the true angle between
//! the gaze ray and a pixel's ray for comparison.

use serde::{Deserialize, Serialize};

use crate::error::{check_range_open_lo, FoveaError, Result};
use crate::units::{Degrees, ScreenPoint};

/// Largest accepted per-eye resolution along one axis (a 16K-per-eye panel is 15360 wide).
pub const MAX_RESOLUTION_PX: u32 = 32_768;

/// How far (as a fraction of the screen size) a gaze point may lie outside the screen before it
/// is rejected. Eye trackers report slightly off-screen points near the border; anything farther
/// is a tracking failure, not a gaze.
pub const GAZE_MARGIN_FRACTION: f64 = 0.05;

/// A per-eye display profile of an HMD, or a flat test resolution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DisplayProfile {
    /// Preset or user name.
    pub name: String,
    /// Horizontal resolution per eye in pixels.
    pub width_px: u32,
    /// Vertical resolution per eye in pixels.
    pub height_px: u32,
    /// Horizontal field of view of the rectilinear render target, degrees, in (0, 180).
    pub hfov: Degrees,
    /// Vertical field of view of the rectilinear render target, degrees, in (0, 180).
    pub vfov: Degrees,
    /// Where the optical axis meets the screen, in pixels (HMD lenses are often off-centre).
    /// `None` means the screen centre.
    pub lens_centre_px: Option<ScreenPoint>,
    /// The panel's pixels per degree at the lens centre as stated by the manufacturer, when the
    /// HMD's lens is not rectilinear and the rectilinear figure would misstate it. `None` means
    /// the rectilinear value `1 / (c_r · 180/π)`.
    pub peak_ppd: Option<f64>,
}

/// Names accepted by [`DisplayProfile::preset`].
pub const PRESET_NAMES: &[&str] = &[
    "vive-pro-eye",
    "pimax-crystal",
    "varjo-xr4",
    "2k",
    "4k",
    "6k",
    "8k",
    "retinal",
];

/// The VaFR test resolutions (Table 1), in order.
pub const VAFR_TEST_PRESETS: &[&str] = &["2k", "4k", "6k", "8k", "retinal"];

impl DisplayProfile {
    /// A validated profile with the optical axis at the screen centre.
    pub fn new(
        name: impl Into<String>,
        width_px: u32,
        height_px: u32,
        hfov: Degrees,
        vfov: Degrees,
    ) -> Result<Self> {
        let p = Self {
            name: name.into(),
            width_px,
            height_px,
            hfov,
            vfov,
            lens_centre_px: None,
            peak_ppd: None,
        };
        p.validate()?;
        Ok(p)
    }

    /// A flat display of `width_px × height_px` with square pixels and the given vertical field
    /// of view; the horizontal field of view follows from the aspect ratio.
    pub fn with_vertical_fov(
        name: impl Into<String>,
        width_px: u32,
        height_px: u32,
        vfov: Degrees,
    ) -> Result<Self> {
        check_range_open_lo("vfov", vfov.0, 0.0, 179.0)?;
        check_resolution(width_px, height_px)?;
        let half_v = (vfov.0 / 2.0).to_radians().tan();
        let half_h = half_v * width_px as f64 / height_px as f64;
        Self::new(
            name,
            width_px,
            height_px,
            Degrees(2.0 * half_h.atan().to_degrees()),
            vfov,
        )
    }

    /// Checks every field; returns a typed error naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        check_resolution(self.width_px, self.height_px)?;
        check_range_open_lo("hfov", self.hfov.0, 0.0, 179.0)?;
        check_range_open_lo("vfov", self.vfov.0, 0.0, 179.0)?;
        if let Some(c) = self.lens_centre_px {
            if !(c.x_px.is_finite() && c.y_px.is_finite())
                || c.x_px < 0.0
                || c.y_px < 0.0
                || c.x_px > self.width_px as f64
                || c.y_px > self.height_px as f64
            {
                return Err(FoveaError::invalid(
                    "lens_centre",
                    format!("{},{}", c.x_px, c.y_px),
                    format!("a point on the {}×{} screen", self.width_px, self.height_px),
                ));
            }
        }
        if let Some(ppd) = self.peak_ppd {
            check_range_open_lo("peak_ppd", ppd, 0.0, 1000.0)?;
        }
        Ok(())
    }

    /// A named preset (see [`PRESET_NAMES`]). Every preset has square pixels: one focal
    /// length across and down, so pixels per degree and eccentricities agree on both axes.
    ///
    /// * `vive-pro-eye`: HTC Vive Pro Eye, 1440×1600 per eye; its published per-eye field of
    ///   about 100°×110° would need 604 px of focal length across and 560 down (non-square
    ///   pixels), so the target keeps 110° down and is 104.2° across (it covers the published
    ///   field on both axes). VaFR (Sec. 3.3, Fig. 3) states its display at 9 cpd, i.e. 18 ppd
    ///   at the lens centre.
    /// * `pimax-crystal`: 2880×2880 per eye, about 105°×105° per eye, about 35 ppd at the
    ///   centre (VaFR Fig. 3: 18 cpd).
    /// * `varjo-xr4`: 3840×3744 per eye, published 120°×105°; square pixels with 120° across
    ///   give 118.7° down (again covering the published field on both axes).
    /// * `2k` … `retinal`: the VaFR test resolutions 2560×1440, 3840×2160, 5760×3240,
    ///   7680×4320 and 11520×6480 on a flat display with a 90° vertical field of view
    ///   (square pixels, so about 121° horizontally: the paper's "120° horizontally").
    pub fn preset(name: &str) -> Result<Self> {
        let lower = name.to_ascii_lowercase();
        let flat = |w: u32, h: u32| Self::with_vertical_fov(lower.clone(), w, h, Degrees(90.0));
        let headset = |name: &str, w: u32, h: u32, hfov: f64, vfov: f64, peak_ppd| {
            Ok(Self {
                peak_ppd,
                ..Self::covering(name, w, h, Degrees(hfov), Degrees(vfov))?
            })
        };
        match lower.as_str() {
            "vive-pro-eye" | "vive" => {
                headset("vive-pro-eye", 1440, 1600, 100.0, 110.0, Some(18.0))
            }
            "pimax-crystal" | "pimax" => {
                headset("pimax-crystal", 2880, 2880, 105.0, 105.0, Some(35.0))
            }
            "varjo-xr4" | "varjo-xr-4" | "xr4" => {
                headset("varjo-xr4", 3840, 3744, 120.0, 105.0, None)
            }
            "2k" => flat(2560, 1440),
            "4k" => flat(3840, 2160),
            "6k" => flat(5760, 3240),
            "8k" => flat(7680, 4320),
            "retinal" => flat(11520, 6480),
            _ => Err(FoveaError::invalid(
                "headset",
                name,
                format!("one of {}", PRESET_NAMES.join(", ")),
            )),
        }
    }

    /// A display of `width_px × height_px` with square pixels whose rectilinear field of view
    /// covers at least `hfov` across and `vfov` down: the shorter of the two focal lengths
    /// those angles need, so one axis has exactly its angle and the other at least its own.
    pub fn covering(
        name: impl Into<String>,
        width_px: u32,
        height_px: u32,
        hfov: Degrees,
        vfov: Degrees,
    ) -> Result<Self> {
        check_range_open_lo("hfov", hfov.0, 0.0, 179.0)?;
        check_range_open_lo("vfov", vfov.0, 0.0, 179.0)?;
        check_resolution(width_px, height_px)?;
        let fx = width_px as f64 / 2.0 / (hfov.0 / 2.0).to_radians().tan();
        let fy = height_px as f64 / 2.0 / (vfov.0 / 2.0).to_radians().tan();
        let f = fx.min(fy);
        let angle = |px: u32| Degrees(2.0 * (px as f64 / 2.0 / f).atan().to_degrees());
        Self::new(name, width_px, height_px, angle(width_px), angle(height_px))
    }

    /// All presets, in the order of [`PRESET_NAMES`].
    pub fn presets() -> Vec<Self> {
        PRESET_NAMES
            .iter()
            .map(|n| Self::preset(n).expect("built-in presets are valid"))
            .collect()
    }

    /// Number of pixels per eye.
    pub fn pixel_count(&self) -> u64 {
        self.width_px as u64 * self.height_px as u64
    }

    /// VaFR's `c_r` (Sec. 3.2.1): film height over focal length, over the height in pixels.
    /// Its reciprocal is the focal length in pixels.
    pub fn c_r(&self) -> f64 {
        2.0 * (self.vfov.0 / 2.0).to_radians().tan() / self.height_px as f64
    }

    /// Horizontal focal length in pixels of the rectilinear render target.
    pub fn focal_x_px(&self) -> f64 {
        self.width_px as f64 / 2.0 / (self.hfov.0 / 2.0).to_radians().tan()
    }

    /// Vertical focal length in pixels (`1 / c_r`).
    pub fn focal_y_px(&self) -> f64 {
        1.0 / self.c_r()
    }

    /// Pixels per degree at the centre of the rectilinear target along each axis,
    /// `(f_x, f_y)·π/180`: equal for square pixels.
    pub fn centre_ppd_axes(&self) -> (f64, f64) {
        let k = std::f64::consts::PI / 180.0;
        (self.focal_x_px() * k, self.focal_y_px() * k)
    }

    /// Where the optical axis meets the screen.
    pub fn principal_point(&self) -> ScreenPoint {
        self.lens_centre_px.unwrap_or(ScreenPoint::new(
            self.width_px as f64 / 2.0,
            self.height_px as f64 / 2.0,
        ))
    }

    /// Pixels per degree at the lens centre: the manufacturer's figure if the profile has one,
    /// otherwise that of the rectilinear target, `π / (180 · c_r)`.
    pub fn ppd(&self) -> f64 {
        self.peak_ppd
            .unwrap_or_else(|| self.rectilinear_ppd(Degrees(0.0)))
    }

    /// The display's own limit in cycles per degree at the lens centre (half its ppd).
    pub fn nyquist_cpd(&self) -> f64 {
        self.ppd() / 2.0
    }

    /// Radial pixels per degree of the rectilinear target at eccentricity `e` (from Eq. 7:
    /// `dr/de = 1 / (c_r · cos²e) · π/180`).
    pub fn rectilinear_ppd(&self, e: Degrees) -> f64 {
        let c = e.to_radians().cos();
        std::f64::consts::PI / 180.0 / (self.c_r() * c * c)
    }

    /// Validates a gaze point: finite, and on the screen or within
    /// [`GAZE_MARGIN_FRACTION`] of it.
    pub fn gaze(&self, x_px: f64, y_px: f64) -> Result<Gaze> {
        let w = self.width_px as f64;
        let h = self.height_px as f64;
        let (mx, my) = (w * GAZE_MARGIN_FRACTION, h * GAZE_MARGIN_FRACTION);
        if !(x_px.is_finite() && y_px.is_finite())
            || x_px < -mx
            || x_px > w + mx
            || y_px < -my
            || y_px > h + my
        {
            return Err(FoveaError::invalid(
                "gaze",
                format!("{x_px},{y_px}"),
                format!(
                    "a finite point on the {}×{} screen (x in [{:.0}, {:.0}], y in [{:.0}, {:.0}] px)",
                    self.width_px, self.height_px, -mx, w + mx, -my, h + my
                ),
            ));
        }
        Ok(Gaze {
            point: ScreenPoint::new(x_px, y_px),
        })
    }

    /// The gaze at the screen centre.
    pub fn centre_gaze(&self) -> Gaze {
        Gaze {
            point: ScreenPoint::new(self.width_px as f64 / 2.0, self.height_px as f64 / 2.0),
        }
    }

    /// Eccentricity of screen point `p` for gaze `g`, VaFR Eq. 3: `e = atan(c_r · r)` with `r`
    /// the pixel distance from the gaze point.
    pub fn eccentricity(&self, p: ScreenPoint, g: &Gaze) -> Degrees {
        Degrees(eccentricity_deg(self.c_r(), p.distance(g.point)))
    }

    /// Pixel distance from the gaze point at which Eq. 3 gives eccentricity `e`:
    /// `r = tan(e) / c_r`.
    pub fn radius_px(&self, e: Degrees) -> f64 {
        e.to_radians().tan() / self.c_r()
    }

    /// The true angle between the eye's ray through the gaze point and its ray through `p`,
    /// for the rectilinear target with the eye on the optical axis through the principal point.
    /// Equals [`Self::eccentricity`] when the gaze is at the principal point.
    pub fn eccentricity_exact(&self, p: ScreenPoint, g: &Gaze) -> Degrees {
        Degrees(crate::math::angle_between_deg(
            self.eye_direction(p),
            self.eye_direction(g.point),
        ))
    }

    /// The unit direction of the eye's ray through screen point `p` (eye space: `x` right,
    /// `y` down the screen, `z` along the optical axis through the principal point).
    pub fn eye_direction(&self, p: ScreenPoint) -> [f64; 3] {
        let c = self.principal_point();
        let v = [
            (p.x_px - c.x_px) / self.focal_x_px(),
            (p.y_px - c.y_px) / self.focal_y_px(),
            1.0,
        ];
        let n = (v[0] * v[0] + v[1] * v[1] + 1.0).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    }

    /// Distance in pixels from the gaze point to the farthest screen corner.
    pub fn farthest_corner_px(&self, g: &Gaze) -> f64 {
        let (w, h) = (self.width_px as f64, self.height_px as f64);
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(x, y)| g.point.distance(ScreenPoint::new(x, y)))
            .fold(0.0, f64::max)
    }

    /// Eccentricity (Eq. 3) of the farthest screen corner for gaze `g`.
    pub fn farthest_corner_eccentricity(&self, g: &Gaze) -> Degrees {
        Degrees(eccentricity_deg(self.c_r(), self.farthest_corner_px(g)))
    }
}

/// A validated gaze point (point of regard) on the screen, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gaze {
    /// The point of regard.
    pub point: ScreenPoint,
}

/// VaFR Eq. 3 in degrees: `atan(c_r · r_px)`.
#[inline]
pub fn eccentricity_deg(c_r: f64, r_px: f64) -> f64 {
    (c_r * r_px).atan().to_degrees()
}

fn check_resolution(w: u32, h: u32) -> Result<()> {
    for (name, v) in [("width", w), ("height", h)] {
        if v == 0 || v > MAX_RESOLUTION_PX {
            return Err(FoveaError::invalid(
                name,
                v,
                format!("a resolution in [1, {MAX_RESOLUTION_PX}] pixels"),
            ));
        }
    }
    Ok(())
}

/// Parses `WxH` (also `W×H`, `W,H`) into a resolution.
pub fn parse_resolution(text: &str) -> Result<(u32, u32)> {
    let bad = || {
        FoveaError::invalid(
            "res",
            text,
            format!("WIDTHxHEIGHT with both in [1, {MAX_RESOLUTION_PX}], e.g. 2560x1440"),
        )
    };
    let parts: Vec<&str> = text.split(['x', 'X', '×', ',']).map(str::trim).collect();
    if parts.len() != 2 {
        return Err(bad());
    }
    let w: u32 = parts[0].parse().map_err(|_| bad())?;
    let h: u32 = parts[1].parse().map_err(|_| bad())?;
    check_resolution(w, h).map_err(|_| bad())?;
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_valid_and_named() {
        for p in DisplayProfile::presets() {
            p.validate().unwrap();
        }
        let xr4 = DisplayProfile::preset("varjo-xr4").unwrap();
        assert_eq!((xr4.width_px, xr4.height_px), (3840, 3744));
        let retinal = DisplayProfile::preset("retinal").unwrap();
        assert_eq!(retinal.pixel_count(), 74_649_600);
        // 90° vertical with square pixels gives about 121° horizontally.
        assert!((retinal.hfov.0 - 121.28).abs() < 0.05, "{}", retinal.hfov.0);
    }

    #[test]
    fn presets_have_square_pixels() {
        for p in DisplayProfile::presets() {
            let (x, y) = p.centre_ppd_axes();
            assert!((x / y - 1.0).abs() < 0.01, "{}: {x} vs {y} px/deg", p.name);
        }
        // The headsets cover their published per-eye fields on both axes, one exactly.
        for (name, h, v) in [
            ("vive-pro-eye", 100.0, 110.0),
            ("pimax-crystal", 105.0, 105.0),
            ("varjo-xr4", 120.0, 105.0),
        ] {
            let p = DisplayProfile::preset(name).unwrap();
            assert!(p.hfov.0 >= h - 1e-9 && p.vfov.0 >= v - 1e-9, "{name}");
            assert!(
                (p.hfov.0 - h).abs() < 1e-9 || (p.vfov.0 - v).abs() < 1e-9,
                "{name}"
            );
        }
        let vive = DisplayProfile::preset("vive-pro-eye").unwrap();
        assert!((vive.hfov.0 - 104.23).abs() < 0.01, "{}", vive.hfov.0);
        let xr4 = DisplayProfile::preset("varjo-xr4").unwrap();
        assert!((xr4.vfov.0 - 118.74).abs() < 0.01, "{}", xr4.vfov.0);
    }

    #[test]
    fn eq3_round_trip_and_centre_agreement() {
        let d = DisplayProfile::preset("2k").unwrap();
        let g = d.centre_gaze();
        for e in [0.5, 5.0, 20.0, 44.0] {
            let r = d.radius_px(Degrees(e));
            let p = ScreenPoint::new(g.point.x_px + r, g.point.y_px);
            assert!((d.eccentricity(p, &g).0 - e).abs() < 1e-9);
            // Gaze at the principal point: Eq. 3 is exact.
            assert!((d.eccentricity_exact(p, &g).0 - e).abs() < 1e-9);
        }
        // 45° vertical half-FOV: the top edge centre is at 45°.
        let top = ScreenPoint::new(g.point.x_px, 0.0);
        assert!((d.eccentricity(top, &g).0 - 45.0).abs() < 1e-9);
    }

    #[test]
    fn ppd_matches_rectilinear_and_peak() {
        let d = DisplayProfile::preset("2k").unwrap();
        let f = d.focal_y_px();
        assert!((d.ppd() - f * std::f64::consts::PI / 180.0).abs() < 1e-9);
        assert_eq!(DisplayProfile::preset("vive-pro-eye").unwrap().ppd(), 18.0);
    }

    #[test]
    fn invalid_inputs_are_typed_errors() {
        let e = DisplayProfile::new("x", 0, 10, Degrees(90.0), Degrees(90.0)).unwrap_err();
        assert!(e.to_string().contains("width"), "{e}");
        let e = DisplayProfile::new("x", 10, 10, Degrees(-5.0), Degrees(90.0)).unwrap_err();
        assert!(
            e.to_string().contains("hfov") && e.to_string().contains("-5"),
            "{e}"
        );
        let d = DisplayProfile::preset("2k").unwrap();
        assert!(d.gaze(f64::NAN, 3.0).is_err());
        assert!(d.gaze(1e6, 3.0).unwrap_err().to_string().contains("gaze"));
        assert!(
            d.gaze(-10.0, 3.0).is_ok(),
            "slightly off-screen is tolerated"
        );
        assert!(DisplayProfile::preset("nope").is_err());
        assert_eq!(parse_resolution("2560x1440").unwrap(), (2560, 1440));
        assert!(parse_resolution("0x10").is_err());
        assert!(parse_resolution("abc").is_err());
    }
}
