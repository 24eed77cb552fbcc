//! The sample-space denoiser on the GPU (issue 38): the twin of `fovea_post::denoise::denoise`,
//! the edge-avoiding à-trous wavelet filter of SVGF (Schied et al. 2017, "Spatiotemporal
//! Variance-Guided Filtering", Sec. 4; after Dammertz et al. 2010) — same roles, depth
//! gradient, 3×3 luminance moments and firefly clamp, same kernels (3×3 linear or 5×5 B3
//! spline), iterations, edge-stopping weights
//! (`exp(−|Δz|/(σ_z|∇z·Δp| + ε_z) − |Δl|/(σ_l √Var + ε) − σ_n(1 − n·n'))` with the same
//! degree-5 exponential), the same albedo demodulation
//! and the same polar seams (rows wrap around the angle axis; a column step keeps the angle;
//! a step inside the innermost ring continues half a turn on across the fovea, as Koskela et
//! al., EGSR 2019, filter in visual-polar space). Only the Monte Carlo part of each colour is
//! filtered; the exact part is added back untouched.
//!
//! **Buffers.** The frame's sample buffers are a [`DeviceSamples`] (`vec4`: RGB + depth, the
//! layers one after another, row-major). The guides are a [`DeviceGuides`] of the same
//! layers: three buffers of one `vec4<f32>` per texel each — albedo, shading normal, the
//! colour's Monte Carlo part (a zero normal: no surface record; a NaN Monte Carlo part: the
//! whole colour is filtered; the part's w lane the temporal variance, SVGF's temporal
//! estimate where the history gives one, as `denoise_with_variance` takes it, NaN or negative
//! where not; the other w lanes 0) — so that no binding holds more than 16 bytes per
//! texel, as the sample buffers. The working buffers — normal and depth, the depth gradient and role, two
//! light-and-variance buffers (16 bytes per texel each), a list of the texels that filter (4
//! bytes each), the polar column table, three counters —
//! and the pipelines and bind groups live in a [`GpuDenoiser`], created once and rebuilt only
//! when the layers' sizes change (or, for the bind groups that name them, the caller's sample
//! or guide buffers).
//!
//! **Passes** (one invocation per texel of all layers, WGSL `shaders/denoise.wgsl`; after the
//! first, over the texels that filter only, listed on the device by the first, where the
//! caller gives a bound of them: [`GpuDenoiser::set_source_bound`]):
//! `denoise_prepare` (roles, demodulated light), `denoise_variance` (gradient, moments, clamp),
//! `iterations` à-trous passes at step `2^i` (`denoise_atrous_first`, then `denoise_atrous`),
//! `denoise_finish` (remodulate into the sample buffers). [`GpuDenoiser::record`] records them
//! into a caller's encoder (the resident frame); [`GpuDenoiser::run`] uploads CPU buffers,
//! records, submits once and reads back (the staged `--backend gpu` path).
//!
//! **Differences from the CPU.** The polar grid's angle alignment is computed in f32 (the CPU:
//! f64), so a tap whose angle falls within about 10⁻⁴ of a row boundary may read the next row;
//! the shader compiler may fuse multiply-adds. The results agree to within the tests' PSNR
//! bound (≥ 40 dB in luma; measured figures in docs/denoise.md), not bit for bit.

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::BufferSize;
use fovea_post::denoise::{DenoiseGuides, DenoiseParams, DenoiseStats, Kernel, MAX_ITERATIONS};
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::samples::{DeviceSamples, SampleLayer};
use crate::shaders::{ShaderSource, WORKGROUP_SIZE};
use crate::transfer::read_buffers;

/// The denoiser's module: entry points `denoise_prepare`, `denoise_variance`,
/// `denoise_atrous_first` (the first iteration, its variance prefiltered), `denoise_atrous`
/// (the later ones), `denoise_finish`; [`DenoiseUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "denoise.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/denoise.wgsl")
    ),
    entry_points: &[
        "denoise_prepare",
        "denoise_variance",
        "denoise_atrous_first",
        "denoise_atrous",
        "denoise_finish",
    ],
    uniform: ("DenoiseParams", std::mem::size_of::<DenoiseUniform>()),
};

/// Most layers one call filters (the uniform's layer table).
pub const MAX_LAYERS: usize = 8;
/// Bytes of one texel's guides (three `vec4<f32>`).
pub const GUIDE_BYTES: u64 = 48;
/// Bytes per texel of the largest binding (every buffer the passes bind: one `vec4<f32>`).
const TEXEL_BYTES: u64 = 16;
/// Bytes of the working buffers per texel: normal + depth, gradient + role, two light and
/// variance buffers, the list of the texels that filter.
pub const WORK_BYTES: u64 = 4 * TEXEL_BYTES + 4;

/// The uniform block `DenoiseParams` of `denoise.wgsl` (same field order; see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DenoiseUniform {
    /// Texels of all layers.
    pub texels: u32,
    /// Layers in `layers`.
    pub layer_count: u32,
    /// À-trous step of the slot's iteration, texels.
    pub atrous_step: i32,
    /// Kernel taps per axis (3 or 5).
    pub taps: i32,
    /// σ_l.
    pub sigma_l: f32,
    /// σ_z.
    pub sigma_z: f32,
    /// σ_n.
    pub sigma_n: f32,
    /// The firefly clamp's k; 0: no clamp.
    pub firefly_k: f32,
    /// ln 2 / σ_n.
    pub same_normal: f32,
    /// 1: the passes after `denoise_prepare` run over its list of the texels that are not
    /// passive ([`GpuDenoiser::set_source_bound`]); 0: over every texel.
    pub listed: u32,
    /// Padding.
    pub pad: [u32; 2],
    /// Per layer: first texel, width, height, 0 (rectangle) or 1 + first column (polar).
    pub layers: [[u32; 4]; MAX_LAYERS],
}

/// A frame's denoiser guides on the device, the layers of a [`DeviceSamples`] (same offsets):
/// three storage buffers of one `vec4<f32>` per texel each (`array<vec4<f32>>`) — the albedo
/// (linear RGB), the unit shading normal (zero: no surface record) and the colour's Monte Carlo
/// part (NaN: unknown, the whole colour is filtered) with, in its w lane, the temporal variance
/// of its demodulated luminance (NaN or negative: none, the spatial estimate); the other w
/// lanes 0. The resident frame's shade
/// pass writes them; the staged path uploads them ([`Self::upload`]).
#[derive(Debug)]
pub struct DeviceGuides {
    albedo: wgpu::Buffer,
    normal: wgpu::Buffer,
    noisy: wgpu::Buffer,
    layers: Vec<SampleLayer>,
    texels: u64,
}

impl DeviceGuides {
    /// Guides for layers of `sizes` (contents undefined until written).
    /// [`GpuError::AdapterTooSmall`] when one of them exceeds one storage binding.
    pub fn new(ctx: &GpuContext, sizes: &[BufferSize]) -> Result<Self> {
        Self::with_capacity(ctx, sizes, 0)
    }

    /// [`Self::new`] with room for at least `capacity_texels` texels, so that a later frame's
    /// layers of another size take the buffers over ([`Self::relayout`]) without allocating —
    /// the resident frame's guides, sized as its [`DeviceSamples`] (a polar buffer's size
    /// follows the gaze).
    pub fn with_capacity(
        ctx: &GpuContext,
        sizes: &[BufferSize],
        capacity_texels: u64,
    ) -> Result<Self> {
        let (layers, texels, bytes) =
            DeviceSamples::sized(sizes, capacity_texels, "denoiser guides")?;
        ctx.check_storage_binding("the denoiser's guides (each of three)", bytes)?;
        let (albedo, normal, noisy) = ctx.scoped("allocating the denoiser's guides", || {
            // COPY_SRC: a test reads the temporal variance back from the part's w lane.
            let make = |label| {
                ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes,
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_DST
                        | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            };
            (
                make("denoise guide albedo"),
                make("denoise guide normal"),
                make("denoise guide noisy part"),
            )
        })?;
        Ok(Self {
            albedo,
            normal,
            noisy,
            layers,
            texels,
        })
    }

    /// The albedo buffer (`array<vec4<f32>>`: linear RGB, w 0).
    pub fn albedo(&self) -> &wgpu::Buffer {
        &self.albedo
    }

    /// The shading normal buffer (`array<vec4<f32>>`: unit normal or zero, w 0).
    pub fn normal(&self) -> &wgpu::Buffer {
        &self.normal
    }

    /// The Monte Carlo part buffer (`array<vec4<f32>>`: linear RGB or NaN; w the temporal
    /// variance, NaN or negative where none).
    pub fn noisy(&self) -> &wgpu::Buffer {
        &self.noisy
    }

    /// The layers.
    pub fn layers(&self) -> &[SampleLayer] {
        &self.layers
    }

    /// Texels each buffer holds room for.
    pub fn capacity(&self) -> u64 {
        self.albedo.size() / TEXEL_BYTES
    }

    /// Takes the layers of `sizes` in the same buffers (contents undefined until written) when
    /// they fit the [`capacity`](Self::capacity); `false`, and nothing changed, otherwise.
    pub fn relayout(&mut self, sizes: &[BufferSize]) -> bool {
        let capacity = self.capacity();
        DeviceSamples::relayout_within(sizes, capacity, &mut self.layers, &mut self.texels)
    }

    /// Whether these guides have exactly the layers of `sizes`.
    pub fn fits(&self, sizes: &[BufferSize]) -> bool {
        same_sizes(&self.layers, sizes)
    }

    /// Writes the CPU's guides (one image each per layer, these layers' sizes): three counted
    /// uploads. A missing Monte Carlo part (`guides.noisy` empty) is uploaded as NaN; the
    /// temporal variance (`guides.variance`, where given) goes into the Monte Carlo part's w
    /// lane, NaN where none is (the denoiser's spatial estimate), as
    /// `fovea_post::denoise::denoise_with_variance` reads it.
    pub fn upload(&self, ctx: &GpuContext, guides: &DenoiseGuides) -> Result<()> {
        let n = self.layers.len();
        let ok = guides.albedo.len() == n
            && guides.normal.len() == n
            && (guides.noisy.is_empty() || guides.noisy.len() == n)
            && self.layers.iter().enumerate().all(|(l, s)| {
                let dims = (s.width, s.height);
                (guides.albedo[l].width(), guides.albedo[l].height()) == dims
                    && (guides.normal[l].width(), guides.normal[l].height()) == dims
                    && guides
                        .noisy
                        .get(l)
                        .is_none_or(|m| (m.width(), m.height()) == dims)
                    && guides
                        .variance
                        .get(l)
                        .is_none_or(|v| (v.width(), v.height()) == dims)
            });
        if !ok {
            return Err(GpuError::Input(format!(
                "denoiser guides of {} layers do not match the device's {:?}",
                guides.albedo.len(),
                self.layers
            )));
        }
        fn plane<'a>(
            layers: &[SampleLayer],
            texels: u64,
            layer: impl Fn(usize) -> Option<&'a [[f32; 3]]>,
        ) -> Vec<[f32; 4]> {
            let mut v: Vec<[f32; 4]> = Vec::with_capacity(texels as usize);
            for (l, s) in layers.iter().enumerate() {
                match layer(l) {
                    Some(d) => v.extend(d.iter().map(|c| [c[0], c[1], c[2], 0.0])),
                    None => v.extend(std::iter::repeat_n(
                        [f32::NAN, f32::NAN, f32::NAN, 0.0],
                        s.width as usize * s.height as usize,
                    )),
                }
            }
            v
        }
        let albedo = plane(&self.layers, self.texels, |l| Some(guides.albedo[l].data()));
        let normal = plane(&self.layers, self.texels, |l| Some(guides.normal[l].data()));
        let mut noisy = plane(&self.layers, self.texels, |l| {
            guides.noisy.get(l).map(|m| m.data())
        });
        let mut at = 0usize;
        for (l, s) in self.layers.iter().enumerate() {
            let n = s.width as usize * s.height as usize;
            let lanes = noisy[at..at + n].iter_mut();
            match guides.variance.get(l) {
                Some(v) => lanes.zip(v.data()).for_each(|(m, &v)| m[3] = v),
                None => lanes.for_each(|m| m[3] = f32::NAN),
            }
            at += n;
        }
        ctx.scoped("uploading the denoiser's guides", || {
            ctx.write_buffer(&self.albedo, 0, bytemuck::cast_slice(&albedo));
            ctx.write_buffer(&self.normal, 0, bytemuck::cast_slice(&normal));
            ctx.write_buffer(&self.noisy, 0, bytemuck::cast_slice(&noisy));
        })
    }
}

fn same_sizes(layers: &[SampleLayer], sizes: &[BufferSize]) -> bool {
    layers.len() == sizes.len()
        && layers
            .iter()
            .zip(sizes)
            .all(|(l, s)| l.width == s.width && l.height == s.height)
}

/// Where the time of one [`GpuDenoiser::run`] went, wall ms.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DenoiseTimes {
    /// Buffers (when sizes changed), uploads, recording and submission.
    pub upload_ms: f64,
    /// Submission until the colours were back (the passes and the readback).
    pub run_and_readback_ms: f64,
    /// All of it.
    pub total_ms: f64,
}

/// The working buffers and bind groups for one set of layer sizes.
struct Sized {
    layers: Vec<SampleLayer>,
    texels: u64,
    /// Texels the working buffers hold room for (at least `texels`).
    capacity: u64,
    /// Polar column records the column table holds room for.
    column_capacity: u64,
    /// The uniform's bytes as last written (not written again while they stay).
    uniform_bytes: Vec<u8>,
    /// One [`DenoiseUniform`] per iteration, `uniform_stride` bytes apart.
    uniform: wgpu::Buffer,
    uniform_stride: u64,
    /// Light and variance, ping and pong.
    light: [wgpu::Buffer; 2],
    /// Per polar column of every layer: rows, period bits.
    columns: wgpu::Buffer,
    /// [filtered, clamped].
    counters: wgpu::Buffer,
    /// `denoise_variance` (light[0] → light[1]).
    variance: wgpu::BindGroup,
    /// `denoise_atrous_first` (`i` = 0) or `denoise_atrous` of iteration `i` (its uniform
    /// slot; light[1 − i % 2] → light[i % 2]).
    atrous: Vec<wgpu::BindGroup>,
    /// The polar grids whose table `columns` holds (`None`: not written yet).
    columns_for: Option<Vec<Grid>>,
    /// The bind groups naming the caller's buffers.
    bound: Option<Bound>,
    /// The staged path's own device buffers and readback.
    staged: Option<Staged>,
    /// Kept alive for the bind groups.
    _geom: wgpu::Buffer,
    _aux: wgpu::Buffer,
    /// The texels that filter, listed by `denoise_prepare` (room for `capacity`).
    work_list: wgpu::Buffer,
}

/// Bind groups of `denoise_prepare` and `denoise_finish` for one pair of caller buffers.
struct Bound {
    samples: wgpu::Buffer,
    /// Albedo, normal, Monte Carlo part.
    guides: [wgpu::Buffer; 3],
    prepare: wgpu::BindGroup,
    /// Reading light[0], light[1].
    finish: [wgpu::BindGroup; 2],
}

/// [`GpuDenoiser::run`]'s device copies of the CPU buffers.
struct Staged {
    samples: DeviceSamples,
    guides: DeviceGuides,
    readback: wgpu::Buffer,
    counters_readback: wgpu::Buffer,
}

/// The denoiser's pipelines and persistent buffers on one device; keep it from frame to frame.
pub struct GpuDenoiser {
    ctx: GpuContext,
    prepare: wgpu::ComputePipeline,
    variance: wgpu::ComputePipeline,
    /// The first iteration's (the variance prefiltered over 3×3) and the later ones'.
    atrous_first: wgpu::ComputePipeline,
    atrous: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    sized: Option<Sized>,
    /// The least room the working buffers are made with: (texels, polar columns).
    reserve: (u64, u64),
    /// An upper bound of the texels the next recorded call filters (not passive), when the
    /// caller knows one ([`Self::set_source_bound`]).
    source_bound: Option<u32>,
}

impl GpuDenoiser {
    /// Compiles the module on `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        let mut p = ctx.scoped("building the denoiser's pipelines", || {
            SHADER.pipelines(ctx.device())
        })?;
        if p.len() != 5 {
            return Err(GpuError::Input(
                "the denoiser's module lacks an entry point".into(),
            ));
        }
        let finish = p.pop().expect("five pipelines");
        let atrous = p.pop().expect("five pipelines");
        let atrous_first = p.pop().expect("five pipelines");
        let variance = p.pop().expect("five pipelines");
        let prepare = p.pop().expect("five pipelines");
        Ok(Self {
            ctx: ctx.clone(),
            prepare,
            variance,
            atrous_first,
            atrous,
            finish,
            sized: None,
            reserve: (0, 0),
            source_bound: None,
        })
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Whether layers of `sizes` fit the device (every per-texel buffer, 16 bytes a texel, in
    /// one storage binding; at most [`MAX_LAYERS`] layers). A caller that can fall back to the
    /// CPU asks this first.
    pub fn fits(&self, sizes: &[BufferSize]) -> bool {
        let texels: u64 = sizes.iter().map(|s| s.pixels()).sum();
        sizes.len() <= MAX_LAYERS
            && texels < u32::MAX as u64
            && texels.max(1) * TEXEL_BYTES <= self.ctx.max_binding_bytes()
            && dispatch_size(&self.ctx, texels).is_some()
    }

    /// Makes the working buffers, when they are next (re)made, with room for at least
    /// `texels` texels and `columns` polar columns, so that later calls whose layers change
    /// size within that room (a polar buffer's size follows the gaze) allocate nothing and
    /// bind nothing anew — the resident frame reserves its sample buffers' capacity.
    pub fn reserve(&mut self, texels: u64, columns: u64) {
        self.reserve = (texels, columns);
    }

    /// Declares an upper bound of the texels the next recorded calls filter — those that are
    /// not passive: with a surface record (a nonzero normal guide) at a finite depth —, or
    /// `None` (the default): unknown. With a bound below the texels, `denoise_prepare` lists
    /// those texels on the device and the later passes are dispatched over `bound` invocations
    /// of that list instead of every texel (the resident frame's polar buffers: the bound of
    /// its list of shaded texels, `frame::compact`). The results are the same bits; a bound
    /// below the true count would leave texels unfiltered, so give only a true bound.
    pub fn set_source_bound(&mut self, bound: Option<u32>) {
        self.source_bound = bound;
    }

    /// The counters buffer of the last recorded call (`[filtered, clamped, listed]`, three
    /// `u32`: the first two are [`DenoiseStats`]'), for a
    /// caller that wants [`DenoiseStats`] from the device; `None` before any call.
    pub fn counters(&self) -> Option<&wgpu::Buffer> {
        self.sized.as_ref().map(|s| &s.counters)
    }

    /// The last call's counters read back (blocking, counted): texels filtered, sources
    /// clamped, texels listed (0 without a bound, [`Self::set_source_bound`]). For tests, never
    /// on the frame path; `None` before any call.
    pub fn read_counts(&self) -> Result<Option<[u32; 3]>> {
        let Some(s) = self.sized.as_ref() else {
            return Ok(None);
        };
        let mut counts = [0u32; 3];
        crate::transfer::read_back(
            &self.ctx,
            &[(&s.counters, 12)],
            "the denoiser's counters",
            |_, bytes| {
                let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
                for (c, w) in counts.iter_mut().zip(words) {
                    *c = w;
                }
            },
        )?;
        Ok(Some(counts))
    }

    /// Records the denoiser over `samples` (in place) guided by `guides` (the same layers) into
    /// `encoder`: `grids[l]` is layer `l`'s topology (a `Grid::Rect` of its size, or its polar
    /// grid). Nothing is submitted. Buffers and bind groups are created only when the layers'
    /// sizes, or the caller's buffers, differ from the last call's; the parameters are written
    /// into a uniform buffer (`Queue::write_buffer`), so the parameters of all calls recorded
    /// before one submission are those of the last.
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        samples: &DeviceSamples,
        guides: &DeviceGuides,
        grids: &[Grid],
        params: &DenoiseParams,
    ) -> Result<()> {
        self.record_timed(encoder, samples, guides, grids, params, None)
    }

    /// [`Self::record`] with the denoiser's compute pass (all its dispatches) timed where
    /// `timestamp_writes` says (a [`crate::frame::FrameTimer`]'s slot).
    pub fn record_timed(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        samples: &DeviceSamples,
        guides: &DeviceGuides,
        grids: &[Grid],
        params: &DenoiseParams,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<()> {
        params
            .validate()
            .map_err(|e| GpuError::Input(e.to_string()))?;
        let layers = samples.layers().to_vec();
        if guides.layers() != layers.as_slice() {
            return Err(GpuError::Input(format!(
                "denoiser guides of layers {:?} for sample buffers of layers {layers:?}",
                guides.layers()
            )));
        }
        if grids.len() != layers.len() {
            return Err(GpuError::Input(format!(
                "{} denoiser grids for {} sample layers",
                grids.len(),
                layers.len()
            )));
        }
        if layers.len() > MAX_LAYERS {
            return Err(GpuError::Unsupported(format!(
                "denoising {} layers at once (at most {MAX_LAYERS} on the GPU)",
                layers.len()
            )));
        }
        let texels = samples.texels();
        if texels == 0 {
            return Ok(());
        }
        let (groups_x, groups_y) = dispatch_size(&self.ctx, texels).ok_or_else(|| {
            GpuError::Unsupported(format!("denoising {texels} texels in one dispatch"))
        })?;
        // Over the list of the texels that filter where a bound of them below the texels is
        // known (`set_source_bound`); the bound fits a dispatch wherever the texels do.
        let listed = self
            .source_bound
            .filter(|&b| u64::from(b) < texels)
            .and_then(|b| dispatch_size(&self.ctx, u64::from(b)));
        let column_base = column_table(&layers, grids)?;
        self.fit(&layers, texels)?;
        self.bind(samples.buffer(), guides)?;
        let s = self.sized.as_mut().expect("fit sized the denoiser");

        // The polar tables, rewritten when the grids change (the gaze moved).
        if !matches!(&s.columns_for, Some(old) if grids_equal(old, grids)) {
            let mut table = vec![[0u32; 2]; column_base.1.max(1)];
            for (l, grid) in grids.iter().enumerate() {
                if let (Grid::Polar { rows, period }, Some(base)) = (grid, column_base.0[l]) {
                    for (c, (&r, &p)) in rows.iter().zip(period).enumerate() {
                        table[base + c] = [r, (p as f32).to_bits()];
                    }
                }
            }
            self.ctx
                .write_buffer(&s.columns, 0, bytemuck::cast_slice(&table));
            s.columns_for = Some(grids.to_vec());
        }

        // The uniform, one slot per iteration.
        let taps = match params.kernel {
            Kernel::Linear3x3 => 3,
            Kernel::B3Spline5x5 => 5,
        };
        let mut table = [[0u32; 4]; MAX_LAYERS];
        for (l, layer) in layers.iter().enumerate() {
            let polar = column_base.0[l].map_or(0, |b| 1 + b as u32);
            table[l] = [layer.offset, layer.width, layer.height, polar];
        }
        let base = DenoiseUniform {
            texels: texels as u32,
            layer_count: layers.len() as u32,
            atrous_step: 1,
            taps,
            sigma_l: params.sigma_luminance,
            sigma_z: params.sigma_depth,
            sigma_n: params.normal_power as f32,
            firefly_k: params.firefly_k.unwrap_or(0.0),
            same_normal: std::f32::consts::LN_2 / params.normal_power as f32,
            listed: u32::from(listed.is_some()),
            pad: [0; 2],
            layers: table,
        };
        let mut bytes = vec![0u8; (s.uniform_stride * MAX_ITERATIONS as u64) as usize];
        for it in 0..MAX_ITERATIONS {
            let u = DenoiseUniform {
                atrous_step: 1 << it,
                ..base
            };
            let at = (s.uniform_stride * it as u64) as usize;
            bytes[at..at + std::mem::size_of::<DenoiseUniform>()]
                .copy_from_slice(bytemuck::bytes_of(&u));
        }
        if bytes != s.uniform_bytes {
            self.ctx.write_buffer(&s.uniform, 0, &bytes);
            s.uniform_bytes = bytes;
        }

        // The passes.
        let bound = s
            .bound
            .as_ref()
            .expect("bind made the caller's bind groups");
        encoder.clear_buffer(&s.counters, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("denoise"),
            timestamp_writes,
        });
        let mut dispatch =
            |pipeline: &wgpu::ComputePipeline, group: &wgpu::BindGroup, (x, y): (u32, u32)| {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(x, y, 1);
            };
        dispatch(&self.prepare, &bound.prepare, (groups_x, groups_y));
        // The later passes: over the list (a listed texel's invocation past the count returns)
        // or every texel.
        let work = listed.unwrap_or((groups_x, groups_y));
        dispatch(&self.variance, &s.variance, work);
        for it in 0..params.iterations as usize {
            let pipeline = if it == 0 {
                &self.atrous_first
            } else {
                &self.atrous
            };
            dispatch(pipeline, &s.atrous[it], work);
        }
        // Iteration i writes light[i % 2]; with none, the variance pass wrote light[1].
        let last = (params.iterations as usize + 1) % 2;
        dispatch(&self.finish, &bound.finish[last], work);
        Ok(())
    }

    /// [`Self::record`] for the CPU's buffers: uploads `samples` and `guides` into the
    /// denoiser's own device buffers (kept while the sizes stay), records, submits once, and
    /// reads the filtered colours back into `samples` (depth unchanged). `grids` and `params`
    /// as for [`Self::record`].
    pub fn run(
        &mut self,
        samples: &mut SampleBuffers,
        guides: &DenoiseGuides,
        grids: &[Grid],
        params: &DenoiseParams,
    ) -> Result<(DenoiseStats, DenoiseTimes)> {
        let t_start = Instant::now();
        let sizes: Vec<BufferSize> = samples
            .color
            .iter()
            .map(|c| BufferSize {
                width: c.width(),
                height: c.height(),
            })
            .collect();
        let texels: u64 = sizes.iter().map(|s| s.pixels()).sum();
        if texels == 0 {
            return Ok((DenoiseStats::default(), DenoiseTimes::default()));
        }
        let (layers, _) = DeviceSamples::layout(&sizes).ok_or_else(|| {
            GpuError::Unsupported(format!("denoising more than {} texels", u32::MAX))
        })?;
        self.fit(&layers, texels)?;
        let ctx = self.ctx.clone();
        let staged = {
            let s = self.sized.as_mut().expect("fit sized the denoiser");
            if s.staged.is_none() {
                let bytes = texels * crate::samples::TEXEL_BYTES;
                let samples = DeviceSamples::new(&ctx, &sizes)?;
                let guides = DeviceGuides::new(&ctx, &sizes)?;
                let (readback, counters_readback) =
                    ctx.scoped("allocating the denoiser's readback", || {
                        let read = |label, size| {
                            ctx.create_buffer(&wgpu::BufferDescriptor {
                                label: Some(label),
                                size,
                                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                                mapped_at_creation: false,
                            })
                        };
                        (
                            read("denoise readback", bytes),
                            read("denoise counters readback", 8),
                        )
                    })?;
                s.staged = Some(Staged {
                    samples,
                    guides,
                    readback,
                    counters_readback,
                });
            }
            s.staged.take().expect("made above")
        };
        let result = self.run_staged(&staged, samples, guides, grids, params, t_start);
        if let Some(s) = self.sized.as_mut() {
            s.staged = Some(staged);
        }
        result
    }

    fn run_staged(
        &mut self,
        staged: &Staged,
        samples: &mut SampleBuffers,
        guides: &DenoiseGuides,
        grids: &[Grid],
        params: &DenoiseParams,
        t_start: Instant,
    ) -> Result<(DenoiseStats, DenoiseTimes)> {
        let ctx = self.ctx.clone();
        let texels = staged.samples.texels();
        let what = format!("denoising {texels} samples");
        staged.samples.upload(&ctx, samples)?;
        staged.guides.upload(&ctx, guides)?;
        let bytes = texels * crate::samples::TEXEL_BYTES;
        let recorded = ctx.scoped(&what, || -> Result<()> {
            let mut encoder =
                ctx.device()
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("denoise"),
                    });
            self.record(&mut encoder, &staged.samples, &staged.guides, grids, params)?;
            let counters = &self.sized.as_ref().expect("recorded").counters;
            encoder.copy_buffer_to_buffer(staged.samples.buffer(), 0, &staged.readback, 0, bytes);
            encoder.copy_buffer_to_buffer(counters, 0, &staged.counters_readback, 0, 8);
            ctx.submit([encoder.finish()]);
            Ok(())
        })?;
        recorded?;
        let upload_ms = ms_since(t_start);
        let t_run = Instant::now();
        let mut stats = DenoiseStats::default();
        let mut short = None;
        read_buffers(
            &ctx,
            &[&staged.readback, &staged.counters_readback],
            &what,
            |k, data| {
                if k == 1 {
                    let c: &[u32] = bytemuck::cast_slice(data);
                    stats.filtered = u64::from(c[0]);
                    stats.clamped = u64::from(c[1]);
                    return;
                }
                let texels: &[[f32; 4]] = bytemuck::cast_slice(data);
                let mut at = 0usize;
                for color in samples.color.iter_mut() {
                    let n = color.data().len();
                    let Some(src) = texels.get(at..at + n) else {
                        short = Some(data.len());
                        return;
                    };
                    for (c, t) in color.data_mut().iter_mut().zip(src) {
                        *c = [t[0], t[1], t[2]];
                    }
                    at += n;
                }
            },
        )?;
        if let Some(got) = short {
            return Err(GpuError::Validation {
                what,
                message: format!("read back {got} bytes, expected {bytes}"),
            });
        }
        let run_and_readback_ms = ms_since(t_run);
        Ok((
            stats,
            DenoiseTimes {
                upload_ms,
                run_and_readback_ms,
                total_ms: ms_since(t_start),
            },
        ))
    }

    /// Working buffers and the bind groups that name only them, for `layers`; kept while the
    /// layers stay the same.
    fn fit(&mut self, layers: &[SampleLayer], texels: u64) -> Result<()> {
        let columns_needed: u64 = layers
            .iter()
            .map(|l| u64::from(l.width))
            .sum::<u64>()
            .max(1);
        if let Some(s) = self.sized.as_mut() {
            if s.layers == layers && s.texels == texels {
                return Ok(());
            }
            if texels <= s.capacity && columns_needed <= s.column_capacity {
                // Other layers within the room: the same buffers and bind groups; the column
                // table and the staged path's copies are the old layers'.
                s.layers = layers.to_vec();
                s.texels = texels;
                s.columns_for = None;
                s.staged = None;
                return Ok(());
            }
        }
        self.sized = None;
        let ctx = &self.ctx;
        let capacity = texels.max(self.reserve.0);
        let work = capacity.max(1) * TEXEL_BYTES;
        ctx.check_storage_binding("the denoiser's working buffers", work)?;
        let columns_len = columns_needed.max(self.reserve.1);
        ctx.check_storage_binding("the denoiser's polar column table", columns_len * 8)?;
        let align = u64::from(ctx.limits().min_uniform_buffer_offset_alignment).max(1);
        let uniform_stride = (std::mem::size_of::<DenoiseUniform>() as u64).div_ceil(align) * align;
        let sized = ctx.scoped("allocating the denoiser's buffers", || {
            let storage = |label, size| {
                ctx.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_DST
                        | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            };
            let uniform = ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("denoise parameters"),
                size: uniform_stride * MAX_ITERATIONS as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let geom = storage("denoise normal and depth", work);
            let aux = storage("denoise gradient and role", work);
            let light = [
                storage("denoise light ping", work),
                storage("denoise light pong", work),
            ];
            let columns = storage("denoise polar columns", columns_len * 8);
            let counters = storage("denoise counters", 16);
            let work_list = storage("denoise listed texels", capacity.max(1) * 4);
            let slot = |it: u64| {
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &uniform,
                    offset: uniform_stride * it,
                    size: wgpu::BufferSize::new(std::mem::size_of::<DenoiseUniform>() as u64),
                })
            };
            fn whole(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
                b.as_entire_binding()
            }
            let group = |pipeline: &wgpu::ComputePipeline,
                         entries: Vec<(u32, wgpu::BindingResource<'_>)>| {
                let entries: Vec<wgpu::BindGroupEntry> = entries
                    .into_iter()
                    .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
                    .collect();
                ctx.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("denoise bindings"),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &entries,
                })
            };
            let variance = group(
                &self.variance,
                vec![
                    (0, slot(0)),
                    (3, whole(&geom)),
                    (4, whole(&aux)),
                    (5, whole(&light[0])),
                    (6, whole(&light[1])),
                    (7, whole(&columns)),
                    (8, whole(&counters)),
                    (11, whole(&work_list)),
                ],
            );
            let atrous = (0..MAX_ITERATIONS as usize)
                .map(|it| {
                    group(
                        if it == 0 {
                            &self.atrous_first
                        } else {
                            &self.atrous
                        },
                        vec![
                            (0, slot(it as u64)),
                            (3, whole(&geom)),
                            (4, whole(&aux)),
                            (5, whole(&light[1 - it % 2])),
                            (6, whole(&light[it % 2])),
                            (7, whole(&columns)),
                            (8, whole(&counters)),
                            (11, whole(&work_list)),
                        ],
                    )
                })
                .collect();
            Sized {
                layers: layers.to_vec(),
                texels,
                capacity,
                column_capacity: columns_len,
                uniform_bytes: Vec::new(),
                uniform,
                uniform_stride,
                light,
                columns,
                counters,
                variance,
                atrous,
                columns_for: None,
                bound: None,
                staged: None,
                _geom: geom,
                _aux: aux,
                work_list,
            }
        })?;
        self.sized = Some(sized);
        Ok(())
    }

    /// The bind groups naming the caller's `samples` and `guides`, made when they are not the
    /// last call's.
    fn bind(&mut self, samples: &wgpu::Buffer, guides: &DeviceGuides) -> Result<()> {
        let ctx = &self.ctx;
        let s = self.sized.as_mut().expect("fit runs before bind");
        let g = [guides.albedo(), guides.normal(), guides.noisy()];
        if s.bound
            .as_ref()
            .is_some_and(|b| &b.samples == samples && b.guides.iter().eq(g))
        {
            return Ok(());
        }
        let (prepare_pipeline, finish_pipeline) = (&self.prepare, &self.finish);
        let slot0 = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &s.uniform,
            offset: 0,
            size: wgpu::BufferSize::new(std::mem::size_of::<DenoiseUniform>() as u64),
        });
        let bound = ctx.scoped("binding the denoiser's buffers", || {
            let make = |pipeline: &wgpu::ComputePipeline,
                        entries: Vec<(u32, wgpu::BindingResource<'_>)>| {
                let entries: Vec<wgpu::BindGroupEntry> = entries
                    .into_iter()
                    .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
                    .collect();
                ctx.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("denoise bindings"),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &entries,
                })
            };
            let prepare = make(
                prepare_pipeline,
                vec![
                    (0, slot0.clone()),
                    (1, samples.as_entire_binding()),
                    (2, g[0].as_entire_binding()),
                    (3, s._geom.as_entire_binding()),
                    (4, s._aux.as_entire_binding()),
                    (6, s.light[0].as_entire_binding()),
                    (7, s.columns.as_entire_binding()),
                    (8, s.counters.as_entire_binding()),
                    (9, g[1].as_entire_binding()),
                    (10, g[2].as_entire_binding()),
                    (11, s.work_list.as_entire_binding()),
                ],
            );
            let finish = [0, 1].map(|src| {
                make(
                    finish_pipeline,
                    vec![
                        (0, slot0.clone()),
                        (1, samples.as_entire_binding()),
                        (2, g[0].as_entire_binding()),
                        (4, s._aux.as_entire_binding()),
                        (5, s.light[src].as_entire_binding()),
                        (8, s.counters.as_entire_binding()),
                        (10, g[2].as_entire_binding()),
                        (11, s.work_list.as_entire_binding()),
                    ],
                )
            });
            Bound {
                samples: samples.clone(),
                guides: g.map(Clone::clone),
                prepare,
                finish,
            }
        })?;
        s.bound = Some(bound);
        Ok(())
    }
}

/// Per layer the index of its first column in the polar table (`None`: a rectangle) and the
/// table's length; checks each grid against its layer.
fn column_table(layers: &[SampleLayer], grids: &[Grid]) -> Result<(Vec<Option<usize>>, usize)> {
    let mut base = Vec::with_capacity(layers.len());
    let mut at = 0usize;
    for (l, (layer, grid)) in layers.iter().zip(grids).enumerate() {
        let (w, h) = (layer.width, layer.height);
        match grid {
            Grid::Rect { width, height } => {
                if (*width, *height) != (w, h) {
                    return Err(GpuError::Input(format!(
                        "denoiser grid {l} is {width}x{height}, its sample layer {w}x{h}"
                    )));
                }
                base.push(None);
            }
            Grid::Polar { rows, period } => {
                if rows.len() > w as usize || period.len() != rows.len() {
                    return Err(GpuError::Input(format!(
                        "a polar denoiser grid of {} columns ({} periods) for a sample layer \
                         {w} texels wide",
                        rows.len(),
                        period.len()
                    )));
                }
                if let Some((i, &r)) = rows.iter().enumerate().find(|(_, &r)| r > h) {
                    return Err(GpuError::Input(format!(
                        "polar column {i} has {r} rows, the sample layer {h}"
                    )));
                }
                base.push(Some(at));
            }
        }
        at += w as usize;
    }
    Ok((base, at))
}

/// Whether two lists of grids are the same topology.
fn grids_equal(a: &[Grid], b: &[Grid]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| match (x, y) {
            (
                Grid::Rect {
                    width: w0,
                    height: h0,
                },
                Grid::Rect {
                    width: w1,
                    height: h1,
                },
            ) => (w0, h0) == (w1, h1),
            (
                Grid::Polar {
                    rows: r0,
                    period: p0,
                },
                Grid::Polar {
                    rows: r1,
                    period: p1,
                },
            ) => r0 == r1 && p0 == p1,
            _ => false,
        })
}

/// Workgroups (x, y) covering `texels` invocations of [`WORKGROUP_SIZE`], read as one linear
/// index; `None` past the device's dispatch limits.
fn dispatch_size(ctx: &GpuContext, texels: u64) -> Option<(u32, u32)> {
    let max = u64::from(ctx.limits().max_compute_workgroups_per_dimension);
    let groups = texels.div_ceil(u64::from(WORKGROUP_SIZE)).max(1);
    let x = groups.min(max);
    let y = groups.div_ceil(x);
    (y <= max).then_some((x as u32, y as u32))
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
