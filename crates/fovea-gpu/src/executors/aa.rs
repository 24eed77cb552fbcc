//! [`GpuSampleAa`] as the pipeline's AA executor (`fovea_render::pipeline::AaExecutor`):
//! FXAA (with the polar seam) and the 3×3 Gaussian, on rect and polar grids.

use std::sync::Arc;

use fovea_core::Image;
use fovea_post::fxaa::FxaaParams;
use fovea_post::grid::Grid;
use fovea_post::Rgb;
use fovea_render::pipeline::{AaExecutor, AaMode};

use super::times::{add_ms, GpuAaMs, Slot};
use crate::{GpuSampleAa, SampleFilter};

/// The AA executor (one per eye: the filter keeps the tables of the last grid it ran).
#[derive(Clone)]
pub struct GpuAaExecutor {
    pub(crate) gpu: Arc<GpuSampleAa>,
    /// The frame's AA times, summed over its layers until taken.
    pub(crate) times: Slot<GpuAaMs>,
}

impl AaExecutor for GpuAaExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(&self, mode: AaMode, grid: &Grid) -> bool {
        // A buffer too large for the device (a full-resolution 8K frame with --aa forced)
        // is filtered on the CPU.
        matches!(mode, AaMode::Fxaa | AaMode::Gaussian) && self.gpu.fits(grid)
    }

    fn anti_alias(
        &mut self,
        mode: AaMode,
        params: &FxaaParams,
        grid: &Grid,
        color: &Image<Rgb>,
    ) -> Result<Image<Rgb>, String> {
        let filter = match mode {
            AaMode::Fxaa => SampleFilter::Fxaa(*params),
            AaMode::Gaussian => SampleFilter::Gaussian,
            other => {
                return Err(format!(
                    "AA mode {other:?} is not a filter; use --backend cpu"
                ))
            }
        };
        let (out, t) = self
            .gpu
            .run(color, grid, filter)
            .map_err(|e| e.to_string())?;
        let mut slot = self.times.lock().unwrap_or_else(|e| e.into_inner());
        let sum = slot.get_or_insert_with(GpuAaMs::default);
        sum.tables_ms += t.tables_ms;
        sum.upload_ms += t.upload_ms;
        sum.run_and_readback_ms += t.run_and_readback_ms;
        sum.gpu_pass_ms = add_ms(sum.gpu_pass_ms, t.gpu_pass_ms);
        sum.layers += 1;
        Ok(out)
    }
}
