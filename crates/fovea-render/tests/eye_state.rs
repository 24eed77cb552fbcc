//! The eye state of a sequence: focus from the tracker's vergence depth, from the vergence of
//! a binocular gaze, from the depth buffer, held through blinks, or fixed.

use fovea_core::display::DisplayProfile;
use fovea_core::gaze::GazeSample;
use fovea_core::optics::AccommodationParams;
use fovea_core::units::Degrees;
use fovea_post::dof::FilterKind;
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::dof::{auto_focus_m, DofSettings, FocusMode};
use fovea_render::eye::{FocusDistance, FocusSource};
use fovea_render::scene::builtin;
use fovea_render::sequence::Sequence;
use fovea_render::world::World;

const FPS: f64 = 10.0;
const FRAMES: usize = 30;

struct Setup {
    world: World,
    rig: HmdRig,
    camera: EyeCamera,
    display: DisplayProfile,
}

fn setup() -> Setup {
    let display = DisplayProfile::new("t", 160, 180, Degrees(100.0), Degrees(110.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Centre, &display).unwrap();
    Setup {
        world,
        rig,
        camera,
        display,
    }
}

fn auto() -> DofSettings {
    DofSettings::new(Some(FilterKind::Gather), FocusMode::Auto)
}

fn plan(s: &Setup, gazes: Vec<GazeSample>, pairs: Option<&[(EyeCamera, EyeCamera)]>) -> Sequence {
    let n = gazes.len();
    Sequence::plan(
        &s.world,
        vec![s.camera.clone(); n],
        gazes,
        Some(&auto()),
        FPS,
        AccommodationParams::default(),
        pairs,
    )
    .unwrap()
}

fn focus_m(f: Option<FocusDistance>) -> f64 {
    f.unwrap().metres()
}

#[test]
fn the_trackers_vergence_depth_drives_focus_not_the_depth_buffer() {
    let s = setup();
    let (x, y) = (80.0, 90.0);
    let gaze = s.display.gaze(x, y).unwrap();
    let buffer_m = auto_focus_m(&s.world, &s.camera, &gaze).unwrap();
    // A vergence depth far from what the depth buffer says at the gaze.
    let vergence_m = if buffer_m > 2.0 { 0.6 } else { 8.0 };
    let gazes: Vec<GazeSample> = (0..FRAMES)
        .map(|k| GazeSample {
            depth_m: Some(vergence_m),
            ..GazeSample::new(k as f64 / FPS, x, y)
        })
        .collect();
    let seq = plan(&s, gazes, None);
    let dir = s.camera.direction(x as f32, y as f32);
    let along_axis = vergence_m * dir.dot(s.camera.forward) as f64;
    for e in &seq.eyes {
        assert_eq!(e.focus_source, Some(FocusSource::TrackerDepth));
        let v = e.vergence.unwrap().metres();
        assert!((v - along_axis).abs() < 1e-9, "{v} vs {along_axis}");
    }
    // The accommodation filter has settled on the vergence, not on the depth buffer.
    let last = focus_m(seq.eyes[FRAMES - 1].focus);
    assert!(
        (last - along_axis).abs() < 0.02 * along_axis,
        "focus {last} m, vergence {along_axis} m, depth buffer {buffer_m} m"
    );
    assert!((last - buffer_m).abs() > 0.3 * buffer_m.min(last));
    // Without the depth column, the same gaze focuses at the depth buffer's estimate.
    let plain: Vec<GazeSample> = (0..FRAMES)
        .map(|k| GazeSample::new(k as f64 / FPS, x, y))
        .collect();
    let seq = plan(&s, plain, None);
    let e = seq.eyes[FRAMES - 1];
    assert_eq!(e.focus_source, Some(FocusSource::DepthBuffer));
    assert!((focus_m(e.focus) - buffer_m).abs() < 0.05 * buffer_m);
}

#[test]
fn a_binocular_gaze_focuses_at_its_vergence_and_blinks_hold_the_focus() {
    let s = setup();
    let d = &s.display;
    let left = s.rig.eye(Eye::Left, d).unwrap();
    let right = s.rig.eye(Eye::Right, d).unwrap();
    // A point 0.9 m ahead of the head, slightly off axis: each eye's gaze is its projection.
    let target = s.camera.position + 0.9 * s.camera.forward + 0.05 * s.camera.up;
    let l = left.screen_point_of(target - left.position).unwrap();
    let r = right.screen_point_of(target - right.position).unwrap();
    let expected = ((target - s.camera.position).dot(s.camera.forward)) as f64;
    let pairs = vec![(left.clone(), right.clone()); FRAMES];
    let gazes: Vec<GazeSample> = (0..FRAMES)
        .map(|k| GazeSample {
            right: Some((r.x_px, r.y_px)),
            valid: !(10..13).contains(&k),
            ..GazeSample::new(k as f64 / FPS, l.x_px, l.y_px)
        })
        .collect();
    // The left eye's camera sees the sample's left gaze.
    let n = gazes.len();
    let seq = Sequence::plan(
        &s.world,
        vec![left.clone(); n],
        gazes,
        Some(&auto()),
        FPS,
        AccommodationParams::default(),
        Some(&pairs),
    )
    .unwrap();
    for (k, e) in seq.eyes.iter().enumerate() {
        let v = e.vergence.unwrap().metres();
        // The vergence is measured from the left eye along its axis: within 1 % of the
        // head's distance to the point.
        assert!(
            (v - expected).abs() < 0.01 * expected,
            "{k}: {v} vs {expected}"
        );
        let want = if (10..13).contains(&k) {
            FocusSource::Held
        } else {
            FocusSource::BinocularVergence
        };
        assert_eq!(e.focus_source, Some(want), "frame {k}");
        assert_eq!(e.valid, !(10..13).contains(&k));
    }
    let last = focus_m(seq.eyes[FRAMES - 1].focus);
    assert!(
        (last - expected).abs() < 0.02 * expected,
        "{last} vs {expected}"
    );
}

#[test]
fn fixed_focus_and_infinity_stay_as_given() {
    let s = setup();
    let gazes: Vec<GazeSample> = (0..3)
        .map(|k| GazeSample::new(k as f64 / FPS, 80.0, 90.0))
        .collect();
    for (f, want) in [
        (2.5, FocusDistance::Metres(2.5)),
        (f64::INFINITY, FocusDistance::Infinity),
    ] {
        let dof = DofSettings::new(Some(FilterKind::Gather), FocusMode::Fixed(f));
        let seq = Sequence::plan(
            &s.world,
            vec![s.camera.clone(); 3],
            gazes.clone(),
            Some(&dof),
            FPS,
            AccommodationParams::default(),
            None,
        )
        .unwrap();
        for e in &seq.eyes {
            assert_eq!(e.focus, Some(want));
            assert_eq!(e.focus_source, Some(FocusSource::Fixed));
        }
    }
    // No DOF: no focus at all.
    let seq = Sequence::plan(
        &s.world,
        vec![s.camera.clone(); 3],
        gazes,
        None,
        FPS,
        AccommodationParams::default(),
        None,
    )
    .unwrap();
    assert!(seq.eyes.iter().all(|e| e.focus.is_none()));
}
