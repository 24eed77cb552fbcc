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
    let one = render_frame(&world, &cam, &settings(Method::Vafr), gaze, &|_, _| {}).unwrap();
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
    bad.pixel_samples = 65;
    let e = render_frame(&world, &cam, &bad, gaze, &|_, _| {}).unwrap_err();
    assert!(e.to_string().contains("pixel-samples"), "{e}");
}
