//! The sample-space denoiser in the frame (issue 38): on the built-in scene lit by its sky
//! through occluded environment rays (the default shading, Monte Carlo noise in every
//! sample), at a small resolution, the denoised frame's mean squared error against a
//! reference of the same primary rays with 256 environment rays per sample is lower than the
//! noisy frame's by a measured factor — at full resolution (the filter over the screen) and
//! for VaFR and visual-polar (over the polar buffer, across the fovea and the angular seam),
//! whose references are the full-resolution reference. The denoiser's stage is timed, its
//! settings are validated, and its buffers are reused from frame to frame.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::denoise::DenoiseParams;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{
    plan_frame, render_frame, render_planned, FrameContext, FrameInputs, FrameSettings, Stage,
};
use fovea_render::scene::builtin;
use fovea_render::shade::{EnvLight, ShadingMode};
use fovea_render::world::World;

fn setup(w: u32, h: u32) -> (World, EyeCamera) {
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let d = DisplayProfile::new("t", w, h, Degrees(100.0), Degrees(110.0)).unwrap();
    let camera = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    (world, camera)
}

fn mse(a: &Image<Rgb>, b: &Image<Rgb>) -> f64 {
    let n = a.data().len() as f64 * 3.0;
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (0..3).map(|k| ((x[k] - y[k]) as f64).powi(2)).sum::<f64>())
        .sum::<f64>()
        / n
}

#[test]
fn denoising_lowers_the_error_against_a_many_ray_reference() {
    let (world, camera) = setup(192, 216);
    let gaze = camera.display.centre_gaze();
    let render = |m: Method, shading: ShadingMode, denoise: bool| {
        let mut s = FrameSettings::new(m);
        s.shading = shading;
        s.denoise = denoise.then(DenoiseParams::default);
        render_frame(&world, &camera, &s, gaze, &|_, _| {}).unwrap()
    };
    let many = ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples: 256 },
    };
    // (method, the least factor asserted). The reference of each method is the same method
    // with 256 environment rays per sample: the same samples, the noise all but gone, so the
    // error measured is the noise (a foveated frame's own error against full resolution is
    // larger than its noise).
    for (m, least) in [
        (Method::Full, 10.0),
        (Method::Vafr, 3.0),
        (Method::VisualPolar, 3.0),
    ] {
        let reference = render(m, many, false);
        let noisy = render(m, ShadingMode::DIRECT, false);
        let clean = render(m, ShadingMode::DIRECT, true);
        let (e0, e1) = (
            mse(&noisy.color, &reference.color),
            mse(&clean.color, &reference.color),
        );
        eprintln!(
            "{m} {:?}: MSE {e0:.3e} noisy -> {e1:.3e} denoised (x{:.2} lower); denoise {:.1} ms cpu of {:.1} ms",
            clean.stats.buffers,
            e0 / e1,
            clean.stats.stages_cpu_ms.get(Stage::Denoise),
            clean.stats.total_cpu_ms
        );
        assert!(e0 / e1 > least, "{m}: only x{:.2}", e0 / e1);
        assert!(clean.stats.stages_ms.ran(Stage::Denoise));
        assert!(!noisy.stats.stages_ms.ran(Stage::Denoise));
        let st = clean.stats.denoise.expect("denoise stats");
        assert!(st.filtered > 0);
        assert!(noisy.stats.denoise.is_none());
    }
}

#[test]
fn the_denoiser_reuses_its_buffers_and_is_deterministic() {
    let (world, camera) = setup(64, 72);
    let mut s = FrameSettings::new(Method::Vafr);
    s.denoise = Some(DenoiseParams::default());
    let gaze = camera.display.centre_gaze();
    let mut ctx = FrameContext::new();
    let mut frames = Vec::new();
    for _ in 0..2 {
        let (plan, times) = plan_frame(&world, &camera, &s, gaze, [0.0, 0.0]).unwrap();
        let f = render_planned(
            &mut ctx,
            &world,
            &camera,
            &plan,
            FrameInputs::default(),
            times,
            &|_, _| {},
        )
        .unwrap();
        frames.push(f.color.clone());
    }
    let alone = render_frame(&world, &camera, &s, gaze, &|_, _| {}).unwrap();
    assert_eq!(frames[0].data(), frames[1].data());
    assert_eq!(frames[0].data(), alone.color.data());
}

#[test]
fn bad_denoiser_settings_are_refused_before_any_ray() {
    let (world, camera) = setup(32, 36);
    let mut s = FrameSettings::new(Method::Vafr);
    s.denoise = Some(DenoiseParams {
        iterations: 0,
        ..DenoiseParams::default()
    });
    let e = render_frame(
        &world,
        &camera,
        &s,
        camera.display.centre_gaze(),
        &|_, _| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("denoise iterations"), "{e}");
}
