//! Temporal accumulation lowers VaFR's peripheral flicker on a sequence with saccades,
//! pursuit and a moving camera (the built-in scene; `fovea flicker` runs the same measurement
//! on real scenes, docs/sequences.md).

use fovea_core::display::DisplayProfile;
use fovea_core::gaze::synth::{Scenario, SynthDisplay};
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_eval::flicker::{FlickerMeter, DEFAULT_BANDS_DEG};
use fovea_eval::metrics::{luma_psnr, Region};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, render_frame_temporal, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};
use fovea_render::thin_lens::{render_window, Window};
use fovea_render::world::World;

#[test]
fn accumulation_lowers_vafr_peripheral_flicker() {
    let d = DisplayProfile::with_vertical_fov("t", 320, 360, Degrees(110.0)).unwrap();
    let scene = builtin::depth_range().unwrap();
    let cam0 = EyeCamera::from_desc(&scene.cameras[0], &d).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let frames = 36usize;
    let fps = 90.0;
    // Fixation, pursuit at 15°/s, a saccade, fixation.
    let step = d.radius_px(Degrees(8.0));
    let (cx, cy) = (160.0, 180.0);
    let gazes = Scenario::new(SynthDisplay::from_profile(&d), (cx - step, cy), 1000.0, 3)
        .fixation(0.08)
        .pursuit_to((cx, cy), 15.0)
        .saccade_to((cx + step, cy - 0.4 * step))
        .fixation(1.0)
        .build()
        .unwrap()
        .resample(fps, frames)
        .unwrap();
    let mut off = FlickerMeter::new(&d, &DEFAULT_BANDS_DEG, 20.0).unwrap();
    let mut on = FlickerMeter::new(&d, &DEFAULT_BANDS_DEG, 20.0).unwrap();
    let mut acc = TemporalAccumulator::new(TemporalSettings::default()).unwrap();
    let (mut psnr_off, mut psnr_on) = (0.0, 0.0);
    for (k, g) in gazes.iter().enumerate() {
        let f = k as f32 / (frames - 1) as f32;
        let cam = EyeCamera::new(
            cam0.position + (0.04 * f) * cam0.right + (0.01 * f) * cam0.up,
            cam0.forward,
            cam0.up,
            &d,
        )
        .unwrap();
        let gaze = d.gaze(g.x_px, g.y_px).unwrap();
        let reference = render_window(
            &world,
            &cam,
            Window::full(d.width_px, d.height_px),
            None,
            4,
            ShadingMode::NOISE_FREE,
            &|_, _| {},
        )
        .unwrap();
        let s = FrameSettings::new(Method::Vafr);
        let plain = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
        let accumulated =
            render_frame_temporal(&world, &cam, &s, gaze, &mut acc, &|_, _| {}).unwrap();
        off.push(&plain.color, &reference.color, &gaze).unwrap();
        on.push(&accumulated.color, &reference.color, &gaze)
            .unwrap();
        let r = d.radius_px(Degrees(10.0));
        let central = Region::around(g.x_px, g.y_px, r, d.width_px, d.height_px);
        psnr_off += luma_psnr(&reference.color, &plain.color, central).unwrap() / frames as f64;
        psnr_on +=
            luma_psnr(&reference.color, &accumulated.color, central).unwrap() / frames as f64;
    }
    let (a, b) = (off.report().periphery, on.report().periphery);
    println!(
        "peripheral flicker RMS {:.3} → {:.3} % (×{:.2}); temporal energy / reference {:.2} → {:.2}; PSNR ≤ 10° {psnr_off:.2} → {psnr_on:.2} dB",
        a.flicker_rms_pct,
        b.flicker_rms_pct,
        a.flicker_rms_pct / b.flicker_rms_pct,
        a.temporal_energy / a.reference_energy,
        b.temporal_energy / b.reference_energy,
    );
    assert!(a.flicker_rms_pct / b.flicker_rms_pct >= 1.1);
    assert!(b.temporal_energy < a.temporal_energy / 1.2);
    assert!(psnr_on > psnr_off - 1.0);
}
