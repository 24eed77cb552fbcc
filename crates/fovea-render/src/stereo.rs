//! Binocular frames (VaFR Sec. 5.1 and 9: VaFR_Dup and VaFR_Rep).
//!
//! * **Dup** renders both eyes through the foveated pipeline, each with its own camera and
//!   gaze.
//! * **Rep** renders the left eye, then forward-warps the left eye's shaded sample buffer into
//!   the right eye's: every left texel's world point (texel centre through the inverse mapping,
//!   at its depth) is projected into the right camera and through the right eye's forward
//!   mapping, and lands in the texel containing it, nearest surface first (a z-buffer in the
//!   right buffer). Misses (sky) warp as directions and never cover a surface. Cracks — right
//!   texels left empty where the warped samples spread apart — are filled from their
//!   neighbours when at least three of the four around are covered and agree in depth within
//!   2 %; everything else (disocclusions, the screen edge the left eye does not see) is traced.
//!   Only those holes cost primary rays and shading; AA and reconstruction then run on the
//!   right buffer as usual.
//!
//! The warp copies the left eye's radiance: view-dependent shading (specular highlights)
//! is seen from the left eye's position, the approximation VaFR_Rep makes.

use rayon::prelude::*;
use serde::Serialize;

use fovea_core::mapping::{FoveationMapping, SamplePoint};
use fovea_core::Image;
use fovea_post::grid::Grid;
use fovea_post::Rgb;

use crate::camera::{Eye, EyeCamera, HmdRig};
use crate::error::{RenderError, Result};
use crate::eye::EyeState;
use crate::pipeline::{
    in_lockstep, render_planned, Frame, FrameContext, FrameInputs, FrameSettings, Lockstep,
    Prefill, Stage, StageTimes, Stopwatch,
};
use crate::plan::FramePlan;
use crate::world::World;

/// How the second eye is produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StereoMode {
    /// Both eyes rendered (VaFR_Dup).
    Dup,
    /// Right eye reprojected from the left eye's buffer, holes traced (VaFR_Rep).
    Rep,
}

impl StereoMode {
    /// Parses `dup` or `rep`.
    pub fn parse(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "dup" => Ok(StereoMode::Dup),
            "rep" => Ok(StereoMode::Rep),
            _ => Err(RenderError::invalid("stereo", s, "dup or rep")),
        }
    }

    /// `dup` or `rep`.
    pub fn name(self) -> &'static str {
        match self {
            StereoMode::Dup => "dup",
            StereoMode::Rep => "rep",
        }
    }
}

/// Counts of a binocular frame.
#[derive(Clone, Debug, Serialize)]
pub struct StereoStats {
    /// The mode.
    pub mode: StereoMode,
    /// Primary rays of the left eye.
    pub rays_primary_left: u64,
    /// Primary rays of the right eye (Rep: the holes only).
    pub rays_primary_right: u64,
    /// Both eyes.
    pub rays_primary: u64,
    /// Rep: right texels covered by warped left samples.
    pub warped: u64,
    /// Rep: right texels filled from covered neighbours (cracks).
    pub cracks_filled: u64,
    /// Rep: right texels traced (disocclusions, unseen edges).
    pub holes_traced: u64,
    /// Wall time of both eyes, milliseconds.
    pub total_ms: f64,
    /// Rep: wall time of the warp and crack fill, milliseconds.
    pub warp_ms: f64,
}

/// A binocular frame.
pub struct StereoFrame {
    /// Left eye.
    pub left: Frame,
    /// Right eye.
    pub right: Frame,
    /// Counts.
    pub stats: StereoStats,
}

/// The world point the gaze fixates: the first surface on the ray through `gaze` of `camera`
/// (10 m along it where nothing is hit).
pub fn fixation_point(
    world: &World,
    camera: &EyeCamera,
    gaze: &fovea_core::display::Gaze,
) -> glam::Vec3 {
    let ray = camera.ray(gaze.point);
    let g = crate::trace::trace_sample(world, &ray, 0.0);
    let t = if g.t.is_finite() { g.t } else { 10.0 };
    ray.origin + ray.dir * t
}

/// Both eyes of `rig` on `display` fixating the cyclopean eye's `gaze` (through
/// [`fixation_point`]): the point and `[(left camera, left gaze), (right camera, right
/// gaze)]`, each gaze clamped onto the screen.
pub fn fixating_eyes(
    world: &World,
    rig: &HmdRig,
    display: &fovea_core::display::DisplayProfile,
    gaze: &fovea_core::display::Gaze,
) -> Result<(glam::Vec3, [(EyeCamera, fovea_core::display::Gaze); 2])> {
    let centre = rig.eye(Eye::Centre, display)?;
    let target = fixation_point(world, &centre, gaze);
    let one = |eye: Eye| -> Result<(EyeCamera, fovea_core::display::Gaze)> {
        let cam = rig.eye(eye, display)?;
        let q = cam.screen_point_of(target - cam.position).ok_or_else(|| {
            RenderError::invalid(
                "gaze",
                format!("{target}"),
                format!("a fixated point in front of the {eye:?} eye"),
            )
        })?;
        let g = display.gaze(
            q.x_px.clamp(0.0, display.width_px as f64),
            q.y_px.clamp(0.0, display.height_px as f64),
        )?;
        Ok((cam, g))
    };
    Ok((target, [one(Eye::Left)?, one(Eye::Right)?]))
}

impl StereoFrame {
    /// Both eyes with their counts.
    #[allow(clippy::too_many_arguments)]
    fn new(
        mode: StereoMode,
        left: Frame,
        right: Frame,
        warped: u64,
        cracks_filled: u64,
        holes_traced: u64,
        t0: std::time::Instant,
        warp_ms: f64,
    ) -> Self {
        let (l, r) = (left.stats.rays_primary, right.stats.rays_primary);
        let stats = StereoStats {
            mode,
            rays_primary_left: l,
            rays_primary_right: r,
            rays_primary: l + r,
            warped,
            cracks_filled,
            holes_traced,
            total_ms: t0.elapsed().as_secs_f64() * 1e3,
            warp_ms,
        };
        Self { left, right, stats }
    }
}

/// Renders both eyes of `settings`, each eye with its own camera and [`EyeState`] (gaze,
/// focus): one frame plan per eye, built once and read by the warp.
pub fn render_stereo(
    world: &World,
    left_camera: &EyeCamera,
    right_camera: &EyeCamera,
    settings: &FrameSettings,
    eyes: [EyeState; 2],
    mode: StereoMode,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<StereoFrame> {
    let mut ctx = FrameContext::new();
    render_stereo_in(
        &mut ctx,
        None,
        world,
        left_camera,
        right_camera,
        settings,
        eyes,
        mode,
        progress,
    )
}

/// The right eye's own context of a binocular frame whose eyes render at the same time
/// ([`crate::pipeline::lockstep`]): its buffers, executors that share the device of the left
/// context's, and where the two eyes' submissions meet.
pub struct SecondEye<'a> {
    /// The right eye's context (its executors run on the same device as the left's).
    pub ctx: &'a mut FrameContext,
    /// The device's meeting point for both eyes' submissions.
    pub lockstep: &'a dyn Lockstep,
}

impl<'a> SecondEye<'a> {
    /// The second eye of `pair` — a context and its device's meeting point, as a backend
    /// offers them — if there is one.
    pub fn of(
        pair: &'a mut Option<(FrameContext, std::sync::Arc<dyn Lockstep + Send + Sync>)>,
    ) -> Option<Self> {
        pair.as_mut().map(|(ctx, lockstep)| SecondEye {
            ctx,
            lockstep: &**lockstep,
        })
    }
}

/// [`render_stereo`] in the caller's context: both eyes run through its executors (a GPU's
/// tracer and reconstructor, [`FrameContext::set_tracer`]) and reuse its buffers; each eye's
/// frame is taken out of it. Dup with a `second` eye's context renders the eyes at the same
/// time, the right in that context, their device work in shared submissions
/// ([`in_lockstep`]); otherwise, and always for Rep (whose right eye starts from the left
/// eye's samples), one after the other.
#[allow(clippy::too_many_arguments)]
pub fn render_stereo_in(
    ctx: &mut FrameContext,
    second: Option<SecondEye<'_>>,
    world: &World,
    left_camera: &EyeCamera,
    right_camera: &EyeCamera,
    settings: &FrameSettings,
    eyes: [EyeState; 2],
    mode: StereoMode,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<StereoFrame> {
    let t0 = std::time::Instant::now();
    let plan_of =
        |camera: &EyeCamera, eye: &EyeState, keep: bool| -> Result<(FramePlan, StageTimes)> {
            let mut times = StageTimes::default();
            let t = Stopwatch::start();
            let mut s = settings.clone();
            s.keep_samples |= keep;
            // The right eye draws its own random numbers (`crate::shade::frame_noise`).
            let index = u32::from(std::ptr::eq(camera, right_camera));
            let plan = FramePlan::new(world, camera, &s, eye, [0.0, 0.0])?
                .with_noise(crate::shade::FrameNoise::new(0, index));
            times.add(Stage::Plan, &t);
            Ok((plan, times))
        };
    // One eye's frame in `ctx`, taken out of it.
    let render_in = |ctx: &mut FrameContext,
                     camera: &EyeCamera,
                     plan: &FramePlan,
                     times: StageTimes,
                     prefill: Option<&Prefill>|
     -> Result<Frame> {
        let inputs = FrameInputs {
            accumulator: None,
            prefill,
        };
        render_planned(ctx, world, camera, plan, inputs, times, progress)?;
        ctx.take_frame()
            .ok_or_else(|| RenderError::Unsupported("the eye's frame was not stored".into()))
    };
    match (mode, second) {
        (
            StereoMode::Dup,
            Some(SecondEye {
                ctx: right_ctx,
                lockstep,
            }),
        ) => {
            // Each eye plans and renders on its own thread.
            let eye = |ctx: &mut FrameContext, camera: &EyeCamera, eye: &EyeState| {
                let (plan, times) = plan_of(camera, eye, false)?;
                render_in(ctx, camera, &plan, times, None)
            };
            let (l, r) = in_lockstep(
                lockstep,
                || eye(ctx, left_camera, &eyes[0]),
                || eye(right_ctx, right_camera, &eyes[1]),
            )?;
            Ok(StereoFrame::new(mode, l, r, 0, 0, 0, t0, 0.0))
        }
        (StereoMode::Dup, None) => {
            let (lp, lt) = plan_of(left_camera, &eyes[0], false)?;
            let l = render_in(ctx, left_camera, &lp, lt, None)?;
            let (rp, rt) = plan_of(right_camera, &eyes[1], false)?;
            let r = render_in(ctx, right_camera, &rp, rt, None)?;
            Ok(StereoFrame::new(mode, l, r, 0, 0, 0, t0, 0.0))
        }
        (StereoMode::Rep, _) => {
            let (lp, lt) = plan_of(left_camera, &eyes[0], true)?;
            let mut l = render_in(ctx, left_camera, &lp, lt, None)?;
            let samples = l
                .samples
                .take()
                .ok_or_else(|| RenderError::Unsupported("the left eye kept no samples".into()))?;
            let (rp, rt) = plan_of(right_camera, &eyes[1], false)?;
            let tw = std::time::Instant::now();
            let (prefill, warped) = warp(
                lp.mapping(),
                left_camera,
                &samples.color,
                &samples.depth,
                rp.mapping(),
                right_camera,
            )?;
            let (prefill, cracks) = fill_cracks(rp.mapping(), prefill);
            let warp_ms = tw.elapsed().as_secs_f64() * 1e3;
            let r = render_in(ctx, right_camera, &rp, rt, Some(&prefill))?;
            let holes = r.stats.rays_primary;
            Ok(StereoFrame::new(
                mode, l, r, warped, cracks, holes, t0, warp_ms,
            ))
        }
    }
}

/// Forward warp of the left sample buffers into the right mapping's buffers.
fn warp(
    lm: &dyn FoveationMapping,
    left: &EyeCamera,
    color: &[Image<Rgb>],
    depth: &[Image<f32>],
    rm: &dyn FoveationMapping,
    right: &EyeCamera,
) -> Result<(Prefill, u64)> {
    let sizes = rm.buffers();
    let mut out = Prefill {
        color: Vec::with_capacity(sizes.len()),
        depth: Vec::with_capacity(sizes.len()),
        known: Vec::with_capacity(sizes.len()),
    };
    for b in &sizes {
        out.color.push(Image::new(b.width, b.height, [0.0f32; 3])?);
        out.depth
            .push(Image::new(b.width, b.height, f32::INFINITY)?);
        out.known.push(Image::new(b.width, b.height, false)?);
    }
    // Where each left texel lands: (layer, i, j, right depth, colour); computed in parallel,
    // resolved with the z-test in order.
    type Hit = (u32, u32, u32, f32, Rgb);
    for (l, (c, d)) in color.iter().zip(depth).enumerate() {
        let layer = l as u32;
        let w = c.width() as usize;
        let hits: Vec<Hit> = (0..w * c.height() as usize)
            .into_par_iter()
            .filter_map(|k| {
                let (i, j) = ((k % w) as u32, (k / w) as u32);
                if !lm.is_shaded(layer, i, j) {
                    return None;
                }
                let p = lm.inverse(SamplePoint {
                    layer,
                    u: i as f64 + 0.5,
                    v: j as f64 + 0.5,
                })?;
                let dir = left.direction(p.x_px as f32, p.y_px as f32);
                let z = *d.get(i, j);
                let (q, zr) = if z.is_finite() {
                    let cos = dir.dot(left.forward);
                    if cos <= 1e-6 {
                        return None;
                    }
                    let world = left.position + dir * (z / cos);
                    let rel = world - right.position;
                    (right.screen_point_of(rel)?, rel.dot(right.forward))
                } else {
                    (right.screen_point_of(dir)?, f32::INFINITY)
                };
                let s = rm.forward(q)?;
                let (ti, tj) = (s.u.floor(), s.v.floor());
                if !(ti >= 0.0 && tj >= 0.0) {
                    return None;
                }
                let (ti, tj) = (ti as u32, tj as u32);
                let b = sizes.get(s.layer as usize)?;
                if ti >= b.width || tj >= b.height || !rm.is_shaded(s.layer, ti, tj) {
                    return None;
                }
                Some((s.layer, ti, tj, zr, *c.get(i, j)))
            })
            .collect();
        for (rl, ti, tj, zr, col) in hits {
            let rl = rl as usize;
            let known = *out.known[rl].get(ti, tj);
            let cur = *out.depth[rl].get(ti, tj);
            // Surfaces win over sky; the nearer surface wins.
            if !known || zr < cur {
                *out.depth[rl].get_mut(ti, tj) = zr;
                *out.color[rl].get_mut(ti, tj) = col;
                *out.known[rl].get_mut(ti, tj) = true;
            }
        }
    }
    let warped = out
        .known
        .iter()
        .map(|k| k.data().iter().filter(|&&b| b).count() as u64)
        .sum();
    Ok((out, warped))
}

/// Fills empty texels that have at least three covered neighbours (of four) agreeing in depth
/// within 2 % (or all sky) with their mean; returns the count.
fn fill_cracks(rm: &dyn FoveationMapping, mut p: Prefill) -> (Prefill, u64) {
    let polar = rm.polar_layout();
    let mut filled = 0;
    for l in 0..p.color.len() {
        let (w, h) = (p.color[l].width(), p.color[l].height());
        let grid = Grid::of_layer(polar.as_ref(), w, h);
        let layer = l as u32;
        let (known, color, depth) = (&p.known[l], &p.color[l], &p.depth[l]);
        let fills: Vec<(u32, u32, Rgb, f32)> = (0..w as usize * h as usize)
            .into_par_iter()
            .filter_map(|k| {
                let (i, j) = ((k % w as usize) as u32, (k / w as usize) as u32);
                if *known.get(i, j) || !rm.is_shaded(layer, i, j) {
                    return None;
                }
                let mut n = Vec::with_capacity(4);
                for (di, dj) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                    let (ni, nj) = grid.step(i, j, di, dj);
                    if (ni, nj) != (i, j) && grid.valid(ni, nj) && *known.get(ni, nj) {
                        n.push((*color.get(ni, nj), *depth.get(ni, nj)));
                    }
                }
                if n.len() < 3 {
                    return None;
                }
                let sky = n.iter().filter(|x| !x.1.is_finite()).count();
                let z = if sky == n.len() {
                    f32::INFINITY
                } else if sky > 0 {
                    return None;
                } else {
                    let (lo, hi) = n
                        .iter()
                        .fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x.1), b.max(x.1)));
                    if hi > lo * 1.02 {
                        return None;
                    }
                    n.iter().map(|x| x.1).sum::<f32>() / n.len() as f32
                };
                let mut c = [0.0f32; 3];
                for x in &n {
                    for ch in 0..3 {
                        c[ch] += x.0[ch] / n.len() as f32;
                    }
                }
                Some((i, j, c, z))
            })
            .collect();
        for (i, j, c, z) in fills {
            *p.color[l].get_mut(i, j) = c;
            *p.depth[l].get_mut(i, j) = z;
            *p.known[l].get_mut(i, j) = true;
            filled += 1;
        }
    }
    (p, filled)
}
