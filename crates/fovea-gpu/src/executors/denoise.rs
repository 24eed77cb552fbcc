//! [`GpuDenoiser`] as the frame pipeline's denoiser
//! ([`fovea_render::pipeline::DenoiseExecutor`]): today's staged `--backend gpu` path, where
//! the trace and shade hand the CPU's sample buffers and guides over, uploads them, filters on
//! the device in one submission and reads the colours back ([`GpuDenoiser::run`]).

use std::sync::{Arc, Mutex};

use fovea_core::mapping::BufferSize;
use fovea_post::denoise::{DenoiseGuides, DenoiseParams, DenoiseStats};
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;
use fovea_render::pipeline::DenoiseExecutor;

use crate::denoise::{DenoiseTimes, GpuDenoiser};
use crate::device::GpuContext;
use crate::error::Result;

/// The GPU denoiser of one frame context (one eye: it keeps that eye's device buffers).
pub struct GpuDenoiseExecutor {
    gpu: GpuDenoiser,
    /// The last call's times, until taken.
    times: Arc<Mutex<Option<DenoiseTimes>>>,
}

impl GpuDenoiseExecutor {
    /// A denoiser on `ctx` (compiles its pipelines; buffers come with the first frame).
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Ok(Self {
            gpu: GpuDenoiser::new(ctx)?,
            times: Arc::default(),
        })
    }

    /// The slot each call writes its [`DenoiseTimes`] into (shared: a bench or CLI keeps a
    /// handle and takes the figures after a frame).
    pub fn times(&self) -> Arc<Mutex<Option<DenoiseTimes>>> {
        self.times.clone()
    }
}

impl DenoiseExecutor for GpuDenoiseExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn supports(&self, sizes: &[(u32, u32)]) -> bool {
        let sizes: Vec<BufferSize> = sizes
            .iter()
            .map(|&(width, height)| BufferSize { width, height })
            .collect();
        self.gpu.fits(&sizes)
    }

    fn denoise(
        &mut self,
        params: &DenoiseParams,
        grids: &[Grid],
        samples: &mut SampleBuffers,
        guides: &DenoiseGuides,
    ) -> std::result::Result<DenoiseStats, String> {
        let (stats, t) = self
            .gpu
            .run(samples, guides, grids, params)
            .map_err(|e| e.to_string())?;
        if let Ok(mut slot) = self.times.lock() {
            *slot = Some(t);
        }
        Ok(stats)
    }
}
