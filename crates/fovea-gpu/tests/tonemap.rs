//! The GPU tone map (`fovea_gpu::GpuToneMap`) against `fovea_post::tonemap::to_srgb8`: the
//! same bytes, or one code value off in at most 1e-4 of the values (Reinhard's division may
//! round differently on the device; the clamp curve has no operation that can). The counts
//! are printed.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use fovea_core::Image;
use fovea_gpu::GpuToneMap;
use fovea_post::tonemap::{srgb8_thresholds, to_srgb8, ToneCurve};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Largest share of values one code off.
const OFF_BY_ONE_SHARE: f64 = 1e-4;

#[test]
fn tone_curve_bytes_equal_the_cpu() {
    let Some(ctx) = common::gpu_or_skip("tone_curve_bytes_equal_the_cpu") else {
        return;
    };
    let gpu = GpuToneMap::new(&ctx).unwrap();
    let mut rng = Pcg64::seed_from_u64(3);
    // Random HDR values, every code step's threshold and its neighbours, and garbage.
    let mut values: Vec<f32> = (0..300_000)
        .map(|_| 10f32.powf(rng.random_range(-5.0f32..1.5)))
        .collect();
    for t in srgb8_thresholds() {
        for b in -2i32..=2 {
            values.push(f32::from_bits((t.to_bits() as i32 + b) as u32));
        }
    }
    values.extend([
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -1.0,
        0.0,
        3e38,
        1e-40,
    ]);
    while !values.len().is_multiple_of(3) {
        values.push(0.5);
    }
    let px: Vec<[f32; 3]> = values.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let w = 997u32;
    let h = (px.len() as u32).div_ceil(w);
    let mut px = px;
    px.resize((w * h) as usize, [0.25; 3]);
    let img = Image::from_vec(w, h, px).unwrap();
    for curve in [ToneCurve::Clamp, ToneCurve::Reinhard] {
        for stops in [0.0f32, -1.5, 2.0, 7.25] {
            let cpu = to_srgb8(&img, stops, curve);
            let g = gpu.to_srgb8(&img, stops, curve).unwrap();
            assert_eq!(g.len(), cpu.len());
            let (mut off1, mut worse) = (0usize, 0usize);
            for (a, b) in g.iter().zip(&cpu) {
                match a.abs_diff(*b) {
                    0 => {}
                    1 => off1 += 1,
                    _ => worse += 1,
                }
            }
            common::shout(&format!(
                "[fovea-gpu] tone map {curve:?} {stops:+} stops: {off1} of {} values one code \
                 off, {worse} more",
                cpu.len()
            ));
            assert_eq!(worse, 0, "{curve:?} {stops}");
            assert!(
                off1 as f64 <= OFF_BY_ONE_SHARE * cpu.len() as f64,
                "{curve:?} {stops}: {off1}"
            );
            if curve == ToneCurve::Clamp {
                assert_eq!(off1, 0, "{stops}");
            }
        }
    }
    // In bands (as an image larger than a binding goes): the same bytes as in one dispatch,
    // whatever the band, even one not a whole number of pixels.
    let row = Image::from_vec(w, 1, img.data()[..w as usize].to_vec()).unwrap();
    for (band, image) in [(64u64, &row), (30_001, &img), (262_147, &img)] {
        let banded = GpuToneMap::new(&ctx).unwrap().with_band_values(band);
        assert_eq!(banded.band_values(), band / 4 * 4);
        for curve in [ToneCurve::Clamp, ToneCurve::Reinhard] {
            let whole = gpu.to_srgb8(image, 1.0, curve).unwrap();
            let bands = banded.to_srgb8(image, 1.0, curve).unwrap();
            assert_eq!(bands, whole, "band {band} {curve:?}");
        }
    }
    // Empty image, bad exposure.
    assert!(gpu
        .to_srgb8(&img, f32::NAN, ToneCurve::Clamp)
        .is_err_and(|e| !e.to_string().contains('\n')));
}
