//! Weier's screen-aligned reconstruction on the GPU (`fovea_gpu::GpuPullPush`) against the
//! CPU's (`fovea_post::pull_push::pull_push` for colour, `fovea_post::inverse_map::
//! nearest_fill_depth` for depth), on every pixel.
//!
//! Both run the same f32 operations in the same order; the only freedom WGSL leaves a device
//! is to fuse a multiply and an add (and a division within 2.5 ulp), which moves a filled
//! value by about an ulp of the values involved. Colours are in [0, 1), so the bound is
//!
//! * **filled colour: |GPU − CPU| ≤ [`MAX_DIFF`] = 1e-5 per channel** (~80 ulp at 1.0; the
//!   measured maximum is in `docs/gpu-measurements.md`),
//! * **shaded colour: identical bits** (those pixels are never written),
//! * **depth: identical bits** everywhere (a pick, no arithmetic; +∞ where no shaded pixel
//!   lies within 64 px).
//!
//! Inputs: random colours in every pixel (shaded or not: the unshaded ones must not leak),
//! random depths with some +∞ (misses), random masks of several densities (100 %, 50 %, 5 %,
//! 1 %, 0 %), odd sizes (1003×997, 1×N, N×1, 1×1), and the real mask of a Weier mapping
//! through `GpuReconstructor` against `fovea_post::inverse_map::reconstruct_into`.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, MappingConfig, Method};
use fovea_core::Image;
use fovea_gpu::{GpuError, GpuPullPush, GpuReconstructor};
use fovea_post::inverse_map::{
    mask_of, nearest_fill_depth, reconstruct_into, ReconstructFilter, SampleBuffers,
};
use fovea_post::pull_push::pull_push;
use fovea_post::Rgb;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Largest per-channel difference of a filled colour.
const MAX_DIFF: f32 = 1e-5;

/// A `w`×`h` frame: random colour in [0, 1) everywhere, random depth in [0.1, 100) m with
/// 2 % misses (+∞), and a mask shaded with probability `density`.
fn random_frame(w: u32, h: u32, density: f64, seed: u64) -> (Image<Rgb>, Image<f32>, Image<bool>) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let n = (w * h) as usize;
    let color = (0..n)
        .map(|_| {
            [
                rng.random::<f32>(),
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        })
        .collect();
    let depth = (0..n)
        .map(|_| {
            if rng.random_bool(0.02) {
                f32::INFINITY
            } else {
                rng.random_range(0.1f32..100.0)
            }
        })
        .collect();
    let mask = (0..n).map(|_| rng.random_bool(density)).collect();
    (
        Image::from_vec(w, h, color).unwrap(),
        Image::from_vec(w, h, depth).unwrap(),
        Image::from_vec(w, h, mask).unwrap(),
    )
}

/// What one comparison measured.
#[derive(Debug, Default)]
struct Agreement {
    /// Unshaded (filled) pixels.
    filled: usize,
    /// Largest per-channel difference of a filled pixel.
    max_filled: f32,
    /// Shaded pixels whose colour bits differ.
    shaded_differ: usize,
    /// Pixels whose depth bits differ.
    depth_differ: usize,
    /// Unshaded pixels left at +∞ depth by the CPU.
    depth_misses: usize,
}

fn compare(
    mask: &Image<bool>,
    (cpu_c, cpu_d): (&Image<Rgb>, &Image<f32>),
    (gpu_c, gpu_d): (&Image<Rgb>, &Image<f32>),
) -> Agreement {
    let mut a = Agreement::default();
    for (k, &m) in mask.data().iter().enumerate() {
        let (c, g) = (cpu_c.data()[k], gpu_c.data()[k]);
        if m {
            a.shaded_differ += usize::from(c.map(f32::to_bits) != g.map(f32::to_bits));
        } else {
            a.filled += 1;
            for ch in 0..3 {
                assert!(g[ch].is_finite(), "pixel {k}: {g:?}");
                a.max_filled = a.max_filled.max((c[ch] - g[ch]).abs());
            }
            a.depth_misses += usize::from(cpu_d.data()[k] == f32::INFINITY);
        }
        a.depth_differ += usize::from(cpu_d.data()[k].to_bits() != gpu_d.data()[k].to_bits());
    }
    a
}

fn assert_agrees(name: &str, a: &Agreement) {
    common::shout(&format!("[fovea-gpu] pull-push {name}: {a:?}"));
    assert!(a.max_filled <= MAX_DIFF, "{name}: {a:?}");
    assert_eq!(a.shaded_differ, 0, "{name}: {a:?}");
    assert_eq!(a.depth_differ, 0, "{name}: {a:?}");
}

fn check(gpu: &GpuPullPush, name: &str, w: u32, h: u32, density: f64, seed: u64) -> Agreement {
    let (color, depth, mask) = random_frame(w, h, density, seed);
    let cpu_c = pull_push(&color, &mask).unwrap();
    let cpu_d = nearest_fill_depth(&depth, &mask).unwrap();
    let (gpu_c, gpu_d, times) = gpu.fill(&color, &depth, &mask).unwrap();
    assert!(times.levels >= 1);
    let a = compare(&mask, (&cpu_c, &cpu_d), (&gpu_c, &gpu_d));
    assert_agrees(&format!("{name} {w}x{h} density {density}"), &a);
    a
}

#[test]
fn random_masks_of_every_density_match_the_cpu() {
    let Some(ctx) = common::gpu_or_skip("random_masks_of_every_density_match_the_cpu") else {
        return;
    };
    let gpu = GpuPullPush::new(&ctx).unwrap();
    for (k, density) in [1.0, 0.5, 0.05, 0.01].into_iter().enumerate() {
        let a = check(&gpu, "random", 1003, 997, density, k as u64);
        // Every hole was compared (and at 100 % there are none).
        assert_eq!(a.filled == 0, density == 1.0, "{a:?}");
    }
    // 1 % leaves rings with no shaded pixel within 64 px on a small screen: +∞ depth.
    let a = check(&gpu, "sparse", 97, 61, 0.001, 9);
    assert!(a.depth_misses > 0, "{a:?}");
}

#[test]
fn odd_sizes_lines_and_single_pixels_match_the_cpu() {
    let Some(ctx) = common::gpu_or_skip("odd_sizes_lines_and_single_pixels_match_the_cpu") else {
        return;
    };
    let gpu = GpuPullPush::new(&ctx).unwrap();
    let mut seed = 100;
    for (w, h) in [
        (1, 1),
        (1, 777),
        (777, 1),
        (2, 3),
        (3, 2),
        (129, 65),
        (65, 129),
    ] {
        for density in [0.5, 0.05] {
            seed += 1;
            check(&gpu, "odd", w, h, density, seed);
        }
    }
}

#[test]
fn all_shaded_is_the_input_and_none_shaded_is_black_at_infinity() {
    let Some(ctx) =
        common::gpu_or_skip("all_shaded_is_the_input_and_none_shaded_is_black_at_infinity")
    else {
        return;
    };
    let gpu = GpuPullPush::new(&ctx).unwrap();
    let (color, depth, _) = random_frame(301, 203, 1.0, 5);
    let all = Image::new(301, 203, true).unwrap();
    let (c, d, _) = gpu.fill(&color, &depth, &all).unwrap();
    assert_eq!(c.data(), color.data());
    let bits = |img: &Image<f32>| img.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&d), bits(&depth));
    // Nothing shaded: the CPU's pyramid is all zero weight, so every pixel is 0 and +∞.
    let none = Image::new(301, 203, false).unwrap();
    let (c, d, _) = gpu.fill(&color, &depth, &none).unwrap();
    let cpu_c = pull_push(&color, &none).unwrap();
    assert!(cpu_c.data().iter().all(|p| *p == [0.0; 3]));
    assert_eq!(c.data(), cpu_c.data());
    assert!(d.data().iter().all(|&v| v == f32::INFINITY));
    let a = check(&gpu, "none", 301, 203, 0.0, 6);
    assert_eq!(a.depth_misses, 301 * 203);
}

#[test]
fn images_of_different_sizes_are_a_one_line_input_error() {
    let Some(ctx) = common::gpu_or_skip("images_of_different_sizes_are_a_one_line_input_error")
    else {
        return;
    };
    let gpu = GpuPullPush::new(&ctx).unwrap();
    let (color, depth, _) = random_frame(20, 10, 1.0, 1);
    let mask = Image::new(10, 20, true).unwrap();
    let e = gpu.fill(&color, &depth, &mask).unwrap_err();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    assert!(!e.to_string().contains('\n'), "{e}");
    assert!(gpu.fits(1440, 1600));
}

#[test]
fn a_pyramid_larger_than_a_binding_is_refused_before_allocating() {
    let Some(ctx) =
        common::gpu_or_skip("a_pyramid_larger_than_a_binding_is_refused_before_allocating")
    else {
        return;
    };
    let gpu = GpuPullPush::new(&ctx).unwrap();
    // A 1×N column's pyramid is ≈ 2N pixels: 144 MB of colour for N = 6 M, past lavapipe's
    // 128 MiB binding while the screen itself (72 MB) is within it.
    let (w, h) = (1u32, 6_000_000u32);
    let limits = ctx.limits();
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let fits = GpuPullPush::pyramid_bytes(w, h) <= binding;
    assert_eq!(gpu.fits(w, h), fits);
    let color = Image::new(w, h, [0.5f32; 3]).unwrap();
    let depth = Image::new(w, h, 2.0f32).unwrap();
    let mask = Image::new(w, h, true).unwrap();
    match gpu.fill(&color, &depth, &mask) {
        Ok((c, d, _)) => {
            assert!(fits);
            assert_eq!(c.data(), color.data());
            assert_eq!(d.data(), depth.data());
        }
        Err(e) => {
            assert!(!fits, "{e}");
            assert!(matches!(e, GpuError::AdapterTooSmall { .. }), "{e}");
            assert!(!e.to_string().contains('\n'), "{e}");
            common::shout(&format!("[fovea-gpu] refused as expected: {e}"));
        }
    }
}

#[test]
fn weier_frames_reconstruct_as_on_the_cpu() {
    let Some(ctx) = common::gpu_or_skip("weier_frames_reconstruct_as_on_the_cpu") else {
        return;
    };
    let gpu = GpuReconstructor::new(&ctx).unwrap();
    let d = DisplayProfile::preset("vive-pro-eye").unwrap();
    for (k, (gx, gy)) in [(720.0, 800.0), (100.0, 1500.0)].into_iter().enumerate() {
        let gaze = d.gaze(gx, gy).unwrap();
        let m = build(Method::Weier, &d, gaze, &MappingConfig::default()).unwrap();
        assert!(GpuReconstructor::supports(m.as_ref()));
        assert!(gpu.fits(m.as_ref()));
        let mut buffers = SampleBuffers::random(m.as_ref(), k as u64).unwrap();
        // A miss among the shaded pixels keeps its +∞ (and lends it to its holes).
        buffers.depth[0].data_mut()[..1000].fill(f32::INFINITY);
        let (w, h) = (d.width_px, d.height_px);
        let mut cpu_c = Image::new(w, h, [0.0f32; 3]).unwrap();
        let mut cpu_d = Image::new(w, h, 0.0f32).unwrap();
        let filter = ReconstructFilter::default();
        let (gpu_frame, times) = gpu.reconstruct(m.as_ref(), &d, &buffers, filter).unwrap();
        reconstruct_into(m.as_ref(), &d, &mut buffers, &mut cpu_c, &mut cpu_d, filter).unwrap();
        assert_eq!(times.bands, 1);
        let mask = mask_of(m.as_ref(), w, h);
        let shaded = mask.data().iter().filter(|&&s| s).count();
        assert!(shaded > 0 && shaded < (w * h) as usize, "{shaded}");
        let a = compare(
            &mask,
            (&cpu_c, &cpu_d),
            (&gpu_frame.color, &gpu_frame.depth),
        );
        assert_agrees(&format!("weier gaze ({gx}, {gy})"), &a);
        assert_eq!(a.filled, (w * h) as usize - shaded);
    }
    // Another mapping's buffers (VaFR's polar one) are not Weier's screen: a one-line error.
    let gaze = d.gaze(720.0, 800.0).unwrap();
    let weier = build(Method::Weier, &d, gaze, &MappingConfig::default()).unwrap();
    let vafr = build(Method::Vafr, &d, gaze, &MappingConfig::default()).unwrap();
    let wrong = SampleBuffers::random(vafr.as_ref(), 3).unwrap();
    let e = gpu
        .reconstruct(weier.as_ref(), &d, &wrong, ReconstructFilter::default())
        .err()
        .unwrap();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    assert!(!e.to_string().contains('\n'), "{e}");
}
