//! Guenter-style nested eccentricity layers (Guenter et al. 2012, "Foveated 3D Graphics"), as
//! VaFR Fig. 5 compares them: concentric layers around the gaze point, each rendered at a
//! fixed fraction of the display resolution, so the shading rate is a step function of
//! eccentricity.
//!
//! Each inner layer `k` owns the disc of eccentricity `e_k` around the gaze and renders the
//! square that encloses it at `1/s_k` resolution per axis; the outer layer renders the whole
//! screen at `1/s_outer`. Defaults (our choice, in the spirit of Guenter's three layers):
//! full resolution to 5°, half to 15°, quarter beyond.

use serde::{Deserialize, Serialize};

use super::layered::{delegate_to_layers, Layer, Layers, Region};
use super::{BufferSize, FoveationMapping, Method, SamplePoint};
use crate::display::{DisplayProfile, Gaze};
use crate::error::{check_range, FoveaError, Result};
use crate::units::ScreenPoint;

/// One inner layer: owns eccentricities up to `radius_deg`, rendered at `1/scale`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GuenterLayer {
    /// Outer eccentricity of the layer, degrees.
    pub radius_deg: f64,
    /// Screen pixels per layer pixel along each axis (≥ 1).
    pub scale: f64,
}

/// Parameters of the nested layers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GuenterParams {
    /// Inner layers, from the fovea outwards (increasing radius and scale).
    pub inner: Vec<GuenterLayer>,
    /// Scale of the outer, whole-screen layer.
    pub outer_scale: f64,
}

impl Default for GuenterParams {
    fn default() -> Self {
        Self {
            inner: vec![
                GuenterLayer {
                    radius_deg: 5.0,
                    scale: 1.0,
                },
                GuenterLayer {
                    radius_deg: 15.0,
                    scale: 2.0,
                },
            ],
            outer_scale: 4.0,
        }
    }
}

/// The nested-layer mapping for one display and gaze.
pub struct GuenterLayers {
    params: GuenterParams,
    layers: Layers,
}

impl GuenterLayers {
    /// Builds the layers; radii must increase within (0, 89]° and scales lie in [1, 64].
    pub fn new(display: &DisplayProfile, gaze: Gaze, params: GuenterParams) -> Result<Self> {
        display.validate()?;
        check_range("outer_scale", params.outer_scale, 1.0, 64.0)?;
        let mut layers = Vec::new();
        let mut prev = 0.0;
        for (k, l) in params.inner.iter().enumerate() {
            check_range(&format!("layers[{k}].scale"), l.scale, 1.0, 64.0)?;
            if !(l.radius_deg.is_finite() && l.radius_deg > prev && l.radius_deg <= 89.0) {
                return Err(FoveaError::invalid(
                    format!("layers[{k}].radius"),
                    l.radius_deg,
                    format!("an eccentricity in ({prev}, 89] degrees, increasing outwards"),
                ));
            }
            prev = l.radius_deg;
            let r = display.radius_px(crate::units::Degrees(l.radius_deg));
            layers.push(Layer {
                origin: ScreenPoint::new(gaze.point.x_px - r, gaze.point.y_px - r),
                width_px: 2.0 * r,
                height_px: 2.0 * r,
                scale: l.scale,
                region: Region::Disc {
                    centre: gaze.point,
                    radius_px: r,
                },
            });
        }
        layers.push(Layer {
            origin: ScreenPoint::new(0.0, 0.0),
            width_px: display.width_px as f64,
            height_px: display.height_px as f64,
            scale: params.outer_scale,
            region: Region::Rect,
        });
        Ok(Self {
            layers: Layers::new(display, gaze.point, layers),
            params,
        })
    }
}

impl FoveationMapping for GuenterLayers {
    fn method(&self) -> Method {
        Method::Guenter
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "inner": self.params.inner.iter().map(|l| [l.radius_deg, l.scale]).collect::<Vec<_>>(),
            "outer_scale": self.params.outer_scale,
        })
    }
    delegate_to_layers!();
}
