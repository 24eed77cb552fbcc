//! Foveation mappings evaluated on the GPU: forward (screen → sample space) and inverse
//! (sample space → screen) for batches of points, one compute invocation per point, so that
//! the shaders can be compared with the f64 Rust mappings they mirror (`tests/mapping.rs`) and
//! later passes (reconstruction, ray generation) can call the same WGSL functions.
//!
//! * [`vafr`]: VaFR (Zhang et al., Eq. 3–12, 19).
//! * [`kfr`]: KFR / LMFR (VaFR Eq. 1, 14).
//! * [`lafr`]: LaFR (VaFR Eq. 15 on KFR's frame).
//!
//! Points travel as f32 (`[x, y]` screen pixels or `[u, v]` buffer pixels); the answer is
//! `None` where the Rust mapping returns `None`. Non-finite inputs are answered on the CPU
//! (`None`, as the reference does) and never reach a shader.

pub mod kfr;
pub mod lafr;
pub mod vafr;

use crate::device::GpuContext;
use crate::error::Result;
use crate::shaders::ShaderSource;
use crate::transfer::{batch_len, run_1d, upload};

/// Bytes per input point (`vec2<f32>`).
const IN_BYTES: u64 = 8;
/// Bytes per output point (`vec4<f32>`: x, y, valid, unused).
const OUT_BYTES: u64 = 16;

/// Which way a batch goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Screen pixels → sample space.
    Forward,
    /// Sample space → screen pixels.
    Inverse,
}

/// A mapping's compute pipelines and its uploaded parameters, on one device.
pub struct GpuMapping {
    ctx: GpuContext,
    name: &'static str,
    uniform: wgpu::Buffer,
    forward: wgpu::ComputePipeline,
    inverse: wgpu::ComputePipeline,
}

impl GpuMapping {
    /// The VaFR mapping `vafr` on `ctx`.
    pub fn vafr(ctx: &GpuContext, vafr: &fovea_core::mapping::Vafr) -> Result<Self> {
        let block = vafr::VafrUniform::new(vafr)?;
        Self::new(ctx, "vafr", &vafr::SHADER, bytemuck::bytes_of(&block))
    }

    /// The KFR / LMFR mapping `kfr` on `ctx`.
    pub fn kfr(ctx: &GpuContext, kfr: &fovea_core::mapping::Kfr) -> Result<Self> {
        let block = kfr::KfrUniform::new(kfr);
        Self::new(ctx, "kfr", &kfr::SHADER, bytemuck::bytes_of(&block))
    }

    /// The LaFR mapping `lafr` on `ctx`.
    pub fn lafr(ctx: &GpuContext, lafr: &fovea_core::mapping::Lafr) -> Result<Self> {
        let block = lafr::LafrUniform::new(lafr);
        Self::new(ctx, "lafr", &lafr::SHADER, bytemuck::bytes_of(&block))
    }

    fn new(
        ctx: &GpuContext,
        name: &'static str,
        shader: &ShaderSource,
        uniform_bytes: &[u8],
    ) -> Result<Self> {
        let device = ctx.device();
        let (uniform, forward, inverse) =
            ctx.scoped(&format!("building the {name} pipelines"), || {
                let uniform = upload(
                    ctx,
                    "mapping parameters",
                    uniform_bytes,
                    wgpu::BufferUsages::UNIFORM,
                );
                // `forward`, `inverse`: the order of the module's entry points.
                let mut p = shader.pipelines(device).into_iter();
                (uniform, p.next(), p.next())
            })?;
        let (Some(forward), Some(inverse)) = (forward, inverse) else {
            return Err(crate::GpuError::Input(format!(
                "the {name} module lacks its forward and inverse entry points"
            )));
        };
        Ok(Self {
            ctx: ctx.clone(),
            name,
            uniform,
            forward,
            inverse,
        })
    }

    /// Screen pixels → sample space (`[u, v]`), as [`FoveationMapping::forward`](fovea_core::mapping::FoveationMapping::forward).
    pub fn forward(&self, points_px: &[[f32; 2]]) -> Result<Vec<Option<[f32; 2]>>> {
        self.run(Direction::Forward, points_px)
    }

    /// Sample space (`[u, v]`) → screen pixels, as [`FoveationMapping::inverse`](fovea_core::mapping::FoveationMapping::inverse).
    pub fn inverse(&self, samples: &[[f32; 2]]) -> Result<Vec<Option<[f32; 2]>>> {
        self.run(Direction::Inverse, samples)
    }

    /// Maps `points` in batches that fit the device's limits (binding size, workgroups per
    /// dispatch).
    pub fn run(&self, direction: Direction, points: &[[f32; 2]]) -> Result<Vec<Option<[f32; 2]>>> {
        let batch = batch_len(&self.ctx, OUT_BYTES);
        let mut out = Vec::with_capacity(points.len());
        for chunk in points.chunks(batch) {
            out.extend(self.run_batch(direction, chunk)?);
        }
        Ok(out)
    }

    fn run_batch(
        &self,
        direction: Direction,
        points: &[[f32; 2]],
    ) -> Result<Vec<Option<[f32; 2]>>> {
        // Non-finite points are answered here; the shader sees a harmless stand-in.
        let finite: Vec<bool> = points
            .iter()
            .map(|p| p[0].is_finite() && p[1].is_finite())
            .collect();
        let input: Vec<[f32; 2]> = points
            .iter()
            .zip(&finite)
            .map(|(&p, &ok)| if ok { p } else { [0.0, 0.0] })
            .collect();
        let n = input.len().max(1) as u64;
        let what = format!(
            "the {} {:?} mapping of {} points",
            self.name,
            direction,
            points.len()
        );
        self.ctx.check_storage_binding(&what, n * OUT_BYTES)?;
        let pipeline = match direction {
            Direction::Forward => &self.forward,
            Direction::Inverse => &self.inverse,
        };
        let input_buf = self.ctx.scoped(&what, || {
            let contents: &[u8] = if input.is_empty() {
                &[0u8; IN_BYTES as usize]
            } else {
                bytemuck::cast_slice(&input)
            };
            upload(
                &self.ctx,
                "points in",
                contents,
                wgpu::BufferUsages::STORAGE,
            )
        })?;
        let (raw, _) = run_1d(
            &self.ctx,
            &what,
            pipeline,
            &[
                self.uniform.as_entire_binding(),
                input_buf.as_entire_binding(),
            ],
            n,
            OUT_BYTES,
            false,
        )?;
        let values: &[[f32; 4]] = bytemuck::cast_slice(&raw);
        Ok(values
            .iter()
            .zip(&finite)
            .take(points.len())
            .map(|(v, &ok)| (ok && v[2] != 0.0).then_some([v[0], v[1]]))
            .collect())
    }
}
