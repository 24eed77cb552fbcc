//! Stages 3–4 of the frame (DESIGN.md "How a frame flows"): **trace** and **shade**.
//!
//! For every shaded buffer pixel its centre (plus the plan's jitter) goes through the inverse
//! mapping to a screen point, which gets one primary ray (so an LP method casts exactly
//! `sample_count()` rays, less the texels whose centre maps off the screen); the closest hit
//! becomes a G-buffer record ([`trace_chunk`]). Each record is then shaded — direct light with
//! shadow rays, or path tracing — unless the DOF roulette (Liu Eq. 11) culls it, and scattered
//! into the sample buffers ([`shade_chunk`]). Culled samples get their colour from their
//! shaded neighbours afterwards (`crate::cull_fill`).
//!
//! Both run chunk by chunk ([`crate::plan::CHUNK_SAMPLES`] samples, whole rows), samples in
//! tiles of [`crate::plan::TRACE_TILE`]² texels, so G-buffer memory stays bounded at any
//! resolution and consecutive rays of a thread meet the same BVH nodes and texels.
//!
//! **Sample footprint.** Each sample's ray cone angle comes from the plan's
//! [`SampleFootprint`](fovea_core::mapping::footprint::SampleFootprint): one pixel at full
//! resolution, one value per polar column, otherwise the per-sample formula.

use rayon::prelude::*;

use fovea_core::mapping::SamplePoint;
use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_post::denoise::DenoiseGuides;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;
use glam::Vec3;

use super::backends::StageBackends;
use super::timing::{Stage, StageTimes, Stopwatch};
use crate::bvh::{Hit, Ray};
use crate::camera::EyeCamera;
use crate::cull_fill::{fill_culled, shade_or_cull, CullBuffers, SampleCull};
use crate::error::{RenderError, Result};
use crate::plan::{FramePlan, RayRings};
use crate::scene::Light;
use crate::shade::frame_noise::with_frame;
use crate::shade::{
    indirect, shade_direct_batch, shade_parts, subsample_key, texel_key, EnvLight, RayCounts,
    ShadingMode, ShadowRays,
};
use crate::trace::{surface, GSample};
use crate::world::World;

/// Another executor of the trace and shade stages' ray casting (e.g. the GPU's, `fovea-gpu`):
/// the closest hits of a chunk's primary rays, and the shadow rays of its direct shading,
/// against the triangles of the world it was built for. The surface attributes (normals, UVs,
/// materials, textures, with the CPU's ray cone) are interpolated on the CPU unless it
/// interpolates them itself ([`Self::interpolates_surfaces`]), and the shading arithmetic
/// stays on the CPU except the lights' and the environment's parts of direct shading where it
/// computes them; the rays of a world it was not built for (a level-of-detail world) stay on
/// the CPU.
pub trait TraceExecutor: Send {
    /// The backend's short name in stats and JSON, e.g. `gpu`.
    fn backend(&self) -> &str;
    /// Whether it holds `world`'s triangles (compare [`World::tris_fingerprint`]).
    fn serves(&self, world: &World) -> bool;
    /// The closest hit of every ray in `[t_min, t_max]`, `Hit::tri` indexing `world.tris`.
    /// An error is one line saying what to do.
    fn closest_hits(&mut self, rays: &[Ray]) -> std::result::Result<Vec<Option<Hit>>, String>;
    /// Whether anything lies on each ray in `[t_min, t_max]` (the shade stage's shadow rays,
    /// `t_max` possibly infinite). An error is one line saying what to do.
    fn occluded(&mut self, rays: &[Ray]) -> std::result::Result<Vec<bool>, String>;
    /// Whether it computes the lights' part of direct shading itself
    /// ([`Self::direct_light`]); if not, the lights' shadow rays come to [`Self::occluded`].
    fn shades_direct_light(&self) -> bool {
        false
    }
    /// The lights' part of direct shading at each surface sample of `hits` (all hits):
    /// [`crate::shade::direct`]'s radiance from `lights`, and the shadow rays it cast. Called
    /// only when [`Self::shades_direct_light`]. An error is one line saying what to do.
    fn direct_light(
        &mut self,
        hits: &[&GSample],
        lights: &[Light],
    ) -> std::result::Result<Vec<(Vec3, u32)>, String> {
        let _ = (hits, lights);
        Err(format!("{} does not compute direct light", self.backend()))
    }
    /// Whether it computes the environment's part of direct shading itself
    /// ([`Self::environment_light`], for the environment of the world it serves); if not, the
    /// environment's shadow rays come to [`Self::occluded`].
    fn shades_environment(&self) -> bool {
        false
    }
    /// The environment's part of direct shading at each surface sample of `hits` (all hits),
    /// with `samples` rays each, `keys[s]` seeding sample `s`'s random numbers:
    /// [`crate::shade::environment_light`]'s radiance with
    /// [`crate::shade::EnvLight::Occluded`] for the environment of the world it serves, and
    /// the rays it cast. Called only when [`Self::shades_environment`] and `samples > 0`. An
    /// error is one line saying what to do.
    fn environment_light(
        &mut self,
        hits: &[&GSample],
        keys: &[u64],
        samples: u32,
    ) -> std::result::Result<Vec<(Vec3, u32)>, String> {
        let _ = (hits, keys, samples);
        Err(format!(
            "{} does not compute the environment light",
            self.backend()
        ))
    }
    /// Whether it generates the primary rays itself — a polar buffer's
    /// ([`Self::closest_hits_polar`]) and a screen-aligned one's
    /// ([`Self::closest_hits_screen`]); if not, they come to [`Self::closest_hits`].
    fn generates_rays(&self) -> bool {
        false
    }
    /// Generates the primary ray through each screen point of `points` (pixels; an executor
    /// may round them to f32, as [`EyeCamera::ray`] does) through `camera`, and returns its
    /// unit direction and its closest hit. Called only when [`Self::generates_rays`]. An
    /// error is one line saying what to do.
    fn closest_hits_screen(
        &mut self,
        camera: &EyeCamera,
        points: &[ScreenPoint],
    ) -> std::result::Result<Vec<(Vec3, Option<Hit>)>, String> {
        let _ = (camera, points);
        Err(format!("{} does not generate rays", self.backend()))
    }
    /// Generates the primary ray of each of `rays` — the screen point `r_px` from `centre`
    /// at `turn` turns (+x towards +y), through `camera` — and returns its unit direction
    /// and its closest hit. Called only when [`Self::generates_rays`]. An error is one line
    /// saying what to do.
    fn closest_hits_polar(
        &mut self,
        camera: &EyeCamera,
        centre: ScreenPoint,
        rays: &[PolarRay],
    ) -> std::result::Result<Vec<(Vec3, Option<Hit>)>, String> {
        let _ = (camera, centre, rays);
        Err(format!("{} does not generate rays", self.backend()))
    }
    /// Why it does not interpolate surfaces ([`Self::interpolates_surfaces`] false), e.g. "a
    /// texture larger than a binding", for the frame's [`StageBackends`] record.
    fn why_no_surfaces(&self) -> Option<String> {
        None
    }

    /// Whether it also interpolates the surface at each generated ray's hit itself — the
    /// scene's normals, UVs, materials and textures on its side — and returns G-buffer
    /// records ([`Self::surfaces_polar`], [`Self::surfaces_screen`]); if not, the hits come
    /// back and [`crate::trace::surface`] interpolates them here. Asked only when
    /// [`Self::generates_rays`].
    fn interpolates_surfaces(&self) -> bool {
        false
    }
    /// [`Self::closest_hits_polar`] with the surface at each hit: the G-buffer record
    /// [`crate::trace::surface`] makes of it, the ray's cone angle (radians) in `spreads`
    /// (one per ray), or [`GSample::miss`] of the ray's direction. Called only when
    /// [`Self::interpolates_surfaces`]. An error is one line saying what to do.
    fn surfaces_polar(
        &mut self,
        camera: &EyeCamera,
        centre: ScreenPoint,
        rays: &[PolarRay],
        spreads: &[f32],
    ) -> std::result::Result<Vec<GSample>, String> {
        let _ = (camera, centre, rays, spreads);
        Err(format!("{} does not interpolate surfaces", self.backend()))
    }
    /// [`Self::closest_hits_screen`] with the surface at each hit, as
    /// [`Self::surfaces_polar`]. Called only when [`Self::interpolates_surfaces`]. An error
    /// is one line saying what to do.
    fn surfaces_screen(
        &mut self,
        camera: &EyeCamera,
        points: &[ScreenPoint],
        spreads: &[f32],
    ) -> std::result::Result<Vec<GSample>, String> {
        let _ = (camera, points, spreads);
        Err(format!("{} does not interpolate surfaces", self.backend()))
    }
}

/// A primary ray of a polar buffer as another executor generates it: its screen point, in
/// polar coordinates around the mapping's centre ([`fovea_core::mapping::Ring::polar`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolarRay {
    /// Distance from the centre, screen pixels.
    pub r_px: f64,
    /// Angle, turns (`[0, 1]`, from +x towards +y).
    pub turn: f64,
}

/// The name of the CPU trace in [`FrameStats::trace_backend`](super::FrameStats::trace_backend).
pub const CPU: &str = "cpu";

/// What the trace and shade stages did.
#[derive(Clone, Copy, Debug, Default)]
pub struct TraceCounts {
    /// Primary rays cast.
    pub primary: u64,
    /// Shadow (lights and environment) and bounce rays.
    pub secondary: RayCounts,
    /// Samples that hit a surface and were shaded.
    pub shaded: u64,
    /// Samples that hit a surface and were culled by the DOF roulette.
    pub culled: u64,
}

/// One chunk of a layer: rows `j0 ..` of buffer `layer`, `row_len` texels wide, visited in
/// `order` (indices into the chunk).
#[derive(Clone, Copy)]
pub struct Chunk<'a> {
    /// Layer.
    pub layer: u32,
    /// First row.
    pub j0: u32,
    /// Row length, texels.
    pub row_len: usize,
    /// Visit order of the chunk's texels (tiles).
    pub order: &'a [u32],
}

/// Where the rays of each texel of `chunk` (in its visit order) start in the chunk's
/// G-buffer, texel-major, with the total last: [`crate::plan::TexelRays::count`] rays each.
pub fn ray_starts(plan: &FramePlan, chunk: Chunk<'_>, starts: &mut Vec<u32>) {
    starts.clear();
    starts.reserve(chunk.order.len() + 1);
    let mut total = 0u32;
    for &k in chunk.order {
        starts.push(total);
        total += plan.rays.count(chunk.layer, k % chunk.row_len as u32);
    }
    starts.push(total);
}

/// Trace: one G-buffer record per primary ray of `chunk` — the texel's
/// [`crate::plan::TexelRays`], texel-major, starting at `starts` ([`ray_starts`]) — for
/// texels that the mapping shades, that are not `known` already, and whose ray's point maps
/// onto the screen; `None` for the others.
///
/// With `tracer` the closest hits come from it (one batch per chunk) and the surfaces are
/// interpolated here — from the rays' screen points, or a polar buffer's polar coordinates,
/// when it generates the rays itself (`(generates, surfaces).0`, as the frame's
/// [`StageBackends`] decided), and then the records themselves when it interpolates the
/// surfaces too (`.1`); without, each ray is cast on the CPU.
#[allow(clippy::too_many_arguments)]
pub fn trace_chunk(
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
    chunk: Chunk<'_>,
    starts: &[u32],
    known: Option<&Image<bool>>,
    tracer: Option<&mut (dyn TraceExecutor + 'static)>,
    (generates, surfaces): (bool, bool),
    gbuf: &mut Vec<Option<GSample>>,
) -> Result<()> {
    let mapping = plan.mapping();
    let (display, gaze, jitter) = (&plan.display, &plan.eye.gaze, plan.jitter_texels);
    let Chunk {
        layer,
        j0,
        row_len,
        order,
    } = chunk;
    let total = starts.last().copied().unwrap_or(0);
    // With the same rays in every texel (the default) a ray's texel is a division away; only
    // per-column counts need the search.
    let uniform = plan.rays.per_column.is_empty().then_some(plan.rays.uniform);
    // A polar buffer's rays read their column's ring (its radius solved once per chunk).
    let rings = RayRings::new(plan, layer, row_len as u32);
    // Ray `r` of the chunk: its texel `(i, j)`, its index in the texel and its offset in the
    // texel; `None` where the texel is not traced.
    let slot = |r: u32| -> Option<(u32, u32, u32, [f64; 2])> {
        let t = match uniform {
            Some(n) => (r / n) as usize,
            None => starts.partition_point(|&s| s <= r) - 1,
        };
        let n = starts[t + 1] - starts[t];
        let k = order[t] as usize;
        let ray = r - starts[t];
        let o = plan.rays.pattern(n).0[ray as usize];
        let (i, j) = ((k % row_len) as u32, j0 + (k / row_len) as u32);
        if !mapping.is_shaded(layer, i, j) || known.is_some_and(|m| *m.get(i, j)) {
            return None;
        }
        Some((i, j, ray, o))
    };
    // The cone of a ray of column `i` whose point is `p` (asked only where the column has no
    // cone of its own).
    let spread_of = |i: u32, p: &dyn Fn() -> Option<ScreenPoint>| -> Option<f32> {
        let spread = match plan.footprint.column_spread_rad(i) {
            Some(s) => s,
            None => plan.footprint.spread_rad(mapping, display, gaze, i, p()?),
        };
        // Each of n rays covers 1/n of the texel: its cone is 1/√n of the texel's.
        let n = plan.rays.count(layer, i);
        Some(if n == 1 {
            spread
        } else {
            spread / (n as f32).sqrt()
        })
    };
    // Ray `r`'s screen point and cone.
    let point_of = |r: u32| -> Option<(ScreenPoint, f32)> {
        let (i, j, ray, o) = slot(r)?;
        let v = j as f64 + o[1] + jitter[1];
        let p = match &rings {
            Some(rings) => rings.get(i, ray)?.point(v)?,
            None => mapping.inverse(SamplePoint {
                layer,
                u: i as f64 + o[0] + jitter[0],
                v,
            })?,
        };
        Some((p, spread_of(i, &|| Some(p))?))
    };
    let ray_of = |r: u32| point_of(r).map(|(p, spread)| (camera.ray(p), spread));
    // A polar buffer on an executor that generates rays: each ray goes as its polar
    // coordinates, and comes back with the direction it was cast along.
    let tracer = match (tracer, &rings) {
        (Some(tracer), Some(rings)) if generates => {
            let polar: Vec<Option<(PolarRay, f32)>> = (0..total)
                .into_par_iter()
                .map(|r| {
                    let (i, j, ray, o) = slot(r)?;
                    let ring = rings.get(i, ray)?;
                    let v = j as f64 + o[1] + jitter[1];
                    let (r_px, turn) = ring.polar(v)?;
                    Some((PolarRay { r_px, turn }, spread_of(i, &|| ring.point(v))?))
                })
                .collect();
            let batch: Vec<PolarRay> = polar.iter().flatten().map(|&(r, _)| r).collect();
            if surfaces {
                let spreads: Vec<f32> = polar.iter().flatten().map(|&(_, s)| s).collect();
                let got = tracer.surfaces_polar(camera, rings.centre(), &batch, &spreads);
                let records = checked(tracer, "trace", ("surfaces", "rays"), batch.len(), got)?;
                placed_gbuf(&polar, records, gbuf);
                return Ok(());
            }
            let got = tracer.closest_hits_polar(camera, rings.centre(), &batch);
            let answers = checked(tracer, "trace", ("hits", "rays"), batch.len(), got)?;
            generated_gbuf(world, camera, polar, answers, gbuf);
            return Ok(());
        }
        // A screen-aligned buffer on an executor that generates rays: each ray goes as its
        // screen point.
        (Some(tracer), None) if generates => {
            let points: Vec<Option<(ScreenPoint, f32)>> =
                (0..total).into_par_iter().map(point_of).collect();
            let batch: Vec<ScreenPoint> = points.iter().flatten().map(|&(p, _)| p).collect();
            if surfaces {
                let spreads: Vec<f32> = points.iter().flatten().map(|&(_, s)| s).collect();
                let got = tracer.surfaces_screen(camera, &batch, &spreads);
                let records = checked(tracer, "trace", ("surfaces", "rays"), batch.len(), got)?;
                placed_gbuf(&points, records, gbuf);
                return Ok(());
            }
            let got = tracer.closest_hits_screen(camera, &batch);
            let answers = checked(tracer, "trace", ("hits", "rays"), batch.len(), got)?;
            generated_gbuf(world, camera, points, answers, gbuf);
            return Ok(());
        }
        (tracer, _) => tracer,
    };
    let Some(tracer) = tracer else {
        // On the CPU: batches of neighbouring texels' rays, each cast as one
        // `intersect_batch` (Embree and obvhs traverse them as packets).
        gbuf.clear();
        gbuf.resize(total as usize, None);
        gbuf.par_chunks_mut(TRACE_BATCH as usize)
            .enumerate()
            .for_each(|(b, out)| {
                let r0 = b as u32 * TRACE_BATCH;
                let rays: Vec<Option<(Ray, f32)>> =
                    (r0..r0 + out.len() as u32).map(ray_of).collect();
                let batch: Vec<Ray> = rays.iter().flatten().map(|&(ray, _)| ray).collect();
                let mut hits = vec![None; batch.len()];
                world.caster.intersect_batch(&batch, &mut hits);
                let mut hits = hits.into_iter();
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = r.map(|(ray, spread)| match hits.next().flatten() {
                        Some(hit) => surface(world, &ray, &hit, spread),
                        None => GSample::miss(ray.dir),
                    });
                }
            });
        return Ok(());
    };
    let rays: Vec<Option<(Ray, f32)>> = (0..total).into_par_iter().map(ray_of).collect();
    let batch: Vec<Ray> = rays.iter().flatten().map(|&(ray, _)| ray).collect();
    let got = tracer.closest_hits(&batch);
    let hits = checked(tracer, "trace", ("hits", "rays"), batch.len(), got)?;
    // Each traced ray with its hit, in order (rays of texels that are not traced have none).
    let mut hits = hits.into_iter();
    let traced: Vec<Option<(Ray, f32, Option<Hit>)>> = rays
        .into_iter()
        .map(|r| r.map(|(ray, spread)| (ray, spread, hits.next().flatten())))
        .collect();
    traced
        .into_par_iter()
        .map(|r| {
            r.map(|(ray, spread, hit)| match hit {
                Some(hit) => surface(world, &ray, &hit, spread),
                None => GSample::miss(ray.dir),
            })
        })
        .collect_into_vec(gbuf);
    Ok(())
}

/// The G-buffer of a chunk whose rays another executor generated: `rays` holds each ray of
/// the chunk as sent (with its cone; `None` where the texel is not traced), `answers` the
/// direction each sent ray was cast along and its closest hit, in order.
fn generated_gbuf<R>(
    world: &World,
    camera: &EyeCamera,
    rays: Vec<Option<(R, f32)>>,
    answers: Vec<(Vec3, Option<Hit>)>,
    gbuf: &mut Vec<Option<GSample>>,
) {
    let mut answers = answers.into_iter();
    let traced: Vec<Option<(f32, Vec3, Option<Hit>)>> = rays
        .into_iter()
        .map(|r| {
            let (_, spread) = r?;
            let (dir, hit) = answers.next()?;
            Some((spread, dir, hit))
        })
        .collect();
    traced
        .into_par_iter()
        .map(|r| {
            r.map(|(spread, dir, hit)| {
                let ray = Ray {
                    origin: camera.position,
                    dir,
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                match hit {
                    Some(hit) => surface(world, &ray, &hit, spread),
                    None => GSample::miss(dir),
                }
            })
        })
        .collect_into_vec(gbuf);
}

/// The G-buffer of a chunk whose surfaces another executor interpolated: `rays` holds each
/// ray of the chunk as sent (`None` where the texel is not traced), `records` each sent ray's
/// record, in order.
fn placed_gbuf<R>(
    rays: &[Option<(R, f32)>],
    records: Vec<GSample>,
    gbuf: &mut Vec<Option<GSample>>,
) {
    let mut records = records.into_iter();
    gbuf.clear();
    gbuf.extend(rays.iter().map(|r| r.as_ref().and_then(|_| records.next())));
}

/// Primary rays cast together by [`trace_chunk`] on the CPU (one
/// [`crate::bvh::RayCaster::intersect_batch`]).
pub const TRACE_BATCH: u32 = 64;

/// Texels shaded together by [`shade_chunk`]'s batched direct lighting: each light's shadow
/// rays of this many neighbouring texels are cast as one batch.
pub const SHADE_BATCH: usize = 256;

/// Texels whose shadow rays [`shade_chunk`] hands another executor in one call (a multiple
/// of [`SHADE_BATCH`]): at most 16 rays each with 12 lights and 4 environment rays, 32 bytes
/// a ray, so up to about 34 MB of rays per call.
pub const SHADE_GROUP: usize = SHADE_BATCH * 256;

/// Shade: every texel of `chunk` whose rays hit (`gbuf`, texel-major from `starts`) shaded —
/// the mean of its rays — or culled by the plan's DOF roulette (decided by the ray nearest the texel
/// centre, whose depth is the texel's), and scattered into the chunk's colour and depth
/// (`color`, `depth`: the chunk's rows). Records the cull state of each sample in
/// `cull_state` when culling. With `noisy` (the chunk's rows) each shaded texel's Monte Carlo
/// part goes there too ([`crate::shade::shade_parts`]: what the denoiser filters) where the
/// shading separates it — without DOF culling; the culled and kept samples of the roulette are
/// left as they are (NaN from [`record_guides`]: the denoiser then filters their whole
/// colour).
///
/// With `tracer`, the shadow rays of direct shading of one ray per texel without culling
/// (the default frame) are cast there, [`SHADE_GROUP`] texels' at a time; the shading
/// arithmetic stays here — except the lights' part where the executor computes it
/// ([`TraceExecutor::shades_direct_light`]) and the environment's where it computes that
/// ([`TraceExecutor::shades_environment`]). Returns what the executor did (the other frames'
/// shadow rays are cast and shaded on the CPU).
#[allow(clippy::too_many_arguments)]
pub fn shade_chunk(
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
    chunk: Chunk<'_>,
    starts: &[u32],
    gbuf: &[Option<GSample>],
    color: &mut [Rgb],
    depth: &mut [f32],
    mut noisy: Option<&mut [Rgb]>,
    mut cull_state: Option<&mut CullBuffers>,
    counts: &mut TraceCounts,
    tracer: Option<&mut (dyn TraceExecutor + 'static)>,
    decided: ShadeCast,
) -> Result<ShadeCast> {
    let want_noisy = noisy.is_some();
    let Chunk {
        layer,
        j0,
        row_len,
        order,
    } = chunk;
    let shading = plan.settings.shading;
    let cull = plan.culling.as_ref();
    // The key of the chunk's texel `k` (row-major in the chunk's rows): its random numbers.
    // The frame and the eye enter every key (`crate::shade::frame_noise`).
    let key_of_texel = |k: u32| {
        with_frame(
            texel_key(layer, k % row_len as u32, j0 + k / row_len as u32),
            plan.noise,
        )
    };
    // Indirect light on top of direct shading, added per surface sample.
    let bounces = match shading {
        ShadingMode::Indirect { bounces, .. } => bounces,
        _ => 0,
    };
    let bounce = bounces > 0;
    // Direct shading of one ray per texel without culling (the default frame): on the CPU
    // each light's shadow rays of a batch of neighbouring texels are cast together; `tracer`
    // gets the shadow rays of many batches at once (gathered first) and may compute the
    // lights' part itself.
    if let (Some(env_light), None, true) = (
        shading.direct_env_light(),
        cull,
        plan.rays.per_column.is_empty() && plan.rays.uniform == 1,
    ) {
        // A batch's texels' representative records (none where nothing was traced), the
        // records, and their keys.
        type Records<'g> = (Vec<Option<&'g GSample>>, Vec<&'g GSample>, Vec<u64>);
        let records = |t0: usize, ks: &[u32]| -> Records<'_> {
            let reps: Vec<Option<&GSample>> = (0..ks.len())
                .map(|i| gbuf[starts[t0 + i] as usize].as_ref())
                .collect();
            let gs: Vec<&GSample> = reps.iter().flatten().copied().collect();
            let keys: Vec<u64> = ks
                .iter()
                .zip(&reps)
                .filter(|(_, r)| r.is_some())
                .map(|(&k, _)| key_of_texel(k))
                .collect();
            (reps, gs, keys)
        };
        // Each texel's colour and depth from its record's radiance (`values`, one per record).
        let emit = |reps: &[Option<&GSample>], values: Vec<Vec3>| -> Vec<Option<(Rgb, f32)>> {
            let mut values = values.into_iter();
            reps.iter()
                .map(|r| {
                    r.map(|g| {
                        let v = values.next().unwrap_or(Vec3::ZERO);
                        (v.to_array(), camera.view_depth(-g.to_eye, g.t))
                    })
                })
                .collect()
        };
        // For another executor: a batch's representative records, their shadow rays, and the
        // keys of its surface samples (hits).
        type Gathered<'g> = (Vec<Option<&'g GSample>>, ShadowRays, RayCounts, Vec<u64>);
        // The lights' and the environment's parts of a batch's surface samples and the rays
        // each cast, where another executor computed them.
        type Given<'d> = (Option<&'d [(Vec3, u32)]>, Option<&'d [(Vec3, u32)]>);
        // The environment's samples when the executor computes its part.
        let env_samples = match env_light {
            EnvLight::Occluded { samples } if samples > 0 => Some(samples),
            _ => None,
        };
        // `parts`: which rays to gather, the lights' and the environment's (the executor
        // computes the others' parts).
        let gather = |t0: usize, ks: &[u32], parts: (bool, bool)| -> Gathered<'_> {
            let (reps, gs, keys) = records(t0, ks);
            let mut rc = RayCounts::default();
            let rays = ShadowRays::gather(world, &gs, &keys, env_light, parts, &mut rc);
            let hit_keys = gs
                .iter()
                .zip(&keys)
                .filter(|(g, _)| g.is_hit())
                .map(|(_, &k)| k)
                .collect();
            (reps, rays, rc, hit_keys)
        };
        // A value per surface sample of `gs` (misses: zero) from `given` (one per hit), its
        // rays added to `count`.
        let per_sample = |gs: &[&GSample], given: &[(Vec3, u32)], count: &mut u64| {
            let mut given = given.iter();
            gs.iter()
                .map(|g| match g.is_hit().then(|| given.next()).flatten() {
                    Some(&(v, n)) => {
                        *count += u64::from(n);
                        v
                    }
                    None => Vec3::ZERO,
                })
                .collect::<Vec<Vec3>>()
        };
        // Each texel's colour and depth once its batch's rays are answered (`blocked`), with
        // the lights' and the environment's parts given per surface sample or summed from the
        // rays.
        let finish = |(reps, rays, rc, hit_keys): Gathered<'_>,
                      blocked: &[bool],
                      (direct, environment): Given<'_>|
         -> Batch {
            let gs: Vec<&GSample> = reps.iter().flatten().copied().collect();
            let mut values = vec![Vec3::ZERO; gs.len()];
            let mut rc = rc;
            let mut given_env = None;
            if direct.is_none() && environment.is_none() {
                rays.shade(world, &gs, env_light, blocked, &mut values);
            } else {
                let lights = match direct {
                    Some(d) => per_sample(&gs, d, &mut rc.shadow),
                    None => rays.light_sums(blocked, gs.len()),
                };
                let env = environment.map(|e| per_sample(&gs, e, &mut rc.environment));
                rays.shade_given(
                    world,
                    &gs,
                    env_light,
                    (&lights, env.as_deref()),
                    blocked,
                    &mut values,
                );
                given_env = env;
            }
            // The Monte Carlo part: the environment's, given or summed from its rays (the
            // bounces' light is added below).
            let mut mc = if want_noisy {
                let env = given_env.unwrap_or_else(|| rays.environment_sums(blocked, gs.len()));
                gs.iter()
                    .zip(env)
                    .map(|(g, e)| match g.is_hit() {
                        true => crate::shade::monte_carlo_part(env_light, e),
                        false => Vec3::ZERO,
                    })
                    .collect()
            } else {
                Vec::new()
            };
            if bounce {
                // The keys of the hits, in order; misses get no bounce.
                let mut keys = hit_keys.iter().copied();
                let keys = gs.iter().map(|g| {
                    if g.is_hit() {
                        keys.next().unwrap_or(0)
                    } else {
                        0
                    }
                });
                let noisy = want_noisy.then_some(mc.as_mut_slice());
                add_bounces(
                    world,
                    &gs,
                    (env_light, bounces),
                    keys,
                    (&mut values, noisy),
                    &mut rc,
                );
            }
            (emit(&reps, values), rc, mc)
        };
        // Per batch: each texel's colour and depth, the batch's secondary rays, and the Monte
        // Carlo part of each surface sample (empty where not separated).
        type Batch = (Vec<Option<(Rgb, f32)>>, RayCounts, Vec<Vec3>);
        // Where the frame's `StageBackends` put the shade stage's parts.
        let on_executor = ShadeCast {
            shadow_rays: tracer.is_some() && decided.shadow_rays,
            direct_light: tracer.is_some() && decided.direct_light,
            environment_light: env_samples.is_some()
                && tracer.is_some()
                && decided.environment_light,
        };
        let blocks: Vec<Batch> = match tracer {
            None => order
                .par_chunks(SHADE_BATCH)
                .enumerate()
                .map(|(b, ks)| {
                    let (reps, gs, keys) = records(b * SHADE_BATCH, ks);
                    let mut rc = RayCounts::default();
                    let mut values = vec![Vec3::ZERO; gs.len()];
                    let mut mc = vec![Vec3::ZERO; if want_noisy { gs.len() } else { 0 }];
                    let parts = want_noisy.then_some(mc.as_mut_slice());
                    shade_direct_batch(world, &gs, &keys, env_light, &mut values, parts, &mut rc);
                    if bounce {
                        let noisy = want_noisy.then_some(mc.as_mut_slice());
                        add_bounces(
                            world,
                            &gs,
                            (env_light, bounces),
                            keys.iter().copied(),
                            (&mut values, noisy),
                            &mut rc,
                        );
                    }
                    (emit(&reps, values), rc, mc)
                })
                .collect(),
            Some(tracer) => {
                let shades = on_executor.direct_light;
                let env_on = on_executor.environment_light;
                let mut blocks = Vec::with_capacity(order.len().div_ceil(SHADE_BATCH));
                for (n, group) in order.chunks(SHADE_GROUP).enumerate() {
                    let parts = (!shades, !env_on);
                    let gathered: Vec<Gathered<'_>> = group
                        .par_chunks(SHADE_BATCH)
                        .enumerate()
                        .map(|(b, ks)| gather(n * SHADE_GROUP + b * SHADE_BATCH, ks, parts))
                        .collect();
                    let hits: Vec<&GSample> = gathered
                        .iter()
                        .flat_map(|g| g.0.iter().flatten().copied())
                        .filter(|g| g.is_hit())
                        .collect();
                    let rays: Vec<Ray> = gathered
                        .iter()
                        .flat_map(|g| g.1.rays.iter().copied())
                        .collect();
                    let got = tracer.occluded(&rays);
                    let blocked =
                        checked(tracer, "shade", ("answers", "shadow rays"), rays.len(), got)?;
                    let what = ("values", "surface samples");
                    // The lights' part of every surface sample of the group, in one call.
                    let direct = if shades {
                        let got = tracer.direct_light(&hits, &world.lights);
                        checked(tracer, "shade", what, hits.len(), got)?
                    } else {
                        Vec::new()
                    };
                    // The environment's part likewise.
                    let environment = match env_samples.filter(|_| env_on) {
                        Some(samples) => {
                            let keys: Vec<u64> =
                                gathered.iter().flat_map(|g| g.3.iter().copied()).collect();
                            let got = tracer.environment_light(&hits, &keys, samples);
                            checked(tracer, "shade", what, hits.len(), got)?
                        }
                        None => Vec::new(),
                    };
                    let (mut at, mut lit) = (0, 0);
                    let spans: Vec<(Gathered<'_>, &[bool], Given<'_>)> = gathered
                        .into_iter()
                        .map(|g| {
                            let n = g.1.rays.len();
                            at += n;
                            let hits = g.0.iter().flatten().filter(|g| g.is_hit()).count();
                            lit += hits;
                            let d = shades.then(|| &direct[lit - hits..lit]);
                            let e = env_on.then(|| &environment[lit - hits..lit]);
                            (g, &blocked[at - n..at], (d, e))
                        })
                        .collect();
                    let done: Vec<Batch> = spans
                        .into_par_iter()
                        .map(|(g, blocked, direct)| finish(g, blocked, direct))
                        .collect();
                    blocks.extend(done);
                }
                blocks
            }
        };
        for (ks, (values, rc, mc)) in order.chunks(SHADE_BATCH).zip(blocks) {
            counts.secondary += rc;
            let mut mc = mc.into_iter();
            for (&k, v) in ks.iter().zip(values) {
                let Some((c, d)) = v else { continue };
                depth[k as usize] = d;
                color[k as usize] = c;
                // One Monte Carlo part per record, in the records' order.
                if let (Some(n), Some(m)) = (noisy.as_deref_mut(), mc.next()) {
                    n[k as usize] = m.to_array();
                }
                if d.is_finite() {
                    counts.shaded += 1;
                }
            }
        }
        return Ok(on_executor);
    }
    type Shaded = (Option<Rgb>, f32, Option<SampleCull>, RayCounts, Option<Rgb>);
    let shaded: Vec<Option<Shaded>> = order
        .par_iter()
        .enumerate()
        .map(|(t, &k)| {
            let rays = &gbuf[starts[t] as usize..starts[t + 1] as usize];
            let n = rays.len();
            let rep = rays[plan.rays.pattern(n as u32).1]
                .as_ref()
                .or_else(|| rays.iter().flatten().next())?;
            let mut rc = RayCounts::default();
            let key = key_of_texel(k);
            // Sub-sample `s` of a texel draws its own random numbers.
            let key_of = |s: usize| subsample_key(key, s);
            let depth = camera.view_depth(-rep.to_eye, rep.t);
            // The mean over the texel's rays of the value and of its Monte Carlo part, `first`
            // the representative ray's.
            let mean_of_others = |first: (Vec3, Vec3), rc: &mut RayCounts| {
                let (mut sum, mut mc) = first;
                let mut m = 1.0f32;
                for (s, g) in rays.iter().enumerate() {
                    if let Some(g) = g.as_ref().filter(|g| !std::ptr::eq(*g, rep)) {
                        let (v, p) = shade_parts(world, g, shading, key_of(s), rc);
                        sum += v;
                        mc += p;
                        m += 1.0;
                    }
                }
                (sum / m, mc / m)
            };
            if let Some(culling) = cull {
                let (i, j) = (k % row_len as u32, j0 + k / row_len as u32);
                let keep = culling.keep(depth, i, j, key);
                let (v, info) = shade_or_cull(world, rep, shading, keep, key, &mut rc);
                let v = match v {
                    Some(v) if n > 1 => Some(mean_of_others((v, Vec3::ZERO), &mut rc).0),
                    v => v,
                };
                return Some((v.map(|v| v.to_array()), depth, Some(info), rc, None));
            }
            let parts = shade_parts(world, rep, shading, key, &mut rc);
            let (v, mc) = if n > 1 {
                mean_of_others(parts, &mut rc)
            } else {
                parts
            };
            Some((Some(v.to_array()), depth, None, rc, Some(mc.to_array())))
        })
        .collect();
    let chunk_start = j0 as usize * row_len;
    for (&k, s) in order.iter().zip(shaded) {
        let Some((c, d, info, rc, mc)) = s else {
            continue;
        };
        depth[k as usize] = d;
        if let (Some(n), Some(m)) = (noisy.as_deref_mut(), mc) {
            n[k as usize] = m;
        }
        counts.secondary += rc;
        let state = match c {
            Some(c) => {
                color[k as usize] = c;
                if d.is_finite() {
                    counts.shaded += 1;
                    1
                } else {
                    0
                }
            }
            None => {
                counts.culled += 1;
                2
            }
        };
        if let (Some(cb), Some(info)) = (cull_state.as_deref_mut(), info) {
            cb.record(chunk_start + k as usize, state, info);
        }
    }
    Ok(ShadeCast::default())
}

/// Adds [`indirect`] light of `bounces` bounces (the primary hits' environment light being
/// `env_light`) to the radiance of every surface sample of `gs` (`keys`: one per sample), its
/// rays counted in `counts`, and to the Monte Carlo part `noisy` when the denoiser wants it.
fn add_bounces(
    world: &World,
    gs: &[&GSample],
    (env_light, bounces): (EnvLight, u32),
    keys: impl Iterator<Item = u64>,
    (values, mut noisy): (&mut [Vec3], Option<&mut [Vec3]>),
    counts: &mut RayCounts,
) {
    for (i, (g, key)) in gs.iter().zip(keys).enumerate() {
        if g.is_hit() {
            let light = indirect(world, g, env_light, bounces, key, counts);
            values[i] += light;
            // The bounces' light is Monte Carlo throughout: the denoiser's to filter.
            if let Some(n) = noisy.as_deref_mut() {
                n[i] += light;
            }
        }
    }
}

/// What another executor did in a chunk's shading ([`shade_chunk`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadeCast {
    /// It cast the shadow rays (the environment's, and the lights' unless it computed the
    /// lights' part).
    pub shadow_rays: bool,
    /// It computed the lights' part of direct shading ([`TraceExecutor::direct_light`]).
    pub direct_light: bool,
    /// It computed the environment's part of direct shading
    /// ([`TraceExecutor::environment_light`]).
    pub environment_light: bool,
}

/// An executor's answer `got` for `expected` items of stage `stage` (what each answer is:
/// `what`, e.g. "hits for … rays"), as the renderer's error when it failed or gave another
/// number of answers.
fn checked<T>(
    tracer: &(dyn TraceExecutor + 'static),
    stage: &'static str,
    what: (&str, &str),
    expected: usize,
    got: std::result::Result<Vec<T>, String>,
) -> Result<Vec<T>> {
    let failed = |message: String| RenderError::Executor {
        stage,
        backend: tracer.backend().to_string(),
        message,
    };
    let got = got.map_err(failed)?;
    if got.len() != expected {
        return Err(failed(format!(
            "{} {} for {expected} {}",
            got.len(),
            what.0,
            what.1
        )));
    }
    Ok(got)
}

/// The denoiser's guides of `chunk` from its G-buffer (`gbuf`, texel-major from `starts`):
/// each texel's albedo and unit shading normal, averaged over its rays that hit a surface,
/// written into the chunk's rows `albedo` and `normal`; zero normal where no ray of the texel
/// hit (sky, untraced and prefilled texels: the denoiser leaves them as they are). The
/// chunk's rows of `noisy` are reset to NaN (unknown) for [`shade_chunk`] to fill.
pub fn record_guides(
    chunk: Chunk<'_>,
    starts: &[u32],
    gbuf: &[Option<GSample>],
    albedo: &mut [Rgb],
    normal: &mut [[f32; 3]],
    noisy: &mut [Rgb],
) {
    normal.fill([0.0; 3]);
    noisy.fill([f32::NAN; 3]);
    let values: Vec<Option<(Rgb, [f32; 3])>> = chunk
        .order
        .par_iter()
        .enumerate()
        .map(|(t, _)| {
            let rays = gbuf.get(starts[t] as usize..starts[t + 1] as usize)?;
            let (mut a, mut n, mut m) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
            for g in rays.iter().flatten().filter(|g| g.is_hit()) {
                a += g.albedo;
                n += g.normal;
                m += 1.0;
            }
            let n = n.normalize_or_zero();
            (m > 0.0 && n != Vec3::ZERO).then(|| ((a / m).to_array(), n.to_array()))
        })
        .collect();
    for (&k, v) in chunk.order.iter().zip(values) {
        if let Some((a, n)) = v {
            albedo[k as usize] = a;
            normal[k as usize] = n;
        }
    }
}

/// Trace and shade every layer of the plan into `samples` (sized and reset for the plan, or
/// holding the prefilled texels of `known`), chunk by chunk; then fill culled samples.
/// `progress(done, total)` is called after each chunk. With `tracer` (for `world`) the
/// primary rays are cast there, and so are the shadow rays of frames [`shade_chunk`] can hand
/// it. With `guides` (sized for the plan) each chunk's denoiser guides are recorded from its
/// G-buffer ([`record_guides`], timed as [`Stage::Denoise`]). Returns the counts and the
/// backends that cast the rays.
#[allow(clippy::too_many_arguments)]
pub fn trace_and_shade(
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
    known: Option<&[Image<bool>]>,
    samples: &mut SampleBuffers,
    mut guides: Option<&mut DenoiseGuides>,
    times: &mut StageTimes,
    mut tracer: Option<&mut (dyn TraceExecutor + 'static)>,
    backends: &StageBackends,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<TraceCounts> {
    let total = plan.sample_count;
    // The executor only where the frame's `StageBackends` put the trace (the world it
    // holds).
    if !backends.trace.on_executor() {
        tracer = None;
    }
    let decided = ShadeCast {
        shadow_rays: backends.shadow.on_executor(),
        direct_light: backends.direct_light.on_executor(),
        environment_light: backends.environment_light.on_executor(),
    };
    let mut counts = TraceCounts::default();
    let mut gbuf = Vec::new();
    for (layer, size) in plan.buffers.iter().enumerate() {
        let (bw, bh) = (size.width, size.height);
        let known = known.map(|k| &k[layer]);
        let mut cull_state = match plan.culling {
            Some(_) => Some(CullBuffers::new(bw, bh)?),
            None => None,
        };
        let rows_per_chunk = plan.tiles.rows_per_chunk(bw, plan.rays.most());
        let mut starts = Vec::new();
        let row_len = bw as usize;
        let chunk_order = plan.tiles.order(row_len, rows_per_chunk);
        let (color, depth) = (&mut samples.color[layer], &mut samples.depth[layer]);
        for (chunk_idx, (c_chunk, d_chunk)) in color
            .data_mut()
            .chunks_mut(rows_per_chunk * row_len)
            .zip(depth.data_mut().chunks_mut(rows_per_chunk * row_len))
            .enumerate()
        {
            let rows = c_chunk.len() / row_len;
            let last_order;
            let order = if rows == rows_per_chunk {
                &chunk_order
            } else {
                last_order = plan.tiles.order(row_len, rows);
                &last_order
            };
            let chunk = Chunk {
                layer: layer as u32,
                j0: (chunk_idx * rows_per_chunk) as u32,
                row_len,
                order,
            };
            ray_starts(plan, chunk, &mut starts);
            let t = Stopwatch::start();
            trace_chunk(
                world,
                camera,
                plan,
                chunk,
                &starts,
                known,
                tracer.as_deref_mut(),
                (
                    backends.ray_generation.on_executor(),
                    backends.surface.on_executor(),
                ),
                &mut gbuf,
            )?;
            times.add(Stage::Trace, &t);
            counts.primary += gbuf.iter().filter(|g| g.is_some()).count() as u64;
            let start = chunk_idx * rows_per_chunk * row_len;
            let span = start..start + c_chunk.len();
            if let Some(g) = guides.as_deref_mut() {
                let t = Stopwatch::start();
                record_guides(
                    chunk,
                    &starts,
                    &gbuf,
                    &mut g.albedo[layer].data_mut()[span.clone()],
                    &mut g.normal[layer].data_mut()[span.clone()],
                    &mut g.noisy[layer].data_mut()[span.clone()],
                );
                times.add(Stage::Denoise, &t);
            }

            let t = Stopwatch::start();
            let cs = cull_state.as_mut();
            shade_chunk(
                world,
                camera,
                plan,
                chunk,
                &starts,
                &gbuf,
                c_chunk,
                d_chunk,
                guides
                    .as_deref_mut()
                    .map(|g| &mut g.noisy[layer].data_mut()[span.clone()]),
                cs,
                &mut counts,
                tracer.as_deref_mut().filter(|_| decided.shadow_rays),
                decided,
            )?;
            times.add(Stage::Shade, &t);
            progress(counts.primary.min(total), total);
        }
        // Culled samples get their colour from the shaded ones before any filtering.
        if let Some(cb) = cull_state.filter(|cb| cb.state.data().contains(&2)) {
            let t = Stopwatch::start();
            samples.color[layer] = fill_culled(&samples.color[layer], &samples.depth[layer], &cb)?;
            times.add(Stage::CullFill, &t);
        }
    }
    Ok(counts)
}
