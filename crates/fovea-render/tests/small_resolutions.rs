//! Small and thin resolutions (issue 21, item 3): every method at 1x1, 2x2, 8x8, 9x9, 16x9,
//! 100x1, 64x4 and 64x8 either builds its mapping and renders a frame of the built-in scene,
//! or returns a typed error that names the resolution. Nothing panics.

use std::panic::{catch_unwind, AssertUnwindSafe};

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, MappingConfig, Method};
use fovea_core::units::Degrees;
use fovea_render::bvh::Backend;
use fovea_render::camera::{EyeCamera, HmdRig};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::stereo::{fixating_eyes, render_stereo, StereoMode};
use fovea_render::world::World;

const SIZES: [(u32, u32); 8] = [
    (1, 1),
    (2, 2),
    (8, 8),
    (9, 9),
    (16, 9),
    (100, 1),
    (64, 4),
    (64, 8),
];

/// What happened to one method at one size.
enum Outcome {
    Rendered,
    Refused(String),
}

fn run(world: &World, method: Method, w: u32, h: u32) -> Result<Outcome, String> {
    let display = DisplayProfile::with_vertical_fov(format!("{w}x{h}"), w, h, Degrees(90.0))
        .map_err(|e| format!("display: {e}"))?;
    let scene = &world.scene;
    let camera =
        EyeCamera::from_desc(&scene.cameras[0], &display).map_err(|e| format!("camera: {e}"))?;
    for gaze in [display.centre_gaze(), display.gaze(0.0, 0.0).unwrap()] {
        if let Err(e) = build(method, &display, gaze, &MappingConfig::default()) {
            let msg = e.to_string();
            check_message(method, w, h, &msg)?;
            return Ok(Outcome::Refused(msg));
        }
        let settings = FrameSettings::new(method);
        match render_frame(world, &camera, &settings, gaze, &|_, _| {}) {
            Ok(frame) => {
                if frame.color.width() != w || frame.color.height() != h {
                    return Err(format!(
                        "frame is {}x{}",
                        frame.color.width(),
                        frame.color.height()
                    ));
                }
                if !frame
                    .color
                    .data()
                    .iter()
                    .all(|c| c.iter().all(|v| v.is_finite()))
                {
                    return Err("non-finite pixel".into());
                }
            }
            Err(e) => {
                let msg = e.to_string();
                check_message(method, w, h, &msg)?;
                return Ok(Outcome::Refused(msg));
            }
        }
    }
    Ok(Outcome::Rendered)
}

/// A refusal must name the resolution and no parameter the user never set.
fn check_message(method: Method, w: u32, h: u32, msg: &str) -> Result<(), String> {
    if !msg.contains(&format!("{w}x{h}")) && !msg.contains(&format!("{w}×{h}")) {
        return Err(format!("error does not name the resolution: {msg}"));
    }
    if method == Method::Lafr && msg.contains("delta") {
        return Err(format!("LaFR error names an internal parameter: {msg}"));
    }
    Ok(())
}

#[test]
fn every_method_renders_or_refuses_small_and_thin_resolutions() {
    let scene = builtin::depth_range().unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let mut failures = Vec::new();
    let mut table = Vec::new();
    for method in Method::ALL {
        for (w, h) in SIZES {
            let r = catch_unwind(AssertUnwindSafe(|| run(&world, method, w, h)));
            match r {
                Ok(Ok(Outcome::Rendered)) => table.push(format!("{method} {w}x{h}: rendered")),
                Ok(Ok(Outcome::Refused(m))) => table.push(format!("{method} {w}x{h}: {m}")),
                Ok(Err(e)) => failures.push(format!("{method} {w}x{h}: {e}")),
                Err(p) => {
                    let msg = p
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    failures.push(format!("{method} {w}x{h}: panic: {msg}"));
                }
            }
        }
    }
    println!("{}", table.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `--eyes both` at small sizes (the 9x9 case): both stereo modes render or refuse.
#[test]
fn stereo_frames_render_or_refuse_small_resolutions() {
    let scene = builtin::depth_range().unwrap();
    let c = scene.cameras[0].clone();
    let rig = HmdRig::new(c.position, c.forward, c.up, 0.063).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let mut failures = Vec::new();
    for method in [Method::Vafr, Method::Kfr, Method::Full] {
        for (w, h) in [(9, 9), (2, 2), (64, 4)] {
            let display =
                DisplayProfile::with_vertical_fov(format!("{w}x{h}"), w, h, Degrees(90.0)).unwrap();
            for mode in [StereoMode::Dup, StereoMode::Rep] {
                let r = catch_unwind(AssertUnwindSafe(|| {
                    let gaze = display.centre_gaze();
                    let (_, [(lc, lg), (rc, rg)]) = fixating_eyes(&world, &rig, &display, &gaze)?;
                    let eyes = [EyeState::looking_at(lg), EyeState::looking_at(rg)];
                    let s = FrameSettings::new(method);
                    render_stereo(&world, &lc, &rc, &s, eyes, mode, &|_, _| {}).map(|_| ())
                }));
                match r {
                    Ok(Ok(())) => {}
                    Ok(Err(e)) => {
                        let m = e.to_string();
                        if !m.contains(&format!("{w}x{h}")) {
                            failures.push(format!("{method} {w}x{h} {mode:?}: {m}"));
                        }
                    }
                    Err(_) => failures.push(format!("{method} {w}x{h} {mode:?}: panic")),
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
