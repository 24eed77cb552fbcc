//! Temporal accumulation: reprojection against fresh renders on a moving camera, fixed
//! points, ghosting.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, Method, SamplePoint};
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, render_frame_temporal, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};
use fovea_render::world::World;

/// [`FrameSettings::new`] with [`ShadingMode::NOISE_FREE`] shading: this file compares frames
/// pixel by pixel whose samples draw different random numbers, so the noise of the occluded
/// environment light (tested on its own in `env_light.rs`) would swamp what is measured here.
fn settings(method: Method) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = ShadingMode::NOISE_FREE;
    s
}

fn setup(d: &DisplayProfile) -> (World, EyeCamera) {
    let scene = builtin::depth_range().unwrap();
    let cam = EyeCamera::from_desc(&scene.cameras[0], d).unwrap();
    (World::new(scene, Backend::Obvhs).unwrap(), cam)
}

fn display() -> DisplayProfile {
    DisplayProfile::with_vertical_fov("t", 320, 240, Degrees(90.0)).unwrap()
}

fn max_abs_diff(a: &Image<Rgb>, b: &Image<Rgb>) -> f32 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).abs()).fold(0.0, f32::max))
        .fold(0.0, f32::max)
}

#[test]
fn a_still_frame_is_a_fixed_point_of_the_accumulation() {
    let d = display();
    let (world, cam) = setup(&d);
    // Weier's history is read at the footprint's mip level, a blur by design outside r₀; see
    // `weier_fovea_is_a_fixed_point`.
    for method in [Method::Vafr, Method::Kfr, Method::Inset, Method::Full] {
        let gaze = d.gaze(150.0, 110.0).unwrap();
        let mut s = settings(method);
        // The bilinear lookup and its one-pixel ray cones. With the footprint reconstruction's
        // narrower cones (the default) VaFR's still frame drifts by up to 0.024 in 103 of
        // 76,800 pixels after three frames, scattered over the frame: not understood yet, left
        // open (issue 17's closing note).
        s.reconstruct_filter = fovea_post::inverse_map::ReconstructFilter::Bilinear;
        let plain = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
        let mut acc = TemporalAccumulator::new(TemporalSettings {
            jitter: false,
            ..Default::default()
        })
        .unwrap();
        let mut last = None;
        for _ in 0..3 {
            last =
                Some(render_frame_temporal(&world, &cam, &s, gaze, &mut acc, &|_, _| {}).unwrap());
        }
        let last = last.unwrap();
        let t = last.stats.temporal.unwrap();
        let diff = max_abs_diff(&plain.color, &last.color);
        eprintln!(
            "{method}: reused {} fresh {} max diff {diff}",
            t.reused, t.fresh
        );
        let differing: Vec<usize> = plain
            .color
            .data()
            .iter()
            .zip(last.color.data())
            .enumerate()
            .filter(|(_, (a, b))| (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3))
            .map(|(k, _)| k)
            .collect();
        let differ = differing.len();
        // Bilinear taps at the angular seam of a polar buffer whose period is not a whole
        // number of rows are not exact.
        assert!(diff < 0.02 && differ < 20, "{method}: {diff}, {differ} px");
        // Every texel whose centre lies on the screen finds itself in the history.
        let mapping = build(method, &d, gaze, &s.mapping).unwrap();
        let mut on_screen = 0u64;
        for (layer, b) in mapping.buffers().iter().enumerate() {
            for j in 0..b.height {
                for i in 0..b.width {
                    let sp = SamplePoint {
                        layer: layer as u32,
                        u: i as f64 + 0.5,
                        v: j as f64 + 0.5,
                    };
                    let on = mapping.inverse(sp).is_some_and(|p| {
                        p.x_px >= 0.0
                            && p.y_px >= 0.0
                            && p.x_px <= d.width_px as f64
                            && p.y_px <= d.height_px as f64
                    });
                    on_screen += (on && mapping.is_shaded(layer as u32, i, j)) as u64;
                }
            }
        }
        assert!(
            t.reused as f64 >= 0.995 * on_screen as f64,
            "{method}: {t:?}, {on_screen}"
        );
    }
}

/// Camera `k` of a sideways move of 5 mm per frame.
fn moved(cam: &EyeCamera, k: usize) -> EyeCamera {
    let pos = cam.position + (0.005 * k as f32) * cam.right + (0.002 * k as f32) * cam.up;
    EyeCamera::new(pos, cam.forward, cam.up, &cam.display).unwrap()
}

#[test]
fn reprojected_history_matches_a_fresh_render_on_a_moving_camera() {
    let d = display();
    let (world, cam) = setup(&d);
    let gaze = d.gaze(160.0, 120.0).unwrap();
    let s = settings(Method::Full);
    let mut acc = TemporalAccumulator::new(TemporalSettings {
        jitter: false,
        ..Default::default()
    })
    .unwrap();
    render_frame_temporal(&world, &cam, &s, gaze, &mut acc, &|_, _| {}).unwrap();
    let next = moved(&cam, 10);
    let fresh = render_frame(&world, &next, &s, gaze, &|_, _| {}).unwrap();
    let history = acc.sample_history().unwrap();
    let mapping = build(Method::Full, &d, gaze, &s.mapping).unwrap();
    let (mut n, mut accepted, mut err) = (0u64, 0u64, 0.0f64);
    let mut static_err = 0.0f64;
    let first = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
    for j in 0..d.height_px {
        for i in 0..d.width_px {
            n += 1;
            let sp = SamplePoint {
                layer: 0,
                u: i as f64 + 0.5,
                v: j as f64 + 0.5,
            };
            let z = *fresh.depth.get(i, j);
            if let Some((c, v, _)) = history.lookup(mapping.as_ref(), &next, sp, z, 0.03) {
                if v > 0.99 {
                    accepted += 1;
                    let f = fresh.color.get(i, j);
                    let o = first.color.get(i, j);
                    err += (0..3).map(|k| (c[k] - f[k]).abs() as f64).sum::<f64>() / 3.0;
                    static_err += (0..3).map(|k| (o[k] - f[k]).abs() as f64).sum::<f64>() / 3.0;
                }
            }
        }
    }
    let (err, static_err) = (err / accepted as f64, static_err / accepted as f64);
    let mean = fresh
        .color
        .data()
        .iter()
        .map(|c| (c[0] + c[1] + c[2]) as f64 / 3.0)
        .sum::<f64>()
        / n as f64;
    eprintln!(
        "accepted {:.1} %, mean abs error {err:.5} (no reprojection {static_err:.5}, mean {mean:.3})",
        100.0 * accepted as f64 / n as f64
    );
    assert!(accepted as f64 > 0.9 * n as f64);
    assert!(err < 0.25 * static_err, "{err} vs {static_err}");
}

#[test]
fn weier_fovea_is_a_fixed_point() {
    let d = display();
    let (world, cam) = setup(&d);
    let (gx, gy) = (150.0, 110.0);
    let gaze = d.gaze(gx, gy).unwrap();
    let s = settings(Method::Weier);
    let plain = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
    let mut acc = TemporalAccumulator::new(TemporalSettings::default()).unwrap();
    let mut last = None;
    for _ in 0..3 {
        last = Some(render_frame_temporal(&world, &cam, &s, gaze, &mut acc, &|_, _| {}).unwrap());
    }
    let last = last.unwrap();
    // Within r₀ = 10° minus a margin for the pull-push and the footprint of the ring beyond.
    let r = d.radius_px(Degrees(8.0));
    let mut worst = 0.0f32;
    for y in 0..d.height_px {
        for x in 0..d.width_px {
            if (x as f64 + 0.5 - gx).hypot(y as f64 + 0.5 - gy) < r {
                let (a, b) = (plain.color.get(x, y), last.color.get(x, y));
                worst = (0..3).map(|c| (a[c] - b[c]).abs()).fold(worst, f32::max);
            }
        }
    }
    assert!(worst < 1e-3, "{worst}");
}

/// Display-encoded luma of linear RGB.
fn encoded(c: &Rgb) -> f32 {
    fovea_post::tonemap::linear_to_srgb(
        (0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]).clamp(0.0, 1.0),
    )
}

/// Pixels of `acc` whose encoded luma lies more than 0.1 outside the range of `fresh` in the
/// 5×5 window around.
fn ghost_count(acc: &Image<Rgb>, fresh: &Image<Rgb>) -> usize {
    let (w, h) = (acc.width() as i64, acc.height() as i64);
    let mut n = 0;
    for y in 0..h {
        for x in 0..w {
            let (mut lo, mut hi) = (f32::MAX, f32::MIN);
            for yy in (y - 2).max(0)..=(y + 2).min(h - 1) {
                for xx in (x - 2).max(0)..=(x + 2).min(w - 1) {
                    let v = encoded(fresh.get(xx as u32, yy as u32));
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            let a = encoded(acc.get(x as u32, y as u32));
            if a < lo - 0.1 || a > hi + 0.1 {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn accumulation_leaves_no_ghosts_on_a_moving_camera() {
    // The camera slides 6 cm sideways past the near sphere in 12 frames while the gaze
    // pursues: depth rejection must keep the sphere's history off the background it uncovers.
    // A ghost is a pixel whose accumulated luma lies more than 0.1 (display-encoded) outside
    // the range of the frame rendered afresh within 2 px: a colour that is nowhere near in
    // the current frame (blur stays inside that range; a trail of the sphere does not).
    let d = display();
    let (world, cam) = setup(&d);
    for method in [Method::Vafr, Method::Weier] {
        let mut acc = TemporalAccumulator::new(TemporalSettings::default()).unwrap();
        let mut worst_fraction = 0.0f64;
        for k in 0..12 {
            let c = moved(&cam, k);
            let gaze = d.gaze(130.0 + 3.0 * k as f64, 112.0).unwrap();
            let s = settings(method);
            let f = render_frame_temporal(&world, &c, &s, gaze, &mut acc, &|_, _| {}).unwrap();
            if k < 4 {
                continue;
            }
            let plain = render_frame(&world, &c, &s, gaze, &|_, _| {}).unwrap();
            let ghosts = ghost_count(&f.color, &plain.color);
            worst_fraction = worst_fraction.max(ghosts as f64 / d.pixel_count() as f64);
        }
        eprintln!(
            "{method}: worst ghost fraction {:.4} %",
            100.0 * worst_fraction
        );
        assert!(worst_fraction < 0.0005, "{method}: {worst_fraction}");
    }
}

#[test]
fn without_depth_rejection_the_test_sees_ghosts() {
    // The ghost criterion above can fail: with depth rejection disabled (τ = 1) the sphere's
    // history smears over the background it uncovers.
    let d = display();
    let (world, cam) = setup(&d);
    let mut acc = TemporalAccumulator::new(TemporalSettings {
        depth_tolerance: 1.0,
        clamp: false,
        alpha_min: 0.05,
        ..Default::default()
    })
    .unwrap();
    let mut ghosts = 0;
    for k in 0..12 {
        let c = moved(&cam, 2 * k);
        let gaze = d.gaze(150.0, 112.0).unwrap();
        let s = settings(Method::Vafr);
        let f = render_frame_temporal(&world, &c, &s, gaze, &mut acc, &|_, _| {}).unwrap();
        if k == 11 {
            let plain = render_frame(&world, &c, &s, gaze, &|_, _| {}).unwrap();
            ghosts = ghost_count(&f.color, &plain.color);
        }
    }
    eprintln!("no rejection: {ghosts} ghost pixels");
    assert!(ghosts as f64 > 0.001 * d.pixel_count() as f64, "{ghosts}");
}
