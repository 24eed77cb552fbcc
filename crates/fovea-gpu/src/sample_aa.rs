//! Sample-space anti-aliasing on the GPU (stage 5 of DESIGN.md, issue 18): FXAA after Lottes'
//! FXAA 3.11 quality variant, as VaFR Sec. 3.4 / 6 runs it in the log-polar buffer (VaFR,
//! visual-polar), and the 3×3 Gaussian of KFR/LMFR (Meng et al. 2018) and LaFR, inside the
//! sample buffer with the polar seam wrapped. The twins of `fovea_post::fxaa::fxaa` and
//! `fovea_post::gaussian_aa::gaussian_3x3`: same neighbours, same arithmetic in the same order.
//!
//! Split of the work:
//!
//! * **Rust, on the CPU**: the grid's tables from [`fovea_post::grid::Grid`] itself — per
//!   column its shaded rows and the column one step left and right (the column itself where
//!   the neighbour is missing or empty), and for a polar grid per texel the row at its angle
//!   in each neighbouring column (`Grid::step`'s f64 `round((j + ½)·period[i±1]/period[i] −
//!   ½)`, wrapped; cached while the layout stays the same). Uploading the rows rather than the
//!   per-column scale keeps the shader off f32 products that round differently near
//!   half-integers (hundreds of texels of a VaFR buffer would get another neighbour).
//! * **WGSL** (`shaders/sample_grid.wgsl`, `fxaa.wgsl`, `gaussian_aa.wgsl`): per texel, the
//!   steps (wrap or clamp), the luma pass and FXAA's search and blend, or the 3×3 sums.
//!
//! Texels are RGB f32, 12 bytes each; the input, the output and FXAA's luma (4 bytes) and
//! alignment table (4 bytes: two rows of at most 65535) must each fit one storage binding,
//! checked before anything is allocated ([`GpuError::AdapterTooSmall`]).

use std::sync::{Arc, Mutex};
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use fovea_core::Image;
use fovea_post::fxaa::FxaaParams;
use fovea_post::grid::Grid;
use fovea_post::Rgb;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::timestamps::PassTimer;
use crate::transfer::{bind_group, read_buffers, stage, upload};

/// FXAA's module: entry points `fxaa_luma` then `fxaa`, [`SampleAaUniform`] at binding 0.
pub const FXAA_SHADER: ShaderSource = ShaderSource {
    file: "fxaa.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/sample_grid.wgsl"),
        include_str!("../shaders/fxaa.wgsl")
    ),
    entry_points: &["fxaa_luma", "fxaa"],
    uniform: ("SampleAaParams", std::mem::size_of::<SampleAaUniform>()),
};

/// The Gaussian's module: entry point `gaussian_3x3`, [`SampleAaUniform`] at binding 0.
pub const GAUSSIAN_SHADER: ShaderSource = ShaderSource {
    file: "gaussian_aa.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/sample_grid.wgsl"),
        include_str!("../shaders/gaussian_aa.wgsl")
    ),
    entry_points: &["gaussian_3x3"],
    uniform: ("SampleAaParams", std::mem::size_of::<SampleAaUniform>()),
};

/// The grid helpers both modules include (after `common.wgsl`).
pub const GRID_FILE: &str = "sample_grid.wgsl";

/// Bytes per texel of the colour buffers (RGB f32).
const RGB_BYTES: u64 = 12;
/// Most FXAA search steps each way the GPU takes (the CPU's default is 12): a bound that keeps
/// the shader's loop finite.
pub const MAX_SEARCH_STEPS: u32 = 1 << 16;
/// Rows a polar column may hold (the alignment table packs two rows into a u32).
pub(crate) const MAX_POLAR_ROWS: u32 = 1 << 16;

/// The uniform block `SampleAaParams` of `sample_grid.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SampleAaUniform {
    /// Texels per row (columns).
    pub width: u32,
    /// Rows of the buffer.
    pub height: u32,
    /// 1: polar grid, 0: rect.
    pub polar: u32,
    /// [`FxaaParams::search_steps`], at most [`MAX_SEARCH_STEPS`].
    pub search_steps: u32,
    /// [`FxaaParams::edge_threshold`].
    pub edge_threshold: f32,
    /// [`FxaaParams::edge_threshold_min`].
    pub edge_threshold_min: f32,
    /// [`FxaaParams::subpix`].
    pub subpix: f32,
    /// Padding.
    pub pad: u32,
}

/// Which filter runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleFilter {
    /// FXAA with these settings (`fovea_post::fxaa::fxaa`).
    Fxaa(FxaaParams),
    /// The 3×3 binomial (`fovea_post::gaussian_aa::gaussian_3x3`).
    Gaussian,
}

/// Where the time of one GPU AA pass went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleAaTimes {
    /// The grid's tables on the CPU (0 when cached), wall ms.
    pub tables_ms: f64,
    /// Buffers, upload, recording and submission, wall ms.
    pub upload_ms: f64,
    /// Submission until the output image was filled (GPU work and readback), wall ms.
    pub run_and_readback_ms: f64,
    /// The compute passes alone, from the device's timestamps (when it has them), ms.
    pub gpu_pass_ms: Option<f64>,
    /// All of the above, wall ms.
    pub total_ms: f64,
}

/// The tables of one grid, as uploaded.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct GridTables {
    /// The buffer's size the tables are for.
    size: (u32, u32),
    /// The polar layout they come from (`None`: rect).
    polar: Option<(Vec<u32>, Vec<f64>)>,
    /// Per column: rows, left column, right column, 0.
    pub(crate) columns: Vec<[u32; 4]>,
    /// Per texel (polar): left row | right row << 16; one 0 for a rect.
    pub(crate) align: Vec<u32>,
}

impl GridTables {
    /// The key this table was built for.
    pub(crate) fn is_for(&self, grid: &Grid, size: (u32, u32)) -> bool {
        self.size == size
            && match (grid, &self.polar) {
                (Grid::Rect { .. }, None) => true,
                (Grid::Polar { rows, period }, Some((r, p))) => rows == r && period == p,
                _ => false,
            }
    }

    pub(crate) fn new(grid: &Grid, (w, h): (u32, u32)) -> Result<Self> {
        match grid {
            Grid::Rect { width, height } => {
                if (*width, *height) != (w, h) {
                    return Err(GpuError::Input(format!(
                        "the AA grid is {width}x{height}, the sample buffer {w}x{h}"
                    )));
                }
                let columns = (0..w)
                    .map(|i| [h, i.saturating_sub(1), (i + 1).min(w - 1), 0])
                    .collect();
                Ok(Self {
                    size: (w, h),
                    polar: None,
                    columns,
                    align: vec![0],
                })
            }
            Grid::Polar { rows, period } => {
                if rows.len() > w as usize || period.len() != rows.len() {
                    return Err(GpuError::Input(format!(
                        "a polar AA grid of {} columns ({} periods) for a sample buffer {w} \
                         texels wide",
                        rows.len(),
                        period.len()
                    )));
                }
                if let Some((i, &r)) = rows.iter().enumerate().find(|(_, &r)| r > h) {
                    return Err(GpuError::Input(format!(
                        "polar column {i} has {r} rows, the sample buffer {h}"
                    )));
                }
                if h > MAX_POLAR_ROWS {
                    return Err(GpuError::Unsupported(format!(
                        "polar AA in a buffer of {h} rows (at most {MAX_POLAR_ROWS})"
                    )));
                }
                let rows_of = |i: u32| rows.get(i as usize).copied().unwrap_or(0);
                let columns: Vec<[u32; 4]> = (0..w)
                    .map(|i| {
                        let r = rows_of(i);
                        let side = |di: i32| {
                            if r == 0 {
                                i
                            } else {
                                grid.step(i, 0, di, 0).0
                            }
                        };
                        [r, side(-1), side(1), 0]
                    })
                    .collect();
                // `Grid::step`'s rows, each column's scale found once, rows in parallel.
                let align = grid.packed_alignment(w, h).ok_or_else(|| {
                    GpuError::Input(format!("a polar AA grid that does not fit {w}x{h}"))
                })?;
                Ok(Self {
                    size: (w, h),
                    polar: Some((rows.clone(), period.clone())),
                    columns,
                    align,
                })
            }
        }
    }
}

/// The AA passes' pipelines on one device; reuse it from frame to frame (it keeps the last
/// polar grid's tables).
pub struct GpuSampleAa {
    ctx: GpuContext,
    fxaa_luma: wgpu::ComputePipeline,
    fxaa: wgpu::ComputePipeline,
    gaussian: wgpu::ComputePipeline,
    tables: Mutex<Option<Arc<GridTables>>>,
}

impl GpuSampleAa {
    /// Compiles both modules on `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        let device = ctx.device();
        let mut fxaa = ctx.scoped("building the FXAA pipelines", || {
            FXAA_SHADER.pipelines(device)
        })?;
        let mut gaussian = ctx.scoped("building the Gaussian AA pipeline", || {
            GAUSSIAN_SHADER.pipelines(device)
        })?;
        let missing = || GpuError::Input("an AA module lacks an entry point".into());
        let gaussian = gaussian.pop().ok_or_else(missing)?;
        let fxaa_main = fxaa.pop().ok_or_else(missing)?;
        let fxaa_luma = fxaa.pop().ok_or_else(missing)?;
        Ok(Self {
            ctx: ctx.clone(),
            fxaa_luma,
            fxaa: fxaa_main,
            gaussian,
            tables: Mutex::new(None),
        })
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Whether a buffer of `grid` fits the device: its RGB texels in one storage binding (a
    /// polar grid counted as its columns times its longest column, the smallest buffer that
    /// holds it) and its rows within one dispatch. A caller that can fall back to the CPU
    /// asks this first; [`Self::run`] checks the actual buffer.
    pub fn fits(&self, grid: &Grid) -> bool {
        let (w, h) = match grid {
            Grid::Rect { width, height } => (*width, *height),
            Grid::Polar { rows, .. } => {
                (rows.len() as u32, rows.iter().copied().max().unwrap_or(0))
            }
        };
        let limits = self.ctx.limits();
        let binding = self.ctx.max_binding_bytes();
        u64::from(w) * u64::from(h) * RGB_BYTES <= binding
            && h <= limits.max_compute_workgroups_per_dimension
            && w.div_ceil(WORKGROUP_SIZE) <= limits.max_compute_workgroups_per_dimension
    }

    /// `filter` applied to the texels of `img` that `grid` marks valid (the others copied), as
    /// `fovea_post::fxaa::fxaa` / `fovea_post::gaussian_aa::gaussian_3x3` do on the CPU.
    pub fn run(
        &self,
        img: &Image<Rgb>,
        grid: &Grid,
        filter: SampleFilter,
    ) -> Result<(Image<Rgb>, SampleAaTimes)> {
        let t_start = Instant::now();
        let (w, h) = (img.width(), img.height());
        let mut out = img.clone();
        if w == 0 || h == 0 {
            return Ok((out, SampleAaTimes::default()));
        }
        // The grid's tables, reused while the layout stays the same. The lock is not held
        // while the pass runs: its submission may wait for the other eye's
        // (`crate::lockstep`).
        let tables = {
            let mut cache = self.tables.lock().unwrap_or_else(|e| e.into_inner());
            match cache.as_ref().filter(|t| t.is_for(grid, (w, h))) {
                Some(t) => t.clone(),
                None => {
                    let t = Arc::new(GridTables::new(grid, (w, h))?);
                    *cache = Some(t.clone());
                    t
                }
            }
        };
        let tables_ms = ms_since(t_start);

        let t_upload = Instant::now();
        let name = match filter {
            SampleFilter::Fxaa(_) => "FXAA",
            SampleFilter::Gaussian => "Gaussian AA",
        };
        let what = format!("{name} of a {w}x{h} sample buffer");
        let texels = w as u64 * h as u64;
        self.ctx
            .check_storage_binding("the AA pass's sample buffer", texels * RGB_BYTES)?;
        self.ctx.check_storage_binding(
            "the AA pass's alignment table",
            tables.align.len() as u64 * 4,
        )?;
        let limits = self.ctx.limits();
        let groups_x = w.div_ceil(WORKGROUP_SIZE);
        let max_groups = limits.max_compute_workgroups_per_dimension;
        if groups_x > max_groups || h > max_groups {
            return Err(GpuError::Unsupported(format!(
                "AA of a {w}x{h} sample buffer (at most {} columns and {max_groups} rows)",
                max_groups as u64 * WORKGROUP_SIZE as u64
            )));
        }
        let params = match filter {
            SampleFilter::Fxaa(p) => p,
            SampleFilter::Gaussian => FxaaParams::default(),
        };
        // The shader's search loop counts to `search_steps` inclusive: a bound keeps it
        // finite (at `u32::MAX` the counter would wrap) and a dispatch short.
        if params.search_steps > MAX_SEARCH_STEPS {
            return Err(GpuError::Input(format!(
                "an FXAA edge search of {} steps each way (at most {MAX_SEARCH_STEPS} on the                  GPU; use --backend cpu)",
                params.search_steps
            )));
        }
        let uniform = SampleAaUniform {
            width: w,
            height: h,
            polar: u32::from(tables.polar.is_some()),
            search_steps: params.search_steps,
            edge_threshold: params.edge_threshold,
            edge_threshold_min: params.edge_threshold_min,
            subpix: params.subpix,
            pad: 0,
        };
        let device = self.ctx.device();
        let bytes = texels * RGB_BYTES;
        let (readback, timer) = self.ctx.scoped(&what, || {
            let storage = wgpu::BufferUsages::STORAGE;
            let uni = upload(
                &self.ctx,
                "AA parameters",
                bytemuck::bytes_of(&uniform),
                wgpu::BufferUsages::UNIFORM,
            );
            let tex = upload(
                &self.ctx,
                "AA input",
                bytemuck::cast_slice(img.data()),
                storage,
            );
            let cols = upload(
                &self.ctx,
                "AA columns",
                bytemuck::cast_slice(&tables.columns),
                storage,
            );
            let align = upload(
                &self.ctx,
                "AA alignment",
                bytemuck::cast_slice(&tables.align),
                storage,
            );
            let out_buf = self.ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("AA output"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let bind = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
                bind_group(&self.ctx, "AA bindings", pipeline, entries)
            };
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sample AA"),
            });
            let timer = PassTimer::new(&self.ctx, "AA timestamps");
            let grid_entries = [(0, &uni), (1, &tex), (2, &cols), (3, &align), (5, &out_buf)];
            match filter {
                SampleFilter::Gaussian => {
                    let group = bind(&self.gaussian, &grid_entries);
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("gaussian_3x3"),
                        timestamp_writes: timer.as_ref().map(PassTimer::writes),
                    });
                    pass.set_pipeline(&self.gaussian);
                    pass.set_bind_group(0, &group, &[]);
                    pass.dispatch_workgroups(groups_x, h, 1);
                }
                SampleFilter::Fxaa(_) => {
                    let lum = self.ctx.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("FXAA luma"),
                        size: texels * 4,
                        usage: storage,
                        mapped_at_creation: false,
                    });
                    let luma_group = bind(&self.fxaa_luma, &[(0, &uni), (1, &tex), (4, &lum)]);
                    let mut all = grid_entries.to_vec();
                    all.push((4, &lum));
                    let fxaa_group = bind(&self.fxaa, &all);
                    // Two passes: every luma is written before any texel reads its neighbours'.
                    {
                        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                            label: Some("fxaa_luma"),
                            timestamp_writes: timer.as_ref().map(PassTimer::begin_writes),
                        });
                        pass.set_pipeline(&self.fxaa_luma);
                        pass.set_bind_group(0, &luma_group, &[]);
                        pass.dispatch_workgroups(groups_x, h, 1);
                    }
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("fxaa"),
                        timestamp_writes: timer.as_ref().map(PassTimer::end_writes),
                    });
                    pass.set_pipeline(&self.fxaa);
                    pass.set_bind_group(0, &fxaa_group, &[]);
                    pass.dispatch_workgroups(groups_x, h, 1);
                }
            }
            let read =
                stage(&self.ctx, &mut encoder, &[(&out_buf, bytes)], "AA readback").remove(0);
            if let Some(timer) = &timer {
                timer.resolve(&mut encoder);
            }
            self.ctx.submit([encoder.finish()]);
            (read, timer)
        })?;
        drop(tables);
        let upload_ms = ms_since(t_upload);

        let t_run = Instant::now();
        let mut buffers = vec![&readback];
        buffers.extend(timer.as_ref().map(PassTimer::readback));
        let mut gpu_pass_ms = None;
        let mut short_read = None;
        read_buffers(&self.ctx, &buffers, &what, |k, data| {
            if k == 0 {
                let dst: &mut [u8] = bytemuck::cast_slice_mut(out.data_mut());
                if dst.len() == data.len() {
                    dst.copy_from_slice(data);
                } else {
                    short_read = Some(data.len());
                }
            } else {
                gpu_pass_ms = Some(PassTimer::ms(&self.ctx, data));
            }
        })?;
        if let Some(got) = short_read {
            return Err(GpuError::Validation {
                what,
                message: format!("read back {got} bytes, expected {bytes}"),
            });
        }
        let run_and_readback_ms = ms_since(t_run);
        Ok((
            out,
            SampleAaTimes {
                tables_ms,
                upload_ms,
                run_and_readback_ms,
                gpu_pass_ms,
                total_ms: ms_since(t_start),
            },
        ))
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
