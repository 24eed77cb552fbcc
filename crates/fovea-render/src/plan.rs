//! The frame plan (DESIGN.md "How a frame flows", stage 2): everything about a frame that is
//! decided before the first ray — the foveation mapping for this eye state, its footprint and
//! spacing tables, the resolved anti-aliasing, the DOF culling limits at the eye's focus, the
//! sample-space jitter, the tiling of the trace and the memory it will need.
//!
//! A plan is built once per eye per frame ([`FramePlan::new`]) and every stage reads it: the
//! trace, temporal accumulation, reconstruction, stereo reprojection and the screen post never
//! build a mapping of their own. What a plan derives from the display, method, parameters, ray
//! settings and gaze alone — the mapping and its tables — a [`PlanCache`] keeps for the last
//! gazes and shares ([`FramePlan::cached`]): a still gaze is planned once. It is data: [`serde::Serialize`] writes it (minus the
//! mapping's internal tables, which its method, parameters, display and gaze determine) so it
//! can be logged, diffed and handed to another executor.

use std::sync::Arc;

use serde::Serialize;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::footprint::{SampleFootprint, SpacingLut};
use fovea_core::mapping::{build, BufferSize, FoveationMapping, MappingConfig, Method, Ring};
use fovea_core::units::ScreenPoint;
use fovea_post::inverse_map::ReconstructFilter;
use fovea_post::Rgb;

use crate::camera::EyeCamera;
use crate::dof::Culling;
use crate::error::{RenderError, Result};
use crate::eye::EyeState;
use crate::settings::{AaMode, FrameSettings};
use crate::shade::FrameNoise;
use crate::trace::GSample;
use crate::world::World;

/// Samples per trace/shade chunk: G-buffer memory stays bounded at any resolution.
pub const CHUNK_SAMPLES: usize = 1 << 18;

/// Side of the square tiles in which samples are traced and shaded, so that consecutive rays
/// of a thread meet the same BVH nodes, triangles and texels.
pub const TRACE_TILE: usize = 16;

/// How the trace walks a buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct TileOrder {
    /// Tile side, buffer pixels.
    pub tile_px: usize,
    /// Samples per chunk (whole buffer rows).
    pub chunk_samples: usize,
}

impl TileOrder {
    /// Indices `j·width + i` of a `width × height` block, tile by tile (row-major across
    /// tiles), each tile in Morton (Z) order: any run of 4ⁿ consecutive texels that starts at
    /// a multiple of 4ⁿ is a square block (the trace's 64-ray packets 8×8 texels, their 8-ray
    /// groups 4×2) and every 2·4ⁿ a 2:1 block, so a batch's rays leave from nearby points. A
    /// tile cut by the block's edge keeps the order of its texels inside the block.
    pub fn order(&self, width: usize, height: usize) -> Vec<u32> {
        let t = self.tile_px.max(1);
        // Morton codes cover the smallest power-of-two square holding a tile.
        let side = t.next_power_of_two();
        let mut order = Vec::with_capacity(width * height);
        for tj in (0..height).step_by(t) {
            for ti in (0..width).step_by(t) {
                for code in 0..side * side {
                    let (di, dj) = morton_decode(code);
                    let (i, j) = (ti + di, tj + dj);
                    if di < t && dj < t && i < width && j < height {
                        order.push((j * width + i) as u32);
                    }
                }
            }
        }
        order
    }

    /// Rows of a `width`-wide buffer per chunk when each texel casts `rays_per_texel` rays
    /// (the G-buffer holds one record per ray).
    pub fn rows_per_chunk(&self, width: u32, rays_per_texel: u32) -> usize {
        (self.chunk_samples / (width.max(1) as usize * rays_per_texel.max(1) as usize)).max(1)
    }
}

/// The column and row of Morton code `code`: its even bits are the column's, its odd bits the
/// row's.
fn morton_decode(code: usize) -> (usize, usize) {
    let compact = |mut v: usize| {
        let mut out = 0;
        let mut bit = 0;
        while v != 0 {
            out |= (v & 1) << bit;
            v >>= 2;
            bit += 1;
        }
        out
    };
    (compact(code), compact(code >> 1))
}

/// One eye's frame, decided.
#[derive(Clone, Serialize)]
pub struct FramePlan {
    /// The settings the frame is rendered with.
    pub settings: FrameSettings,
    /// The eye: gaze (the mapping's centre), focus, pupil.
    pub eye: EyeState,
    /// The display.
    pub display: DisplayProfile,
    /// The method's mapping for this display and gaze, built once.
    #[serde(skip)]
    mapping: Arc<dyn FoveationMapping>,
    /// Sample buffers (one per layer).
    pub buffers: Vec<BufferSize>,
    /// Samples the mapping shades.
    pub sample_count: u64,
    /// Sample-space anti-aliasing, resolved for the method.
    pub aa: AaMode,
    /// Sub-texel jitter of every sample (temporal accumulation), buffer texels.
    pub jitter_texels: [f64; 2],
    /// The frame index and the eye, which enter every random number of the shading
    /// (`crate::shade::frame_noise`): frame 0 of eye 0 from [`FramePlan::new`]; a sequence
    /// sets its frame's ([`FramePlan::with_noise`]).
    pub noise: FrameNoise,
    /// The primary rays of every texel: how many, and where inside the texel.
    pub rays: TexelRays,
    /// Ray-cone angle of the samples.
    pub footprint: SampleFootprint,
    /// Sample spacing in pixels by eccentricity (temporal accumulation, contrast).
    pub spacing: SpacingLut,
    /// DOF-aware culling at the eye's focus (with `dof.cull`).
    pub culling: Option<Culling>,
    /// How the trace walks the buffers.
    pub tiles: TileOrder,
    /// Estimated peak memory of the frame's buffers, bytes.
    pub memory_bytes: u64,
    /// Whether every screen pixel has samples: `false` only for a polar mapping whose
    /// buffer stops short of a screen corner (a fixed maximum eccentricity, such as VaFR's
    /// paper 60°): the pixels beyond reconstruct black.
    pub covers_screen: bool,
}

impl std::fmt::Debug for FramePlan {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FramePlan")
            .field("method", &self.settings.method)
            .field("eye", &self.eye)
            .field("buffers", &self.buffers)
            .field("sample_count", &self.sample_count)
            .field("aa", &self.aa)
            .field("memory_bytes", &self.memory_bytes)
            .finish_non_exhaustive()
    }
}

impl FramePlan {
    /// The plan of a frame of `settings` seen by `camera` with `eye`, its samples jittered by
    /// `jitter_texels` (zero outside temporal accumulation). Validates the settings, builds the
    /// mapping at the eye's gaze, and refuses a frame whose buffers would exceed
    /// `settings.memory_limit_bytes`.
    pub fn new(
        world: &World,
        camera: &EyeCamera,
        settings: &FrameSettings,
        eye: &EyeState,
        jitter_texels: [f64; 2],
    ) -> Result<Self> {
        Self::build(world, camera, settings, eye, jitter_texels, None)
    }

    /// [`FramePlan::new`] with the mapping and its tables taken from `cache` where it holds
    /// them for this display, method, parameters, rays and gaze, and built and kept there
    /// otherwise ([`PlanCache`]). The plan is the one [`FramePlan::new`] builds (tested).
    pub fn cached(
        world: &World,
        camera: &EyeCamera,
        settings: &FrameSettings,
        eye: &EyeState,
        jitter_texels: [f64; 2],
        cache: &mut PlanCache,
    ) -> Result<Self> {
        Self::build(world, camera, settings, eye, jitter_texels, Some(cache))
    }

    fn build(
        world: &World,
        camera: &EyeCamera,
        settings: &FrameSettings,
        eye: &EyeState,
        jitter_texels: [f64; 2],
        cache: Option<&mut PlanCache>,
    ) -> Result<Self> {
        settings.validate()?;
        if !jitter_texels
            .iter()
            .all(|j| j.is_finite() && j.abs() <= 0.5)
        {
            return Err(RenderError::invalid(
                "jitter",
                format!("{jitter_texels:?}"),
                "sub-texel offsets in [-0.5, 0.5]",
            ));
        }
        let display = &camera.display;
        let tables = match cache {
            Some(cache) => cache.tables(display, settings, eye)?,
            None => Arc::new(GazeTables::new(display, settings, eye)?),
        };
        let mapping = Arc::clone(&tables.mapping);
        let mut memory = memory_estimate(mapping.as_ref(), display, settings.density_view);
        if settings.dof.is_some() {
            // CoC map and the filtered image.
            memory += display.pixel_count() * (4 + std::mem::size_of::<Rgb>() as u64);
        }
        if settings.denoise.is_some() {
            // The denoiser's guides (albedo, normal) and working buffers per sample.
            let samples: u64 = mapping.buffers().iter().map(|b| b.pixels()).sum();
            memory += samples * fovea_post::denoise::BYTES_PER_SAMPLE;
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
        let focus_m = eye.focus.map(|f| f.metres());
        let mut dof = settings.dof.clone();
        if let (Some(d), Some(p)) = (dof.as_mut(), eye.pupil_mm) {
            d.eye.pupil = fovea_core::units::Millimetres(p);
        }
        let culling = match (&dof, focus_m) {
            (Some(d), Some(f)) if d.cull => Some(Culling::new(d, camera, world, f)?),
            (Some(d), None) if d.cull || d.filter.is_some() => {
                return Err(RenderError::invalid(
                    "eye focus",
                    "none",
                    "a focus distance for a frame with depth of field (EyeState::fixating or an EyeTracker gives one)",
                ))
            }
            _ => None,
        };
        let mut settings = settings.clone();
        settings.dof = dof;
        Ok(Self {
            covers_screen: tables.covers_screen,
            rays: tables.rays.clone(),
            buffers: mapping.buffers(),
            sample_count: mapping.sample_count(),
            aa: settings.aa.resolve(settings.method),
            jitter_texels,
            noise: FrameNoise::default(),
            footprint: tables.footprint.clone(),
            spacing: tables.spacing.clone(),
            culling,
            tiles: TileOrder {
                tile_px: TRACE_TILE,
                chunk_samples: CHUNK_SAMPLES,
            },
            memory_bytes: memory,
            display: display.clone(),
            eye: *eye,
            settings,
            mapping,
        })
    }

    /// The plan of frame `noise.frame` of eye `noise.eye`: the same rays, other random
    /// numbers in the shading.
    pub fn with_noise(mut self, noise: FrameNoise) -> Self {
        self.noise = noise;
        self
    }

    /// The mapping.
    pub fn mapping(&self) -> &dyn FoveationMapping {
        self.mapping.as_ref()
    }

    /// The mapping, shared (for a history that outlives the frame).
    pub fn shared_mapping(&self) -> Arc<dyn FoveationMapping> {
        Arc::clone(&self.mapping)
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.settings.method
    }

    /// The focus distance for the optics, metres (`None` without depth of field).
    pub fn focus_m(&self) -> Option<f64> {
        self.settings
            .dof
            .as_ref()
            .and(self.eye.focus)
            .map(|f| f.metres())
    }

    /// The plan as pretty JSON.
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string_pretty(self)
            .map_err(|e| RenderError::Unsupported(format!("cannot serialise the plan: {e}")))
    }
}

/// What a plan derives from its display, method, mapping parameters, ray settings and gaze,
/// and from nothing else: the mapping and its tables. [`PlanCache`] keeps them; the rest of a
/// plan (memory, culling at the eye's focus, jitter, noise) is decided per frame.
struct GazeTables {
    mapping: Arc<dyn FoveationMapping>,
    spacing: SpacingLut,
    rays: TexelRays,
    footprint: SampleFootprint,
    covers_screen: bool,
}

impl std::fmt::Debug for GazeTables {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GazeTables")
            .field("method", &self.mapping.method())
            .field("buffers", &self.mapping.buffers())
            .finish_non_exhaustive()
    }
}

impl GazeTables {
    fn new(display: &DisplayProfile, settings: &FrameSettings, eye: &EyeState) -> Result<Self> {
        Self::with_mapping(
            Arc::from(build(
                settings.method,
                display,
                eye.gaze,
                &settings.mapping,
            )?),
            display,
            settings,
            eye,
        )
    }

    /// The tables of `mapping`, built for `display`, `settings` and `eye`'s gaze.
    fn with_mapping(
        mapping: Arc<dyn FoveationMapping>,
        display: &DisplayProfile,
        settings: &FrameSettings,
        eye: &EyeState,
    ) -> Result<Self> {
        let spacing = SpacingLut::new(mapping.as_ref(), display, eye.gaze);
        let rays = TexelRays::new(
            mapping.as_ref(),
            display,
            eye,
            &spacing,
            settings.pixel_samples,
            settings.periphery_rays,
        );
        let footprint = SampleFootprint::with_floor(
            mapping.as_ref(),
            display,
            &eye.gaze,
            cone_floor_px(mapping.as_ref(), settings.reconstruct_filter),
        );
        Ok(Self {
            covers_screen: covers_screen(mapping.as_ref(), display),
            mapping,
            spacing,
            rays,
            footprint,
        })
    }
}

/// Everything a [`GazeTables`] depends on but the gaze.
#[derive(Clone, Debug, PartialEq)]
struct TablesKey {
    display: DisplayProfile,
    method: Method,
    mapping: MappingConfig,
    pixel_samples: u32,
    periphery_rays: u32,
    filter: ReconstructFilter,
}

impl TablesKey {
    fn of(display: &DisplayProfile, settings: &FrameSettings) -> Self {
        Self {
            display: display.clone(),
            method: settings.method,
            mapping: settings.mapping.clone(),
            pixel_samples: settings.pixel_samples,
            periphery_rays: settings.periphery_rays,
            filter: settings.reconstruct_filter,
        }
    }
}

/// Gazes whose tables a [`PlanCache`] keeps: both eyes of the frame and of the one before.
pub const PLAN_CACHE_GAZES: usize = 4;

/// The mappings and tables of the last [`PLAN_CACHE_GAZES`] gazes planned for one display,
/// method, mapping parameters and ray settings, shared (`Arc`) by every plan made from them
/// ([`FramePlan::cached`]). A gaze is the same when its point is, bit for bit: a still gaze,
/// both eyes looking at one screen point, a frame planned again. Asked for another display,
/// method or parameters, the cache empties first.
///
/// What it saves is the whole mapping: VaFR's exact rings depend on the gaze itself, not only
/// on the distance from it (each ring is sized by its worst point on the screen), so nothing of
/// them is shared between two gazes (docs/rendering.md, "What the plan costs per gaze"). A
/// mapping whose layout does not depend on the gaze (VaFR's rings for any gaze) is made at a
/// new gaze from the last one ([`fovea_core::mapping::rebuild_at`]: only its shaded runs laid
/// out again), the same mapping bit for bit.
#[derive(Debug, Default)]
pub struct PlanCache {
    key: Option<TablesKey>,
    /// Most recent first.
    entries: Vec<([u64; 2], Arc<GazeTables>)>,
    /// The last tables after [`Self::forget_gazes`]: their mapping makes the next one where
    /// its layout does not depend on the gaze.
    last: Option<Arc<GazeTables>>,
    hits: u64,
    misses: u64,
}

impl PlanCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Plans whose tables came from the cache.
    pub fn hits(&self) -> u64 {
        self.hits
    }

    /// Plans whose tables were built (and kept).
    pub fn misses(&self) -> u64 {
        self.misses
    }

    /// Gazes held now.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether it holds no tables.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Forgets the gazes planned, so that the next plans are made afresh (a benchmark's
    /// moving gaze whose path returns to its points: a tracked gaze never does), keeping only
    /// what does not depend on the gaze (the last mapping, from which the next is made where
    /// its layout allows).
    pub fn forget_gazes(&mut self) {
        if let Some((_, t)) = self.entries.first() {
            self.last = Some(Arc::clone(t));
        }
        self.entries.clear();
    }

    fn tables(
        &mut self,
        display: &DisplayProfile,
        settings: &FrameSettings,
        eye: &EyeState,
    ) -> Result<Arc<GazeTables>> {
        let key = TablesKey::of(display, settings);
        if self.key.as_ref() != Some(&key) {
            self.entries.clear();
            self.last = None;
            self.key = Some(key);
        }
        let gaze = [eye.gaze.point.x_px.to_bits(), eye.gaze.point.y_px.to_bits()];
        if let Some(k) = self.entries.iter().position(|(g, _)| *g == gaze) {
            let entry = self.entries.remove(k);
            let tables = Arc::clone(&entry.1);
            self.entries.insert(0, entry);
            self.hits += 1;
            return Ok(tables);
        }
        let last = self.entries.first().map(|(_, t)| t).or(self.last.as_ref());
        let moved = last.and_then(|last| {
            fovea_core::mapping::rebuild_at(last.mapping.as_ref(), display, eye.gaze)
        });
        let tables = Arc::new(match moved {
            Some(m) => GazeTables::with_mapping(Arc::from(m), display, settings, eye)?,
            None => GazeTables::new(display, settings, eye)?,
        });
        self.entries.insert(0, (gaze, Arc::clone(&tables)));
        self.entries.truncate(PLAN_CACHE_GAZES);
        self.misses += 1;
        Ok(tables)
    }
}

/// The primary rays of every texel of a frame: a stratified pattern of `pixel_samples` rays in
/// every texel, or — with one ray per sample, on a polar buffer — as many rays as the texel
/// covers screen pixels (its area `s²` from the sample spacing `s` at its column's
/// eccentricity, rounded), at most `periphery_rays`: the anti-aliased periphery of the
/// "faithful wherever the eye looks" issue. Where a texel spans several pixels, one ray
/// point-samples it and its edges and highlights alias into sawtooth and sparkle; a few rays
/// average it. Screen-aligned layers (Guenter, insets) and Weier's sparse set keep their
/// papers' one ray per texel.
#[derive(Clone, Debug, Serialize)]
pub struct TexelRays {
    /// The offsets (buffer texels, `[0, 1)²`, before the jitter) of a texel casting `n`
    /// rays at index `n − 1`, for every `n` up to the most any texel casts
    /// ([`subsample_offsets`]).
    pub patterns: Vec<Vec<[f64; 2]>>,
    /// For each pattern, its ray nearest the texel centre: that ray's depth is the texel's,
    /// and it decides DOF culling for the texel.
    pub representatives: Vec<usize>,
    /// Rays of each column of a polar buffer (layer 0); empty: [`uniform`](Self::uniform)
    /// rays in every texel.
    pub per_column: Vec<u8>,
    /// Rays of every texel where `per_column` is empty.
    pub uniform: u32,
}

impl TexelRays {
    /// The rays of a frame of `mapping` on `display` seen by `eye` whose samples lie
    /// `spacing` apart (see the type).
    pub fn new(
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        eye: &EyeState,
        spacing: &SpacingLut,
        pixel_samples: u32,
        periphery_rays: u32,
    ) -> Self {
        let per_column: Vec<u8> = match mapping.polar_layout() {
            Some(layout) if pixel_samples <= 1 && periphery_rays > 1 => (0..layout.rows.len())
                .map(|i| {
                    let s = fovea_core::mapping::SamplePoint {
                        layer: 0,
                        u: i as f64 + 0.5,
                        v: 0.0,
                    };
                    let area_px = mapping.inverse(s).map_or(1.0, |p| {
                        let e = display.eccentricity(p, &eye.gaze).0;
                        (spacing.at(e) as f64).powi(2)
                    });
                    area_px
                        .round()
                        .clamp(1.0, periphery_rays.min(u8::MAX as u32) as f64)
                        as u8
                })
                .collect(),
            _ => Vec::new(),
        };
        let uniform = pixel_samples.max(1);
        let most = per_column
            .iter()
            .map(|&n| n as u32)
            .max()
            .unwrap_or(uniform)
            .max(uniform);
        let patterns: Vec<Vec<[f64; 2]>> = (1..=most).map(subsample_offsets).collect();
        let representatives = patterns
            .iter()
            .map(|p| {
                (0..p.len())
                    .min_by(|&a, &b| {
                        let d = |o: [f64; 2]| (o[0] - 0.5).powi(2) + (o[1] - 0.5).powi(2);
                        d(p[a]).total_cmp(&d(p[b]))
                    })
                    .unwrap_or(0)
            })
            .collect();
        Self {
            patterns,
            representatives,
            per_column,
            uniform,
        }
    }

    /// Rays of a texel in column `column` of layer `layer`.
    #[inline]
    pub fn count(&self, layer: u32, column: u32) -> u32 {
        if layer == 0 {
            if let Some(&n) = self.per_column.get(column as usize) {
                return n as u32;
            }
        }
        self.uniform
    }

    /// The offsets of a texel casting `n` rays, and which of them stands for the texel.
    #[inline]
    pub fn pattern(&self, n: u32) -> (&[[f64; 2]], usize) {
        let k = (n.max(1) as usize - 1).min(self.patterns.len() - 1);
        (&self.patterns[k], self.representatives[k])
    }

    /// The most rays any texel casts.
    pub fn most(&self) -> u32 {
        self.patterns.len() as u32
    }
}

/// The ring of every primary ray of a polar buffer's columns ([`FoveationMapping::ring`]),
/// read once per chunk: ray `k` of a texel in column `i` lies on the ring of
/// `u = i + offset_k + jitter`, so its screen point is that ring's
/// [`point`](fovea_core::mapping::Ring::point) at its `v` — what the mapping's inverse gives,
/// bit for bit, without solving for the ring's radius again for every ray (VaFR's exact rings
/// solve a cubic; the log-polar kernels take a logarithm and an exponential).
#[derive(Clone, Debug)]
pub struct RayRings {
    /// The rings' centre (the mapping's pole).
    centre: ScreenPoint,
    /// Where column `i`'s rings start in `rings`; the total last.
    start: Vec<u32>,
    /// The ring of each ray of each column (`None` where the inverse has no point).
    rings: Vec<Option<Ring>>,
}

impl RayRings {
    /// The rings of layer `layer` of `plan`, whose buffer is `width` columns wide; `None` for a
    /// screen-aligned mapping.
    pub fn new(plan: &FramePlan, layer: u32, width: u32) -> Option<Self> {
        let mapping = plan.mapping();
        let centre = mapping.polar_layout()?.centre;
        let mut start = Vec::with_capacity(width as usize + 1);
        let mut rings = Vec::new();
        for i in 0..width {
            start.push(rings.len() as u32);
            let (offsets, _) = plan.rays.pattern(plan.rays.count(layer, i));
            rings.extend(
                offsets
                    .iter()
                    .map(|o| mapping.ring(layer, i as f64 + o[0] + plan.jitter_texels[0])),
            );
        }
        start.push(rings.len() as u32);
        Some(Self {
            centre,
            start,
            rings,
        })
    }

    /// The rings' centre (the mapping's pole, the gaze).
    pub fn centre(&self) -> ScreenPoint {
        self.centre
    }

    /// The ring of ray `k` of column `column`'s texels.
    #[inline]
    pub fn get(&self, column: u32, k: u32) -> Option<Ring> {
        let c = column as usize;
        let (a, b) = (*self.start.get(c)?, *self.start.get(c + 1)?);
        if a + k < b {
            self.rings[(a + k) as usize]
        } else {
            None
        }
    }
}

/// The narrowest ray cone, screen pixels: one pixel where the reconstruction reads a dense
/// buffer with a bilinear lookup (finer detail would alias into moiré on the pixel grid), an
/// eighth of a pixel where it boxes every texel a pixel covers — polar buffers with
/// [`ReconstructFilter::Footprint`] — since the box filters the detail to the pixel, as a
/// supersampled full frame does (VaFR's fovea holds up to ~8 texels per pixel each way).
pub fn cone_floor_px(mapping: &dyn FoveationMapping, filter: ReconstructFilter) -> f64 {
    match (filter, mapping.polar_layout()) {
        (ReconstructFilter::Footprint, Some(_)) => 0.125,
        _ => 1.0,
    }
}

/// `n` stratified points in the unit square: the `k × k` cell centres when `n = k²`, otherwise
/// a rank-1 (Fibonacci) lattice `((s + ½)/n, frac((s + ½)·φ⁻¹))`, which puts one point in
/// every `1/n` column and spreads them evenly down the rows. `n = 1` is the centre.
pub fn subsample_offsets(n: u32) -> Vec<[f64; 2]> {
    let n = n.max(1);
    let k = (n as f64).sqrt().round() as u32;
    if k * k == n {
        let step = 1.0 / k as f64;
        return (0..n)
            .map(|s| {
                let (i, j) = (s % k, s / k);
                [(i as f64 + 0.5) * step, (j as f64 + 0.5) * step]
            })
            .collect();
    }
    let inv_phi = (5f64.sqrt() - 1.0) / 2.0;
    (0..n)
        .map(|s| {
            let t = s as f64 + 0.5;
            [t / n as f64, (t * inv_phi).fract()]
        })
        .collect()
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

/// Whether `mapping` has samples for every pixel of `display`: screen-aligned mappings always
/// do; a polar one does when its forward map reaches the four corner pixels, the screen's
/// farthest points from any gaze.
fn covers_screen(mapping: &dyn FoveationMapping, display: &DisplayProfile) -> bool {
    if mapping.polar_layout().is_none() {
        return true;
    }
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    [
        (0.5, 0.5),
        (w - 0.5, 0.5),
        (0.5, h - 0.5),
        (w - 0.5, h - 0.5),
    ]
    .iter()
    .all(|&(x, y)| {
        mapping
            .forward(fovea_core::units::ScreenPoint::new(x, y))
            .is_some()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_order_visits_every_index_once() {
        let t = TileOrder {
            tile_px: 16,
            chunk_samples: 1 << 10,
        };
        for (w, h) in [(1, 1), (17, 5), (40, 33)] {
            let mut o = t.order(w, h);
            assert_eq!(o.len(), w * h);
            o.sort_unstable();
            assert!(o.iter().enumerate().all(|(k, &v)| k as u32 == v));
        }
        assert_eq!(t.rows_per_chunk(100, 1), 10);
        assert_eq!(t.rows_per_chunk(100, 4), 2);
        assert_eq!(t.rows_per_chunk(5000, 1), 1);
    }

    #[test]
    fn a_full_tile_is_visited_in_square_blocks() {
        let t = TileOrder {
            tile_px: 16,
            chunk_samples: 1 << 10,
        };
        let (w, h) = (40usize, 33usize);
        let o = t.order(w, h);
        // The first tile is whole: every aligned run of 64 texels is an 8×8 block, of 8 a 4×2
        // block, of 4 a 2×2 block.
        for (run, bw, bh) in [(64, 8, 8), (8, 4, 2), (4, 2, 2)] {
            for block in o[..256].chunks(run) {
                let xs = block.iter().map(|&k| k as usize % w);
                let ys = block.iter().map(|&k| k as usize / w);
                let (x0, x1) = (xs.clone().min().unwrap(), xs.max().unwrap());
                let (y0, y1) = (ys.clone().min().unwrap(), ys.max().unwrap());
                assert_eq!((x1 - x0 + 1, y1 - y0 + 1), (bw, bh), "{block:?}");
            }
        }
        assert_eq!(morton_decode(0b11_1001), (0b101, 0b110));
    }

    #[test]
    fn subsamples_are_stratified_and_centred() {
        assert_eq!(subsample_offsets(1), vec![[0.5, 0.5]]);
        for n in [2, 3, 4, 5, 9, 16, 64] {
            let o = subsample_offsets(n);
            assert_eq!(o.len(), n as usize);
            assert!(o.iter().flatten().all(|&v| (0.0..1.0).contains(&v)), "{n}");
            // Stratified in u: one point in every 1/n column, or a k×k grid.
            let mean = o.iter().fold([0.0, 0.0], |m, p| [m[0] + p[0], m[1] + p[1]]);
            assert!((mean[0] / n as f64 - 0.5).abs() < 1e-12, "{n}");
            assert!(
                (mean[1] / n as f64 - 0.5).abs() < 0.5 / n as f64 + 1e-12,
                "{n}"
            );
            let mut us: Vec<f64> = o.iter().map(|p| p[0]).collect();
            us.sort_by(f64::total_cmp);
            us.dedup();
            let k = (n as f64).sqrt().round() as usize;
            assert_eq!(us.len(), if k * k == n as usize { k } else { n as usize });
        }
    }
}
