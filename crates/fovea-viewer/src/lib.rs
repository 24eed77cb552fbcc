//! `fovea view`: a window where the mouse or an eye tracker is the gaze.
//!
//! The frame is the one `fovea render` makes (`fovea_render::pipeline`: eye state → plan →
//! trace → shade → sample-space post → reconstruct → screen post), rendered on a thread of its
//! own ([`frame::RenderWorker`]) with the GPU executors of the trace and reconstruct stages
//! when the caller hands them over, and shown with egui on wgpu in a winit window
//! ([`app`]). The gaze is the pointer, a replayed CSV or a UDP stream ([`gaze_input`]); the
//! panel and the keys change [`controls::ViewSettings`], which decide the frame settings;
//! [`record::Recorder`] writes the gaze and camera of every frame shown as CSV files that
//! `fovea sequence` reads back.
//!
//! Headless (`frames`), the viewer renders a fixed number of frames, one per gaze sample, and
//! writes the last as a screenshot: what CI runs under Xvfb on lavapipe.

pub mod app;
pub mod controls;
pub mod display_server;
pub mod error;
pub mod frame;
pub mod gaze_input;
pub mod present;
pub mod record;

use std::path::PathBuf;

use fovea_core::display::DisplayProfile;
use fovea_post::tonemap::ToneMapExecutor;
use fovea_render::camera_path::CameraPath;
use fovea_render::pipeline::{Executors, FrameSettings};
use fovea_render::world::World;

pub use controls::{ViewMethod, ViewSettings};
pub use display_server::{connect_display_server, DisplayHold};
pub use error::{Result, ViewerError};
pub use frame::{Pose, ResidentStats, ResidentTotals, SecondEyeExecutors, Traffic};

/// Where the gaze comes from.
pub enum GazeSource {
    /// The mouse pointer over the frame.
    Mouse,
    /// A gaze CSV played back.
    Replay(gaze_input::GazeReplay),
    /// A UDP stream on 127.0.0.1 at this port ([`gaze_input`] documents the protocol).
    Udp(u16),
}

/// Everything the viewer opens with.
pub struct ViewerConfig {
    /// The scene.
    pub world: World,
    /// The display opened (a headset preset or `--res`); the panel can switch presets.
    pub display: DisplayProfile,
    /// The eye camera's pose to start from.
    pub pose: Pose,
    /// Interpupillary distance, metres (both eyes).
    pub ipd_m: f32,
    /// The frame settings the panel does not change (mapping parameters, shading, AA, memory
    /// limit, DOF options such as the CoC model).
    pub base: FrameSettings,
    /// The view settings to open with.
    pub view: ViewSettings,
    /// The gaze.
    pub gaze: GazeSource,
    /// A camera path to follow (`t,x,y,z,look_x,…`, as `fovea sequence --camera-path`)
    /// instead of the keys.
    pub camera_path: Option<CameraPath>,
    /// Headless: render this many frames (frame `i` at `i / fps` seconds of the gaze and
    /// camera path), write the screenshot, and exit.
    pub frames: Option<u64>,
    /// Frames per second of a headless run and of a stepped replay.
    pub fps: f64,
    /// Where a headless run writes its last frame (PNG, with its statistics as JSON beside).
    pub screenshot: Option<PathBuf>,
    /// Where the screenshot key writes (`shot_0001.png` …).
    pub shots_dir: PathBuf,
    /// Write every frame shown as `frame_00000.png` … into this folder.
    pub frames_out: Option<PathBuf>,
    /// Record the gaze and camera of every frame shown into this folder.
    pub record: Option<PathBuf>,
    /// Executors of the frame's stages other than the CPU's (the GPU's), if any: both eyes
    /// run on them.
    pub executors: Executors,
    /// Executor of the display encoding (exposure, tone curve, 8-bit sRGB; the GPU's), if any.
    pub tone_map: Option<Box<dyn ToneMapExecutor>>,
    /// Both eyes at the same time: the right eye's executors (on the device of `executors`)
    /// and the device's meeting point for both eyes' submissions
    /// (`fovea_render::pipeline::lockstep`); `None`: the eyes render in turn on `executors`.
    pub second_eye: Option<SecondEyeExecutors>,
    /// The GPU device the executors run on, when there is one: the views the resident frame
    /// serves (`fovea_gpu::frame::ResidentFrame`) render on it, and the window is drawn with
    /// it, the frames as textures (issue 37, item 6). `None`: the CPU path.
    pub resident: Option<fovea_gpu::GpuContext>,
    /// Which backend renders, in words (the HUD shows it).
    pub backend: String,
    /// Whether the frames are rendered on the CPU (then a still view is refined from the
    /// reduced scale to full scale).
    pub cpu_path: bool,
    /// Camera speed of the W A S D Q E keys, metres per second.
    pub move_speed_m_s: f32,
    /// No progress lines on stderr.
    pub quiet: bool,
    /// The connection to the display server made before the GPU was probed
    /// ([`connect_display_server`]), closed once the window's event loop has its own.
    pub display_hold: DisplayHold,
}

/// How a viewing went.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Summary {
    /// Frames shown.
    pub frames: u64,
    /// Frames shown per second of the viewing (wall clock).
    pub fps: f64,
    /// Mean wall time of a frame's rendering, milliseconds.
    pub mean_frame_ms: f64,
    /// The adapter that drew the window.
    pub adapter: String,
    /// The backend that rendered.
    pub backend: String,
    /// The gaze stream's counts, when there was one.
    pub stream: Option<gaze_input::StreamCounts>,
    /// Files written (screenshots, recordings).
    pub written: Vec<PathBuf>,
}

/// Whether a display server is there to open a window on: on Linux and the BSDs, `DISPLAY`
/// (X11) or `WAYLAND_DISPLAY` must be set. The error names both.
pub fn check_display_server() -> Result<()> {
    #[cfg(all(unix, not(target_os = "macos"), not(target_os = "ios")))]
    {
        let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
        if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
            return Err(ViewerError::NoDisplay(
                "neither DISPLAY (X11) nor WAYLAND_DISPLAY (Wayland) is set; run fovea view in a \
                 desktop session, or headless under `xvfb-run -a fovea view --frames N --screenshot out.png`"
                    .into(),
            ));
        }
    }
    Ok(())
}

/// Opens the window and runs until it is closed (or, headless, until the frames are done).
pub fn run(config: ViewerConfig) -> Result<Summary> {
    check_display_server()?;
    app::run(config)
}
