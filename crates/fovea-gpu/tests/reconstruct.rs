//! The GPU polar reconstruction against the CPU one (`fovea_post::inverse_map::
//! reconstruct_into`) with the same filter, on every pixel of the screen.
//!
//! Texels are random (every texel independent, colour uniform in [0, 1): the worst case for
//! any coordinate error) and depth is the texel's index (so a different pick is seen). The two
//! executors read identical tables (`PolarTables`: the u(r) table, the padded and prefiltered
//! columns); they differ in the coordinates only: the CPU interpolates them between every 8th
//! pixel within 1/64 texel (`COORD_TOLERANCE_TEXELS`) and uses an atan2 polynomial good to
//! 1e-5 rad, the GPU computes every pixel with its own atan (~1e-7 rad). A coordinate error of
//! δ texels moves a bilinear lookup on random texels by at most δ in each of its two
//! directions, so the bound per channel is
//!
//! * **max |GPU − CPU| ≤ 2 · 1/64 + 2e-3** (the CPU test's own bound against the exact
//!   coordinates, the 2e-3 for rounding where a pixel's coordinates straddle a texel
//!   boundary and for the CPU's atan2 at the largest periods),
//! * **mean |GPU − CPU| ≤ 1.5e-3** per channel over the screen,
//! * **depth** (nearest texel, no interpolation): identical except where a pixel's
//!   coordinate lies within the coordinate error of a half-texel, at most 1 % of the
//!   pixels; coverage (black at infinite depth past the buffer) counts among those.
//!
//! Both differences are the CPU's: against the exact lookup (f64 coordinates from the
//! mapping itself) the GPU is within 2e-3 per channel (measured ≤ 5.1e-4, mean ≤ 2e-5) where
//! the CPU is 0.016–0.021 off (mean 6–9e-4); `bilinear_on_the_gpu_equals_the_exact_lookup`.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, FoveationMapping, MappingConfig, Method};
use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_gpu::{GpuError, GpuReconstructor};
use fovea_post::inverse_map::{
    reconstruct_filtered, PolarTables, ReconstructFilter, SampleBuffers, ScreenFrame,
    COORD_TOLERANCE_TEXELS,
};
use fovea_post::Rgb;

/// Largest per-channel difference allowed on random texels in [0, 1).
const MAX_DIFF: f32 = 2.0 * COORD_TOLERANCE_TEXELS + 2e-3;
/// Largest mean per-channel difference allowed (measured on lavapipe: 6.3e-4 to 9.2e-4, all of
/// it the CPU's interpolated coordinates; see the exact-lookup test).
const MEAN_DIFF: f64 = 1.5e-3;
/// Largest share of pixels whose depth pick (or coverage) may differ (measured: 0.32 % to
/// 0.44 %).
const DEPTH_SHARE: f64 = 0.01;
/// Against the exact lookup, the GPU's largest per-channel difference (measured: 1.5e-4 to
/// 5.1e-4; the CPU's is 0.016 to 0.021).
const EXACT_MAX_DIFF: f32 = 2e-3;
/// … its mean (measured: 8.3e-6 to 2.0e-5; the CPU's 6.3e-4 to 9.3e-4).
const EXACT_MEAN_DIFF: f64 = 5e-5;
/// … and the share of differing depth picks (measured: 0.004 % to 0.1 %; the CPU's 0.3 % to
/// 0.5 %).
const EXACT_DEPTH_SHARE: f64 = 0.002;

/// The bilinear polar reconstruction of pixel `(x, y)` computed the slow way (as the CPU
/// test's `reference_polar`): the column through the mapping's own f64 forward map, the angle
/// by `f64::atan2`, then the bilinear lookup with wrapping rows and the nearer texel's depth.
/// `None` where the mapping has no sample.
fn exact_bilinear(
    m: &dyn FoveationMapping,
    bufs: &SampleBuffers,
    x: u32,
    y: u32,
) -> Option<(Rgb, f32)> {
    let layout = m.polar_layout().unwrap();
    let last = layout.rows.iter().rposition(|&r| r > 0).unwrap();
    let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
    let u = m.forward(p)?.u;
    let (dx, dy) = (p.x_px - layout.centre.x_px, p.y_px - layout.centre.y_px);
    let turn = dy.atan2(dx).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
    let uc = (u - 0.5).clamp(0.0, last as f64);
    let i0 = uc as usize;
    let i1 = (i0 + 1).min(last);
    let fu = uc - i0 as f64;
    let read = |i: usize| -> ([f64; 3], f32) {
        let rows = layout.rows[i] as i64;
        let v = turn * layout.period[i] - 0.5;
        let j = v.floor();
        let fv = v - j;
        let ja = (j as i64).rem_euclid(rows) as u32;
        let jb = (j as i64 + 1).rem_euclid(rows) as u32;
        let (a, b) = (
            bufs.color[0].get(i as u32, ja),
            bufs.color[0].get(i as u32, jb),
        );
        let d = if fv < 0.5 { ja } else { jb };
        (
            [0, 1, 2].map(|k| a[k] as f64 + (b[k] as f64 - a[k] as f64) * fv),
            *bufs.depth[0].get(i as u32, d),
        )
    };
    let (a, da) = read(i0);
    let (b, db) = read(i1);
    Some((
        [0, 1, 2].map(|k| (a[k] + (b[k] - a[k]) * fu) as f32),
        if fu < 0.5 { da } else { db },
    ))
}

/// Random colour in every texel, depth = texel index ([`SampleBuffers::random`]).
fn random_buffers(mapping: &dyn FoveationMapping, seed: u64) -> SampleBuffers {
    SampleBuffers::random(mapping, seed).unwrap()
}

fn cpu(
    m: &dyn FoveationMapping,
    d: &DisplayProfile,
    bufs: &SampleBuffers,
    filter: ReconstructFilter,
) -> ScreenFrame {
    reconstruct_filtered(m, d, bufs.clone(), filter).unwrap()
}

/// How far apart two reconstructions are.
#[derive(Debug, Default)]
struct Diff {
    max: f32,
    mean: f64,
    depth_differs: usize,
    pixels: usize,
    /// Pixels whose colour differs by more than 1e-3 (to see that the comparison saw content).
    differing: usize,
}

fn compare(a: &ScreenFrame, b: &ScreenFrame) -> Diff {
    let mut d = Diff {
        pixels: a.color.data().len(),
        ..Default::default()
    };
    let mut sum = 0.0f64;
    for (ca, cb) in a.color.data().iter().zip(b.color.data()) {
        let mut worst = 0.0f32;
        for k in 0..3 {
            let e = (ca[k] - cb[k]).abs();
            assert!(e.is_finite(), "{ca:?} against {cb:?}");
            worst = worst.max(e);
            sum += e as f64;
        }
        d.max = d.max.max(worst);
        d.differing += (worst > 1e-3) as usize;
    }
    d.mean = sum / (3 * d.pixels.max(1)) as f64;
    d.depth_differs = a
        .depth
        .data()
        .iter()
        .zip(b.depth.data())
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    d
}

/// The cases of the issue: VaFR on the Vive Pro Eye centred and off-centre, VaFR at 2K, KFR;
/// visual-polar besides (the same pass reads any polar layout).
fn cases() -> Vec<(&'static str, Method, &'static str, f64, f64)> {
    vec![
        (
            "VaFR, Vive Pro Eye, centred",
            Method::Vafr,
            "vive-pro-eye",
            0.5,
            0.5,
        ),
        (
            "VaFR, Vive Pro Eye, off-centre",
            Method::Vafr,
            "vive-pro-eye",
            0.365,
            0.57,
        ),
        ("VaFR, 2K, off-centre", Method::Vafr, "2k", 0.31, 0.62),
        ("KFR, 2K, off-centre", Method::Kfr, "2k", 0.7, 0.4),
        ("visual-polar, 2K", Method::VisualPolar, "2k", 0.45, 0.55),
    ]
}

fn run_filter(test: &str, filter: ReconstructFilter) {
    let Some(ctx) = common::gpu_or_skip(test) else {
        return;
    };
    let gpu = GpuReconstructor::new(&ctx).unwrap();
    for (seed, (name, method, preset, gx, gy)) in cases().into_iter().enumerate() {
        let d = DisplayProfile::preset(preset).unwrap();
        let gaze = d
            .gaze(gx * d.width_px as f64, gy * d.height_px as f64)
            .unwrap();
        let m = build(method, &d, gaze, &MappingConfig::default()).unwrap();
        let bufs = random_buffers(m.as_ref(), seed as u64);
        let want = cpu(m.as_ref(), &d, &bufs, filter);
        let (got, times) = gpu.reconstruct(m.as_ref(), &d, &bufs, filter).unwrap();
        let diff = compare(&got, &want);
        common::shout(&format!(
            "[fovea-gpu] {name} ({filter:?}): max |GPU − CPU| {:.5} (bound {MAX_DIFF:.5}), mean \
             {:.2e} (bound {MEAN_DIFF:.0e}), {} pixels over 1e-3, depth picks differing {}/{} \
             ({:.4} %), {} band(s)",
            diff.max,
            diff.mean,
            diff.differing,
            diff.depth_differs,
            diff.pixels,
            100.0 * diff.depth_differs as f64 / diff.pixels as f64,
            times.bands
        ));
        assert!(diff.max <= MAX_DIFF, "{name} {filter:?}: {diff:?}");
        assert!(diff.mean <= MEAN_DIFF, "{name} {filter:?}: {diff:?}");
        assert!(
            (diff.depth_differs as f64) <= DEPTH_SHARE * diff.pixels as f64,
            "{name} {filter:?}: {diff:?}"
        );
        // The images have content: most pixels are lit, and the pass did not return the
        // same constant everywhere.
        let lit = got
            .color
            .data()
            .iter()
            .filter(|c| c.iter().any(|&v| v > 0.0))
            .count();
        assert!(lit * 2 > diff.pixels, "{name}: {lit} lit pixels");
    }
}

/// The GPU's bilinear reconstruction against the exact one (f64 coordinates from the mapping
/// itself, no lookup table, no interpolated coordinates) on every 5th row and column and the
/// gaze's row (the angular seam runs along it): the GPU computes each pixel's coordinates, so
/// it is much closer to the exact lookup than the CPU (whose coordinates are only within 1/64
/// texel). What is left is the u(r) table's linear interpolation between ⅛-px entries and f32
/// rounding.
#[test]
fn bilinear_on_the_gpu_equals_the_exact_lookup() {
    let Some(ctx) = common::gpu_or_skip("bilinear_on_the_gpu_equals_the_exact_lookup") else {
        return;
    };
    let gpu = GpuReconstructor::new(&ctx).unwrap();
    for (seed, (name, method, preset, gx, gy)) in cases().into_iter().enumerate() {
        let d = DisplayProfile::preset(preset).unwrap();
        let gaze = d
            .gaze(gx * d.width_px as f64, gy * d.height_px as f64)
            .unwrap();
        let m = build(method, &d, gaze, &MappingConfig::default()).unwrap();
        let bufs = random_buffers(m.as_ref(), seed as u64);
        let filter = ReconstructFilter::Bilinear;
        let (got, _) = gpu.reconstruct(m.as_ref(), &d, &bufs, filter).unwrap();
        let want_cpu = cpu(m.as_ref(), &d, &bufs, filter);
        let gy_px = gaze.point.y_px as u32;
        let (mut max_gpu, mut max_cpu, mut sum_gpu, mut sum_cpu) = (0.0f32, 0.0f32, 0.0, 0.0);
        let (mut depth_gpu, mut depth_cpu, mut n) = (0usize, 0usize, 0usize);
        for y in (0..d.height_px).step_by(5).chain([gy_px, gy_px + 1]) {
            let step = if y == gy_px || y == gy_px + 1 { 1 } else { 5 };
            for x in (0..d.width_px).step_by(step) {
                let Some((c, dep)) = exact_bilinear(m.as_ref(), &bufs, x, y) else {
                    continue;
                };
                let (g, k) = (got.color.get(x, y), want_cpu.color.get(x, y));
                for q in 0..3 {
                    max_gpu = max_gpu.max((g[q] - c[q]).abs());
                    max_cpu = max_cpu.max((k[q] - c[q]).abs());
                    sum_gpu += (g[q] - c[q]).abs() as f64;
                    sum_cpu += (k[q] - c[q]).abs() as f64;
                }
                depth_gpu += (*got.depth.get(x, y) != dep) as usize;
                depth_cpu += (*want_cpu.depth.get(x, y) != dep) as usize;
                n += 1;
            }
        }
        let (mean_gpu, mean_cpu) = (sum_gpu / (3 * n) as f64, sum_cpu / (3 * n) as f64);
        common::shout(&format!(
            "[fovea-gpu] {name}: against the exact lookup on {n} pixels: GPU max {max_gpu:.5} \
             mean {mean_gpu:.2e} depth {depth_gpu}; CPU max {max_cpu:.5} mean {mean_cpu:.2e} \
             depth {depth_cpu}"
        ));
        assert!(max_gpu <= EXACT_MAX_DIFF, "{name}: {max_gpu}");
        assert!(mean_gpu <= EXACT_MEAN_DIFF, "{name}: {mean_gpu}");
        assert!(
            (depth_gpu as f64) <= EXACT_DEPTH_SHARE * n as f64,
            "{name}: {depth_gpu}/{n}"
        );
    }
}

#[test]
fn bilinear_on_the_gpu_equals_the_cpu() {
    run_filter(
        "bilinear_on_the_gpu_equals_the_cpu",
        ReconstructFilter::Bilinear,
    );
}

#[test]
fn footprint_on_the_gpu_equals_the_cpu() {
    run_filter(
        "footprint_on_the_gpu_equals_the_cpu",
        ReconstructFilter::Footprint,
    );
}

/// The footprint filter actually filters on the GPU: in VaFR's fovea on a Vive Pro Eye (5–8
/// texels per pixel each way) it differs from the GPU's own bilinear lookup, far out it is
/// the same lookup bit for bit, and a constant buffer stays constant everywhere it is covered.
#[test]
fn footprint_on_the_gpu_filters_the_fovea_only() {
    let Some(ctx) = common::gpu_or_skip("footprint_on_the_gpu_filters_the_fovea_only") else {
        return;
    };
    let gpu = GpuReconstructor::new(&ctx).unwrap();
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    let gaze = d.gaze(700.0, 820.0).unwrap();
    let m = build(Method::Vafr, &d, gaze, &MappingConfig::default()).unwrap();
    let bufs = random_buffers(m.as_ref(), 7);
    let (fp, _) = gpu
        .reconstruct(m.as_ref(), &d, &bufs, ReconstructFilter::Footprint)
        .unwrap();
    let (bl, _) = gpu
        .reconstruct(m.as_ref(), &d, &bufs, ReconstructFilter::Bilinear)
        .unwrap();
    let near = (720u32, 830u32);
    let (a, b) = (fp.color.get(near.0, near.1), bl.color.get(near.0, near.1));
    assert!((0..3).any(|k| (a[k] - b[k]).abs() > 0.05), "{a:?} vs {b:?}");
    for (x, y) in [(5u32, 5u32), (1400, 1500), (100, 1200)] {
        assert_eq!(fp.color.get(x, y), bl.color.get(x, y), "({x}, {y})");
    }
    assert_eq!(
        fp.depth
            .data()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>(),
        bl.depth
            .data()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    );
    let mut flat = bufs.clone();
    flat.color
        .iter_mut()
        .for_each(|c| c.data_mut().fill([0.25, 0.5, 0.75]));
    let (out, _) = gpu
        .reconstruct(m.as_ref(), &d, &flat, ReconstructFilter::Footprint)
        .unwrap();
    for (k, c) in out.color.data().iter().enumerate() {
        for q in 0..3 {
            assert!(
                (c[q] - [0.25, 0.5, 0.75][q]).abs() < 1e-5,
                "pixel {k}: {c:?}"
            );
        }
    }
}

/// An 8K screen's output (530 MB) exceeds lavapipe's 128 MiB storage binding: the pass splits
/// it into bands of rows, and the result still equals the CPU's, seams between bands included.
#[test]
fn a_screen_larger_than_one_binding_is_split_into_bands() {
    let Some(ctx) = common::gpu_or_skip("a_screen_larger_than_one_binding_is_split_into_bands")
    else {
        return;
    };
    let gpu = GpuReconstructor::new(&ctx).unwrap();
    let d = DisplayProfile::preset("8k").unwrap();
    let gaze = d.gaze(0.4 * 7680.0, 0.55 * 4320.0).unwrap();
    let m = build(Method::Vafr, &d, gaze, &MappingConfig::default()).unwrap();
    let bufs = random_buffers(m.as_ref(), 11);
    let filter = ReconstructFilter::Footprint;
    let want = cpu(m.as_ref(), &d, &bufs, filter);
    let (got, times) = gpu.reconstruct(m.as_ref(), &d, &bufs, filter).unwrap();
    let diff = compare(&got, &want);
    let limit = ctx.limits().max_storage_buffer_binding_size;
    common::shout(&format!(
        "[fovea-gpu] VaFR 8K: {} band(s) under a {limit}-byte binding, max |GPU − CPU| {:.5}, \
         mean {:.2e}, depth picks differing {}/{}",
        times.bands, diff.max, diff.mean, diff.depth_differs, diff.pixels
    ));
    let needed = d.pixel_count() * 16;
    assert_eq!(
        times.bands as u64,
        needed.div_ceil((limit / (16 * 7680)) * 16 * 7680),
        "bands"
    );
    assert!(diff.max <= MAX_DIFF, "{diff:?}");
    assert!(diff.mean <= MEAN_DIFF, "{diff:?}");
    assert!((diff.depth_differs as f64) <= DEPTH_SHARE * diff.pixels as f64);
}

/// Inputs the pass cannot take are typed errors, never panics: a screen-aligned mapping,
/// buffers of another mapping's size, output images of the wrong size.
#[test]
fn unsupported_and_inconsistent_inputs_are_errors() {
    let Some(ctx) = common::gpu_or_skip("unsupported_and_inconsistent_inputs_are_errors") else {
        return;
    };
    let gpu = GpuReconstructor::new(&ctx).unwrap();
    let d = DisplayProfile::preset("2k").unwrap();
    let gaze = d.gaze(1000.0, 700.0).unwrap();
    let guenter = build(Method::Guenter, &d, gaze, &MappingConfig::default()).unwrap();
    assert!(!GpuReconstructor::supports(guenter.as_ref()));
    let bufs = random_buffers(guenter.as_ref(), 1);
    let e = gpu
        .reconstruct(guenter.as_ref(), &d, &bufs, ReconstructFilter::Bilinear)
        .err()
        .unwrap();
    assert!(matches!(e, GpuError::Unsupported(_)), "{e}");
    assert!(e.to_string().contains("--backend cpu"), "{e}");

    let vafr = build(Method::Vafr, &d, gaze, &MappingConfig::default()).unwrap();
    assert!(GpuReconstructor::supports(vafr.as_ref()));
    let kfr = build(Method::Kfr, &d, gaze, &MappingConfig::default()).unwrap();
    let wrong = random_buffers(kfr.as_ref(), 2);
    let e = gpu
        .reconstruct(vafr.as_ref(), &d, &wrong, ReconstructFilter::Bilinear)
        .err()
        .unwrap();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    assert!(!e.to_string().contains('\n'), "{e}");

    let right = random_buffers(vafr.as_ref(), 3);
    let mut color = Image::new(10, 10, [0.0f32; 3]).unwrap();
    let mut depth = Image::new(10, 10, 0.0f32).unwrap();
    let e = gpu
        .reconstruct_into(
            vafr.as_ref(),
            &d,
            &right,
            ReconstructFilter::Bilinear,
            &mut color,
            &mut depth,
        )
        .err()
        .unwrap();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
}

/// What `GpuReconstructor::fits` weighs against the device's binding limit is what the pass
/// uploads: the texels of `PolarTables`' padded columns, counted from the layout alone (no
/// device needed). At 8K, KFR's buffer is over lavapipe's 128 MiB and VaFR's under it.
#[test]
fn texel_bytes_are_what_the_pass_uploads() {
    for (name, method, preset, gx, gy) in cases() {
        let d = DisplayProfile::preset(preset).unwrap();
        let gaze = d
            .gaze(gx * d.width_px as f64, gy * d.height_px as f64)
            .unwrap();
        let m = build(method, &d, gaze, &MappingConfig::default()).unwrap();
        let bufs = random_buffers(m.as_ref(), 7);
        let tables = PolarTables::new(m.as_ref(), &d, &bufs, ReconstructFilter::Bilinear).unwrap();
        assert_eq!(
            GpuReconstructor::texel_bytes(m.as_ref()),
            Some(tables.columns.texels().len() as u64 * 16),
            "{name}"
        );
    }
    let d = DisplayProfile::preset("8k").unwrap();
    let bytes = |method| {
        let m = build(method, &d, d.centre_gaze(), &MappingConfig::default()).unwrap();
        GpuReconstructor::texel_bytes(m.as_ref()).unwrap()
    };
    let lavapipe = 128 << 20;
    assert!(bytes(Method::Kfr) > lavapipe, "{}", bytes(Method::Kfr));
    assert!(bytes(Method::Vafr) < lavapipe, "{}", bytes(Method::Vafr));
    let full = build(Method::Full, &d, d.centre_gaze(), &MappingConfig::default()).unwrap();
    assert_eq!(GpuReconstructor::texel_bytes(full.as_ref()), None);
}
