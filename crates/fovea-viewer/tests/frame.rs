//! The viewer's frames without a window: the full-scale frame is the pipeline's own frame
//! through the same tone curve, the reduced scale of the CPU path caps VaFR at the reduced
//! display's Nyquist rate, both eyes come side by side, and the light, overlay and A/B
//! settings reach the frame.

use fovea_core::display::DisplayProfile;
use fovea_core::gaze::GazeSample;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, HmdRig};
use fovea_render::pipeline::{render_frame, Executors, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::world::World;
use fovea_viewer::controls::{EyesChoice, LightsChoice};
use fovea_viewer::frame::{FrameRenderer, FrameRequest, RING_DEG};
use fovea_viewer::{Pose, ViewMethod, ViewSettings};

fn setup() -> (World, DisplayProfile, Pose) {
    let display = DisplayProfile::new("t", 192, 160, Degrees(100.0), Degrees(90.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Centre, &display).unwrap();
    (world, display, Pose::of(&camera))
}

fn request(view: ViewSettings, display: &DisplayProfile, pose: Pose) -> FrameRequest {
    FrameRequest {
        id: 7,
        view,
        display: display.clone(),
        pose,
        gaze: GazeSample::new(0.0, 120.0, 70.0),
        dt_s: 1.0 / 90.0,
        read_back: true,
    }
}

/// A renderer of `world` with `base` settings on the CPU (no executors, the CPU tone map), 63 mm
/// between the eyes.
fn cpu_renderer(world: World, base: FrameSettings) -> FrameRenderer {
    FrameRenderer::new(world, base, 0.063, Executors::default(), None).unwrap()
}

fn vafr(scale: f32) -> ViewSettings {
    ViewSettings::new(ViewMethod::Method(Method::Vafr), None, scale)
}

#[test]
fn the_full_scale_frame_is_the_pipelines_frame() {
    let (world, display, pose) = setup();
    let camera = pose.camera(&display).unwrap();
    let base = FrameSettings::new(Method::Vafr);
    let want = render_frame(
        &world,
        &camera,
        &base,
        display.gaze(120.0, 70.0).unwrap(),
        &|_, _| {},
    )
    .unwrap();
    let want = to_srgb8(&want.color, 0.0, ToneCurve::Reinhard);
    let mut r = cpu_renderer(world, base);
    let f = r.render(&request(vafr(1.0), &display, pose)).unwrap();
    assert_eq!((f.id, f.width, f.height), (7, 192, 160));
    let got: Vec<u8> = f
        .rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    assert_eq!(got, want);
    assert_eq!(f.backend, "cpu");
}

#[test]
fn a_reduced_scale_caps_vafr_at_the_reduced_displays_nyquist_rate() {
    let (world, display, pose) = setup();
    let mut r = cpu_renderer(world, FrameSettings::new(Method::Vafr));
    let full = r.render(&request(vafr(1.0), &display, pose)).unwrap();
    let half = r.render(&request(vafr(0.5), &display, pose)).unwrap();
    assert_eq!((half.width, half.height), (96, 80));
    let (n1, n2) = (full.stats[0].samples, half.stats[0].samples);
    println!("VaFR samples: {n1} at full scale, {n2} at half scale");
    // A quarter of the pixels; the uncapped buffer would not shrink at all.
    assert!(n2 * 2 < n1, "{n2} vs {n1}");
    // Full resolution at half scale: a quarter of the samples, exactly.
    let mut full_res = ViewSettings::new(ViewMethod::Method(Method::Full), None, 0.5);
    full_res.overlays.rings = true;
    let f = r.render(&request(full_res, &display, pose)).unwrap();
    assert_eq!(f.stats[0].samples, 96 * 80);
    assert_eq!(f.rings.len(), RING_DEG.len());
    // The 5° ring lies around the gaze (at half scale: 60, 35).
    let ring = &f.rings[0];
    assert!(!ring.is_empty());
    for p in ring {
        let d = ((p[0] - 60.0).powi(2) + (p[1] - 35.0).powi(2)).sqrt();
        assert!(d > 1.0 && d < 20.0, "{p:?}");
    }
}

#[test]
fn both_eyes_lights_and_ab_reach_the_frame() {
    let (world, display, pose) = setup();
    let lights = world.lights.len();
    let mut r = cpu_renderer(world, FrameSettings::new(Method::Kfr));
    let mut v = ViewSettings::new(ViewMethod::Method(Method::Kfr), None, 1.0);
    v.eyes = EyesChoice::Both;
    let both = r.render(&request(v.clone(), &display, pose)).unwrap();
    assert_eq!((both.width, both.height, both.stats.len()), (384, 160, 2));
    // The two eyes see from 63 mm apart: their halves differ.
    let half = |k: usize| -> Vec<u8> {
        both.rgba
            .chunks_exact(384 * 4)
            .flat_map(|row| row[k * 192 * 4..(k + 1) * 192 * 4].to_vec())
            .collect()
    };
    assert_ne!(half(0), half(1));
    v.eyes = EyesChoice::One;
    let all = r.render(&request(v.clone(), &display, pose)).unwrap();
    v.lights = LightsChoice::One;
    let one = r.render(&request(v.clone(), &display, pose)).unwrap();
    if lights > 1 {
        assert!(one.stats[0].rays_shadow < all.stats[0].rays_shadow);
    } else {
        assert_eq!(one.stats[0].rays_shadow, all.stats[0].rays_shadow);
    }
    v.compare_full = true;
    let ab = r.render(&request(v, &display, pose)).unwrap();
    assert_eq!(ab.stats[0].method, "full");
    assert_eq!(ab.stats[0].samples, 192 * 160);
}

#[test]
fn a_bad_setting_is_an_error_not_a_panic() {
    let (world, display, pose) = setup();
    let mut r = cpu_renderer(world, FrameSettings::new(Method::Vafr));
    let mut v = vafr(1.0);
    v.dof = Some(fovea_post::dof::FilterKind::Gather);
    v.pupil = fovea_viewer::controls::PupilChoice::Mm(40.0);
    assert!(r.render(&request(v, &display, pose)).is_err());
    let mut req = request(vafr(1.0), &display, pose);
    req.gaze.x_px = f64::NAN;
    assert!(r.render(&req).is_err());
    // The renderer still renders afterwards.
    assert!(r.render(&request(vafr(1.0), &display, pose)).is_ok());
}
