//! The resident frame as the tools run it (issue 37, item 4): `fovea render --backend gpu`
//! and `fovea bench --backend gpu --eyes both` render through [`ResidentFrame`] whenever it
//! serves the frame's plans, and through the staged executors otherwise.
//!
//! **Decided once, before the first pass** ([`Route::decide`]), as
//! `fovea_render::pipeline::StageBackends` decides each stage's executor: from the plans and
//! cameras alone ([`ResidentFrame::supports`]), before anything is uploaded. A refusal is
//! [`Route::Staged`] with its one-line reason ([`refusal`]) (what the JSON and the printed line carry); a
//! device error is an error.
//!
//! **Counted per frame** ([`FrameCounts`]): what the device's own counters
//! ([`crate::TrafficCounts`], `GpuContext::traffic`) moved while [`ResidentRun::render`] ran —
//! bytes up and back, submissions, blocking waits, buffers and bind groups created — and the
//! render thread's host time there ([`super::BinocularTimes`]: checks, tables, uniforms and
//! command recording, without `queue.submit`). An image is read back only when asked for
//! ([`ResidentRun::image`]), a counted readback outside the frame's counts.

use fovea_core::Image;
use fovea_post::Rgb;
use fovea_render::camera::EyeCamera;
use fovea_render::plan::FramePlan;
use fovea_render::world::World;
use serde::Serialize;

use super::binocular::{BinocularTimes, ResidentFrame, ToneSettings};
use super::timing::FrameGpuTimes;
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::traffic::TrafficCounts;

/// One binocular frame of [`ResidentRun::render`], counted by the device (see the module).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameCounts {
    /// Bytes written from the host into device buffers.
    pub bytes_uploaded: u64,
    /// Bytes of mapped buffers read back (the frame's own; timers' slots of earlier frames
    /// included when their mapping completed during the call).
    pub bytes_read_back: u64,
    /// `queue.submit` calls.
    pub submissions: u64,
    /// Times the render thread blocked until the queue was idle.
    pub blocking_waits: u64,
    /// Buffers created.
    pub buffers_created: u64,
    /// Bind groups created.
    pub bind_groups_created: u64,
    /// The render thread's time on the frame without the submission (checks, tables,
    /// uniforms, recording), ms.
    pub host_ms: f64,
    /// The render thread's CPU time over the same span, ms (NaN without a thread clock).
    pub host_cpu_ms: f64,
    /// Of that, the sample side's per-column tables, ms.
    pub tables_ms: f64,
    /// The `queue.submit` call, ms.
    pub submit_ms: f64,
}

impl FrameCounts {
    /// The counts of a frame that moved `moved` and took `times`.
    pub fn of(moved: &TrafficCounts, times: &BinocularTimes) -> Self {
        Self {
            bytes_uploaded: moved.bytes_uploaded,
            bytes_read_back: moved.bytes_read_back,
            submissions: moved.submissions,
            blocking_waits: moved.blocking_waits,
            buffers_created: moved.buffers_created,
            bind_groups_created: moved.bind_groups_created,
            host_ms: times.host_ms,
            host_cpu_ms: times.host_cpu_ms,
            tables_ms: times.tables_ms,
            submit_ms: times.submit_ms,
        }
    }

    /// Each field of `self` and `other` combined: the counts by `count`, the times by `ms`
    /// (e.g. `+` for a sum of frames, `max` for the most of any).
    pub fn zip_with(
        &self,
        other: &Self,
        count: fn(u64, u64) -> u64,
        ms: fn(f64, f64) -> f64,
    ) -> Self {
        Self {
            bytes_uploaded: count(self.bytes_uploaded, other.bytes_uploaded),
            bytes_read_back: count(self.bytes_read_back, other.bytes_read_back),
            submissions: count(self.submissions, other.submissions),
            blocking_waits: count(self.blocking_waits, other.blocking_waits),
            buffers_created: count(self.buffers_created, other.buffers_created),
            bind_groups_created: count(self.bind_groups_created, other.bind_groups_created),
            host_ms: ms(self.host_ms, other.host_ms),
            host_cpu_ms: ms(self.host_cpu_ms, other.host_cpu_ms),
            tables_ms: ms(self.tables_ms, other.tables_ms),
            submit_ms: ms(self.submit_ms, other.submit_ms),
        }
    }
}

/// Where a run's frames go, decided before the first pass (see the module).
pub enum Route {
    /// Through the resident frame.
    Resident(Box<ResidentRun>),
    /// Through the staged executors, and why (one line).
    Staged(String),
}

impl Route {
    /// The resident frame when it serves `plans` seen by `cameras` (index = eye: left,
    /// right; a one-eye frame passes its plan twice and records one side,
    /// [`ResidentRun::set_eyes`]), made on `ctx` for `world` with `tone`;
    /// otherwise [`Route::Staged`] with the refusal's line. Nothing is uploaded for a refusal
    /// of the plans; a device too small for the frame's buffers (found while making them) is
    /// staged too, with the binding it lacks.
    pub fn decide(
        ctx: &GpuContext,
        world: &World,
        plans: [&FramePlan; 2],
        cameras: [&EyeCamera; 2],
        tone: ToneSettings,
    ) -> Result<Self> {
        if let Some(why) = refusal(plans, cameras) {
            return Ok(Route::Staged(why));
        }
        match ResidentRun::new(ctx, world, plans, cameras, tone) {
            Ok(run) => Ok(Route::Resident(Box::new(run))),
            // A device whose bindings cannot hold the frame's buffers (lavapipe's 128 MiB at
            // 8K): the staged path splits its work and runs.
            Err(e @ GpuError::AdapterTooSmall { .. }) => {
                Ok(Route::Staged(format!("not served: {e}")))
            }
            Err(e) => Err(e),
        }
    }

    /// `"resident"` or `"staged"`.
    pub fn name(&self) -> &'static str {
        match self {
            Route::Resident(_) => "resident",
            Route::Staged(_) => "staged",
        }
    }

    /// Why the frames are staged (`None` when resident).
    pub fn staged_because(&self) -> Option<&str> {
        match self {
            Route::Resident(_) => None,
            Route::Staged(why) => Some(why),
        }
    }
}

/// Why the resident frame does not serve `plans` seen by `cameras`, one line ("not served:
/// indirect light (3 bounces) in the resident frame (use --shading direct)"); `None` when it
/// does.
pub fn refusal(plans: [&FramePlan; 2], cameras: [&EyeCamera; 2]) -> Option<String> {
    (0..2).find_map(|e| {
        ResidentFrame::supports(plans[e], cameras[e])
            .err()
            .map(|err| match err {
                GpuError::Unsupported(what) => format!("not served: {what}"),
                other => format!("resident frame: {other}"),
            })
    })
}

/// The resident frame with its device, each frame counted (see the module).
pub struct ResidentRun {
    ctx: GpuContext,
    frame: ResidentFrame,
    /// Each eye's screen size (width, height), pixels, as of the last frame's plans.
    sizes: [(u32, u32); 2],
}

/// Each eye's screen size in pixels.
fn sizes(plans: [&FramePlan; 2]) -> [(u32, u32); 2] {
    plans.map(|p| (p.display.width_px, p.display.height_px))
}

impl ResidentRun {
    /// [`ResidentFrame::new`] on `ctx` (refusing what it refuses, before anything is
    /// allocated).
    pub fn new(
        ctx: &GpuContext,
        world: &World,
        plans: [&FramePlan; 2],
        cameras: [&EyeCamera; 2],
        tone: ToneSettings,
    ) -> Result<Self> {
        Ok(Self {
            ctx: ctx.clone(),
            frame: ResidentFrame::new(ctx, world, plans, cameras, tone)?,
            sizes: sizes(plans),
        })
    }

    /// Renders one binocular frame ([`ResidentFrame::render`]: one encoder, one submission,
    /// no wait) and counts it.
    pub fn render(
        &mut self,
        world: &World,
        plans: [&FramePlan; 2],
        cameras: [&EyeCamera; 2],
    ) -> Result<FrameCounts> {
        let before = self.ctx.traffic();
        let times = self.frame.render(world, plans, cameras)?;
        self.sizes = sizes(plans);
        Ok(FrameCounts::of(&self.ctx.traffic().since(&before), &times))
    }

    /// Temporal accumulation on the device from the next frame (`None`: off); see
    /// [`ResidentFrame::set_temporal`].
    pub fn set_temporal(
        &mut self,
        settings: Option<fovea_render::temporal::TemporalSettings>,
    ) -> Result<()> {
        self.frame.set_temporal(settings)
    }

    /// Records both eyes (2) or the left eye only (1) from the next frame; see
    /// [`ResidentFrame::set_eyes`].
    pub fn set_eyes(&mut self, eyes: usize) -> Result<()> {
        self.frame.set_eyes(eyes)
    }

    /// Forgets the temporal history (a resumed sequence's gap): the next frame is
    /// accumulated afresh; see [`ResidentFrame::reset_temporal`].
    pub fn reset_temporal(&mut self) {
        self.frame.reset_temporal();
    }

    /// Waits until the device has finished the submitted frames — for a benchmark's wall
    /// clock only, outside any frame's counts (it is a counted blocking wait).
    pub fn finish(&self) -> Result<()> {
        self.ctx.wait_idle("the resident frame")
    }

    /// Eye `eye`'s (0 left, 1 right) tone-mapped 8-bit sRGB image of the last frame, 3 bytes
    /// a pixel, row-major: a counted, blocking readback (`render --out`).
    pub fn image(&mut self, eye: usize) -> Result<Image<[u8; 3]>> {
        let (w, h) = *self
            .sizes
            .get(eye)
            .ok_or_else(|| GpuError::Input(format!("eye {eye} (0 left, 1 right)")))?;
        let bytes = self.frame.image(eye)?;
        let px: Vec<[u8; 3]> = bytes.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Image::from_vec(w, h, px).map_err(|e| GpuError::Input(e.to_string()))
    }

    /// Eye `eye`'s linear colour and depth of the last frame before its depth of field and
    /// tone map: a counted, blocking readback (an EXR `--out`).
    pub fn linear(&self, eye: usize) -> Result<(Image<Rgb>, Image<f32>)> {
        self.frame
            .screen(eye)
            .ok_or_else(|| GpuError::Input(format!("eye {eye} (0 left, 1 right)")))?
            .read_linear()
    }

    /// The frames whose per-pass GPU times have arrived ([`ResidentFrame::poll_gpu_times`]),
    /// never blocking.
    pub fn gpu_times(&mut self) -> Result<Vec<FrameGpuTimes>> {
        self.frame.poll_gpu_times()
    }

    /// The resident frame.
    pub fn frame(&self) -> &ResidentFrame {
        &self.frame
    }
}
