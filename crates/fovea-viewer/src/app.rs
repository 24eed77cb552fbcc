//! The window: winit events, the camera keys, the gaze of each frame, frames to and from the
//! render thread, and the panel, HUD and frame drawn with egui on wgpu.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;
use winit::application::ApplicationHandler;
use winit::event::{DeviceEvent, DeviceId, ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use fovea_core::display::{DisplayProfile, PRESET_NAMES};
use fovea_core::gaze::GazeSample;
use fovea_render::camera_path::CameraPath;
use fovea_render::eye::FocusDistance;
use fovea_render::pipeline::Stage;

use crate::controls::{key_actions, panel, Action, EyesChoice, ViewSettings};
use crate::error::{Result, ViewerError};
use crate::frame::{FrameRenderer, FrameRequest, Pose, RenderWorker, ViewFrame};
use crate::gaze_input::{GazeReplay, GazeStream, PointerGaze, ReplayMode};
use crate::present::{fit, Presenter};
use crate::record::Recorder;
use crate::{GazeSource, Summary, ViewerConfig};

/// Radians of view turned per pixel of mouse motion (right button held).
const LOOK_RAD_PER_PX: f32 = 0.003;

/// Frames a still view with auto focus is rendered again while the accommodation filter
/// settles (its time constant is a few hundred milliseconds).
const SETTLE_FRAMES: u32 = 30;

/// What decides a frame in the window: the view settings, the pose, the gaze (x, y, valid)
/// and the display's name. A still view (the same key) is not rendered again.
type SubmitKey = (ViewSettings, Pose, Option<(f64, f64, bool)>, String);

/// A headless run's progress.
struct Script {
    frames: u64,
    next: u64,
    waiting: Option<u64>,
}

struct App {
    display: DisplayProfile,
    view: ViewSettings,
    pose: Pose,
    world_up: Vec3,
    camera_path: Option<CameraPath>,
    fps: f64,
    shots_dir: PathBuf,
    screenshot: Option<PathBuf>,
    frames_out: Option<PathBuf>,
    backend: String,
    move_speed: f32,
    quiet: bool,

    window: Option<Arc<Window>>,
    presenter: Option<Presenter>,
    egui_ctx: egui::Context,
    egui_state: Option<egui_winit::State>,
    texture: Option<egui::TextureHandle>,
    /// The frames' GPU device, when they render on one (the window is drawn with it).
    frames_device: Option<fovea_gpu::GpuContext>,
    /// The resident frame's textures as egui textures, one per eye shown.
    native: Vec<(wgpu::Texture, egui::TextureId)>,
    /// A screenshot asked for while the frame shown had no bytes on the CPU: written when
    /// the frame read back for it arrives (`None` inside: the next `shot_NNNN.png`).
    pending_shot: Option<Option<PathBuf>>,

    worker: RenderWorker,
    latest: Option<ViewFrame>,
    frame_rect: egui::Rect,
    pointer: PointerGaze,
    replay: Option<GazeReplay>,
    stream: Option<GazeStream>,
    gaze: Option<GazeSample>,
    recorder: Option<Recorder>,
    script: Option<Script>,

    keys: HashSet<KeyCode>,
    looking: bool,
    start: Instant,
    last_tick: Instant,
    last_submitted: Option<SubmitKey>,
    last_gaze_t: f64,
    settling: u32,
    next_id: u64,
    shown: u64,
    shown_times: Vec<Instant>,
    render_ms_sum: f64,
    shots: u32,
    written: Vec<PathBuf>,
    status: String,
    error: Option<ViewerError>,
    /// The window needs drawing again (an input event, a new frame, egui asked for it): the
    /// window is not redrawn otherwise, so a software adapter drawing it leaves the cores to
    /// the renderer.
    dirty: bool,
}

/// Runs the viewer (after [`crate::check_display_server`]).
pub fn run(cfg: ViewerConfig) -> Result<Summary> {
    let event_loop = EventLoop::new().map_err(|e| {
        ViewerError::NoDisplay(format!(
            "cannot connect to the display server ({e}); check DISPLAY (X11) or WAYLAND_DISPLAY (Wayland)"
        ))
    })?;
    // The event loop holds its own connection now: the server no longer risks a reset
    // between clients (see `display_server`).
    drop(cfg.display_hold);
    let (w, h) = (cfg.display.width_px as f64, cfg.display.height_px as f64);
    let (replay, stream) = match cfg.gaze {
        GazeSource::Mouse => (None, None),
        GazeSource::Replay(r) => (Some(r), None),
        GazeSource::Udp(port) => (None, Some(GazeStream::bind(port, w, h)?)),
    };
    if let Some(s) = &stream {
        if !cfg.quiet {
            eprintln!(
                "gaze: listening for JSON lines on UDP 127.0.0.1:{} (see the README)",
                s.port()
            );
        }
    }
    let recorder = cfg.record.as_deref().map(Recorder::create).transpose()?;
    if let Some(dir) = &cfg.frames_out {
        std::fs::create_dir_all(dir).map_err(|e| ViewerError::Io {
            path: dir.clone(),
            reason: e,
        })?;
    }
    let mut renderer =
        FrameRenderer::new(cfg.world, cfg.base, cfg.ipd_m, cfg.executors, cfg.tone_map)?;
    if let Some(second) = cfg.second_eye {
        renderer.set_second_eye(second);
    }
    if let Some(ctx) = &cfg.resident {
        renderer.set_resident(ctx.clone(), cfg.quiet);
    }
    let headless = cfg.frames.is_some();
    let worker = RenderWorker::start(renderer, cfg.cpu_path && !headless);
    let mut app = App {
        world_up: cfg.pose.up,
        display: cfg.display,
        view: cfg.view,
        pose: cfg.pose,
        camera_path: cfg.camera_path,
        fps: cfg.fps,
        shots_dir: cfg.shots_dir,
        screenshot: cfg.screenshot,
        frames_out: cfg.frames_out,
        backend: cfg.backend,
        move_speed: cfg.move_speed_m_s,
        quiet: cfg.quiet,
        window: None,
        presenter: None,
        egui_ctx: egui::Context::default(),
        egui_state: None,
        texture: None,
        frames_device: cfg.resident,
        native: Vec::new(),
        pending_shot: None,
        worker,
        latest: None,
        frame_rect: egui::Rect::NOTHING,
        pointer: PointerGaze::default(),
        replay,
        stream,
        gaze: None,
        recorder,
        script: cfg.frames.map(|n| Script {
            frames: n,
            next: 0,
            waiting: None,
        }),
        keys: HashSet::new(),
        looking: false,
        start: Instant::now(),
        last_tick: Instant::now(),
        last_submitted: None,
        last_gaze_t: 0.0,
        settling: 0,
        next_id: 0,
        shown: 0,
        shown_times: Vec::new(),
        render_ms_sum: 0.0,
        shots: 0,
        written: Vec::new(),
        status: String::new(),
        error: None,
        dirty: true,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewerError::Window(format!("the window's event loop failed: {e}")))?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    if app.presenter.is_none() {
        return Err(ViewerError::Window(
            "the window never opened (the display server closed it)".into(),
        ));
    }
    let elapsed = app.start.elapsed().as_secs_f64();
    Ok(Summary {
        frames: app.shown,
        fps: app.shown as f64 / elapsed.max(1e-9),
        mean_frame_ms: app.render_ms_sum / app.shown.max(1) as f64,
        adapter: app
            .presenter
            .as_ref()
            .map_or(String::new(), Presenter::describe),
        backend: app.backend.clone(),
        stream: app.stream.as_ref().map(|s| s.counts),
        written: std::mem::take(&mut app.written),
    })
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        self.error = Some(e);
        event_loop.exit();
    }

    /// The display of the panel's headset choice.
    fn current_display(&self) -> Result<DisplayProfile> {
        match self.view.headset.and_then(|i| PRESET_NAMES.get(i)) {
            Some(name) => Ok(DisplayProfile::preset(name)?),
            None => Ok(self.display.clone()),
        }
    }

    fn create_window(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let d = &self.display;
        // The frame at its size where it fits a 1600×900 screen, with room for the panel.
        let eyes = if self.view.eyes == EyesChoice::Both {
            2.0
        } else {
            1.0
        };
        let fit = (1280.0 / (d.width_px as f64 * eyes))
            .min(860.0 / d.height_px as f64)
            .min(1.0);
        let size = winit::dpi::LogicalSize::new(
            (d.width_px as f64 * eyes * fit + 300.0).max(640.0),
            (d.height_px as f64 * fit + 40.0).max(400.0),
        );
        let window = Arc::new(
            event_loop
                .create_window(
                    Window::default_attributes()
                        .with_title("fovea view")
                        .with_inner_size(size),
                )
                .map_err(|e| ViewerError::Window(format!("cannot open a window: {e}")))?,
        );
        let presenter =
            Presenter::new(event_loop, &window, self.frames_device.as_ref(), self.quiet)?;
        let max_side = match &presenter {
            Presenter::Gpu(g) => Some(g.max_texture_side()),
            Presenter::Soft(_) => None,
        };
        self.egui_state = Some(egui_winit::State::new(
            self.egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            max_side,
        ));
        if !self.quiet {
            eprintln!(
                "window: drawn by {}; frames rendered by {}",
                presenter.describe(),
                self.backend
            );
        }
        self.presenter = Some(presenter);
        self.window = Some(window);
        Ok(())
    }

    /// Moves the camera with the held keys (W A S D forward/left/back/right, Q E down/up).
    fn move_camera(&mut self, dt: f32) {
        let axis = |pos: KeyCode, neg: KeyCode| {
            f32::from(u8::from(self.keys.contains(&pos)))
                - f32::from(u8::from(self.keys.contains(&neg)))
        };
        let f = axis(KeyCode::KeyW, KeyCode::KeyS);
        let r = axis(KeyCode::KeyD, KeyCode::KeyA);
        let u = axis(KeyCode::KeyE, KeyCode::KeyQ);
        if f == 0.0 && r == 0.0 && u == 0.0 {
            return;
        }
        let right = self.pose.forward.cross(self.world_up).normalize_or_zero();
        let step = self.move_speed * dt;
        self.pose.position += step * (f * self.pose.forward + r * right + u * self.world_up);
        self.dirty = true;
    }

    /// Turns the view by a mouse motion (right button held).
    fn look(&mut self, dx: f64, dy: f64) {
        let up = self.world_up;
        let yaw = glam::Quat::from_axis_angle(up, -dx as f32 * LOOK_RAD_PER_PX);
        let right = self.pose.forward.cross(up).normalize_or_zero();
        let pitch = glam::Quat::from_axis_angle(right, -dy as f32 * LOOK_RAD_PER_PX);
        let f = (yaw * pitch * self.pose.forward).normalize_or_zero();
        // Stop short of looking straight up or down.
        if f != Vec3::ZERO && f.dot(up).abs() < 0.98 {
            self.pose.forward = f;
            self.pose.up = f.cross(up).cross(f).normalize_or_zero();
            self.dirty = true;
        }
    }

    /// The gaze and pose of the next frame, and sends it when the worker is free.
    fn submit(&mut self) -> Result<()> {
        let display = self.current_display()?;
        let (w, h) = (display.width_px as f64, display.height_px as f64);
        let draws_textures = self.draws_textures();
        if let Some(script) = &mut self.script {
            if script.waiting.is_some() || script.next >= script.frames {
                return Ok(());
            }
            let i = script.next;
            let t = i as f64 / self.fps;
            let gaze = match &self.replay {
                // A headless run holds the CSV's last sample past its end, as `fovea
                // sequence` does, rather than looping.
                Some(r) if r.mode() == ReplayMode::RealTime => GazeSample {
                    t_s: t,
                    ..r.trajectory().at(r.trajectory().start_s() + t)
                },
                Some(r) => r.at(t),
                None => centre_sample(&display, t),
            };
            if let Some(p) = &self.camera_path {
                self.pose = Pose::along(p, t, &display)?;
            }
            let last = i + 1 == script.frames;
            let read_back =
                self.frames_out.is_some() || !draws_textures || (last && self.screenshot.is_some());
            let req = FrameRequest {
                id: i,
                view: self.view.clone(),
                display,
                pose: self.pose,
                gaze,
                dt_s: 1.0 / self.fps,
                read_back,
            };
            script.waiting = Some(i);
            if let Some(r) = &mut self.replay {
                r.step();
            }
            self.worker.submit(req);
            return Ok(());
        }
        let t = self.start.elapsed().as_secs_f64();
        let gaze = if let Some(s) = &mut self.stream {
            s.set_display(w, h);
            s.poll(t)
        } else if let Some(r) = &self.replay {
            Some(r.at(t))
        } else {
            let pointer = self.egui_ctx.input(|i| i.pointer.latest_pos());
            let eyes = if self.view.eyes == EyesChoice::Both {
                2
            } else {
                1
            };
            self.pointer.update(t, pointer, self.frame_rect, eyes, w, h)
        };
        // Before the first gaze (the pointer never over the frame, no packet yet): the screen
        // centre, the gaze the frame is foveated at (recorded as such, so a replay renders
        // the same frames; the CSV reader would put the first measured gaze there instead
        // of a gap's).
        let gaze = gaze
            .or(self.gaze)
            .unwrap_or_else(|| centre_sample(&display, t));
        self.gaze = Some(gaze);
        if let Some(p) = &self.camera_path {
            self.pose = Pose::along(p, t, &display)?;
        }
        if self.worker.busy() {
            return Ok(());
        }
        let key = (
            self.view.clone(),
            self.pose,
            Some((gaze.x_px, gaze.y_px, gaze.valid)),
            display.name.clone(),
        );
        // A still view is not rendered again (the worker refines it), unless the frame
        // changes by itself: temporal accumulation, a moving camera path, auto focus settling.
        let same = self.last_submitted.as_ref() == Some(&key);
        let animating = self.view.temporal
            || self.camera_path.is_some()
            || (self.view.effective_dof().is_some() && self.settling < SETTLE_FRAMES);
        if same && !animating {
            return Ok(());
        }
        if !same {
            // A new view: the last screenshot or refusal no longer applies.
            self.status.clear();
        }
        self.settling = if same { self.settling + 1 } else { 0 };
        let dt = (t - self.last_gaze_t).clamp(1e-3, 0.5);
        self.last_gaze_t = t;
        self.next_id += 1;
        self.worker.submit(FrameRequest {
            id: self.next_id,
            view: self.view.clone(),
            display,
            pose: self.pose,
            gaze,
            dt_s: dt,
            // A screenshot waiting for its bytes: this request may have replaced its own.
            read_back: self.frames_out.is_some()
                || !self.draws_textures()
                || self.pending_shot.is_some(),
        });
        self.last_submitted = Some(key);
        Ok(())
    }

    /// Whether the window draws the resident frame's textures as they are (drawn with the
    /// frames' device): then a frame's bytes are read back only when asked for.
    fn draws_textures(&self) -> bool {
        self.presenter
            .as_ref()
            .is_some_and(Presenter::shares_frames_device)
    }

    /// A frame came back from the worker.
    fn receive(&mut self, frame: ViewFrame) -> Result<()> {
        let native = match (&frame.resident, self.presenter.as_mut()) {
            (Some(r), Some(Presenter::Gpu(g))) if g.shares_frames_device() => Some((r, g)),
            _ => None,
        };
        if let Some((r, g)) = native {
            // The resident frame's own textures: registered once, rebound when the frame
            // made new ones (another display or method); nothing is copied.
            for (_, id) in self.native.drain(r.textures.len().min(self.native.len())..) {
                g.free_frame_texture(id);
            }
            for (k, t) in r.textures.iter().enumerate() {
                match self.native.get_mut(k) {
                    Some((held, _)) if held == t => {}
                    Some((held, id)) => {
                        *id = g.frame_texture(t, Some(*id));
                        *held = t.clone();
                    }
                    None => {
                        let id = g.frame_texture(t, None);
                        self.native.push((t.clone(), id));
                    }
                }
            }
        } else if !frame.rgba.is_empty() {
            let img = egui::ColorImage::from_rgba_unmultiplied(
                [frame.width as usize, frame.height as usize],
                &frame.rgba,
            );
            match &mut self.texture {
                Some(t) => t.set(img, egui::TextureOptions::LINEAR),
                None => {
                    self.texture = Some(self.egui_ctx.load_texture(
                        "frame",
                        img,
                        egui::TextureOptions::LINEAR,
                    ))
                }
            }
        }
        self.shown += 1;
        self.render_ms_sum += frame.wall_ms;
        let now = Instant::now();
        self.shown_times.push(now);
        self.shown_times
            .retain(|t| now.duration_since(*t) < Duration::from_secs(2));
        let req = &frame.request;
        if let Some(r) = &mut self.recorder {
            if req.dt_s > 0.0 {
                let cam = req.pose.camera(&req.display)?;
                r.record(req.gaze.t_s, &req.gaze, &cam)?;
            }
        }
        if let Some(dir) = &self.frames_out {
            let p = dir.join(format!("frame_{:05}.png", frame.id));
            write_png(&p, &frame)?;
        }
        if let Some(script) = &mut self.script {
            if script.waiting == Some(frame.id) {
                script.waiting = None;
                script.next += 1;
                if !self.quiet {
                    eprintln!(
                        "frame {}/{}: {:.0} ms ({})",
                        script.next, script.frames, frame.wall_ms, frame.backend
                    );
                }
            }
        }
        let has_bytes = !frame.rgba.is_empty();
        self.latest = Some(frame);
        self.dirty = true;
        if has_bytes {
            if let Some(path) = self.pending_shot.take() {
                self.screenshot(path)?;
            }
        }
        Ok(())
    }

    /// Writes the current frame as PNG + JSON.
    fn screenshot(&mut self, path: Option<PathBuf>) -> Result<()> {
        let Some(frame) = &self.latest else {
            self.status = "no frame yet to save".into();
            return Ok(());
        };
        if frame.rgba.is_empty() {
            // A resident frame lives on the device: the same view again, read back (a
            // counted readback, the only one).
            let mut req = frame.request.clone();
            self.next_id += 1;
            req.id = self.next_id;
            req.dt_s = 0.0;
            req.read_back = true;
            self.pending_shot = Some(path);
            self.worker.submit(req);
            return Ok(());
        }
        let path = match path {
            Some(p) => p,
            None => {
                self.shots += 1;
                self.shots_dir.join(format!("shot_{:04}.png", self.shots))
            }
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| ViewerError::Io {
                path: dir.to_path_buf(),
                reason: e,
            })?;
        }
        write_png(&path, frame)?;
        let json_path = path.with_extension("json");
        let r = &frame.request;
        let json = serde_json::json!({
            "display": r.display.name,
            "width": frame.width,
            "height": frame.height,
            "scale": frame.scale,
            "method": r.view.effective_method().name(),
            "dof_filter": r.view.effective_dof().map(|k| k.name()),
            "eyes": if r.view.eyes == EyesChoice::Both { "both" } else { "one" },
            "gaze": [r.gaze.x_px, r.gaze.y_px],
            "gaze_valid": r.gaze.valid,
            "camera": {
                "position": frame.camera.position.to_array(),
                "forward": frame.camera.forward.to_array(),
                "up": frame.camera.up.to_array(),
            },
            "exposure_stops": r.view.exposure_stops,
            "backend": frame.backend,
            "lockstep": frame.lockstep,
            "resident": frame.resident.as_ref().map(|r| &r.stats),
            "window_on_frames_device": self.draws_textures(),
            "hud": self.hud(),
            "wall_ms": frame.wall_ms,
            "lod": frame.lod,
            "frames": frame.stats,
        });
        let text = serde_json::to_string_pretty(&json)
            .map_err(|e| ViewerError::Render(format!("frame statistics: {e}")))?;
        fovea_core::atomic_file::write_atomic(&json_path, (text + "\n").as_bytes())?;
        self.status = format!("wrote {} and {}", path.display(), json_path.display());
        if !self.quiet {
            eprintln!("{}", self.status);
        }
        self.written.push(path);
        self.written.push(json_path);
        Ok(())
    }

    /// The HUD's lines.
    fn hud(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let fps = if self.shown_times.len() >= 2 {
            let span = self
                .shown_times
                .last()
                .zip(self.shown_times.first())
                .map_or(0.0, |(a, b)| a.duration_since(*b).as_secs_f64());
            (self.shown_times.len() - 1) as f64 / span.max(1e-9)
        } else {
            0.0
        };
        lines.push(format!("{fps:.1} fps | backend: {}", self.backend));
        if let Some(p) = &self.presenter {
            lines.push(format!("window: {}", p.describe()));
        }
        let Some(f) = &self.latest else {
            lines.push("rendering the first frame…".into());
            return lines;
        };
        if let Some(r) = &f.resident {
            let s = &r.stats;
            lines.push(format!(
                "{} {}×{} | host {:.2} ms, submit {:.2} ms | up {} B, back {} B, {} submission(s), {} wait(s) a frame",
                f.request.view.effective_method().name(),
                f.width,
                f.height,
                s.host_ms,
                s.submit_ms,
                s.traffic.bytes_uploaded,
                s.traffic.bytes_read_back,
                s.traffic.submissions,
                s.traffic.blocking_waits,
            ));
            let gpu: Vec<String> = s
                .gpu_ms
                .iter()
                .map(|(n, ms)| format!("{n} {ms:.2}"))
                .collect();
            lines.push(match s.gpu_frame {
                Some(g) => format!(
                    "GPU ms (frame {g}, {} late): {}",
                    s.frame.saturating_sub(g),
                    gpu.join(", ")
                ),
                None => "GPU ms: not arrived yet (read frames late, never waited for)".into(),
            });
            lines.push(f.backend.clone());
        }
        // The staged and CPU paths' per-stage figures (a resident frame has its own above).
        if let Some(s) = f.stats.first() {
            let stages: Vec<String> = Stage::ALL
                .iter()
                .filter(|&&k| s.stages_ms.get(k) > 0.0)
                .map(|&k| format!("{} {:.1}", k.name(), s.stages_ms.get(k)))
                .collect();
            lines.push(format!(
                "{} {}×{} | frame {:.0} ms | {}",
                s.method,
                f.width,
                f.height,
                f.wall_ms,
                stages.join(", ")
            ));
            let rays: u64 = f.stats.iter().map(|s| s.rays).sum();
            let samples: u64 = f.stats.iter().map(|s| s.samples).sum();
            lines.push(format!(
                "{samples} samples, {rays} rays ({} primary, {} shadow) | {}",
                f.stats.iter().map(|s| s.rays_primary).sum::<u64>(),
                f.stats.iter().map(|s| s.rays_shadow).sum::<u64>(),
                f.backend
            ));
        }
        let focus = match f.eye.focus {
            Some(FocusDistance::Metres(m)) => format!("focus {m:.2} m"),
            Some(FocusDistance::Infinity) => "focus ∞".into(),
            None => "no DOF".into(),
        };
        let pupil = f
            .eye
            .pupil_mm
            .map_or(String::new(), |p| format!(", pupil {p:.2} mm"));
        let g = &f.request.gaze;
        lines.push(format!(
            "{focus}{pupil} | gaze {:.0}, {:.0}{}",
            g.x_px,
            g.y_px,
            if g.valid { "" } else { " (held)" }
        ));
        if let Some(l) = &f.lod {
            lines.push(format!(
                "lod: {} of {} triangles",
                l.triangles, l.triangles_full
            ));
        }
        if f.scale < 1.0 {
            lines.push(format!(
                "CPU path: {:.0} % scale ({}×{}); a still view refines to full scale",
                f.scale * 100.0,
                f.width,
                f.height
            ));
        }
        if let Some(s) = &self.stream {
            let c = s.counts;
            lines.push(format!(
                "stream :{} | {} lines, {} valid, {} gaps, {} malformed",
                s.port(),
                c.lines,
                c.valid,
                c.gaps,
                c.malformed
            ));
        }
        if let Some(r) = &self.recorder {
            lines.push(format!(
                "recording {} frames into {}",
                r.frames(),
                r.dir().display()
            ));
        }
        if !self.status.is_empty() {
            lines.push(self.status.clone());
        }
        lines
    }

    /// One egui pass and the window's frame.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let (Some(window), Some(state)) = (self.window.clone(), self.egui_state.as_mut()) else {
            return Ok(());
        };
        let input = state.take_egui_input(&window);
        let ctx = self.egui_ctx.clone();
        let mut actions = Vec::new();
        let mut view = self.view.clone();
        let hud = self.hud();
        let latest = self.latest.as_ref();
        // The frame's images: the resident frame's textures, one per eye shown, or the
        // frame's bytes uploaded as one egui texture.
        let images: Vec<egui::TextureId> = match latest {
            Some(f) if f.resident.is_some() && self.native.len() == f.eyes() => {
                self.native.iter().map(|(_, id)| *id).collect()
            }
            Some(f) if !f.rgba.is_empty() => self.texture.iter().map(|t| t.id()).collect(),
            _ => Vec::new(),
        };
        let mut frame_rect = self.frame_rect;
        // Without a device for egui (the software presenter) the pass still reads the keys
        // and the pointer; only the frame is drawn.
        let draws_egui = self.presenter.as_ref().is_some_and(Presenter::draws_egui);
        let mut output = ctx.run_ui(input, |ui| {
            actions.extend(key_actions(ui.ctx()));
            if !draws_egui {
                return;
            }
            if view.panel {
                egui::Panel::left("controls").show(ui, |ui| {
                    actions.extend(panel(ui, &mut view, PRESET_NAMES, &self.display.name));
                });
            }
            egui::Panel::bottom("hud").show(ui, |ui| {
                for l in &hud {
                    ui.monospace(l);
                }
            });
            egui::CentralPanel::no_frame().show(ui, |ui| {
                let avail = ui.available_rect_before_wrap();
                let Some(f) = latest.filter(|_| !images.is_empty()) else {
                    ui.centered_and_justified(|ui| ui.label("rendering…"));
                    return;
                };
                let rect = fit(avail, f.width, f.height);
                frame_rect = rect;
                let painter = ui.painter_at(avail);
                let part = rect.width() / images.len() as f32;
                for (k, id) in images.iter().enumerate() {
                    let r = egui::Rect::from_min_size(
                        rect.min + egui::vec2(k as f32 * part, 0.0),
                        egui::vec2(part, rect.height()),
                    );
                    painter.image(
                        *id,
                        r,
                        egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                        egui::Color32::WHITE,
                    );
                }
                // The gaze (display pixels) and the rings (frame pixels), in each eye's half.
                let n = f.eyes();
                let eye_w = rect.width() / n as f32;
                let per_frame_px = eye_w / (f.width as f32 / n as f32);
                let per_display_px = eye_w / f.request.display.width_px as f32;
                let ring_stroke = egui::Stroke::new(1.0, egui::Color32::from_white_alpha(140));
                let gaze = &f.request.gaze;
                let colour = if gaze.valid {
                    egui::Color32::from_rgb(255, 80, 40)
                } else {
                    egui::Color32::GRAY
                };
                for e in 0..n {
                    let origin = rect.min + egui::vec2(e as f32 * eye_w, 0.0);
                    for ring in &f.rings {
                        let pts: Vec<egui::Pos2> = ring
                            .iter()
                            .map(|p| origin + egui::vec2(p[0], p[1]) * per_frame_px)
                            .collect();
                        painter.add(egui::Shape::line(pts, ring_stroke));
                    }
                    let g =
                        origin + egui::vec2(gaze.x_px as f32, gaze.y_px as f32) * per_display_px;
                    painter.circle_stroke(g, 6.0, egui::Stroke::new(1.5, colour));
                }
            });
        });
        self.frame_rect = frame_rect;
        // egui asks for another pass (an animation, a widget being dragged).
        self.dirty |= output
            .viewport_output
            .get(&egui::ViewportId::ROOT)
            .is_some_and(|v| v.repaint_delay.is_zero());
        let changed_headset = view.headset != self.view.headset;
        self.view = view;
        let presets = PRESET_NAMES.len();
        for a in actions {
            match a {
                Action::Quit => event_loop.exit(),
                Action::Screenshot => self.screenshot(None)?,
                Action::StepGaze => {
                    if let Some(r) = &mut self.replay {
                        r.step();
                    }
                }
                other => {
                    let before = self.view.headset;
                    self.view.apply(other, presets);
                    if self.view.headset != before {
                        self.headset_changed()?;
                    }
                }
            }
        }
        if changed_headset {
            self.headset_changed()?;
        }
        let Some(state) = self.egui_state.as_mut() else {
            return Ok(());
        };
        state.handle_platform_output(&window, std::mem::take(&mut output.platform_output));
        match self.presenter.as_mut() {
            Some(Presenter::Gpu(g)) => g.present(&ctx, &window, output)?,
            Some(Presenter::Soft(soft)) => {
                let rect = soft.present(&window, self.latest.as_ref())?;
                // The pointer is in points; the software presenter works in pixels.
                let k = 1.0 / window.scale_factor() as f32;
                self.frame_rect = egui::Rect::from_min_max(
                    (rect.min.to_vec2() * k).to_pos2(),
                    (rect.max.to_vec2() * k).to_pos2(),
                );
                let hud = self.hud();
                window.set_title(&format!(
                    "fovea view | {}",
                    hud.iter().take(3).cloned().collect::<Vec<_>>().join(" | ")
                ));
            }
            None => {}
        }
        Ok(())
    }

    /// A new headset: the gaze sources follow its size.
    fn headset_changed(&mut self) -> Result<()> {
        let d = self.current_display()?;
        if let Some(r) = &mut self.replay {
            r.rescale(d.width_px as f64, d.height_px as f64)?;
        }
        self.gaze = None;
        Ok(())
    }

    fn tick(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let now = Instant::now();
        let dt = now.duration_since(self.last_tick).as_secs_f32().min(0.25);
        self.last_tick = now;
        if self.script.is_none() && !self.egui_ctx.egui_wants_keyboard_input() {
            self.move_camera(dt);
        }
        while let Some(r) = self.worker.try_recv() {
            match r {
                Ok(frame) => self.receive(frame)?,
                // In the window a refused frame (say, a preset whose buffers exceed the memory
                // limit) is said in the HUD and the last frame stays; headless, it is the
                // run's error.
                Err(e) if self.script.is_none() => {
                    self.status = format!("frame refused: {e}");
                    if !self.quiet {
                        eprintln!("{}", self.status);
                    }
                    self.dirty = true;
                }
                Err(e) => return Err(e),
            }
        }
        if let Some(s) = &self.script {
            if s.next >= s.frames && s.waiting.is_none() {
                if let Some(p) = self.screenshot.clone() {
                    self.screenshot(Some(p))?;
                }
                event_loop.exit();
                return Ok(());
            }
        }
        self.submit()?;
        if self.dirty {
            self.dirty = false;
            if let Some(w) = &self.window {
                w.request_redraw();
            }
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            if let Err(e) = self.create_window(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let (Some(w), Some(s)) = (&self.window, &mut self.egui_state) {
            let _ = s.on_window_event(w, &event);
        }
        if !matches!(event, WindowEvent::RedrawRequested) {
            self.dirty = true;
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(p) = &mut self.presenter {
                    p.resize(size.width, size.height);
                }
            }
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    match event.state {
                        ElementState::Pressed => self.keys.insert(code),
                        ElementState::Released => self.keys.remove(&code),
                    };
                }
            }
            WindowEvent::Focused(false) => self.keys.clear(),
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Right,
                ..
            } => self.looking = state == ElementState::Pressed,
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn device_event(&mut self, _: &ActiveEventLoop, _: DeviceId, event: DeviceEvent) {
        if let DeviceEvent::MouseMotion { delta } = event {
            if self.looking && self.script.is_none() && self.camera_path.is_none() {
                self.look(delta.0, delta.1);
            }
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            return;
        }
        if let Err(e) = self.tick(event_loop) {
            self.fail(event_loop, e);
            return;
        }
        event_loop.set_control_flow(ControlFlow::WaitUntil(
            Instant::now() + Duration::from_millis(8),
        ));
    }
}

/// A gaze at the centre of `display`'s screen at time `t_s`.
fn centre_sample(display: &DisplayProfile, t_s: f64) -> GazeSample {
    let c = display.centre_gaze();
    GazeSample::new(t_s, c.point.x_px, c.point.y_px)
}

/// Writes a frame's pixels as an 8-bit sRGB PNG (RGB).
fn write_png(path: &Path, frame: &ViewFrame) -> Result<()> {
    let rgb: Vec<u8> = frame
        .rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut png = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(
        &mut png,
        &rgb,
        frame.width,
        frame.height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| ViewerError::Io {
        path: path.to_path_buf(),
        reason: std::io::Error::other(e.to_string()),
    })?;
    Ok(fovea_core::atomic_file::write_atomic(path, png.get_ref())?)
}
