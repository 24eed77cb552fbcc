//! Several primary rays per sample (`FrameSettings::pixel_samples`): at full resolution, 16
//! stratified rays per pixel equal the frame rendered at 4× the resolution and box-filtered
//! 4×4 (the brute-force supersampled reference); a foveated frame casts exactly N rays per
//! texel.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::world::World;

/// [`FrameSettings::new`] with [`ShadingMode::NOISE_FREE`] shading: this file compares frames
/// pixel by pixel whose samples draw different random numbers, so the noise of the occluded
/// environment light (tested on its own in `env_light.rs`) would swamp what is measured here.
fn settings(method: Method) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = ShadingMode::NOISE_FREE;
    s
}

fn camera(world: &World, w: u32, h: u32) -> EyeCamera {
    let d = DisplayProfile::new("t", w, h, Degrees(90.0), Degrees(100.0)).unwrap();
    EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap()
}

#[test]
fn sixteen_rays_per_pixel_equal_the_4x_frame_box_filtered() {
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let (w, h) = (48u32, 54u32);
    let small = camera(&world, w, h);
    let big = camera(&world, 4 * w, 4 * h);
    let mut s = settings(Method::Full);
    s.pixel_samples = 16;
    let gaze = small.display.centre_gaze();
    let ss = render_frame(&world, &small, &s, gaze, &|_, _| {}).unwrap();
    assert_eq!(ss.stats.rays_primary, 16 * (w * h) as u64);
    let big_gaze = big.display.centre_gaze();
    let reference =
        render_frame(&world, &big, &settings(Method::Full), big_gaze, &|_, _| {}).unwrap();
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0.0f32; 3];
            for dy in 0..4 {
                for dx in 0..4 {
                    let c = reference.color.get(4 * x + dx, 4 * y + dy);
                    for k in 0..3 {
                        sum[k] += c[k];
                    }
                }
            }
            let got = ss.color.get(x, y);
            for k in 0..3 {
                let want = sum[k] / 16.0;
                worst = worst.max((got[k] - want).abs() / want.abs().max(1e-3));
            }
        }
    }
    // Same rays and cones, summed in another order.
    assert!(worst < 1e-4, "largest relative difference {worst}");
}

#[test]
fn a_foveated_frame_casts_n_rays_per_texel() {
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let cam = camera(&world, 160, 180);
    let gaze = cam.display.gaze(60.0, 80.0).unwrap();
    let mut single = settings(Method::Vafr);
    single.periphery_rays = 1;
    let one = render_frame(&world, &cam, &single, gaze, &|_, _| {}).unwrap();
    assert!(one.stats.rays_primary <= one.stats.samples);
    for n in [2, 4, 5] {
        let mut s = settings(Method::Vafr);
        s.pixel_samples = n;
        let f = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
        // Sub-samples near the buffer's edge may map off the screen: at most n per texel.
        assert!(f.stats.rays_primary <= n as u64 * f.stats.samples);
        assert!(
            f.stats.rays_primary >= (n as u64 - 1) * one.stats.rays_primary,
            "{n}"
        );
        assert!(f.color.data().iter().flatten().all(|v| v.is_finite()));
    }
    let mut bad = settings(Method::Vafr);
    bad.pixel_samples = 0;
    assert!(render_frame(&world, &cam, &bad, gaze, &|_, _| {}).is_err());
    bad.pixel_samples = fovea_render::settings::MAX_PIXEL_SAMPLES + 1;
    let e = render_frame(&world, &cam, &bad, gaze, &|_, _| {}).unwrap_err();
    assert!(e.to_string().contains("pixel-samples"), "{e}");
}

/// A converged reference (issue 38 asks for ≥ 256 rays per pixel): 256 rays per pixel at full
/// resolution trace 256 primary rays for every pixel, in chunks of whole rows (a 64-pixel row
/// holds 16,384 G-buffer records), and the frame is finite.
#[test]
fn a_reference_takes_256_rays_per_pixel() {
    let d = DisplayProfile::new("tiny", 64, 40, Degrees(90.0), Degrees(60.0)).unwrap();
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let cam = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    let mut s = FrameSettings::new(Method::Full);
    s.pixel_samples = 256;
    let f = render_frame(&world, &cam, &s, d.centre_gaze(), &|_, _| {}).unwrap();
    assert_eq!(f.stats.rays_primary, 256 * 64 * 40);
    assert!(f.color.data().iter().flatten().all(|v| v.is_finite()));
}

/// The anti-aliased periphery (`FrameSettings::periphery_rays`). A coarse acuity model
/// (`ω(e) = 0.05·e + 0.1` deg/cycle) on a 4 px/deg display makes VaFR's outer texels span
/// several pixels: each texel casts one ray per pixel it covers (its column's rounded
/// spacing², at most the cap), the counts never fall outward, and the frame's primary rays
/// are at most their sum. What the rays buy is stability: when the gaze moves by a fraction
/// of a pixel the scene beyond 20° stays where it is, and any change there is the sampling
/// sparkling — with one ray per texel, point samples jump across edges and highlights; with a
/// ray per covered pixel they average them. The RMS change beyond 20° between the two frames
/// (linear RGB) must fall by at least 15 % (measured: 0.0244 → 0.0184, −25 %; the rest is the
/// bilinear reconstruction of large texels following the moved pole). (Against a supersampled full frame, the error there is
/// the reconstruction's blur of large texels, which more rays per texel do not lower; it is
/// printed, not asserted.)
#[test]
fn periphery_texels_cast_one_ray_per_pixel_they_cover() {
    use fovea_core::acuity::AcuityModel;
    use fovea_render::eye::EyeState;
    use fovea_render::pipeline::Frame;
    use fovea_render::plan::FramePlan;
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let cam = camera(&world, 320, 360);
    let display = &cam.display;
    let gaze = display.gaze(130.0, 160.0).unwrap();
    let moved = display.gaze(130.43, 160.29).unwrap();
    let coarse = |rays: u32| {
        let mut s = settings(Method::Vafr);
        s.mapping.vafr.acuity = AcuityModel::linear(0.05, 0.1).unwrap();
        s.periphery_rays = rays;
        s
    };
    let eye = EyeState::looking_at(gaze);
    let plan = FramePlan::new(&world, &cam, &coarse(4), &eye, [0.0; 2]).unwrap();
    let per_column = &plan.rays.per_column;
    assert!(per_column.iter().all(|&n| (1..=4).contains(&n)));
    assert_eq!(per_column[0], 1, "the fovea: one ray per texel");
    assert_eq!(*per_column.last().unwrap(), 4, "the far periphery: the cap");
    assert!(
        per_column.windows(2).all(|w| w[0] <= w[1]),
        "{per_column:?}"
    );
    let rows = plan.mapping().polar_layout().unwrap().rows;
    let most: u64 = rows
        .iter()
        .zip(per_column)
        .map(|(&r, &n)| r as u64 * n as u64)
        .sum();

    let rms_beyond_20 = |a: &Frame, b: &Frame| {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for y in 0..display.height_px {
            for x in 0..display.width_px {
                let p = fovea_core::units::ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                if display.eccentricity(p, &gaze).0 < 20.0 {
                    continue;
                }
                let (a, b) = (a.color.get(x, y), b.color.get(x, y));
                sum += (0..3).map(|k| ((a[k] - b[k]) as f64).powi(2)).sum::<f64>();
                n += 3;
            }
        }
        (sum / n as f64).sqrt()
    };
    let render = |s: &FrameSettings, g| render_frame(&world, &cam, s, g, &|_, _| {}).unwrap();
    let mut reference = settings(Method::Full);
    reference.pixel_samples = 16;
    let reference = render(&reference, gaze);
    let (one, one_moved) = (render(&coarse(1), gaze), render(&coarse(1), moved));
    let (four, four_moved) = (render(&coarse(4), gaze), render(&coarse(4), moved));
    assert!(four.stats.rays_primary <= most);
    assert!(four.stats.rays_primary > 2 * one.stats.rays_primary);
    let (s1, s4) = (
        rms_beyond_20(&one, &one_moved),
        rms_beyond_20(&four, &four_moved),
    );
    println!(
        "beyond 20°, a gaze shift of half a pixel changes the frame by RMS {s1:.4} with one ray \
         per texel, {s4:.4} with up to 4 ({} → {} primary rays); error against 16 rays per \
         pixel {:.4} → {:.4}",
        one.stats.rays_primary,
        four.stats.rays_primary,
        rms_beyond_20(&one, &reference),
        rms_beyond_20(&four, &reference)
    );
    assert!(s4 < 0.85 * s1, "{s4} vs {s1}");
}
