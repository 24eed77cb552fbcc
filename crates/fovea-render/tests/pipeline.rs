//! End-to-end frames of the built-in scene: foveated images against the full-resolution
//! ground truth rendered through the same code.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, Method, SamplePoint};
use fovea_core::Image;
use fovea_eval::metrics::{flip_mean, luma_psnr, Region};
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::world::World;

/// [`FrameSettings::new`] with [`ShadingMode::NOISE_FREE`] shading: this file compares frames
/// pixel by pixel whose samples draw different random numbers, so the noise of the occluded
/// environment light (tested on its own in `env_light.rs`) would swamp what is measured here.
/// Noise-free shading and one ray per texel everywhere (the anti-aliased periphery's extra
/// rays are tested in `supersampling.rs`), so rays can be counted against samples.
fn settings(method: Method) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = ShadingMode::NOISE_FREE;
    s.periphery_rays = 1;
    s
}

fn setup(display: &DisplayProfile) -> (World, EyeCamera) {
    let scene = builtin::depth_range().unwrap();
    let cam = EyeCamera::from_desc(&scene.cameras[0], display).unwrap();
    (World::new(scene, Backend::Obvhs).unwrap(), cam)
}

fn render(world: &World, cam: &EyeCamera, method: Method, gx: f64, gy: f64) -> Image<Rgb> {
    let gaze = cam.display.gaze(gx, gy).unwrap();
    let s = settings(method);
    let f = render_frame(world, cam, &s, gaze, &|_, _| {}).unwrap();
    // Count, independently of the pipeline, the shaded buffer pixels whose centre maps back
    // onto the screen: each must get exactly one primary ray.
    let mapping = build(method, &cam.display, gaze, &s.mapping).unwrap();
    let mut on_screen = 0u64;
    for (layer, b) in mapping.buffers().iter().enumerate() {
        let layer = layer as u32;
        for j in 0..b.height {
            for i in 0..b.width {
                let p = SamplePoint {
                    layer,
                    u: i as f64 + 0.5,
                    v: j as f64 + 0.5,
                };
                if mapping.is_shaded(layer, i, j) && mapping.inverse(p).is_some() {
                    on_screen += 1;
                }
            }
        }
    }
    assert_eq!(
        f.stats.rays_primary, on_screen,
        "{method}: one ray per sample"
    );
    assert!(f.stats.rays_primary <= f.stats.samples);
    assert_eq!(f.stats.samples, mapping.sample_count());
    assert!(f
        .color
        .data()
        .iter()
        .all(|c| c.iter().all(|v| v.is_finite())));
    f.color
}

/// A full-resolution frame with 4 stratified rays per pixel: the reference for VaFR's fovea,
/// which the footprint reconstruction anti-aliases (up to several texels per pixel on a 2K
/// display), so that a one-ray full frame, aliased itself, is no longer the frame to match.
fn supersampled_full(world: &World, cam: &EyeCamera, gx: f64, gy: f64) -> Image<Rgb> {
    let gaze = cam.display.gaze(gx, gy).unwrap();
    let mut s = settings(Method::Full);
    s.pixel_samples = 4;
    render_frame(world, cam, &s, gaze, &|_, _| {})
        .unwrap()
        .color
}

/// Pixels within `deg` degrees of eccentricity around the gaze, as a square of that radius.
fn fovea_region(d: &DisplayProfile, gx: f64, gy: f64, deg: f64) -> Region {
    let r = d.radius_px(fovea_core::units::Degrees(deg));
    Region::around(gx, gy, r, d.width_px, d.height_px)
}

#[test]
fn vafr_matches_full_resolution_in_the_fovea_and_moves_with_the_gaze() {
    let d = DisplayProfile::preset("2k").unwrap();
    let (world, cam) = setup(&d);
    let full = supersampled_full(&world, &cam, 1280.0, 720.0);
    let ppd = d.ppd() as f32;
    let (ga, gb) = ((900.0, 800.0), (1700.0, 760.0));
    let va = render(&world, &cam, Method::Vafr, ga.0, ga.1);
    let vb = render(&world, &cam, Method::Vafr, gb.0, gb.1);
    let ra = fovea_region(&d, ga.0, ga.1, 5.0);
    let rb = fovea_region(&d, gb.0, gb.1, 5.0);
    let flip_aa = flip_mean(&full, &va, ra, ppd).unwrap();
    let flip_ab = flip_mean(&full, &vb, ra, ppd).unwrap();
    let psnr_aa = luma_psnr(&full, &va, ra).unwrap();
    let psnr_ab = luma_psnr(&full, &vb, ra).unwrap();
    let psnr_bb = luma_psnr(&full, &vb, rb).unwrap();
    let psnr_ba = luma_psnr(&full, &va, rb).unwrap();
    println!("fovea A: FLIP {flip_aa:.4} (gaze elsewhere {flip_ab:.4}), PSNR {psnr_aa:.2} dB (gaze elsewhere {psnr_ab:.2})");
    println!("fovea B: PSNR {psnr_bb:.2} dB (gaze elsewhere {psnr_ba:.2})");
    // Whole image, for reference.
    let whole = Region::full(d.width_px, d.height_px);
    println!(
        "whole image: PSNR {:.2} dB",
        luma_psnr(&full, &va, whole).unwrap()
    );
    // Against the 4-ray reference (measured 0.060; 0.29 with the gaze elsewhere).
    assert!(flip_aa < 0.075, "FLIP in the fovea {flip_aa}");
    assert!(
        psnr_aa > 30.0 && psnr_bb > 30.0,
        "PSNR in the fovea {psnr_aa} {psnr_bb}"
    );
    // The sharp region follows the gaze.
    assert!(psnr_aa > psnr_ab + 3.0 && psnr_bb > psnr_ba + 3.0);
    assert!(flip_ab > 1.5 * flip_aa);
}

/// The band `[x0, x1) × [yc − half, yc + half]`.
fn band(x0: f64, x1: f64, yc: f64, half: f64) -> Region {
    Region {
        x0: x0.round() as u32,
        x1: x1.round() as u32,
        y0: (yc - half).round() as u32,
        y1: (yc + half + 1.0).round() as u32,
    }
}

#[test]
fn angular_seam_and_gaze_point_carry_no_artifact() {
    let d = DisplayProfile::preset("2k").unwrap();
    let (world, cam) = setup(&d);
    let (gx, gy) = (900.0, 800.0);
    let full = supersampled_full(&world, &cam, gx, gy);
    let vafr = render(&world, &cam, Method::Vafr, gx, gy);
    // The log-polar buffer's rows wrap at angle 0: the ray from the gaze towards +x. Compare
    // the error along that ray (eccentricity 1°–6°, 5 rows) with bands 10 px above and below.
    let r1 = d.radius_px(fovea_core::units::Degrees(1.0));
    let r6 = d.radius_px(fovea_core::units::Degrees(6.0));
    let seam = luma_psnr(&full, &vafr, band(gx + r1, gx + r6, gy, 2.0)).unwrap();
    let above = luma_psnr(&full, &vafr, band(gx + r1, gx + r6, gy - 10.0, 2.0)).unwrap();
    let below = luma_psnr(&full, &vafr, band(gx + r1, gx + r6, gy + 10.0, 2.0)).unwrap();
    // The gaze point: the 7×7 pixels around it, where the first log-polar column is read.
    let centre = luma_psnr(
        &full,
        &vafr,
        Region::around(gx, gy, 3.5, d.width_px, d.height_px),
    )
    .unwrap();
    println!("seam {seam:.2} dB, beside it {above:.2} / {below:.2} dB; gaze point {centre:.2} dB");
    assert!(
        seam > above.min(below) - 2.0,
        "the angular seam is {seam:.2} dB, the bands beside it {above:.2} / {below:.2} dB"
    );
    assert!(seam > 30.0, "seam band {seam:.2} dB");
    assert!(centre > 30.0, "gaze point {centre:.2} dB");
}

#[test]
fn every_method_casts_one_ray_per_sample_and_covers_the_gaze_point() {
    let d = DisplayProfile::preset("2k").unwrap();
    let (world, cam) = setup(&d);
    let (gx, gy) = (1400.0, 650.0);
    let full = render(&world, &cam, Method::Full, gx, gy);
    for method in Method::ALL {
        if method == Method::Full {
            continue;
        }
        let img = render(&world, &cam, method, gx, gy);
        let centre = luma_psnr(
            &full,
            &img,
            Region::around(gx, gy, 8.0, d.width_px, d.height_px),
        )
        .unwrap();
        let whole = luma_psnr(&full, &img, Region::full(d.width_px, d.height_px)).unwrap();
        println!("{method}: gaze 16×16 px {centre:.2} dB, whole image {whole:.2} dB");
        // No hole or smear at the gaze: every method samples at least at screen rate there
        // (measured 32–57 dB, ∞ where the fovea is rendered at full resolution).
        assert!(centre > 28.0, "{method}: gaze region {centre:.2} dB");
    }
}

#[test]
fn retinal_frames_fit_the_machine_and_oversized_requests_are_refused_first() {
    use fovea_render::pipeline::memory_estimate;
    let d = DisplayProfile::preset("retinal").unwrap();
    let cfg = fovea_core::mapping::MappingConfig::default();
    let full = build(Method::Full, &d, d.centre_gaze(), &cfg).unwrap();
    let vafr = build(Method::Vafr, &d, d.centre_gaze(), &cfg).unwrap();
    let (mf, mv) = (
        memory_estimate(full.as_ref(), &d, false),
        memory_estimate(vafr.as_ref(), &d, false),
    );
    println!(
        "retinal: full {:.2} GiB, vafr {:.2} GiB",
        mf as f64 / (1u64 << 30) as f64,
        mv as f64 / (1u64 << 30) as f64
    );
    // Screen colour + depth at 16 bytes per pixel is the floor for either.
    assert!(mf >= d.pixel_count() * 16 && mv >= d.pixel_count() * 16);
    assert!(
        mf + mv < 24 << 30,
        "both frames together need {} bytes",
        mf + mv
    );

    // A budget below the estimate is refused before anything is traced.
    let (world, cam) = setup(&d);
    let mut s = settings(Method::Full);
    s.memory_limit_bytes = mf - 1;
    let t = std::time::Instant::now();
    let err = render_frame(&world, &cam, &s, d.centre_gaze(), &|_, _| {
        panic!("no sample may be traced")
    })
    .expect_err("refused");
    assert!(t.elapsed().as_secs_f64() < 5.0);
    let msg = err.to_string();
    assert!(msg.contains("GiB") && msg.contains("--max-memory"), "{msg}");
}

/// The reconstruct stage's vector kernel against its scalar one on a rendered frame's samples
/// (VaFR of the built-in scene at the Vive Pro Eye, gaze off centre, the default footprint
/// filter): colour within 1/255 and the same depth at every pixel.
#[test]
fn vector_and_scalar_reconstruction_agree_on_a_rendered_frame() {
    use fovea_post::inverse_map::{reconstruct_into_with_kernel, PolarKernel};
    if !PolarKernel::Avx2.available() {
        println!("skipped: this processor has no AVX2, only the scalar kernel runs");
        return;
    }
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let (world, cam) = setup(&display);
    let gaze = display.gaze(500.0, 900.0).unwrap();
    let mut s = settings(Method::Vafr);
    s.keep_samples = true;
    let f = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
    let samples = f.samples.expect("kept samples");
    let mapping = build(Method::Vafr, &display, gaze, &s.mapping).unwrap();
    let run = |kernel| {
        let mut samples = samples.clone();
        let (w, h) = (display.width_px, display.height_px);
        let mut color = Image::new(w, h, [0.0f32; 3]).unwrap();
        let mut depth = Image::new(w, h, 0.0f32).unwrap();
        reconstruct_into_with_kernel(
            mapping.as_ref(),
            &display,
            &mut samples,
            &mut color,
            &mut depth,
            s.reconstruct_filter,
            kernel,
        )
        .unwrap();
        (color, depth)
    };
    let (sc, sd) = run(PolarKernel::Scalar);
    let (vc, vd) = run(PolarKernel::Avx2);
    let worst = sc
        .data()
        .iter()
        .zip(vc.data())
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0f32, f32::max);
    let depths = sd
        .data()
        .iter()
        .zip(vd.data())
        .filter(|(a, b)| a.to_bits() != b.to_bits())
        .count();
    println!("largest colour difference {worst}, {depths} depths differ");
    assert!(worst <= 1.0 / 255.0, "{worst}");
    assert_eq!(depths, 0);
}
