//! Binocular frames: VaFR_Dup against VaFR_Rep (VaFR Sec. 5.1, 9).

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_eval::metrics::{flip_mean, luma_psnr, Region};
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, EyeCamera, HmdRig};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::FrameSettings;
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::stereo::{render_stereo, StereoMode};
use fovea_render::world::World;
use glam::Vec3;

/// [`FrameSettings::new`] with [`ShadingMode::NOISE_FREE`] shading: this file compares frames
/// pixel by pixel whose samples draw different random numbers, so the noise of the occluded
/// environment light (tested on its own in `env_light.rs`) would swamp what is measured here.
fn settings(method: Method) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = ShadingMode::NOISE_FREE;
    s
}

/// Each eye's gaze at a world point.
fn gaze_at(cam: &EyeCamera, p: Vec3) -> Gaze {
    let s = cam.screen_point_of(p - cam.position).unwrap();
    cam.display.gaze(s.x_px, s.y_px).unwrap()
}

#[test]
fn rep_traces_at_most_60_percent_of_dup_and_matches_the_direct_right_eye() {
    let d = DisplayProfile::with_vertical_fov("t", 480, 540, Degrees(110.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let c = &scene.cameras[0];
    let rig = HmdRig::new(c.position, c.forward, c.up, 0.063).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let (lc, rc) = (
        rig.eye(Eye::Left, &d).unwrap(),
        rig.eye(Eye::Right, &d).unwrap(),
    );
    // Both eyes converge on a point 2 m ahead.
    let target = rig.head + 2.0 * rig.forward;
    let s = settings(Method::Vafr);
    let eyes = [
        EyeState::looking_at(gaze_at(&lc, target)),
        EyeState::looking_at(gaze_at(&rc, target)),
    ];
    let dup = render_stereo(&world, &lc, &rc, &s, eyes, StereoMode::Dup, &|_, _| {}).unwrap();
    let rep = render_stereo(&world, &lc, &rc, &s, eyes, StereoMode::Rep, &|_, _| {}).unwrap();
    let ratio = rep.stats.rays_primary as f64 / dup.stats.rays_primary as f64;
    let whole = Region::full(d.width_px, d.height_px);
    let psnr = luma_psnr(&dup.right.color, &rep.right.color, whole).unwrap();
    let flip = flip_mean(&dup.right.color, &rep.right.color, whole, d.ppd() as f32).unwrap();
    println!(
        "dup {} rays, rep {} rays ({:.1} %): warped {}, cracks {}, holes {}; right eye rep vs direct: PSNR {psnr:.2} dB, FLIP {flip:.4}",
        dup.stats.rays_primary,
        rep.stats.rays_primary,
        100.0 * ratio,
        rep.stats.warped,
        rep.stats.cracks_filled,
        rep.stats.holes_traced
    );
    // Stated bound: PSNR ≥ 33 dB, ꟻLIP ≤ 0.05 (measured 35.7 dB, 0.035).
    assert!(ratio <= 0.6, "{ratio}");
    assert!(psnr >= 33.0, "{psnr}");
    assert!(flip <= 0.05, "{flip}");
    // The left eyes are the same frame.
    assert_eq!(dup.left.color.data(), rep.left.color.data());
}

#[test]
fn disocclusions_behind_a_thin_pole_are_traced_not_smeared() {
    use fovea_render::scene::{Material, Mesh};
    let d = DisplayProfile::with_vertical_fov("t", 320, 360, Degrees(90.0)).unwrap();
    let mut scene = builtin::depth_range().unwrap();
    let c = scene.cameras[0].clone();
    // A red pole 2 cm wide, 0.6 m in front of the head, facing it.
    let red = scene.materials.len() as u32;
    scene
        .materials
        .push(Material::diffuse("pole", Vec3::new(0.8, 0.02, 0.02)));
    let right = c.forward.cross(c.up).normalize();
    let o = c.position + 0.6 * c.forward - 0.01 * right - 0.5 * c.up;
    let n = -c.forward;
    scene.meshes.push(Mesh {
        name: "pole".into(),
        positions: vec![o, o + 0.02 * right, o + 0.02 * right + c.up, o + c.up],
        normals: vec![n; 4],
        uvs: vec![],
        tangents: vec![],
        colors: vec![],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: red,
    });
    let rig = HmdRig::new(c.position, c.forward, c.up, 0.063).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let (lc, rc) = (
        rig.eye(Eye::Left, &d).unwrap(),
        rig.eye(Eye::Right, &d).unwrap(),
    );
    let target = rig.head + 0.6 * rig.forward;
    let s = settings(Method::Vafr);
    let eyes = [
        EyeState::looking_at(gaze_at(&lc, target)),
        EyeState::looking_at(gaze_at(&rc, target)),
    ];
    let dup = render_stereo(&world, &lc, &rc, &s, eyes, StereoMode::Dup, &|_, _| {}).unwrap();
    let rep = render_stereo(&world, &lc, &rc, &s, eyes, StereoMode::Rep, &|_, _| {}).unwrap();
    let red_px = |c: &[f32; 3]| c[0] > 0.25 && c[1] < 0.6 * c[0] && c[2] < 0.6 * c[0];
    // Background pixels (direct depth beyond 1 m) within 24 px of the pole in the right eye.
    let (w, h) = (d.width_px as i64, d.height_px as i64);
    let near = |x: i64, y: i64| {
        (-24..=24).any(|dx| {
            let xx = x + dx;
            xx >= 0 && xx < w && *dup.right.depth.get(xx as u32, y as u32) < 1.0
        })
    };
    let (mut bg, mut smeared, mut err) = (0u64, 0u64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let (xu, yu) = (x as u32, y as u32);
            if *dup.right.depth.get(xu, yu) > 1.0 && near(x, y) {
                bg += 1;
                let (a, b) = (rep.right.color.get(xu, yu), dup.right.color.get(xu, yu));
                if red_px(a) && !red_px(b) {
                    smeared += 1;
                }
                err += (0..3).map(|k| (a[k] - b[k]).abs() as f64).sum::<f64>() / 3.0;
            }
        }
    }
    let err = err / bg as f64;
    println!(
        "{bg} background pixels beside the pole: {smeared} show the pole's red in rep; mean abs difference {err:.4}; holes traced {}",
        rep.stats.holes_traced
    );
    assert!(bg > 1000);
    assert!(rep.stats.holes_traced > 0);
    assert!((smeared as f64) < 0.002 * bg as f64, "{smeared}");
    assert!(err < 0.03, "{err}");
}

#[test]
fn rep_on_a_real_scene() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes/japanese-classroom/scene.xml");
    if !path.exists() {
        println!("skipping: ../shared/scenes not found");
        return;
    }
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let scene = fovea_render::scene::Scene::load(&path).unwrap();
    let mut world = World::new(scene, Backend::Obvhs).unwrap();
    let head = Vec3::new(-1.4, 1.05, 4.0);
    let forward = (Vec3::new(-1.0, 0.7, 0.0) - head).normalize();
    let rig = HmdRig::new(head, forward, Vec3::Y, 0.063).unwrap();
    let centre = rig.eye(Eye::Centre, &d).unwrap();
    world.lights = fovea_render::lights::view_lights(&world, &centre, 4).unwrap();
    // Fixate the first surface at the screen centre of the cyclopean eye.
    let (_, [(lc, lg), (rc, rg)]) =
        fovea_render::stereo::fixating_eyes(&world, &rig, &d, &d.centre_gaze()).unwrap();
    let s = settings(Method::Vafr);
    let eyes = [EyeState::looking_at(lg), EyeState::looking_at(rg)];
    let dup = render_stereo(&world, &lc, &rc, &s, eyes, StereoMode::Dup, &|_, _| {}).unwrap();
    let rep = render_stereo(&world, &lc, &rc, &s, eyes, StereoMode::Rep, &|_, _| {}).unwrap();
    let ratio = rep.stats.rays_primary as f64 / dup.stats.rays_primary as f64;
    let whole = Region::full(d.width_px, d.height_px);
    let psnr = luma_psnr(&dup.right.color, &rep.right.color, whole).unwrap();
    let flip = flip_mean(&dup.right.color, &rep.right.color, whole, d.ppd() as f32).unwrap();
    println!(
        "classroom, Vive Pro Eye: rep traces {:.1} % of dup's primary rays ({} holes, {} cracks filled); right eye rep vs direct: PSNR {psnr:.2} dB, FLIP {flip:.4}",
        100.0 * ratio,
        rep.stats.holes_traced,
        rep.stats.cracks_filled
    );
    // Stated bound: PSNR ≥ 29 dB, ꟻLIP ≤ 0.06 (measured 30.5 dB, 0.038: warped samples sit up
    // to half a texel off their texel's centre, which shows on the classroom's fine textures).
    assert!(ratio <= 0.6, "{ratio}");
    assert!(psnr >= 29.0, "{psnr}");
    assert!(flip <= 0.06, "{flip}");
}
