//! The whole binocular frame on the device (issue 37, item 1): both eyes' sample side
//! ([`ResidentSamples`]: ray generation, trace, surfaces, direct and environment light into
//! each eye's [`super::DeviceSamples`]) and both eyes' screen side ([`ScreenContext`]: AA,
//! polar reconstruction (VaFR Sec. 3.4), gather DOF, tone map) recorded into **one** command
//! encoder and submitted **once**; nothing is read back unless an eye's image is asked for
//! ([`ResidentFrame::image`]). Per-pass GPU times come from [`FrameTimer`]s read frames late
//! ([`ResidentFrame::poll_gpu_times`]), never blocking.
//!
//! The order inside the encoder: left shade, right shade, with temporal accumulation on
//! ([`ResidentFrame::set_temporal`]) each eye's accumulation pass and the copy of its result
//! over the samples ([`super::temporal`]), then — when the plans denoise — the left and the
//! right eye's sample-space denoiser (issue 38: the GPU twin of `fovea_post::denoise` over the
//! samples, guided by the albedo, normal and Monte Carlo part the shade kernels wrote;
//! [`ResidentSamples::record_denoise`]), then the left eye's screen passes, then the right
//! eye's (each pass reads what the passes before it wrote; wgpu orders the passes of one
//! encoder).
//!
//! What it cannot serve is refused with [`GpuError::Unsupported`] before anything is written
//! or recorded ([`ResidentFrame::supports`]): everything the sample side refuses
//! ([`super::supports`]: indirect light, several rays per texel, culling, the inset's
//! Gaussian and Laplacian smoothings), what the screen side refuses
//! ([`ScreenContext::supports`]: Weier),
//! peripheral contrast, DOF filters other than the gather, and sample-space AA at full
//! resolution.

use std::time::Instant;

use fovea_core::mapping::{FoveationMapping, Method};
use fovea_core::units::Metres;
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::dof::FilterKind;
use fovea_post::fxaa::FxaaParams;
use fovea_post::tonemap::ToneCurve;
use fovea_render::camera::EyeCamera;
use fovea_render::dof::coc_params;
use fovea_render::plan::FramePlan;
use fovea_render::settings::AaMode;
use fovea_render::world::World;

use super::context::ResidentSamples;
use super::screen::{
    ScreenConfig, ScreenContext, ScreenDof, ScreenInput, ScreenLimits, SCREEN_PASSES,
};
use super::shade::supports as samples_support;
use super::temporal::ResidentTemporal;
use super::timing::{FrameGpuTimes, FrameTimer};
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::sample_aa::SampleFilter;

/// Every pass of a binocular frame as [`ResidentFrame::poll_gpu_times`] names them: per eye
/// the sample side's pass, then the screen side's ([`SCREEN_PASSES`]).
pub const BINOCULAR_PASSES: [[&str; EYE_PASSES]; 2] = [
    [
        "left shade",
        "left aa",
        "left columns",
        "left reconstruct",
        "left split",
        "left dof",
        "left tonemap",
        "left present",
    ],
    [
        "right shade",
        "right aa",
        "right columns",
        "right reconstruct",
        "right split",
        "right dof",
        "right tonemap",
        "right present",
    ],
];

/// Passes per eye in [`BINOCULAR_PASSES`]: the sample side's, then the screen side's.
const EYE_PASSES: usize = 1 + SCREEN_PASSES.len();

/// The denoiser's passes as [`ResidentFrame::poll_gpu_times`] names them, after
/// [`BINOCULAR_PASSES`]' (absent, `None`, in frames whose plans do not denoise).
pub const DENOISE_PASSES: [&str; 2] = ["left denoise", "right denoise"];

/// The temporal accumulation's passes as [`ResidentFrame::poll_gpu_times`] names them, after
/// [`DENOISE_PASSES`] (absent, `None`, in frames without temporal accumulation). The copy of
/// its result over the samples that follows each pass is a buffer copy, not timed.
pub const TEMPORAL_PASSES: [&str; 2] = ["left temporal", "right temporal"];

/// Frames each timer's ring holds in flight.
const TIMER_RING: usize = 4;

/// The tone map the frame ends with (the CLI's `--exposure` and `--tone`; not in the plan).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneSettings {
    /// Exposure, stops.
    pub exposure_stops: f32,
    /// Tone curve.
    pub curve: ToneCurve,
}

/// Where one binocular frame's host time went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BinocularTimes {
    /// The frame's index in the timers (counted from 0 by [`ResidentFrame::render`]).
    pub frame: u64,
    /// Checking, preparing (tables, uniforms) and recording both eyes' every pass, wall ms:
    /// the render thread's work on the frame without the submission.
    pub host_ms: f64,
    /// The render thread's CPU time over the same span (`host_ms`), ms: what the work costs
    /// whatever else the machine runs (on a shared machine the wall time also counts the
    /// time the thread waited for a core); NaN where the thread clock is unavailable.
    pub host_cpu_ms: f64,
    /// Of that, the sample side's per-column tables, wall ms.
    pub tables_ms: f64,
    /// The `queue.submit` call, wall ms.
    pub submit_ms: f64,
}

/// The render thread's CPU clock now (`None` where the platform has none).
pub(crate) fn thread_cpu() -> Option<cpu_time::ThreadTime> {
    cpu_time::ThreadTime::try_now().ok()
}

/// Milliseconds of the render thread's CPU since `since` (NaN without a thread clock).
pub(crate) fn thread_cpu_ms(since: Option<cpu_time::ThreadTime>) -> f64 {
    since
        .and_then(|c| c.try_elapsed().ok())
        .map_or(f64::NAN, |d| d.as_secs_f64() * 1e3)
}

/// The frame's timers ([`ResidentFrame`]'s `timers`), each read back on its own: 16 bytes a
/// pass, 320 bytes a timed frame in all (the statistics' readback, well within issue 37's
/// 64 KiB a frame).
const TIMERS: usize = 5;

/// Each pass's name and GPU ms (`None`: not run, or not arrived yet).
type PassTimes = Vec<(&'static str, Option<f64>)>;

/// One eye's screen side and the limits it was built for.
struct EyeScreen {
    screen: ScreenContext,
    limits: ScreenLimits,
}

/// Both eyes' resident frame (see the module).
pub struct ResidentFrame {
    ctx: GpuContext,
    samples: ResidentSamples,
    screens: [Option<EyeScreen>; 2],
    tone: ToneSettings,
    /// Whether each eye's screen side also fills its presenter texture
    /// ([`Self::set_presenting`]).
    presenting: bool,
    /// The sample side's timer (one pass per eye), each eye's screen timer, the denoiser's
    /// and the temporal accumulation's (one pass per eye each); `None` on a device without
    /// timestamp queries.
    timers: Option<[FrameTimer; TIMERS]>,
    /// Frames whose timers have partly arrived: (frame, timers arrived, passes).
    pending: Vec<(u64, u8, PassTimes)>,
    frames: u64,
    /// Temporal accumulation between the shading and the screen side, when set
    /// ([`Self::set_temporal`]).
    temporal: Option<ResidentTemporal>,
    /// The eyes [`Self::render`] records: 2, or 1 (the left only, [`Self::set_eyes`]).
    eyes: usize,
}

/// The screen side's settings of `plan` seen by `camera`, or why the resident frame does not
/// run it.
fn screen_config(plan: &FramePlan, camera: &EyeCamera, tone: ToneSettings) -> Result<ScreenConfig> {
    let unsupported = |what: &str| {
        Err(GpuError::Unsupported(format!(
            "{what} in the resident frame"
        )))
    };
    let method = plan.method();
    if !ScreenContext::supports(method) {
        return Err(GpuError::Unsupported(format!(
            "the {method} mapping in the resident frame (it runs vafr, kfr, lafr, \
             visual-polar, guenter, inset, full and weier; use the staged --backend gpu or --backend cpu)"
        )));
    }
    if let Some(d) = &plan.settings.denoise {
        d.validate().map_err(|e| GpuError::Input(e.to_string()))?;
    }
    if plan.settings.contrast.is_some() {
        return unsupported("peripheral contrast enhancement");
    }
    let polar = plan.mapping().polar_layout().is_some();
    let aa = match plan.aa {
        AaMode::None | AaMode::Auto => None,
        AaMode::Fxaa => Some(SampleFilter::Fxaa(FxaaParams::default())),
        AaMode::Gaussian => Some(SampleFilter::Gaussian),
    };
    if aa.is_some() && !polar {
        return unsupported("sample-space AA at full resolution (use --aa none)");
    }
    let dof = match &plan.settings.dof {
        None => None,
        Some(d) => match d.filter {
            // The CoC map alone leaves the colour as it is.
            None => None,
            Some(FilterKind::Gather) => Some(ScreenDof {
                filter: ScatterAsGather::default(),
                coc: coc_params(d, camera),
            }),
            Some(other) => {
                return Err(GpuError::Unsupported(format!(
                    "the {} DOF filter in the resident frame (it runs the gather)",
                    other.name()
                )))
            }
        },
    };
    Ok(ScreenConfig {
        aa,
        filter: plan.settings.reconstruct_filter,
        dof,
        exposure_stops: tone.exposure_stops,
        curve: tone.curve,
        inset_smoothing: plan.settings.inset_smoothing,
        // Set by `ResidentFrame::set_presenting` (`fovea view` draws the texture).
        texture: false,
    })
}

/// Limits that hold `plan`'s mapping and its method's mappings at the screen's corners and
/// centre (where a screen-covering polar buffer is largest), so that a moving gaze does not
/// outgrow the screen side.
fn screen_limits(plan: &FramePlan) -> ScreenLimits {
    let maps =
        ScreenLimits::any_gaze_mappings(plan.method(), &plan.display, &plan.settings.mapping);
    let mut refs: Vec<&dyn FoveationMapping> = maps.iter().map(|m| m.as_ref()).collect();
    refs.push(plan.mapping());
    ScreenLimits::of(&refs)
}

impl ResidentFrame {
    /// Whether the resident frame renders `plan` seen by `camera`: `Ok` or the
    /// [`GpuError::Unsupported`] (or [`GpuError::Input`]) that [`Self::render`] would return,
    /// decided from the plan alone.
    pub fn supports(plan: &FramePlan, camera: &EyeCamera) -> Result<()> {
        samples_support(plan)?;
        screen_config(
            plan,
            camera,
            ToneSettings {
                exposure_stops: 0.0,
                curve: ToneCurve::Reinhard,
            },
        )?;
        if (camera.display.width_px, camera.display.height_px)
            != (plan.display.width_px, plan.display.height_px)
        {
            return Err(GpuError::Input(
                "the camera's display is not the plan's".into(),
            ));
        }
        Ok(())
    }

    /// Whether the resident frame accumulates `plan`'s frames temporally (with
    /// [`Self::set_temporal`] on): `Ok`, or the [`GpuError::Unsupported`] that [`Self::render`]
    /// returns before anything is sent — several sample layers (Guenter's, the inset's), and
    /// Weier's frames, which the CPU accumulates in screen
    /// space (`fovea_render::temporal::weier_taa`: the reconstructed frame kept as a pyramid
    /// history), not in sample space as the resident temporal pass does.
    pub fn supports_temporal(plan: &FramePlan) -> Result<()> {
        // The resident temporal pass accumulates one sample layer.
        if plan.buffers.len() != 1 {
            return Err(GpuError::Unsupported(format!(
                "temporal accumulation of {} sample layers ({}) in the resident frame (use \
                 --temporal off)",
                plan.buffers.len(),
                plan.method()
            )));
        }
        if plan.method() == Method::Weier {
            return Err(GpuError::Unsupported(format!(
                "temporal accumulation of the {} method in the resident frame (its screen-space \
                 pyramid history is CPU-only; turn temporal off or use --backend cpu)",
                plan.method()
            )));
        }
        Ok(())
    }

    /// The scene of `world` on `ctx`, each eye's screen side for `plans` (index = eye: left,
    /// right) seen by `cameras`, and the timers; each eye's sample buffers are made with its
    /// first frame. Refuses what [`Self::supports`] refuses, before allocating anything.
    pub fn new(
        ctx: &GpuContext,
        world: &World,
        plans: [&FramePlan; 2],
        cameras: [&EyeCamera; 2],
        tone: ToneSettings,
    ) -> Result<Self> {
        for e in 0..2 {
            Self::supports(plans[e], cameras[e])?;
        }
        if !tone.exposure_stops.is_finite() {
            return Err(GpuError::Input(format!(
                "exposure {} stops (a finite number of stops)",
                tone.exposure_stops
            )));
        }
        let samples = ResidentSamples::new(ctx, world)?;
        let timers = match (
            FrameTimer::new(ctx, &["left shade", "right shade"], TIMER_RING)?,
            FrameTimer::new(ctx, &SCREEN_PASSES, TIMER_RING)?,
            FrameTimer::new(ctx, &SCREEN_PASSES, TIMER_RING)?,
            FrameTimer::new(ctx, &DENOISE_PASSES, TIMER_RING)?,
            FrameTimer::new(ctx, &TEMPORAL_PASSES, TIMER_RING)?,
        ) {
            (Some(a), Some(b), Some(c), Some(d), Some(t)) => Some([a, b, c, d, t]),
            _ => None,
        };
        let mut frame = Self {
            ctx: ctx.clone(),
            samples,
            screens: [None, None],
            tone,
            presenting: false,
            timers,
            pending: Vec::new(),
            frames: 0,
            temporal: None,
            eyes: 2,
        };
        for e in 0..2 {
            frame.ensure_screen(e, plans[e], cameras[e])?;
        }
        Ok(frame)
    }

    /// Keeps eye `eye`'s screen side when it serves `plan`, else builds one for it.
    fn ensure_screen(&mut self, eye: usize, plan: &FramePlan, camera: &EyeCamera) -> Result<()> {
        let config = ScreenConfig {
            texture: self.presenting,
            ..screen_config(plan, camera, self.tone)?
        };
        let keep = self.screens[eye].as_ref().is_some_and(|s| {
            s.screen
                .matches(&plan.display, plan.method(), &config, s.limits)
                && s.screen.fits(plan.mapping())
        });
        if !keep {
            let limits = screen_limits(plan);
            let screen =
                ScreenContext::new(&self.ctx, &plan.display, plan.method(), config, limits)?;
            self.screens[eye] = Some(EyeScreen { screen, limits });
        }
        Ok(())
    }

    /// Turns temporal accumulation on with `settings` (the CPU's `TemporalSettings`, checked
    /// as the CPU checks them: [`GpuError::Input`]) or off (`None`). A new setting starts
    /// without history; the same one keeps it. The plans' jitter and noise frame should be the
    /// CPU accumulator's (`TemporalAccumulator::jitter`, `frame`), as for `render_planned`.
    pub fn set_temporal(
        &mut self,
        settings: Option<fovea_render::temporal::TemporalSettings>,
    ) -> Result<()> {
        if self.temporal.as_ref().map(|t| t.settings()) == settings.as_ref() {
            return Ok(());
        }
        self.temporal = match settings {
            Some(s) => Some(ResidentTemporal::new(&self.ctx, s)?),
            None => None,
        };
        Ok(())
    }

    /// Forgets the temporal history (a cut): the next frame is accumulated afresh.
    pub fn reset_temporal(&mut self) {
        if let Some(t) = &mut self.temporal {
            t.reset();
        }
    }

    /// The temporal accumulation's settings, when on.
    pub fn temporal(&self) -> Option<&fovea_render::temporal::TemporalSettings> {
        self.temporal.as_ref().map(|t| t.settings())
    }

    /// From the next frame on, each eye's screen side also fills an `Rgba8Unorm` texture on
    /// the frame's device with the tone-mapped frame ([`ScreenConfig::texture`]; one more pass
    /// per eye, `present`), which a presenter on the same device draws without a readback
    /// (issue 37, item 6: `fovea view`). Changing it rebuilds both screen sides at the next
    /// [`Self::render`].
    pub fn set_presenting(&mut self, on: bool) {
        self.presenting = on;
    }

    /// The tone map from the next frame on (the viewer's exposure keys); a change rebuilds
    /// both screen sides at the next [`Self::render`], the scene stays.
    pub fn set_tone(&mut self, tone: ToneSettings) -> Result<()> {
        if !tone.exposure_stops.is_finite() {
            return Err(GpuError::Input(format!(
                "exposure {} stops (a finite number of stops)",
                tone.exposure_stops
            )));
        }
        self.tone = tone;
        Ok(())
    }

    /// Eye `eye`'s presenter texture (0 left, 1 right): the last submitted frame's
    /// tone-mapped sRGB codes, alpha 255, `Rgba8Unorm`; `None` unless
    /// [`Self::set_presenting`] was on for the last [`Self::render`]. The same texture from
    /// frame to frame while the eye's screen side is kept.
    pub fn texture(&self, eye: usize) -> Option<&wgpu::Texture> {
        self.screen(eye)?.texture()
    }

    /// The device the frame renders on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The sample side (its scene, each eye's buffers).
    pub fn samples(&self) -> &ResidentSamples {
        &self.samples
    }

    /// Eye `eye`'s screen side.
    pub fn screen(&self, eye: usize) -> Option<&ScreenContext> {
        self.screens.get(eye)?.as_ref().map(|s| &s.screen)
    }

    /// Whether per-pass GPU times are measured (the device has timestamp queries).
    pub fn timed(&self) -> bool {
        self.timers.is_some()
    }

    /// Renders one binocular frame: checks both eyes' plans (refusals before anything is
    /// written), readies each eye's buffers and uniforms, records both eyes' sample side and
    /// then both eyes' screen side — every pass, timed — into one encoder, and submits it once.
    /// No wait, nothing read back (but the timers' slots of earlier frames, mapped without
    /// waiting). `plans` and `cameras` are indexed by eye (left, right).
    pub fn render(
        &mut self,
        world: &World,
        plans: [&FramePlan; 2],
        cameras: [&EyeCamera; 2],
    ) -> Result<BinocularTimes> {
        let t = Instant::now();
        let cpu = thread_cpu();
        for e in 0..2 {
            Self::supports(plans[e], cameras[e])?;
            if self.temporal.is_some() && plans[e].buffers.len() != 1 {
                return Err(GpuError::Unsupported(format!(
                    "temporal accumulation of {} sample layers ({}) in the resident frame",
                    plans[e].buffers.len(),
                    plans[e].method()
                )));
            }
        }
        if self.temporal.is_some() {
            for p in plans {
                Self::supports_temporal(p)?;
            }
        }
        for e in 0..self.eyes {
            self.ensure_screen(e, plans[e], cameras[e])?;
        }
        let t_tables = self.samples_tables_ms();
        let mut encoder =
            self.ctx
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("resident binocular frame"),
                });
        for e in 0..self.eyes {
            self.samples.prepare_eye(e, world, cameras[e], plans[e])?;
        }
        if let Some(t) = &mut self.temporal {
            for e in 0..self.eyes {
                let shade = self.samples.eye(e).ok_or_else(|| {
                    GpuError::Input(format!("eye {e} of the resident frame was not prepared"))
                })?;
                t.prepare(e, plans[e], cameras[e], shade)?;
            }
        }
        let tables_ms = self.samples_tables_ms() - t_tables;
        let frame = self.frames;
        self.frames += 1;
        let ctx = self.ctx.clone();
        ctx.scoped(
            "recording the resident binocular frame",
            || -> Result<()> {
                if let Some(timers) = &mut self.timers {
                    for timer in timers.iter_mut() {
                        timer.begin_frame();
                    }
                }
                for e in 0..self.eyes {
                    let eye = self.samples.eye(e).ok_or_else(|| {
                        GpuError::Input(format!("eye {e} of the resident frame was not prepared"))
                    })?;
                    let writes = self.timers.as_mut().and_then(|t| t[0].writes(e));
                    eye.record_timed(self.samples.scene(), &mut encoder, writes);
                }
                // Temporal accumulation: after the shading, before the screen side.
                if let Some(t) = &mut self.temporal {
                    for e in 0..self.eyes {
                        let writes = self.timers.as_mut().and_then(|t| t[4].writes(e));
                        t.record(e, &mut encoder, writes)?;
                    }
                }
                // The sample-space denoiser, after shading and temporal accumulation, before
                // the screen side (issue 38).
                for (e, plan) in plans.iter().enumerate().take(self.eyes) {
                    let writes = match plan.settings.denoise {
                        Some(_) => self.timers.as_mut().and_then(|t| t[3].writes(e)),
                        None => None,
                    };
                    self.samples.record_denoise(e, plan, &mut encoder, writes)?;
                }
                for e in 0..self.eyes {
                    let samples = self.samples.samples(e).ok_or_else(|| {
                        GpuError::Input(format!("eye {e} of the resident frame has no samples"))
                    })?;
                    let Some(s) = &mut self.screens[e] else {
                        return Err(GpuError::Input(format!("eye {e} has no screen side")));
                    };
                    let input = ScreenInput {
                        mapping: plans[e].mapping(),
                        focus: plans[e].focus_m().map(Metres),
                    };
                    let timer = self.timers.as_mut().map(|t| &mut t[1 + e]);
                    s.screen.record(&mut encoder, samples, &input, timer)?;
                }
                if let Some(timers) = &self.timers {
                    for timer in timers {
                        timer.end_frame(&mut encoder);
                    }
                }
                Ok(())
            },
        )??;
        let commands = encoder.finish();
        let host_ms = t.elapsed().as_secs_f64() * 1e3;
        let host_cpu_ms = thread_cpu_ms(cpu);
        let t = Instant::now();
        ctx.scoped("submitting the resident binocular frame", || {
            ctx.submit([commands])
        })?;
        if let Some(timers) = &mut self.timers {
            for timer in timers.iter_mut() {
                timer.submitted();
            }
        }
        Ok(BinocularTimes {
            frame,
            host_ms,
            host_cpu_ms,
            tables_ms,
            submit_ms: t.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The sample side's table time so far (its counter is reset by `render_eyes` only).
    fn samples_tables_ms(&self) -> f64 {
        self.samples.tables_ms()
    }

    /// From the next frame on, record both eyes (`2`, the default) or the left eye's passes
    /// only (`1`: a one-eye frame — `fovea sequence` — whose right plan and camera are
    /// checked and not rendered, so the device does the eye's work once). A change forgets
    /// the temporal history.
    pub fn set_eyes(&mut self, eyes: usize) -> Result<()> {
        if !(1..=2).contains(&eyes) {
            return Err(GpuError::Input(format!("{eyes} eyes (1 or 2)")));
        }
        if eyes != self.eyes {
            self.eyes = eyes;
            self.reset_temporal();
        }
        Ok(())
    }

    /// Eye `eye`'s (0 left, 1 right) tone-mapped image of the last submitted frame: 8-bit
    /// sRGB, 3 bytes a pixel, row-major (`to_srgb8`'s bytes) — a counted, blocking readback,
    /// for `render --out`, screenshots and sequences only.
    pub fn image(&mut self, eye: usize) -> Result<Vec<u8>> {
        if eye >= self.eyes {
            return Err(GpuError::Input(format!(
                "eye {eye} of a frame that renders {} eye",
                self.eyes
            )));
        }
        let Some(Some(s)) = self.screens.get_mut(eye) else {
            return Err(GpuError::Input(format!("eye {eye} (0 left, 1 right)")));
        };
        s.screen.read_srgb8()
    }

    /// The frames whose every pass's GPU time has arrived since the last call, oldest first,
    /// the passes named as [`BINOCULAR_PASSES`] (left eye, then right), then
    /// [`DENOISE_PASSES`], then [`TEMPORAL_PASSES`]. Never blocks.
    pub fn poll_gpu_times(&mut self) -> Result<Vec<FrameGpuTimes>> {
        let Some(timers) = &mut self.timers else {
            return Ok(Vec::new());
        };
        for (k, timer) in timers.iter_mut().enumerate() {
            for t in timer.poll()? {
                let at = match self.pending.iter().position(|p| p.0 == t.frame) {
                    Some(at) => at,
                    None => {
                        let passes = BINOCULAR_PASSES
                            .iter()
                            .flatten()
                            .chain(&DENOISE_PASSES)
                            .chain(&TEMPORAL_PASSES)
                            .map(|&n| (n, None))
                            .collect();
                        self.pending.push((t.frame, 0, passes));
                        self.pending.len() - 1
                    }
                };
                let entry = &mut self.pending[at];
                entry.1 |= 1 << k;
                for (p, (_, ms)) in t.passes.iter().enumerate() {
                    let slot = match k {
                        0 => EYE_PASSES * p,
                        3 => 2 * EYE_PASSES + p,
                        4 => 2 * EYE_PASSES + DENOISE_PASSES.len() + p,
                        eye => EYE_PASSES * (eye - 1) + 1 + p,
                    };
                    if let Some(e) = entry.2.get_mut(slot) {
                        e.1 = *ms;
                    }
                }
            }
        }
        let mut done: Vec<FrameGpuTimes> = Vec::new();
        self.pending.retain(|(frame, arrived, passes)| {
            if *arrived == (1 << TIMERS) - 1 {
                done.push(FrameGpuTimes {
                    frame: *frame,
                    passes: passes.clone(),
                });
                false
            } else {
                true
            }
        });
        // A frame one timer left untimed never completes: forget those far behind.
        if let Some(last) = done.iter().map(|d| d.frame).max() {
            let horizon = 4 * TIMER_RING as u64;
            self.pending.retain(|p| p.0 + horizon > last);
        }
        done.sort_by_key(|d| d.frame);
        Ok(done)
    }
}
