//! Temporal accumulation inside the resident frame (`ResidentFrame::set_temporal`,
//! `fovea_gpu::frame::temporal`, issue 37 item 4) against the CPU's sample-space accumulation
//! (`fovea_render::temporal`, through `render_planned` with a `TemporalAccumulator` per eye):
//!
//! * VaFR and full resolution at the Vive Pro Eye, both eyes, the built-in scene with direct
//!   shading (the occluded environment's Monte Carlo estimate: every frame's noise differs),
//!   the default `TemporalSettings`: a sequence of a still view (three frames), then the
//!   camera turning 0.6° and moving 3 cm a frame, with a saccade-sized gaze step (to the
//!   first gaze's mirror through the screen's centre) in the fifth frame — each frame's
//!   tone-mapped image of each eye against the CPU's with the same plans and settings: luma
//!   PSNR ≥ 40 dB; every frame after the first: one submission, no blocking wait, at most
//!   256 KiB up, nothing read back, no buffer and no bind group created;
//! * VaFR with the accumulator's sub-texel jitter (`TemporalSettings::jitter`), four frames
//!   of the same sequence: the same bar;
//! * VaFR with the sample-space denoiser after the accumulation (the pass rewrites the
//!   accumulated colour's Monte Carlo part for it, as the CPU's `complement_part` does, and
//!   keeps SVGF's temporal moments of it, whose variance both denoisers read where a texel's
//!   history is 4 frames old), six frames of the same sequence: luma PSNR ≥ 58 dB
//!   ([`DENOISED_PSNR_MIN_DB`]). Measured on lavapipe: 63.3–67.1 dB over all six frames
//!   (without the device's moments it was 52 → 46 dB in frames 3–5, where the CPU's
//!   denoiser switches to the moments' variance). Each frame the variance the device's
//!   denoiser read (the Monte Carlo part's w lane) is read back against the CPU's
//!   (`FrameContext::denoise_variance`): none before frame 3; from it ≥ 98 % of the texels
//!   with one on either side have one on both, and there the relative difference has a
//!   median ≤ 0.005 and a 99th percentile ≤ 0.4 (measured: 99.6–100 %, ≤ 4.5e-4 and
//!   ≤ 0.17, the largest in frame 3, the first moving one);
//! * a still view with one environment ray per sample: each frame's image against a
//!   many-ray reference (the CPU's frame with 32 rays per sample): the mean squared error
//!   falls as frames accumulate (the last frame's below 60 % of the first's; the figures
//!   printed);
//! * the accumulation pass's GPU time (`TEMPORAL_PASSES`) arrives from the frame's timers for
//!   both eyes of every timed frame of those sequences;
//! * settings the CPU refuses are refused (`GpuError::Input`), with nothing sent;
//! * the pass's column and spacing tables go up only when they change: with VaFR's rings for
//!   any gaze, a frame at another gaze sends the pass's uniform blocks and nothing else (the
//!   frame's upload counter with the pass on less with it off).
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;
#[path = "common/resident.rs"]
mod resident;

use common::{gpu_or_skip, shout};
use fovea_core::mapping::Method;
use fovea_gpu::frame::{ResidentFrame, ToneSettings, TEMPORAL_PASSES};
use fovea_gpu::{GpuContext, GpuError};
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_render::camera::EyeCamera;
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{
    render_planned, FrameContext, FrameInputs, FrameSettings, StageTimes,
};
use fovea_render::plan::FramePlan;
use fovea_render::shade::{EnvLight, FrameNoise, ShadingMode};
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings, VARIANCE_MIN_AGE};
use fovea_render::world::World;
use resident::{luma_mse, luma_psnr, plan, setup};

const PSNR_MIN_DB: f64 = 40.0;
/// The bar of the denoised sequence: its lowest frame on lavapipe (63.3 dB, both eyes, all
/// six frames) less 5 dB for another device's rounding. Without the temporal moments on the
/// device (the denoiser's spatial estimate where the CPU's reads the moments' variance) the
/// frames from the fourth on fall to 46–52 dB, below it.
const DENOISED_PSNR_MIN_DB: f64 = 58.0;
/// Of the texels with a temporal variance on either side, the share with one on both.
const VARIANCE_SAME_TEXELS: f64 = 0.98;
/// Where both sides have a temporal variance: the median and 99th percentile of their
/// relative difference.
const VARIANCE_REL_MEDIAN: f64 = 0.005;
const VARIANCE_REL_P99: f64 = 0.4;
const STEADY_UPLOAD_MAX: u64 = 256 * 1024;
const TONE: ToneSettings = ToneSettings {
    exposure_stops: 0.0,
    curve: ToneCurve::Reinhard,
};

/// Both eyes' cameras of frame `f`: still for the first three frames, then turning 0.6° and
/// moving 3 cm to the right (and 1 cm forward) per frame.
fn cameras(base: &[EyeCamera; 2], f: u64) -> [EyeCamera; 2] {
    let k = f.saturating_sub(2) as f32;
    base.clone().map(|c| {
        let yaw = (0.6f32 * k).to_radians();
        let forward = c.forward * yaw.cos() + c.right * yaw.sin();
        let position = c.position + c.right * (0.03 * k) + c.forward * (0.01 * k);
        EyeCamera::new(position, forward, c.up, &c.display).unwrap()
    })
}

/// Both eyes' gazes of frame `f` (screen pixels; the screen's centre is (720, 800)): the
/// first gazes, then from frame 4 on each mirrored through the centre (a saccade-sized step:
/// 8° for the left eye, 6° for the right, which keeps the foveated buffers' sizes and so the
/// AA and reconstruction tables: a step that changes them sends those again, the
/// gaze-dependent layout of issue 37's item 3).
fn gazes(f: u64) -> [(f64, f64); 2] {
    if f < 4 {
        [(620.0, 800.0), (660.0, 760.0)]
    } else {
        [(820.0, 800.0), (780.0, 840.0)]
    }
}

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

/// The CPU's frame of `plan` (accumulated by `acc` when given), tone-mapped.
fn cpu_image(
    ctx: &mut FrameContext,
    world: &World,
    camera: &EyeCamera,
    plan: &FramePlan,
    acc: Option<&mut TemporalAccumulator>,
) -> Vec<u8> {
    let frame = render_planned(
        ctx,
        world,
        camera,
        plan,
        FrameInputs {
            accumulator: acc,
            prefill: None,
        },
        StageTimes::default(),
        &|_, _| {},
    )
    .unwrap();
    to_srgb8(&frame.color, TONE.exposure_stops, TONE.curve)
}

/// What the frames of [`accumulated_frames_are_the_cpus`] denoise after the accumulation.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Denoise {
    Off,
    /// The sample-space denoiser with the default `TemporalSettings` (`variance` on: both
    /// sides keep the temporal moments and their denoisers read the moments' variance where
    /// a texel's history is 4 frames old).
    Temporal,
}

impl Denoise {
    /// The luma PSNR each frame must reach against the CPU's.
    fn psnr_min_db(self) -> f64 {
        match self {
            Denoise::Off => PSNR_MIN_DB,
            Denoise::Temporal => DENOISED_PSNR_MIN_DB,
        }
    }
}

fn accumulated_frames_are_the_cpus(
    ctx: &GpuContext,
    method: Method,
    jitter: bool,
    frames: u64,
    denoise: Denoise,
) {
    let (world, base) = setup();
    let mut s = resident::settings(method, ShadingMode::DIRECT);
    if denoise != Denoise::Off {
        s.denoise = Some(fovea_post::denoise::DenoiseParams::default());
    }
    let settings = TemporalSettings {
        jitter,
        ..Default::default()
    };
    let cams = cameras(&base, 0);
    let p0 = plans(&world, &cams, &s, gazes(0), 0);
    let mut frame =
        ResidentFrame::new(ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE).unwrap();
    frame.set_temporal(Some(settings)).unwrap();
    let mut accs = [0, 1].map(|_| TemporalAccumulator::new(settings).unwrap());
    let mut cpu_ctx = [FrameContext::new(), FrameContext::new()];
    for f in 0..frames {
        let cams = cameras(&base, f);
        let mut p = plans(&world, &cams, &s, gazes(f), f);
        if jitter {
            // The accumulator's sub-texel jitter (Halton 2, 3), the same for both eyes.
            let j = accs[0].jitter(method);
            assert!(f == 0 || j != [0.0, 0.0]);
            p = [0usize, 1].map(|e| {
                let g = cams[e].display.gaze(gazes(f)[e].0, gazes(f)[e].1).unwrap();
                FramePlan::new(&world, &cams[e], &s, &EyeState::looking_at(g), j)
                    .unwrap()
                    .with_noise(FrameNoise::new(f, e as u32))
            });
        }
        let before = ctx.traffic();
        let t = frame
            .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
            .unwrap();
        let traffic = ctx.traffic().since(&before);
        shout(&format!(
            "[fovea-gpu] resident temporal {method} (jitter {jitter}) frame {f}: host {:.2} ms, {traffic:?}",
            t.host_ms
        ));
        assert_eq!(traffic.submissions, 1, "one submission per binocular frame");
        assert_eq!(traffic.bytes_read_back, 0, "{traffic:?}");
        if f > 0 {
            assert_eq!(traffic.blocking_waits, 0, "{traffic:?}");
            assert!(traffic.bytes_uploaded <= STEADY_UPLOAD_MAX, "{traffic:?}");
            assert_eq!(traffic.buffers_created, 0, "{traffic:?}");
            assert_eq!(traffic.bind_groups_created, 0, "{traffic:?}");
        }
        for e in 0..2 {
            let gpu = frame.image(e).unwrap();
            let cpu = cpu_image(&mut cpu_ctx[e], &world, &cams[e], &p[e], Some(&mut accs[e]));
            let psnr = luma_psnr(&cpu, &gpu);
            let stats = accs[e].last_stats();
            shout(&format!(
                "[fovea-gpu] resident temporal {method} (jitter {jitter}, denoise {denoise:?}) frame {f} eye {e}: luma PSNR {psnr:.2} \
                 dB against render_planned with the CPU's accumulator (CPU: {} reused, {} \
                 fresh)",
                stats.reused, stats.fresh
            ));
            assert!(
                psnr >= denoise.psnr_min_db(),
                "{method} frame {f} eye {e}: {psnr:.2} dB (bar {} dB)",
                denoise.psnr_min_db()
            );
            if f > 0 && f != 4 {
                assert!(stats.reused > stats.fresh, "the history is used: {stats:?}");
            }
            if denoise == Denoise::Temporal {
                variance_is_the_cpus(ctx, &frame, e, f, &cpu_ctx[e]);
            }
        }
        ctx.wait_idle("the test").unwrap();
    }
    // The accumulation pass is timed as every other pass (the bench's JSON and the viewer's
    // HUD list it): each frame whose times arrived has both eyes' temporal milliseconds.
    let times = frame.poll_gpu_times().unwrap();
    if frame.timed() {
        assert!(
            !times.is_empty(),
            "timestamps arrive once the device is idle"
        );
        for t in &times {
            let ms: Vec<Option<f64>> = TEMPORAL_PASSES
                .iter()
                .map(|&name| t.passes.iter().find(|p| p.0 == name).and_then(|p| p.1))
                .collect();
            shout(&format!(
                "[fovea-gpu] resident temporal {method} (jitter {jitter}) frame {} GPU ms: \
                 temporal {ms:?}, whole frame {:.2}",
                t.frame,
                t.total_ms()
            ));
            assert!(
                ms.iter()
                    .all(|m| m.is_some_and(|v| v.is_finite() && v >= 0.0)),
                "frame {}: the temporal passes are timed: {:?}",
                t.frame,
                t.passes
            );
        }
    }
}

/// The temporal variance the device's denoiser read in frame `f` (the w lane of eye `e`'s
/// Monte Carlo part, read back with the test's own buffer, uncounted) against the CPU's
/// (`FrameContext::denoise_variance`): the same texels have one (finite, ≥ 0; none before a
/// history is [`VARIANCE_MIN_AGE`] frames old), and where both do they agree.
fn variance_is_the_cpus(
    ctx: &GpuContext,
    frame: &ResidentFrame,
    e: usize,
    f: u64,
    cpu: &FrameContext,
) {
    let samples = frame.samples();
    let layer = samples.samples(e).unwrap().layers()[0];
    let noisy = samples.eye(e).unwrap().guides().unwrap().noisy();
    let texels = u64::from(layer.width) * u64::from(layer.height);
    let bytes = texels * 16;
    let read = ctx.device().create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: bytes,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    encoder.copy_buffer_to_buffer(noisy, u64::from(layer.offset) * 16, &read, 0, bytes);
    ctx.submit([encoder.finish()]);
    read.map_async(wgpu::MapMode::Read, .., |r| r.unwrap());
    ctx.wait_idle("the variance's readback").unwrap();
    let gpu: Vec<f32> = bytemuck::cast_slice::<u8, [f32; 4]>(&read.get_mapped_range(..).unwrap())
        .iter()
        .map(|v| v[3])
        .collect();
    let given = |v: f32| v.is_finite() && v >= 0.0;
    let cpu = cpu.denoise_variance();
    let (mut both, mut gpu_only, mut cpu_only) = (0usize, 0usize, 0usize);
    let mut rel: Vec<f64> = Vec::new();
    for (k, &g) in gpu.iter().enumerate() {
        let c = cpu.first().map_or(f32::NAN, |img| {
            img.data().get(k).copied().unwrap_or(f32::NAN)
        });
        match (given(g), given(c)) {
            (true, true) => {
                both += 1;
                let d = (f64::from(g) - f64::from(c)).abs();
                rel.push(d / (f64::from(g.abs().max(c.abs())) + 1e-6));
            }
            (true, false) => gpu_only += 1,
            (false, true) => cpu_only += 1,
            _ => {}
        }
    }
    rel.sort_by(f64::total_cmp);
    let at = |q: f64| rel.get(((rel.len() as f64 * q) as usize).min(rel.len().saturating_sub(1)));
    shout(&format!(
        "[fovea-gpu] resident temporal variance frame {f} eye {e}: {both} texels with it on \
         both sides, {gpu_only} on the device only, {cpu_only} on the CPU only; relative \
         difference median {:?}, 99th percentile {:?}",
        at(0.5),
        at(0.99)
    ));
    if f + 1 < u64::from(VARIANCE_MIN_AGE) {
        assert_eq!(
            both + gpu_only + cpu_only,
            0,
            "no history is old enough yet"
        );
        return;
    }
    let n = both + gpu_only + cpu_only;
    assert!(
        both as f64 >= VARIANCE_SAME_TEXELS * n as f64,
        "frame {f} eye {e}: {both} of {n} texels have a variance on both sides"
    );
    assert!(
        at(0.5).is_some_and(|&r| r <= VARIANCE_REL_MEDIAN)
            && at(0.99).is_some_and(|&r| r <= VARIANCE_REL_P99),
        "frame {f} eye {e}: relative differences median {:?}, 99th percentile {:?}",
        at(0.5),
        at(0.99)
    );
}

#[test]
fn vafr_accumulated_frames_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_accumulated_frames_are_the_cpus") else {
        return;
    };
    accumulated_frames_are_the_cpus(&ctx, Method::Vafr, false, 6, Denoise::Off);
}

#[test]
fn vafr_jittered_accumulated_frames_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_jittered_accumulated_frames_are_the_cpus") else {
        return;
    };
    accumulated_frames_are_the_cpus(&ctx, Method::Vafr, true, 4, Denoise::Off);
}

#[test]
fn full_resolution_accumulated_frames_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("full_resolution_accumulated_frames_are_the_cpus") else {
        return;
    };
    accumulated_frames_are_the_cpus(&ctx, Method::Full, false, 6, Denoise::Off);
}

#[test]
fn vafr_accumulated_and_denoised_frames_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("vafr_accumulated_and_denoised_frames_are_the_cpus") else {
        return;
    };
    accumulated_frames_are_the_cpus(&ctx, Method::Vafr, false, 6, Denoise::Temporal);
}

#[test]
fn accumulating_a_still_view_approaches_the_many_ray_reference() {
    let Some(ctx) = gpu_or_skip("accumulating_a_still_view_approaches_the_many_ray_reference")
    else {
        return;
    };
    let (world, cams) = setup();
    let one = ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples: 1 },
    };
    let many = ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples: 32 },
    };
    let s = resident::settings(Method::Vafr, one);
    let g = gazes(0);
    let reference: Vec<Vec<u8>> = {
        let r = plans(
            &world,
            &cams,
            &resident::settings(Method::Vafr, many),
            g,
            1000,
        );
        (0..2)
            .map(|e| cpu_image(&mut FrameContext::new(), &world, &cams[e], &r[e], None))
            .collect()
    };
    let p0 = plans(&world, &cams, &s, g, 0);
    let mut frame =
        ResidentFrame::new(&ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE).unwrap();
    frame
        .set_temporal(Some(TemporalSettings::default()))
        .unwrap();
    let frames = 8u64;
    let mut mse = vec![[0.0f64; 2]; frames as usize];
    for f in 0..frames {
        let p = plans(&world, &cams, &s, g, f);
        frame
            .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
            .unwrap();
        for e in 0..2 {
            mse[f as usize][e] = luma_mse(&frame.image(e).unwrap(), &reference[e]);
        }
        shout(&format!(
            "[fovea-gpu] resident temporal VaFR still view, 1 environment ray: frame {f} luma \
             MSE against 32 rays: left {:.3e}, right {:.3e}",
            mse[f as usize][0], mse[f as usize][1]
        ));
    }
    for e in 0..2 {
        let (first, last) = (mse[0][e], mse[frames as usize - 1][e]);
        assert!(
            last < 0.6 * first,
            "eye {e}: MSE {first:.3e} at frame 0, {last:.3e} at frame {}",
            frames - 1
        );
        assert!(
            mse[1][e] < first && mse[3][e] < mse[1][e],
            "eye {e}: the error falls frame by frame: {mse:?}"
        );
    }
}

#[test]
fn settings_the_cpu_refuses_are_refused_before_anything_is_sent() {
    let Some(ctx) = gpu_or_skip("settings_the_cpu_refuses_are_refused_before_anything_is_sent")
    else {
        return;
    };
    let (world, cams) = setup();
    let s = resident::settings(Method::Vafr, ShadingMode::DIRECT);
    let p = plans(&world, &cams, &s, gazes(0), 0);
    let mut frame =
        ResidentFrame::new(&ctx, &world, [&p[0], &p[1]], [&cams[0], &cams[1]], TONE).unwrap();
    for bad in [
        TemporalSettings {
            alpha_min: 0.0,
            ..Default::default()
        },
        TemporalSettings {
            depth_tolerance: f32::NAN,
            ..Default::default()
        },
    ] {
        let before = ctx.traffic();
        let err = frame.set_temporal(Some(bad)).unwrap_err();
        let moved = ctx.traffic().since(&before);
        assert!(matches!(err, GpuError::Input(_)), "{err}");
        assert_eq!(
            moved.bytes_uploaded + moved.buffers_created + moved.submissions,
            0,
            "{moved:?}"
        );
        assert!(frame.temporal().is_none());
    }
}

/// The temporal pass's share of each frame's upload: the bytes a frame sends with temporal
/// accumulation on less those of the same frame with it off (everything else the frame sends
/// is the same), VaFR with the rings for any gaze (`VafrRings::Eq3AnyGaze`, the real-time
/// preset's) on a small display (256 × 288, 100° × 110°), both eyes, one resident frame:
/// three frames with the pass off, then the same three with it on — at gazes B, A, B, where
/// B is A mirrored through the screen's centre (a saccade-sized step). Each run's frame 0
/// follows the same gaze B, so the rest of the frame sends the same. The pass's uniform
/// blocks go up every frame (272 B an eye); its column and spacing tables with the pass's
/// first frame only: frames 1 and 2, each at another gaze, send the uniform blocks and
/// nothing else.
#[test]
fn the_temporal_tables_go_up_once_for_a_layout_of_any_gaze() {
    use fovea_core::display::DisplayProfile;
    use fovea_core::mapping::VafrRings;
    use fovea_core::units::Degrees;
    use fovea_gpu::frame::temporal::TemporalUniform;
    let Some(ctx) = gpu_or_skip("the_temporal_tables_go_up_once_for_a_layout_of_any_gaze") else {
        return;
    };
    let (world, base) = setup();
    let display = DisplayProfile::new("small", 256, 288, Degrees(100.0), Degrees(110.0)).unwrap();
    let cams = base
        .clone()
        .map(|c| EyeCamera::new(c.position, c.forward, c.up, &display).unwrap());
    let gaze = |f: usize| {
        let [a, b] = if f == 1 {
            [(108.0, 150.0), (118.0, 140.0)]
        } else {
            [(148.0, 138.0), (138.0, 148.0)]
        };
        [
            display.gaze(a.0, a.1).unwrap(),
            display.gaze(b.0, b.1).unwrap(),
        ]
    };
    let mut s = resident::settings(Method::Vafr, ShadingMode::DIRECT);
    s.mapping.vafr.rings = VafrRings::Eq3AnyGaze;
    let plans = |f: usize| {
        let g = gaze(f);
        [0usize, 1].map(|e| plan(&world, &cams[e], &s, g[e], f as u64, e as u32))
    };
    let p0 = plans(0);
    assert!(p0[0].mapping().layout_is_gaze_free());
    let mut frame =
        ResidentFrame::new(&ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE).unwrap();
    let mut sent = [[0i64; 3]; 2];
    for (on, sent) in sent.iter_mut().enumerate() {
        frame
            .set_temporal((on == 1).then(TemporalSettings::default))
            .unwrap();
        for (f, sent) in sent.iter_mut().enumerate() {
            let p = plans(f);
            let before = ctx.traffic();
            frame
                .render(&world, [&p[0], &p[1]], [&cams[0], &cams[1]])
                .unwrap();
            *sent = ctx.traffic().since(&before).bytes_uploaded as i64;
            ctx.wait_idle("the test").unwrap();
        }
    }
    let uniforms = 2 * std::mem::size_of::<TemporalUniform>() as i64;
    let temporal: Vec<i64> = (0..3).map(|f| sent[1][f] - sent[0][f]).collect();
    shout(&format!(
        "[fovea-gpu] resident temporal, rings for any gaze: bytes up per frame with the pass \
         less without {temporal:?} (frames 1, 2 compared; uniform blocks {uniforms} B; without \
         the pass {:?})",
        sent[0]
    ));
    for f in 1..3 {
        assert_eq!(
            temporal[f], uniforms,
            "frame {f}, another gaze, the same layout: no table goes up: {temporal:?}"
        );
    }
}
