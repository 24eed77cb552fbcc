//! Full resolution: every screen pixel is a sample (the ground truth). Sample space is screen
//! space; the shading rate is the display's own, `½·dr/de`.

use super::{screen_rate_cpd, BufferSize, FoveationMapping, Method, SamplePoint};
use crate::display::DisplayProfile;
use crate::error::Result;
use crate::units::ScreenPoint;

/// The identity mapping.
pub struct FullResolution {
    width: u32,
    height: u32,
    c_r: f64,
}

impl FullResolution {
    /// The full-resolution "mapping" of `display`.
    pub fn new(display: &DisplayProfile) -> Result<Self> {
        display.validate()?;
        Ok(Self {
            width: display.width_px,
            height: display.height_px,
            c_r: display.c_r(),
        })
    }
}

impl FoveationMapping for FullResolution {
    fn method(&self) -> Method {
        Method::Full
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({})
    }
    fn buffers(&self) -> Vec<BufferSize> {
        vec![BufferSize {
            width: self.width,
            height: self.height,
        }]
    }
    fn sample_count(&self) -> u64 {
        self.width as u64 * self.height as u64
    }
    fn is_shaded(&self, layer: u32, i: u32, j: u32) -> bool {
        layer == 0 && i < self.width && j < self.height
    }
    fn forward(&self, p: ScreenPoint) -> Option<SamplePoint> {
        ((0.0..self.width as f64).contains(&p.x_px) && (0.0..self.height as f64).contains(&p.y_px))
            .then_some(SamplePoint::new(p.x_px, p.y_px))
    }
    fn inverse(&self, s: SamplePoint) -> Option<ScreenPoint> {
        (s.layer == 0
            && (0.0..=self.width as f64).contains(&s.u)
            && (0.0..=self.height as f64).contains(&s.v))
        .then_some(ScreenPoint::new(s.u, s.v))
    }
    fn radial_rate_cpd(&self, e_deg: f64) -> f64 {
        screen_rate_cpd(self.c_r, e_deg)
    }
    fn tangential_rate_cpd(&self, e_deg: f64) -> f64 {
        screen_rate_cpd(self.c_r, e_deg)
    }
}
