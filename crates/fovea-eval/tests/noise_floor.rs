//! The reference's noise floor (issue 38, item 5): two references of different seeds differ
//! and score a finite floor with the viewer's noisy shading; the same seed renders the same
//! frame; noise-free shading gives identical frames whatever the seed (PSNR ∞, ꟻLIP 0).

use fovea_core::display::DisplayProfile;
use fovea_eval::reference::{noise_floor, render_reference, render_seeded, MeasuredShading};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::scene::builtin;
use fovea_render::world::World;

fn setup() -> (World, EyeCamera, DisplayProfile) {
    let d =
        DisplayProfile::with_vertical_fov("t", 64, 72, fovea_core::units::Degrees(100.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let cam = EyeCamera::from_desc(&scene.cameras[0], &d).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    (world, cam, d)
}

#[test]
fn two_seeds_differ_and_the_same_seed_repeats() {
    let (world, cam, d) = setup();
    let gaze = d.centre_gaze();
    let s = MeasuredShading::Viewer.reference_settings(4);
    let a = render_seeded(&world, &cam, &s, gaze, 0).unwrap();
    let a2 = render_seeded(&world, &cam, &s, gaze, 0).unwrap();
    let b = render_seeded(&world, &cam, &s, gaze, 7).unwrap();
    assert_eq!(
        a.color.data(),
        a2.color.data(),
        "the same seed, the same frame"
    );
    let differ = a
        .color
        .data()
        .iter()
        .zip(b.color.data())
        .filter(|(x, y)| x != y)
        .count();
    assert!(differ > 100, "{differ} pixels differ between seeds 0 and 7");
    let same = noise_floor(&a.color, &a2.color, [0, 0], d.ppd()).unwrap();
    assert_eq!(same.psnr_db, f64::INFINITY);
    assert_eq!(same.flip, 0.0);
    assert!(same.is_exact());
    let floor = noise_floor(&a.color, &b.color, [0, 7], d.ppd()).unwrap();
    assert!(
        floor.psnr_db.is_finite() && floor.psnr_db > 0.0,
        "{floor:?}"
    );
    assert!(floor.flip.is_finite() && floor.flip > 0.0, "{floor:?}");
    assert!(!floor.is_exact());
    assert_eq!(floor.json()["psnr_db"].as_f64(), Some(floor.psnr_db));
    assert_eq!(same.json()["psnr_db"], "inf");
}

#[test]
fn more_rays_lower_the_floor_and_noise_free_has_none() {
    let (world, cam, d) = setup();
    let gaze = d.centre_gaze();
    let coarse = render_reference(&world, &cam, MeasuredShading::Viewer, 2, gaze, [0, 1])
        .unwrap()
        .floor;
    let fine = render_reference(&world, &cam, MeasuredShading::Viewer, 32, gaze, [0, 1])
        .unwrap()
        .floor;
    // 16× the rays: the difference's variance falls ~16× (12 dB); ask for half of that.
    assert!(
        fine.psnr_db > coarse.psnr_db + 6.0,
        "2 rays: {coarse:?}, 32 rays: {fine:?}"
    );
    assert!(fine.flip < coarse.flip, "{coarse:?} {fine:?}");
    // Noise-free: two seeds render the same frame, bit for bit.
    let s = MeasuredShading::NoiseFree.reference_settings(2);
    let a = render_seeded(&world, &cam, &s, gaze, 0).unwrap();
    let b = render_seeded(&world, &cam, &s, gaze, 5).unwrap();
    let floor = noise_floor(&a.color, &b.color, [0, 5], d.ppd()).unwrap();
    assert_eq!(floor.psnr_db, f64::INFINITY);
    assert_eq!(floor.flip, 0.0);
    let r = render_reference(&world, &cam, MeasuredShading::NoiseFree, 2, gaze, [0, 5]).unwrap();
    assert!(r.floor.is_exact() && r.twin.is_none());
}
