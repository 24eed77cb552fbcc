//! The GPU depth of field (`fovea_gpu::GpuDof`) against the CPU's: the CoC map
//! (`fovea_post::dof::coc::coc_map`) and the scatter-as-gather filter
//! (`fovea_post::dof::gather::ScatterAsGather::apply`), every pixel.
//!
//! Bounds:
//!
//! * **CoC**: |GPU − CPU| ≤ 1e-4 · max(1, |CPU|) px. The GPU evaluates in f32 from constants
//!   the CPU computed in f64 and rounded once; the CPU evaluates in f64 and rounds the
//!   result, so they differ by a few f32 ulps (measured below; printed).
//! * **Gather** on the CPU's CoC map: |GPU − CPU| ≤ 1e-4 per channel for colours in [0, 1]
//!   (the same taps in the same order; only f32 rounding of the sums and the area
//!   interpolation may differ, e.g. fused multiply-adds). The worst difference and the
//!   number of texels that differ at all are printed.
//! * **The whole stage** (the GPU's own CoC, then its gather) against the CPU's: the same
//!   bound; the CoC's few ulps move a radius by ~1e-6 px.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1. Run with `--nocapture` to see the measured differences.

mod common;

use fovea_core::optics::EyeModel;
use fovea_core::units::Metres;
use fovea_core::Image;
use fovea_gpu::{GpuDof, GpuError};
use fovea_post::dof::coc::{coc_map, CocModel, CocParams};
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::dof::{DofFilter, DofInput};
use fovea_post::Rgb;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Largest per-channel difference of the gather, colours in [0, 1].
const MAX_DIFF: f32 = 1e-4;
/// Largest CoC difference relative to max(1 px, |CoC|).
const COC_REL: f64 = 1e-4;

fn params(model: CocModel) -> CocParams {
    CocParams {
        model,
        ..CocParams::thin_lens(EyeModel::default(), 1000.0)
    }
}

/// Worst per-channel difference and the count of texels (pixel channels) that differ.
fn compare(name: &str, gpu: &Image<Rgb>, cpu: &Image<Rgb>) -> (f32, usize) {
    assert_eq!((gpu.width(), gpu.height()), (cpu.width(), cpu.height()));
    let (mut worst, mut differ, mut at) = (0.0f32, 0usize, 0usize);
    for (i, (g, c)) in gpu.data().iter().zip(cpu.data()).enumerate() {
        for k in 0..3 {
            let d = (g[k] - c[k]).abs();
            if g[k] != c[k] {
                differ += 1;
            }
            // A NaN difference is the worst of all (and fails the bound).
            if d.is_nan() || d > worst {
                worst = d;
                at = i;
            }
        }
    }
    let n = gpu.data().len() * 3;
    common::shout(&format!(
        "[fovea-gpu] gather {name}: worst |GPU − CPU| {worst:.3e} (pixel {at}), {differ} of {n} \
         channel values differ"
    ));
    (worst, differ)
}

/// A textured near plane (x < edge) in front of a textured far plane.
fn depth_step(w: u32, h: u32, edge: u32, near_m: f32, far_m: f32) -> (Image<Rgb>, Image<f32>) {
    let color = Image::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let check = ((x / 4 + y / 4) % 2) as f32;
                if x < edge {
                    [0.9 * check, 0.2, 0.1 + 0.5 * check]
                } else {
                    [0.1, 0.3 + 0.6 * check, 0.8 * (1.0 - check)]
                }
            })
            .collect(),
    )
    .unwrap();
    let depth = Image::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| if i % w < edge { near_m } else { far_m })
            .collect(),
    )
    .unwrap();
    (color, depth)
}

fn cpu_gather(
    f: &ScatterAsGather,
    color: &Image<Rgb>,
    depth: &Image<f32>,
    coc: &Image<f32>,
    focus_m: f32,
) -> Image<Rgb> {
    f.apply(&DofInput {
        color,
        depth_m: depth,
        coc_px: coc,
        focus_m,
        px_per_dioptre: 1.0,
        gaze_px: [0.0, 0.0],
        px_per_degree: 17.0,
    })
    .unwrap()
}

#[test]
fn coc_map_equals_the_cpu_within_1e_4_relative() {
    let Some(ctx) = common::gpu_or_skip("coc_map_equals_the_cpu_within_1e_4_relative") else {
        return;
    };
    let gpu = GpuDof::new(&ctx).unwrap();
    let mut rng = Pcg64::seed_from_u64(18);
    let (w, h) = (61u32, 37u32);
    let mut depth: Vec<f32> = (0..w * h)
        .map(|_| 10f32.powf(rng.random_range(-1.5f32..2.0)))
        .collect();
    // No hits and garbage: NaN, ±∞, 0, negative.
    for (k, v) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -2.0, 1e-30]
        .into_iter()
        .enumerate()
    {
        depth[k * 7] = v;
    }
    let depth = Image::from_vec(w, h, depth).unwrap();
    let mut worst = 0.0f64;
    for model in [CocModel::ThinLens, CocModel::Stabilised] {
        for focus in [0.3, 1.0, 2.5, 40.0, f64::INFINITY] {
            let p = params(model);
            let cpu = coc_map(&p, Metres(focus), &depth).unwrap();
            let g = gpu.coc_map(&p, Metres(focus), &depth).unwrap();
            for (i, (a, b)) in g.data().iter().zip(cpu.data()).enumerate() {
                let rel = (*a as f64 - *b as f64).abs() / (*b as f64).abs().max(1.0);
                assert!(
                    rel <= COC_REL,
                    "{model:?} focus {focus}: pixel {i} depth {} GPU {a} CPU {b}",
                    depth.data()[i]
                );
                worst = worst.max(rel);
            }
        }
    }
    common::shout(&format!(
        "[fovea-gpu] CoC map: worst |GPU − CPU| / max(1, |CPU|) = {worst:.3e} px"
    ));
}

#[test]
fn gather_equals_the_cpu_on_a_depth_step() {
    let Some(ctx) = common::gpu_or_skip("gather_equals_the_cpu_on_a_depth_step") else {
        return;
    };
    let gpu = GpuDof::new(&ctx).unwrap();
    let (w, h) = (96u32, 64u32);
    let (color, depth) = depth_step(w, h, 40, 0.5, 3.0);
    // Pupil 4 mm on f = 1000 px: 4 px per dioptre; a larger pupil blurs more.
    let mut p = params(CocModel::ThinLens);
    p.eye.pupil = fovea_core::units::Millimetres(8.0);
    for focus in [0.5f64, 3.0, 1.0] {
        for f in [
            ScatterAsGather::default(),
            ScatterAsGather {
                fill_behind: false,
                ..Default::default()
            },
            ScatterAsGather {
                separate_near: false,
                max_radius_px: 6.5,
                ..Default::default()
            },
        ] {
            let cpu_coc = coc_map(&p, Metres(focus), &depth).unwrap();
            let cpu = cpu_gather(&f, &color, &depth, &cpu_coc, focus as f32);
            let (g, _) = gpu.gather(&f, &color, &depth, &cpu_coc).unwrap();
            let (worst, _) = compare(&format!("depth step, focus {focus} m, {f:?}"), &g, &cpu);
            assert!(worst <= MAX_DIFF, "{worst}");
            // The whole stage: the GPU's own CoC map, then its gather.
            let (g2, g_coc, _) = gpu
                .coc_and_gather(&f, &p, Metres(focus), &color, &depth)
                .unwrap();
            let (worst, _) = compare(&format!("stage, focus {focus} m"), &g2, &cpu);
            assert!(worst <= MAX_DIFF, "{worst}");
            for (a, b) in g_coc.data().iter().zip(cpu_coc.data()) {
                assert!((a - b).abs() <= 1e-4 * b.abs().max(1.0), "{a} {b}");
            }
        }
    }
}

#[test]
fn gather_equals_the_cpu_on_random_images() {
    let Some(ctx) = common::gpu_or_skip("gather_equals_the_cpu_on_random_images") else {
        return;
    };
    let gpu = GpuDof::new(&ctx).unwrap();
    let mut rng = Pcg64::seed_from_u64(7);
    let mut total = (0.0f32, 0usize, 0usize);
    for (w, h) in [(73u32, 41u32), (1, 1), (5, 90), (130, 3), (40, 40)] {
        for trial in 0..3 {
            let n = (w * h) as usize;
            let color = Image::from_vec(
                w,
                h,
                (0..n)
                    .map(|_| [rng.random(), rng.random(), rng.random()])
                    .collect(),
            )
            .unwrap();
            // Depth in blocks (surfaces) with noise, some misses; CoC with NaN and big values.
            let depth = Image::from_vec(
                w,
                h,
                (0..n)
                    .map(|i| {
                        let (x, y) = (i as u32 % w, i as u32 / w);
                        match rng.random_range(0..40) {
                            0 => f32::INFINITY,
                            1 => f32::NAN,
                            _ => {
                                0.5 + ((x / 9 + 3 * (y / 7)) % 5) as f32
                                    + rng.random::<f32>() * 0.01
                            }
                        }
                    })
                    .collect(),
            )
            .unwrap();
            let coc = Image::from_vec(
                w,
                h,
                (0..n)
                    .map(|_| match rng.random_range(0..50) {
                        0 => f32::NAN,
                        1 => 500.0,
                        _ => rng.random_range(-30.0f32..30.0),
                    })
                    .collect(),
            )
            .unwrap();
            let f = ScatterAsGather {
                max_radius_px: [32.0, 12.3, 0.5][trial],
                fill_behind: trial != 1,
                separate_near: trial != 2,
                depth_tolerance: [0.02, 0.0, 0.3][trial],
            };
            let cpu = cpu_gather(&f, &color, &depth, &coc, 1.0);
            let (g, _) = gpu.gather(&f, &color, &depth, &coc).unwrap();
            let (worst, differ) = compare(&format!("random {w}x{h} #{trial}"), &g, &cpu);
            assert!(worst <= MAX_DIFF, "{w}x{h} #{trial}: {worst}");
            total = (total.0.max(worst), total.1 + differ, total.2 + 3 * n);
        }
    }
    common::shout(&format!(
        "[fovea-gpu] gather on random images: worst {:.3e}, {} of {} channel values differ",
        total.0, total.1, total.2
    ));
}

#[test]
fn bad_input_is_a_typed_error() {
    let Some(ctx) = common::gpu_or_skip("bad_input_is_a_typed_error") else {
        return;
    };
    let gpu = GpuDof::new(&ctx).unwrap();
    let (color, depth) = depth_step(8, 4, 3, 0.5, 2.0);
    let small = Image::new(4, 4, 0.0f32).unwrap();
    let f = ScatterAsGather::default();
    assert!(matches!(
        gpu.gather(&f, &color, &depth, &small),
        Err(GpuError::Input(_))
    ));
    let bad = ScatterAsGather {
        max_radius_px: f32::NAN,
        ..f
    };
    assert!(matches!(
        gpu.gather(&bad, &color, &depth, &depth),
        Err(GpuError::Input(_))
    ));
    let weier = params(CocModel::TrackingAware { uncertainty_m: 0.2 });
    let e = gpu
        .coc_and_gather(&f, &weier, Metres(1.0), &color, &depth)
        .unwrap_err();
    assert!(matches!(e, GpuError::Unsupported(_)), "{e}");
    assert!(!e.to_string().contains('\n'));
    assert!(matches!(
        gpu.coc_map(&params(CocModel::ThinLens), Metres(f64::NAN), &depth),
        Err(GpuError::Input(_))
    ));
    assert!(!GpuDof::supports_coc(&weier.model));
}

/// `GpuDof::fits` says beforehand what the passes' own checks decide: a frame whose planes
/// exceed one storage binding is `AdapterTooSmall` before anything is allocated, and `fits`
/// is false for it; a small frame fits. The large frame is just over lavapipe's 128 MiB
/// (8192×4100 × 4 bytes a plane); on a device with larger bindings both say it fits. An 8K
/// frame (7680×4320, 126.6 MiB a plane) fits any device whose bindings hold that (issue 37).
#[test]
fn fits_agrees_with_the_passes_checks() {
    let Some(ctx) = common::gpu_or_skip("fits_agrees_with_the_passes_checks") else {
        return;
    };
    let gpu = GpuDof::new(&ctx).unwrap();
    assert!(gpu.fits(320, 180));
    let (w, h) = (8192u32, 4100u32);
    let limits = ctx.limits();
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let plane = |w: u32, h: u32| u64::from(w) * u64::from(h) * fovea_gpu::dof::PLANE_BYTES;
    assert_eq!(gpu.fits(7680, 4320), plane(7680, 4320) <= binding);
    let over = plane(w, h) > binding;
    assert_eq!(gpu.fits(w, h), !over);
    if over {
        let color = Image::new(w, h, [0.5f32; 3]).unwrap();
        let depth = Image::new(w, h, 1.0f32).unwrap();
        let e = gpu
            .coc_and_gather(
                &ScatterAsGather::default(),
                &params(CocModel::ThinLens),
                Metres(1.0),
                &color,
                &depth,
            )
            .unwrap_err();
        assert!(matches!(e, GpuError::AdapterTooSmall { .. }), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");
    } else {
        common::shout("[fovea-gpu] fits_agrees_with_the_passes_checks: this adapter's bindings hold 8192×4100; only `fits` was checked");
    }
}
