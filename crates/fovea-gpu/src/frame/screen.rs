//! The screen side of the resident frame (issue 37): from one eye's shaded sample buffers on
//! the device ([`DeviceSamples`]) to its tone-mapped 8-bit image on the device, recorded into
//! the caller's command encoder — no submission, no readback, nothing created per frame.
//!
//! Passes, in the order of DESIGN.md's stages 6–7 (each its own compute pass, so that
//! [`FrameTimer`] can time them one by one):
//!
//! | pass | what | shader |
//! |---|---|---|
//! | `aa` | sample-space FXAA or 3×3 Gaussian on the polar layer (when configured) | `frame_screen_split.wgsl`, `fxaa.wgsl` / `gaussian_aa.wgsl` |
//! | `columns` | the polar layer padded column by column and angularly prefiltered | `frame_polar_columns.wgsl` |
//! | `reconstruct` | every pixel's `u(r)`, angle, bilinear or footprint lookup (VaFR Sec. 3.4), into the colour and depth planes | `polar_reconstruct.wgsl::reconstruct_planes` |
//! | `reconstruct` (layers) | Guenter's layers and the inset: every pixel's layer, bilinear, the inset's alpha blend ([`crate::frame::layers`]), into a `vec4` screen | `frame_layers.wgsl` |
//! | `split` | full resolution, Weier and the layers: a `vec4` screen's pixels into the colour and depth planes | `frame_screen_split.wgsl::split_planes` |
//! | `dof` | the eye's CoC map, tile max, tile reach and the scatter-as-gather filter | `dof_coc.wgsl`, `dof_gather.wgsl` |
//! | `tonemap` | exposure, tone curve, 8-bit sRGB, four codes a word | `tonemap.wgsl::tonemap_planes` |
//!
//! Full resolution (the samples are the screen) skips the first three and runs `split`; a
//! polar mapping's reconstruction writes the planes itself. Weier's sparse pattern (its
//! samples are the screen's shaded pixels) runs `split` too, then its pull-push
//! reconstruction ([`ResidentPullPush`], timed as `reconstruct`) fills the planes' holes;
//! Guenter's layers and the inset composite into a screen that `split` reads
//! ([`ResidentLayers`]). The DOF runs when the context was
//! built with it and the frame has a focus.
//!
//! **Every per-pixel buffer holds 4 bytes a pixel** (issue 37): the linear colour as three
//! planes of f32 (red, green, blue), depth as u32 bits, the DOF's planes (depth bits, radius,
//! 1/A) and blurred colour likewise, the CoC map f32, the tone-mapped bytes 3 a pixel and the
//! presenter's RGBA rows 4 a pixel. An 8K screen (7680×4320) is 126.6 MiB a plane, so each
//! fits one storage binding of lavapipe's 128 MiB; interleaved RGB (12 bytes a pixel, 380 MiB)
//! did not. [`ScreenSizes`] lists every such binding; [`ScreenContext::new`] checks each
//! against the adapter and allocates from the same list, so a screen that still does not fit
//! (retinal, 11520×6480: 285 MiB a plane) is refused naming the binding.
//!
//! A [`ScreenContext`] is built for one display, method, filter, DOF and tone settings and for
//! sample buffers up to its [`ScreenLimits`]; it owns every buffer, bind group and pipeline of
//! these passes. Per frame ([`ScreenContext::record`]) only the uniforms go up — the pole, the
//! focus's CoC constants — plus, when the mapping changed (a new gaze), the entries of the
//! reconstruction's tables that changed ([`crate::frame::reconstruct`]). An image comes back
//! only when asked for ([`ScreenContext::read_srgb8`]).

use bytemuck::Zeroable;
use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, FoveationMapping, MappingConfig, Method};
use fovea_core::units::Metres;
use fovea_core::Image;
use fovea_post::dof::coc::CocParams;
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::inset_smoothing::Smoothing;
use fovea_post::inverse_map::{PolarColumns, ReconstructFilter};
use fovea_post::tonemap::{srgb8_thresholds, ToneCurve};
use fovea_post::Rgb;

use crate::device::GpuContext;
use crate::dof::{coc_uniform, CocUniform, GatherUniform, OFFSET_BYTES};
use crate::error::{GpuError, Result};
use crate::frame::layers::ResidentLayers;
use crate::frame::pull_push::ResidentPullPush;
use crate::frame::reconstruct::{PolarCapacity, ResidentPolar, ScreenPlanes, TableUpload};
use crate::frame::samples::DeviceSamples;
use crate::frame::timing::FrameTimer;
use crate::sample_aa::SampleFilter;
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::tonemap::ToneUniform;
use crate::transfer::{bind_group, read_back, read_buffers};

/// The split module: entry points `split_screen` (interleaved colour, the sample-space AA's
/// input) and `split_planes` (the screen's planes), [`SplitUniform`] at binding 0.
pub const SPLIT_SHADER: ShaderSource = ShaderSource {
    file: "frame_screen_split.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/frame_screen_split.wgsl")
    ),
    entry_points: &[
        "split_screen",
        "split_planes",
        "planes_to_rgb",
        "rgb_to_planes",
    ],
    uniform: ("SplitParams", std::mem::size_of::<SplitUniform>()),
};

/// The presenter module: entry point `present_rgba`, [`PresentUniform`] at binding 0.
pub const PRESENT_SHADER: ShaderSource = ShaderSource {
    file: "frame_present.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/frame_present.wgsl")
    ),
    entry_points: &["present_rgba"],
    uniform: ("PresentParams", std::mem::size_of::<PresentUniform>()),
};

/// The passes [`ScreenContext::record`] times, in order ([`FrameTimer::new`]'s `passes`).
pub const SCREEN_PASSES: [&str; 7] = [
    "aa",
    "columns",
    "reconstruct",
    "split",
    "dof",
    "tonemap",
    "present",
];

/// The uniform block `PresentParams` of `frame_present.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, Zeroable)]
pub struct PresentUniform {
    /// Screen width, pixels.
    pub width: u32,
    /// Screen height, pixels.
    pub height: u32,
    /// u32 words per padded row (the copy's 256-byte row pitch).
    pub row_words: u32,
    /// Padding.
    pub pad: u32,
}

/// The presenter's texture and what fills it.
struct Present {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    rgba: wgpu::Buffer,
    texture: wgpu::Texture,
    row_bytes: u32,
}

/// Workgroups along x of one row of the tone map's dispatch (its shader's `65535u`).
const TONE_GROUPS_PER_ROW: u32 = 65535;

/// The uniform block `SplitParams` of `frame_screen_split.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, Zeroable)]
pub struct SplitUniform {
    /// The screen's first pixel in the source buffer.
    pub offset: u32,
    /// Screen width, pixels.
    pub width: u32,
    /// Screen height, pixels.
    pub height: u32,
    /// Padding.
    pub pad: u32,
}

/// The depth of field the screen side runs (the gather filter; its CoC model thin lens or
/// stabilised).
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenDof {
    /// The filter's parameters.
    pub filter: ScatterAsGather,
    /// The eye's CoC model (`fovea_render::dof::coc_params` of the frame's settings and camera).
    pub coc: CocParams,
}

/// What a [`ScreenContext`] is built for besides the display and method.
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenConfig {
    /// Sample-space AA before the reconstruction (polar mappings; `None`: off).
    pub aa: Option<SampleFilter>,
    /// How polar buffers are read at each pixel.
    pub filter: ReconstructFilter,
    /// The depth of field, if any.
    pub dof: Option<ScreenDof>,
    /// Exposure, stops.
    pub exposure_stops: f32,
    /// Also fill an `Rgba8Unorm` texture with the tone-mapped frame, for a presenter on the
    /// same device ([`ScreenContext::texture`]).
    pub texture: bool,
    /// Tone curve.
    pub curve: ToneCurve,
    /// The inset's boundary smoothing (none or the alpha blend; other methods ignore it).
    pub inset_smoothing: Smoothing,
}

/// The largest sample buffer a context serves (a polar buffer's columns and rows); beyond them
/// a new context is needed ([`ScreenContext::fits`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScreenLimits {
    /// Columns (buffer width).
    pub max_columns: u32,
    /// Rows (buffer height).
    pub max_rows: u32,
    /// Texels of a polar buffer's columns as the reconstruction lays them out, each padded
    /// by a row on either side (`fovea_post::inverse_map::PolarColumns::texel_count`).
    pub max_padded_texels: u64,
    /// Texels of the buffer's rectangle, width × height (the AA pass's buffers).
    pub max_texels: u64,
}

impl ScreenLimits {
    /// The polar reconstruction's capacity for these limits on a `w × h` screen (what
    /// [`ScreenContext::new`] builds it with).
    pub fn polar_capacity(&self, w: u32, h: u32) -> PolarCapacity {
        PolarCapacity {
            columns: self.max_columns,
            rows: self.max_rows,
            texels: self.max_padded_texels,
            rect_texels: self.max_texels,
            lut_entries: PolarCapacity::lut_for_screen(w, h),
        }
    }

    /// `method`'s mappings on `display` with the gaze at the screen's four corners and its
    /// centre (where a screen-covering polar buffer is largest): with the frame's own mapping,
    /// what [`Self::of`] sizes a context for, so that a moving gaze does not outgrow it.
    /// Gazes the display or method refuse are left out.
    pub fn any_gaze_mappings(
        method: Method,
        display: &DisplayProfile,
        config: &MappingConfig,
    ) -> Vec<Box<dyn FoveationMapping>> {
        let (w, h) = (f64::from(display.width_px), f64::from(display.height_px));
        [
            (0.0, 0.0),
            (w - 1.0, 0.0),
            (0.0, h - 1.0),
            (w - 1.0, h - 1.0),
            (0.5 * w, 0.5 * h),
        ]
        .into_iter()
        .filter_map(|(x, y)| display.gaze(x, y).ok())
        .filter_map(|gaze| build(method, display, gaze, config).ok())
        .collect()
    }

    /// The smallest limits that hold every mapping of `mappings` (e.g. one per gaze at the
    /// screen's centre and corners, where a screen-covering polar buffer is largest).
    pub fn of(mappings: &[&dyn FoveationMapping]) -> Self {
        let mut l = Self {
            max_columns: 1,
            max_rows: 1,
            max_padded_texels: 1,
            max_texels: 1,
        };
        for m in mappings {
            let buffers = m.buffers();
            for b in &buffers {
                l.max_columns = l.max_columns.max(b.width);
                l.max_rows = l.max_rows.max(b.height);
                l.max_texels = l.max_texels.max(b.pixels());
            }
            if let (Some(layout), Some(b)) = (m.polar_layout(), buffers.first()) {
                l.max_padded_texels = l
                    .max_padded_texels
                    .max(PolarColumns::texel_count(&layout, b.height));
            }
        }
        l
    }
}

/// The screen side's per-pixel storage bindings for one display and configuration, each
/// named as [`GpuError::AdapterTooSmall`] names it: what [`ScreenContext::new`] checks
/// against the adapter before it allocates, and allocates from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScreenSizes {
    /// Screen width, pixels.
    pub width: u32,
    /// Screen height, pixels.
    pub height: u32,
    /// Screen pixels.
    pub pixels: u64,
    /// Bytes of one plane (4 a pixel): each colour channel, depth, each DOF plane, the CoC map.
    pub plane_bytes: u64,
    /// Words of the tone-mapped screen (3 bytes a pixel, four a word).
    pub tone_words: u64,
    /// Bytes of one of the presenter's RGBA rows (4 a pixel, padded to the copy's 256 bytes).
    pub present_row_bytes: u32,
    /// Whether the configuration has the depth of field.
    pub dof: bool,
    /// Whether it fills the presenter's texture.
    pub texture: bool,
}

impl ScreenSizes {
    /// The sizes of a `width × height` screen with `config`.
    pub fn new(width: u32, height: u32, config: &ScreenConfig) -> Self {
        let pixels = u64::from(width) * u64::from(height);
        let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        Self {
            width,
            height,
            pixels,
            plane_bytes: pixels * crate::dof::PLANE_BYTES,
            tone_words: (3 * pixels).div_ceil(4),
            present_row_bytes: (4 * width).div_ceil(align) * align,
            dof: config.dof.is_some(),
            texture: config.texture,
        }
    }

    /// The sizes of `display`'s screen with `config`.
    pub fn of(display: &DisplayProfile, config: &ScreenConfig) -> Self {
        Self::new(display.width_px, display.height_px, config)
    }

    /// Bytes of the presenter's RGBA rows.
    pub fn present_bytes(&self) -> u64 {
        u64::from(self.present_row_bytes) * u64::from(self.height)
    }

    /// Every per-pixel storage binding, `(what, bytes)`: colour (each of three planes), depth,
    /// the tone-mapped screen; with the DOF its planes, blurred colour and CoC map (named as
    /// [`crate::dof::dof_bindings`] names them for the per-call passes); with the texture the
    /// presenter's rows.
    pub fn per_pixel_bindings(&self) -> Vec<(&'static str, u64)> {
        let mut b = vec![
            (
                "the screen's colour (each of three planes)",
                self.plane_bytes,
            ),
            ("the screen's depth", self.plane_bytes),
            ("the tone-mapped screen", self.tone_words * 4),
        ];
        if self.dof {
            // The gather reads the screen's colour planes; the disc offsets are checked with
            // the filter's tables.
            b.extend([
                (
                    "the depth-of-field planes (each of three)",
                    self.plane_bytes,
                ),
                (
                    "the blurred colour (each of three planes)",
                    self.plane_bytes,
                ),
                ("the CoC map", self.plane_bytes),
            ]);
        }
        if self.texture {
            b.push(("the presenter's RGBA rows", self.present_bytes()));
        }
        b
    }
}

/// One frame's input besides its samples.
pub struct ScreenInput<'a> {
    /// The frame's mapping (its pole is the gaze).
    pub mapping: &'a dyn FoveationMapping,
    /// The eye's focus distance, for the depth of field (`None`: no DOF this frame).
    pub focus: Option<Metres>,
}

/// The depth-of-field passes' buffers and bindings.
struct DofPasses {
    params: CocParams,
    coc: wgpu::ComputePipeline,
    tile_max: wgpu::ComputePipeline,
    tile_reach: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    coc_uniform: wgpu::Buffer,
    /// The CoC block without the focus's constants (sizes and table parameters).
    coc_base: CocUniform,
    coc_bind: wgpu::BindGroup,
    max_bind: wgpu::BindGroup,
    reach_bind: wgpu::BindGroup,
    gather_bind: wgpu::BindGroup,
    tiles: (u32, u32),
    /// The blurred colour, one plane a channel.
    out: [wgpu::Buffer; 3],
}

/// The screen side of one eye's resident frame (see the module).
pub struct ScreenContext {
    ctx: GpuContext,
    method: Method,
    config: ScreenConfig,
    limits: ScreenLimits,
    display: DisplayProfile,
    width: u32,
    height: u32,
    polar: Option<ResidentPolar>,
    /// Guenter's layers' and the inset's reconstruction (`crate::frame::layers`).
    layers: Option<ResidentLayers>,
    /// Weier's reconstruction, after the split pass over the screen's planes.
    pull_push: Option<ResidentPullPush>,
    split: wgpu::ComputePipeline,
    split_uniform: wgpu::Buffer,
    /// The split pass's bindings and the sample buffer they read (full resolution only).
    split_bind: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    /// The linear colour, one plane a channel (f32, 4 bytes a pixel each).
    color: [wgpu::Buffer; 3],
    /// The depth's bits.
    depth: wgpu::Buffer,
    dof: Option<DofPasses>,
    tone: wgpu::ComputePipeline,
    tone_from_color: wgpu::BindGroup,
    tone_from_dof: Option<wgpu::BindGroup>,
    out: wgpu::Buffer,
    /// The staging buffer of [`Self::read_srgb8`], made on the first image asked for.
    staging: Option<wgpu::Buffer>,
    /// Whether the last recorded frame ran the DOF.
    last_dof: bool,
    present: Option<Present>,
}

impl ScreenContext {
    /// Whether the screen side runs `method`: the polar mappings (VaFR, KFR/LMFR, LaFR,
    /// visual-polar), Guenter's layers, the inset, full resolution and Weier's sparse pattern
    /// (pull-push, [`ResidentPullPush`]).
    pub fn supports(method: Method) -> bool {
        matches!(
            method,
            Method::Vafr
                | Method::Kfr
                | Method::Lafr
                | Method::VisualPolar
                | Method::Guenter
                | Method::Inset
                | Method::Full
                | Method::Weier
        )
    }

    /// Everything for `display`, `method`, `config` and buffers within `limits`, sized and
    /// checked against the adapter before anything is allocated. [`GpuError::Unsupported`] for
    /// a method the screen side does not run or a CoC model the GPU does not evaluate.
    pub fn new(
        ctx: &GpuContext,
        display: &DisplayProfile,
        method: Method,
        config: ScreenConfig,
        limits: ScreenLimits,
    ) -> Result<Self> {
        if !Self::supports(method) {
            return Err(GpuError::Unsupported(format!(
                "the resident screen side for {method} (it runs vafr, kfr, lafr, visual-polar, \
                 guenter, inset, full and weier; use the per-stage GPU path or --backend cpu)"
            )));
        }
        if !config.exposure_stops.is_finite() {
            return Err(GpuError::Input(format!(
                "exposure {} stops (a finite number of stops)",
                config.exposure_stops
            )));
        }
        let (w, h) = (display.width_px, display.height_px);
        let groups = ctx.limits().max_compute_workgroups_per_dimension;
        if w.div_ceil(WORKGROUP_SIZE) > groups || h > groups {
            return Err(GpuError::Unsupported(format!(
                "a {w}x{h} screen (more than {groups} workgroups a side)"
            )));
        }
        // Every per-pixel binding, checked before anything is allocated and allocated from
        // the same sizes.
        let sizes = ScreenSizes::of(display, &config);
        for (what, bytes) in sizes.per_pixel_bindings() {
            ctx.check_storage_binding(what, bytes)?;
        }
        let (n, plane_bytes, n_words) = (sizes.pixels, sizes.plane_bytes, sizes.tone_words);
        let n_values = 3 * n;
        let dof_tables = match &config.dof {
            Some(d) => {
                if !crate::GpuDof::supports_coc(&d.coc.model) {
                    return Err(GpuError::Unsupported(format!(
                        "the {} CoC model on the resident screen side (thin-lens and \
                         stabilised run there)",
                        d.coc.model.name()
                    )));
                }
                crate::dof::check_gather_stage(ctx)?;
                let t = d
                    .filter
                    .tables()
                    .map_err(|e| GpuError::Input(e.to_string()))?;
                ctx.check_storage_binding(
                    "the gather's disc offsets",
                    t.offsets.len() as u64 * OFFSET_BYTES,
                )?;
                Some(t)
            }
            None => None,
        };
        if matches!(method, Method::Full | Method::Weier) && config.aa.is_some() {
            return Err(GpuError::Unsupported(format!(
                "sample-space AA on the resident screen side for {method} (it runs on polar \
                 buffers)"
            )));
        }
        if matches!(method, Method::Guenter | Method::Inset) && config.aa.is_some() {
            return Err(GpuError::Unsupported(format!(
                "sample-space AA on the resident screen side on {method}'s layers (it runs on \
                 polar buffers)"
            )));
        }
        let layers = match method {
            Method::Guenter | Method::Inset => {
                Some(ResidentLayers::new(ctx, w, h, config.inset_smoothing)?)
            }
            _ => None,
        };
        let device = ctx.device();
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            crate::transfer::empty(ctx, label, size, usage)
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let copy_dst = wgpu::BufferUsages::COPY_DST;
        let missing = || GpuError::Input("a screen-side module lacks an entry point".into());
        let what = format!("building the resident screen side at {w}x{h}");
        let (split, tone, split_uniform, color, depth, tone_uniform, thresholds, out) = ctx
            .scoped(&what, || {
                let split = SPLIT_SHADER.pipelines_of(device, &["split_planes"]).pop();
                let tone = crate::tonemap::SHADER
                    .pipelines_of(device, &["tonemap_planes"])
                    .pop();
                let split_uniform = buffer(
                    "split parameters",
                    std::mem::size_of::<SplitUniform>() as u64,
                    uniform,
                );
                let color = ["screen red", "screen green", "screen blue"].map(|label| {
                    buffer(label, plane_bytes, storage | wgpu::BufferUsages::COPY_SRC)
                });
                let depth = buffer(
                    "screen depth",
                    plane_bytes,
                    storage | wgpu::BufferUsages::COPY_SRC,
                );
                let tone_uniform = buffer(
                    "tone parameters",
                    std::mem::size_of::<ToneUniform>() as u64,
                    uniform,
                );
                let thresholds = buffer("sRGB thresholds", 255 * 4, storage | copy_dst);
                ctx.write_buffer(
                    &thresholds,
                    0,
                    bytemuck::cast_slice(srgb8_thresholds().as_slice()),
                );
                let out = buffer(
                    "tone-mapped screen",
                    n_words * 4,
                    storage | wgpu::BufferUsages::COPY_SRC,
                );
                (
                    split,
                    tone,
                    split_uniform,
                    color,
                    depth,
                    tone_uniform,
                    thresholds,
                    out,
                )
            })?;
        let (split, tone) = (split.ok_or_else(missing)?, tone.ok_or_else(missing)?);
        let polar = match method {
            Method::Full | Method::Weier | Method::Guenter | Method::Inset => None,
            _ => Some(ResidentPolar::new(
                ctx,
                display,
                config.filter,
                config.aa,
                limits.polar_capacity(w, h),
                ScreenPlanes {
                    color: [&color[0], &color[1], &color[2]],
                    depth: &depth,
                },
            )?),
        };
        let pull_push = match method {
            Method::Weier => Some(ResidentPullPush::new(
                ctx,
                w,
                h,
                [&color[0], &color[1], &color[2]],
                &depth,
            )?),
            _ => None,
        };
        let dof = match (&config.dof, dof_tables) {
            (Some(d), Some(t)) => Some(ctx.scoped(&what, || -> Result<DofPasses> {
                let mut coc_p = crate::dof::COC_SHADER.pipelines(device);
                let mut gather_p = crate::dof::GATHER_SHADER.pipelines(device);
                let gather = gather_p.pop().ok_or_else(missing)?;
                let tile_reach = gather_p.pop().ok_or_else(missing)?;
                let tile_max = gather_p.pop().ok_or_else(missing)?;
                let coc = coc_p.pop().ok_or_else(missing)?;
                let tile = t.tile_px;
                let tiles = (w.div_ceil(tile), h.div_ceil(tile));
                let coc_base = CocUniform {
                    width: w,
                    height: h,
                    lut_max_k: (t.inv_area.len().max(2) - 2) as u32,
                    max_radius_px: d.filter.max_radius_px,
                    lut_steps_per_px: t.inv_area_steps_per_px,
                    ..CocUniform::zeroed()
                };
                let flags =
                    u32::from(d.filter.fill_behind) | (u32::from(d.filter.separate_near) << 1);
                let gather_u = GatherUniform {
                    width: w,
                    height: h,
                    tiles_x: tiles.0,
                    tiles_y: tiles.1,
                    tile_px: tile,
                    span: ((d.filter.max_radius_px + 0.5) / tile as f32).ceil() as i32 + 1,
                    n_offsets: t.offsets.len() as u32,
                    flags,
                    near_factor: 1.0 - d.filter.depth_tolerance,
                    far_factor: 1.0 + d.filter.depth_tolerance,
                    pad: [0; 2],
                };
                let offsets: Vec<[u32; 4]> = t
                    .offsets
                    .iter()
                    .map(|&(dx, dy, r)| [dx as u32, dy as u32, r.to_bits(), 0])
                    .collect();
                let mut inv_area = t.inv_area.clone();
                if inv_area.len() < 2 {
                    inv_area.resize(2, 1.0);
                }
                let coc_uniform = buffer(
                    "CoC parameters",
                    std::mem::size_of::<CocUniform>() as u64,
                    uniform,
                );
                let gather_uniform = buffer(
                    "gather parameters",
                    std::mem::size_of::<GatherUniform>() as u64,
                    uniform,
                );
                ctx.write_buffer(&gather_uniform, 0, bytemuck::bytes_of(&gather_u));
                let no_map = buffer("no CoC map", 4, storage);
                let area = buffer(
                    "1/A(r) table",
                    inv_area.len() as u64 * 4,
                    storage | copy_dst,
                );
                ctx.write_buffer(&area, 0, bytemuck::cast_slice(&inv_area));
                let offsets_buf = buffer(
                    "disc offsets",
                    offsets.len() as u64 * OFFSET_BYTES,
                    storage | copy_dst,
                );
                ctx.write_buffer(&offsets_buf, 0, bytemuck::cast_slice(&offsets));
                let coc_out = buffer("CoC map", plane_bytes, storage);
                let planes = ["DOF depth plane", "DOF radius plane", "DOF 1/A plane"]
                    .map(|label| buffer(label, plane_bytes, storage));
                let tile_bytes = u64::from(tiles.0) * u64::from(tiles.1) * 4;
                let tile_max_buf = buffer("tile max", tile_bytes, storage);
                let reach = buffer("tile reach", tile_bytes, storage);
                let dof_out = ["blurred red", "blurred green", "blurred blue"].map(|label| {
                    buffer(label, plane_bytes, storage | wgpu::BufferUsages::COPY_SRC)
                });
                let g = &gather_uniform;
                let coc_bind = bind_group(
                    ctx,
                    "resident CoC",
                    &coc,
                    &[
                        (0, &coc_uniform),
                        (1, &depth),
                        (2, &no_map),
                        (3, &area),
                        (4, &coc_out),
                        (5, &planes[0]),
                        (6, &planes[1]),
                        (7, &planes[2]),
                    ],
                );
                let max_bind = bind_group(
                    ctx,
                    "resident tile max",
                    &tile_max,
                    &[(0, g), (2, &planes[1]), (8, &tile_max_buf)],
                );
                let reach_bind = bind_group(
                    ctx,
                    "resident tile reach",
                    &tile_reach,
                    &[(0, g), (8, &tile_max_buf), (9, &reach)],
                );
                let gather_bind = bind_group(
                    ctx,
                    "resident gather",
                    &gather,
                    &[
                        (0, g),
                        (1, &planes[0]),
                        (2, &planes[1]),
                        (3, &planes[2]),
                        (4, &color[0]),
                        (5, &color[1]),
                        (6, &color[2]),
                        (7, &offsets_buf),
                        (9, &reach),
                        (10, &dof_out[0]),
                        (11, &dof_out[1]),
                        (12, &dof_out[2]),
                    ],
                );
                Ok(DofPasses {
                    params: d.coc,
                    coc,
                    tile_max,
                    tile_reach,
                    gather,
                    coc_uniform,
                    coc_base,
                    coc_bind,
                    max_bind,
                    reach_bind,
                    gather_bind,
                    tiles,
                    out: dof_out,
                })
            })??),
            _ => None,
        };
        let curve = match config.curve {
            ToneCurve::Clamp => 0,
            ToneCurve::Reinhard => 1,
        };
        let tone_u = ToneUniform {
            n_values: n_values as u32,
            n_words: n_words as u32,
            scale: 2f32.powf(config.exposure_stops),
            curve,
        };
        let (tone_from_color, tone_from_dof) = ctx.scoped(&what, || {
            ctx.write_buffer(&tone_uniform, 0, bytemuck::bytes_of(&tone_u));
            let bind = |planes: &[wgpu::Buffer; 3]| {
                bind_group(
                    ctx,
                    "resident tone map",
                    &tone,
                    &[
                        (0, &tone_uniform),
                        (2, &thresholds),
                        (3, &out),
                        (4, &planes[0]),
                        (5, &planes[1]),
                        (6, &planes[2]),
                    ],
                )
            };
            (bind(&color), dof.as_ref().map(|d| bind(&d.out)))
        })?;
        let present = if config.texture {
            Some(Present::new(ctx, &sizes, &out)?)
        } else {
            None
        };
        Ok(Self {
            ctx: ctx.clone(),
            method,
            config,
            limits,
            display: display.clone(),
            width: w,
            height: h,
            polar,
            layers,
            pull_push,
            split,
            split_uniform,
            split_bind: None,
            color,
            depth,
            dof,
            tone,
            tone_from_color,
            tone_from_dof,
            out,
            staging: None,
            last_dof: false,
            present,
        })
    }

    /// Whether this context serves frames of `display`, `method`, `config` and `limits`
    /// (otherwise build a new one).
    pub fn matches(
        &self,
        display: &DisplayProfile,
        method: Method,
        config: &ScreenConfig,
        limits: ScreenLimits,
    ) -> bool {
        (display.width_px, display.height_px) == (self.width, self.height)
            && method == self.method
            && *config == self.config
            && limits.max_columns <= self.limits.max_columns
            && limits.max_rows <= self.limits.max_rows
            && limits.max_padded_texels <= self.limits.max_padded_texels
            && limits.max_texels <= self.limits.max_texels
    }

    /// Whether `mapping`'s buffers fit this context (its method and limits).
    pub fn fits(&self, mapping: &dyn FoveationMapping) -> bool {
        mapping.method() == self.method
            && match (&self.polar, &self.layers) {
                (Some(p), _) => p.fits(mapping),
                (None, Some(_)) => ResidentLayers::fits(mapping),
                (None, None) => mapping
                    .buffers()
                    .first()
                    .is_some_and(|b| (b.width, b.height) == (self.width, self.height)),
            }
    }

    /// What the last recorded frame sent up for the reconstruction's tables (zero for full
    /// resolution and for a frame whose mapping was the previous one's).
    pub fn last_table_upload(&self) -> TableUpload {
        self.polar
            .as_ref()
            .map(ResidentPolar::last_upload)
            .unwrap_or_default()
    }

    /// Bytes of the reconstruction's tables on the device (`u(r)` table, column records);
    /// zero for full resolution.
    pub fn table_bytes(&self) -> (u64, u64) {
        self.polar
            .as_ref()
            .map_or((0, 0), ResidentPolar::table_bytes)
    }

    /// The tone-mapped screen on the device: 8-bit sRGB RGB bytes, row-major, four a `u32`
    /// (the bytes of `fovea_post::tonemap::to_srgb8`, padded to a whole word).
    pub fn output(&self) -> &wgpu::Buffer {
        &self.out
    }

    /// Records one frame's screen side into `encoder`: uniforms (and changed tables) are
    /// written to the queue, which applies them before the caller's next submission; nothing
    /// is submitted or read. With `timer`, each pass is timed ([`SCREEN_PASSES`]; the caller
    /// calls [`FrameTimer::begin_frame`] before and [`FrameTimer::end_frame`] after).
    /// Refuses, before recording anything, a mapping of another method or one beyond the
    /// context's limits, and samples of another layout.
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        samples: &DeviceSamples,
        input: &ScreenInput<'_>,
        mut timer: Option<&mut FrameTimer>,
    ) -> Result<()> {
        let mapping = input.mapping;
        if mapping.method() != self.method {
            return Err(GpuError::Unsupported(format!(
                "a {} frame on a screen context built for {}",
                mapping.method(),
                self.method
            )));
        }
        // The split pass's source: Guenter's or the inset's composited layers, or full
        // resolution's samples themselves (a polar reconstruction writes the planes).
        let split_source = match (&mut self.polar, &mut self.layers) {
            (Some(p), _) => {
                p.prepare(mapping, &self.display, samples)?;
                None
            }
            (None, Some(l)) => {
                l.prepare(mapping, samples)?;
                Some((l.output().clone(), 0))
            }
            (None, None) => {
                let fits = samples.layers().len() == 1
                    && samples
                        .layers()
                        .first()
                        .is_some_and(|l| (l.width, l.height) == (self.width, self.height));
                if !fits {
                    return Err(GpuError::Input(format!(
                        "full-resolution samples {:?} for a {}x{} screen",
                        samples.layers(),
                        self.width,
                        self.height
                    )));
                }
                Some((samples.buffer().clone(), samples.layers()[0].offset))
            }
        };
        let dof_coc = match (&self.dof, input.focus) {
            (Some(d), Some(focus)) => {
                let k = coc_uniform(&d.params, focus)?;
                Some(CocUniform {
                    form: k.form,
                    a: k.a,
                    b: k.b,
                    max_coc_px: k.max_coc_px,
                    no_hit_coc_px: k.no_hit_coc_px,
                    ..d.coc_base
                })
            }
            _ => None,
        };
        if let Some(pp) = &mut self.pull_push {
            pp.prepare(mapping)?;
        }
        let ctx = &self.ctx;
        ctx.scoped("recording the resident screen side", || {
            if let (Some(d), Some(u)) = (&self.dof, &dof_coc) {
                ctx.write_buffer(&d.coc_uniform, 0, bytemuck::bytes_of(u));
            }
            if let Some((source, offset)) = &split_source {
                let split_u = SplitUniform {
                    offset: *offset,
                    width: self.width,
                    height: self.height,
                    pad: 0,
                };
                ctx.write_buffer(&self.split_uniform, 0, bytemuck::bytes_of(&split_u));
                if self.split_bind.as_ref().is_none_or(|(b, _)| b != source) {
                    let bind = bind_group(
                        ctx,
                        "resident split",
                        &self.split,
                        &[
                            (0, &self.split_uniform),
                            (1, source),
                            (3, &self.depth),
                            (4, &self.color[0]),
                            (5, &self.color[1]),
                            (6, &self.color[2]),
                        ],
                    );
                    self.split_bind = Some((source.clone(), bind));
                }
            }
        })?;
        let (w, h) = (self.width, self.height);
        ctx.scoped("recording the resident screen side", || -> Result<()> {
            if let Some(p) = &self.polar {
                p.record(encoder, timer.as_deref_mut(), 0)?;
            } else {
                if let Some(l) = &self.layers {
                    l.record(encoder, timer.as_deref_mut())?;
                }
                let Some((_, split_bind)) = &self.split_bind else {
                    return Err(GpuError::Input("the split pass has no bindings".into()));
                };
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("split"),
                    timestamp_writes: timer.as_deref_mut().and_then(|t| t.writes(3)),
                });
                pass.set_pipeline(&self.split);
                pass.set_bind_group(0, split_bind, &[]);
                pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), h, 1);
            }
            // Weier: the pull-push over the split's colour and depth, timed as `reconstruct`.
            if let Some(pp) = &self.pull_push {
                pp.record(encoder, timer.as_deref_mut().and_then(|t| t.writes(2)))?;
            }
            let mut tone_bind = &self.tone_from_color;
            if let (Some(d), Some(_)) = (&self.dof, &dof_coc) {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("depth of field"),
                    timestamp_writes: timer.as_deref_mut().and_then(|t| t.writes(4)),
                });
                let tile_groups = d.tiles.0.div_ceil(WORKGROUP_SIZE);
                pass.set_pipeline(&d.coc);
                pass.set_bind_group(0, &d.coc_bind, &[]);
                pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), h, 1);
                pass.set_pipeline(&d.tile_max);
                pass.set_bind_group(0, &d.max_bind, &[]);
                pass.dispatch_workgroups(tile_groups, d.tiles.1, 1);
                pass.set_pipeline(&d.tile_reach);
                pass.set_bind_group(0, &d.reach_bind, &[]);
                pass.dispatch_workgroups(tile_groups, d.tiles.1, 1);
                pass.set_pipeline(&d.gather);
                pass.set_bind_group(0, &d.gather_bind, &[]);
                pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), h, 1);
                if let Some(b) = &self.tone_from_dof {
                    tone_bind = b;
                }
            }
            let words = (3 * u64::from(w) * u64::from(h)).div_ceil(4);
            let groups = words.div_ceil(u64::from(WORKGROUP_SIZE));
            let gx = groups.min(u64::from(TONE_GROUPS_PER_ROW)) as u32;
            let gy = groups.div_ceil(u64::from(TONE_GROUPS_PER_ROW)) as u32;
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("tone map"),
                timestamp_writes: timer.as_deref_mut().and_then(|t| t.writes(5)),
            });
            pass.set_pipeline(&self.tone);
            pass.set_bind_group(0, tone_bind, &[]);
            pass.dispatch_workgroups(gx.max(1), gy.max(1), 1);
            drop(pass);
            if let Some(p) = &self.present {
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("present"),
                        timestamp_writes: timer.and_then(|t| t.writes(6)),
                    });
                    pass.set_pipeline(&p.pipeline);
                    pass.set_bind_group(0, &p.bind, &[]);
                    pass.dispatch_workgroups(w.div_ceil(WORKGROUP_SIZE), h, 1);
                }
                encoder.copy_buffer_to_texture(
                    wgpu::TexelCopyBufferInfo {
                        buffer: &p.rgba,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(p.row_bytes),
                            rows_per_image: Some(h),
                        },
                    },
                    p.texture.as_image_copy(),
                    wgpu::Extent3d {
                        width: w,
                        height: h,
                        depth_or_array_layers: 1,
                    },
                );
            }
            Ok(())
        })??;
        self.last_dof = dof_coc.is_some();
        Ok(())
    }

    /// The tone-mapped image of the last submitted frame: copies the output to a staging
    /// buffer (made on the first call and kept), submits that copy and waits for it — a
    /// blocking, counted readback, for `render --out`, screenshots and sequences only. Call
    /// after the frame's encoder was submitted. 3 bytes a pixel, as `to_srgb8`.
    pub fn read_srgb8(&mut self) -> Result<Vec<u8>> {
        let size = self.out.size();
        let ctx = &self.ctx;
        let staging = ctx.scoped("reading back the tone-mapped screen", || {
            let staging = self.staging.get_or_insert_with(|| {
                ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("tone-mapped screen readback"),
                    size,
                    usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                    mapped_at_creation: false,
                })
            });
            let mut encoder =
                ctx.device()
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("tone-mapped screen readback"),
                    });
            encoder.copy_buffer_to_buffer(&self.out, 0, staging, 0, size);
            ctx.submit([encoder.finish()]);
            staging.clone()
        })?;
        let n = 3 * self.width as usize * self.height as usize;
        let mut bytes = Vec::new();
        read_buffers(ctx, &[&staging], "the tone-mapped screen", |_, b| {
            bytes = b[..n.min(b.len())].to_vec();
        })?;
        Ok(bytes)
    }

    /// The linear screen of the last submitted frame before its depth of field and tone map
    /// (the reconstruction's colour and depth): a blocking, counted readback for tests and
    /// debugging views.
    pub fn read_linear(&self) -> Result<(Image<Rgb>, Image<f32>)> {
        let n = self.width as usize * self.height as usize;
        let (mut color, mut depth) = (vec![[0f32; 3]; n], Vec::new());
        let sources: Vec<(&wgpu::Buffer, u64)> = self
            .color
            .iter()
            .chain([&self.depth])
            .map(|b| (b, b.size()))
            .collect();
        read_back(&self.ctx, &sources, "the linear screen", |k, b| {
            let plane = bytemuck::pod_collect_to_vec::<u8, f32>(b);
            if k < 3 {
                for (p, &v) in color.iter_mut().zip(&plane) {
                    p[k] = v;
                }
            } else {
                depth = plane;
                depth.truncate(n);
            }
        })?;
        let err = |e: fovea_core::FoveaError| GpuError::Input(e.to_string());
        Ok((
            Image::from_vec(self.width, self.height, color).map_err(err)?,
            Image::from_vec(self.width, self.height, depth).map_err(err)?,
        ))
    }

    /// Whether the last recorded frame ran the depth of field.
    pub fn last_ran_dof(&self) -> bool {
        self.last_dof
    }

    /// The `Rgba8Unorm` texture each recorded frame ends in (the tone-mapped sRGB codes, alpha
    /// 255; usage `TEXTURE_BINDING | COPY_SRC | COPY_DST`), when the context was built with
    /// [`ScreenConfig::texture`]: what a presenter on the same device samples or blits.
    pub fn texture(&self) -> Option<&wgpu::Texture> {
        self.present.as_ref().map(|p| &p.texture)
    }
}

impl Present {
    /// The pack pipeline, its padded RGBA buffer, the texture and their bindings for a
    /// screen of `sizes` (whose bindings the caller checked) whose tone-mapped words are
    /// `rgb`.
    fn new(ctx: &GpuContext, sizes: &ScreenSizes, rgb: &wgpu::Buffer) -> Result<Self> {
        let (w, h) = (sizes.width, sizes.height);
        let row_bytes = sizes.present_row_bytes;
        let bytes = sizes.present_bytes();
        let limits = ctx.limits();
        if w > limits.max_texture_dimension_2d || h > limits.max_texture_dimension_2d {
            return Err(GpuError::Unsupported(format!(
                "a {w}x{h} texture (the adapter's largest is {})",
                limits.max_texture_dimension_2d
            )));
        }
        let what = "building the presenter's texture";
        let pipeline = ctx
            .scoped(what, || PRESENT_SHADER.pipelines(ctx.device()).pop())?
            .ok_or_else(|| GpuError::Input("the present module has no entry point".into()))?;
        ctx.scoped(what, || {
            let uniform = ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("present parameters"),
                size: std::mem::size_of::<PresentUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let u = PresentUniform {
                width: w,
                height: h,
                row_words: row_bytes / 4,
                pad: 0,
            };
            ctx.write_buffer(&uniform, 0, bytemuck::bytes_of(&u));
            let rgba = ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("presenter RGBA rows"),
                size: bytes.max(4),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let texture = ctx.device().create_texture(&wgpu::TextureDescriptor {
                label: Some("presented frame"),
                size: wgpu::Extent3d {
                    width: w.max(1),
                    height: h.max(1),
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let bind = bind_group(
                ctx,
                "presenter",
                &pipeline,
                &[(0, &uniform), (1, rgb), (2, &rgba)],
            );
            Self {
                pipeline,
                bind,
                rgba,
                texture,
                row_bytes,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::mapping::vafr::VafrRings;
    use fovea_core::optics::EyeModel;

    /// lavapipe's `max_storage_buffer_binding_size`.
    const LAVAPIPE_BINDING: u64 = 128 << 20;

    /// Everything the screen side can allocate per pixel: the DOF and the presenter's
    /// texture on.
    fn everything(display: &DisplayProfile) -> ScreenConfig {
        ScreenConfig {
            aa: None,
            filter: ReconstructFilter::Footprint,
            dof: Some(ScreenDof {
                filter: ScatterAsGather::default(),
                coc: CocParams::thin_lens(EyeModel::default(), display.focal_y_px()),
            }),
            exposure_stops: 0.0,
            texture: true,
            curve: ToneCurve::Reinhard,
            inset_smoothing: Smoothing::ALPHA_BLEND,
        }
    }

    /// Issue 37: at the 8K display (7680×4320 an eye) every per-pixel binding the screen side
    /// allocates — by the sizes `ScreenContext::new` checks and allocates from — holds within
    /// lavapipe's 128 MiB, and so do the polar reconstruction's for VaFR at any gaze (the
    /// limits `binocular.rs` builds the context with, both ring layouts). The interleaved
    /// colour this replaced (12 bytes a pixel) would not, and at the retinal display (11520 ×
    /// 6480) the planes themselves do not: the same sizes name them.
    #[test]
    fn every_per_pixel_binding_of_an_8k_screen_fits_128_mib() {
        let display = DisplayProfile::preset("8k").unwrap();
        assert_eq!((display.width_px, display.height_px), (7680, 4320));
        let sizes = ScreenSizes::of(&display, &everything(&display));
        let n = 7680u64 * 4320;
        assert_eq!(sizes.pixels, n);
        let bindings = sizes.per_pixel_bindings();
        let names: Vec<&str> = bindings.iter().map(|b| b.0).collect();
        assert_eq!(
            names,
            [
                "the screen's colour (each of three planes)",
                "the screen's depth",
                "the tone-mapped screen",
                "the depth-of-field planes (each of three)",
                "the blurred colour (each of three planes)",
                "the CoC map",
                "the presenter's RGBA rows",
            ]
        );
        for (what, bytes) in &bindings {
            assert!(
                *bytes <= LAVAPIPE_BINDING,
                "{what}: {bytes} B > {LAVAPIPE_BINDING} B at 8K"
            );
            // Each is at most 4 bytes a pixel (the presenter's rows are exactly 4: 7680 × 4
            // is a multiple of 256).
            assert!(*bytes <= 4 * n, "{what}: {bytes} B");
        }
        assert_eq!(sizes.plane_bytes, 132_710_400);
        assert_eq!(sizes.tone_words * 4, 99_532_800);
        assert_eq!(sizes.present_bytes(), 132_710_400);
        // The layout this replaced: interleaved RGB, 380 MiB.
        assert!(n * 12 > LAVAPIPE_BINDING);

        for rings in [VafrRings::default(), VafrRings::Eq3AnyGaze] {
            let mut config = MappingConfig::default();
            config.vafr.rings = rings;
            let maps = ScreenLimits::any_gaze_mappings(Method::Vafr, &display, &config);
            assert_eq!(maps.len(), 5, "{rings:?}");
            let refs: Vec<&dyn FoveationMapping> = maps.iter().map(|m| m.as_ref()).collect();
            let limits = ScreenLimits::of(&refs);
            let capacity = limits.polar_capacity(display.width_px, display.height_px);
            for (what, bytes) in capacity.bindings() {
                assert!(
                    bytes <= LAVAPIPE_BINDING,
                    "VaFR {rings:?}: {what}: {bytes} B > {LAVAPIPE_BINDING} B at 8K"
                );
            }
        }

        let retinal = DisplayProfile::preset("retinal").unwrap();
        let over: Vec<&str> = ScreenSizes::of(&retinal, &everything(&retinal))
            .per_pixel_bindings()
            .into_iter()
            .filter(|&(_, bytes)| bytes > LAVAPIPE_BINDING)
            .map(|(what, _)| what)
            .collect();
        assert_eq!(
            over.first(),
            Some(&"the screen's colour (each of three planes)")
        );
        assert!(over.contains(&"the screen's depth"), "{over:?}");
    }
}
