//! [`GpuDof`] as the pipeline's depth-of-field executor
//! (`fovea_render::pipeline::DofExecutor`): the gather filter (its default parameters, as
//! `FilterKind::Gather` builds it) on the GPU's own CoC map.

use std::sync::Arc;

use fovea_core::units::Metres;
use fovea_core::Image;
use fovea_post::dof::coc::{CocModel, CocParams};
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::dof::FilterKind;
use fovea_post::Rgb;
use fovea_render::pipeline::DofExecutor;

use super::times::{GpuDofMs, Slot};
use crate::GpuDof;

/// The depth-of-field executor.
#[derive(Clone)]
pub struct GpuDofExecutor {
    pub(crate) gpu: Arc<GpuDof>,
    pub(crate) times: Slot<GpuDofMs>,
}

impl DofExecutor for GpuDofExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(&self, filter: FilterKind, coc_model: &CocModel) -> bool {
        filter == FilterKind::Gather && GpuDof::supports_coc(coc_model)
    }

    fn fits(&self, width_px: u32, height_px: u32) -> bool {
        // A frame too large for the device (8K on lavapipe) is filtered on the CPU.
        self.gpu.fits(width_px, height_px)
    }

    fn depth_of_field(
        &mut self,
        filter: FilterKind,
        coc: &CocParams,
        focus_m: f64,
        color: &Image<Rgb>,
        depth_m: &Image<f32>,
    ) -> Result<(Image<Rgb>, Image<f32>), String> {
        if filter != FilterKind::Gather {
            return Err(format!(
                "the {} filter is not on the GPU; use --backend cpu",
                filter.name()
            ));
        }
        let gather = ScatterAsGather::default();
        let (blurred, coc_px, t) = self
            .gpu
            .coc_and_gather(&gather, coc, Metres(focus_m), color, depth_m)
            .map_err(|e| e.to_string())?;
        *self.times.lock().unwrap_or_else(|e| e.into_inner()) = Some(GpuDofMs {
            upload_ms: t.upload_ms,
            run_and_readback_ms: t.run_and_readback_ms,
            gpu_pass_ms: t.gpu_pass_ms,
            total_ms: t.total_ms,
        });
        Ok((blurred, coc_px))
    }
}
