//! The denoiser's temporal variance (issue 38; SVGF, Schied et al. 2017, Sec. 4.2): with
//! temporal accumulation the sample-space history keeps the first and second moments of the
//! Monte Carlo part's demodulated luminance, and the denoiser's luminance edge-stopping
//! weight reads their variance where a texel's history holds at least 4 frames (its spatial
//! 3×3 estimate elsewhere). On a still view of the built-in scene (its sky through one
//! occluded environment ray per sample, so the frames are noisy):
//!
//! - the estimate is absent for the first three frames and then falls as the accumulated
//!   mean's variance does (`Σ wₖ²` of the running estimate's weights: ¼ at 4 frames, 0.066
//!   at 16 with α_min = 0.1);
//! - the denoised accumulated frames are closer to a 64-ray frame than with the spatial
//!   estimate alone while the noise dominates their error (frames 3 and 7), and no more than
//!   5 % farther at frame 15.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::denoise::DenoiseParams;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{
    plan_frame, render_alone, render_planned, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::scene::builtin;
use fovea_render::shade::{EnvLight, FrameNoise, ShadingMode};
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings, VARIANCE_MIN_AGE};
use fovea_render::world::World;

fn setup() -> (World, EyeCamera) {
    let d = DisplayProfile::with_vertical_fov("t", 96, 72, Degrees(90.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let cam = EyeCamera::from_desc(&scene.cameras[0], &d).unwrap();
    (World::new(scene, Backend::Obvhs).unwrap(), cam)
}

fn settings(method: Method, samples: u32, denoise: bool) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples },
    };
    // As `frame_noise.rs`: the bilinear lookup keeps a still VaFR frame a fixed point of the
    // accumulation.
    s.reconstruct_filter = fovea_post::inverse_map::ReconstructFilter::Bilinear;
    s.denoise = denoise.then(DenoiseParams::default);
    s
}

fn mse(a: &Image<Rgb>, b: &Image<Rgb>) -> f64 {
    let n = a.data().len() as f64 * 3.0;
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (0..3).map(|c| ((x[c] - y[c]) as f64).powi(2)).sum::<f64>())
        .sum::<f64>()
        / n
}

/// A still sequence of `frames` frames with accumulation: per frame the colour, the number
/// of samples with a temporal variance and their mean variance.
fn still(
    world: &World,
    cam: &EyeCamera,
    s: &FrameSettings,
    temporal: TemporalSettings,
    frames: u64,
) -> Vec<(Image<Rgb>, usize, f64)> {
    let d = &cam.display;
    let gaze = d
        .gaze(d.width_px as f64 / 2.0, d.height_px as f64 / 2.0)
        .unwrap();
    let mut ctx = FrameContext::new();
    let mut acc = TemporalAccumulator::new(temporal).unwrap();
    let mut out = Vec::new();
    for _ in 0..frames {
        let (plan, times) = plan_frame(world, cam, s, gaze, acc.jitter(s.method)).unwrap();
        let plan = plan.with_noise(FrameNoise::new(acc.frame(), 0));
        let inputs = FrameInputs {
            accumulator: Some(&mut acc),
            prefill: None,
        };
        let colour = render_planned(&mut ctx, world, cam, &plan, inputs, times, &|_, _| {})
            .unwrap()
            .color
            .clone();
        let v: Vec<f64> = ctx
            .denoise_variance()
            .iter()
            .flat_map(|i| i.data().iter())
            .filter(|v| v.is_finite())
            .map(|&v| v as f64)
            .collect();
        let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
        out.push((colour, v.len(), mean));
    }
    out
}

/// `Σ wₖ²` of the running estimate after `n` frames of a still view (every history kept):
/// the new frame's weight is `max(α_min, 1/(age + 1))`.
fn squared_weights(n: u32, alpha_min: f64) -> f64 {
    let mut s = 1.0;
    for age in 1..n {
        let a = alpha_min.max(1.0 / (age as f64 + 1.0));
        s = a * a + (1.0 - a) * (1.0 - a) * s;
    }
    s
}

fn reference(world: &World, cam: &EyeCamera, method: Method) -> Image<Rgb> {
    let d = &cam.display;
    let gaze = d
        .gaze(d.width_px as f64 / 2.0, d.height_px as f64 / 2.0)
        .unwrap();
    let eye = fovea_render::eye::EyeState::fixating(world, cam, gaze, None).unwrap();
    let plan = FramePlan::new(world, cam, &settings(method, 64, false), &eye, [0.0, 0.0])
        .unwrap()
        .with_noise(FrameNoise::default());
    render_alone(
        world,
        cam,
        &plan,
        FrameInputs::default(),
        StageTimes::default(),
        &|_, _| {},
    )
    .unwrap()
    .color
}

#[test]
fn the_temporal_variance_falls_as_frames_accumulate() {
    let (world, cam) = setup();
    for method in [Method::Full, Method::Vafr] {
        let t = TemporalSettings::default();
        let frames = still(&world, &cam, &settings(method, 1, true), t, 16);
        for (f, (_, count, mean)) in frames.iter().enumerate() {
            eprintln!(
                "{method} frame {f}: {count} samples with a temporal variance, mean {mean:.3e}"
            );
        }
        // None before the history holds VARIANCE_MIN_AGE frames, most samples after.
        let first = VARIANCE_MIN_AGE as usize - 1;
        for (f, frame) in frames.iter().enumerate().take(first) {
            assert_eq!(frame.1, 0, "{method} frame {f}");
        }
        let most = frames[15].1;
        assert!(most > 1000, "{method}: only {most} samples");
        assert!(
            frames[first].1 * 10 >= most * 9,
            "{method}: {} of {most}",
            frames[first].1
        );
        // Falls as Σw² does, within a factor of 1.5 either way (the shading's noise is not
        // independent from frame to frame: its random numbers are a low-discrepancy
        // sequence over frames).
        let want = squared_weights(16, t.alpha_min as f64) / squared_weights(4, t.alpha_min as f64);
        let got = frames[15].2 / frames[first].2;
        eprintln!("{method}: variance falls x{got:.3} from frame 3 to 15; Σw² falls x{want:.3}");
        assert!(
            got < want * 1.5 && got > want / 1.5,
            "{method}: x{got:.3}, Σw² x{want:.3}"
        );
        // And monotonically while the history grows.
        for f in first + 1..16 {
            assert!(frames[f].2 < frames[f - 1].2 * 1.05, "{method} frame {f}");
        }
    }
}

#[test]
fn the_temporal_variance_denoises_no_worse_than_the_spatial_one() {
    let (world, cam) = setup();
    for method in [Method::Full, Method::Vafr] {
        let r = reference(&world, &cam, method);
        let s = settings(method, 1, true);
        let with = still(&world, &cam, &s, TemporalSettings::default(), 16);
        let spatial = TemporalSettings {
            variance: false,
            ..Default::default()
        };
        let without = still(&world, &cam, &s, spatial, 16);
        for f in [3, 7, 15] {
            let (a, b) = (mse(&with[f].0, &r), mse(&without[f].0, &r));
            eprintln!(
                "{method} frame {f}: MSE {a:.4e} temporal variance, {b:.4e} spatial ({:+.1} %)",
                100.0 * (a / b - 1.0)
            );
            // Measured: 4–9 % lower at frames 3 and 7; at frame 15, where both frames' error
            // has risen again (the accumulation's own drift, `frame_noise.rs`) and is no
            // longer the noise the variance measures, within 3 % (+2.9 % full, +1.1 % VaFR).
            let bound = if f < 15 { 1.0 } else { 1.05 };
            assert!(a < b * bound, "{method} frame {f}: {a:.4e} vs {b:.4e}");
        }
        // Before the history is long enough both are the same frame.
        assert_eq!(with[0].0.data(), without[0].0.data());
    }
}
