//! The resident frame's polar reconstruction (VaFR Sec. 3.4 / Eq. 10–11; the reconstruct stage
//! of DESIGN.md): a polar sample buffer that lives on the device ([`DeviceSamples`]) back to
//! the screen, recorded into the caller's command encoder — nothing is read back and, from one
//! frame to the next, only what changed goes up.
//!
//! Passes per frame:
//!
//! 0. With sample-space AA: the layer's colour into a planar RGB buffer
//!    (`frame_screen_split.wgsl`), then FXAA (`fxaa.wgsl`: luma, then edge search and blend;
//!    VaFR Sec. 3.4) or the 3×3 Gaussian (`gaussian_aa.wgsl`), the per-call path's shaders on
//!    the grid tables of `fovea_post::grid::Grid` (built on the CPU when the layout changes,
//!    sent as the entries that changed); columns whose texels are denser than the screen keep
//!    their samples' colour (`minified_columns`, as the CPU's `restore_columns`).
//! 1. `frame_polar_columns.wgsl::pad_columns`: the sample layer laid out column by column,
//!    each column padded by one row on either side, and for [`ReconstructFilter::Footprint`]
//!    each column's colour boxed along its rows to a pixel's width — on the device, where
//!    `fovea_post::inverse_map::PolarColumns::new` does it on the CPU for the other paths.
//! 2. `polar_reconstruct.wgsl::reconstruct_planes` (the per-call path's own shader, its
//!    planar entry point): per pixel, `u(r)` from the lookup table, the angle, bilinear across
//!    the two nearest columns or the footprint's box across columns, written straight into the
//!    screen's planes — red, green, blue, depth bits, 4 bytes a pixel each, the caller's
//!    buffers ([`ScreenPlanes`]) — so no binding holds more than 4 bytes a screen pixel (an 8K
//!    plane is 126.6 MiB, within lavapipe's 128 MiB; issue 37).
//!
//! What the CPU still builds, from the mapping alone (never from the samples): the `u(r)`
//! lookup table (`fovea_post::inverse_map::polar_lut`, the CPU reconstruction's own) and per
//! column its base, rows, period, radial footprint `du/dr` and angular prefilter width
//! (`fovea_post::inverse_map::column_footprints`). They depend on the mapping and its pole, so
//! they are rebuilt when the mapping changes (a new gaze), kept otherwise, and each goes up as
//! the range of entries that differs from what the device already holds. The buffers are sized
//! once for the context's limits (the most columns and rows a buffer of the method may have,
//! the lookup table for the screen's diagonal) and are never reallocated for a new gaze.

use bytemuck::{Pod, Zeroable};
use fovea_core::display::DisplayProfile;
use fovea_core::mapping::FoveationMapping;
use fovea_post::fxaa::FxaaParams;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::{
    column_footprints, minified_columns, polar_lut, polar_lut_len, polar_lut_to, PolarColumns,
    ReconstructFilter, LUT_STEP_PX,
};

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::frame::samples::DeviceSamples;
use crate::frame::screen::{SplitUniform, SPLIT_SHADER};
use crate::mapping::vafr::split_f64;
use crate::reconstruct::ReconstructUniform;
use crate::sample_aa::{
    GridTables, SampleAaUniform, SampleFilter, FXAA_SHADER, GAUSSIAN_SHADER, MAX_POLAR_ROWS,
    MAX_SEARCH_STEPS,
};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::transfer::bind_group;

/// The column layout module: entry point `pad_columns`, [`PadUniform`] at binding 0.
pub const PAD_SHADER: ShaderSource = ShaderSource {
    file: "frame_polar_columns.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/frame_polar_columns.wgsl")
    ),
    entry_points: &["pad_columns"],
    uniform: ("PadParams", std::mem::size_of::<PadUniform>()),
};

/// Bytes of a padded texel (`vec4<u32>`).
const TEXEL_BYTES: u64 = 16;

/// The screen buffers the reconstruction writes, 4 bytes a pixel each (f32 bits): red, green,
/// blue and depth (+∞ for a pixel no sample covers). The caller's — the screen side's own
/// planar colour and depth.
pub struct ScreenPlanes<'a> {
    /// Red, green and blue.
    pub color: [&'a wgpu::Buffer; 3],
    /// Depth.
    pub depth: &'a wgpu::Buffer,
}
/// What the lookup table holds where the mapping has no sample (as `crate::reconstruct`).
const LUT_UNCOVERED: f32 = 1e30;
/// A prefilter width standing for "the whole column" (the CPU's +∞ at the pole), finite so
/// that no infinity reaches the shader.
const WHOLE_COLUMN: f32 = 1e30;

/// The uniform block `PadParams` of `frame_polar_columns.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PadUniform {
    /// The layer's first texel in the sample buffer.
    pub offset: u32,
    /// The layer's width (row stride), texels.
    pub width: u32,
    /// Columns to lay out.
    pub n_columns: u32,
    /// Most stored texels of any column (rows + 2).
    pub stored_max: u32,
    /// 1: colour from the AA output where the column is not kept.
    pub aa: u32,
    /// Padding to 32 bytes.
    pub pad: [u32; 3],
}

/// One column as both shaders read it (`Column` / `PadColumn`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameColumn {
    /// First stored texel (the copy of the last row).
    pub base: u32,
    /// Stored rows (at least 1).
    pub rows: u32,
    /// Rows per turn (0: no shaded rows).
    pub period: f32,
    /// Columns per pixel radially (`du/dr`; 1 for bilinear).
    pub texels_per_px: f32,
}

/// The most a polar buffer of this context may hold; a mapping beyond them needs a new
/// context ([`crate::frame::ScreenContext::fits`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PolarCapacity {
    /// Columns (the buffer's width).
    pub columns: u32,
    /// Rows (the buffer's height).
    pub rows: u32,
    /// Padded texels of the columns (every column's rows and the two copies around them).
    pub texels: u64,
    /// Texels of the buffer's rectangle (width × height; the sample-space AA's buffers).
    pub rect_texels: u64,
    /// Entries of the `u(r)` table.
    pub lut_entries: u32,
}

impl PolarCapacity {
    /// The reconstruction's storage bindings for this capacity, named as an error names them:
    /// the `u(r)` table, the column records, the columns' prefilter widths and the padded
    /// columns (16 bytes a texel) — what [`ResidentPolar::new`] checks and allocates.
    pub fn bindings(&self) -> [(&'static str, u64); 4] {
        let columns = u64::from(self.columns.max(1));
        [
            (
                "the reconstruction's u(r) table",
                u64::from(self.lut_entries.max(2)) * 4,
            ),
            ("the reconstruction's column table", columns * 16),
            ("the reconstruction's prefilter widths", columns * 4),
            ("the padded polar columns", self.texels.max(1) * TEXEL_BYTES),
        ]
    }

    /// Entries of the `u(r)` table that reaches every screen pixel from a pole anywhere on a
    /// `w × h` screen: the diagonal plus 2 px ([`polar_lut`]), every [`LUT_STEP_PX`].
    pub fn lut_for_screen(w: u32, h: u32) -> u32 {
        ((f64::from(w).hypot(f64::from(h)) + 2.0) / LUT_STEP_PX).ceil() as u32 + 3
    }
}

/// The tables of one mapping, as they were last sent to the device.
#[derive(Default)]
struct Tables {
    /// What identifies the mapping they came from: its pole, buffers and parameters.
    key: Option<String>,
    lut: Vec<f32>,
    columns: Vec<FrameColumn>,
    extra: Vec<f32>,
    last: u32,
    stored_max: u32,
    centre: (f64, f64),
}

/// Bytes that went up for the tables of the last [`ResidentPolar::prepare`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TableUpload {
    /// Of the `u(r)` table.
    pub lut_bytes: u64,
    /// Of the column records and prefilter widths.
    pub column_bytes: u64,
    /// Whether the tables were rebuilt on the CPU (a new mapping).
    pub rebuilt: bool,
}

/// The sample-space AA passes' pipelines, buffers and tables.
struct AaStage {
    filter: SampleFilter,
    split: wgpu::ComputePipeline,
    luma: Option<wgpu::ComputePipeline>,
    main: wgpu::ComputePipeline,
    uniform: wgpu::Buffer,
    split_uniform: wgpu::Buffer,
    input: wgpu::Buffer,
    depth_scratch: wgpu::Buffer,
    columns: wgpu::Buffer,
    align: wgpu::Buffer,
    out: wgpu::Buffer,
    luma_bind: Option<wgpu::BindGroup>,
    main_bind: wgpu::BindGroup,
    /// The split's bindings (they name the caller's sample buffer).
    split_bind: Option<wgpu::BindGroup>,
    /// The grid tables as the device holds them.
    tables: Option<GridTables>,
}

/// The resident polar reconstruction of one eye (see the module).
pub struct ResidentPolar {
    ctx: GpuContext,
    filter: ReconstructFilter,
    width: u32,
    height: u32,
    capacity: PolarCapacity,
    pad: wgpu::ComputePipeline,
    reconstruct: wgpu::ComputePipeline,
    pad_uniform: wgpu::Buffer,
    rec_uniform: wgpu::Buffer,
    lut: wgpu::Buffer,
    columns: wgpu::Buffer,
    extra: wgpu::Buffer,
    texels: wgpu::Buffer,
    rec_bind: wgpu::BindGroup,
    /// The pad pass's bindings and the sample buffer they bind.
    pad_bind: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    tables: Tables,
    last_upload: TableUpload,
    aa: Option<AaStage>,
    keep: wgpu::Buffer,
    keep_sent: Vec<u32>,
    /// The layer's size at the last [`Self::prepare`].
    layer_size: (u32, u32),
}

impl ResidentPolar {
    /// Buffers, pipelines and the reconstruction's bind group for a `display`-sized screen
    /// written into `screen` and polar buffers within `capacity`, read with `filter`. Every
    /// size is checked against the adapter's limits first ([`GpuError::AdapterTooSmall`]; the
    /// screen's planes are the caller's to check, [`crate::frame::ScreenSizes`]).
    pub fn new(
        ctx: &GpuContext,
        display: &DisplayProfile,
        filter: ReconstructFilter,
        aa: Option<SampleFilter>,
        capacity: PolarCapacity,
        screen: ScreenPlanes<'_>,
    ) -> Result<Self> {
        let (w, h) = (display.width_px, display.height_px);
        let limits = ctx.limits();
        let groups = limits.max_compute_workgroups_per_dimension;
        if w.div_ceil(WORKGROUP_SIZE) > groups || h > groups || capacity.columns > groups {
            return Err(GpuError::Unsupported(format!(
                "a {w}x{h} screen from {} columns in one dispatch (at most {groups} workgroups \
                 a side)",
                capacity.columns
            )));
        }
        let [lut_bytes, col_bytes, extra_bytes, texel_bytes] = capacity.bindings().map(|(_, b)| b);
        for (what, bytes) in capacity.bindings() {
            ctx.check_storage_binding(what, bytes)?;
        }
        let aa_stage = match aa {
            Some(f) => Some(AaStage::new(ctx, f, capacity)?),
            None => None,
        };
        let keep = ctx.scoped("building the resident polar reconstruction", || {
            ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("kept columns"),
                size: u64::from(capacity.columns.max(1)) * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let device = ctx.device();
        ctx.scoped("building the resident polar reconstruction", || {
            let pad = PAD_SHADER.pipelines(device).pop();
            let reconstruct = crate::reconstruct::SHADER
                .pipelines_of(device, &["reconstruct_planes"])
                .pop();
            let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
            let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
                ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage,
                    mapped_at_creation: false,
                })
            };
            let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
            let pad_uniform = buffer(
                "pad parameters",
                std::mem::size_of::<PadUniform>() as u64,
                uniform,
            );
            let rec_uniform = buffer(
                "reconstruct parameters",
                std::mem::size_of::<ReconstructUniform>() as u64,
                uniform,
            );
            let lut = buffer("u(r) table", lut_bytes, storage);
            let columns = buffer("columns", col_bytes, storage);
            let extra = buffer("column prefilter widths", extra_bytes, storage);
            let texels = buffer("padded columns", texel_bytes, wgpu::BufferUsages::STORAGE);
            (
                pad,
                reconstruct,
                pad_uniform,
                rec_uniform,
                lut,
                columns,
                extra,
                texels,
            )
        })
        .and_then(
            |(pad, reconstruct, pad_uniform, rec_uniform, lut, columns, extra, texels)| {
                let missing = || GpuError::Input("a reconstruction module has no entry".into());
                let (pad, reconstruct) =
                    (pad.ok_or_else(missing)?, reconstruct.ok_or_else(missing)?);
                let rec_bind = ctx.scoped("binding the resident reconstruction", || {
                    bind_group(
                        ctx,
                        "resident reconstruct",
                        &reconstruct,
                        &[
                            (0, &rec_uniform),
                            (1, &lut),
                            (2, &columns),
                            (3, &texels),
                            (5, screen.color[0]),
                            (6, screen.color[1]),
                            (7, screen.color[2]),
                            (8, screen.depth),
                        ],
                    )
                })?;
                Ok(Self {
                    ctx: ctx.clone(),
                    filter,
                    width: w,
                    height: h,
                    capacity,
                    pad,
                    reconstruct,
                    pad_uniform,
                    rec_uniform,
                    lut,
                    columns,
                    extra,
                    texels,
                    rec_bind,
                    pad_bind: None,
                    tables: Tables::default(),
                    last_upload: TableUpload::default(),
                    aa: aa_stage,
                    keep,
                    keep_sent: Vec::new(),
                    layer_size: (0, 0),
                })
            },
        )
    }

    /// What the last [`Self::prepare`] sent up for the tables.
    pub fn last_upload(&self) -> TableUpload {
        self.last_upload
    }

    /// Bytes of the tables as the device holds them now (`u(r)` table, column records and
    /// prefilter widths).
    pub fn table_bytes(&self) -> (u64, u64) {
        (
            self.tables.lut.len() as u64 * 4,
            self.tables.columns.len() as u64 * 20,
        )
    }

    /// Whether `mapping`'s buffer fits the context's capacity.
    pub fn fits(&self, mapping: &dyn FoveationMapping) -> bool {
        let Some(layout) = mapping.polar_layout() else {
            return false;
        };
        mapping.buffers().first().is_some_and(|b| {
            b.width <= self.capacity.columns
                && b.height <= self.capacity.rows
                && PolarColumns::texel_count(&layout, b.height) <= self.capacity.texels
                && b.pixels() <= self.capacity.rect_texels
                && (self.aa.is_none() || b.height <= MAX_POLAR_ROWS)
        })
    }

    /// Brings the tables on the device up to `mapping` (rebuilding them on the CPU only when
    /// the mapping differs from the last one, uploading only the entries that changed) and
    /// writes the two passes' uniforms. Call before [`Self::record`], once per frame.
    pub fn prepare(
        &mut self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        samples: &DeviceSamples,
    ) -> Result<()> {
        let layer = *samples
            .layers()
            .first()
            .ok_or_else(|| GpuError::Input("the frame's sample buffers have no layer".into()))?;
        let sizes = mapping.buffers();
        if sizes.len() != 1
            || samples.layers().len() != 1
            || (sizes[0].width, sizes[0].height) != (layer.width, layer.height)
        {
            return Err(GpuError::Input(format!(
                "the {} mapping's buffers {sizes:?} are not the device's sample layers {:?}",
                mapping.method(),
                samples.layers()
            )));
        }
        if (display.width_px, display.height_px) != (self.width, self.height) {
            return Err(GpuError::Input(format!(
                "a {}x{} display for a screen context of {}x{}",
                display.width_px, display.height_px, self.width, self.height
            )));
        }
        if !self.fits(mapping) {
            return Err(GpuError::Input(format!(
                "the {} buffer {}x{} exceeds the screen context's {}x{} (build a new context \
                 with larger limits)",
                mapping.method(),
                layer.width,
                layer.height,
                self.capacity.columns,
                self.capacity.rows
            )));
        }
        let key = mapping_key(mapping, display);
        let mut upload = TableUpload::default();
        if self.tables.key.as_deref() != Some(key.as_str()) {
            let t = self.build_tables(mapping, display, layer.height)?;
            upload = self.send_tables(t, key)?;
            upload.column_bytes += self.send_aa_tables(mapping, (layer.width, layer.height))?;
        }
        self.last_upload = upload;
        self.layer_size = (layer.width, layer.height);
        let t = &self.tables;
        let pad = PadUniform {
            offset: layer.offset,
            width: layer.width,
            n_columns: t.columns.len() as u32,
            stored_max: t.stored_max,
            aa: u32::from(self.aa.is_some()),
            pad: [0; 3],
        };
        // The pole is this frame's (a gaze-free layout's tables were built at another gaze).
        let centre = mapping
            .polar_layout()
            .map_or(t.centre, |l| (l.centre.x_px, l.centre.y_px));
        let (px_hi, px_lo) = split_f64(centre.0);
        let (py_hi, py_lo) = split_f64(centre.1);
        let pi = std::f64::consts::PI;
        let rec = ReconstructUniform {
            pole_hi: [px_hi, py_hi],
            pole_lo: [px_lo, py_lo],
            width: self.width,
            row0: 0,
            band_rows: self.height,
            lut_max_k: (t.lut.len() - 2) as u32,
            inv_step: (1.0 / LUT_STEP_PX) as f32,
            cols_end: (t.last + 1) as f32,
            last: t.last,
            miss_depth_bits: f32::INFINITY.to_bits(),
            footprint: u32::from(self.filter == ReconstructFilter::Footprint),
            turns_per_rad: (0.5 / pi) as f32,
            rad_per_turn: (2.0 * pi) as f32,
            pad: 0,
        };
        let same_samples = self
            .pad_bind
            .as_ref()
            .is_some_and(|(b, _)| b == samples.buffer());
        self.ctx
            .scoped("preparing the resident reconstruction", || {
                self.ctx
                    .write_buffer(&self.pad_uniform, 0, bytemuck::bytes_of(&pad));
                self.ctx
                    .write_buffer(&self.rec_uniform, 0, bytemuck::bytes_of(&rec));
                if let Some(aa) = &self.aa {
                    let params = match aa.filter {
                        SampleFilter::Fxaa(p) => p,
                        SampleFilter::Gaussian => FxaaParams::default(),
                    };
                    let u = SampleAaUniform {
                        width: layer.width,
                        height: layer.height,
                        polar: 1,
                        search_steps: params.search_steps,
                        edge_threshold: params.edge_threshold,
                        edge_threshold_min: params.edge_threshold_min,
                        subpix: params.subpix,
                        pad: 0,
                    };
                    let split = SplitUniform {
                        offset: layer.offset,
                        width: layer.width,
                        height: layer.height,
                        pad: 0,
                    };
                    self.ctx
                        .write_buffer(&aa.uniform, 0, bytemuck::bytes_of(&u));
                    self.ctx
                        .write_buffer(&aa.split_uniform, 0, bytemuck::bytes_of(&split));
                }
                if !same_samples {
                    let aa_rgb = self.aa.as_ref().map_or(&self.keep, |a| &a.out);
                    let bind = bind_group(
                        &self.ctx,
                        "resident column layout",
                        &self.pad,
                        &[
                            (0, &self.pad_uniform),
                            (1, &self.columns),
                            (2, &self.extra),
                            (3, samples.buffer()),
                            (4, &self.texels),
                            (5, aa_rgb),
                            (6, &self.keep),
                        ],
                    );
                    self.pad_bind = Some((samples.buffer().clone(), bind));
                    if let Some(aa) = &mut self.aa {
                        aa.split_bind = Some(bind_group(
                            &self.ctx,
                            "resident AA input",
                            &aa.split,
                            &[
                                (0, &aa.split_uniform),
                                (1, samples.buffer()),
                                (2, &aa.input),
                                (3, &aa.depth_scratch),
                            ],
                        ));
                    }
                }
            })
    }

    /// Records the passes (sample-space AA when configured, column layout, reconstruction)
    /// into `encoder`, timed by `timer` at `pass_index`, `+ 1`, `+ 2` when given.
    /// [`Self::prepare`] first.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut crate::frame::FrameTimer>,
        pass_index: usize,
    ) -> Result<()> {
        let Some((_, pad_bind)) = &self.pad_bind else {
            return Err(GpuError::Input(
                "the resident reconstruction was recorded before it was prepared".into(),
            ));
        };
        let t = &self.tables;
        if let Some(aa) = &self.aa {
            let Some(split_bind) = &aa.split_bind else {
                return Err(GpuError::Input("the AA input has no bindings".into()));
            };
            let (w, h) = self.layer_size;
            let groups = w.div_ceil(WORKGROUP_SIZE);
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("sample-space AA"),
                timestamp_writes: timer.as_deref_mut().and_then(|t| t.writes(pass_index)),
            });
            pass.set_pipeline(&aa.split);
            pass.set_bind_group(0, split_bind, &[]);
            pass.dispatch_workgroups(groups, h, 1);
            if let (Some(luma), Some(bind)) = (&aa.luma, &aa.luma_bind) {
                pass.set_pipeline(luma);
                pass.set_bind_group(0, bind, &[]);
                pass.dispatch_workgroups(groups, h, 1);
            }
            pass.set_pipeline(&aa.main);
            pass.set_bind_group(0, &aa.main_bind, &[]);
            pass.dispatch_workgroups(groups, h, 1);
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("polar columns"),
                timestamp_writes: timer.as_deref_mut().and_then(|t| t.writes(pass_index + 1)),
            });
            pass.set_pipeline(&self.pad);
            pass.set_bind_group(0, pad_bind, &[]);
            pass.dispatch_workgroups(
                t.stored_max.div_ceil(WORKGROUP_SIZE),
                t.columns.len() as u32,
                1,
            );
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("polar reconstruct"),
            timestamp_writes: timer.and_then(|t| t.writes(pass_index + 2)),
        });
        pass.set_pipeline(&self.reconstruct);
        pass.set_bind_group(0, &self.rec_bind, &[]);
        pass.dispatch_workgroups(self.width.div_ceil(WORKGROUP_SIZE), self.height, 1);
        Ok(())
    }

    /// The tables of `mapping` from the CPU's own functions.
    fn build_tables(
        &self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        buffer_height: u32,
    ) -> Result<Tables> {
        let layout = mapping.polar_layout().ok_or_else(|| {
            GpuError::Unsupported(format!("{} is not a polar mapping", mapping.method()))
        })?;
        let last = layout.rows.iter().rposition(|&r| r > 0).ok_or_else(|| {
            GpuError::Input(format!(
                "the {} buffer has no shaded samples",
                mapping.method()
            ))
        })?;
        let raw = if mapping.layout_is_gaze_free() {
            // Out to the farthest corner of any gaze on the screen, so the table holds wherever
            // the pole moves (`mapping_key` leaves the pole out).
            polar_lut_to(mapping, layout.centre, gaze_free_lut_len(mapping, display))
        } else {
            polar_lut(mapping, layout.centre, display.width_px, display.height_px)
        };
        if raw.len() < 2 || raw.len() > self.capacity.lut_entries as usize {
            return Err(GpuError::Input(format!(
                "the {} mapping's u(r) table has {} entries (2 to {}: a pole on the screen)",
                mapping.method(),
                raw.len(),
                self.capacity.lut_entries
            )));
        }
        let footprint = (self.filter == ReconstructFilter::Footprint)
            .then(|| column_footprints(&raw, &layout, last));
        let mut columns = Vec::with_capacity(layout.rows.len());
        let mut extra = Vec::with_capacity(layout.rows.len());
        let (mut base, mut stored_max) = (0u32, 0u32);
        for (i, (&rows, &period)) in layout.rows.iter().zip(&layout.period).enumerate() {
            let rows = rows.min(buffer_height);
            let stored = rows.max(1) + 2;
            columns.push(FrameColumn {
                base,
                rows: rows.max(1),
                period: if rows == 0 { 0.0 } else { period as f32 },
                texels_per_px: footprint
                    .as_ref()
                    .and_then(|f| f.texels_per_px.get(i))
                    .copied()
                    .unwrap_or(1.0),
            });
            let e = footprint
                .as_ref()
                .and_then(|f| f.rows_per_px.get(i))
                .map_or(0.0, |&r| r - 1.0);
            extra.push(if e.is_finite() { e } else { WHOLE_COLUMN });
            base += stored;
            stored_max = stored_max.max(stored);
        }
        if u64::from(base) > self.capacity.texels {
            return Err(GpuError::Input(format!(
                "the {} buffer's padded columns ({base} texels) exceed the context's {}",
                mapping.method(),
                self.capacity.texels
            )));
        }
        let lut = raw
            .iter()
            .map(|&u| if u.is_finite() { u } else { LUT_UNCOVERED })
            .collect();
        Ok(Tables {
            key: None,
            lut,
            columns,
            extra,
            last: last as u32,
            stored_max,
            centre: (layout.centre.x_px, layout.centre.y_px),
        })
    }

    /// Sends the entries of `new` that differ from the device's copy; keeps `new` as that copy.
    fn send_tables(&mut self, new: Tables, key: String) -> Result<TableUpload> {
        let old = std::mem::take(&mut self.tables);
        let ctx = &self.ctx;
        let (lut_bytes, column_bytes) =
            ctx.scoped("uploading the reconstruction's tables", || {
                let lut = write_changed(ctx, &self.lut, &old.lut, &new.lut);
                let cols = write_changed(ctx, &self.columns, &old.columns, &new.columns);
                let extra = write_changed(ctx, &self.extra, &old.extra, &new.extra);
                (lut, cols + extra)
            })?;
        self.tables = Tables {
            key: Some(key),
            ..new
        };
        Ok(TableUpload {
            lut_bytes,
            column_bytes,
            rebuilt: true,
        })
    }
}

impl ResidentPolar {
    /// With AA: the grid tables of `mapping`'s layout (rebuilt only when the layout changed)
    /// and the kept columns, each sent as the entries that changed. Returns the bytes sent.
    fn send_aa_tables(&mut self, mapping: &dyn FoveationMapping, size: (u32, u32)) -> Result<u64> {
        let Some(aa) = &mut self.aa else {
            return Ok(0);
        };
        let layout = mapping.polar_layout().ok_or_else(|| {
            GpuError::Unsupported(format!("{} is not a polar mapping", mapping.method()))
        })?;
        let grid = Grid::polar(&layout);
        let ctx = &self.ctx;
        let mut bytes = 0;
        if !aa.tables.as_ref().is_some_and(|t| t.is_for(&grid, size)) {
            let new = GridTables::new(&grid, size)?;
            let (old_cols, old_align) = aa
                .tables
                .as_ref()
                .map_or((&[][..], &[][..]), |t| (&t.columns[..], &t.align[..]));
            bytes += ctx.scoped("uploading the AA grid tables", || {
                write_changed(ctx, &aa.columns, old_cols, &new.columns)
                    + write_changed(ctx, &aa.align, old_align, &new.align)
            })?;
            aa.tables = Some(new);
        }
        let mut keep: Vec<u32> = match self.filter {
            ReconstructFilter::Footprint => minified_columns(mapping)
                .unwrap_or_default()
                .into_iter()
                .map(u32::from)
                .collect(),
            ReconstructFilter::Bilinear => Vec::new(),
        };
        keep.resize(size.0 as usize, 0);
        bytes += ctx.scoped("uploading the kept columns", || {
            write_changed(ctx, &self.keep, &self.keep_sent, &keep)
        })?;
        self.keep_sent = keep;
        Ok(bytes)
    }
}

impl AaStage {
    /// Pipelines, buffers (sized for `capacity`) and the bind groups that name no caller's
    /// buffer.
    fn new(ctx: &GpuContext, filter: SampleFilter, capacity: PolarCapacity) -> Result<Self> {
        if let SampleFilter::Fxaa(p) = filter {
            if p.search_steps > MAX_SEARCH_STEPS {
                return Err(GpuError::Input(format!(
                    "an FXAA edge search of {} steps each way (at most {MAX_SEARCH_STEPS} on \
                     the GPU)",
                    p.search_steps
                )));
            }
        }
        if capacity.rows > MAX_POLAR_ROWS {
            return Err(GpuError::Unsupported(format!(
                "sample-space AA in a buffer of {} rows (at most {MAX_POLAR_ROWS})",
                capacity.rows
            )));
        }
        let n = capacity.rect_texels.max(1);
        for (what, bytes) in [
            ("the AA pass's sample colour", n * 12),
            ("the AA pass's alignment table", n * 4),
        ] {
            ctx.check_storage_binding(what, bytes)?;
        }
        let device = ctx.device();
        let missing = || GpuError::Input("an AA module lacks an entry point".into());
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            crate::transfer::empty(ctx, label, size, usage)
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let what = "building the resident sample-space AA";
        let (split, luma, main) = ctx.scoped(what, || {
            let split = SPLIT_SHADER.pipelines_of(device, &["split_screen"]).pop();
            let (luma, main) = match filter {
                SampleFilter::Fxaa(_) => {
                    let mut p = FXAA_SHADER.pipelines(device);
                    let main = p.pop();
                    (p.pop(), main)
                }
                SampleFilter::Gaussian => (None, GAUSSIAN_SHADER.pipelines(device).pop()),
            };
            (split, luma, main)
        })?;
        let split = split.ok_or_else(missing)?;
        let main = main.ok_or_else(missing)?;
        ctx.scoped(what, || {
            let aa_uniform = buffer(
                "AA parameters",
                std::mem::size_of::<SampleAaUniform>() as u64,
                uniform,
            );
            let split_uniform = buffer(
                "AA input parameters",
                std::mem::size_of::<SplitUniform>() as u64,
                uniform,
            );
            let input = buffer("AA input", n * 12, storage);
            let depth_scratch = buffer("AA input depth (unused)", n * 4, storage);
            let columns = buffer(
                "AA columns",
                u64::from(capacity.columns.max(1)) * 16,
                storage | wgpu::BufferUsages::COPY_DST,
            );
            let align = buffer(
                "AA alignment",
                n * 4,
                storage | wgpu::BufferUsages::COPY_DST,
            );
            let lum = buffer("FXAA luma", n * 4, storage);
            let out = buffer("AA output", n * 12, storage);
            let luma_bind = luma.as_ref().map(|l| {
                bind_group(
                    ctx,
                    "resident FXAA luma",
                    l,
                    &[(0, &aa_uniform), (1, &input), (4, &lum)],
                )
            });
            let mut entries = vec![
                (0, &aa_uniform),
                (1, &input),
                (2, &columns),
                (3, &align),
                (5, &out),
            ];
            if luma.is_some() {
                entries.push((4, &lum));
            }
            let main_bind = bind_group(ctx, "resident AA", &main, &entries);
            Self {
                filter,
                split,
                luma,
                main,
                uniform: aa_uniform,
                split_uniform,
                input,
                depth_scratch,
                columns,
                align,
                out,
                luma_bind,
                main_bind,
                split_bind: None,
                tables: None,
            }
        })
    }
}

/// What identifies a mapping's tables: its method, pole, buffers and parameters. A gaze-free
/// layout (`FoveationMapping::layout_is_gaze_free`) leaves the pole out — its tables hold at
/// every gaze with the same buffers and parameters — and puts the `u(r)` table's length in
/// (longer only for a pole off the screen, farther from a corner than the diagonal).
fn mapping_key(mapping: &dyn FoveationMapping, display: &DisplayProfile) -> String {
    let gaze_free = mapping.layout_is_gaze_free();
    let c = mapping.polar_layout().map(|l| l.centre);
    let pole = if gaze_free {
        format!("any pole, {} entries", gaze_free_lut_len(mapping, display))
    } else {
        format!("{:?}", c.map(|c| (c.x_px.to_bits(), c.y_px.to_bits())))
    };
    format!(
        "{}|{pole}|{:?}|{}",
        mapping.method(),
        mapping.buffers(),
        mapping.params()
    )
}

/// Entries of a gaze-free layout's `u(r)` table: out to the screen's diagonal plus 2 px (the
/// farthest corner of any pole on the screen), or to this pole's farthest corner where that
/// lies farther.
fn gaze_free_lut_len(mapping: &dyn FoveationMapping, display: &DisplayProfile) -> usize {
    let (w, h) = (f64::from(display.width_px), f64::from(display.height_px));
    let far = mapping.polar_layout().map_or(0.0, |l| {
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(x, y)| (x - l.centre.x_px).hypot(y - l.centre.y_px))
            .fold(0.0, f64::max)
    });
    polar_lut_len(w.hypot(h).max(far) + 2.0)
}

/// Writes the entries of `new` from the first that differs from `old` to the last that does
/// (or to its end when it is longer) into `buffer`; returns the bytes written.
fn write_changed<T: Pod>(ctx: &GpuContext, buffer: &wgpu::Buffer, old: &[T], new: &[T]) -> u64 {
    let same = |k: usize| bytemuck::bytes_of(&old[k]) == bytemuck::bytes_of(&new[k]);
    let common = old.len().min(new.len());
    let first = (0..common).find(|&k| !same(k)).unwrap_or(common);
    let end = if new.len() > common {
        new.len()
    } else {
        (first..common)
            .rev()
            .find(|&k| !same(k))
            .map_or(first, |k| k + 1)
    };
    if end <= first {
        return 0;
    }
    let size = std::mem::size_of::<T>() as u64;
    let bytes: &[u8] = bytemuck::cast_slice(&new[first..end]);
    ctx.write_buffer(buffer, first as u64 * size, bytes);
    bytes.len() as u64
}
