//! A sequence through the resident frame (issue 37, item 7): `fovea sequence --backend gpu`
//! renders the frames of a [`Sequence`] through [`ResidentRun`] wherever the resident frame
//! serves the sequence's settings — temporal accumulation (on the device,
//! [`ResidentRun::set_temporal`]) and the sample-space denoiser, each without the other —
//! and through the
//! staged path (a `fovea_render::sequence::Track` on the GPU executors) otherwise.
//!
//! **The same frames as the staged track.** Frame `i` is what `Track::render` makes of it:
//! the plan `FramePlan::cached(world, cameras[i], settings, eyes[i], jitter)` with frame
//! `i`'s random numbers (`FrameNoise::new(i, 0)`), the jitter of the accumulator's frame
//! count ([`TemporalSettings::jitter_at`]: frames accumulated so far, warm-up frames
//! included); a frame after a gap (a resumed run) resets the history
//! ([`ResidentRun::reset_temporal`]) and renders the up to [`WARMUP_FRAMES`] frames before it
//! first, unwritten. The resident frame is binocular and a sequence has one eye: its plan and
//! camera go to both sides, and only the left side is recorded
//! ([`ResidentRun::set_eyes`]`(1)`) and its image read back.
//!
//! **Decided once, before the first pass** ([`SequenceRoute::decide`]): from frame 0's plan
//! ([`super::refusal`], and with temporal accumulation [`ResidentFrame::supports_temporal`]),
//! then the frame made on the device ([`Route::decide`]: a device whose bindings cannot hold
//! it is staged too). A refusal is [`SequenceRoute::Staged`] with its one line. A later frame
//! the resident frame refuses (an [`GpuError::Unsupported`] or
//! [`GpuError::AdapterTooSmall`] the first frame did not show) sends it and the rest of the
//! run to the staged track, said in the report ([`SequenceReport::fell_back`]).
//!
//! **Counted per written frame** ([`SequenceFrameStats`]): the resident frame's
//! [`FrameCounts`] (1 submission, no blocking wait), the warm-up frames' apart, and the one
//! image read back for the file ([`ImageReadback`]: one blocking wait, `3·w·h` bytes); a
//! staged frame, the device's counters over its render and its tone map.

use std::collections::BTreeMap;

use fovea_core::Image;
use fovea_render::pipeline::{Frame, FrameSettings, Stopwatch};
use fovea_render::plan::{FramePlan, PlanCache};
use fovea_render::sequence::{RunCounts, Sequence, Track, WARMUP_FRAMES};
use fovea_render::shade::FrameNoise;
use fovea_render::temporal::TemporalSettings;
use fovea_render::world::World;
use fovea_render::RenderError;
use serde::Serialize;

use super::binocular::{BinocularTimes, ResidentFrame, ToneSettings};
use super::run::{refusal, FrameCounts, ResidentRun, Route};
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::traffic::TrafficCounts;

/// What a sequence renders (see the module).
#[derive(Clone, Copy)]
pub struct SequenceParams<'a> {
    /// The scene.
    pub world: &'a World,
    /// Every frame's camera and eye state.
    pub seq: &'a Sequence,
    /// The frames' settings (method, shading, AA, DOF, denoiser, …).
    pub settings: &'a FrameSettings,
    /// Temporal accumulation (`None`: off).
    pub temporal: Option<TemporalSettings>,
    /// The tone map the images end with.
    pub tone: ToneSettings,
}

/// A GPU error from the renderer's side (a plan that cannot be made).
fn render_err(e: RenderError) -> GpuError {
    GpuError::Input(e.to_string())
}

/// The resident frame rendering a sequence's frames (see the module).
pub struct ResidentSequence {
    run: ResidentRun,
    temporal: Option<TemporalSettings>,
    /// The mappings of the last gazes (a still gaze is planned once), as the track's.
    plans: PlanCache,
    /// Frames accumulated since the run began: the CPU accumulator's `frame()`, whose jitter
    /// the next frame takes.
    accumulated: u64,
    /// The last frame rendered.
    last: Option<usize>,
}

/// Where a sequence's frames go, decided before the first pass (see the module).
pub enum SequenceRoute {
    /// Through the resident frame.
    Resident(Box<ResidentSequence>),
    /// Through the staged track, and why (one line).
    Staged(String),
}

impl SequenceRoute {
    /// The resident frame on `ctx` when it serves `p`'s frames (frame 0's plan decides, see
    /// the module), with temporal accumulation set; otherwise [`SequenceRoute::Staged`] with
    /// the refusal's line. Nothing is uploaded for a refusal of the plan.
    pub fn decide(ctx: &GpuContext, p: &SequenceParams<'_>) -> Result<Self> {
        let mut plans = PlanCache::new();
        let plan = frame_plan(p, 0, 0, &mut plans)?;
        let camera = &p.seq.cameras[0];
        let temporal_refusal = match p.temporal {
            Some(_) => ResidentFrame::supports_temporal(&plan).err(),
            None => None,
        };
        let refused = match temporal_refusal {
            Some(GpuError::Unsupported(what)) => Some(format!("not served: {what}")),
            Some(e) => return Err(e),
            None => refusal([&plan, &plan], [camera, camera]),
        };
        if let Some(why) = refused {
            return Ok(SequenceRoute::Staged(why));
        }
        let mut run = match Route::decide(ctx, p.world, [&plan, &plan], [camera, camera], p.tone)? {
            Route::Resident(run) => run,
            Route::Staged(why) => return Ok(SequenceRoute::Staged(why)),
        };
        run.set_temporal(p.temporal)?;
        run.set_eyes(1)?;
        Ok(SequenceRoute::Resident(Box::new(ResidentSequence {
            run: *run,
            temporal: p.temporal,
            plans,
            accumulated: 0,
            last: None,
        })))
    }

    /// `"resident"` or `"staged"`.
    pub fn name(&self) -> &'static str {
        match self {
            SequenceRoute::Resident(_) => "resident",
            SequenceRoute::Staged(_) => "staged",
        }
    }

    /// Why the frames are staged (`None` when resident).
    pub fn staged_because(&self) -> Option<&str> {
        match self {
            SequenceRoute::Resident(_) => None,
            SequenceRoute::Staged(why) => Some(why),
        }
    }
}

/// Frame `i`'s plan of `p` with the jitter of `accumulated` frames accumulated, and frame
/// `i`'s random numbers (as `Track::render`'s).
fn frame_plan(
    p: &SequenceParams<'_>,
    i: usize,
    accumulated: u64,
    cache: &mut PlanCache,
) -> Result<FramePlan> {
    let (Some(camera), Some(eye)) = (p.seq.cameras.get(i), p.seq.eyes.get(i)) else {
        return Err(GpuError::Input(format!(
            "frame {i} of a sequence of {} frames",
            p.seq.len()
        )));
    };
    let jitter = p
        .temporal
        .map_or([0.0, 0.0], |t| t.jitter_at(p.settings.method, accumulated));
    Ok(
        FramePlan::cached(p.world, camera, p.settings, eye, jitter, cache)
            .map_err(render_err)?
            .with_noise(FrameNoise::new(i as u64, 0)),
    )
}

impl ResidentSequence {
    /// Renders frame `i` of `p` (the params it was decided for) after the warm-up frames a
    /// gap needs: its counts, and the warm-up frames' (how many, their counts summed).
    fn render(
        &mut self,
        p: &SequenceParams<'_>,
        i: usize,
    ) -> Result<(FrameCounts, usize, Option<FrameCounts>)> {
        let mut warmup: Option<FrameCounts> = None;
        let mut warmed = 0;
        if self.temporal.is_some() && i > 0 && self.last != Some(i - 1) {
            self.run.reset_temporal();
            for k in i.saturating_sub(WARMUP_FRAMES)..i {
                let c = self.render_one(p, k)?;
                warmup = Some(match warmup {
                    Some(w) => sum(&w, &c),
                    None => c,
                });
                warmed += 1;
            }
        }
        Ok((self.render_one(p, i)?, warmed, warmup))
    }

    fn render_one(&mut self, p: &SequenceParams<'_>, i: usize) -> Result<FrameCounts> {
        let plan = frame_plan(p, i, self.accumulated, &mut self.plans)?;
        let camera = &p.seq.cameras[i];
        let counts = self.run.render(p.world, [&plan, &plan], [camera, camera])?;
        self.last = Some(i);
        if self.temporal.is_some() {
            self.accumulated += 1;
        }
        Ok(counts)
    }
}

/// Two frames' counts added (the host times too).
fn sum(a: &FrameCounts, b: &FrameCounts) -> FrameCounts {
    a.zip_with(b, |x, y| x + y, |x, y| x + y)
}

/// Each field's largest value of the two.
fn most(a: &FrameCounts, b: &FrameCounts) -> FrameCounts {
    a.zip_with(b, u64::max, f64::max)
}

/// A written frame's image, for the caller to write.
pub enum SequenceImage<'a> {
    /// The resident frame's tone-mapped 8-bit sRGB image (read back).
    Srgb8(Image<[u8; 3]>),
    /// The staged track's frame (linear colour; the caller tone-maps it).
    Staged(&'a Frame),
}

/// One written frame handed to the caller.
pub struct SequenceOutput<'a> {
    /// Frame index.
    pub index: usize,
    /// Its image.
    pub image: SequenceImage<'a>,
}

/// The one image read back for a written frame's file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ImageReadback {
    /// Bytes read back (`3·w·h`).
    pub bytes_read_back: u64,
    /// Blocking waits (1: the readback's).
    pub blocking_waits: u64,
    /// Submissions (the copy to the readback buffer).
    pub submissions: u64,
}

/// One written frame: which route it took and what it moved.
#[derive(Clone, Debug, Serialize)]
pub struct SequenceFrameStats {
    /// Frame index.
    pub frame: usize,
    /// `"resident"` or `"staged"`.
    pub route: &'static str,
    /// The frame's own counts: resident, [`ResidentRun::render`]'s; staged, the device's
    /// counters over its render and tone map (`host_ms` 0).
    pub counts: FrameCounts,
    /// Frames rendered first, unwritten, to rebuild the temporal history after a gap.
    pub warmup_frames: usize,
    /// Their counts summed (resident only; a staged frame's are in `counts`).
    pub warmup: Option<FrameCounts>,
    /// The image read back for the file (resident only).
    pub image_readback: Option<ImageReadback>,
    /// Wall ms from the frame's plan to its image handed on (warm-up frames included).
    pub wall_ms: f64,
}

/// How a sequence went on the GPU.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SequenceReport {
    /// `"resident"` or `"staged"`: the route decided before the first frame.
    pub route: &'static str,
    /// Why the frames are staged (`None` when resident).
    pub staged_because: Option<String>,
    /// The frame from which a resident run went staged, and why (`None`: it did not).
    pub fell_back: Option<(usize, String)>,
    /// Frames rendered and handed on.
    pub rendered: usize,
    /// Frames skipped (already there).
    pub skipped: usize,
    /// Written frames rendered resident.
    pub resident_frames: usize,
    /// Written frames rendered staged.
    pub staged_frames: usize,
    /// Each field's largest value over the resident written frames' own counts.
    pub resident_most: Option<FrameCounts>,
    /// Each field's largest value over the staged written frames' counts.
    pub staged_most: Option<FrameCounts>,
    /// The largest image readback of a resident frame.
    pub image_readback_most: Option<ImageReadback>,
    /// The resident frame's GPU ms per pass, the median over the frames whose timestamps
    /// arrived (late, without waiting); empty without timestamp queries.
    pub resident_gpu_pass_ms: BTreeMap<String, f64>,
    /// Every written frame.
    pub frames: Vec<SequenceFrameStats>,
}

impl SequenceReport {
    /// The route counts as [`RunCounts`].
    pub fn counts(&self) -> RunCounts {
        RunCounts {
            rendered: self.rendered,
            skipped: self.skipped,
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Every frame of `p` in order on `ctx`, along `route`: frames where `skip(i)` holds are left
/// out (`progress` is still told); the others are rendered (resident, or by `staged`, a
/// track of `p`'s settings on the GPU executors) and handed to `sink`. `progress(i)` is called
/// after each frame, rendered or skipped — as `fovea_render::sequence::SequenceDriver::run`.
pub fn run_sequence<E: From<GpuError> + From<RenderError>>(
    ctx: &GpuContext,
    p: &SequenceParams<'_>,
    route: SequenceRoute,
    staged: &mut Track,
    skip: &dyn Fn(usize) -> bool,
    sink: &mut dyn FnMut(SequenceOutput<'_>) -> std::result::Result<(), E>,
    progress: &mut dyn FnMut(usize),
) -> std::result::Result<SequenceReport, E> {
    let mut report = SequenceReport {
        route: route.name(),
        staged_because: route.staged_because().map(str::to_string),
        ..Default::default()
    };
    let mut resident = match route {
        SequenceRoute::Resident(r) => Some(r),
        SequenceRoute::Staged(_) => None,
    };
    let mut gpu_passes: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    // The staged track's last rendered frame (a gap makes it warm up, inside its render).
    let mut staged_last: Option<usize> = None;
    for i in 0..p.seq.len() {
        if skip(i) {
            report.skipped += 1;
            progress(i);
            continue;
        }
        let sw = Stopwatch::start();
        let mut stats = None;
        if let Some(r) = resident.as_mut() {
            match r.render(p, i) {
                Ok((counts, warmup_frames, warmup)) => {
                    let before = ctx.traffic();
                    let image = r.run.image(0)?;
                    let moved = ctx.traffic().since(&before);
                    for g in r.run.gpu_times()? {
                        for (name, ms) in g.passes {
                            if let Some(ms) = ms {
                                gpu_passes.entry(name.to_string()).or_default().push(ms);
                            }
                        }
                    }
                    sink(SequenceOutput {
                        index: i,
                        image: SequenceImage::Srgb8(image),
                    })?;
                    stats = Some(SequenceFrameStats {
                        frame: i,
                        route: "resident",
                        counts,
                        warmup_frames,
                        warmup,
                        image_readback: Some(readback(&moved)),
                        wall_ms: sw.elapsed_ms().0,
                    });
                }
                Err(e @ (GpuError::Unsupported(_) | GpuError::AdapterTooSmall { .. })) => {
                    report.fell_back = Some((i, e.to_string()));
                    resident = None;
                }
                Err(e) => return Err(e.into()),
            }
        }
        let stats = match stats {
            Some(s) => s,
            None => {
                let warmup_frames = match (staged.accumulator(), staged_last) {
                    (Some(_), last) if i > 0 && last != Some(i - 1) => i.min(WARMUP_FRAMES),
                    _ => 0,
                };
                let before = ctx.traffic();
                let frame = staged.render(p.world, p.seq, i)?;
                sink(SequenceOutput {
                    index: i,
                    image: SequenceImage::Staged(frame),
                })?;
                staged_last = Some(i);
                let moved = ctx.traffic().since(&before);
                SequenceFrameStats {
                    frame: i,
                    route: "staged",
                    counts: FrameCounts::of(&moved, &BinocularTimes::default()),
                    warmup_frames,
                    warmup: None,
                    image_readback: None,
                    wall_ms: sw.elapsed_ms().0,
                }
            }
        };
        if stats.route == "resident" {
            report.resident_frames += 1;
            report.resident_most = Some(match &report.resident_most {
                Some(m) => most(m, &stats.counts),
                None => stats.counts,
            });
            let img = stats.image_readback.unwrap_or_default();
            let m = report.image_readback_most.unwrap_or_default();
            report.image_readback_most = Some(ImageReadback {
                bytes_read_back: m.bytes_read_back.max(img.bytes_read_back),
                blocking_waits: m.blocking_waits.max(img.blocking_waits),
                submissions: m.submissions.max(img.submissions),
            });
        } else {
            report.staged_frames += 1;
            report.staged_most = Some(match &report.staged_most {
                Some(m) => most(m, &stats.counts),
                None => stats.counts,
            });
        }
        report.frames.push(stats);
        report.rendered += 1;
        progress(i);
    }
    report.resident_gpu_pass_ms = gpu_passes
        .into_iter()
        .map(|(k, v)| (k, median(v)))
        .collect();
    Ok(report)
}

/// An image readback's counters.
fn readback(moved: &TrafficCounts) -> ImageReadback {
    ImageReadback {
        bytes_read_back: moved.bytes_read_back,
        blocking_waits: moved.blocking_waits,
        submissions: moved.submissions,
    }
}
