//! The resident frame's sample side (`fovea_gpu::frame::ResidentSamples`, issue 37) against
//! the CPU's `trace_and_shade` of the same plans, and its traffic:
//!
//! * VaFR (exact rings, the default), Guenter's three layers and full resolution at the Vive
//!   Pro Eye, both eyes (the right eye 63 mm to the right with its own gaze, frame and eye in
//!   the random keys), the
//!   built-in scene with direct shading (one light; the environment through 4 occluded rays, a
//!   second frame with the unshadowed ambient term), one ray per texel: the resident sample
//!   buffers, read back here only, match the CPU's with display-encoded luma PSNR ≥ 40 dB
//!   (Reinhard, 8-bit sRGB, Rec. 601 luma, as `fovea_eval::metrics::luma_psnr`), and at least
//!   99 % of the texels agree on hitting or missing; KFR, LaFR and visual-polar likewise for
//!   one eye (the same kernels, their own rings and shaded rows);
//! * a steady-state binocular frame (the second, the gaze moved by a saccade-sized step): one
//!   submission, no blocking wait, at most 256 KiB uploaded, nothing read back, no buffer or
//!   bind group created;
//! * what the kernel does not serve (path tracing, periphery rays, the inset's Laplacian
//!   blend) is
//!   refused with `GpuError::Unsupported` naming it, before anything is recorded.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;
#[path = "common/resident.rs"]
mod resident;

use common::{gpu_or_skip, shout};
use fovea_core::mapping::Method;
use fovea_core::Image;
use fovea_gpu::frame::ResidentSamples;
use fovea_gpu::{GpuContext, GpuError};
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::trace_shade::trace_and_shade;
use fovea_render::pipeline::StageTimes;
use fovea_render::plan::FramePlan;
use fovea_render::shade::{EnvLight, ShadingMode};
use fovea_render::world::World;
use resident::{plan, settings, setup};

/// The CPU's sample buffers of `plan`, from the frame context's starting state (black, +∞).
fn cpu_samples(world: &World, camera: &EyeCamera, plan: &FramePlan) -> SampleBuffers {
    let mut s = SampleBuffers {
        color: plan
            .buffers
            .iter()
            .map(|b| Image::new(b.width, b.height, [0.0f32; 3]).unwrap())
            .collect(),
        depth: plan
            .buffers
            .iter()
            .map(|b| Image::new(b.width, b.height, f32::INFINITY).unwrap())
            .collect(),
    };
    let mut times = StageTimes::default();
    trace_and_shade(
        world,
        camera,
        plan,
        None,
        &mut s,
        None,
        &mut times,
        None,
        &fovea_render::pipeline::StageBackends::default(),
        &|_, _| {},
    )
    .unwrap();
    s
}

/// Display-encoded luma PSNR (dB) of `test` against `reference`, and the fraction of texels
/// whose depth agrees on a hit or a miss.
fn compare(reference: &SampleBuffers, test: &SampleBuffers) -> (f64, f64) {
    let luma = |img: &Image<[f32; 3]>| -> Vec<f64> {
        to_srgb8(img, 0.0, ToneCurve::Reinhard)
            .chunks_exact(3)
            .map(|c| (0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64) / 255.0)
            .collect()
    };
    let (mut se, mut n, mut same_hit) = (0.0f64, 0usize, 0usize);
    for k in 0..reference.color.len() {
        let (a, b) = (luma(&reference.color[k]), luma(&test.color[k]));
        assert_eq!(a.len(), b.len());
        se += a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>();
        n += a.len();
        same_hit += reference.depth[k]
            .data()
            .iter()
            .zip(test.depth[k].data())
            .filter(|(x, y)| x.is_finite() == y.is_finite())
            .count();
    }
    let mse = se / n as f64;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    };
    (psnr, same_hit as f64 / n as f64)
}

/// Both eyes of one method: the resident samples against the CPU's, for two frames (the
/// second with the gaze moved and the unshadowed environment), and the second frame's
/// traffic.
fn both_eyes_match_the_cpu(ctx: &GpuContext, method: Method) {
    let (world, cams) = setup();
    let display = &cams[0].display;
    let mut resident = ResidentSamples::new(ctx, &world).unwrap();
    let frames = [
        (ShadingMode::DIRECT, [(700.0, 820.0), (760.0, 800.0)], 0u64),
        (
            ShadingMode::Direct {
                env_light: EnvLight::Unshadowed,
            },
            [(520.0, 600.0), (580.0, 590.0)],
            1,
        ),
    ];
    for (f, (shading, gazes, frame)) in frames.into_iter().enumerate() {
        let s = settings(method, shading);
        let plans: Vec<FramePlan> = (0..2)
            .map(|e| {
                let g = display.gaze(gazes[e].0, gazes[e].1).unwrap();
                plan(&world, &cams[e], &s, g, frame, e as u32)
            })
            .collect();
        let eyes = [(&cams[0], &plans[0]), (&cams[1], &plans[1])];
        let before = ctx.traffic();
        let times = resident.render_eyes(&world, &eyes).unwrap();
        let moved = ctx.traffic().since(&before);
        shout(&format!(
            "[fovea-gpu] resident {method} frame {f}: host {:.2} ms (tables {:.2}), submit \
             {:.2} ms, {moved:?}",
            times.host_ms, times.tables_ms, times.submit_ms
        ));
        assert_eq!(moved.submissions, 1, "one submission per binocular frame");
        assert_eq!(moved.blocking_waits, 0);
        assert_eq!(moved.bytes_read_back, 0);
        if f > 0 {
            // Steady state: the gaze moved, the buffers stay.
            assert!(moved.bytes_uploaded <= 256 * 1024, "{moved:?}");
            assert_eq!(moved.buffers_created, 0, "{moved:?}");
            assert_eq!(moved.bind_groups_created, 0, "{moved:?}");
        }
        for e in 0..2 {
            let gpu = resident.samples(e).unwrap().read(ctx).unwrap();
            let cpu = cpu_samples(&world, &cams[e], &plans[e]);
            let (psnr, same_hit) = compare(&cpu, &gpu);
            shout(&format!(
                "[fovea-gpu] resident {method} frame {f} eye {e}: luma PSNR {psnr:.2} dB \
                 against the CPU's trace_and_shade, {:.4} % of texels agree on hit/miss",
                100.0 * same_hit
            ));
            assert!(psnr >= 40.0, "{method} frame {f} eye {e}: {psnr:.2} dB");
            assert!(same_hit >= 0.99, "{method} frame {f} eye {e}: {same_hit}");
        }
    }
}

#[test]
fn vafr_samples_of_both_eyes_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_samples_of_both_eyes_are_the_cpus") else {
        return;
    };
    both_eyes_match_the_cpu(&ctx, Method::Vafr);
}

#[test]
fn guenter_layers_of_both_eyes_are_the_cpus() {
    // Every layer of Guenter's three (one dispatch of each kernel per layer, each with its
    // own uniforms), against the CPU's layers texel by texel.
    let Some(ctx) = gpu_or_skip("guenter_layers_of_both_eyes_are_the_cpus") else {
        return;
    };
    both_eyes_match_the_cpu(&ctx, Method::Guenter);
}

#[test]
fn inset_layers_of_both_eyes_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("inset_layers_of_both_eyes_are_the_cpus") else {
        return;
    };
    both_eyes_match_the_cpu(&ctx, Method::Inset);
}

#[test]
fn full_resolution_samples_of_both_eyes_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("full_resolution_samples_of_both_eyes_are_the_cpus") else {
        return;
    };
    both_eyes_match_the_cpu(&ctx, Method::Full);
}

#[test]
fn what_the_kernel_does_not_serve_is_refused_before_recording() {
    let Some(ctx) = gpu_or_skip("what_the_kernel_does_not_serve_is_refused_before_recording")
    else {
        return;
    };
    let (world, cams) = setup();
    let gaze = cams[0].display.gaze(700.0, 820.0).unwrap();
    let mut resident = ResidentSamples::new(&ctx, &world).unwrap();
    let cases = [
        (
            settings(
                Method::Vafr,
                ShadingMode::Path {
                    bounces: 2,
                    spp: 1,
                    seed: 0,
                },
            ),
            "path tracing",
        ),
        (
            {
                let mut s = settings(Method::Vafr, ShadingMode::DIRECT);
                s.periphery_rays = 4;
                s
            },
            "rays per texel",
        ),
        (
            {
                let mut s = settings(Method::Inset, ShadingMode::DIRECT);
                s.inset_smoothing = fovea_post::inset_smoothing::Smoothing::LAPLACIAN;
                s
            },
            "boundary smoothing",
        ),
    ];
    for (s, what) in cases {
        let p = plan(&world, &cams[0], &s, gaze, 0, 0);
        let mut encoder = ctx
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        let before = ctx.traffic();
        let err = resident
            .record_eyes(&world, &[(&cams[0], &p)], &mut encoder)
            .unwrap_err();
        let moved = ctx.traffic().since(&before);
        assert!(
            matches!(&err, GpuError::Unsupported(m) if m.contains(what)),
            "{what}: {err}"
        );
        assert_eq!(moved.bytes_uploaded + moved.buffers_created, 0, "{what}");
        assert!(resident.samples(0).is_none(), "{what}: nothing prepared");
    }
}

/// The other polar mappings go through the same kernels (their rings, their shaded rows):
/// one eye, one frame each, against the CPU with the same bounds.
#[test]
fn kfr_lafr_and_visual_polar_samples_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("kfr_lafr_and_visual_polar_samples_are_the_cpus") else {
        return;
    };
    let (world, cams) = setup();
    let gaze = cams[0].display.gaze(610.0, 900.0).unwrap();
    let mut resident = ResidentSamples::new(&ctx, &world).unwrap();
    for method in [Method::Kfr, Method::Lafr, Method::VisualPolar] {
        let s = settings(method, ShadingMode::DIRECT);
        let p = plan(&world, &cams[0], &s, gaze, 3, 0);
        resident.render_eyes(&world, &[(&cams[0], &p)]).unwrap();
        let gpu = resident.samples(0).unwrap().read(&ctx).unwrap();
        let cpu = cpu_samples(&world, &cams[0], &p);
        let (psnr, same_hit) = compare(&cpu, &gpu);
        shout(&format!(
            "[fovea-gpu] resident {method}: luma PSNR {psnr:.2} dB against the CPU's \
             trace_and_shade, {:.4} % of texels agree on hit/miss",
            100.0 * same_hit
        ));
        assert!(psnr >= 40.0, "{method}: {psnr:.2} dB");
        assert!(same_hit >= 0.99, "{method}: {same_hit}");
    }
}
