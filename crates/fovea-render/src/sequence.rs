//! Sequences of frames: a camera pose and a gaze sample per frame, the eye state planned
//! through one [`EyeTracker`], and one or more *tracks* (a method with its settings, its
//! temporal history and its reused buffers) rendered frame by frame.
//!
//! `fovea sequence` renders one track and writes each frame; `fovea flicker` renders a track
//! per method and accumulation mode and measures each frame against a reference; `fovea demo`
//! renders one. All of them go through [`SequenceDriver::run`], the one loop over frames.
//!
//! **Eye state first.** [`Sequence::plan`] runs the tracker over every frame before anything is
//! rendered (auto focus costs a few thousand rays a frame), so the focus of frame `i` does not
//! depend on which frames a resumed run renders.
//!
//! **Resume.** Frames for which `skip(i)` is true are not rendered. A track with temporal
//! accumulation whose previous rendered frame is not `i − 1` rebuilds its history from the up
//! to [`WARMUP_FRAMES`] frames before `i`, rendered and not passed on: identical frames when
//! the gap falls within the first 32 frames; otherwise history older than 32 frames (weight
//! ≤ (1 − α_min)³² ≈ 3 %) is lost.

use fovea_core::gaze::GazeSample;
use fovea_core::optics::AccommodationParams;

use crate::camera::EyeCamera;
use crate::dof::DofSettings;
use crate::error::{RenderError, Result};
use crate::eye::{EyePair, EyeState, EyeTracker};
use crate::pipeline::{
    render_planned, Frame, FrameContext, FrameInputs, FrameSettings, Stage, StageTimes, Stopwatch,
};
use crate::plan::{FramePlan, PlanCache};
use crate::shade::FrameNoise;
use crate::temporal::{TemporalAccumulator, TemporalSettings};
use crate::world::World;

/// Frames re-rendered (not passed on) before the first frame after a gap of a temporal track.
pub const WARMUP_FRAMES: usize = 32;

/// Most frames of one sequence.
pub const MAX_FRAMES: usize = 100_000;

/// Per frame: the camera, the gaze sample and the eye state planned from it.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// Camera of each frame.
    pub cameras: Vec<EyeCamera>,
    /// Gaze sample of each frame (as read or synthesised).
    pub gazes: Vec<GazeSample>,
    /// Eye state of each frame.
    pub eyes: Vec<EyeState>,
    /// Frames per second.
    pub fps: f64,
}

impl Sequence {
    /// Plans the eye state of every frame: `gazes[i]` seen by `cameras[i]`, the focus of
    /// `dof`'s policy through one [`EyeTracker`] with `accommodation` (auto focus from the
    /// sample's vergence depth, a binocular sample's vergence when `pairs` gives both eyes'
    /// cameras per frame, else the depth buffer). `cameras` and `gazes` must have the same
    /// length, 1 to [`MAX_FRAMES`].
    pub fn plan(
        world: &World,
        cameras: Vec<EyeCamera>,
        gazes: Vec<GazeSample>,
        dof: Option<&DofSettings>,
        fps: f64,
        accommodation: AccommodationParams,
        pairs: Option<&[(EyeCamera, EyeCamera)]>,
    ) -> Result<Self> {
        let n = gazes.len();
        if n == 0 || n > MAX_FRAMES || cameras.len() != n || pairs.is_some_and(|p| p.len() != n) {
            return Err(RenderError::invalid(
                "sequence",
                format!("{} gaze samples, {} cameras", n, cameras.len()),
                format!("1 to {MAX_FRAMES} frames, one camera (and eye pair) per gaze sample"),
            ));
        }
        if !(fps.is_finite() && fps > 0.0) {
            return Err(RenderError::invalid("fps", fps, "frames per second > 0"));
        }
        let mut tracker = EyeTracker::new(accommodation)?;
        let dt = 1.0 / fps;
        let eyes = gazes
            .iter()
            .zip(&cameras)
            .enumerate()
            .map(|(i, (g, camera))| {
                let pair = pairs.map(|p| EyePair {
                    left: &p[i].0,
                    right: &p[i].1,
                });
                tracker.update(world, camera, g, dof, pair, dt)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            cameras,
            gazes,
            eyes,
            fps,
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.eyes.len()
    }

    /// Whether the sequence has no frames (never, once planned).
    pub fn is_empty(&self) -> bool {
        self.eyes.is_empty()
    }

    /// Time of frame `i`, seconds from the first frame.
    pub fn time_s(&self, i: usize) -> f64 {
        i as f64 / self.fps
    }
}

/// One method rendered along a sequence: its settings, temporal history and buffers.
pub struct Track {
    /// A name for outputs (e.g. `vafr-on`).
    pub name: String,
    settings: FrameSettings,
    accumulator: Option<TemporalAccumulator>,
    last: Option<usize>,
    ctx: FrameContext,
    /// The mappings of the last gazes: a still gaze is planned once.
    plans: PlanCache,
}

impl Track {
    /// A track rendering `settings`, with temporal accumulation when `temporal` is given.
    pub fn new(
        name: impl Into<String>,
        settings: FrameSettings,
        temporal: Option<TemporalSettings>,
    ) -> Result<Self> {
        settings.validate()?;
        Ok(Self {
            name: name.into(),
            settings,
            accumulator: temporal.map(TemporalAccumulator::new).transpose()?,
            last: None,
            ctx: FrameContext::new(),
            plans: PlanCache::new(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &FrameSettings {
        &self.settings
    }

    /// The temporal accumulator, if the track has one.
    pub fn accumulator(&self) -> Option<&TemporalAccumulator> {
        self.accumulator.as_ref()
    }

    /// The last frame rendered.
    pub fn frame(&self) -> Option<&Frame> {
        self.ctx.frame()
    }

    /// The track's frame context, e.g. to plug in another executor of the trace or
    /// reconstruct stage ([`FrameContext::set_tracer`], [`FrameContext::set_reconstructor`]).
    pub fn context_mut(&mut self) -> &mut FrameContext {
        &mut self.ctx
    }

    /// Screen buffers allocated by this track so far.
    pub fn screen_allocations(&self) -> u64 {
        self.ctx.screen_allocations()
    }

    /// Renders frame `i` of `seq` (after the warm-up frames its history needs).
    pub fn render(&mut self, world: &World, seq: &Sequence, i: usize) -> Result<&Frame> {
        if self.accumulator.is_some() && i > 0 && self.last != Some(i - 1) {
            // A gap (resume): rebuild the history from the frames before this one.
            if let Some(acc) = self.accumulator.as_mut() {
                acc.reset();
            }
            for k in i.saturating_sub(WARMUP_FRAMES)..i {
                self.render_one(world, seq, k)?;
            }
        }
        self.render_one(world, seq, i)?;
        Ok(self.ctx.frame().expect("rendered above"))
    }

    fn render_one(&mut self, world: &World, seq: &Sequence, i: usize) -> Result<()> {
        let camera = &seq.cameras[i];
        let mut times = StageTimes::default();
        let t = Stopwatch::start();
        let jitter = self
            .accumulator
            .as_ref()
            .map_or([0.0, 0.0], |a| a.jitter(self.settings.method));
        // Frame `i`'s own random numbers in the shading (`crate::shade::frame_noise`).
        let plan = FramePlan::cached(
            world,
            camera,
            &self.settings,
            &seq.eyes[i],
            jitter,
            &mut self.plans,
        )?
        .with_noise(FrameNoise::new(i as u64, 0));
        times.add(Stage::Plan, &t);
        let inputs = FrameInputs {
            accumulator: self.accumulator.as_mut(),
            prefill: None,
        };
        render_planned(
            &mut self.ctx,
            world,
            camera,
            &plan,
            inputs,
            times,
            &|_, _| {},
        )?;
        self.last = Some(i);
        Ok(())
    }
}

/// What the driver hands on for each rendered frame.
pub struct FrameEvent<'a> {
    /// Frame index.
    pub index: usize,
    /// The frame's camera.
    pub camera: &'a EyeCamera,
    /// The frame's eye state.
    pub eye: &'a EyeState,
    /// The frame of every track, in track order.
    pub frames: Vec<&'a Frame>,
    /// The tracks (for their names and accumulators).
    pub tracks: &'a [Track],
}

/// How a run went.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunCounts {
    /// Frames rendered and handed on.
    pub rendered: usize,
    /// Frames skipped (already there).
    pub skipped: usize,
}

/// Renders tracks along a sequence.
pub struct SequenceDriver<'a> {
    world: &'a World,
    seq: &'a Sequence,
    tracks: Vec<Track>,
}

impl<'a> SequenceDriver<'a> {
    /// A driver of `tracks` along `seq` in `world`.
    pub fn new(world: &'a World, seq: &'a Sequence, tracks: Vec<Track>) -> Result<Self> {
        if tracks.is_empty() {
            return Err(RenderError::invalid(
                "tracks",
                0,
                "at least one method to render",
            ));
        }
        Ok(Self { world, seq, tracks })
    }

    /// The tracks.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Every frame in order: frames where `skip(i)` holds are left out (`progress` is still
    /// told); the others are rendered by every track and handed to `sink`. `progress(i)` is
    /// called after each frame, rendered or skipped. The sink's error type is the caller's
    /// (anything a [`RenderError`] converts into).
    pub fn run<E: From<RenderError>>(
        &mut self,
        skip: &dyn Fn(usize) -> bool,
        sink: &mut dyn FnMut(FrameEvent<'_>) -> std::result::Result<(), E>,
        progress: &mut dyn FnMut(usize),
    ) -> std::result::Result<RunCounts, E> {
        let mut counts = RunCounts::default();
        for i in 0..self.seq.len() {
            if skip(i) {
                counts.skipped += 1;
                progress(i);
                continue;
            }
            for t in self.tracks.iter_mut() {
                t.render(self.world, self.seq, i)?;
            }
            let event = FrameEvent {
                index: i,
                camera: &self.seq.cameras[i],
                eye: &self.seq.eyes[i],
                frames: self
                    .tracks
                    .iter()
                    .map(|t| t.frame().expect("rendered above"))
                    .collect(),
                tracks: &self.tracks,
            };
            sink(event)?;
            counts.rendered += 1;
            progress(i);
        }
        Ok(counts)
    }
}
