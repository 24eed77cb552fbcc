//! Foveation mappings evaluated on the GPU: forward (screen → sample space) and inverse
//! (sample space → screen) for batches of points, one compute invocation per point, so that
//! the shaders can be compared with the f64 Rust mappings they mirror (`tests/mapping.rs`) and
//! later passes (reconstruction, ray generation) can call the same WGSL functions.
//!
//! * [`vafr`]: VaFR (Zhang et al., Eq. 3–12, 19) with the paper's Eq. 3 rings.
//! * [`vafr_rings`]: VaFR with exact rings (each ring sized at its worst on-screen point), the
//!   default, as a [`polar_table`].
//! * [`kfr`]: KFR / LMFR (VaFR Eq. 1, 14).
//! * [`lafr`]: LaFR (VaFR Eq. 15 on KFR's frame).
//! * [`visual_polar`]: visual-polar (Liu et al., Eq. 1–3), as a [`polar_table`].
//! * [`polar_table`]: polar mappings given by a tabulated radial profile (the shader both of
//!   the above use).
//!
//! Points travel as f32 (`[x, y]` screen pixels or `[u, v]` buffer pixels); the answer is
//! `None` where the Rust mapping returns `None`. Non-finite inputs are answered on the CPU
//! (`None`, as the reference does) and never reach a shader.

pub mod kfr;
pub mod lafr;
pub mod polar_table;
pub mod vafr;
pub mod vafr_rings;
pub mod visual_polar;

use crate::device::GpuContext;
use crate::error::Result;
use crate::shaders::ShaderSource;
use crate::transfer::{batch_len, run_1d_at, upload};

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
    /// The segment table of a [`polar_table`] mapping (binding
    /// [`polar_table::TABLE_BINDING`]), `None` for the closed-form ones.
    table: Option<wgpu::Buffer>,
    forward: wgpu::ComputePipeline,
    inverse: wgpu::ComputePipeline,
}

impl GpuMapping {
    /// The VaFR mapping `vafr` on `ctx`, either rings: Eq. 3's ([`vafr`]) or the exact ones,
    /// the default ([`vafr_rings`], the reference's ring table uploaded).
    pub fn vafr(ctx: &GpuContext, vafr: &fovea_core::mapping::Vafr) -> Result<Self> {
        match vafr.rings() {
            fovea_core::mapping::VafrRings::Eq3 | fovea_core::mapping::VafrRings::Eq3AnyGaze => {
                let block = vafr::VafrUniform::new(vafr)?;
                Self::new(ctx, "vafr", &vafr::SHADER, bytemuck::bytes_of(&block), None)
            }
            fovea_core::mapping::VafrRings::Exact => {
                Self::table(ctx, "vafr (exact rings)", &vafr_rings::table(vafr)?)
            }
        }
    }

    /// The KFR / LMFR mapping `kfr` on `ctx`.
    pub fn kfr(ctx: &GpuContext, kfr: &fovea_core::mapping::Kfr) -> Result<Self> {
        let block = kfr::KfrUniform::new(kfr);
        Self::new(ctx, "kfr", &kfr::SHADER, bytemuck::bytes_of(&block), None)
    }

    /// The LaFR mapping `lafr` on `ctx`.
    pub fn lafr(ctx: &GpuContext, lafr: &fovea_core::mapping::Lafr) -> Result<Self> {
        let block = lafr::LafrUniform::new(lafr);
        Self::new(ctx, "lafr", &lafr::SHADER, bytemuck::bytes_of(&block), None)
    }

    /// The visual-polar mapping `vp` on `ctx` (either inverse: the exact CDF or the paper's
    /// Eq. 3 fit), its radial profile uploaded as a table ([`visual_polar`]).
    pub fn visual_polar(ctx: &GpuContext, vp: &fovea_core::mapping::VisualPolar) -> Result<Self> {
        Self::table(ctx, "visual-polar", &visual_polar::table(vp)?)
    }

    fn table(
        ctx: &GpuContext,
        name: &'static str,
        table: &polar_table::PolarTable,
    ) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(&table.segments);
        ctx.check_storage_binding(
            &format!("the {name} mapping's segment table"),
            bytes.len() as u64,
        )?;
        Self::new(
            ctx,
            name,
            &polar_table::SHADER,
            bytemuck::bytes_of(&table.uniform),
            Some(bytes),
        )
    }

    fn new(
        ctx: &GpuContext,
        name: &'static str,
        shader: &ShaderSource,
        uniform_bytes: &[u8],
        table_bytes: Option<&[u8]>,
    ) -> Result<Self> {
        let device = ctx.device();
        let (uniform, table, forward, inverse) =
            ctx.scoped(&format!("building the {name} pipelines"), || {
                let uniform = upload(
                    ctx,
                    "mapping parameters",
                    uniform_bytes,
                    wgpu::BufferUsages::UNIFORM,
                );
                let table = table_bytes
                    .map(|bytes| upload(ctx, "mapping table", bytes, wgpu::BufferUsages::STORAGE));
                // `forward`, `inverse`: the order of the module's entry points.
                let mut p = shader.pipelines(device).into_iter();
                (uniform, table, p.next(), p.next())
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
            table,
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
        // Parameters at 0, points in at 1, out at 2, the table (if any) at 3.
        let mut inputs = vec![
            (0, self.uniform.as_entire_binding()),
            (1, input_buf.as_entire_binding()),
        ];
        if let Some(table) = &self.table {
            inputs.push((polar_table::TABLE_BINDING, table.as_entire_binding()));
        }
        let (raw, _) = run_1d_at(&self.ctx, &what, pipeline, &inputs, 2, n, OUT_BYTES, false)?;
        let values: &[[f32; 4]] = bytemuck::cast_slice(&raw);
        Ok(values
            .iter()
            .zip(&finite)
            .take(points.len())
            .map(|(v, &ok)| (ok && v[2] != 0.0).then_some([v[0], v[1]]))
            .collect())
    }
}
