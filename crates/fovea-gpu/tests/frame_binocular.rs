//! The whole binocular resident frame (`fovea_gpu::frame::ResidentFrame`, issue 37) against
//! the CPU's frame, and its traffic:
//!
//! * VaFR, Guenter's layers and full resolution at the Vive Pro Eye, both eyes (the right eye 63 mm to the right
//!   with its own gaze, frame and eye in the random keys), the built-in scene with direct
//!   shading, one ray per texel, the method's own AA (FXAA for VaFR, none at full resolution),
//!   the footprint reconstruction: each eye's tone-mapped 8-bit image (`ResidentFrame::image`)
//!   against `fovea_render::pipeline::render_planned` of the same plans and the CPU's
//!   `to_srgb8` with the same exposure and curve: luma PSNR ≥ 40 dB (Rec. 601 luma of the
//!   codes, as `fovea_eval::metrics::luma_psnr`), for the first frame and for a frame after a
//!   saccade-sized gaze step;
//! * VaFR with Eq. 3's rings in the buffer for any gaze (`VafrRings::Eq3AnyGaze`, the layout
//!   whose tables the resident frame builds once) the same, along a path of 8° steps that
//!   changes the exact rings' buffer every frame;
//! * that steady-state frame (the gaze moved 8° for the left eye and 6° for the right, to the
//!   mirror of their first gazes through the screen's centre, which keeps the exact rings'
//!   buffers' sizes; for `eq3-any-gaze`, each step of its path): exactly one submission, no blocking wait, at most 256 KiB uploaded,
//!   nothing read back, no buffer and no bind group created; the host's milliseconds per
//!   binocular frame (checking, tables, uniforms, recording; no submission) printed, never
//!   asserted;
//! * the denoiser in the resident frame (issue 38): VaFR, full resolution and visual-polar,
//!   both eyes, direct shading with one occluded environment ray per sample (the realtime
//!   preset's noise), the sample-space denoiser on (3×3, 4 iterations): each eye's image
//!   against `render_planned` with the same settings (the CPU's `fovea_post::denoise`),
//!   ≥ 40 dB, and nearer to it than to the CPU's frame without denoising (so the GPU did
//!   denoise); the steady frames' counters as above; the denoiser's GPU ms from the timers;
//! * the inset (Liu et al.'s, following the gaze) with the alpha-blended boundary the same,
//!   on the mirrored gazes and with the inset against the screen's corners (edges that are the
//!   screen's are not blended);
//! * what the resident frame does not serve (path tracing, the inset's Laplacian blend,
//!   peripheral contrast) is refused with `GpuError::Unsupported` naming it, with nothing uploaded,
//!   created or submitted.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;
#[path = "common/resident.rs"]
mod resident;

use common::{gpu_or_skip, shout};
use fovea_core::mapping::{Method, VafrRings};
use fovea_gpu::frame::{ResidentFrame, ToneSettings, TEMPORAL_PASSES};
use fovea_gpu::{GpuContext, GpuError};
use fovea_post::denoise::DenoiseParams;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::shade::{EnvLight, ShadingMode};
use fovea_render::world::World;
use resident::{luma_psnr, plan, setup};

const PSNR_MIN_DB: f64 = 40.0;
const STEADY_UPLOAD_MAX: u64 = 256 * 1024;
const TONE: ToneSettings = ToneSettings {
    exposure_stops: 0.0,
    curve: ToneCurve::Reinhard,
};

/// `method` with direct shading, one ray per texel.
fn settings(method: Method) -> FrameSettings {
    resident::settings(method, ShadingMode::DIRECT)
}

/// The CPU's frame of `plan`, tone-mapped as the resident frame does.
fn cpu_image(world: &World, camera: &EyeCamera, plan: &FramePlan) -> Vec<u8> {
    let mut ctx = FrameContext::new();
    let frame = render_planned(
        &mut ctx,
        world,
        camera,
        plan,
        FrameInputs::default(),
        StageTimes::default(),
        &|_, _| {},
    )
    .unwrap();
    to_srgb8(&frame.color, TONE.exposure_stops, TONE.curve)
}

/// Both eyes' plans of frame `frame` with the gazes `gazes` (screen pixels).
fn plans(
    world: &World,
    cams: &[EyeCamera; 2],
    s: &FrameSettings,
    gazes: [(f64, f64); 2],
    frame: u64,
) -> [FramePlan; 2] {
    let d = &cams[0].display;
    [0usize, 1].map(|e| {
        let g = d.gaze(gazes[e].0, gazes[e].1).unwrap();
        plan(world, &cams[e], s, g, frame, e as u32)
    })
}

/// Each eye's resident image against the CPU's. With the denoiser on, also against the CPU's
/// frame of the same plan without it: the resident image must be nearer the denoised one.
fn check_images(
    frame: &mut ResidentFrame,
    world: &World,
    cams: &[EyeCamera; 2],
    plans: &[FramePlan; 2],
    what: &str,
) {
    for e in 0..2 {
        let gpu = frame.image(e).unwrap();
        let cpu = cpu_image(world, &cams[e], &plans[e]);
        let psnr = luma_psnr(&cpu, &gpu);
        shout(&format!(
            "[fovea-gpu] resident binocular {what} eye {e}: luma PSNR {psnr:.2} dB against \
             render_planned + to_srgb8"
        ));
        assert!(psnr >= PSNR_MIN_DB, "{what} eye {e}: {psnr:.2} dB");
        if plans[e].settings.denoise.is_some() {
            let mut noisy = plans[e].clone();
            noisy.settings.denoise = None;
            let raw = cpu_image(world, &cams[e], &noisy);
            let (to_raw, moved) = (luma_psnr(&raw, &gpu), luma_psnr(&raw, &cpu));
            shout(&format!(
                "[fovea-gpu] resident binocular {what} eye {e}: against the CPU's frame without \
                 denoising {to_raw:.2} dB (the CPU's denoiser moved it to {moved:.2} dB)"
            ));
            assert!(
                moved.is_finite(),
                "{what} eye {e}: the CPU's denoiser changed nothing"
            );
            assert!(
                psnr > to_raw,
                "{what} eye {e}: {psnr:.2} dB to the denoised CPU frame, {to_raw:.2} dB to \
                 the noisy one"
            );
        }
    }
}

/// The screen's centre is (720, 800): each second gaze is the first mirrored through it.
const MIRRORED: [[(f64, f64); 2]; 2] = [
    [(620.0, 800.0), (660.0, 760.0)],
    [(820.0, 800.0), (780.0, 840.0)],
];

/// Saccade-sized steps (~8°, 80–90 px at the Vive Pro Eye) that change the exact rings'
/// buffer every frame (no gaze is another's mirror), down to near a corner and back.
const WANDERING: [[(f64, f64); 2]; 5] = [
    [(620.0, 800.0), (660.0, 760.0)],
    [(540.0, 740.0), (580.0, 700.0)],
    [(455.0, 690.0), (495.0, 650.0)],
    [(390.0, 610.0), (430.0, 575.0)],
    [(470.0, 660.0), (505.0, 625.0)],
];

fn the_binocular_frame_is_the_cpus(ctx: &GpuContext, method: Method) {
    the_frame_with_settings_is_the_cpus(ctx, method, settings(method), 4);
}

/// `method` with direct shading of one occluded environment ray per sample and the
/// sample-space denoiser on (its defaults).
fn denoised_settings(method: Method) -> FrameSettings {
    let mut s = resident::settings(
        method,
        ShadingMode::Direct {
            env_light: EnvLight::Occluded { samples: 1 },
        },
    );
    s.denoise = Some(DenoiseParams::default());
    s
}

/// The first frame and `steady` frames after it (the gaze stepping back and forth between
/// mirrored gazes) of `s` against the CPU.
fn the_frame_with_settings_is_the_cpus(
    ctx: &GpuContext,
    method: Method,
    s: FrameSettings,
    steady: usize,
) {
    let path: Vec<_> = (0..=steady).map(|f| MIRRORED[f % 2]).collect();
    binocular_frame_on_a_path(ctx, &s, &method.to_string(), &path);
}
/// The resident frame of `s` along `path` (both eyes' gazes per frame) against the CPU's:
/// the first and last frames' images, every later frame's traffic.
fn binocular_frame_on_a_path(
    ctx: &GpuContext,
    s: &FrameSettings,
    method: &str,
    path: &[[(f64, f64); 2]],
) {
    let (world, cams) = setup();
    let s = s.clone();
    let p0 = plans(&world, &cams, &s, path[0], 0);
    let mut frame =
        ResidentFrame::new(ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE).unwrap();
    let before = ctx.traffic();
    let t0 = frame
        .render(&world, [&p0[0], &p0[1]], [&cams[0], &cams[1]])
        .unwrap();
    let first_traffic = ctx.traffic().since(&before);
    shout(&format!(
        "[fovea-gpu] resident binocular {method} frame 0: host {:.2} ms (tables {:.2}), submit \
         {:.2} ms, {first_traffic:?}",
        t0.host_ms, t0.tables_ms, t0.submit_ms
    ));
    assert_eq!(first_traffic.submissions, 1);
    assert_eq!(first_traffic.bytes_read_back, 0);
    check_images(&mut frame, &world, &cams, &p0, &format!("{method} frame 0"));

    // Steady state: the gaze moves by a saccade-sized step every frame, back and forth.
    let mut host = Vec::new();
    let mut last = p0;
    for (f, &gazes) in path.iter().enumerate().skip(1) {
        let f = f as u64;
        let p = plans(&world, &cams, &s, gazes, f);
        let before = ctx.traffic();
        let t = frame
            .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
            .unwrap();
        let traffic = ctx.traffic().since(&before);
        shout(&format!(
            "[fovea-gpu] resident binocular {method} frame {f}: host {:.2} ms (tables {:.2}), \
             submit {:.2} ms, {traffic:?}",
            t.host_ms, t.tables_ms, t.submit_ms
        ));
        assert_eq!(traffic.submissions, 1, "one submission per binocular frame");
        assert_eq!(traffic.blocking_waits, 0, "{traffic:?}");
        assert!(traffic.bytes_uploaded <= STEADY_UPLOAD_MAX, "{traffic:?}");
        assert_eq!(traffic.bytes_read_back, 0, "{traffic:?}");
        assert_eq!(traffic.buffers_created, 0, "{traffic:?}");
        assert_eq!(traffic.bind_groups_created, 0, "{traffic:?}");
        host.push(t.host_ms);
        last = p;
        // Let the device finish (outside the counted frame) so that the timers' slots free.
        ctx.wait_idle("the test").unwrap();
    }
    let mean = host.iter().sum::<f64>() / host.len() as f64;
    shout(&format!(
        "[fovea-gpu] resident binocular {method}: host {mean:.2} ms per steady binocular frame \
         (mean of {}; recording, excluding the submit)",
        host.len()
    ));
    let times = frame.poll_gpu_times().unwrap();
    for t in &times {
        let passes: Vec<String> = t
            .passes
            .iter()
            .filter_map(|(n, ms)| ms.map(|ms| format!("{n} {ms:.2}")))
            .collect();
        shout(&format!(
            "[fovea-gpu] resident binocular {method} frame {} GPU ms: total {:.2}; {}",
            t.frame,
            t.total_ms(),
            passes.join(", ")
        ));
    }
    if frame.timed() {
        assert!(
            !times.is_empty(),
            "timestamps arrive once the device is idle"
        );
        // Without temporal accumulation its passes do not run and have no time.
        for t in &times {
            for name in TEMPORAL_PASSES {
                let ms = t.passes.iter().find(|p| p.0 == name).map(|p| p.1);
                assert_eq!(ms, Some(None), "frame {}: {name}", t.frame);
            }
        }
    }
    check_images(
        &mut frame,
        &world,
        &cams,
        &last,
        &format!("{method} frame {}", path.len() - 1),
    );
    if s.denoise.is_some() && frame.timed() {
        let denoise_ms: Vec<f64> = times
            .iter()
            .flat_map(|t| t.passes.iter())
            .filter(|(n, _)| n.ends_with("denoise"))
            .filter_map(|(_, ms)| *ms)
            .collect();
        assert!(
            !denoise_ms.is_empty(),
            "the denoiser's passes are timed: {times:?}"
        );
    }
}

#[test]
fn vafr_binocular_frame_denoises_as_the_cpu() {
    let Some(ctx) = gpu_or_skip("vafr_binocular_frame_denoises_as_the_cpu") else {
        return;
    };
    the_frame_with_settings_is_the_cpus(&ctx, Method::Vafr, denoised_settings(Method::Vafr), 2);
}

#[test]
fn full_resolution_binocular_frame_denoises_as_the_cpu() {
    let Some(ctx) = gpu_or_skip("full_resolution_binocular_frame_denoises_as_the_cpu") else {
        return;
    };
    the_frame_with_settings_is_the_cpus(&ctx, Method::Full, denoised_settings(Method::Full), 2);
}

#[test]
fn visual_polar_binocular_frame_denoises_as_the_cpu() {
    let Some(ctx) = gpu_or_skip("visual_polar_binocular_frame_denoises_as_the_cpu") else {
        return;
    };
    let m = Method::VisualPolar;
    the_frame_with_settings_is_the_cpus(&ctx, m, denoised_settings(m), 2);
}

#[test]
fn guenter_binocular_frame_denoises_as_the_cpu() {
    // The real-time preset's denoiser over Guenter's three layers (each its own grid).
    let Some(ctx) = gpu_or_skip("guenter_binocular_frame_denoises_as_the_cpu") else {
        return;
    };
    let m = Method::Guenter;
    the_frame_with_settings_is_the_cpus(&ctx, m, denoised_settings(m), 2);
}

#[test]
fn vafr_binocular_frame_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_binocular_frame_is_the_cpus") else {
        return;
    };
    the_binocular_frame_is_the_cpus(&ctx, Method::Vafr);
}

#[test]
fn vafr_any_gaze_frame_is_the_cpus_while_the_gaze_wanders() {
    // Eq. 3's rings in the buffer for any gaze (`VafrRings::Eq3AnyGaze`): the tables are
    // built with the first frame and only the pole, the rings' uniforms and the shaded runs
    // go up after, wherever the gaze goes; the CPU renders the same plans.
    let Some(ctx) = gpu_or_skip("vafr_any_gaze_frame_is_the_cpus_while_the_gaze_wanders") else {
        return;
    };
    let mut s = settings(Method::Vafr);
    s.mapping.vafr.rings = VafrRings::Eq3AnyGaze;
    binocular_frame_on_a_path(&ctx, &s, "vafr eq3-any-gaze", &WANDERING);
}

#[test]
fn guenter_binocular_frame_is_the_cpus() {
    // Guenter et al. 2012's three layers: each layer shaded by the resident kernels (one
    // dispatch per layer), reconstructed and composited on the device.
    let Some(ctx) = gpu_or_skip("guenter_binocular_frame_is_the_cpus") else {
        return;
    };
    the_binocular_frame_is_the_cpus(&ctx, Method::Guenter);
}

#[test]
fn inset_binocular_frame_is_the_cpus() {
    // The inset over the ¼-resolution periphery, its boundary alpha-blended (the default),
    // composited on the device.
    let Some(ctx) = gpu_or_skip("inset_binocular_frame_is_the_cpus") else {
        return;
    };
    the_binocular_frame_is_the_cpus(&ctx, Method::Inset);
    // The boundary was blended: the image is nearer the CPU's blended frame than its hard one.
    let (world, cams) = setup();
    let p = plans(&world, &cams, &settings(Method::Inset), MIRRORED[0], 0);
    let mut frame =
        ResidentFrame::new(&ctx, &world, [&p[0], &p[1]], [&cams[0], &cams[1]], TONE).unwrap();
    frame
        .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
        .unwrap();
    for e in 0..2 {
        let gpu = frame.image(e).unwrap();
        let blended = luma_psnr(&cpu_image(&world, &cams[e], &p[e]), &gpu);
        let mut hard = p[e].clone();
        hard.settings.inset_smoothing = fovea_post::inset_smoothing::Smoothing::None;
        let to_hard = luma_psnr(&cpu_image(&world, &cams[e], &hard), &gpu);
        shout(&format!(
            "[fovea-gpu] resident binocular inset eye {e}: {blended:.2} dB to the CPU's \
             alpha-blended frame, {to_hard:.2} dB to its hard boundary"
        ));
        assert!(
            blended > to_hard,
            "eye {e}: {blended:.2} <= {to_hard:.2} dB"
        );
    }
}

#[test]
fn inset_against_the_screens_corners_is_the_cpus() {
    // Gazes near the corners push the inset against the screen's edges, which are not blended.
    let Some(ctx) = gpu_or_skip("inset_against_the_screens_corners_is_the_cpus") else {
        return;
    };
    let corners = [
        [(100.0, 100.0), (1400.0, 1550.0)],
        [(1400.0, 120.0), (60.0, 1500.0)],
    ];
    binocular_frame_on_a_path(&ctx, &settings(Method::Inset), "inset at corners", &corners);
}

#[test]
fn full_resolution_binocular_frame_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("full_resolution_binocular_frame_is_the_cpus") else {
        return;
    };
    the_binocular_frame_is_the_cpus(&ctx, Method::Full);
}

#[test]
fn what_the_frame_does_not_serve_is_refused_before_anything_is_sent() {
    let Some(ctx) = gpu_or_skip("what_the_frame_does_not_serve_is_refused_before_anything_is_sent")
    else {
        return;
    };
    let (world, cams) = setup();
    let gazes = [(620.0, 800.0), (660.0, 760.0)];
    let good = plans(&world, &cams, &settings(Method::Vafr), gazes, 0);
    let mut frame = ResidentFrame::new(
        &ctx,
        &world,
        [&good[0], &good[1]],
        [&cams[0], &cams[1]],
        TONE,
    )
    .unwrap();
    let with = |f: &dyn Fn(&mut FrameSettings)| {
        let mut s = settings(Method::Vafr);
        f(&mut s);
        s
    };
    let cases = [
        (
            with(&|s: &mut FrameSettings| {
                s.shading = ShadingMode::Path {
                    bounces: 2,
                    spp: 1,
                    seed: 0,
                }
            }),
            "path tracing",
        ),
        (
            {
                let mut s = settings(Method::Inset);
                s.inset_smoothing = fovea_post::inset_smoothing::Smoothing::LAPLACIAN;
                s
            },
            "boundary smoothing",
        ),
        (
            with(&|s: &mut FrameSettings| {
                s.contrast = Some(Default::default());
            }),
            "contrast",
        ),
    ];
    for (s, what) in cases {
        // The left eye is served, the right is not: nothing of either may go out.
        let bad = plans(&world, &cams, &s, gazes, 1);
        let before = ctx.traffic();
        let err = frame
            .render(&world, [&good[0], &bad[1]], [&cams[0], &cams[1]])
            .unwrap_err();
        let moved = ctx.traffic().since(&before);
        assert!(
            matches!(&err, GpuError::Unsupported(m) if m.contains(what)),
            "{what}: {err}"
        );
        assert_eq!(
            moved.bytes_uploaded + moved.buffers_created + moved.submissions,
            0,
            "{what}: {moved:?}"
        );
        let err = ResidentFrame::new(&ctx, &world, [&bad[1], &bad[1]], [&cams[1], &cams[1]], TONE)
            .err()
            .unwrap();
        assert!(
            matches!(&err, GpuError::Unsupported(m) if m.contains(what)),
            "{what}: {err}"
        );
    }
}
