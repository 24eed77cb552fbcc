//! `--backend gpu` through the resident frame (issue 37; docs/gpu.md "The resident frame in
//! the tools"): `fovea render` renders through `fovea_gpu::frame::ResidentRun` when the
//! library's route (`fovea_gpu::frame::Route::decide`, once, before the first pass) takes
//! the plans and the outputs asked for need nothing the device does not keep; `fovea bench
//! --eyes both` times each method's binocular frame resident against staged
//! (`fovea_gpu::frame::compare_binocular`). This file maps options and prints; the logic is
//! the library's. Without the `gpu` feature nothing here runs.

use std::path::Path;

use anyhow::Result;
use clap::ValueEnum;
use serde_json::Value;

use fovea_post::tonemap::ToneCurve;
use fovea_render::camera::EyeCamera;
use fovea_render::plan::FramePlan;
use fovea_render::world::World;

use crate::backend::Backend;

/// `--gaze-path` of `fovea bench` (`fovea_gpu::frame::GazePath`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GazePathArg {
    /// A saccade-sized jump every frame, around a square.
    Saccade,
    /// Saccade-sized arcs of a circle a fifth of the screen's height in radius.
    Circle,
    /// The same gaze every frame.
    Still,
}

/// What `fovea render` did with the resident frame.
pub enum Rendered {
    /// It rendered the frame and wrote `--out`: the backend's JSON and the printed line.
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    Resident { json: Value, line: String },
    /// The staged path renders it, and why (`None`: no GPU).
    Staged(Option<String>),
}

/// Renders `plans` seen by `cameras` (one eye: one of each; `--eyes both`: left, right, the
/// image side by side) through the resident frame and writes `out` — when `backend` is a GPU,
/// `outputs` (the CLI's own check of what else was asked for) is `Ok`, the exposure is fixed
/// (`stops`) and the library's route takes the plans; otherwise says why not.
#[cfg(feature = "gpu")]
#[allow(clippy::too_many_arguments)]
pub fn render(
    backend: &Backend,
    world: &World,
    plans: &[&FramePlan],
    cameras: &[&EyeCamera],
    stops: Option<f32>,
    curve: ToneCurve,
    out: &Path,
    outputs: std::result::Result<(), String>,
) -> Result<Rendered> {
    use fovea_gpu::frame::{Route, ToneSettings};
    let Some(ctx) = &backend.gpu else {
        return Ok(Rendered::Staged(None));
    };
    if let Err(why) = outputs {
        return Ok(Rendered::Staged(Some(why)));
    }
    let Some(exposure_stops) = stops else {
        return Ok(Rendered::Staged(Some(
            "not served: auto exposure (it meters the linear frame on the CPU; give \
             --exposure or --ev100)"
                .into(),
        )));
    };
    let eyes = plans.len();
    let two = |k: usize| k.min(eyes - 1);
    let (p2, c2) = ([plans[0], plans[two(1)]], [cameras[0], cameras[two(1)]]);
    let tone = ToneSettings {
        exposure_stops,
        curve,
    };
    let mut run = match Route::decide(ctx, world, p2, c2, tone)? {
        Route::Resident(run) => run,
        Route::Staged(why) => return Ok(Rendered::Staged(Some(why))),
    };
    // One eye: its plan on both sides, the left one recorded.
    run.set_eyes(eyes)?;
    let counts = run.render(world, p2, c2)?;
    let before = ctx.traffic();
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        let mut img = run.linear(0)?.0;
        if eyes == 2 {
            img = crate::output::side_by_side(&img, &run.linear(1)?.0)?;
        }
        crate::output::write_rgb_on(out, &img, exposure_stops, curve, None)?;
    } else {
        let mut img = run.image(0)?;
        if eyes == 2 {
            img = crate::output::side_by_side(&img, &run.image(1)?)?;
        }
        let bytes: Vec<u8> = img.data().iter().flatten().copied().collect();
        let png = crate::output::png_bytes(out, img.width(), img.height(), bytes)?;
        crate::output::write_file(out, &png)?;
    }
    let image = ctx.traffic().since(&before);
    let line = format!(
        "resident frame: {} submission, {} blocking waits, {:.1} KB up, {} B back, host {:.2} \
         ms{}; the image read back on request ({:.1} KB)",
        counts.submissions,
        counts.blocking_waits,
        counts.bytes_uploaded as f64 / 1e3,
        counts.bytes_read_back,
        counts.host_ms,
        if eyes == 1 { " (one eye)" } else { "" },
        image.bytes_read_back as f64 / 1e3,
    );
    let json = serde_json::json!({
        "requested": backend.requested,
        "resolved": backend.describe,
        "adapter": backend.adapter,
        "cpu_emulated": backend.cpu_emulated,
        "route": "resident",
        "resident_frame": counts,
        "image_readback": {
            "bytes_read_back": image.bytes_read_back,
            "blocking_waits": image.blocking_waits,
            "submissions": image.submissions,
        },
    });
    Ok(Rendered::Resident { json, line })
}

/// Without the `gpu` feature there is no GPU: the staged (CPU) path renders.
#[cfg(not(feature = "gpu"))]
#[allow(clippy::too_many_arguments)]
pub fn render(
    _backend: &Backend,
    _world: &World,
    _plans: &[&FramePlan],
    _cameras: &[&EyeCamera],
    _stops: Option<f32>,
    _curve: ToneCurve,
    _out: &Path,
    _outputs: std::result::Result<(), String>,
) -> Result<Rendered> {
    Ok(Rendered::Staged(None))
}

/// How the benchmark's binocular frames move their gaze, and whether they accumulate.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub struct MovingGaze {
    /// `--gaze-path`.
    pub path: GazePathArg,
    /// `--gaze-step`, degrees a frame.
    pub step_deg: f64,
    /// `--temporal`: accumulation on both paths.
    pub temporal: bool,
}

/// `--eyes both` on a GPU: each display's binocular frame of every `--methods` method,
/// resident against staged with the gaze moving along `path` by `step_deg` a frame, printed
/// unless `quiet`; the rows for the JSON's `resident_binocular`.
#[cfg(feature = "gpu")]
pub fn bench_rows(
    loaded: &mut crate::scene_args::Loaded,
    scene: &crate::scene_args::SceneArgs,
    params: &fovea_eval::experiments::bench::BenchParams,
    preflight: &crate::backend::Preflight,
    moving: MovingGaze,
    quiet: bool,
) -> Result<Vec<Value>> {
    use fovea_gpu::frame::{compare_binocular, CompareParams, GazePath, ToneSettings};
    let Some(ctx) = &preflight.gpu else {
        return Ok(Vec::new());
    };
    let MovingGaze {
        path,
        step_deg,
        temporal,
    } = moving;
    let path = match path {
        GazePathArg::Saccade => GazePath::Saccade,
        GazePathArg::Circle => GazePath::Circle,
        GazePathArg::Still => GazePath::Still,
    };
    let mut rows = Vec::new();
    for display in &params.displays {
        // The view sets the display's camera and lights, as the bench's other frames.
        loaded.view(scene, display)?;
        for &method in &params.methods {
            let mut settings = params.frame.clone();
            settings.method = method;
            let c = compare_binocular(
                ctx,
                &CompareParams {
                    world: &loaded.world,
                    rig: loaded.rig(),
                    display,
                    settings: &settings,
                    path,
                    start: display.centre_gaze(),
                    step_deg,
                    warmup: params.warmup.max(1) as usize,
                    frames: params.frames as usize,
                    staged: true,
                    tone: ToneSettings {
                        exposure_stops: 0.0,
                        curve: ToneCurve::Reinhard,
                    },
                    temporal: temporal.then(fovea_render::temporal::TemporalSettings::default),
                },
            )?;
            if !quiet {
                println!("{}", bench_line(&c));
            }
            rows.push(serde_json::to_value(&c)?);
        }
    }
    Ok(rows)
}

/// Without the `gpu` feature no GPU runs (the preflight refused `--backend gpu`).
#[cfg(not(feature = "gpu"))]
pub fn bench_rows(
    _loaded: &mut crate::scene_args::Loaded,
    _scene: &crate::scene_args::SceneArgs,
    _params: &fovea_eval::experiments::bench::BenchParams,
    _preflight: &crate::backend::Preflight,
    _moving: MovingGaze,
    _quiet: bool,
) -> Result<Vec<Value>> {
    Ok(Vec::new())
}

/// One comparison's line: each path's median wall, CPU and share, the resident frame's host
/// time and counts, the ratio.
#[cfg(feature = "gpu")]
fn bench_line(c: &fovea_gpu::frame::BinocularComparison) -> String {
    let time = |s: &fovea_gpu::frame::PathSummary| {
        format!(
            "{:.1} ms wall, cpu {:.1} ms ({:.0}% CPU); a frame at most {} submits, {} waits, \
             {:.1} KB up, {:.1} KB back",
            s.wall_ms,
            s.cpu_ms,
            100.0 * s.cpu_share,
            s.submissions_max,
            s.blocking_waits_max,
            s.bytes_uploaded_max as f64 / 1e3,
            s.bytes_read_back_max as f64 / 1e3
        )
    };
    let resident = match (&c.resident, &c.staged_because) {
        (Some(r), _) => format!(
            "resident {}; host {:.2} ms wall (plans {:.2}, record {:.2}; at most {:.2}), \
             render-thread cpu {:.2} ms (plans {:.2}, record {:.2}; at most {:.2}; {:.0}% of \
             the wall), {} plans built",
            time(r),
            r.host_ms.unwrap_or(f64::NAN),
            r.plan_ms,
            r.record_ms,
            r.host_ms_max.unwrap_or(f64::NAN),
            r.host_cpu_ms.unwrap_or(f64::NAN),
            r.plan_cpu_ms,
            r.record_cpu_ms,
            r.host_cpu_ms_max.unwrap_or(f64::NAN),
            100.0 * r.host_cpu_share.unwrap_or(f64::NAN),
            r.plans_built
        ),
        (None, why) => format!("staged only ({})", why.as_deref().unwrap_or("")),
    };
    let staged = c
        .staged
        .as_ref()
        .map_or(String::new(), |s| format!(" | staged {}", time(s)));
    let ratio = match (c.staged_over_resident_wall, c.staged_over_resident_cpu) {
        (Some(w), Some(cpu)) => format!(" | staged/resident {w:.2} wall, {cpu:.2} cpu"),
        _ => String::new(),
    };
    format!(
        "{} {}x{} {} binocular, gaze {} {}°/frame, temporal {}, median of {}: \
         {resident}{staged}{ratio}",
        c.display,
        c.width,
        c.height,
        c.method,
        c.gaze_path,
        c.step_deg,
        if c.temporal { "on" } else { "off" },
        c.frames
    )
}

/// A written frame of `fovea sequence` on a GPU, for the caller's file.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub enum SequenceImage<'a> {
    /// The resident frame's tone-mapped 8-bit sRGB image (read back).
    Srgb8(&'a fovea_core::Image<[u8; 3]>),
    /// A staged frame: linear colour, tone-mapped by the caller.
    Linear(&'a fovea_render::pipeline::Frame),
}

/// What `fovea sequence` asks of the GPU: the frames and how they end.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub struct SequenceInputs<'a> {
    pub world: &'a World,
    pub seq: &'a fovea_render::sequence::Sequence,
    pub settings: &'a fovea_render::pipeline::FrameSettings,
    pub temporal: Option<fovea_render::temporal::TemporalSettings>,
    /// The one exposure of every frame, stops (the tone curve is Reinhard).
    pub exposure_stops: f32,
}

/// Where `fovea sequence --backend gpu`'s frames go (`fovea_gpu::frame::SequenceRoute`).
#[cfg(feature = "gpu")]
pub struct SequenceRun {
    ctx: fovea_gpu::GpuContext,
    route: fovea_gpu::frame::SequenceRoute,
}

/// Without the `gpu` feature no sequence runs on a GPU.
#[cfg(not(feature = "gpu"))]
pub enum SequenceRun {}

/// What a sequence on the GPU did: the counts, the stats JSON's `backend` and the printed
/// line.
pub struct SequenceDone {
    pub counts: fovea_render::sequence::RunCounts,
    pub json: Value,
    pub line: String,
}

#[cfg(feature = "gpu")]
impl SequenceRun {
    /// `"resident"` or `"staged"`.
    pub fn name(&self) -> &'static str {
        self.route.name()
    }

    /// Why the frames are staged (`None` when resident).
    pub fn staged_because(&self) -> Option<&str> {
        self.route.staged_because()
    }
}

#[cfg(not(feature = "gpu"))]
impl SequenceRun {
    pub fn name(&self) -> &'static str {
        match *self {}
    }

    pub fn staged_because(&self) -> Option<&str> {
        match *self {}
    }
}

/// On a GPU, where `inp`'s frames go: the library's route (`SequenceRoute::decide`, once,
/// before the first frame), or staged because `staged` (`--staged`) asks; `None` on the CPU.
#[cfg(feature = "gpu")]
pub fn sequence_route(
    backend: &Backend,
    staged: bool,
    inp: &SequenceInputs<'_>,
) -> Result<Option<SequenceRun>> {
    use fovea_gpu::frame::SequenceRoute;
    let Some(ctx) = &backend.gpu else {
        return Ok(None);
    };
    let route = if staged {
        SequenceRoute::Staged("--staged asked for".into())
    } else {
        SequenceRoute::decide(ctx, &gpu_params(inp))?
    };
    Ok(Some(SequenceRun {
        ctx: ctx.clone(),
        route,
    }))
}

/// Without the `gpu` feature there is no GPU.
#[cfg(not(feature = "gpu"))]
pub fn sequence_route(
    _backend: &Backend,
    _staged: bool,
    _inp: &SequenceInputs<'_>,
) -> Result<Option<SequenceRun>> {
    Ok(None)
}

#[cfg(feature = "gpu")]
fn gpu_params<'a>(inp: &SequenceInputs<'a>) -> fovea_gpu::frame::SequenceParams<'a> {
    fovea_gpu::frame::SequenceParams {
        world: inp.world,
        seq: inp.seq,
        settings: inp.settings,
        temporal: inp.temporal,
        tone: fovea_gpu::frame::ToneSettings {
            exposure_stops: inp.exposure_stops,
            curve: ToneCurve::Reinhard,
        },
    }
}

/// Renders `inp`'s frames along `run` (`fovea_gpu::frame::run_sequence`; `track`, on the GPU
/// executors, renders what is staged), each written frame handed to `write`, frames where
/// `skip` holds left out; `progress` is told of every frame.
#[cfg(feature = "gpu")]
pub fn run_sequence(
    run: SequenceRun,
    backend: &Backend,
    inp: &SequenceInputs<'_>,
    track: &mut fovea_render::sequence::Track,
    skip: &dyn Fn(usize) -> bool,
    write: &mut dyn FnMut(usize, SequenceImage<'_>) -> Result<()>,
    progress: &mut dyn FnMut(usize),
) -> Result<SequenceDone> {
    use fovea_gpu::frame::{run_sequence, SequenceImage as Gpu};
    let report = run_sequence::<anyhow::Error>(
        &run.ctx,
        &gpu_params(inp),
        run.route,
        track,
        skip,
        &mut |o| match o.image {
            Gpu::Srgb8(img) => write(o.index, SequenceImage::Srgb8(&img)),
            Gpu::Staged(frame) => write(o.index, SequenceImage::Linear(frame)),
        },
        progress,
    )?;
    let mut json = serde_json::json!({
        "requested": backend.requested,
        "resolved": backend.describe,
        "adapter": backend.adapter,
        "cpu_emulated": backend.cpu_emulated,
    });
    if let (Value::Object(j), Value::Object(r)) = (&mut json, serde_json::to_value(&report)?) {
        j.extend(r);
    }
    let line = sequence_line(&report);
    Ok(SequenceDone {
        counts: report.counts(),
        json,
        line,
    })
}

/// Without the `gpu` feature no sequence runs on a GPU.
#[cfg(not(feature = "gpu"))]
pub fn run_sequence(
    run: SequenceRun,
    _backend: &Backend,
    _inp: &SequenceInputs<'_>,
    _track: &mut fovea_render::sequence::Track,
    _skip: &dyn Fn(usize) -> bool,
    _write: &mut dyn FnMut(usize, SequenceImage<'_>) -> Result<()>,
    _progress: &mut dyn FnMut(usize),
) -> Result<SequenceDone> {
    match run {}
}

/// One line: the route, and per written frame at most what the resident frame moved, the
/// image readback; or why staged.
#[cfg(feature = "gpu")]
fn sequence_line(r: &fovea_gpu::frame::SequenceReport) -> String {
    let mut line = match (&r.resident_most, &r.image_readback_most) {
        (Some(m), Some(img)) => format!(
            "resident frame: {} frames, each at most {} submission, {} blocking waits, {:.1} \
             KB up, {} B back, host {:.2} ms; each image read back for its file ({:.1} KB, {} \
             wait)",
            r.resident_frames,
            m.submissions,
            m.blocking_waits,
            m.bytes_uploaded as f64 / 1e3,
            m.bytes_read_back,
            m.host_ms,
            img.bytes_read_back as f64 / 1e3,
            img.blocking_waits,
        ),
        _ => String::new(),
    };
    if let Some(why) = &r.staged_because {
        line = format!("staged GPU path ({why}): {} frames", r.staged_frames);
    } else if let Some((i, why)) = &r.fell_back {
        line += &format!(
            "; from frame {i} the staged GPU path ({why}): {} frames",
            r.staged_frames
        );
    }
    line
}
