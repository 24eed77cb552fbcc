//! Screen-aligned layered buffers in the resident frame (issue 37): Guenter et al. 2012's
//! nested eccentricity layers ("Foveated 3D Graphics": concentric layers around the gaze,
//! each rendered at a fixed fraction of the display's resolution and composited from the
//! finest outwards) and the inset of Liu et al.'s inset paper (a full-resolution inset over a
//! periphery at ¼ resolution), both `fovea_core::mapping::FoveationMapping::screen_layers`.
//!
//! **Sample side.** Every layer lies in the eye's one sample buffer (`DeviceSamples`, the
//! layers one after another) and is shaded by the resident kernels of
//! `shaders/frame_shade.wgsl` — one dispatch of each kernel per layer, each with its own
//! `FrameParams` (the layer's offset, size and key) and [`ShadeLayerGpu`] (binding 30: the
//! layer's rectangle on the screen, its shaded texels, its rays' cones), so the per-layer
//! uniforms are all that goes up: 256 B a layer. A texel's ray goes through the CPU
//! mapping's `inverse` (`origin + (i + ½ + jitter)·scale`), its cone is the CPU's
//! `SampleFootprint::spread_rad` in closed form (`shaders/frame_shade_layers.wgsl`) with the
//! step function of the mapping's rate uploaded as its steps ([`spread_steps`]), its noise
//! key `texel_key(layer, i, j)` with the frame's.
//!
//! **Screen side** ([`ResidentLayers`], `shaders/frame_layers.wgsl`): per screen pixel the
//! finest layer owning it (`ScreenLayer::contains`, the CPU's `forward`), bilinear inside
//! that layer clamped to its shaded rectangle and the nearest texel's depth —
//! `fovea_post::inverse_map`'s `layered` step for step — into the screen's `vec4<u32>`
//! pixels, which the screen side's split, DOF and tone map read as they read the polar
//! reconstruction's. The layers' records go up only when the mapping changed (304 B).
//!
//! Guenter's composite has hard boundaries on the CPU too (each pixel reads its own layer).
//! The inset's boundary is smoothed as the CPU's `fovea_post::inset_smoothing::composite`
//! does with the naive alpha blend (Liu et al. Sec. 3.1, the default): inside the inset,
//! within `S` pixels of a boundary edge that is not the screen's, the periphery's bilinear
//! upsampling (pixel centres aligned: the layered lookup of the periphery, bit for bit where
//! the periphery is an exact 2× or 4× subsampling) blended in with weight `1 − (d + ½)/S`;
//! an inexact periphery keeps the hard boundary, as on the CPU. The Gaussian and Laplacian
//! smoothings are refused ([`supports`]).

use bytemuck::{Pod, Zeroable};
use fovea_core::display::eccentricity_deg;
use fovea_core::mapping::footprint::MAX_SPREAD_DEG;
use fovea_core::mapping::{FoveationMapping, Method, SamplePoint, ScreenLayer};
use fovea_post::inset_smoothing::Smoothing;
use fovea_render::camera::EyeCamera;
use fovea_render::plan::FramePlan;
use fovea_render::shade::frame_noise::with_frame;
use fovea_render::shade::texel_key;

use super::samples::DeviceSamples;
use super::shade::FrameUniform;
use super::timing::FrameTimer;
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::transfer::bind_group;

/// The most layers the resident frame serves (Guenter's default has three, the inset two).
pub const MAX_LAYERS: usize = 4;

/// The most steps of a layered mapping's rate along the probe direction ([`spread_steps`]).
pub const MAX_STEPS: usize = 8;

/// The screen-side module: entry point `reconstruct_layers`, [`LayersUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "frame_layers.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/frame_layers.wgsl")
    ),
    entry_points: &["reconstruct_layers"],
    uniform: ("LayersParams", std::mem::size_of::<LayersUniform>()),
};

/// `FrameScreenLayer` of `frame_shade_layers.wgsl`: one layer's rays (binding 30 of the
/// shade kernels).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadeLayerGpu {
    /// The layer's origin minus the principal point, pixels.
    pub origin: [f32; 2],
    /// Screen pixels per texel.
    pub scale: f32,
    /// Steps of the rate in use.
    pub steps: u32,
    /// Shaded texels: `i` in `[x, y)`, `j` in `[z, w)`.
    pub shaded: [u32; 4],
    /// The gaze minus the principal point, pixels.
    pub gaze: [f32; 2],
    /// `DisplayProfile::c_r`.
    pub c_r: f32,
    /// The narrowest cone, radians.
    pub floor_rad: f32,
    /// The widest cone, radians.
    pub max_rad: f32,
    /// Padding.
    pub pad: [u32; 3],
    /// Each step's first radius, pixels.
    pub step_r: [[f32; 4]; 2],
    /// Each step's scale (0: no layer).
    pub step_scale: [[f32; 4]; 2],
}

/// `LayerRecord` of `frame_layers.wgsl`: one layer as the reconstruction reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LayerRecordGpu {
    /// The rectangle's top-left corner, screen pixels.
    pub origin: [f32; 2],
    /// The rectangle's size, screen pixels.
    pub size: [f32; 2],
    /// The disc's centre and radius, pixels, and 1 where the layer has one (else 0).
    pub disc: [f32; 4],
    /// The CPU's shaded rectangle, inclusive: `i0, i1, j0, j1`.
    pub rect: [u32; 4],
    /// Screen pixels per texel.
    pub scale: f32,
    /// The layer's first texel in the sample buffer.
    pub offset: u32,
    /// Width, texels.
    pub width: u32,
    /// Padding.
    pub pad: u32,
}

/// The uniform block `LayersParams` of `frame_layers.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LayersUniform {
    /// Screen width, pixels.
    pub width: u32,
    /// Screen height, pixels.
    pub height: u32,
    /// Layers in use.
    pub count: u32,
    /// `f32::INFINITY.to_bits()`.
    pub inf_bits: u32,
    /// The inset's rectangle on the screen, inclusive: `x0, y0, x1, y1`.
    pub inset: [u32; 4],
    /// The inset's alpha-blend strip, pixels (0: a hard boundary).
    pub strip: u32,
    /// Padding.
    pub pad: [u32; 3],
    /// The layers, finest first.
    pub layers: [LayerRecordGpu; MAX_LAYERS],
}

/// The WGSL name and Rust size of the shade kernels' layer record (in
/// `super::shade::SHADER`; `tests/shaders.rs` compares them with naga).
pub const SHADE_RECORD_STRUCTS: [(&str, usize); 1] =
    [("FrameScreenLayer", std::mem::size_of::<ShadeLayerGpu>())];

/// The WGSL names and Rust sizes of [`SHADER`]'s records (`tests/shaders.rs` compares them
/// with naga).
pub const RECORD_STRUCTS: [(&str, usize); 2] = [
    ("LayerRecord", std::mem::size_of::<LayerRecordGpu>()),
    ("LayersParams", std::mem::size_of::<LayersUniform>()),
];

/// Whether the resident frame serves `plan`'s layered mapping: at most [`MAX_LAYERS`] layers,
/// one buffer each, and for the inset a hard boundary or the alpha blend.
pub fn supports(plan: &FramePlan) -> Result<()> {
    let layers = plan.mapping().screen_layers();
    if plan.method() == Method::Inset {
        match plan.settings.inset_smoothing {
            Smoothing::None => {}
            Smoothing::AlphaBlend { strip_px } if strip_px > 0 => {}
            Smoothing::AlphaBlend { .. } => {
                return Err(GpuError::Input(
                    "an inset alpha blend over a strip of 0 pixels (at least 1)".into(),
                ))
            }
            other => {
                return Err(GpuError::Unsupported(format!(
                    "the inset's {} boundary smoothing in the resident frame (it runs \
                     alpha-blend and none; use the staged --backend gpu or --backend cpu)",
                    other.name()
                )))
            }
        }
    }
    if layers.len() > MAX_LAYERS || layers.len() != plan.buffers.len() {
        return Err(GpuError::Unsupported(format!(
            "{} sample layers ({}) in the resident frame (it runs up to {MAX_LAYERS})",
            plan.buffers.len(),
            plan.method()
        )));
    }
    Ok(())
}

/// The step function `scale(r)` of `mapping`'s shading rate at distance `r` (pixels) from the
/// gaze — `screen_rate(e) / radial_rate_cpd(e)` with `tan e = c_r·r`, the CPU's own rate, so
/// the steps are where the CPU's cones change — as `[r_start, scale]` from `r = 0` to `r_end`
/// (0 where no layer owns the point). Found by scanning every pixel of radius and bisecting
/// each change to 1e-9 px; a layer narrower than a pixel along the probe may be missed.
pub fn spread_steps(mapping: &dyn FoveationMapping, c_r: f64, r_end: f64) -> Result<Vec<[f64; 2]>> {
    let layers = mapping.screen_layers();
    let scale_at = |r: f64| -> f64 {
        let e = eccentricity_deg(c_r, r);
        let rate = mapping.radial_rate_cpd(e);
        if !(rate.is_finite() && rate > 0.0) {
            return 0.0;
        }
        let c = e.to_radians().cos();
        let s = 0.5 * std::f64::consts::PI / 180.0 / (c_r * c * c) / rate;
        // The layer's own scale where the quotient rounds next to it.
        layers
            .iter()
            .map(|l| l.scale)
            .find(|&k| (s - k).abs() <= 1e-9 * k)
            .unwrap_or(s)
    };
    let mut steps = vec![[0.0, scale_at(0.0)]];
    let n = r_end.max(1.0).ceil() as u32;
    let mut prev = steps[0][1];
    for k in 1..=n {
        let r = f64::from(k);
        let s = scale_at(r);
        if s == prev {
            continue;
        }
        // The first radius in (r − 1, r] with the new scale.
        let (mut lo, mut hi) = (r - 1.0, r);
        while hi - lo > 1e-9 {
            let mid = 0.5 * (lo + hi);
            if scale_at(mid) == prev {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let s_hi = scale_at(hi);
        steps.push([hi, s_hi]);
        prev = s_hi;
        if s_hi != s {
            steps.push([r, s]);
            prev = s;
        }
        if steps.len() > MAX_STEPS {
            return Err(GpuError::Unsupported(format!(
                "a layered mapping whose rate changes more than {MAX_STEPS} times along the \
                 screen in the resident frame"
            )));
        }
    }
    Ok(steps)
}

/// Layer `layer`'s texels whose centre lies on the screen, `[i0, i1) × [j0, j1)`: the CPU's
/// `Layers::is_shaded`, whose set is a rectangle, with the same f64 arithmetic.
fn shaded_range(l: &ScreenLayer, width: u32, height: u32, screen: (f64, f64)) -> [u32; 4] {
    let range = |origin: f64, n: u32, extent: f64| {
        let on = |i: u32| (0.0..extent).contains(&(origin + (f64::from(i) + 0.5) * l.scale));
        match (0..n).find(|&i| on(i)) {
            Some(a) => [a, (a..n).take_while(|&i| on(i)).last().map_or(a, |b| b + 1)],
            None => [0, 0],
        }
    };
    let [i0, i1] = range(l.origin.x_px, width, screen.0);
    let [j0, j1] = range(l.origin.y_px, height, screen.1);
    [i0, i1, j0, j1]
}

/// Each layer's [`ShadeLayerGpu`] for `plan` seen by `camera` (the rays' coordinates are
/// relative to its principal point); [`GpuError::Unsupported`] for a mapping the kernels do
/// not serve ([`supports`], [`spread_steps`]).
pub fn shade_blocks(plan: &FramePlan, camera: &EyeCamera) -> Result<Vec<ShadeLayerGpu>> {
    supports(plan)?;
    let mapping = plan.mapping();
    let d = &plan.display;
    let c_r = d.c_r();
    let gaze = plan.eye.gaze;
    let layers = mapping.screen_layers();
    let widest = layers.iter().map(|l| l.scale).fold(1.0, f64::max);
    let steps = spread_steps(
        mapping,
        c_r,
        d.farthest_corner_px(&gaze) + 2.0 * widest + 2.0,
    )?;
    let mut step_r = [[0f32; 4]; 2];
    let mut step_scale = [[0f32; 4]; 2];
    for (n, [r, s]) in steps.iter().enumerate() {
        step_r[n / 4][n % 4] = *r as f32;
        step_scale[n / 4][n % 4] = *s as f32;
    }
    let (px, py) = camera.principal_point_px();
    let (px, py) = (f64::from(px), f64::from(py));
    let screen = (f64::from(d.width_px), f64::from(d.height_px));
    Ok(layers
        .iter()
        .zip(&plan.buffers)
        .map(|(l, b)| ShadeLayerGpu {
            origin: [(l.origin.x_px - px) as f32, (l.origin.y_px - py) as f32],
            scale: l.scale as f32,
            steps: steps.len() as u32,
            shaded: shaded_range(l, b.width, b.height, screen),
            gaze: [(gaze.point.x_px - px) as f32, (gaze.point.y_px - py) as f32],
            c_r: c_r as f32,
            floor_rad: plan.footprint.floor_rad,
            max_rad: MAX_SPREAD_DEG.to_radians() as f32,
            pad: [0; 3],
            step_r,
            step_scale,
        })
        .collect())
}

/// The shade kernels' bindings of one layer past the first: its `FrameParams` (binding 21)
/// and [`ShadeLayerGpu`] (binding 30), the bind group naming them with the eye's other
/// buffers, and its dispatch.
pub struct LayerPass {
    frame: wgpu::Buffer,
    block: wgpu::Buffer,
    pub(crate) bind_group: wgpu::BindGroup,
    pub(crate) groups: [u32; 2],
}

/// A uniform buffer of `bytes` for the kernels, counted.
pub(crate) fn uniform_buffer(ctx: &GpuContext, label: &str, bytes: usize) -> wgpu::Buffer {
    ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16) as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The passes of layers 1.. of `groups` (each layer's dispatch grid), binding `entries` (the
/// first layer's, whose 21 and 30 are replaced) with `pipeline`'s layout. Call inside an
/// error scope.
pub(crate) fn more_passes(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
    groups: &[[u32; 2]],
) -> Vec<LayerPass> {
    groups
        .iter()
        .skip(1)
        .map(|&g| {
            let frame = uniform_buffer(
                ctx,
                "frame layer parameters",
                std::mem::size_of::<FrameUniform>(),
            );
            let block = uniform_buffer(
                ctx,
                "frame layer rays",
                std::mem::size_of::<ShadeLayerGpu>(),
            );
            let own: Vec<(u32, &wgpu::Buffer)> = entries
                .iter()
                .map(|&(b, buf)| match b {
                    21 => (b, &frame),
                    30 => (b, &block),
                    _ => (b, buf),
                })
                .collect();
            let bind_group = bind_group(ctx, "resident frame layer", pipeline, &own);
            LayerPass {
                frame,
                block,
                bind_group,
                groups: g,
            }
        })
        .collect()
}

/// Writes layers 1..'s `FrameParams` (the first layer's `first` with the layer's offset,
/// size, key and grid) and every layer's [`ShadeLayerGpu`] (the first into `first_block`).
pub(crate) fn write_layers(
    ctx: &GpuContext,
    plan: &FramePlan,
    first: &FrameUniform,
    first_block: &wgpu::Buffer,
    more: &[LayerPass],
    samples: &DeviceSamples,
    blocks: &[ShadeLayerGpu],
) {
    if let Some(b) = blocks.first() {
        ctx.write_buffer(first_block, 0, bytemuck::bytes_of(b));
    }
    for (k, pass) in more.iter().enumerate() {
        let layer = k as u32 + 1;
        let Some(l) = samples.layers().get(layer as usize) else {
            continue;
        };
        let f = FrameUniform {
            texels: l.width * l.height,
            layer: super::shade::FrameLayerGpu {
                offset: l.offset,
                width: l.width,
                height: l.height,
                key_hi: (with_frame(texel_key(layer, 0, 0), plan.noise) >> 32) as u32,
            },
            row_invocations: pass.groups[0] * WORKGROUP_SIZE,
            ..*first
        };
        ctx.write_buffer(&pass.frame, 0, bytemuck::bytes_of(&f));
        if let Some(b) = blocks.get(layer as usize) {
            ctx.write_buffer(&pass.block, 0, bytemuck::bytes_of(b));
        }
    }
}

/// The records of `mapping`'s layers for the reconstruction, as `fovea_post::inverse_map`'s
/// `layered` reads them (its shaded rectangles scanned along the middle row and column, as
/// the CPU scans them).
fn records(
    mapping: &dyn FoveationMapping,
    samples: &DeviceSamples,
) -> Result<[LayerRecordGpu; MAX_LAYERS]> {
    let layers = mapping.screen_layers();
    let sample_layers = samples.layers();
    if layers.len() > MAX_LAYERS || layers.len() != sample_layers.len() {
        return Err(GpuError::Input(format!(
            "{} sample layers for a mapping of {} (at most {MAX_LAYERS})",
            sample_layers.len(),
            layers.len()
        )));
    }
    let mut out = [LayerRecordGpu::default(); MAX_LAYERS];
    for (k, (l, s)) in layers.iter().zip(sample_layers).enumerate() {
        let b = mapping.buffers().get(k).copied();
        if b.map(|b| (b.width, b.height)) != Some((s.width, s.height)) || s.width == 0 {
            return Err(GpuError::Input(format!(
                "sample layer {k} is {}x{}, the mapping's {:?}",
                s.width, s.height, b
            )));
        }
        let (bw, bh) = (s.width, s.height);
        let layer = k as u32;
        let (mid_i, mid_j) = (bw / 2, bh / 2);
        let i0 = (0..bw)
            .find(|&i| mapping.is_shaded(layer, i, mid_j))
            .unwrap_or(0);
        let i1 = (0..bw)
            .rev()
            .find(|&i| mapping.is_shaded(layer, i, mid_j))
            .unwrap_or(bw - 1);
        let j0 = (0..bh)
            .find(|&j| mapping.is_shaded(layer, mid_i, j))
            .unwrap_or(0);
        let j1 = (0..bh)
            .rev()
            .find(|&j| mapping.is_shaded(layer, mid_i, j))
            .unwrap_or(bh - 1);
        let (dc, dr, has) = match l.disc {
            Some((c, r)) => ([c.x_px as f32, c.y_px as f32], r as f32, 1.0),
            None => ([0.0, 0.0], 0.0, 0.0),
        };
        out[k] = LayerRecordGpu {
            origin: [l.origin.x_px as f32, l.origin.y_px as f32],
            size: [l.width_px as f32, l.height_px as f32],
            disc: [dc[0], dc[1], dr, has],
            rect: [i0, i1.max(i0), j0, j1.max(j0)],
            scale: l.scale as f32,
            offset: s.offset,
            width: bw,
            pad: 0,
        };
    }
    Ok(out)
}

/// The screen side's layered reconstruction (module header): its pipeline, uniform, the
/// reconstructed screen (`vec4<u32>` a pixel: RGB bits, depth bits) and the bind group of the
/// samples it last read.
pub struct ResidentLayers {
    ctx: GpuContext,
    width: u32,
    height: u32,
    pipeline: wgpu::ComputePipeline,
    uniform: wgpu::Buffer,
    out: wgpu::Buffer,
    /// The uniform as last written (rewritten only when it changes).
    last: Option<LayersUniform>,
    /// The bind group and the sample buffer it names.
    bind: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    /// The inset's boundary smoothing (none or the alpha blend).
    smoothing: Smoothing,
}

/// The inset's rectangle and alpha-blend strip as the CPU's `reconstruct` composites them
/// (`[0; 4], 0`: a hard boundary): layer 0's first texel centre through the inverse mapping
/// and the layer's size, blended only where the periphery (layer 1) is an exact 2× or 4×
/// subsampling of the screen.
fn inset_blend(
    mapping: &dyn FoveationMapping,
    samples: &DeviceSamples,
    smoothing: Smoothing,
    (w, h): (u32, u32),
) -> ([u32; 4], u32) {
    let hard = ([0; 4], 0);
    let Smoothing::AlphaBlend { strip_px } = smoothing else {
        return hard;
    };
    let layers = samples.layers();
    if mapping.method() != Method::Inset || layers.len() < 2 {
        return hard;
    }
    let (inset, periphery) = (layers[0], layers[1]);
    let factor = w / periphery.width.max(1);
    let exact =
        matches!(factor, 2 | 4) && periphery.width * factor == w && periphery.height * factor == h;
    let first = mapping.inverse(SamplePoint {
        layer: 0,
        u: 0.5,
        v: 0.5,
    });
    let Some(p) = first.filter(|_| exact) else {
        return hard;
    };
    let (x0, y0) = ((p.x_px - 0.5).round(), (p.y_px - 0.5).round());
    let fits = x0 >= 0.0
        && y0 >= 0.0
        && inset.width > 0
        && inset.height > 0
        && x0 as u64 + u64::from(inset.width) <= u64::from(w)
        && y0 as u64 + u64::from(inset.height) <= u64::from(h);
    if !fits {
        return hard;
    }
    let (x0, y0) = (x0 as u32, y0 as u32);
    (
        [x0, y0, x0 + inset.width - 1, y0 + inset.height - 1],
        strip_px,
    )
}

impl ResidentLayers {
    /// Everything for a `width × height` screen, the inset's boundary smoothed with
    /// `smoothing` (none or the alpha blend; others [`GpuError::Unsupported`]), checked
    /// against the adapter first.
    pub fn new(ctx: &GpuContext, width: u32, height: u32, smoothing: Smoothing) -> Result<Self> {
        if !matches!(smoothing, Smoothing::None | Smoothing::AlphaBlend { .. }) {
            return Err(GpuError::Unsupported(format!(
                "the inset's {} boundary smoothing on the resident screen side",
                smoothing.name()
            )));
        }
        let bytes = u64::from(width) * u64::from(height) * 16;
        ctx.check_storage_binding("the layered reconstruction's screen", bytes)?;
        let what = "building the resident layered reconstruction";
        let pipeline = ctx
            .scoped(what, || SHADER.pipelines(ctx.device()).pop())?
            .ok_or_else(|| GpuError::Input("the layers module has no entry point".into()))?;
        let (uniform, out) = ctx.scoped(what, || {
            let uniform = uniform_buffer(
                ctx,
                "layers parameters",
                std::mem::size_of::<LayersUniform>(),
            );
            let out = crate::transfer::empty(
                ctx,
                "layered screen",
                bytes.max(16),
                wgpu::BufferUsages::STORAGE,
            );
            (uniform, out)
        })?;
        Ok(Self {
            ctx: ctx.clone(),
            width,
            height,
            pipeline,
            uniform,
            out,
            last: None,
            bind: None,
            smoothing,
        })
    }

    /// Whether `mapping`'s layers fit (a layered mapping of at most [`MAX_LAYERS`] layers).
    pub fn fits(mapping: &dyn FoveationMapping) -> bool {
        let n = mapping.screen_layers().len();
        n > 0 && n <= MAX_LAYERS && n == mapping.buffers().len()
    }

    /// The reconstructed screen: `vec4<u32>` a pixel (RGB bits, depth bits).
    pub fn output(&self) -> &wgpu::Buffer {
        &self.out
    }

    /// Checks `samples` against `mapping` and writes the layers' records where they changed,
    /// binding `samples` when it is a new buffer. Errors before anything is written.
    pub fn prepare(
        &mut self,
        mapping: &dyn FoveationMapping,
        samples: &DeviceSamples,
    ) -> Result<()> {
        let layers = records(mapping, samples)?;
        let (inset, strip) =
            inset_blend(mapping, samples, self.smoothing, (self.width, self.height));
        let u = LayersUniform {
            width: self.width,
            height: self.height,
            count: mapping.screen_layers().len() as u32,
            inf_bits: f32::INFINITY.to_bits(),
            inset,
            strip,
            pad: [0; 3],
            layers,
        };
        let ctx = &self.ctx;
        let same = self
            .bind
            .as_ref()
            .is_some_and(|(b, _)| b == samples.buffer());
        ctx.scoped("preparing the resident layered reconstruction", || {
            if self.last != Some(u) {
                ctx.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&u));
                self.last = Some(u);
            }
            if !same {
                let bind = bind_group(
                    ctx,
                    "resident layers",
                    &self.pipeline,
                    &[(0, &self.uniform), (1, samples.buffer()), (2, &self.out)],
                );
                self.bind = Some((samples.buffer().clone(), bind));
            }
        })
    }

    /// Records the reconstruction's pass, timed as the screen side's `reconstruct` (pass 2
    /// of `SCREEN_PASSES`).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut FrameTimer>,
    ) -> Result<()> {
        let Some((_, bind)) = &self.bind else {
            return Err(GpuError::Input(
                "the layered reconstruction was not prepared".into(),
            ));
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("reconstruct layers"),
            timestamp_writes: timer.and_then(|t| t.writes(2)),
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(self.width.div_ceil(WORKGROUP_SIZE), self.height, 1);
        Ok(())
    }
}
