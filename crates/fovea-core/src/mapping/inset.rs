//! Inset foveation (Liu et al., "inset boundary smoothing"): a high-resolution inset of
//! `1/4 × 1/4` of the frame, rendered at full resolution, over a periphery rendered at `1/4`
//! resolution per axis and upsampled. The inset is fixed at the screen centre (fixed foveated
//! rendering) or follows the gaze (dynamic), clamped to stay on the screen.
//!
//! Shading rates are reported along the direction from the gaze to the farthest screen corner.

use serde::{Deserialize, Serialize};

use super::layered::{delegate_to_layers, Layer, Layers, Region};
use super::{BufferSize, FoveationMapping, Method, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::error::{check_range, Result};
use crate::units::ScreenPoint;

/// Parameters of inset foveation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct InsetParams {
    /// Inset width and height as a fraction of the frame's (the paper: 1/4).
    pub inset_fraction: f64,
    /// Periphery downscale per axis (the paper: 4).
    pub periphery_scale: f64,
    /// `true`: the inset follows the gaze; `false`: fixed at the screen centre.
    pub dynamic: bool,
}

impl Default for InsetParams {
    fn default() -> Self {
        Self {
            inset_fraction: 0.25,
            periphery_scale: 4.0,
            dynamic: true,
        }
    }
}

/// The inset mapping for one display and gaze.
pub struct Inset {
    params: InsetParams,
    layers: Layers,
    inset_origin: ScreenPoint,
}

impl Inset {
    /// Builds the mapping; `inset_fraction` must be in (0, 1], `periphery_scale` in [1, 64].
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: InsetParams) -> Result<Self> {
        display.validate()?;
        crate::error::check_range_open_lo("inset_fraction", params.inset_fraction, 0.0, 1.0)?;
        check_range("periphery_scale", params.periphery_scale, 1.0, 64.0)?;
        let (w, h) = (display.width_px as f64, display.height_px as f64);
        let (iw, ih) = (
            (w * params.inset_fraction).round().max(1.0),
            (h * params.inset_fraction).round().max(1.0),
        );
        let centre = if params.dynamic {
            gaze.point
        } else {
            ScreenPoint::new(w / 2.0, h / 2.0)
        };
        let origin = ScreenPoint::new(
            (centre.x_px - iw / 2.0).round().clamp(0.0, w - iw),
            (centre.y_px - ih / 2.0).round().clamp(0.0, h - ih),
        );
        let layers = vec![
            Layer {
                origin,
                width_px: iw,
                height_px: ih,
                scale: 1.0,
                region: Region::Rect,
            },
            Layer {
                origin: ScreenPoint::new(0.0, 0.0),
                width_px: w,
                height_px: h,
                scale: params.periphery_scale,
                region: Region::Rect,
            },
        ];
        Ok(Self {
            layers: Layers::new(display, gaze.point, layers),
            params,
            inset_origin: origin,
        })
    }

    /// Top-left corner of the inset on the screen, pixels.
    pub fn inset_origin(&self) -> ScreenPoint {
        self.inset_origin
    }

    /// Inset size in screen pixels.
    pub fn inset_size(&self) -> (u32, u32) {
        let l = &self.layers.layers[0];
        (l.width_px as u32, l.height_px as u32)
    }
}

impl FoveationMapping for Inset {
    fn method(&self) -> Method {
        Method::Inset
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "inset_fraction": self.params.inset_fraction,
            "periphery_scale": self.params.periphery_scale,
            "dynamic": self.params.dynamic,
        })
    }
    delegate_to_layers!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_one_eighth_of_the_pixels() {
        let d = DisplayProfile::preset("2k").unwrap();
        let m = Inset::new(&d, d.centre_gaze(), InsetParams::default()).unwrap();
        // 640×360 inset + 640×360 periphery.
        assert_eq!(m.sample_count(), 2 * 640 * 360);
        assert_eq!(m.inset_size(), (640, 360));
        // A gaze in the corner keeps the inset on screen.
        let g = d.gaze(0.0, 0.0).unwrap();
        let m = Inset::new(&d, g, InsetParams::default()).unwrap();
        assert_eq!(m.inset_origin(), ScreenPoint::new(0.0, 0.0));
    }
}
