//! The thin-lens reference and DOF in the frame pipeline, on the built-in scene: the reference
//! reduces to the pinhole frame for a zero pupil and on the focus plane, converges as lens
//! samples grow; DOF-aware culling on VaFR saves shading for a near focus at a bounded cost.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Metres;
use fovea_eval::metrics::{crop, luma_psnr, Region};
use fovea_post::dof::coc::{coc_map, CocParams};
use fovea_post::dof::FilterKind;
use fovea_post::luma;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::thin_lens::{render_window, ThinLens, Window};
use fovea_render::world::World;

fn setup(display: &DisplayProfile) -> (World, EyeCamera) {
    let scene = builtin::depth_range().unwrap();
    let cam = EyeCamera::from_desc(&scene.cameras[0], display).unwrap();
    (World::new(scene, Backend::Obvhs).unwrap(), cam)
}

fn small_display() -> DisplayProfile {
    DisplayProfile::with_vertical_fov("test", 320, 240, fovea_core::units::Degrees(40.0)).unwrap()
}

#[test]
fn zero_pupil_is_the_pinhole_frame() {
    let d = small_display();
    let (world, cam) = setup(&d);
    let win = Window::centred(160.0, 120.0, 64, 48, 320, 240);
    let pin = render_window(&world, &cam, win, None, 1, ShadingMode::DIRECT, &|_, _| {}).unwrap();
    let lens = ThinLens {
        pupil_m: 0.0,
        focus_m: 1.0,
        lens_samples: 16,
    };
    let zero = render_window(
        &world,
        &cam,
        win,
        Some(&lens),
        1,
        ShadingMode::DIRECT,
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(pin.color, zero.color);
    assert!(zero.halves.is_none());
}

#[test]
fn pixel_area_sampling_is_shared_by_pinhole_and_reference() {
    // A zero pupil with 16 lens samples through the R2 pixel offsets is the pinhole frame
    // with 16 pixel samples.
    let d = small_display();
    let (world, cam) = setup(&d);
    let win = Window::centred(160.0, 120.0, 64, 48, 320, 240);
    let pin = render_window(&world, &cam, win, None, 16, ShadingMode::DIRECT, &|_, _| {}).unwrap();
    let lens = ThinLens {
        pupil_m: 0.0,
        focus_m: 1.0,
        lens_samples: 16,
    };
    let zero = render_window(
        &world,
        &cam,
        win,
        Some(&lens),
        16,
        ShadingMode::DIRECT,
        &|_, _| {},
    )
    .unwrap();
    // The same rays up to rounding in their directions, which can flip one of the 16 samples
    // of a pixel on a silhouette.
    let diffs: Vec<f32> = pin
        .color
        .data()
        .iter()
        .zip(zero.color.data())
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
        .collect();
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let worst = diffs.iter().fold(0.0f32, |m, &v| m.max(v));
    assert!(mean < 1e-4 && worst < 0.1, "{mean} {worst}");
    // Anti-aliased: differs from the centre-sampled frame at edges, same depth.
    let centre =
        render_window(&world, &cam, win, None, 1, ShadingMode::DIRECT, &|_, _| {}).unwrap();
    assert_ne!(centre.color, pin.color);
    assert_eq!(centre.depth, pin.depth);
    assert!(render_window(&world, &cam, win, None, 0, ShadingMode::DIRECT, &|_, _| {}).is_err());
}

#[test]
fn focus_plane_stays_sharp_and_reference_converges() {
    // The pinhole frame and the lens samples draw different random numbers: compare them
    // without the environment light's Monte Carlo noise.
    const NOISE_FREE: ShadingMode = ShadingMode::NOISE_FREE;
    let d = small_display();
    let (world, cam) = setup(&d);
    let win = Window::full(320, 240);
    let pin = render_window(&world, &cam, win, None, 1, NOISE_FREE, &|_, _| {}).unwrap();
    // Focus on the surface at the screen centre.
    let focus = *pin.depth.get(160, 120) as f64;
    assert!(focus.is_finite());
    let pupil_m = 0.006;
    let render = |n| {
        let lens = ThinLens {
            pupil_m,
            focus_m: focus,
            lens_samples: n,
        };
        render_window(&world, &cam, win, Some(&lens), 1, NOISE_FREE, &|_, _| {}).unwrap()
    };
    let r32 = render(32);
    let r128 = render(128);
    // Pixels whose 5×5 neighbourhood lies within 0.05 px of CoC of the focus plane match the
    // pinhole frame: the blur is only where the CoC says.
    let params = CocParams {
        eye: fovea_core::optics::EyeModel::default()
            .with_pupil(fovea_core::units::Millimetres(pupil_m * 1e3))
            .unwrap(),
        ..CocParams::thin_lens(Default::default(), d.focal_y_px())
    };
    let coc = coc_map(&params, Metres(focus), &pin.depth).unwrap();
    let mut diffs = Vec::new();
    for y in 2..238u32 {
        for x in 2..318u32 {
            let flat = (-2i32..=2).all(|dy| {
                (-2i32..=2).all(|dx| {
                    coc.get((x as i32 + dx) as u32, (y as i32 + dy) as u32)
                        .abs()
                        < 0.05
                })
            });
            if flat {
                diffs.push((luma(*r128.color.get(x, y)) - luma(*pin.color.get(x, y))).abs());
            }
        }
    }
    diffs.sort_by(|a, b| a.total_cmp(b));
    let n = diffs.len();
    assert!(n > 50, "{n}");
    let mean = diffs.iter().sum::<f32>() / n as f32;
    let p99 = diffs[n * 99 / 100];
    println!(
        "{n} focus-plane pixels: luma difference mean {mean:.5}, 99th percentile {p99:.4}, worst {:.4}",
        diffs[n - 1]
    );
    // Glossy highlights move a little as the ray origin moves over the pupil; the texture
    // and geometry seen through the pixel centre do not.
    assert!(mean < 0.002 && p99 < 0.02, "{mean} {p99}");
    // Out of focus the reference differs from the pinhole frame.
    let blurred = luma_psnr(&pin.color, &r128.color, Region::full(320, 240)).unwrap();
    assert!(blurred < 40.0, "{blurred}");
    // Four times the samples: the noise floor rises by about 6 dB for independent samples,
    // more for stratified ones.
    let (a, b) = (
        r32.noise_floor_psnr_db().unwrap(),
        r128.noise_floor_psnr_db().unwrap(),
    );
    println!("noise floor: 32 samples {a:.2} dB, 128 samples {b:.2} dB");
    assert!(b - a > 3.0 && b - a < 15.0, "{a} {b}");
    // And the two estimates agree with each other to about the floor of the coarser one.
    let agree = luma_psnr(&r128.color, &r32.color, Region::full(320, 240)).unwrap();
    assert!(agree > a - 3.0, "{agree} vs {a}");
}

#[test]
fn invalid_lens_and_window_are_errors() {
    let d = small_display();
    let (world, cam) = setup(&d);
    let win = Window::full(320, 240);
    for lens in [
        ThinLens {
            pupil_m: f64::NAN,
            focus_m: 1.0,
            lens_samples: 4,
        },
        ThinLens {
            pupil_m: 0.004,
            focus_m: 0.0,
            lens_samples: 4,
        },
        ThinLens {
            pupil_m: 0.004,
            focus_m: f64::NAN,
            lens_samples: 4,
        },
        ThinLens {
            pupil_m: 0.004,
            focus_m: 1.0,
            lens_samples: 0,
        },
        ThinLens {
            pupil_m: 0.5,
            focus_m: 1.0,
            lens_samples: 4,
        },
    ] {
        assert!(render_window(
            &world,
            &cam,
            win,
            Some(&lens),
            1,
            ShadingMode::DIRECT,
            &|_, _| {}
        )
        .is_err());
    }
    let outside = Window {
        x0: 300,
        y0: 0,
        width: 64,
        height: 8,
    };
    assert!(render_window(
        &world,
        &cam,
        outside,
        None,
        1,
        ShadingMode::DIRECT,
        &|_, _| {}
    )
    .is_err());
    // Focus at infinity is valid.
    let inf = ThinLens {
        pupil_m: 0.004,
        focus_m: f64::INFINITY,
        lens_samples: 4,
    };
    let small = Window::centred(160.0, 120.0, 16, 16, 320, 240);
    let r = render_window(
        &world,
        &cam,
        small,
        Some(&inf),
        1,
        ShadingMode::DIRECT,
        &|_, _| {},
    )
    .unwrap();
    assert!(r
        .color
        .data()
        .iter()
        .all(|c| c.iter().all(|v| v.is_finite())));
}

/// DOF-aware culling (Liu Eq. 10–11) on VaFR's LP buffer, focused near: it saves a measured
/// share of the shaded samples, and the blurred frame loses at most 0.5 dB of luma PSNR
/// against the thin-lens reference compared with the same filter without culling.
#[test]
fn culling_on_vafr_saves_shading_at_half_a_db_at_most() {
    let d = DisplayProfile::preset("2k").unwrap();
    let (world, cam) = setup(&d);
    let gaze = d.centre_gaze();
    let frame = |cull: bool| {
        let mut s = FrameSettings::new(Method::Vafr);
        let mut dof = DofSettings::new(Some(FilterKind::Gather), FocusMode::Fixed(0.5));
        dof.cull = cull;
        s.dof = Some(dof);
        render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap()
    };
    let (plain, culled) = (frame(false), frame(true));
    assert_eq!(plain.stats.samples_culled, 0);
    let total = culled.stats.samples_shaded + culled.stats.samples_culled;
    let saved = culled.stats.samples_culled as f64 / total as f64;
    // The reference: a window around the gaze, the eye's 4.49 mm pupil, focus 0.5 m.
    let win = Window::centred(
        gaze.point.x_px,
        gaze.point.y_px,
        256,
        256,
        d.width_px,
        d.height_px,
    );
    let lens = ThinLens {
        pupil_m: 0.00449,
        focus_m: 0.5,
        lens_samples: 64,
    };
    let reference = render_window(
        &world,
        &cam,
        win,
        Some(&lens),
        1,
        ShadingMode::DIRECT,
        &|_, _| {},
    )
    .unwrap();
    let region = Region {
        x0: win.x0,
        y0: win.y0,
        x1: win.x0 + win.width,
        y1: win.y0 + win.height,
    };
    let full = Region::full(win.width, win.height);
    let score = |img| luma_psnr(&reference.color, &crop(img, region).unwrap(), full).unwrap();
    let (p_plain, p_culled) = (score(&plain.color), score(&culled.color));
    let whole = luma_psnr(
        &plain.color,
        &culled.color,
        Region::full(d.width_px, d.height_px),
    )
    .unwrap();
    println!(
        "culling saved {:.1} % of {} surface samples ({} of {} shadow rays, {} of {} environment rays); PSNR vs reference {p_plain:.2} dB without, {p_culled:.2} dB with culling; whole frame culled vs not {whole:.2} dB",
        saved * 100.0,
        total,
        plain.stats.rays_shadow - culled.stats.rays_shadow,
        plain.stats.rays_shadow,
        plain.stats.rays_environment - culled.stats.rays_environment,
        plain.stats.rays_environment
    );
    assert!(culled.stats.rays_environment < plain.stats.rays_environment);
    assert!(culled.stats.rays_shadow < plain.stats.rays_shadow);
    assert!(saved > 0.05, "{saved}");
    assert!(p_plain - p_culled <= 0.5, "{p_plain} {p_culled}");
}
