//! Tone curve and 8-bit sRGB encoding on the GPU (DESIGN.md stage 7's tone map; IEC
//! 61966-2-1's transfer function, Reinhard et al. 2002's `x/(1+x)`), the twin of
//! `fovea_post::tonemap::to_srgb8`: the same bytes from a linear image, an exposure in stops
//! and a [`ToneCurve`].
//!
//! Rust computes `2^stops` (as the CPU does, in f32) and the 255 linear thresholds of the
//! 8-bit code steps (`fovea_post::tonemap::srgb8_thresholds`, the CPU's own table); the shader
//! (`shaders/tonemap.wgsl`) scales, applies the curve and counts the thresholds at or below
//! each value, packing four codes per u32. The only arithmetic that may round differently from
//! the CPU is Reinhard's division (Vulkan allows 2.5 ulp): a value within an ulp or two of a
//! code step can land one code off (`tests/tonemap.rs` counts them).
//!
//! An image larger than one storage binding (an 8K frame is 398 MB of f32 values; lavapipe
//! binds 128 MiB) is encoded in bands of whole output words, one dispatch each
//! ([`GpuToneMap::band_values`]); the bytes do not depend on the bands.

use bytemuck::{Pod, Zeroable};
use fovea_core::Image;
use fovea_post::tonemap::{srgb8_thresholds, ToneCurve};
use fovea_post::Rgb;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::transfer::{read_buffers, stage, upload};

/// The module: entry points `tonemap` (interleaved values, this path) and `tonemap_planes`
/// (three planes, the resident screen's), [`ToneUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "tonemap.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/tonemap.wgsl")
    ),
    entry_points: &["tonemap", "tonemap_planes"],
    uniform: ("ToneParams", std::mem::size_of::<ToneUniform>()),
};

/// Workgroups along x of one row of the dispatch (the shader's `65535u`).
const GROUPS_PER_ROW: u32 = 65535;

/// The uniform block `ToneParams` of `tonemap.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ToneUniform {
    /// Channel values (3 per pixel).
    pub n_values: u32,
    /// Output words, `ceil(n_values / 4)`.
    pub n_words: u32,
    /// `2^exposure_stops`.
    pub scale: f32,
    /// 0 clamp, 1 Reinhard.
    pub curve: u32,
}

/// The tone-mapping pipeline on one device.
pub struct GpuToneMap {
    ctx: GpuContext,
    pipeline: wgpu::ComputePipeline,
    /// Most values one dispatch encodes (a multiple of 4: whole output words): what fits one
    /// storage binding and one dispatch. A larger image goes in bands of this many.
    band_values: u64,
}

impl GpuToneMap {
    /// Compiles the pass on `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        let device = ctx.device();
        let pipeline = ctx
            .scoped("building the tone-map pipeline", || {
                SHADER.pipelines_of(device, &["tonemap"]).pop()
            })?
            .ok_or_else(|| GpuError::Input("the tone-map module has no entry point".into()))?;
        let limits = ctx.limits();
        let binding = ctx.max_binding_bytes();
        let dispatch = u64::from(limits.max_compute_workgroups_per_dimension)
            * u64::from(GROUPS_PER_ROW)
            * u64::from(WORKGROUP_SIZE)
            * 4;
        let band_values = (binding / 4).min(dispatch).min(u64::from(u32::MAX)) / 4 * 4;
        Ok(Self {
            ctx: ctx.clone(),
            pipeline,
            band_values,
        })
    }

    /// The same pipeline encoding at most `values` channel values per dispatch (rounded down
    /// to whole output words; at least 4), e.g. to test the bands of a frame larger than one
    /// binding on a small image, or to bound the device memory one dispatch takes.
    pub fn with_band_values(mut self, values: u64) -> Self {
        self.band_values = self.band_values.min(values / 4 * 4).max(4);
        self
    }

    /// Most channel values (3 a pixel) one dispatch encodes; a larger image goes in bands.
    pub fn band_values(&self) -> u64 {
        self.band_values
    }

    /// `img` scaled by `2^exposure_stops`, through `curve`, encoded to 8-bit sRGB RGB bytes
    /// (row-major, 3 per pixel), as `fovea_post::tonemap::to_srgb8`.
    pub fn to_srgb8(
        &self,
        img: &Image<Rgb>,
        exposure_stops: f32,
        curve: ToneCurve,
    ) -> Result<Vec<u8>> {
        if !exposure_stops.is_finite() {
            return Err(GpuError::Input(format!(
                "exposure {exposure_stops} stops (a finite number of stops)"
            )));
        }
        let values: &[f32] = bytemuck::cast_slice(img.data());
        let scale = 2f32.powf(exposure_stops);
        let curve = match curve {
            ToneCurve::Clamp => 0,
            ToneCurve::Reinhard => 1,
        };
        let what = format!("the tone map of {}x{}", img.width(), img.height());
        let mut out = Vec::with_capacity(values.len());
        for band in values.chunks(self.band_values as usize) {
            out.extend(self.encode(band, scale, curve, &what)?);
        }
        Ok(out)
    }

    /// One dispatch: `values` scaled by `scale`, through curve number `curve`, encoded.
    fn encode(&self, values: &[f32], scale: f32, curve: u32, what: &str) -> Result<Vec<u8>> {
        let n_values = values.len() as u64;
        if n_values == 0 {
            return Ok(Vec::new());
        }
        let n_words = n_values.div_ceil(4);
        self.ctx
            .check_storage_binding("the tone map's input", n_values * 4)?;
        let groups = n_words.div_ceil(WORKGROUP_SIZE as u64);
        let rows = groups.div_ceil(GROUPS_PER_ROW as u64);
        let max_groups = self.ctx.limits().max_compute_workgroups_per_dimension as u64;
        if rows > max_groups || n_words > u32::MAX as u64 {
            return Err(GpuError::Unsupported(format!(
                "tone-mapping {n_values} values at once"
            )));
        }
        let uniform = ToneUniform {
            n_values: n_values as u32,
            n_words: n_words as u32,
            scale,
            curve,
        };
        let thresholds = srgb8_thresholds();
        let inputs = [
            upload(
                &self.ctx,
                "tone parameters",
                bytemuck::bytes_of(&uniform),
                wgpu::BufferUsages::UNIFORM,
            ),
            upload(
                &self.ctx,
                "linear values",
                bytemuck::cast_slice(values),
                wgpu::BufferUsages::STORAGE,
            ),
            upload(
                &self.ctx,
                "sRGB thresholds",
                bytemuck::cast_slice(&thresholds),
                wgpu::BufferUsages::STORAGE,
            ),
        ];
        let device = self.ctx.device();
        let bytes = n_words * 4;
        let readback = self.ctx.scoped(what, || {
            let out = self.ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("sRGB bytes"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let mut entries: Vec<wgpu::BindGroupEntry> = inputs
                .iter()
                .enumerate()
                .map(|(k, b)| wgpu::BindGroupEntry {
                    binding: k as u32,
                    resource: b.as_entire_binding(),
                })
                .collect();
            entries.push(wgpu::BindGroupEntry {
                binding: 3,
                resource: out.as_entire_binding(),
            });
            let bind = self.ctx.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tone map"),
                layout: &self.pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tone map"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("tone map"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &bind, &[]);
                let x = if rows > 1 {
                    GROUPS_PER_ROW
                } else {
                    groups as u32
                };
                pass.dispatch_workgroups(x, rows as u32, 1);
            }
            let read = stage(&self.ctx, &mut encoder, &[(&out, bytes)], "sRGB readback");
            self.ctx.submit([encoder.finish()]);
            read
        })?;
        let mut out = Vec::new();
        read_buffers(&self.ctx, &[&readback[0]], what, |_, b| {
            out = b.to_vec();
        })?;
        out.truncate(n_values as usize);
        Ok(out)
    }
}
