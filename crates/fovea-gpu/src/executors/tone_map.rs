//! [`GpuToneMap`] as the output's tone-map executor (`fovea_post::tonemap::ToneMapExecutor`):
//! exposure, tone curve and 8-bit sRGB encoding, any size (bands of rows).

use std::time::Instant;

use fovea_core::Image;
use fovea_post::tonemap::{ToneCurve, ToneMapExecutor};
use fovea_post::Rgb;

use super::times::{GpuToneMs, Slot};
use crate::GpuToneMap;

/// The tone-map executor.
pub struct GpuToneExecutor {
    pub(crate) gpu: GpuToneMap,
    /// Sums over the images encoded.
    pub(crate) times: Slot<GpuToneMs>,
}

impl ToneMapExecutor for GpuToneExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn to_srgb8(
        &mut self,
        img: &Image<Rgb>,
        exposure_stops: f32,
        curve: ToneCurve,
    ) -> Result<Vec<u8>, String> {
        let t = Instant::now();
        let bytes = self
            .gpu
            .to_srgb8(img, exposure_stops, curve)
            .map_err(|e| e.to_string())?;
        let mut slot = self.times.lock().unwrap_or_else(|e| e.into_inner());
        let sum = slot.get_or_insert_with(GpuToneMs::default);
        sum.calls += 1;
        sum.total_ms += t.elapsed().as_secs_f64() * 1e3;
        Ok(bytes)
    }
}
