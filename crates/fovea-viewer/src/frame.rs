//! The viewer's frames: a [`FrameRequest`] (view settings, display, camera pose, gaze) run
//! through the same frame plan and stages as `fovea render` (`fovea_render::pipeline`), on the
//! GPU executors when the viewer was given them, and turned into the 8-bit image the window
//! shows ([`ViewFrame`]). [`RenderWorker`] runs it on its own thread, newest request first, so
//! the window stays responsive while a CPU frame takes its time, and refines a reduced-scale
//! frame to full scale when the view is still.
//!
//! With a GPU context ([`FrameRenderer::set_resident`]) the views the resident frame serves
//! (`fovea_gpu::frame::ResidentFrame`: both eyes' every pass in one submission, nothing read
//! back, issue 37) render on it and end in one texture per eye on that device, which the
//! window draws directly ([`ViewFrame::resident`]); the 8-bit bytes are read back only when
//! an image is asked for ([`FrameRequest::read_back`]: screenshots, `--frames-out`). The
//! views it does not serve fall back to the staged path above, with a one-line notice.

use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

use glam::Vec3;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::gaze::GazeSample;
use fovea_core::units::{CyclesPerDegree, Degrees};
use fovea_core::Image;
use fovea_gpu::frame::{ResidentFrame, ToneSettings};
use fovea_gpu::traffic::TrafficCounts;
use fovea_gpu::GpuContext;
use fovea_post::tonemap::{to_srgb8, ToneCurve, ToneMapExecutor};
use fovea_render::camera::EyeCamera;
use fovea_render::eye::{EyeState, EyeTracker};
use fovea_render::lod::{LodParams, LodScene, LodStats};
use fovea_render::pipeline::{
    in_lockstep, render_planned, Executors, FrameContext, FrameInputs, FrameSettings, FrameStats,
    Lockstep, Stage, StageTimes, Stopwatch,
};
use fovea_render::plan::FramePlan;
use fovea_render::scene::Light;
use fovea_render::shade::FrameNoise;
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};
use fovea_render::world::World;

use crate::controls::{EyesChoice, LightsChoice, ViewSettings};
use crate::error::{Result, ViewerError};

/// Eccentricities of the ring overlay, degrees.
pub const RING_DEG: [f64; 6] = [5.0, 10.0, 20.0, 30.0, 45.0, 60.0];

/// Where the eye camera is: position, view direction and up, world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Eye position, metres.
    pub position: Vec3,
    /// View direction (unit).
    pub forward: Vec3,
    /// Up (unit).
    pub up: Vec3,
}

impl Pose {
    /// The pose of a camera.
    pub fn of(camera: &EyeCamera) -> Self {
        Self {
            position: camera.position,
            forward: camera.forward,
            up: camera.up,
        }
    }

    /// The pose of a camera path at `t_s` seconds, as `fovea sequence --camera-path` places
    /// its camera (`display` only checks it).
    pub fn along(
        path: &fovea_render::camera_path::CameraPath,
        t_s: f64,
        display: &DisplayProfile,
    ) -> Result<Self> {
        let (pos, look, up) = path.at(t_s);
        Ok(Self::of(&EyeCamera::new(pos, look - pos, up, display)?))
    }

    /// The camera at this pose rendering `display`.
    pub fn camera(&self, display: &DisplayProfile) -> Result<EyeCamera> {
        Ok(EyeCamera::new(
            self.position,
            self.forward,
            self.up,
            display,
        )?)
    }
}

/// One frame to render.
#[derive(Clone, Debug)]
pub struct FrameRequest {
    /// A number the frame comes back with.
    pub id: u64,
    /// The view settings.
    pub view: ViewSettings,
    /// The display at full scale.
    pub display: DisplayProfile,
    /// The eye camera's pose (the head's, with both eyes).
    pub pose: Pose,
    /// The gaze, pixels of the full-scale display.
    pub gaze: GazeSample,
    /// Seconds since the previous frame's gaze (the accommodation filter's step); 0 renders
    /// the previous eye state again (a refinement).
    pub dt_s: f64,
    /// Whether the frame's 8-bit bytes are wanted on the CPU ([`ViewFrame::rgba`]). A
    /// resident GPU frame reads them back only then (a screenshot, `--frames-out`, a window
    /// drawn by another device); the other paths always make them.
    pub read_back: bool,
}

/// What the resident GPU frame did for one binocular frame (the HUD's and the screenshot's
/// figures; the traffic counted by `fovea_gpu`'s instrumentation).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ResidentStats {
    /// The frame's index in the resident frame (counted from 0).
    pub frame: u64,
    /// The render thread's time preparing and recording the frame, without the submit, ms.
    pub host_ms: f64,
    /// The `queue.submit`, ms.
    pub submit_ms: f64,
    /// This frame's traffic (the render call alone, not an image read back for a
    /// screenshot).
    pub traffic: Traffic,
    /// Each pass's GPU ms of the newest frame whose timestamps had arrived (frames late,
    /// never waited for), and that frame's index; empty until the first arrives or on a
    /// device without timestamps.
    pub gpu_ms: Vec<(String, f64)>,
    /// The frame the GPU times are of.
    pub gpu_frame: Option<u64>,
    /// Since the resident frame was made: frames rendered and their traffic summed.
    pub totals: ResidentTotals,
}

/// What crossed the bus and what the host waited for, as counted by `fovea_gpu`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Traffic {
    /// Bytes written to the device.
    pub bytes_uploaded: u64,
    /// Bytes read back (the timestamps' few bytes unless an image was asked for).
    pub bytes_read_back: u64,
    /// Queue submissions.
    pub submissions: u64,
    /// Blocking waits on the device.
    pub blocking_waits: u64,
    /// Buffers created.
    pub buffers_created: u64,
    /// Bind groups created.
    pub bind_groups_created: u64,
}

impl Traffic {
    fn of(t: &TrafficCounts) -> Self {
        Self {
            bytes_uploaded: t.bytes_uploaded,
            bytes_read_back: t.bytes_read_back,
            submissions: t.submissions,
            blocking_waits: t.blocking_waits,
            buffers_created: t.buffers_created,
            bind_groups_created: t.bind_groups_created,
        }
    }

    fn add(&mut self, o: &Self) {
        self.bytes_uploaded += o.bytes_uploaded;
        self.bytes_read_back += o.bytes_read_back;
        self.submissions += o.submissions;
        self.blocking_waits += o.blocking_waits;
        self.buffers_created += o.buffers_created;
        self.bind_groups_created += o.bind_groups_created;
    }
}

/// The resident frame's running totals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ResidentTotals {
    /// Frames rendered by the resident frame.
    pub frames: u64,
    /// Their render calls' traffic, summed (images read back not included).
    pub traffic: Traffic,
    /// Images read back (one per eye for each frame asked for as bytes).
    pub images_read: u64,
    /// Their bytes.
    pub image_bytes: u64,
}

/// A frame the resident GPU frame rendered: its textures on the render device, which the
/// window draws directly, and its figures.
#[derive(Clone, Debug)]
pub struct ResidentView {
    /// Each shown eye's tone-mapped frame (`Rgba8Unorm`, sRGB codes, alpha 255), left first.
    pub textures: Vec<wgpu::Texture>,
    /// The frame's figures.
    pub stats: ResidentStats,
}

/// A rendered frame, ready to show.
#[derive(Clone, Debug)]
pub struct ViewFrame {
    /// The request's id.
    pub id: u64,
    /// Width, pixels (both eyes: twice the display's).
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// 8-bit sRGB, RGBA, row by row.
    pub rgba: Vec<u8>,
    /// The statistics of each eye's frame.
    pub stats: Vec<FrameStats>,
    /// The request.
    pub request: FrameRequest,
    /// The (first) eye's camera.
    pub camera: EyeCamera,
    /// The eye state the frame was rendered for.
    pub eye: EyeState,
    /// The scale rendered (1: full).
    pub scale: f32,
    /// Eccentricity rings ([`RING_DEG`]) as polylines in frame pixels (one eye).
    pub rings: Vec<Vec<[f32; 2]>>,
    /// The level of detail, when on.
    pub lod: Option<LodStats>,
    /// Wall time of the whole frame, milliseconds.
    pub wall_ms: f64,
    /// The executors that ran (`cpu`, or `gpu` for the primary rays / reconstruction).
    pub backend: String,
    /// Whether both eyes rendered at the same time, their device work in shared submissions.
    pub lockstep: bool,
    /// Rendered by the resident GPU frame: its textures and figures (`rgba` is empty unless
    /// the request asked for the bytes); `None` on the other paths.
    pub resident: Option<ResidentView>,
}

impl ViewFrame {
    /// Eyes side by side in the frame (1 or 2).
    pub fn eyes(&self) -> usize {
        if self.request.view.eyes == EyesChoice::Both {
            2
        } else {
            1
        }
    }
}

/// The right eye's executors of a viewer whose eyes render at the same time, on the device of
/// the left eye's, and that device's meeting point for both eyes' submissions.
pub struct SecondEyeExecutors {
    /// The right eye's executors.
    pub executors: Executors,
    /// Where both eyes' submissions meet.
    pub lockstep: Arc<dyn Lockstep + Send + Sync>,
}

/// Renders requests with one world, reusing buffers and the temporal history from frame to
/// frame.
pub struct FrameRenderer {
    world: World,
    all_lights: Vec<Light>,
    base: FrameSettings,
    ipd_m: f32,
    /// Each eye's buffers; the executors stay in the first's between frames (in lockstep
    /// each eye keeps its own).
    ctx: [FrameContext; 2],
    /// Where both eyes' submissions meet when they render at the same time.
    lockstep: Option<Arc<dyn Lockstep + Send + Sync>>,
    /// The display encoding's executor, if not the CPU.
    tone_map: Option<Box<dyn ToneMapExecutor>>,
    tracker: EyeTracker,
    last_eye: Option<EyeState>,
    accumulator: Option<(TemporalAccumulator, String)>,
    lod: Option<LodScene>,
    /// The resident GPU frame's device and state, when the frames render on a GPU.
    resident: Option<Resident>,
}

/// The resident GPU frame of a viewer, made with the first view it serves.
struct Resident {
    ctx: GpuContext,
    /// The frame and the lights it was made for (a change of lights uploads the scene again).
    frame: Option<(ResidentFrame, LightsChoice)>,
    totals: ResidentTotals,
    gpu: Option<fovea_gpu::frame::FrameGpuTimes>,
    /// The last fallback said (each new reason is said once).
    said: Option<String>,
    quiet: bool,
    /// Frames accumulated on the device since temporal accumulation (T) went on or the frame
    /// was made: the next frame's noise index, as the CPU accumulator's `frame()`.
    accumulated: u64,
}

/// Why the resident frame does not render `view` (checked before the plans; the plans'
/// own refusals come from `ResidentFrame::supports`).
fn resident_refusal(view: &ViewSettings) -> Option<&'static str> {
    if view.lod {
        Some("level of detail (L) changes the scene per gaze")
    } else if view.overlays.density || view.overlays.coc {
        Some("the density and CoC overlays (Y, C) read the frame on the CPU")
    } else {
        None
    }
}

impl FrameRenderer {
    /// A renderer of `world` with `base` settings (the panel changes the rest), both eyes
    /// `ipd_m` apart; `executors` run the stages they support (both eyes, in turn), and
    /// `tone_map` the display encoding.
    pub fn new(
        world: World,
        base: FrameSettings,
        ipd_m: f32,
        executors: Executors,
        tone_map: Option<Box<dyn ToneMapExecutor>>,
    ) -> Result<Self> {
        let mut ctx = [FrameContext::new(), FrameContext::new()];
        ctx[0].set_executors(executors);
        Ok(Self {
            tone_map,
            all_lights: world.lights.clone(),
            world,
            base,
            ipd_m,
            ctx,
            lockstep: None,
            tracker: EyeTracker::new(Default::default())?,
            last_eye: None,
            accumulator: None,
            lod: None,
            resident: None,
        })
    }

    /// Renders the views the resident GPU frame serves on `ctx` (the device of the
    /// executors, and of the window when it can present): both eyes' every pass in one
    /// submission, the frame left on the device as a texture per eye. The other views keep
    /// the path above; each new reason is said in one `note:` line (unless `quiet`).
    pub fn set_resident(&mut self, ctx: GpuContext, quiet: bool) {
        self.resident = Some(Resident {
            ctx,
            frame: None,
            totals: ResidentTotals::default(),
            gpu: None,
            said: None,
            quiet,
            accumulated: 0,
        });
    }

    /// Renders both eyes at the same time from now on, the right eye on `second`'s
    /// executors (on the same device as the left's), their device work in shared
    /// submissions.
    pub fn set_second_eye(&mut self, second: SecondEyeExecutors) {
        self.ctx[1].set_executors(second.executors);
        self.lockstep = Some(second.lockstep);
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Renders one request.
    pub fn render(&mut self, req: &FrameRequest) -> Result<ViewFrame> {
        let t0 = Stopwatch::start();
        let view = &req.view;
        let mut settings = view.frame_settings(&self.base)?;
        self.world.lights = match view.lights {
            LightsChoice::One => self.all_lights.iter().take(1).cloned().collect(),
            LightsChoice::All => self.all_lights.clone(),
        };
        let scale = view.scale.clamp(0.05, 1.0);
        let display = scaled_display(&req.display, scale)?;
        if scale < 1.0 {
            // VaFR's buffer follows the acuity model, not the display: at a reduced scale it
            // would shade as many samples as at full scale. Capped at the reduced display's
            // Nyquist rate (VaFR Sec. 3.3, the headset cap), it shades what that display can
            // show. The full-scale frame is uncapped, as `fovea render`.
            let vafr = &mut settings.mapping.vafr;
            vafr.acuity = vafr
                .acuity
                .clamped(CyclesPerDegree(display.nyquist_cpd()))?;
        }
        let camera = req.pose.camera(&display)?;
        let sx = f64::from(display.width_px) / f64::from(req.display.width_px);
        let sy = f64::from(display.height_px) / f64::from(req.display.height_px);
        let mut sample = req.gaze;
        sample.x_px = (sample.x_px * sx).clamp(0.0, f64::from(display.width_px));
        sample.y_px = (sample.y_px * sy).clamp(0.0, f64::from(display.height_px));
        sample.right = sample.right.map(|(x, y)| (x * sx, y * sy));
        let mut times = StageTimes::default();
        let t = Stopwatch::start();
        let eye = match (&self.last_eye, req.dt_s > 0.0) {
            (Some(last), false) => {
                let mut e = *last;
                e.gaze = display.gaze(sample.x_px, sample.y_px)?;
                e
            }
            _ => self.tracker.update(
                &self.world,
                &camera,
                &sample,
                settings.dof.as_ref(),
                None,
                req.dt_s.max(1e-3),
            )?,
        };
        self.last_eye = Some(eye);
        times.add(Stage::Plan, &t);

        // The level of detail of this gaze and focus (Liu Eq. 14), shared by both eyes.
        let (lod_world, lod_stats) = if view.lod {
            let (w, st) = self.lod_world(&camera, &settings, &eye)?;
            (Some(w), Some(st))
        } else {
            self.lod = None;
            (None, None)
        };
        let world = lod_world.as_ref().unwrap_or(&self.world);

        if let Some(resident) = &mut self.resident {
            let attempt = ResidentAttempt {
                req,
                view,
                settings: &settings,
                display: &display,
                camera: &camera,
                eye: &eye,
                ipd_m: self.ipd_m,
            };
            if let Some(frame) = resident.render(world, attempt)? {
                return Ok(ViewFrame {
                    scale,
                    lod: lod_stats,
                    wall_ms: t0.elapsed_ms().0,
                    ..frame
                });
            }
        }

        let mut frames = Vec::new();
        match view.eyes {
            EyesChoice::One => {
                // Temporal history belongs to one display, method and setting.
                let key = format!("{}x{} {:?}", display.width_px, display.height_px, settings);
                if view.temporal {
                    if self.accumulator.as_ref().is_none_or(|(_, k)| *k != key) {
                        self.accumulator =
                            Some((TemporalAccumulator::new(TemporalSettings::default())?, key));
                    }
                } else {
                    self.accumulator = None;
                }
                let jitter = self
                    .accumulator
                    .as_ref()
                    .map_or([0.0, 0.0], |(a, _)| a.jitter(settings.method));
                // Each accumulated frame draws its own random numbers (issue 38).
                let noise = self.accumulator.as_ref().map_or(0, |(a, _)| a.frame());
                let plan = FramePlan::new(world, &camera, &settings, &eye, jitter)?
                    .with_noise(FrameNoise::new(noise, 0));
                let inputs = FrameInputs {
                    accumulator: self.accumulator.as_mut().map(|(a, _)| a),
                    prefill: None,
                };
                render_planned(
                    &mut self.ctx[0],
                    world,
                    &camera,
                    &plan,
                    inputs,
                    times,
                    &|_, _| {},
                )?;
            }
            EyesChoice::Both => {
                self.accumulator = None;
                let rig = fovea_render::camera::HmdRig::new(
                    camera.position,
                    camera.forward,
                    camera.up,
                    self.ipd_m,
                )?;
                let (_, pair) =
                    fovea_render::stereo::fixating_eyes(world, &rig, &display, &eye.gaze)?;
                if let Some(lockstep) = &self.lockstep {
                    // Each eye plans and renders on its own thread, in its own context.
                    let [(lc, lg), (rc, rg)] = pair;
                    let [left, right] = &mut self.ctx;
                    let settings = &settings;
                    let one = |ctx: &mut FrameContext,
                               cam: &EyeCamera,
                               gaze: Gaze,
                               index: u32,
                               times: StageTimes|
                     -> fovea_render::Result<()> {
                        let mut e = eye;
                        e.gaze = gaze;
                        let plan = FramePlan::new(world, cam, settings, &e, [0.0, 0.0])?
                            .with_noise(FrameNoise::new(0, index));
                        render_planned(
                            ctx,
                            world,
                            cam,
                            &plan,
                            FrameInputs::default(),
                            times,
                            &|_, _| {},
                        )?;
                        Ok(())
                    };
                    in_lockstep(
                        &**lockstep,
                        || one(left, &lc, lg, 0, times),
                        || one(right, &rc, rg, 1, StageTimes::default()),
                    )?;
                } else {
                    for (k, (cam, gaze)) in pair.into_iter().enumerate() {
                        let mut e = eye;
                        e.gaze = gaze;
                        // Each eye draws its own random numbers, as `fovea render --eyes
                        // both` (`fovea_render::stereo`).
                        let plan = FramePlan::new(world, &cam, &settings, &e, [0.0, 0.0])?
                            .with_noise(FrameNoise::new(0, k as u32));
                        // The executors go to this eye's context and come back, error or not.
                        if k > 0 {
                            let executors = self.ctx[0].take_executors();
                            self.ctx[k].set_executors(executors);
                        }
                        let rendered = render_planned(
                            &mut self.ctx[k],
                            world,
                            &cam,
                            &plan,
                            FrameInputs::default(),
                            if k == 0 { times } else { StageTimes::default() },
                            &|_, _| {},
                        )
                        .map(|_| ());
                        if k > 0 {
                            let executors = self.ctx[k].take_executors();
                            self.ctx[0].set_executors(executors);
                        }
                        rendered?;
                    }
                }
            }
        }
        let eyes = if view.eyes == EyesChoice::Both { 2 } else { 1 };
        for ctx in &self.ctx[..eyes] {
            frames.push(
                ctx.frame()
                    .ok_or_else(|| ViewerError::Render("the pipeline returned no frame".into()))?,
            );
        }
        let (w, h) = (display.width_px, display.height_px);
        let width = w * eyes as u32;
        let mut rgba = vec![255u8; (width * h * 4) as usize];
        for (k, f) in frames.iter().enumerate() {
            let rgb = eye_rgb(f, view, self.tone_map.as_deref_mut())?;
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let src = (y * w as usize + x) * 3;
                    let dst = (y * width as usize + k * w as usize + x) * 4;
                    rgba[dst..dst + 3].copy_from_slice(&rgb[src..src + 3]);
                }
            }
        }
        let rings = if view.overlays.rings {
            rings(&camera, &eye.gaze)
        } else {
            Vec::new()
        };
        let stats: Vec<FrameStats> = frames.iter().map(|f| f.stats.clone()).collect();
        let backend = stats.first().map_or("cpu".to_string(), |s| {
            if s.trace_backend == "cpu" && s.reconstruct_backend == "cpu" {
                "cpu".to_string()
            } else {
                format!(
                    "primary rays {}, surfaces {}, shadow rays {}, direct light {}, \
                     environment light {}, reconstruct {}",
                    s.trace_backend,
                    s.surface_backend,
                    s.shadow_backend,
                    s.direct_light_backend,
                    s.environment_light_backend,
                    s.reconstruct_backend
                )
            }
        });
        Ok(ViewFrame {
            id: req.id,
            width,
            height: h,
            rgba,
            stats,
            request: req.clone(),
            camera,
            eye,
            scale,
            rings,
            lod: lod_stats,
            wall_ms: t0.elapsed_ms().0,
            backend,
            lockstep: eyes == 2 && self.lockstep.is_some(),
            resident: None,
        })
    }

    /// The frame's world with gaze-contingent level of detail (as `fovea render --lod on`;
    /// the simplified meshes are built once, when LOD is first turned on).
    fn lod_world(
        &mut self,
        camera: &EyeCamera,
        settings: &FrameSettings,
        eye: &EyeState,
    ) -> Result<(World, LodStats)> {
        if self.lod.is_none() {
            self.lod = Some(LodScene::new(
                self.world.scene.clone(),
                LodParams::default(),
            )?);
        }
        let lod = self.lod.as_ref().expect("set above");
        let eye_model = settings
            .dof
            .as_ref()
            .map_or(fovea_core::optics::EyeModel::default(), |d| d.eye);
        Ok(lod.world_for(&self.world, camera, &eye_model, eye)?)
    }
}

/// What one view asks of the resident frame.
struct ResidentAttempt<'a> {
    req: &'a FrameRequest,
    view: &'a ViewSettings,
    settings: &'a FrameSettings,
    display: &'a DisplayProfile,
    camera: &'a EyeCamera,
    eye: &'a EyeState,
    ipd_m: f32,
}

impl Resident {
    /// Says once why a view falls back.
    fn fall_back(&mut self, why: String) {
        if self.said.as_deref() != Some(why.as_str()) {
            if !self.quiet {
                eprintln!(
                    "note: the resident GPU frame does not render this view ({why}); \
                     rendering it with the staged GPU path, each frame read back"
                );
            }
            self.said = Some(why);
        }
    }

    /// The frame of `a` on the device, or `None` when the resident frame does not serve it
    /// (said once; the caller renders it the staged way).
    fn render(&mut self, world: &World, a: ResidentAttempt<'_>) -> Result<Option<ViewFrame>> {
        if let Some(why) = resident_refusal(a.view) {
            self.fall_back(why.to_string());
            return Ok(None);
        }
        let both = a.view.eyes == EyesChoice::Both;
        // Temporal accumulation (T) where the CPU path accumulates: one eye shown (both eyes
        // render each frame afresh there, and so here).
        let accumulate = a.view.temporal && !both;
        // Each eye's camera and eye state: both eyes at the fixated point (as the staged
        // path and `fovea render --eyes both`), or the one eye twice (the resident frame takes
        // two plans; with one eye shown it renders the left only, `ResidentFrame::set_eyes`).
        let eyes: [(EyeCamera, EyeState); 2] = if both {
            let rig = fovea_render::camera::HmdRig::new(
                a.camera.position,
                a.camera.forward,
                a.camera.up,
                a.ipd_m,
            )?;
            let (_, [(lc, lg), (rc, rg)]) =
                fovea_render::stereo::fixating_eyes(world, &rig, a.display, &a.eye.gaze)?;
            let (mut le, mut re) = (*a.eye, *a.eye);
            le.gaze = lg;
            re.gaze = rg;
            [(lc, le), (rc, re)]
        } else {
            [(a.camera.clone(), *a.eye), (a.camera.clone(), *a.eye)]
        };
        let mut plans = Vec::with_capacity(2);
        for (k, (cam, e)) in eyes.iter().enumerate() {
            // Each eye its own random numbers (as `fovea render --eyes both` and the staged
            // path); one eye shown: the staged path's frame 0 without an accumulator.
            let index = if both { k as u32 } else { 0 };
            // With temporal accumulation (T) each frame draws its own random numbers, as the
            // CPU accumulator's frames do (issue 38); the device's pass blends them.
            let noise = if accumulate { self.accumulated } else { 0 };
            let plan = FramePlan::new(world, cam, a.settings, e, [0.0, 0.0])?
                .with_noise(FrameNoise::new(noise, index));
            if let Err(e) = ResidentFrame::supports(&plan, cam) {
                self.fall_back(e.to_string());
                return Ok(None);
            }
            // The resident temporal pass accumulates one sample layer (not Guenter's or the
            // inset's several).
            if accumulate && plan.buffers.len() != 1 {
                self.fall_back(format!(
                    "temporal accumulation (T) of {} sample layers in the resident frame",
                    plan.buffers.len()
                ));
                return Ok(None);
            }
            plans.push(plan);
        }
        let plans = [&plans[0], &plans[1]];
        let cams = [&eyes[0].0, &eyes[1].0];
        let tone = ToneSettings {
            exposure_stops: a.view.exposure_stops,
            curve: ToneCurve::Reinhard,
        };
        let gpu_err =
            |e: fovea_gpu::GpuError| ViewerError::Render(format!("resident GPU frame: {e}"));
        if self.frame.as_ref().is_none_or(|(_, l)| *l != a.view.lights) {
            self.frame = None;
            let mut f = ResidentFrame::new(&self.ctx, world, plans, cams, tone).map_err(gpu_err)?;
            f.set_presenting(true);
            self.frame = Some((f, a.view.lights));
            self.accumulated = 0;
            self.totals = ResidentTotals::default();
            self.gpu = None;
        }
        let Some((frame, _)) = &mut self.frame else {
            return Ok(None);
        };
        frame.set_tone(tone).map_err(gpu_err)?;
        // One eye shown: the frame records the left eye's passes only (the right plan and
        // camera, the same eye's, are checked and not rendered); both: both. A change (which
        // also turns the accumulation on or off below) forgets the temporal history.
        let shown = if both { 2 } else { 1 };
        frame.set_eyes(shown).map_err(gpu_err)?;
        // Temporal accumulation on the device (the CPU's default settings, no jitter); turning
        // it on starts a new history.
        let temporal = accumulate.then(TemporalSettings::default);
        if frame.temporal() != temporal.as_ref() {
            frame.set_temporal(temporal).map_err(gpu_err)?;
            self.accumulated = 0;
        }
        let before = self.ctx.traffic();
        // A combination the plans alone do not show (e.g. Weier with temporal accumulation):
        // refused before anything is sent, rendered the staged way.
        let times = match frame.render(world, plans, cams) {
            Ok(t) => t,
            Err(e @ fovea_gpu::GpuError::Unsupported(_)) => {
                self.fall_back(e.to_string());
                return Ok(None);
            }
            Err(e) => return Err(gpu_err(e)),
        };
        if let Some(t) = frame.poll_gpu_times().map_err(gpu_err)?.pop() {
            self.gpu = Some(t);
        }
        let traffic = Traffic::of(&self.ctx.traffic().since(&before));
        self.accumulated = if accumulate { self.accumulated + 1 } else { 0 };
        self.totals.frames += 1;
        self.totals.traffic.add(&traffic);
        self.said = None;
        let (w, h) = (a.display.width_px, a.display.height_px);
        let width = w * shown as u32;
        let mut rgba = Vec::new();
        if a.req.read_back {
            rgba = vec![255u8; (width * h * 4) as usize];
            for k in 0..shown {
                let rgb = frame.image(k).map_err(gpu_err)?;
                self.totals.images_read += 1;
                self.totals.image_bytes += rgb.len() as u64;
                for y in 0..h as usize {
                    for x in 0..w as usize {
                        let src = (y * w as usize + x) * 3;
                        let dst = (y * width as usize + k * w as usize + x) * 4;
                        rgba[dst..dst + 3].copy_from_slice(&rgb[src..src + 3]);
                    }
                }
            }
        }
        let textures = (0..shown)
            .map(|k| {
                frame.texture(k).cloned().ok_or_else(|| {
                    ViewerError::Render(format!("the resident frame has no texture for eye {k}"))
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let stats = ResidentStats {
            frame: times.frame,
            host_ms: times.host_ms,
            submit_ms: times.submit_ms,
            traffic,
            gpu_ms: self.gpu.as_ref().map_or_else(Vec::new, |g| {
                g.passes
                    .iter()
                    .filter_map(|(n, ms)| ms.map(|ms| (n.to_string(), ms)))
                    .collect()
            }),
            gpu_frame: self.gpu.as_ref().map(|g| g.frame),
            totals: self.totals,
        };
        let rings = if a.view.overlays.rings {
            rings(a.camera, &a.eye.gaze)
        } else {
            Vec::new()
        };
        Ok(Some(ViewFrame {
            id: a.req.id,
            width,
            height: h,
            rgba,
            stats: Vec::new(),
            request: a.req.clone(),
            camera: a.camera.clone(),
            eye: *a.eye,
            scale: 1.0,
            rings,
            lod: None,
            wall_ms: 0.0,
            backend: format!(
                "resident GPU frame ({}, {} in one submission)",
                plans[0].method(),
                if both { "both eyes" } else { "one eye" }
            ),
            lockstep: both,
            resident: Some(ResidentView { textures, stats }),
        }))
    }
}

/// `display` at `scale` of its pixels, the same field of view.
pub fn scaled_display(display: &DisplayProfile, scale: f32) -> Result<DisplayProfile> {
    if scale >= 1.0 {
        return Ok(display.clone());
    }
    let w = ((display.width_px as f32 * scale).round() as u32).max(16);
    let h = ((display.height_px as f32 * scale).round() as u32).max(16);
    Ok(DisplayProfile::with_vertical_fov(
        &display.name,
        w,
        h,
        Degrees(display.vfov.0),
    )?)
}

/// One eye's 8-bit sRGB pixels (RGB): the frame through the tone curve, or the CoC map, with
/// the density overlay blended over it.
fn eye_rgb(
    f: &fovea_render::pipeline::Frame,
    view: &ViewSettings,
    tone_map: Option<&mut (dyn ToneMapExecutor + 'static)>,
) -> Result<Vec<u8>> {
    let (stops, curve) = (view.exposure_stops, ToneCurve::Reinhard);
    let mut rgb = match (&f.coc, view.overlays.coc, tone_map) {
        (Some(coc), true, _) => false_colour(coc, |v| v.abs().max(0.01), 0.01, 64.0),
        (_, _, Some(t)) => t
            .to_srgb8(&f.color, stops, curve)
            .map_err(|e| ViewerError::Render(format!("tone map on the {}: {e}", t.backend())))?,
        (_, _, None) => to_srgb8(&f.color, stops, curve),
    };
    if let (Some(d), true) = (&f.density, view.overlays.density) {
        let over = false_colour(d, |v| v.max(1e-3), 1e-3, 10.0);
        for (p, o) in rgb.iter_mut().zip(over) {
            *p = ((u16::from(*p) + u16::from(o)) / 2) as u8;
        }
    }
    Ok(rgb)
}

/// A false-colour view of a scalar image, log-scaled from `lo` (blue) to `hi` (red).
fn false_colour(img: &Image<f32>, f: impl Fn(f32) -> f32, lo: f32, hi: f32) -> Vec<u8> {
    let (l0, l1) = (lo.ln(), hi.ln());
    img.data()
        .iter()
        .flat_map(|&v| {
            let v = f(v);
            let u = if v.is_finite() {
                ((v.ln() - l0) / (l1 - l0)).clamp(0.0, 1.0)
            } else {
                1.0
            };
            // Blue → cyan → green → yellow → red.
            let r = (1.5 - (4.0 * u - 3.0).abs()).clamp(0.0, 1.0);
            let g = (1.5 - (4.0 * u - 2.0).abs()).clamp(0.0, 1.0);
            let b = (1.5 - (4.0 * u - 1.0).abs()).clamp(0.0, 1.0);
            [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8]
        })
        .collect()
}

/// The eccentricity rings around `gaze` on `camera`'s screen: for each of [`RING_DEG`], the
/// screen points of the directions at that angle from the gaze direction (points off the
/// screen are left out, so a ring may come in pieces joined across its gap).
pub fn rings(camera: &EyeCamera, gaze: &Gaze) -> Vec<Vec<[f32; 2]>> {
    let g = camera.ray(gaze.point).dir.normalize();
    let a = if g.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
    let u = g.cross(a).normalize();
    let v = g.cross(u);
    RING_DEG
        .iter()
        .map(|&e| {
            let (s, c) = (e.to_radians().sin() as f32, e.to_radians().cos() as f32);
            (0..=96)
                .filter_map(|k| {
                    let phi = k as f32 / 96.0 * std::f32::consts::TAU;
                    let d = c * g + s * (phi.cos() * u + phi.sin() * v);
                    camera
                        .screen_point_of(d)
                        .map(|p| [p.x_px as f32, p.y_px as f32])
                })
                .collect()
        })
        .collect()
}

/// What the worker hands back.
pub type Rendered = Result<ViewFrame>;

/// A thread rendering the newest request (older ones waiting are dropped), and refining a
/// frame rendered below full scale to full scale when no new request comes.
pub struct RenderWorker {
    slot: Arc<(Mutex<Slot>, Condvar)>,
    results: Receiver<Rendered>,
    handle: Option<JoinHandle<()>>,
}

#[derive(Default)]
struct Slot {
    next: Option<FrameRequest>,
    busy: bool,
    quit: bool,
}

impl RenderWorker {
    /// Starts the thread; `refine`: render a still view again at full scale.
    pub fn start(mut renderer: FrameRenderer, refine: bool) -> Self {
        let slot = Arc::new((Mutex::new(Slot::default()), Condvar::new()));
        let (tx, results): (Sender<Rendered>, _) = mpsc::channel();
        let shared = slot.clone();
        let handle = std::thread::Builder::new()
            .name("fovea-view-render".into())
            .spawn(move || {
                let (lock, cv) = &*shared;
                let mut last: Option<FrameRequest> = None;
                loop {
                    let req = {
                        let Ok(mut s) = lock.lock() else { return };
                        loop {
                            if s.quit {
                                return;
                            }
                            if let Some(r) = s.next.take() {
                                s.busy = true;
                                break r;
                            }
                            // A still view rendered below full scale: the full-scale frame.
                            if let Some(mut r) =
                                last.take().filter(|r| refine && r.view.scale < 1.0)
                            {
                                r.view.scale = 1.0;
                                r.dt_s = 0.0;
                                s.busy = true;
                                break r;
                            }
                            s.busy = false;
                            let Ok(g) = cv.wait(s) else { return };
                            s = g;
                        }
                    };
                    let out = renderer.render(&req);
                    last = Some(req);
                    if tx.send(out).is_err() {
                        return;
                    }
                }
            })
            .ok();
        Self {
            slot,
            results,
            handle,
        }
    }

    /// Asks for a frame, replacing any request still waiting.
    pub fn submit(&self, req: FrameRequest) {
        let (lock, cv) = &*self.slot;
        if let Ok(mut s) = lock.lock() {
            s.next = Some(req);
            cv.notify_one();
        }
    }

    /// Whether the thread is rendering or has a request waiting.
    pub fn busy(&self) -> bool {
        let (lock, _) = &*self.slot;
        lock.lock().is_ok_and(|s| s.busy || s.next.is_some())
    }

    /// The next finished frame, if any.
    pub fn try_recv(&self) -> Option<Rendered> {
        match self.results.try_recv() {
            Ok(r) => Some(r),
            Err(mpsc::TryRecvError::Empty) => None,
            Err(mpsc::TryRecvError::Disconnected) => {
                Some(Err(ViewerError::Render("the render thread stopped".into())))
            }
        }
    }

    /// Waits for the next finished frame.
    pub fn recv(&self) -> Rendered {
        self.results
            .recv()
            .unwrap_or_else(|_| Err(ViewerError::Render("the render thread stopped".into())))
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        let (lock, cv) = &*self.slot;
        if let Ok(mut s) = lock.lock() {
            s.quit = true;
            cv.notify_one();
        }
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}
