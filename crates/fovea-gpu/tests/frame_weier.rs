//! Weier et al.'s sparse sampling in the whole binocular resident frame
//! (`fovea_gpu::frame::ResidentFrame`, issue 37): the shade kernels cast rays where the
//! pattern's device tables say (`frame::weier_pattern`), the screen side fills the rest by
//! pull-push (`frame::ResidentPullPush`), then the tone map — one encoder, one submission.
//!
//! * Weier at the Vive Pro Eye, both eyes (the right eye 63 mm to the right, its own gaze and
//!   keys), the built-in scene, direct shading: each eye's tone-mapped image
//!   (`ResidentFrame::image`) against `render_planned` of the same plans and the CPU's
//!   `to_srgb8`, luma PSNR ≥ 40 dB, on the first frame and after saccade-sized gaze steps and
//!   a jump to the screen's corners (where `S_in` is clipped by the screen's edges); each
//!   eye's linear screen (`ScreenContext::read_linear`, before the DOF) against the CPU's
//!   frame pixel by pixel: the shaded pixels' depth bit for bit, every pixel's depth (the
//!   nearest-shaded fill) bit for bit, colour within a tolerance;
//! * the same with one occluded environment ray per sample and the sample-space denoiser on,
//!   and with the gather DOF;
//! * every frame after the first: one submission, no blocking wait, ≤ 256 KiB up (the pattern's
//!   per-frame words, 16 bytes an eye and side, beside the uniforms), nothing read back, no
//!   buffer or bind group created;
//! * temporal accumulation of a Weier frame is refused (the CPU's is `weier_taa`, a
//!   screen-space pyramid history the resident frame does not have) with nothing sent.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;
#[path = "common/resident.rs"]
mod resident;

use common::{gpu_or_skip, shout};
use fovea_core::mapping::Method;
use fovea_gpu::frame::{ResidentFrame, ToneSettings};
use fovea_gpu::{GpuContext, GpuError};
use fovea_post::denoise::DenoiseParams;
use fovea_post::dof::FilterKind;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_render::camera::EyeCamera;
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::shade::{EnvLight, FrameNoise, ShadingMode};
use fovea_render::temporal::TemporalSettings;
use fovea_render::world::World;
use resident::{luma_psnr, plan, setup};

const PSNR_MIN_DB: f64 = 40.0;
const STEADY_UPLOAD_MAX: u64 = 256 * 1024;
const TONE: ToneSettings = ToneSettings {
    exposure_stops: 0.0,
    curve: ToneCurve::Reinhard,
};

/// Both eyes' gazes per frame: mirrored saccade-sized steps through the screen's centre
/// (720, 800), then both eyes near opposite corners.
const PATH: [[(f64, f64); 2]; 4] = [
    [(620.0, 800.0), (660.0, 760.0)],
    [(820.0, 800.0), (780.0, 840.0)],
    [(620.0, 800.0), (660.0, 760.0)],
    [(40.0, 70.0), (1410.0, 1560.0)],
];

/// The CPU's frame of `plan`: its linear colour and depth before the DOF is not kept, so the
/// frame (after the DOF) and its 8-bit image.
fn cpu_frame(
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
) -> (Vec<[f32; 3]>, Vec<f32>, Vec<u8>) {
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
    let image = to_srgb8(&frame.color, TONE.exposure_stops, TONE.curve);
    (
        frame.color.data().to_vec(),
        frame.depth.data().to_vec(),
        image,
    )
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
        if s.dof.is_none() {
            return plan(world, &cams[e], s, g, frame, e as u32);
        }
        // The DOF needs the eye's focus: the depth at the gaze.
        let eye = EyeState::fixating(world, &cams[e], g, s.dof.as_ref()).unwrap();
        FramePlan::new(world, &cams[e], s, &eye, [0.0, 0.0])
            .unwrap()
            .with_noise(FrameNoise::new(frame, e as u32))
    })
}

/// Each eye's resident image and linear screen against the CPU's frame.
fn check_eyes(
    frame: &mut ResidentFrame,
    world: &World,
    cams: &[EyeCamera; 2],
    plans: &[FramePlan; 2],
    what: &str,
) {
    for e in 0..2 {
        let gpu = frame.image(e).unwrap();
        let (color, depth, cpu) = cpu_frame(world, &cams[e], &plans[e]);
        let psnr = luma_psnr(&cpu, &gpu);
        shout(&format!(
            "[fovea-gpu] resident weier {what} eye {e}: luma PSNR {psnr:.2} dB against \
             render_planned + to_srgb8"
        ));
        assert!(psnr >= PSNR_MIN_DB, "{what} eye {e}: {psnr:.2} dB");
        if plans[e].settings.denoise.is_some() {
            // The GPU did denoise: its image is nearer the CPU's denoised frame than the
            // CPU's frame without the denoiser.
            let mut noisy = plans[e].clone();
            noisy.settings.denoise = None;
            let (_, _, raw) = cpu_frame(world, &cams[e], &noisy);
            let to_raw = luma_psnr(&raw, &gpu);
            shout(&format!(
                "[fovea-gpu] resident weier {what} eye {e}: {to_raw:.2} dB against the CPU's \
                 frame without denoising"
            ));
            assert!(psnr > to_raw, "{what} eye {e}: {psnr:.2} / {to_raw:.2} dB");
        }
        if plans[e].settings.dof.is_some() {
            // The CPU's frame keeps the colour after its DOF only.
            continue;
        }
        let (lin, lin_depth) = frame.screen(e).unwrap().read_linear().unwrap();
        let mapping = plans[e].mapping();
        let w = plans[e].display.width_px;
        let n = lin.data().len() as u64;
        let (mut shaded, mut depth_differ, mut colour_differ) = (0u64, 0u64, 0u64);
        let mut shaded_differ = 0u64;
        for (k, (g, c)) in lin.data().iter().zip(&color).enumerate() {
            let (i, j) = (k as u32 % w, k as u32 / w);
            shaded += u64::from(mapping.is_shaded(0, i, j));
            let (a, b) = (lin_depth.data()[k], depth[k]);
            let same = a == b || (a - b).abs() <= 1e-4 * b.abs();
            depth_differ += u64::from(!same);
            let off = (0..3).any(|ch| (g[ch] - c[ch]).abs() > 1e-2 * c[ch].abs().max(1.0));
            colour_differ += u64::from(off);
            shaded_differ += u64::from(off && mapping.is_shaded(0, i, j));
        }
        shout(&format!(
            "[fovea-gpu] resident weier {what} eye {e}: {shaded} of {n} pixels shaded; depth \
             differs (beyond 1e-4 relative) at {depth_differ}, colour (beyond 1 %) at \
             {colour_differ} ({shaded_differ} of them shaded)"
        ));
        // A pixel the kernels shaded where the CPU did not (or the other way round) moves the
        // nearest-shaded depth of the pixels around it and the pull-push's colours over
        // several pixels; a ray that grazes another triangle in f32 moves one pixel.
        assert!(
            depth_differ * 1000 <= n,
            "{what} eye {e}: depth differs at {depth_differ} pixels"
        );
        assert!(
            colour_differ * 1000 <= n,
            "{what} eye {e}: colour differs at {colour_differ} pixels"
        );
    }
}

/// The resident frame of `s` along [`PATH`] against the CPU: every frame's traffic after the
/// first, the first and last frames' images.
fn weier_frame_along_the_path(ctx: &GpuContext, s: &FrameSettings, what: &str) {
    let (world, cams) = setup();
    let p0 = plans(&world, &cams, s, PATH[0], 0);
    let mut frame =
        ResidentFrame::new(ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE).unwrap();
    let before = ctx.traffic();
    let t0 = frame
        .render(&world, [&p0[0], &p0[1]], [&cams[0], &cams[1]])
        .unwrap();
    let first = ctx.traffic().since(&before);
    shout(&format!(
        "[fovea-gpu] resident weier {what} frame 0: host {:.2} ms, {first:?}",
        t0.host_ms
    ));
    assert_eq!(first.submissions, 1);
    assert_eq!(first.bytes_read_back, 0);
    check_eyes(&mut frame, &world, &cams, &p0, &format!("{what} frame 0"));
    let mut last = p0;
    let mut host = Vec::new();
    for (f, &gazes) in PATH.iter().enumerate().skip(1) {
        let p = plans(&world, &cams, s, gazes, f as u64);
        let before = ctx.traffic();
        let t = frame
            .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
            .unwrap();
        let traffic = ctx.traffic().since(&before);
        shout(&format!(
            "[fovea-gpu] resident weier {what} frame {f}: host {:.2} ms (tables {:.2}), \
             {traffic:?}",
            t.host_ms, t.tables_ms
        ));
        assert_eq!(traffic.submissions, 1, "one submission per binocular frame");
        assert_eq!(traffic.blocking_waits, 0, "{traffic:?}");
        assert!(traffic.bytes_uploaded <= STEADY_UPLOAD_MAX, "{traffic:?}");
        assert_eq!(traffic.bytes_read_back, 0, "{traffic:?}");
        assert_eq!(traffic.buffers_created, 0, "{traffic:?}");
        assert_eq!(traffic.bind_groups_created, 0, "{traffic:?}");
        host.push(t.host_ms);
        last = p;
        ctx.wait_idle("the test").unwrap();
    }
    shout(&format!(
        "[fovea-gpu] resident weier {what}: host {:.2} ms per steady binocular frame (mean of {})",
        host.iter().sum::<f64>() / host.len() as f64,
        host.len()
    ));
    for t in frame.poll_gpu_times().unwrap() {
        let passes: Vec<String> = t
            .passes
            .iter()
            .filter_map(|(n, ms)| ms.map(|ms| format!("{n} {ms:.2}")))
            .collect();
        shout(&format!(
            "[fovea-gpu] resident weier {what} frame {} GPU ms: total {:.2}; {}",
            t.frame,
            t.total_ms(),
            passes.join(", ")
        ));
    }
    check_eyes(
        &mut frame,
        &world,
        &cams,
        &last,
        &format!("{what} frame {}", PATH.len() - 1),
    );
}

fn weier(shading: ShadingMode) -> FrameSettings {
    resident::settings(Method::Weier, shading)
}

#[test]
fn weier_binocular_frame_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("weier_binocular_frame_is_the_cpus") else {
        return;
    };
    weier_frame_along_the_path(&ctx, &weier(ShadingMode::DIRECT), "direct");
}

#[test]
fn weier_binocular_frame_denoises_as_the_cpu() {
    let Some(ctx) = gpu_or_skip("weier_binocular_frame_denoises_as_the_cpu") else {
        return;
    };
    let mut s = weier(ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples: 1 },
    });
    s.denoise = Some(DenoiseParams::default());
    weier_frame_along_the_path(&ctx, &s, "denoised");
}

#[test]
fn weier_binocular_frame_with_the_gather_dof_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("weier_binocular_frame_with_the_gather_dof_is_the_cpus") else {
        return;
    };
    let mut s = weier(ShadingMode::DIRECT);
    s.dof = Some(DofSettings::new(
        Some(FilterKind::Gather),
        FocusMode::Fixed(1.0),
    ));
    weier_frame_along_the_path(&ctx, &s, "gather dof");
}

#[test]
fn weier_temporal_accumulation_is_refused_before_anything_is_sent() {
    let Some(ctx) = gpu_or_skip("weier_temporal_accumulation_is_refused_before_anything_is_sent")
    else {
        return;
    };
    let (world, cams) = setup();
    let s = weier(ShadingMode::DIRECT);
    let p = plans(&world, &cams, &s, PATH[0], 0);
    let mut frame =
        ResidentFrame::new(&ctx, &world, [&p[0], &p[1]], [&cams[0], &cams[1]], TONE).unwrap();
    frame
        .set_temporal(Some(TemporalSettings::default()))
        .unwrap();
    let before = ctx.traffic();
    let err = frame
        .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
        .unwrap_err();
    let moved = ctx.traffic().since(&before);
    assert!(
        matches!(&err, GpuError::Unsupported(m) if m.contains("temporal")),
        "{err}"
    );
    assert_eq!(
        moved.bytes_uploaded + moved.buffers_created + moved.submissions,
        0,
        "{moved:?}"
    );
    // Off again: the same frame renders.
    frame.set_temporal(None).unwrap();
    frame
        .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
        .unwrap();
}
