//! The binocular frame resident against staged, side by side in one run (issue 37, "counted,
//! not estimated" and "faster where it can be measured"): what `fovea bench --backend gpu
//! --eyes both` runs for each display and method.
//!
//! Every frame moves the gaze along a [`GazePath`] (a saccade-sized step by default), and
//! each path renders that frame's both eyes from scratch:
//!
//! 1. **eye state and plans** (host): the cyclopean gaze of the frame, both eyes' gazes at the
//!    point it fixates (`fovea_render::stereo::fixating_eyes`), each eye's state
//!    (`EyeState::fixating`: the focus where a DOF asks for one) and plan
//!    (`FramePlan::cached`, a cache per eye and path, as a view renderer keeps one; its gazes
//!    forgotten every frame of a moving path (`PlanCache::forget_gazes`), so that every moving
//!    frame plans afresh — the saccade path's square returns to its corners every fourth
//!    frame, a tracked gaze never does);
//! 2. **the frame**: resident — [`ResidentRun::render`] (one encoder, one submission, no wait,
//!    counted by the device), then a wait for the device outside the counts, to read the wall
//!    clock; staged — `render_planned` of each eye with the library's per-call GPU executors
//!    (`crate::executors::GpuExecutors`) and their tone map of each eye, as `fovea render
//!    --backend gpu` ran them before the resident frame.
//!
//! Per path and frame: wall and process CPU ms (`fovea_render::pipeline::Stopwatch`), the host
//! time (resident: eye state and plans plus the frame's recording, [`FrameCounts::host_ms`];
//! without `queue.submit` and device waits) in wall ms and in the render thread's CPU ms (its
//! own clock: on a shared machine the wall time also holds the time the thread waited for a
//! core), the plans built, and the device's counters over the frame. The
//! first `warmup` frames (buffers made, pipelines compiled) are rendered and not reported. The
//! route is decided once, on the first frame's plans ([`Route::decide`]); a refused plan runs
//! the staged path only, the reason recorded.

use std::collections::BTreeMap;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_render::camera::{EyeCamera, HmdRig};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, StageTimes, Stopwatch,
};
use fovea_render::plan::{FramePlan, PlanCache};
use fovea_render::shade::FrameNoise;
use fovea_render::stereo::fixating_eyes;
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};
use fovea_render::world::World;
use serde::Serialize;

use super::binocular::{thread_cpu, thread_cpu_ms, ToneSettings};
use super::gaze_path::GazePath;
use super::run::{FrameCounts, Route};
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::executors::GpuExecutors;

/// What to compare (see the module).
pub struct CompareParams<'a> {
    /// The scene.
    pub world: &'a World,
    /// The headset rig the eyes' cameras come from.
    pub rig: &'a HmdRig,
    /// Each eye's display.
    pub display: &'a DisplayProfile,
    /// The frame's settings (method, shading, AA, DOF, …).
    pub settings: &'a FrameSettings,
    /// How the gaze moves, and its start (the cyclopean gaze of frame 0).
    pub path: GazePath,
    /// The start of the path.
    pub start: Gaze,
    /// The path's step, degrees a frame.
    pub step_deg: f64,
    /// Frames rendered first and not reported.
    pub warmup: usize,
    /// Frames reported.
    pub frames: usize,
    /// Whether the staged path runs beside the resident one.
    pub staged: bool,
    /// The tone map both paths end with.
    pub tone: ToneSettings,
    /// Temporal accumulation on both paths (`None`: off): the resident frame's pass
    /// ([`super::ResidentFrame::set_temporal`]), the staged path's CPU accumulator per eye;
    /// frame `f` draws the random numbers of noise index `f` on both.
    pub temporal: Option<TemporalSettings>,
}

/// One path's binocular frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PathFrame {
    /// Wall ms from the eye state to the device's last pass (resident: its wait; staged: the
    /// second eye's tone map read back).
    pub wall_ms: f64,
    /// Process CPU ms over the same span (every thread, lavapipe's included).
    pub cpu_ms: f64,
    /// Eye state and both plans, ms.
    pub plan_ms: f64,
    /// The render thread's CPU time over the eye state and both plans, ms.
    pub plan_cpu_ms: f64,
    /// Plans whose mapping and tables were built this frame (plan-cache misses; 2 a frame
    /// wherever the gaze moves, since a moving gaze plans afresh: see the module).
    pub plans_built: u64,
    /// The render thread's host time: eye state and plans plus the frame's checks, tables,
    /// uniforms and recording, without `queue.submit` and device waits, ms (resident only).
    pub host_ms: Option<f64>,
    /// The render thread's CPU time over the same spans, ms (resident only): the host time
    /// without the time the thread waited for a core on a shared machine.
    pub host_cpu_ms: Option<f64>,
    /// The device's counters over the frame (resident: [`ResidentRun::render`]'s; staged:
    /// both eyes' passes and tone maps); `host_ms` there is the recording's share.
    pub counts: FrameCounts,
}

/// One reported frame of both paths.
#[derive(Clone, Debug, Serialize)]
pub struct ComparedFrame {
    /// The frame's index (warmup frames included).
    pub frame: usize,
    /// The cyclopean gaze, pixels.
    pub gaze_px: [f64; 2],
    /// The resident frame's (`None` when staged).
    pub resident: Option<PathFrame>,
    /// The staged path's (`None` when not run).
    pub staged: Option<PathFrame>,
}

/// One path over the reported frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PathSummary {
    /// Median wall ms per binocular frame.
    pub wall_ms: f64,
    /// Median process CPU ms per binocular frame.
    pub cpu_ms: f64,
    /// Process CPU share: median CPU / median wall (1 = one core busy).
    pub cpu_share: f64,
    /// Binocular frames per second at the median wall time.
    pub fps: f64,
    /// Median eye state and plans, ms.
    pub plan_ms: f64,
    /// Median render-thread CPU over the eye state and plans, ms.
    pub plan_cpu_ms: f64,
    /// Plans built over the reported frames (plan-cache misses).
    pub plans_built: u64,
    /// Median host ms (resident only).
    pub host_ms: Option<f64>,
    /// Largest host ms of a frame (resident only).
    pub host_ms_max: Option<f64>,
    /// Median render-thread CPU ms over the host spans (resident only).
    pub host_cpu_ms: Option<f64>,
    /// Largest render-thread CPU ms of a frame's host spans (resident only).
    pub host_cpu_ms_max: Option<f64>,
    /// The render thread's share of the host wall time: median host CPU / median host ms
    /// (1: it ran the whole span; less: it waited for a core).
    pub host_cpu_share: Option<f64>,
    /// Median recording ms (resident: checks, tables, uniforms, recording).
    pub record_ms: f64,
    /// Median render-thread CPU ms of the recording (resident only; NaN staged).
    pub record_cpu_ms: f64,
    /// The most a frame uploaded, bytes.
    pub bytes_uploaded_max: u64,
    /// The most a frame read back, bytes.
    pub bytes_read_back_max: u64,
    /// The most submissions of a frame.
    pub submissions_max: u64,
    /// The most blocking waits of a frame.
    pub blocking_waits_max: u64,
    /// The most buffers a frame created.
    pub buffers_created_max: u64,
}

/// The comparison's result (see the module).
#[derive(Clone, Debug, Serialize)]
pub struct BinocularComparison {
    /// The display's name and size of each eye.
    pub display: String,
    pub width: u32,
    pub height: u32,
    /// The method.
    pub method: String,
    /// The gaze path and its step, degrees.
    pub gaze_path: &'static str,
    pub step_deg: f64,
    /// Whether both paths accumulated temporally.
    pub temporal: bool,
    /// Frames reported (after the warmup).
    pub frames: usize,
    /// `"resident"` or `"staged"`: where the tool's frames go.
    pub route: &'static str,
    /// Why the frames are staged, one line (`None` when resident).
    pub staged_because: Option<String>,
    /// The resident frame's summary.
    pub resident: Option<PathSummary>,
    /// The staged path's summary.
    pub staged: Option<PathSummary>,
    /// Staged median wall over resident median wall (> 1: the resident frame is faster).
    pub staged_over_resident_wall: Option<f64>,
    /// Staged median CPU over resident median CPU.
    pub staged_over_resident_cpu: Option<f64>,
    /// The resident frame's GPU ms per pass, the median over the frames whose timestamps
    /// arrived (late, without waiting); empty without timestamp queries.
    pub resident_gpu_pass_ms: BTreeMap<String, f64>,
    /// Every reported frame.
    pub per_frame: Vec<ComparedFrame>,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn summary(frames: &[PathFrame]) -> Option<PathSummary> {
    if frames.is_empty() {
        return None;
    }
    let med = |f: fn(&PathFrame) -> f64| median(frames.iter().map(f).collect());
    let max = |f: fn(&PathFrame) -> u64| frames.iter().map(f).max().unwrap_or(0);
    let (wall, cpu) = (med(|f| f.wall_ms), med(|f| f.cpu_ms));
    let hosts: Vec<f64> = frames.iter().filter_map(|f| f.host_ms).collect();
    let host_max = hosts.iter().copied().reduce(f64::max);
    let host_cpus: Vec<f64> = frames.iter().filter_map(|f| f.host_cpu_ms).collect();
    let host_cpu_max = host_cpus.iter().copied().reduce(f64::max);
    let host = (!hosts.is_empty()).then(|| median(hosts));
    let host_cpu = (!host_cpus.is_empty()).then(|| median(host_cpus));
    Some(PathSummary {
        wall_ms: wall,
        cpu_ms: cpu,
        cpu_share: cpu / wall.max(1e-9),
        fps: 1e3 / wall.max(1e-9),
        plan_ms: med(|f| f.plan_ms),
        plan_cpu_ms: med(|f| f.plan_cpu_ms),
        plans_built: frames.iter().map(|f| f.plans_built).sum(),
        host_ms: host,
        host_ms_max: host_max,
        host_cpu_ms: host_cpu,
        host_cpu_ms_max: host_cpu_max,
        host_cpu_share: host.zip(host_cpu).map(|(w, c)| c / w.max(1e-9)),
        record_ms: med(|f| f.counts.host_ms),
        record_cpu_ms: med(|f| f.counts.host_cpu_ms),
        bytes_uploaded_max: max(|f| f.counts.bytes_uploaded),
        bytes_read_back_max: max(|f| f.counts.bytes_read_back),
        submissions_max: max(|f| f.counts.submissions),
        blocking_waits_max: max(|f| f.counts.blocking_waits),
        buffers_created_max: max(|f| f.counts.buffers_created),
    })
}

/// Both eyes' cameras and plans of frame `f` (caches per eye), the cyclopean gaze, and how
/// many of the plans were built (cache misses). A moving gaze plans every frame afresh: its
/// caches forget their gazes first, since a tracked gaze never returns to a point bit for
/// bit (the saccade path's square does, every fourth frame).
fn plans_of(
    p: &CompareParams<'_>,
    f: usize,
    caches: &mut [PlanCache; 2],
) -> Result<([EyeCamera; 2], [FramePlan; 2], Gaze, u64)> {
    let render = |e: fovea_render::RenderError| GpuError::Input(e.to_string());
    if p.path != GazePath::Still {
        for c in caches.iter_mut() {
            c.forget_gazes();
        }
    }
    let misses = |c: &[PlanCache; 2]| c[0].misses() + c[1].misses();
    let before = misses(caches);
    let gaze = p.path.gaze(p.display, p.start, f, p.step_deg)?;
    let (_, [(lc, lg), (rc, rg)]) =
        fixating_eyes(p.world, p.rig, p.display, &gaze).map_err(render)?;
    let dof = p.settings.dof.as_ref();
    let mut plan = |e: usize, cam: &EyeCamera, g: Gaze| -> Result<FramePlan> {
        let eye = EyeState::fixating(p.world, cam, g, dof).map_err(render)?;
        Ok(
            FramePlan::cached(p.world, cam, p.settings, &eye, [0.0, 0.0], &mut caches[e])
                .map_err(render)?
                .with_noise(FrameNoise::new(f as u64, e as u32)),
        )
    };
    let plans = [plan(0, &lc, lg)?, plan(1, &rc, rg)?];
    let built = misses(caches) - before;
    Ok(([lc, rc], plans, gaze, built))
}

/// Runs the comparison on `ctx` (see the module).
pub fn compare_binocular(ctx: &GpuContext, p: &CompareParams<'_>) -> Result<BinocularComparison> {
    if p.frames == 0 {
        return Err(GpuError::Input("0 frames to compare (1 or more)".into()));
    }
    if p.temporal.is_some_and(|t| t.jitter) {
        return Err(GpuError::Input(
            "temporal jitter in the comparison (its plans are not jittered; jitter off)".into(),
        ));
    }
    let world = p.world;
    let mut caches = [PlanCache::new(), PlanCache::new()];
    let (cams, plans, _, _) = plans_of(p, 0, &mut caches)?;
    // Temporal accumulation the resident frame does not run (Weier's, several sample layers') stages the frames.
    let temporal_refusal = p.temporal.and_then(|_| {
        plans
            .iter()
            .find_map(|pl| super::ResidentFrame::supports_temporal(pl).err())
    });
    let mut route = match temporal_refusal {
        Some(GpuError::Unsupported(what)) => Route::Staged(format!("not served: {what}")),
        Some(e) => return Err(e),
        None => Route::decide(
            ctx,
            world,
            [&plans[0], &plans[1]],
            [&cams[0], &cams[1]],
            p.tone,
        )?,
    };
    if let Route::Resident(run) = &mut route {
        run.set_temporal(p.temporal)?;
    }
    let mut staged = if p.staged || matches!(route, Route::Staged(_)) {
        let gx = GpuExecutors::new(ctx, world)?;
        let mut fc = FrameContext::new();
        fc.set_executors(gx.first);
        let accumulators = match p.temporal {
            Some(t) => {
                let acc =
                    || TemporalAccumulator::new(t).map_err(|e| GpuError::Input(e.to_string()));
                Some([acc()?, acc()?])
            }
            None => None,
        };
        Some((
            fc,
            gx.tone_map,
            [PlanCache::new(), PlanCache::new()],
            accumulators,
        ))
    } else {
        None
    };
    let render = |e: fovea_render::RenderError| GpuError::Input(e.to_string());
    let mut per_frame = Vec::new();
    let mut gpu_passes: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for f in 0..p.warmup + p.frames {
        let mut row = ComparedFrame {
            frame: f,
            gaze_px: [0.0; 2],
            resident: None,
            staged: None,
        };
        if let Route::Resident(run) = &mut route {
            let sw = Stopwatch::start();
            let cpu = thread_cpu();
            let (cams, plans, gaze, plans_built) = plans_of(p, f, &mut caches)?;
            let plan_ms = sw.elapsed_ms().0;
            let plan_cpu_ms = thread_cpu_ms(cpu);
            row.gaze_px = [gaze.point.x_px, gaze.point.y_px];
            let counts = run.render(world, [&plans[0], &plans[1]], [&cams[0], &cams[1]])?;
            run.finish()?;
            let (wall_ms, cpu_ms) = sw.elapsed_ms();
            row.resident = Some(PathFrame {
                wall_ms,
                cpu_ms,
                plan_ms,
                plan_cpu_ms,
                plans_built,
                host_ms: Some(plan_ms + counts.host_ms),
                host_cpu_ms: Some(plan_cpu_ms + counts.host_cpu_ms),
                counts,
            });
            for g in run.gpu_times()? {
                if (g.frame as usize) < p.warmup {
                    continue;
                }
                for (name, ms) in g.passes {
                    if let Some(ms) = ms {
                        gpu_passes.entry(name.to_string()).or_default().push(ms);
                    }
                }
            }
        }
        if let Some((fc, tone, caches, accumulators)) = &mut staged {
            let before = ctx.traffic();
            let sw = Stopwatch::start();
            let cpu = thread_cpu();
            let (cams, plans, gaze, plans_built) = plans_of(p, f, caches)?;
            let plan_ms = sw.elapsed_ms().0;
            let plan_cpu_ms = thread_cpu_ms(cpu);
            row.gaze_px = [gaze.point.x_px, gaze.point.y_px];
            for e in 0..2 {
                let frame = render_planned(
                    fc,
                    world,
                    &cams[e],
                    &plans[e],
                    FrameInputs {
                        accumulator: accumulators.as_mut().map(|a| &mut a[e]),
                        prefill: None,
                    },
                    StageTimes::default(),
                    &|_, _| {},
                )
                .map_err(render)?;
                tone.to_srgb8(&frame.color, p.tone.exposure_stops, p.tone.curve)
                    .map_err(|e| GpuError::Input(e.to_string()))?;
            }
            let (wall_ms, cpu_ms) = sw.elapsed_ms();
            let moved = ctx.traffic().since(&before);
            row.staged = Some(PathFrame {
                wall_ms,
                cpu_ms,
                plan_ms,
                plan_cpu_ms,
                plans_built,
                host_ms: None,
                host_cpu_ms: None,
                counts: FrameCounts::of(
                    &moved,
                    &super::binocular::BinocularTimes {
                        host_cpu_ms: f64::NAN,
                        ..Default::default()
                    },
                ),
            });
        }
        if f >= p.warmup {
            per_frame.push(row);
        }
    }
    let of = |pick: fn(&ComparedFrame) -> Option<PathFrame>| -> Vec<PathFrame> {
        per_frame.iter().filter_map(pick).collect()
    };
    let (resident, staged_summary) = (summary(&of(|r| r.resident)), summary(&of(|r| r.staged)));
    let ratio = |f: fn(&PathSummary) -> f64| match (&resident, &staged_summary) {
        (Some(r), Some(s)) => Some(f(s) / f(r).max(1e-9)),
        _ => None,
    };
    Ok(BinocularComparison {
        display: p.display.name.clone(),
        width: p.display.width_px,
        height: p.display.height_px,
        method: p.settings.method.name().to_string(),
        gaze_path: p.path.name(),
        step_deg: p.step_deg,
        temporal: p.temporal.is_some(),
        frames: p.frames,
        route: route.name(),
        staged_because: route.staged_because().map(str::to_string),
        staged_over_resident_wall: ratio(|s| s.wall_ms),
        staged_over_resident_cpu: ratio(|s| s.cpu_ms),
        resident,
        staged: staged_summary,
        resident_gpu_pass_ms: gpu_passes
            .into_iter()
            .map(|(k, v)| (k, median(v)))
            .collect(),
        per_frame,
    })
}
