//! Polar reconstruction on the GPU: a polar sample buffer (VaFR, KFR/LMFR, LaFR,
//! visual-polar) back to screen colour and depth (VaFR Sec. 3.4 / Eq. 10–11; the reconstruct
//! stage of DESIGN.md), the twin of `fovea_post::inverse_map`'s polar loop. Weier's sparse
//! screen-aligned buffer goes to [`GpuPullPush`] instead (pull-push, Gortler et al. 1996;
//! Weier et al. 2016), with the mask of `fovea_post::inverse_map::mask_of` as on the CPU.
//!
//! Split of the work:
//!
//! * **Rust, on the CPU** ([`fovea_post::inverse_map::PolarTables`], the very function the CPU
//!   path uses): the `u(r)` lookup table from the mapping's forward map every ⅛ px of radius,
//!   each column's base, rows and period, the columns padded by one row on either side, and
//!   for [`ReconstructFilter::Footprint`] the radial footprint `du/dr` per column and the
//!   angular prefilter (each column boxed along its rows to `period/(2πr) − 1` rows). The
//!   prefilter stays on the CPU in this first version: it is a per-column prefix sum, cheap
//!   next to the per-pixel work, and sharing it keeps both executors on identical texels.
//! * **WGSL** (`shaders/polar_reconstruct.wgsl`): per screen pixel, `u` from the table, the
//!   angle with the crate's own `atan`, bilinear across the two nearest columns, and the
//!   footprint's box across `du/dr` columns where a pixel spans more than one.
//!
//! Differences from the CPU loop, both within its own tolerance of the exact coordinates: the
//! CPU interpolates coordinates linearly between every 8th pixel where that stays within
//! [`COORD_TOLERANCE_TEXELS`](fovea_post::inverse_map::COORD_TOLERANCE_TEXELS) (1/64 texel),
//! the GPU computes every pixel exactly; the CPU's `atan2` is a polynomial with |error| < 1e-5
//! rad, the GPU's ~1e-7.
//!
//! The screen is split into bands of rows whose output fits the adapter's storage-binding
//! limit (lavapipe: 128 MiB, i.e. 8.4 M pixels at 16 bytes); the table, columns and texels must
//! each fit one binding, checked before anything is allocated ([`GpuError::AdapterTooSmall`]).

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{FoveationMapping, Method};
use fovea_core::Image;
use fovea_post::inverse_map::{
    mask_of, PolarColumns, PolarTables, ReconstructFilter, SampleBuffers, ScreenFrame,
};
use fovea_post::Rgb;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::mapping::vafr::split_f64;
use crate::pull_push::GpuPullPush;
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::timestamps::PassTimer;
use crate::transfer::{read_buffers, stage, upload};

/// The module: entry points `reconstruct` (`vec4<u32>` a pixel, this path's bands) and
/// `reconstruct_planes` (four planes, the resident screen's), [`ReconstructUniform`] at
/// binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "polar_reconstruct.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/polar_reconstruct.wgsl")
    ),
    entry_points: &["reconstruct", "reconstruct_planes"],
    uniform: (
        "ReconstructParams",
        std::mem::size_of::<ReconstructUniform>(),
    ),
};

/// Bytes per screen pixel of the output (`vec4<u32>`: r, g, b, depth bits).
const OUT_BYTES: u64 = 16;
/// Bytes per stored texel (`[r, g, b, depth]`).
const TEXEL_BYTES: u64 = 16;
/// Bytes per column (`Column` of the shader).
const COLUMN_BYTES: u64 = 16;
/// What the table holds where the mapping has no sample (the CPU's `f32::INFINITY`): any
/// value past the last column does, and a finite one keeps infinities out of the shader.
const LUT_UNCOVERED: f32 = 1e30;

/// The uniform block `ReconstructParams` of `polar_reconstruct.wgsl` (same field order; see
/// there). One per band of rows.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ReconstructUniform {
    /// The pole, f32 high part, pixels.
    pub pole_hi: [f32; 2],
    /// The pole, f32 low part, pixels.
    pub pole_lo: [f32; 2],
    /// Screen width, pixels.
    pub width: u32,
    /// First row of the band.
    pub row0: u32,
    /// Rows of the band.
    pub band_rows: u32,
    /// Table length − 2.
    pub lut_max_k: u32,
    /// 1 / table step, per pixel.
    pub inv_step: f32,
    /// `last + 1`.
    pub cols_end: f32,
    /// The last column with shaded rows.
    pub last: u32,
    /// `f32::INFINITY.to_bits()`.
    pub miss_depth_bits: u32,
    /// 1 for [`ReconstructFilter::Footprint`], 0 for bilinear.
    pub footprint: u32,
    /// 1/(2π).
    pub turns_per_rad: f32,
    /// 2π.
    pub rad_per_turn: f32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// The shader's `Column`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct GpuColumn {
    pub(crate) base: u32,
    pub(crate) rows: u32,
    pub(crate) period: f32,
    pub(crate) texels_per_px: f32,
}

/// Where the time of one GPU reconstruction went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReconstructTimes {
    /// Building the tables on the CPU (lookup table, columns, prefilter; for Weier the mask),
    /// wall ms.
    pub tables_ms: f64,
    /// Creating buffers, uploading, recording and submitting, wall ms.
    pub upload_ms: f64,
    /// From submission until the output was read back into the images, wall ms (includes the
    /// GPU's work and the copy out).
    pub run_and_readback_ms: f64,
    /// The compute pass alone, from the device's timestamps (when it has
    /// `TIMESTAMP_QUERY`), ms; for Weier the pull, push and depth passes together
    /// ([`PullPushTimes`](crate::PullPushTimes) has them one by one).
    pub gpu_pass_ms: Option<f64>,
    /// All of the above, wall ms.
    pub total_ms: f64,
    /// Bands of rows the screen was split into (1 for Weier).
    pub bands: u32,
}

/// The reconstruction's pipelines on one device (the polar lookup and Weier's pull-push);
/// reuse it from frame to frame.
pub struct GpuReconstructor {
    ctx: GpuContext,
    pipeline: wgpu::ComputePipeline,
    pull_push: GpuPullPush,
}

impl GpuReconstructor {
    /// Compiles the pass on `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        let device = ctx.device();
        let pipeline = ctx
            .scoped("building the reconstruct pipeline", || {
                SHADER.pipelines_of(device, &["reconstruct"]).pop()
            })?
            .ok_or_else(|| GpuError::Input("the reconstruct module has no entry point".into()))?;
        Ok(Self {
            ctx: ctx.clone(),
            pipeline,
            pull_push: GpuPullPush::new(ctx)?,
        })
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Whether the passes can reconstruct `mapping`'s buffers: polar mappings (one buffer
    /// whose columns are rings around the gaze: VaFR, KFR/LMFR, LaFR, visual-polar) and
    /// Weier's sparse screen-aligned buffer (pull-push).
    pub fn supports(mapping: &dyn FoveationMapping) -> bool {
        mapping.buffers().len() == 1
            && (mapping.polar_layout().is_some() || mapping.method() == Method::Weier)
    }

    /// Bytes of texels [`Self::reconstruct_into`] uploads for `mapping`'s polar buffer (its
    /// columns, each padded by one row on either side, [`TEXEL_BYTES`] a texel:
    /// `PolarColumns::texel_count`); `None` for a mapping that is not polar.
    pub fn texel_bytes(mapping: &dyn FoveationMapping) -> Option<u64> {
        let layout = mapping.polar_layout()?;
        let height = mapping.buffers().first().map_or(0, |b| b.height);
        Some(PolarColumns::texel_count(&layout, height) * TEXEL_BYTES)
    }

    /// Whether `mapping`'s frame fits this device, for a caller that can fall back to the CPU:
    /// Weier's pyramid within one storage binding ([`GpuPullPush::fits`]); a polar buffer's
    /// texels ([`Self::texel_bytes`]) within one binding (a KFR buffer at 8K does not fit
    /// lavapipe's 128 MiB; the screen is split into bands of rows and always fits).
    /// [`Self::reconstruct_into`] checks every table it uploads.
    pub fn fits(&self, mapping: &dyn FoveationMapping) -> bool {
        if !Self::supports(mapping) {
            return false;
        }
        if mapping.method() == Method::Weier {
            return mapping
                .buffers()
                .first()
                .is_some_and(|b| self.pull_push.fits(b.width, b.height));
        }
        Self::texel_bytes(mapping).is_some_and(|b| b <= self.ctx.max_binding_bytes())
    }

    /// [`Self::reconstruct_into`] into new images.
    pub fn reconstruct(
        &self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        buffers: &SampleBuffers,
        filter: ReconstructFilter,
    ) -> Result<(ScreenFrame, ReconstructTimes)> {
        let (w, h) = (display.width_px, display.height_px);
        let image_err = |e: fovea_core::FoveaError| GpuError::Input(e.to_string());
        let mut out = ScreenFrame {
            color: Image::new(w, h, [0.0f32; 3]).map_err(image_err)?,
            depth: Image::new(w, h, 0.0f32).map_err(image_err)?,
        };
        let times = self.reconstruct_into(
            mapping,
            display,
            buffers,
            filter,
            &mut out.color,
            &mut out.depth,
        )?;
        Ok((out, times))
    }

    /// Maps `buffers` back to the screen of `display` through the polar `mapping`, read with
    /// `filter`, writing every pixel of `color` and `depth` (both of the display's size), as
    /// `fovea_post::inverse_map::reconstruct_into` does on the CPU.
    pub fn reconstruct_into(
        &self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        buffers: &SampleBuffers,
        filter: ReconstructFilter,
        color: &mut Image<Rgb>,
        depth: &mut Image<f32>,
    ) -> Result<ReconstructTimes> {
        let t_start = Instant::now();
        let (w, h) = (display.width_px, display.height_px);
        for (name, size) in [
            ("output colour", (color.width(), color.height())),
            ("output depth", (depth.width(), depth.height())),
        ] {
            if size != (w, h) {
                return Err(GpuError::Input(format!(
                    "{name} is {}x{}, the display {w}x{h}",
                    size.0, size.1
                )));
            }
        }
        if !Self::supports(mapping) {
            return Err(GpuError::Unsupported(format!(
                "reconstructing {} buffers (the GPU reconstructs polar buffers and Weier's: \
                 vafr, kfr, lafr, visual-polar, weier)",
                mapping.method()
            )));
        }
        if mapping.method() == Method::Weier {
            return self.weier_into(mapping, buffers, color, depth);
        }
        let tables = PolarTables::new(mapping, display, buffers, filter)
            .map_err(|e| GpuError::Input(e.to_string()))?;
        let lut: Vec<f32> = tables
            .lut
            .iter()
            .map(|&u| if u.is_finite() { u } else { LUT_UNCOVERED })
            .collect();
        // The shader interpolates between entries k and k + 1 with k ≤ len − 2: a table of
        // fewer than two entries has no interval (an empty screen or a degenerate mapping).
        if lut.len() < 2 {
            return Err(GpuError::Input(format!(
                "the {} mapping's u(r) table has {} entries (at least 2 needed)",
                mapping.method(),
                lut.len()
            )));
        }
        let radial = tables.texels_per_px.as_deref();
        let gpu_columns: Vec<GpuColumn> = tables
            .columns
            .columns()
            .iter()
            .enumerate()
            .map(|(i, c)| GpuColumn {
                base: c.base,
                rows: c.rows,
                period: c.period,
                texels_per_px: radial.and_then(|r| r.get(i)).copied().unwrap_or(1.0),
            })
            .collect();
        let texels = tables.columns.texels();
        let tables_ms = ms_since(t_start);

        // Sizes against the adapter's limits, before any allocation.
        let t_upload = Instant::now();
        let what = format!("the {} reconstruction at {w}x{h}", mapping.method());
        let limits = self.ctx.limits();
        self.ctx
            .check_storage_binding("the reconstruction's u(r) table", lut.len() as u64 * 4)?;
        self.ctx.check_storage_binding(
            "the reconstruction's column table",
            gpu_columns.len() as u64 * COLUMN_BYTES,
        )?;
        self.ctx.check_storage_binding(
            "the polar sample buffer's texels",
            texels.len() as u64 * TEXEL_BYTES,
        )?;
        let row_bytes = w as u64 * OUT_BYTES;
        let binding = self.ctx.max_binding_bytes();
        // One row must fit, and a band may not exceed the dispatch's workgroups in y.
        self.ctx
            .check_storage_binding("one screen row of the reconstruction", row_bytes)?;
        if w.div_ceil(WORKGROUP_SIZE) > limits.max_compute_workgroups_per_dimension {
            return Err(GpuError::Unsupported(format!(
                "a screen {w} px wide (more than {} workgroups of {WORKGROUP_SIZE})",
                limits.max_compute_workgroups_per_dimension
            )));
        }
        let band_rows = (binding / row_bytes)
            .min(limits.max_compute_workgroups_per_dimension as u64)
            .min(h.max(1) as u64)
            .max(1) as u32;
        let bands: Vec<(u32, u32)> = (0..h.div_ceil(band_rows))
            .map(|b| {
                let row0 = b * band_rows;
                (row0, band_rows.min(h - row0))
            })
            .collect();
        let (pole_x_hi, pole_x_lo) = split_f64(tables.centre.x_px);
        let (pole_y_hi, pole_y_lo) = split_f64(tables.centre.y_px);
        let pi = std::f64::consts::PI;
        let uniform_of = |row0: u32, rows: u32| ReconstructUniform {
            pole_hi: [pole_x_hi, pole_y_hi],
            pole_lo: [pole_x_lo, pole_y_lo],
            width: w,
            row0,
            band_rows: rows,
            lut_max_k: (lut.len() - 2) as u32,
            inv_step: (1.0 / tables.lut_step_px) as f32,
            cols_end: (tables.last + 1) as f32,
            last: tables.last as u32,
            miss_depth_bits: f32::INFINITY.to_bits(),
            footprint: u32::from(filter == ReconstructFilter::Footprint),
            turns_per_rad: (0.5 / pi) as f32,
            rad_per_turn: (2.0 * pi) as f32,
            pad: 0,
        };
        let device = self.ctx.device();
        let (readbacks, timer) = self.ctx.scoped(&what, || {
            let storage = wgpu::BufferUsages::STORAGE;
            let lut_buf = upload(&self.ctx, "u(r) table", bytemuck::cast_slice(&lut), storage);
            let col_buf = upload(
                &self.ctx,
                "columns",
                bytemuck::cast_slice(&gpu_columns),
                storage,
            );
            let tex_buf = upload(&self.ctx, "texels", bytemuck::cast_slice(texels), storage);
            let layout = self.pipeline.get_bind_group_layout(0);
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("reconstruct"),
            });
            let timer = PassTimer::new(&self.ctx, "reconstruct timestamps");
            let mut outputs = Vec::with_capacity(bands.len());
            let mut binds = Vec::with_capacity(bands.len());
            for &(row0, rows) in &bands {
                let bytes = rows as u64 * row_bytes;
                let uniform = upload(
                    &self.ctx,
                    "reconstruct parameters",
                    bytemuck::bytes_of(&uniform_of(row0, rows)),
                    wgpu::BufferUsages::UNIFORM,
                );
                let out = self.ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("reconstructed band"),
                    size: bytes,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let bind = self.ctx.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("reconstruct bindings"),
                    layout: &layout,
                    entries: &[
                        entry(0, &uniform),
                        entry(1, &lut_buf),
                        entry(2, &col_buf),
                        entry(3, &tex_buf),
                        entry(4, &out),
                    ],
                });
                outputs.push(out);
                binds.push(bind);
            }
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("reconstruct"),
                    timestamp_writes: timer.as_ref().map(PassTimer::writes),
                });
                pass.set_pipeline(&self.pipeline);
                for (bind, &(_, rows)) in binds.iter().zip(&bands) {
                    pass.set_bind_group(0, bind, &[]);
                    pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), rows, 1);
                }
            }
            let outs: Vec<(&wgpu::Buffer, u64)> =
                outputs.iter().map(|out| (out, out.size())).collect();
            let readbacks = stage(
                &self.ctx,
                &mut encoder,
                &outs,
                "reconstructed band readback",
            );
            if let Some(timer) = &timer {
                timer.resolve(&mut encoder);
            }
            self.ctx.submit([encoder.finish()]);
            (readbacks, timer)
        })?;
        let upload_ms = ms_since(t_upload);

        let t_run = Instant::now();
        let mut all: Vec<&wgpu::Buffer> = readbacks.iter().collect();
        all.extend(timer.as_ref().map(PassTimer::readback));
        let wu = w as usize;
        let mut gpu_pass_ms = None;
        read_buffers(&self.ctx, &all, &what, |k, bytes| {
            if k == bands.len() {
                gpu_pass_ms = Some(PassTimer::ms(&self.ctx, bytes));
                return;
            }
            let (row0, rows) = bands[k];
            // Same bits as the shader's u32s: r, g, b and depth as f32.
            let px: &[[f32; 4]] = bytemuck::cast_slice(bytes);
            let start = row0 as usize * wu;
            let end = start + rows as usize * wu;
            for ((c, d), p) in color.data_mut()[start..end]
                .iter_mut()
                .zip(&mut depth.data_mut()[start..end])
                .zip(px)
            {
                *c = [p[0], p[1], p[2]];
                *d = p[3];
            }
        })?;
        let run_and_readback_ms = ms_since(t_run);
        Ok(ReconstructTimes {
            tables_ms,
            upload_ms,
            run_and_readback_ms,
            gpu_pass_ms,
            total_ms: ms_since(t_start),
            bands: bands.len() as u32,
        })
    }
}

impl GpuReconstructor {
    /// Weier's buffer (the screen, shaded where the mapping says) filled by pull-push, as
    /// `fovea_post::inverse_map::reconstruct_into` does on the CPU. `tables_ms` is the mask,
    /// `gpu_pass_ms` the pull, push and depth passes together.
    fn weier_into(
        &self,
        mapping: &dyn FoveationMapping,
        buffers: &SampleBuffers,
        color: &mut Image<Rgb>,
        depth: &mut Image<f32>,
    ) -> Result<ReconstructTimes> {
        let t_start = Instant::now();
        let (w, h) = (color.width(), color.height());
        let (Some(c), Some(d)) = (buffers.color.first(), buffers.depth.first()) else {
            return Err(GpuError::Input("Weier's frame has no sample buffer".into()));
        };
        for (name, img) in [
            ("colour", (c.width(), c.height())),
            ("depth", (d.width(), d.height())),
        ] {
            if img != (w, h) {
                return Err(GpuError::Input(format!(
                    "Weier's {name} buffer is {}x{}, the screen {w}x{h}",
                    img.0, img.1
                )));
            }
        }
        let mask = mask_of(mapping, w, h);
        let tables_ms = ms_since(t_start);
        let t = self.pull_push.fill_into(c, d, &mask, color, depth)?;
        Ok(ReconstructTimes {
            tables_ms,
            upload_ms: t.upload_ms,
            run_and_readback_ms: t.run_and_readback_ms,
            gpu_pass_ms: t.gpu_passes_ms(),
            total_ms: ms_since(t_start),
            bands: 1,
        })
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
