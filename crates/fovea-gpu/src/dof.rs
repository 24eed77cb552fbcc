//! Depth of field on the GPU (DESIGN.md stage 7, "screen post"): the signed circle of
//! confusion of every pixel from its depth and the eye model (Liu et al. Eq. 12's thin-lens
//! form, Eq. 13 scaled; `fovea_post::dof::coc`), then the scatter-as-gather near/far filter
//! (Jimenez 2014; `fovea_post::dof::gather::ScatterAsGather`), the twins of the CPU's
//! `coc_map` and `ScatterAsGather::apply`.
//!
//! Split of the work:
//!
//! * **Rust, on the CPU**: every constant, from the very functions the CPU path uses — the
//!   CoC model's closed form at this focus in f64 ([`fovea_post::dof::coc::coc_constants`]),
//!   the disc's offsets sorted by distance and the `1/A(r)` table
//!   ([`ScatterAsGather::tables`]), `1 ± depth_tolerance`, the tile dilation's span.
//! * **WGSL**, four passes in one submission: `dof_coc.wgsl::coc` (per pixel: the CoC, its
//!   radius and `1/A(r)`), `dof_gather.wgsl::tile_max`, `::tile_reach` (the CPU's
//!   `TileReach`, per 16×16 tile) and `::gather` (per pixel, the near/far disc gather).
//!
//! Buffers: depth (u32 bits, 4 B/px), colour (three planes of f32, one a channel), the CoC
//! map out (f32), the gather's planes (three of 4 B/px: depth bits, radius, 1/A), the offsets
//! (16 B each, ≤ 207k for a 256 px radius), the area table, two tile planes and the colour out
//! (three planes). No per-pixel buffer holds more than 4 bytes a pixel, so each fits one
//! storage binding up to 33.5 M pixels on lavapipe's 128 MiB (an 8K screen, 33.2 M, fits;
//! issue 37), checked before anything is allocated ([`dof_bindings`]). The gather binds
//! [`GATHER_STORAGE_BUFFERS`] storage buffers, also checked against the adapter.
//!
//! Differences from the CPU: the CoC is evaluated in f32 from constants rounded once (the CPU
//! evaluates in f64 and rounds the result), ~1e-7 relative; the gather sums the same taps in
//! the same order with f32 arithmetic that may fuse multiply-adds. `tests/dof.rs` measures
//! both.

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use fovea_core::units::Metres;
use fovea_core::Image;
use fovea_post::dof::coc::{coc_constants, CocForm, CocModel, CocParams};
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::Rgb;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::timestamps::PassTimer;
use crate::transfer::{bind_group, read_buffers, stage, upload};

/// The CoC module: entry point `coc`, [`CocUniform`] at binding 0.
pub const COC_SHADER: ShaderSource = ShaderSource {
    file: "dof_coc.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/dof_coc.wgsl")
    ),
    entry_points: &["coc"],
    uniform: ("DofCocParams", std::mem::size_of::<CocUniform>()),
};

/// The gather module: entry points `tile_max`, `tile_reach`, `gather`, [`GatherUniform`] at
/// binding 0.
pub const GATHER_SHADER: ShaderSource = ShaderSource {
    file: "dof_gather.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/dof_gather.wgsl")
    ),
    entry_points: &["tile_max", "tile_reach", "gather"],
    uniform: ("GatherParams", std::mem::size_of::<GatherUniform>()),
};

/// A disc offset as `dof_gather.wgsl` reads it (`Offset`): pixels from the centre and the
/// distance, pixels.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct OffsetGpu {
    /// Columns from the centre.
    pub dx: i32,
    /// Rows from the centre.
    pub dy: i32,
    /// Distance from the centre, pixels.
    pub d: f32,
    pad: u32,
}

/// The shaders' `Offset`, bytes.
pub const OFFSET_BYTES: u64 = std::mem::size_of::<OffsetGpu>() as u64;
/// Bytes a pixel of each per-pixel plane the passes bind: the gather's planes (depth bits,
/// radius, 1/A, written and read on the device only), each colour channel, the CoC map.
pub const PLANE_BYTES: u64 = 4;
/// The gather's planes that `dof_coc.wgsl` writes (depth bits, radius, 1/A).
pub const GATHER_PLANES: u64 = 3;
/// Storage buffers the `gather` entry point binds: three planes, three colour channels in,
/// the offsets, the tile reach, three colour channels out.
pub const GATHER_STORAGE_BUFFERS: u32 = 11;

/// Every per-pixel storage binding of the depth of field on a screen of `n` pixels with
/// `n_offsets` disc offsets, named as the error would name it: what both the per-call passes
/// and the resident screen side check before they allocate (and allocate from).
pub fn dof_bindings(n: u64, n_offsets: u64) -> [(&'static str, u64); 5] {
    [
        ("the depth-of-field planes (each of three)", n * PLANE_BYTES),
        (
            "the depth-of-field colour (each of three planes)",
            n * PLANE_BYTES,
        ),
        ("the blurred colour (each of three planes)", n * PLANE_BYTES),
        ("the CoC map", n * PLANE_BYTES),
        ("the gather's disc offsets", n_offsets * OFFSET_BYTES),
    ]
}

/// [`GpuError::Unsupported`] when the adapter binds fewer storage buffers a stage than the
/// gather needs ([`GATHER_STORAGE_BUFFERS`]).
pub(crate) fn check_gather_stage(ctx: &GpuContext) -> Result<()> {
    let have = ctx.limits().max_storage_buffers_per_shader_stage;
    if have < GATHER_STORAGE_BUFFERS {
        return Err(GpuError::Unsupported(format!(
            "the depth-of-field gather on this adapter (it binds {GATHER_STORAGE_BUFFERS} \
             storage buffers, the adapter {have} a stage)"
        )));
    }
    Ok(())
}

/// The uniform block `DofCocParams` of `dof_coc.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct CocUniform {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// 0 thin lens, 1 linear (Eq. 13), 2 zero, 3 the uploaded map.
    pub form: u32,
    /// Area table length − 2.
    pub lut_max_k: u32,
    /// Pixels per dioptre (thin lens) or per metre (linear).
    pub a: f32,
    /// `1/F` (thin lens) or `F` in metres (linear).
    pub b: f32,
    /// Largest CoC magnitude, pixels.
    pub max_coc_px: f32,
    /// The CoC of a pixel with no hit, pixels.
    pub no_hit_coc_px: f32,
    /// The gather's largest radius, pixels.
    pub max_radius_px: f32,
    /// Area table entries per pixel of radius.
    pub lut_steps_per_px: f32,
    /// Padding.
    pub pad: [u32; 2],
}

/// The uniform block `GatherParams` of `dof_gather.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GatherUniform {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Tiles across.
    pub tiles_x: u32,
    /// Tiles down.
    pub tiles_y: u32,
    /// Tile side, pixels.
    pub tile_px: u32,
    /// Tiles either way a tile's reach looks at.
    pub span: i32,
    /// Disc offsets in the table.
    pub n_offsets: u32,
    /// Bit 0 `fill_behind`, bit 1 `separate_near`.
    pub flags: u32,
    /// `1 − depth_tolerance` (f32).
    pub near_factor: f32,
    /// `1 + depth_tolerance` (f32).
    pub far_factor: f32,
    /// Padding.
    pub pad: [u32; 2],
}

/// Where the CoC map comes from.
enum CocSource<'a> {
    /// Computed from depth with these constants (`form`, `a`, `b`, max, no-hit).
    Model(CocUniform),
    /// The caller's map.
    Map(&'a Image<f32>),
}

/// Where the time of one GPU depth of field went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DofTimes {
    /// Creating buffers, uploading, recording and submitting, wall ms.
    pub upload_ms: f64,
    /// From submission until the images were filled, wall ms (the GPU's work and the copy out).
    pub run_and_readback_ms: f64,
    /// The four compute passes alone, from timestamps (when the device has them), ms.
    pub gpu_pass_ms: Option<f64>,
    /// All of it, wall ms.
    pub total_ms: f64,
}

/// The CoC and gather pipelines on one device; reuse from frame to frame.
pub struct GpuDof {
    ctx: GpuContext,
    coc: wgpu::ComputePipeline,
    tile_max: wgpu::ComputePipeline,
    tile_reach: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
}

impl GpuDof {
    /// Compiles the passes on `ctx` ([`GpuError::Unsupported`] on an adapter that binds fewer
    /// than [`GATHER_STORAGE_BUFFERS`] storage buffers a stage).
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        check_gather_stage(ctx)?;
        let device = ctx.device();
        let (mut coc, mut gather) = ctx.scoped("building the depth-of-field pipelines", || {
            (
                COC_SHADER.pipelines(device),
                GATHER_SHADER.pipelines(device),
            )
        })?;
        let missing = || GpuError::Input("a depth-of-field module lacks an entry point".into());
        let gather_p = gather.pop().ok_or_else(missing)?;
        let tile_reach = gather.pop().ok_or_else(missing)?;
        let tile_max = gather.pop().ok_or_else(missing)?;
        Ok(Self {
            ctx: ctx.clone(),
            coc: coc.pop().ok_or_else(missing)?,
            tile_max,
            tile_reach,
            gather: gather_p,
        })
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Whether an image of `width × height` pixels fits this device: each of its per-pixel
    /// planes ([`PLANE_BYTES`] a pixel: the gather's planes, each colour channel) in one
    /// storage binding, and its rows and columns within one dispatch. A caller that can fall
    /// back to the CPU asks this first (an 8K frame's planes, 126.6 MiB each, fit lavapipe's
    /// 128 MiB; a retinal one's, 285 MiB, do not); the passes check the same before
    /// allocating ([`GpuError::AdapterTooSmall`]).
    pub fn fits(&self, width: u32, height: u32) -> bool {
        let limits = self.ctx.limits();
        let binding = self.ctx.max_binding_bytes();
        let n = u64::from(width) * u64::from(height);
        let groups = limits.max_compute_workgroups_per_dimension;
        dof_bindings(n, 0).iter().all(|&(_, b)| b <= binding)
            && width.div_ceil(WORKGROUP_SIZE) <= groups
            && height <= groups
    }

    /// Whether the CoC pass evaluates `model` (thin lens and Eq. 13; Weier's tracking-aware
    /// CoC stays on the CPU).
    pub fn supports_coc(model: &CocModel) -> bool {
        matches!(model, CocModel::ThinLens | CocModel::Stabilised)
    }

    /// The signed CoC map of `depth_m` (metres; NaN, ≤ 0 and +∞ count as no hit) with the
    /// eye model of `params` focused at `focus`, as `fovea_post::dof::coc::coc_map`.
    pub fn coc_map(
        &self,
        params: &CocParams,
        focus: Metres,
        depth_m: &Image<f32>,
    ) -> Result<Image<f32>> {
        let filter = ScatterAsGather::default();
        let (_, coc, _) = self.run(
            &filter,
            CocSource::Model(coc_uniform(params, focus)?),
            None,
            depth_m,
        )?;
        Ok(coc)
    }

    /// `filter` on `color` with its `depth_m` and the caller's signed CoC map `coc_px`, as
    /// `ScatterAsGather::apply` (the same sizes required).
    pub fn gather(
        &self,
        filter: &ScatterAsGather,
        color: &Image<Rgb>,
        depth_m: &Image<f32>,
        coc_px: &Image<f32>,
    ) -> Result<(Image<Rgb>, DofTimes)> {
        let (out, _, t) = self.run(filter, CocSource::Map(coc_px), Some(color), depth_m)?;
        Ok((out.unwrap_or_else(|| color.clone()), t))
    }

    /// The whole stage: the CoC map of `depth_m` with `params` focused at `focus`, then
    /// `filter` on `color` with it. Returns the blurred image and the CoC map, as
    /// `fovea_post::dof::coc::coc_map` followed by `ScatterAsGather::apply`.
    pub fn coc_and_gather(
        &self,
        filter: &ScatterAsGather,
        params: &CocParams,
        focus: Metres,
        color: &Image<Rgb>,
        depth_m: &Image<f32>,
    ) -> Result<(Image<Rgb>, Image<f32>, DofTimes)> {
        let (out, coc, t) = self.run(
            filter,
            CocSource::Model(coc_uniform(params, focus)?),
            Some(color),
            depth_m,
        )?;
        Ok((out.unwrap_or_else(|| color.clone()), coc, t))
    }

    /// The passes: the CoC (always), the gather when `color` is given.
    fn run(
        &self,
        filter: &ScatterAsGather,
        source: CocSource,
        color: Option<&Image<Rgb>>,
        depth_m: &Image<f32>,
    ) -> Result<(Option<Image<Rgb>>, Image<f32>, DofTimes)> {
        let t_start = Instant::now();
        let (w, h) = (depth_m.width(), depth_m.height());
        let sizes = [
            color.map(|c| ("colour", c.width(), c.height())),
            match &source {
                CocSource::Map(m) => Some(("CoC map", m.width(), m.height())),
                CocSource::Model(_) => None,
            },
        ];
        for (name, iw, ih) in sizes.into_iter().flatten() {
            if (iw, ih) != (w, h) {
                return Err(GpuError::Input(format!(
                    "the {name} is {iw}x{ih}, the depth {w}x{h}"
                )));
            }
        }
        let tables = filter
            .tables()
            .map_err(|e| GpuError::Input(e.to_string()))?;
        let n = w as u64 * h as u64;
        let what = format!("the depth of field at {w}x{h}");
        for (name, bytes) in dof_bindings(n, tables.offsets.len() as u64) {
            self.ctx.check_storage_binding(name, bytes)?;
        }
        let limits = self.ctx.limits();
        let max_groups = limits.max_compute_workgroups_per_dimension;
        if w.div_ceil(WORKGROUP_SIZE) > max_groups || h > max_groups {
            return Err(GpuError::Unsupported(format!(
                "an image of {w}x{h} (more than {max_groups} workgroups a side)"
            )));
        }
        let tile = tables.tile_px;
        let (tiles_x, tiles_y) = (w.div_ceil(tile), h.div_ceil(tile));
        let mut coc_u = match source {
            CocSource::Model(u) => u,
            CocSource::Map(_) => CocUniform {
                form: 3,
                ..CocUniform::zeroed()
            },
        };
        coc_u.width = w;
        coc_u.height = h;
        coc_u.lut_max_k = (tables.inv_area.len().max(2) - 2) as u32;
        coc_u.max_radius_px = filter.max_radius_px;
        coc_u.lut_steps_per_px = tables.inv_area_steps_per_px;
        let flags = u32::from(filter.fill_behind) | (u32::from(filter.separate_near) << 1);
        let gather_u = GatherUniform {
            width: w,
            height: h,
            tiles_x,
            tiles_y,
            tile_px: tile,
            span: ((filter.max_radius_px + 0.5) / tile as f32).ceil() as i32 + 1,
            n_offsets: tables.offsets.len() as u32,
            flags,
            near_factor: 1.0 - filter.depth_tolerance,
            far_factor: 1.0 + filter.depth_tolerance,
            pad: [0; 2],
        };
        let offsets: Vec<OffsetGpu> = tables
            .offsets
            .iter()
            .map(|&(dx, dy, d)| OffsetGpu { dx, dy, d, pad: 0 })
            .collect();
        let mut inv_area = tables.inv_area.clone();
        if inv_area.len() < 2 {
            inv_area.resize(2, 1.0);
        }
        let n_bytes = |per: u64| (n * per).max(4);

        let t_upload = Instant::now();
        let device = self.ctx.device();
        let (readbacks, timer) = self.ctx.scoped(&what, || {
            let storage = wgpu::BufferUsages::STORAGE;
            let uniform = wgpu::BufferUsages::UNIFORM;
            let coc_uniform = upload(
                &self.ctx,
                "CoC parameters",
                bytemuck::bytes_of(&coc_u),
                uniform,
            );
            let gather_uniform = upload(
                &self.ctx,
                "gather parameters",
                bytemuck::bytes_of(&gather_u),
                uniform,
            );
            let depth = upload(
                &self.ctx,
                "depth",
                bytes_or_word(bytemuck::cast_slice(depth_m.data())),
                storage,
            );
            let coc_in = match source {
                CocSource::Map(m) => upload(
                    &self.ctx,
                    "CoC map in",
                    bytes_or_word(bytemuck::cast_slice(m.data())),
                    storage,
                ),
                CocSource::Model(_) => upload(&self.ctx, "no CoC map", &[0; 4], storage),
            };
            let area = upload(
                &self.ctx,
                "1/A(r) table",
                bytemuck::cast_slice(&inv_area),
                storage,
            );
            let scratch = |label: &str, bytes: u64, usage: wgpu::BufferUsages| {
                self.ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes,
                    usage,
                    mapped_at_creation: false,
                })
            };
            let copy_out = storage | wgpu::BufferUsages::COPY_SRC;
            let coc_out = scratch("CoC map", n_bytes(PLANE_BYTES), copy_out);
            let planes: [wgpu::Buffer; 3] =
                ["DOF depth plane", "DOF radius plane", "DOF 1/A plane"]
                    .map(|label| scratch(label, n_bytes(PLANE_BYTES), storage));
            let bind = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
                bind_group(&self.ctx, "depth of field", pipeline, entries)
            };
            let coc_bind = bind(
                &self.coc,
                &[
                    (0, &coc_uniform),
                    (1, &depth),
                    (2, &coc_in),
                    (3, &area),
                    (4, &coc_out),
                    (5, &planes[0]),
                    (6, &planes[1]),
                    (7, &planes[2]),
                ],
            );
            // The gather's buffers and bindings, when it runs.
            let gather = color.map(|color| {
                let color_in: Vec<wgpu::Buffer> = (0..3)
                    .map(|c| {
                        let plane: Vec<f32> = color.data().iter().map(|p| p[c]).collect();
                        upload(
                            &self.ctx,
                            "colour plane",
                            bytes_or_word(bytemuck::cast_slice(&plane)),
                            storage,
                        )
                    })
                    .collect();
                let offsets_buf = upload(
                    &self.ctx,
                    "disc offsets",
                    bytemuck::cast_slice(&offsets),
                    storage,
                );
                let tiles = (tiles_x as u64 * tiles_y as u64 * 4).max(4);
                let tile_max = scratch("tile max", tiles, storage);
                let reach = scratch("tile reach", tiles, storage);
                let out: [wgpu::Buffer; 3] = ["blurred red", "blurred green", "blurred blue"]
                    .map(|label| scratch(label, n_bytes(PLANE_BYTES), copy_out));
                let g = &gather_uniform;
                let b_max = bind(&self.tile_max, &[(0, g), (2, &planes[1]), (8, &tile_max)]);
                let b_reach = bind(&self.tile_reach, &[(0, g), (8, &tile_max), (9, &reach)]);
                let b_gather = bind(
                    &self.gather,
                    &[
                        (0, g),
                        (1, &planes[0]),
                        (2, &planes[1]),
                        (3, &planes[2]),
                        (4, &color_in[0]),
                        (5, &color_in[1]),
                        (6, &color_in[2]),
                        (7, &offsets_buf),
                        (9, &reach),
                        (10, &out[0]),
                        (11, &out[1]),
                        (12, &out[2]),
                    ],
                );
                (b_max, b_reach, b_gather, out)
            });
            let timer = PassTimer::new(&self.ctx, "depth-of-field timestamps");
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("depth of field"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("depth of field"),
                    timestamp_writes: timer.as_ref().map(PassTimer::writes),
                });
                pass.set_pipeline(&self.coc);
                pass.set_bind_group(0, &coc_bind, &[]);
                pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), h, 1);
                if let Some((b_max, b_reach, b_gather, _)) = &gather {
                    let tile_groups = tiles_x.div_ceil(WORKGROUP_SIZE);
                    pass.set_pipeline(&self.tile_max);
                    pass.set_bind_group(0, b_max, &[]);
                    pass.dispatch_workgroups(tile_groups, tiles_y, 1);
                    pass.set_pipeline(&self.tile_reach);
                    pass.set_bind_group(0, b_reach, &[]);
                    pass.dispatch_workgroups(tile_groups, tiles_y, 1);
                    pass.set_pipeline(&self.gather);
                    pass.set_bind_group(0, b_gather, &[]);
                    pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), h, 1);
                }
            }
            let out_color = gather.map(|g| g.3);
            let outs: Vec<(&wgpu::Buffer, u64)> = std::iter::once(&coc_out)
                .chain(out_color.iter().flatten())
                .map(|out| (out, out.size()))
                .collect();
            let readbacks = stage(&self.ctx, &mut encoder, &outs, "depth-of-field readback");
            if let Some(timer) = &timer {
                timer.resolve(&mut encoder);
            }
            self.ctx.submit([encoder.finish()]);
            (readbacks, timer)
        })?;
        let upload_ms = ms_since(t_upload);

        let t_run = Instant::now();
        let mut all: Vec<&wgpu::Buffer> = readbacks.iter().collect();
        let n_images = all.len();
        all.extend(timer.as_ref().map(PassTimer::readback));
        let nu = n as usize;
        let (mut coc, mut blurred, mut gpu_pass_ms) = (Vec::new(), None, None);
        read_buffers(&self.ctx, &all, &what, |k, bytes| {
            if k == n_images {
                gpu_pass_ms = Some(PassTimer::ms(&self.ctx, bytes));
            } else if k == 0 {
                coc = bytemuck::pod_collect_to_vec::<u8, f32>(bytes);
                coc.truncate(nu);
            } else {
                // Channel k − 1's plane into the interleaved image.
                let px = blurred.get_or_insert_with(|| vec![[0f32; 3]; nu]);
                let plane = bytemuck::pod_collect_to_vec::<u8, f32>(bytes);
                for (p, &v) in px.iter_mut().zip(&plane) {
                    p[k - 1] = v;
                }
            }
        })?;
        let image_err = |e: fovea_core::FoveaError| GpuError::Input(e.to_string());
        let coc = Image::from_vec(w, h, coc).map_err(image_err)?;
        let blurred = match blurred {
            Some(px) => Some(Image::from_vec(w, h, px).map_err(image_err)?),
            None => None,
        };
        let run_and_readback_ms = ms_since(t_run);
        Ok((
            blurred,
            coc,
            DofTimes {
                upload_ms,
                run_and_readback_ms,
                gpu_pass_ms,
                total_ms: ms_since(t_start),
            },
        ))
    }
}

/// The CoC pass's constants for `params` at `focus` (every one from
/// [`coc_constants`], rounded once to f32).
pub(crate) fn coc_uniform(params: &CocParams, focus: Metres) -> Result<CocUniform> {
    let k = coc_constants(params, focus).map_err(|e| GpuError::Input(e.to_string()))?;
    let (form, a, b) = match k.form {
        CocForm::ThinLens {
            px_per_dioptre,
            inv_focus_per_m,
        } => (0, px_per_dioptre, inv_focus_per_m),
        CocForm::Linear { px_per_m, focus_m } => (1, px_per_m, focus_m),
        CocForm::Zero => (2, 0.0, 0.0),
        CocForm::Other => {
            return Err(GpuError::Unsupported(format!(
                "the {} CoC model (the GPU evaluates thin-lens and stabilised)",
                params.model.name()
            )))
        }
    };
    Ok(CocUniform {
        form,
        a: a as f32,
        b: b as f32,
        max_coc_px: k.max_coc_px as f32,
        no_hit_coc_px: k.no_hit_coc_px,
        ..CocUniform::zeroed()
    })
}

/// `bytes`, or one zero word for an empty image (a binding may not be empty).
fn bytes_or_word(bytes: &[u8]) -> &[u8] {
    if bytes.is_empty() {
        &[0; 4]
    } else {
        bytes
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
