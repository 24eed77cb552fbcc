//! Indirect light in the resident frame (`fovea_gpu::frame::bounce`, issues 37 and 38) against
//! the CPU's frame: VaFR and full resolution at the Vive Pro Eye, both eyes (the right eye
//! 63 mm to the right with its own gaze, and the eye in the random keys), the built-in scene
//! with direct light plus 1 and plus the default 3 bounces of indirect light
//! (`ShadingMode::Indirect`, four occluded environment rays at the primary hit, one at each
//! bounce), one ray per texel, the method's own AA, the footprint reconstruction:
//!
//! * each eye's tone-mapped 8-bit image (`ResidentFrame::image`) of a frame whose index is not
//!   0 (so the frame's rotation of the first bounce's numbers is not zero) against
//!   `fovea_render::pipeline::render_planned` of the same plans and the CPU's `to_srgb8`:
//!   luma PSNR ≥ 40 dB, one frame each, no averaging over frames (the paths are the CPU's,
//!   sample for sample: the same random numbers, the same BVH, f32 on both sides);
//! * the bounces add light: the image with bounces is brighter than the resident frame's
//!   image of the same plan with direct shading (mean luma), so the kernels ran;
//! * that frame is a steady one (the second; the gaze moved to the mirror of the first through
//!   the screen's centre): one submission, no blocking wait, nothing read back, no buffer and
//!   no bind group created.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;
#[path = "common/resident.rs"]
mod resident;

use common::{gpu_or_skip, shout};
use fovea_core::mapping::Method;
use fovea_gpu::frame::{ResidentFrame, ToneSettings};
use fovea_gpu::GpuContext;
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::shade::{EnvLight, ShadingMode};
use fovea_render::world::World;
use resident::{luma_psnr, plan, settings, setup};

const PSNR_MIN_DB: f64 = 40.0;
const TONE: ToneSettings = ToneSettings {
    exposure_stops: 0.0,
    curve: ToneCurve::Reinhard,
};

/// The screen's centre is (720, 800): the second gazes are the first mirrored through it.
const GAZES: [[(f64, f64); 2]; 2] = [
    [(620.0, 800.0), (660.0, 760.0)],
    [(820.0, 800.0), (780.0, 840.0)],
];

/// The frame index of the compared (second) frame.
const FRAME: u64 = 5;

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

/// Mean Rec. 601 luma of 8-bit sRGB codes, in codes.
fn mean_luma(img: &[u8]) -> f64 {
    let n = img.len() / 3;
    img.chunks_exact(3)
        .map(|p| 0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64)
        .sum::<f64>()
        / n as f64
}

fn indirect_frame_is_the_cpus(ctx: &GpuContext, method: Method, bounces: u32) {
    let (world, cams) = setup();
    let shading = ShadingMode::Indirect {
        env_light: EnvLight::DEFAULT,
        bounces,
    };
    let s = settings(method, shading);
    let direct = settings(method, ShadingMode::DIRECT);
    let plans_of = |s: &FrameSettings, f: usize, frame: u64| {
        let d = &cams[0].display;
        [0usize, 1].map(|e| {
            let (x, y) = GAZES[f][e];
            plan(&world, &cams[e], s, d.gaze(x, y).unwrap(), frame, e as u32)
        })
    };
    let p0 = plans_of(&s, 0, 0);
    let p1 = plans_of(&s, 1, FRAME);
    let what = format!("{method} {bounces} bounce(s)");
    let mut frame =
        ResidentFrame::new(ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE).unwrap();
    frame
        .render(&world, [&p0[0], &p0[1]], [&cams[0], &cams[1]])
        .unwrap();
    ctx.wait_idle("the test").unwrap();
    let before = ctx.traffic();
    frame
        .render(&world, [&p1[0], &p1[1]], [&cams[0], &cams[1]])
        .unwrap();
    let traffic = ctx.traffic().since(&before);
    shout(&format!(
        "[fovea-gpu] resident {what} steady frame: {traffic:?}"
    ));
    assert_eq!(traffic.submissions, 1, "{what}: {traffic:?}");
    assert_eq!(traffic.blocking_waits, 0, "{what}: {traffic:?}");
    assert_eq!(traffic.bytes_read_back, 0, "{what}: {traffic:?}");
    assert_eq!(traffic.buffers_created, 0, "{what}: {traffic:?}");
    assert_eq!(traffic.bind_groups_created, 0, "{what}: {traffic:?}");
    let gpu: Vec<Vec<u8>> = (0..2).map(|e| frame.image(e).unwrap()).collect();
    // The same frame with direct shading, resident too: what the bounces added.
    let d1 = plans_of(&direct, 1, FRAME);
    frame
        .render(&world, [&d1[0], &d1[1]], [&cams[0], &cams[1]])
        .unwrap();
    for e in 0..2 {
        let cpu = cpu_image(&world, &cams[e], &p1[e]);
        let psnr = luma_psnr(&cpu, &gpu[e]);
        let lit = frame.image(e).unwrap();
        let (with, without) = (mean_luma(&gpu[e]), mean_luma(&lit));
        shout(&format!(
            "[fovea-gpu] resident {what} eye {e} frame {FRAME}: luma PSNR {psnr:.2} dB against \
             render_planned + to_srgb8; mean luma {with:.2} (CPU {:.2}), direct only {without:.2}",
            mean_luma(&cpu)
        ));
        assert!(psnr >= PSNR_MIN_DB, "{what} eye {e}: {psnr:.2} dB");
        assert!(
            with > without,
            "{what} eye {e}: mean luma {with:.2} with bounces, {without:.2} without"
        );
    }
}

#[test]
fn vafr_frame_with_one_bounce_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_frame_with_one_bounce_is_the_cpus") else {
        return;
    };
    indirect_frame_is_the_cpus(&ctx, Method::Vafr, 1);
}

#[test]
fn vafr_frame_with_the_default_bounces_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_frame_with_the_default_bounces_is_the_cpus") else {
        return;
    };
    indirect_frame_is_the_cpus(&ctx, Method::Vafr, fovea_render::shade::DEFAULT_BOUNCES);
}

#[test]
fn full_resolution_frame_with_one_bounce_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("full_resolution_frame_with_one_bounce_is_the_cpus") else {
        return;
    };
    indirect_frame_is_the_cpus(&ctx, Method::Full, 1);
}

#[test]
fn full_resolution_frame_with_the_default_bounces_is_the_cpus() {
    let Some(ctx) = gpu_or_skip("full_resolution_frame_with_the_default_bounces_is_the_cpus")
    else {
        return;
    };
    indirect_frame_is_the_cpus(&ctx, Method::Full, fovea_render::shade::DEFAULT_BOUNCES);
}
