//! [`GpuReconstructor`] as the pipeline's reconstruct executor
//! (`fovea_render::pipeline::ReconstructExecutor`): the polar methods' lookup and Weier's
//! pull-push; a frame too large for the device is reconstructed on the CPU.

use std::sync::Arc;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::FoveationMapping;
use fovea_core::Image;
use fovea_post::inverse_map::{ReconstructFilter, SampleBuffers};
use fovea_post::Rgb;
use fovea_render::pipeline::ReconstructExecutor;

use super::times::{GpuReconstructMs, Slot};
use crate::GpuReconstructor;

/// The reconstruct executor.
#[derive(Clone)]
pub struct GpuReconstructExecutor {
    pub(crate) gpu: Arc<GpuReconstructor>,
    pub(crate) times: Slot<GpuReconstructMs>,
}

impl ReconstructExecutor for GpuReconstructExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(&self, mapping: &dyn FoveationMapping) -> bool {
        // A frame too large for the device (KFR's texels at 8K on lavapipe, a Weier pyramid
        // past one binding) is reconstructed on the CPU; the frame's stats say so.
        GpuReconstructor::supports(mapping) && self.gpu.fits(mapping)
    }

    fn reconstruct_into(
        &mut self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        samples: &SampleBuffers,
        filter: ReconstructFilter,
        color: &mut Image<Rgb>,
        depth: &mut Image<f32>,
    ) -> Result<(), String> {
        let t = self
            .gpu
            .reconstruct_into(mapping, display, samples, filter, color, depth)
            .map_err(|e| e.to_string())?;
        *self.times.lock().unwrap_or_else(|e| e.into_inner()) = Some(GpuReconstructMs {
            tables_ms: t.tables_ms,
            upload_ms: t.upload_ms,
            run_and_readback_ms: t.run_and_readback_ms,
            gpu_pass_ms: t.gpu_pass_ms,
            bands: t.bands,
        });
        Ok(())
    }
}
