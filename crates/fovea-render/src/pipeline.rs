//! One foveated frame, end to end (DESIGN.md "How a frame flows", VaFR Sec. 3.4 and 6):
//!
//! 1. **plan**: build the method's mapping for the display and gaze;
//! 2. **trace**: for every shaded buffer pixel, its centre goes through the inverse mapping to
//!    a screen point, which gets one primary ray (so an LP method casts exactly
//!    `sample_count()` rays); the closest hit becomes a G-buffer record;
//! 3. **shade**: direct light with shadow rays (or path tracing) per record;
//! 4. **aa**: sample-space anti-aliasing — FXAA in the LP buffer (VaFR, visual-polar),
//!    the 3×3 Gaussian (KFR, LaFR), none for the others unless asked;
//! 5. **reconstruct**: the inverse mapping to screen pixels with filtered lookups
//!    (`fovea_post::inverse_map`);
//! 6. optionally **contrast**: peripheral contrast enhancement (`fovea_post::contrast`), then
//!    **dof**: the depth-of-field filter.
//!
//! In a sequence, [`render_frame_temporal`] jitters the samples in sample space, folds the
//! previous frame into the fresh samples between shade and AA, and keeps this frame for the
//! next (`crate::temporal`).
//!
//! Full resolution runs through the same code with the identity mapping: every pixel is a
//! sample, no AA, the buffer is the screen. Trace and shade run chunk by chunk (about
//! 2¹⁸ samples), so G-buffer memory stays bounded at any resolution; per-stage wall times are
//! summed over chunks.
//!
//! **Sample footprint.** Each sample's ray cone angle is its sample spacing: one pixel
//! (`1/f_y` rad) at full resolution; otherwise `1/(2√(ρ_r ρ_t))` degrees from the mapping's
//! radial and tangential shading rates (cycles per degree) at the sample's eccentricity.

use std::collections::BTreeMap;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::{
    build, BufferSize, FoveationMapping, MappingConfig, Method, SamplePoint,
};
use fovea_core::Image;
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::{reconstruct, SampleBuffers};
use fovea_post::Rgb;

use crate::camera::EyeCamera;
use crate::cull_fill::{fill_culled, shade_or_cull, CullBuffers, SampleCull};
use crate::dof::{apply_dof, auto_focus_m, Culling, DofSettings, FocusMode};
use crate::error::{RenderError, Result};
use crate::shade::{shade, RayCounts, ShadingMode};
use crate::temporal::{SpacingLut, TemporalAccumulator, TemporalStats};
use crate::trace::{trace_sample, GSample};
use crate::world::World;
use fovea_post::contrast::{enhance, PeripheralContrast};

/// Samples per trace/shade chunk.
const CHUNK_SAMPLES: usize = 1 << 18;

/// Sample-space anti-aliasing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AaMode {
    /// The method's own: FXAA for VaFR and visual-polar, Gaussian for KFR and LaFR, none
    /// otherwise.
    Auto,
    /// No anti-aliasing.
    None,
    /// FXAA in sample space.
    Fxaa,
    /// 3×3 Gaussian in sample space.
    Gaussian,
}

impl AaMode {
    /// Parses `auto`, `none`, `fxaa`, `gaussian`.
    pub fn parse(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(AaMode::Auto),
            "none" | "off" => Ok(AaMode::None),
            "fxaa" => Ok(AaMode::Fxaa),
            "gaussian" | "gauss" => Ok(AaMode::Gaussian),
            _ => Err(RenderError::invalid(
                "aa",
                s,
                "auto, none, fxaa or gaussian",
            )),
        }
    }

    /// What `Auto` means for `method`.
    pub fn resolve(self, method: Method) -> AaMode {
        match (self, method) {
            (AaMode::Auto, Method::Vafr | Method::VisualPolar) => AaMode::Fxaa,
            (AaMode::Auto, Method::Kfr | Method::Lafr) => AaMode::Gaussian,
            (AaMode::Auto, _) => AaMode::None,
            (m, _) => m,
        }
    }
}

/// Everything that decides a frame besides the scene and camera.
#[derive(Clone, Debug)]
pub struct FrameSettings {
    /// Foveation method.
    pub method: Method,
    /// Parameters of every method.
    pub mapping: MappingConfig,
    /// Gaze point.
    pub gaze: Gaze,
    /// Shading.
    pub shading: ShadingMode,
    /// Sample-space anti-aliasing.
    pub aa: AaMode,
    /// Also produce the sample-density view.
    pub density_view: bool,
    /// Refuse frames whose buffers would need more than this many bytes.
    pub memory_limit_bytes: u64,
    /// Depth of field: focus, DOF-aware culling and the screen-space filter (`None`: sharp).
    pub dof: Option<DofSettings>,
    /// Peripheral contrast enhancement after reconstruction (`None`: off).
    pub contrast: Option<PeripheralContrast>,
    /// Keep the shaded sample buffers (before AA) in [`Frame::samples`].
    pub keep_samples: bool,
}

impl FrameSettings {
    /// Defaults: direct shading, the method's own AA, a memory limit from
    /// [`default_memory_limit`].
    pub fn new(method: Method, gaze: Gaze) -> Self {
        Self {
            method,
            mapping: MappingConfig::default(),
            gaze,
            shading: ShadingMode::Direct,
            aa: AaMode::Auto,
            density_view: false,
            memory_limit_bytes: default_memory_limit(),
            dof: None,
            contrast: None,
            keep_samples: false,
        }
    }
}

/// 80 % of the memory the OS reports available (`MemAvailable`), or 16 GiB where unknown.
pub fn default_memory_limit() -> u64 {
    let avail = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
    });
    avail.map_or(16 << 30, |kb| kb * 1024 / 10 * 8)
}

/// Per-frame statistics, as `fovea render` prints and writes to JSON.
#[derive(Clone, Debug, Serialize)]
pub struct FrameStats {
    /// Method name.
    pub method: String,
    /// Display width, pixels.
    pub width: u32,
    /// Display height, pixels.
    pub height: u32,
    /// Samples the mapping shades (`sample_count()`); buffer pixels whose centre maps off the
    /// screen (corners of layered and kernel mappings) get no ray, so `rays_primary` may be
    /// slightly lower.
    pub samples: u64,
    /// Primary rays.
    pub rays_primary: u64,
    /// Shadow rays.
    pub rays_shadow: u64,
    /// Bounce rays (path-traced mode).
    pub rays_bounce: u64,
    /// All rays.
    pub rays: u64,
    /// Wall time per stage, milliseconds: plan, trace, shade, aa, reconstruct.
    pub stages_ms: BTreeMap<String, f64>,
    /// Total wall time, milliseconds.
    pub total_ms: f64,
    /// Processor time per stage, milliseconds, summed over threads (`CLOCK_PROCESS_CPUTIME_ID`;
    /// unlike wall time, it leaves out time the machine's hypervisor gave to other guests).
    pub stages_cpu_ms: BTreeMap<String, f64>,
    /// Total processor time, milliseconds, summed over threads.
    pub total_cpu_ms: f64,
    /// Sample buffers (width × height per layer).
    pub buffers: Vec<[u32; 2]>,
    /// Anti-aliasing used.
    pub aa: AaMode,
    /// Estimated peak memory of the frame's buffers, bytes.
    pub memory_bytes: u64,
    /// Focus distance used for depth of field, metres (`null` without DOF; JSON has no ∞, so
    /// focus at infinity is written as 1e308).
    pub focus_m: Option<f64>,
    /// Samples that hit a surface and were shaded.
    pub samples_shaded: u64,
    /// Samples that hit a surface and were culled by the DOF roulette (Liu Eq. 11).
    pub samples_culled: u64,
    /// The DOF filter applied, if any.
    pub dof_filter: Option<String>,
    /// Temporal accumulation of this frame (in a sequence with accumulation on).
    pub temporal: Option<TemporalStats>,
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Linear RGB at display resolution.
    pub color: Image<Rgb>,
    /// Depth along the view axis, metres (∞ where nothing was hit).
    pub depth: Image<f32>,
    /// Samples per screen pixel predicted by the mapping's shading rates (when asked).
    pub density: Option<Image<f32>>,
    /// Signed circle of confusion per pixel (with depth of field), pixels.
    pub coc: Option<Image<f32>>,
    /// Counts and timings.
    pub stats: FrameStats,
    /// The shaded sample buffers before AA (when [`FrameSettings::keep_samples`]).
    pub samples: Option<SampleBuffers>,
}

/// Sample values known before tracing (e.g. warped from the other eye): texels whose `known`
/// flag is set get no ray and keep `color` and `depth`.
#[derive(Clone, Debug)]
pub struct Prefill {
    /// Colour per layer, the mapping's buffer sizes.
    pub color: Vec<Image<Rgb>>,
    /// Depth per layer.
    pub depth: Vec<Image<f32>>,
    /// Which texels are known.
    pub known: Vec<Image<bool>>,
}

/// Bytes a frame of `mapping` on `display` needs at its peak: sample buffers (colour + depth,
/// twice during AA), the screen image and depth, the density view, and one chunk of G-buffer.
pub fn memory_estimate(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    density: bool,
) -> u64 {
    let screen = display.pixel_count();
    let buf: u64 = mapping.buffers().iter().map(|b| b.pixels()).sum();
    let per_px = (std::mem::size_of::<Rgb>() + 4) as u64;
    let gbuf = (CHUNK_SAMPLES * (std::mem::size_of::<GSample>() + 16)) as u64;
    let samples = if mapping.method() == Method::Full {
        screen * per_px
    } else {
        2 * buf * per_px + screen * per_px
    };
    samples + if density { screen * 4 } else { 0 } + gbuf
}

/// Whether `images` are one per buffer of `sizes`, each of its size.
fn sizes_match<T>(images: &[Image<T>], sizes: &[BufferSize]) -> bool {
    images.len() == sizes.len()
        && images
            .iter()
            .zip(sizes)
            .all(|(i, b)| i.width() == b.width && i.height() == b.height)
}

/// Side of the square tiles in which samples are traced and shaded.
const TRACE_TILE: usize = 16;

/// Indices `j·width + i` of a `width × height` block, tile by tile
/// ([`TRACE_TILE`]² pixels, row-major inside a tile and across tiles).
fn tile_order(width: usize, height: usize) -> Vec<u32> {
    let mut order = Vec::with_capacity(width * height);
    for tj in (0..height).step_by(TRACE_TILE) {
        for ti in (0..width).step_by(TRACE_TILE) {
            for j in tj..(tj + TRACE_TILE).min(height) {
                for i in ti..(ti + TRACE_TILE).min(width) {
                    order.push((j * width + i) as u32);
                }
            }
        }
    }
    order
}

/// Wall and process CPU time since a start.
struct Stopwatch {
    wall: Instant,
    cpu: Option<cpu_time::ProcessTime>,
}

impl Stopwatch {
    fn start() -> Self {
        Self {
            wall: Instant::now(),
            cpu: cpu_time::ProcessTime::try_now().ok(),
        }
    }

    /// (wall, CPU) milliseconds elapsed; CPU is NaN where the clock is unavailable.
    fn elapsed_ms(&self) -> (f64, f64) {
        let wall = self.wall.elapsed().as_secs_f64() * 1e3;
        let cpu = self
            .cpu
            .and_then(|c| c.try_elapsed().ok())
            .map_or(f64::NAN, |d| d.as_secs_f64() * 1e3);
        (wall, cpu)
    }
}

/// Wall and CPU milliseconds per stage, summed over the times a stage runs (trace and shade
/// run once per chunk).
#[derive(Default)]
struct StageTimes {
    wall: BTreeMap<String, f64>,
    cpu: BTreeMap<String, f64>,
}

impl StageTimes {
    /// Adds the time since `since` to `stage`.
    fn add(&mut self, stage: &str, since: &Stopwatch) {
        let (w, c) = since.elapsed_ms();
        *self.wall.entry(stage.to_string()).or_default() += w;
        *self.cpu.entry(stage.to_string()).or_default() += c;
    }
}

/// Renders one frame. `progress(done, total)` is called after each chunk of samples.
pub fn render_frame(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    render(world, camera, settings, None, None, progress)
}

/// Renders a frame whose `prefill.known` texels are already shaded: only the others get rays
/// (binocular reprojection traces just the holes). `prefill` must match the mapping's buffers.
pub fn render_frame_prefilled(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    prefill: &Prefill,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    render(world, camera, settings, None, Some(prefill), progress)
}

/// Renders the next frame of a sequence with temporal accumulation: samples jittered in
/// sample space, the previous frame (kept in `accumulator`) reprojected and folded into the
/// fresh samples before AA, and this frame kept for the next.
pub fn render_frame_temporal(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    accumulator: &mut TemporalAccumulator,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    render(world, camera, settings, Some(accumulator), None, progress)
}

fn render(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    mut accumulator: Option<&mut TemporalAccumulator>,
    prefill: Option<&Prefill>,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame> {
    if let Some(c) = &settings.contrast {
        c.validate()?;
    }
    let t_total = Stopwatch::start();
    let display = &camera.display;
    let mut times = StageTimes::default();

    // 1. Plan.
    let t = Stopwatch::start();
    let mapping = build(settings.method, display, settings.gaze, &settings.mapping)?;
    let mut memory = memory_estimate(mapping.as_ref(), display, settings.density_view);
    if settings.dof.is_some() {
        // CoC map and the filtered image.
        memory += display.pixel_count() * (4 + std::mem::size_of::<Rgb>() as u64);
    }
    if memory > settings.memory_limit_bytes {
        return Err(RenderError::ResourceLimit {
            what: format!(
                "a {} frame at {}x{}",
                settings.method, display.width_px, display.height_px
            ),
            needed: format!("{:.2} GiB", memory as f64 / (1u64 << 30) as f64),
            limit: format!(
                "{:.2} GiB (set with --max-memory)",
                settings.memory_limit_bytes as f64 / (1u64 << 30) as f64
            ),
        });
    }
    let sizes = mapping.buffers();
    if let Some(p) = prefill {
        if !(sizes_match(&p.color, &sizes)
            && sizes_match(&p.depth, &sizes)
            && sizes_match(&p.known, &sizes))
        {
            return Err(RenderError::invalid(
                "prefill",
                format!("{} layers", p.color.len()),
                format!("buffers of the mapping's sizes {sizes:?}"),
            ));
        }
    }
    let aa = settings.aa.resolve(settings.method);
    let jitter = accumulator
        .as_ref()
        .map_or([0.0, 0.0], |a| a.jitter(settings.method));
    // Eye state: the focus (auto focus casts a small depth patch around the gaze) and, for
    // DOF-aware culling, the DOF limits and the scene's depth range.
    let focus_m = match &settings.dof {
        Some(d) => Some(match d.focus {
            FocusMode::Fixed(f) => f,
            FocusMode::Auto => auto_focus_m(world, camera, &settings.gaze)?,
        }),
        None => None,
    };
    let cull = match (&settings.dof, focus_m) {
        (Some(d), Some(f)) if d.cull => Some(Culling::new(d, camera, world, f)?),
        _ => None,
    };
    times.add("plan", &t);

    // 2–3. Trace and shade, layer by layer, chunk by chunk.
    let total_samples = mapping.sample_count();
    let mut primary = 0u64;
    let mut counts = RayCounts::default();
    let (mut n_shaded, mut n_culled) = (0u64, 0u64);
    let mut colors = Vec::with_capacity(sizes.len());
    let mut depths = Vec::with_capacity(sizes.len());
    let full = settings.method == Method::Full;
    let pixel_spread = (1.0 / display.focal_y_px()) as f32;
    // A polar buffer's column lies at one distance from the gaze, so at one eccentricity
    // (VaFR Eq. 3): its samples share one footprint, computed once per column.
    let column_spread: Option<Vec<f32>> = match (full, mapping.polar_layout()) {
        (false, Some(layout)) => Some(
            (0..layout.rows.len())
                .into_par_iter()
                .map(|i| {
                    let s = SamplePoint {
                        layer: 0,
                        u: i as f64 + 0.5,
                        v: 0.5,
                    };
                    mapping.inverse(s).map_or(f32::NAN, |p| {
                        sample_spread_rad(mapping.as_ref(), display, &settings.gaze, p)
                    })
                })
                .collect(),
        ),
        _ => None,
    };
    for (layer, size) in sizes.iter().enumerate() {
        let layer = layer as u32;
        let (bw, bh) = (size.width, size.height);
        let known = prefill.map(|p| &p.known[layer as usize]);
        let (mut color, mut depth) = match prefill {
            Some(p) => (
                p.color[layer as usize].clone(),
                p.depth[layer as usize].clone(),
            ),
            None => (
                Image::new(bw, bh, [0.0f32; 3])?,
                Image::new(bw, bh, f32::INFINITY)?,
            ),
        };
        // When culling: per buffer pixel, whether it is a shaded surface (1), a culled one
        // (2) or neither (0), and its reconstruction basis (`shade::culled_basis`).
        let mut cull_state = match cull {
            Some(_) => Some(CullBuffers::new(bw, bh)?),
            None => None,
        };
        let rows_per_chunk = (CHUNK_SAMPLES / bw as usize).max(1);
        let row_len = bw as usize;
        // Samples in tiles of TRACE_TILE × TRACE_TILE buffer pixels, so that consecutive
        // rays of a thread meet the same BVH nodes, triangles and texels.
        let chunk_order = tile_order(row_len, rows_per_chunk);
        for (chunk_idx, (c_chunk, d_chunk)) in color
            .data_mut()
            .chunks_mut(rows_per_chunk * row_len)
            .zip(depth.data_mut().chunks_mut(rows_per_chunk * row_len))
            .enumerate()
        {
            let j0 = (chunk_idx * rows_per_chunk) as u32;
            let rows = c_chunk.len() / row_len;
            let last_order;
            let order = if rows == rows_per_chunk {
                &chunk_order
            } else {
                last_order = tile_order(row_len, rows);
                &last_order
            };
            // Trace: one G-buffer record per shaded pixel of the chunk.
            let t = Stopwatch::start();
            let gbuf: Vec<Option<GSample>> = order
                .par_iter()
                .map(|&k| {
                    let k = k as usize;
                    let (i, j) = ((k % row_len) as u32, j0 + (k / row_len) as u32);
                    if !mapping.is_shaded(layer, i, j) || known.is_some_and(|m| *m.get(i, j)) {
                        return None;
                    }
                    let s = SamplePoint {
                        layer,
                        u: i as f64 + 0.5 + jitter[0],
                        v: j as f64 + 0.5 + jitter[1],
                    };
                    let p = mapping.inverse(s)?;
                    let column = column_spread.as_ref().and_then(|cs| cs.get(i as usize));
                    let spread = match column {
                        _ if full => pixel_spread,
                        Some(&s) if s.is_finite() => s,
                        _ => sample_spread_rad(mapping.as_ref(), display, &settings.gaze, p),
                    };
                    Some(trace_sample(world, &camera.ray(p), spread))
                })
                .collect();
            times.add("trace", &t);
            primary += gbuf.iter().filter(|g| g.is_some()).count() as u64;

            // Shade (unless the DOF roulette culls the sample), in the same order, then
            // scatter to the buffer.
            let t = Stopwatch::start();
            type Shaded = (Option<Rgb>, f32, Option<SampleCull>, RayCounts);
            let shaded: Vec<Option<Shaded>> = order
                .par_iter()
                .zip(gbuf.par_iter())
                .map(|(&k, g)| {
                    let g = g.as_ref()?;
                    let mut rc = RayCounts::default();
                    let key = ((layer as u64) << 48) ^ ((j0 as u64 * row_len as u64) + k as u64);
                    let depth = camera.view_depth(-g.to_eye, g.t);
                    if let Some(culling) = &cull {
                        let (i, j) = (k % row_len as u32, j0 + k / row_len as u32);
                        let keep = culling.keep(depth, i, j, key);
                        let (v, info) =
                            shade_or_cull(world, g, settings.shading, keep, key, &mut rc);
                        return Some((v.map(|v| v.to_array()), depth, Some(info), rc));
                    }
                    let v = shade(world, g, settings.shading, key, &mut rc);
                    Some((Some(v.to_array()), depth, None, rc))
                })
                .collect();
            let mut chunk_counts = RayCounts::default();
            let chunk_start = j0 as usize * row_len;
            for (&k, s) in order.iter().zip(shaded) {
                if let Some((c, d, info, rc)) = s {
                    d_chunk[k as usize] = d;
                    chunk_counts += rc;
                    let at = chunk_start + k as usize;
                    let state = match c {
                        Some(c) => {
                            c_chunk[k as usize] = c;
                            if d.is_finite() {
                                n_shaded += 1;
                                1
                            } else {
                                0
                            }
                        }
                        None => {
                            n_culled += 1;
                            2
                        }
                    };
                    if let (Some(cb), Some(info)) = (cull_state.as_mut(), info) {
                        cb.record(at, state, info);
                    }
                }
            }
            counts += chunk_counts;
            times.add("shade", &t);
            progress(primary.min(total_samples), total_samples);
        }
        // Culled samples get their colour from the shaded ones before any filtering.
        if let Some(cb) = cull_state.filter(|cb| cb.state.data().contains(&2)) {
            let t = Stopwatch::start();
            color = fill_culled(&color, &depth, &cb)?;
            times.add("cull-fill", &t);
        }
        colors.push(color);
        depths.push(depth);
    }

    // The mapping's sample spacing by eccentricity, for accumulation and contrast.
    let spacing = if accumulator.is_some() || settings.contrast.is_some() {
        Some(SpacingLut::new(mapping.as_ref(), display, settings.gaze)?)
    } else {
        None
    };

    // Temporal accumulation: the previous frame folded into the fresh samples.
    let mut temporal = None;
    if let (Some(acc), Some(lut)) = (accumulator.as_deref_mut(), &spacing) {
        let t = Stopwatch::start();
        let mut buffers = SampleBuffers {
            color: colors,
            depth: depths,
        };
        temporal = Some(acc.accumulate(
            mapping.as_ref(),
            settings,
            camera,
            &mut buffers,
            jitter,
            lut,
        )?);
        colors = buffers.color;
        depths = buffers.depth;
        times.add("temporal", &t);
    }

    let samples = settings.keep_samples.then(|| SampleBuffers {
        color: colors.clone(),
        depth: depths.clone(),
    });

    // 4. Sample-space anti-aliasing.
    let t = Stopwatch::start();
    if aa != AaMode::None {
        let polar = mapping.polar_layout();
        for c in colors.iter_mut() {
            let grid = match &polar {
                Some(l) => Grid::polar(l),
                None => Grid::Rect {
                    width: c.width(),
                    height: c.height(),
                },
            };
            *c = match aa {
                AaMode::Fxaa => fxaa(c, &grid, &FxaaParams::default()),
                AaMode::Gaussian => gaussian_3x3(c, &grid),
                AaMode::None | AaMode::Auto => unreachable!("resolved above"),
            };
        }
    }
    times.add("aa", &t);

    // 5. Reconstruct.
    let t = Stopwatch::start();
    let screen = reconstruct(
        mapping.as_ref(),
        display,
        SampleBuffers {
            color: colors,
            depth: depths,
        },
    )?;
    times.add("reconstruct", &t);
    if let Some(acc) = accumulator {
        let t = Stopwatch::start();
        acc.finish(mapping.as_ref(), camera, &screen)?;
        times.add("temporal", &t);
    }
    let screen = match (&settings.contrast, &spacing) {
        (Some(c), Some(lut)) => {
            let t = Stopwatch::start();
            let gaze = settings.gaze;
            let ecc = |x: u32, y: u32| {
                let p = fovea_core::units::ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                display.eccentricity(p, &gaze).0 as f32
            };
            let color = enhance(&screen.color, c, &ecc, &|e| lut.at(e as f64))?;
            times.add("contrast", &t);
            fovea_post::inverse_map::ScreenFrame {
                color,
                depth: screen.depth,
            }
        }
        _ => screen,
    };

    // 6. Depth of field in screen space.
    let (color, coc) = match (&settings.dof, focus_m) {
        (Some(d), Some(f)) => {
            let t = Stopwatch::start();
            let gaze = [
                settings.gaze.point.x_px as f32,
                settings.gaze.point.y_px as f32,
            ];
            let r = apply_dof(d, camera, &screen.color, &screen.depth, f, gaze)?;
            times.add("dof", &t);
            (r.color, Some(r.coc_px))
        }
        _ => (screen.color, None),
    };

    let density = if settings.density_view {
        Some(density_view(mapping.as_ref(), display, &settings.gaze)?)
    } else {
        None
    };
    let (total_ms, total_cpu_ms) = t_total.elapsed_ms();
    let stats = FrameStats {
        method: settings.method.name().to_string(),
        width: display.width_px,
        height: display.height_px,
        samples: total_samples,
        rays_primary: primary,
        rays_shadow: counts.shadow,
        rays_bounce: counts.bounce,
        rays: primary + counts.shadow + counts.bounce,
        stages_ms: times.wall,
        total_ms,
        stages_cpu_ms: times.cpu,
        total_cpu_ms,
        buffers: sizes.iter().map(|b| [b.width, b.height]).collect(),
        aa,
        memory_bytes: memory,
        focus_m: focus_m.map(|f| f.min(1e308)),
        samples_shaded: n_shaded,
        samples_culled: n_culled,
        dof_filter: settings
            .dof
            .as_ref()
            .and_then(|d| d.filter.map(|k| k.name().to_string())),
        temporal,
    };
    Ok(Frame {
        color,
        depth: screen.depth,
        density,
        coc,
        stats,
        samples,
    })
}

/// Angle a sample of `mapping` spans at screen point `p`: its spacing `1/(2√(ρ_r ρ_t))`
/// degrees from the shading rates, at least one screen pixel (the full-resolution ray's
/// footprint, `1/f_px` rad) and at most 10°. The lower bound matters where a mapping samples
/// more densely than the screen (VaFR near the gaze on low-resolution displays): detail finer
/// than a pixel would be resampled onto the pixel grid by the inverse mapping and alias into
/// moiré, so textures are filtered to the screen's Nyquist rate there, as in the full frame.
pub fn sample_spread_rad(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
    p: fovea_core::units::ScreenPoint,
) -> f32 {
    let e = display.eccentricity(p, gaze).0;
    let rr = mapping.radial_rate_cpd(e);
    let rt = mapping.tangential_rate_cpd(e);
    let rate = (rr.max(0.0) * rt.max(0.0)).sqrt();
    let spacing_deg = if rate.is_finite() && rate > 0.0 {
        0.5 / rate
    } else if rr.is_finite() && rr > 0.0 {
        0.5 / rr
    } else {
        0.0
    };
    let pixel_rad = 1.0 / display.focal_y_px();
    spacing_deg
        .to_radians()
        .clamp(pixel_rad, 10f64.to_radians()) as f32
}

/// Samples per screen pixel predicted by the mapping's rates: `ρ_r ρ_t / (ppd(e)/2)²`.
pub fn density_view(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    gaze: &Gaze,
) -> Result<Image<f32>> {
    let (w, h) = (display.width_px, display.height_px);
    let mut img = Image::new(w, h, 0.0f32)?;
    img.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, v) in row.iter_mut().enumerate() {
                let p = fovea_core::units::ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                let e = display.eccentricity(p, gaze).0;
                let screen = display.rectilinear_ppd(fovea_core::units::Degrees(e)) / 2.0;
                let rr = mapping.radial_rate_cpd(e).clamp(0.0, 1e6);
                let rt = mapping.tangential_rate_cpd(e).clamp(0.0, 1e6);
                *v = (rr * rt / (screen * screen)) as f32;
            }
        });
    Ok(img)
}
