//! Times the resident frame's screen side (`fovea_gpu::frame::ScreenContext`) frame by frame
//! with the gaze moving: the host's time recording each frame (tables, uniforms, passes into
//! the encoder), what each frame moved across the bus, and each pass's GPU time from the
//! timestamps of `FrameTimer`, which arrive one or more frames late and are never waited for.
//!
//! ```sh
//! XDG_RUNTIME_DIR=$(mktemp -d) cargo run --release -p fovea-gpu --example screen_timing \
//!     [-- vive-pro-eye [frames [vafr|full [fxaa|none]]]]
//! ```
//!
//! The gaze walks a saccade-sized step (160 px) each frame, back and forth through the
//! screen's centre, mirrored so that the screen-covering buffer keeps its size between the two
//! sides; the samples (random texels) go up once per buffer size before the frames and are not
//! part of any frame's traffic. VaFR with FXAA in sample space, the footprint filter, the gather DOF focused at
//! 1.2 m and the Reinhard tone map. After each frame the example waits for the device (so that
//! frames do not pile up on a software device; a renderer paces on its swapchain instead) —
//! outside the timed recording. Timing only; correctness is `tests/frame_screen.rs`.

use std::collections::HashMap;
use std::time::Instant;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, FoveationMapping, MappingConfig, Method};
use fovea_core::optics::EyeModel;
use fovea_core::units::Metres;
use fovea_gpu::frame::{
    DeviceSamples, FrameTimer, ScreenConfig, ScreenContext, ScreenDof, ScreenInput, ScreenLimits,
    SCREEN_PASSES,
};
use fovea_gpu::{GpuContext, GpuRequest, SampleFilter};
use fovea_post::dof::coc::CocParams;
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::fxaa::FxaaParams;
use fovea_post::inverse_map::{ReconstructFilter, SampleBuffers};
use fovea_post::tonemap::ToneCurve;

#[allow(dead_code)] // cpu_ms: the other timing examples'
mod common;

use common::median;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let preset = args.next().unwrap_or_else(|| "vive-pro-eye".into());
    let frames: usize = args.next().map_or(Ok(12), |r| r.parse())?;
    let method = match args.next().as_deref() {
        None | Some("vafr") => Method::Vafr,
        Some("full") => Method::Full,
        Some(other) => return Err(format!("method `{other}`: expected vafr or full").into()),
    };
    let aa = match args.next().as_deref() {
        None | Some("fxaa") => {
            (method != Method::Full).then_some(SampleFilter::Fxaa(FxaaParams::default()))
        }
        Some("none") => None,
        Some(other) => return Err(format!("AA `{other}`: expected fxaa or none").into()),
    };
    let ctx = GpuContext::new(&GpuRequest::default())?;
    println!("device: {} — {}", ctx.adapter(), ctx.adapter().driver);
    let display = DisplayProfile::preset(&preset)?;
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let mapping_at = |x: f64, y: f64| -> Result<Box<dyn FoveationMapping>, String> {
        let gaze = display.gaze(x, y).map_err(|e| e.to_string())?;
        build(method, &display, gaze, &MappingConfig::default()).map_err(|e| e.to_string())
    };
    // Limits from the largest buffers any gaze gives: the centre and the corners.
    let corners: Vec<Box<dyn FoveationMapping>> =
        [(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(fx, fy)| mapping_at(fx * (w - 1.0), fy * (h - 1.0)))
            .collect::<Result<_, _>>()?;
    let refs: Vec<&dyn FoveationMapping> = corners.iter().map(|m| m.as_ref()).collect();
    let limits = ScreenLimits::of(&refs);
    let config = ScreenConfig {
        aa,
        filter: ReconstructFilter::Footprint,
        dof: Some(ScreenDof {
            filter: ScatterAsGather::default(),
            coc: CocParams::thin_lens(EyeModel::default(), display.focal_y_px()),
        }),
        exposure_stops: 0.0,
        texture: true,
        curve: ToneCurve::Reinhard,
        inset_smoothing: fovea_post::inset_smoothing::Smoothing::ALPHA_BLEND,
    };
    let t = Instant::now();
    let mut screen = ScreenContext::new(&ctx, &display, method, config, limits)?;
    println!(
        "{preset} {}x{}, {method}, AA {aa:?}: context built in {:.1} ms (limits {limits:?})",
        display.width_px,
        display.height_px,
        t.elapsed().as_secs_f64() * 1e3
    );
    let mut timer = FrameTimer::new(&ctx, &SCREEN_PASSES, 3)?;
    if timer.is_none() {
        println!("no timestamp queries on this device: GPU times not measured");
    }

    // The gaze path and each distinct buffer's samples, uploaded before the frames.
    let step = 160.0;
    let path: Vec<(f64, f64)> = (0..frames)
        .map(|k| {
            let side = if k % 2 == 0 { -1.0 } else { 1.0 };
            let reach = step * (1 + (k / 2) % 3) as f64 / 2.0;
            (0.5 * w + side * reach, 0.45 * h)
        })
        .collect();
    let mappings: Vec<Box<dyn FoveationMapping>> = path
        .iter()
        .map(|&(x, y)| mapping_at(x, y))
        .collect::<Result<_, _>>()?;
    let key = |m: &dyn FoveationMapping| -> Vec<(u32, u32)> {
        m.buffers().iter().map(|b| (b.width, b.height)).collect()
    };
    let mut samples: HashMap<Vec<(u32, u32)>, DeviceSamples> = HashMap::new();
    for (k, m) in mappings.iter().enumerate() {
        if let std::collections::hash_map::Entry::Vacant(e) = samples.entry(key(m.as_ref())) {
            let s = DeviceSamples::for_mapping(&ctx, m.as_ref())?;
            s.upload(&ctx, &SampleBuffers::random(m.as_ref(), k as u64)?)?;
            e.insert(s);
        }
    }
    ctx.wait_idle("the samples' upload")?;

    println!(
        "\n{:>5} {:>9} {:>12} {:>9} {:>8} {:>9} {:>7} {:>6} {:>7}",
        "frame", "gaze x", "buffer", "host ms", "tables", "up B", "back B", "bind", "submits"
    );
    let mut host = Vec::new();
    let mut gpu: Vec<fovea_gpu::frame::FrameGpuTimes> = Vec::new();
    for (k, m) in mappings.iter().enumerate() {
        let device = &samples[&key(m.as_ref())];
        let before = ctx.traffic();
        let t = Instant::now();
        let mut encoder = ctx
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("screen side"),
            });
        if let Some(timer) = &mut timer {
            timer.begin_frame();
        }
        screen.record(
            &mut encoder,
            device,
            &ScreenInput {
                mapping: m.as_ref(),
                focus: Some(Metres(1.2)),
            },
            timer.as_mut(),
        )?;
        if let Some(timer) = &timer {
            timer.end_frame(&mut encoder);
        }
        let commands = encoder.finish();
        let host_ms = t.elapsed().as_secs_f64() * 1e3;
        let moved = ctx.traffic().since(&before);
        ctx.submit([commands]);
        if let Some(timer) = &mut timer {
            timer.submitted();
            gpu.extend(timer.poll()?);
        }
        let b = m.buffers()[0];
        println!(
            "{k:>5} {:>9.1} {:>12} {host_ms:>9.3} {:>8} {:>9} {:>7} {:>6} {:>7}",
            path[k].0,
            format!("{}x{}", b.width, b.height),
            if screen.last_table_upload().rebuilt {
                "rebuilt"
            } else {
                "kept"
            },
            moved.bytes_uploaded,
            moved.bytes_read_back,
            moved.bind_groups_created,
            moved.submissions
        );
        if k > 0 {
            host.push(host_ms);
        }
        // Outside the timed recording: keep a software device from piling frames up.
        ctx.wait_idle("the frame")?;
    }
    if let Some(timer) = &mut timer {
        gpu.extend(timer.poll()?);
        println!("\nGPU ms per pass (timestamps read back late; frame: passes):");
        for t in &gpu {
            let passes: Vec<String> = t
                .passes
                .iter()
                .map(|(n, ms)| match ms {
                    Some(ms) => format!("{n} {ms:.3}"),
                    None => format!("{n} -"),
                })
                .collect();
            println!(
                "  {:>3}: {} | total {:.3}",
                t.frame,
                passes.join(", "),
                t.total_ms()
            );
        }
        let later: Vec<_> = gpu.iter().filter(|t| t.frame > 0).collect();
        if !later.is_empty() {
            let med: Vec<String> = SCREEN_PASSES
                .iter()
                .enumerate()
                .filter_map(|(p, name)| {
                    let v: Vec<f64> = later.iter().filter_map(|t| t.passes[p].1).collect();
                    (!v.is_empty()).then(|| format!("{name} {:.3}", median(v)))
                })
                .collect();
            let totals = later.iter().map(|t| t.total_ms()).collect();
            println!(
                "median over frames 1..: {} | total {:.3} ms",
                med.join(", "),
                median(totals)
            );
        }
        println!("untimed frames (ring full): {}", timer.untimed_frames());
    }
    if !host.is_empty() {
        println!(
            "host ms recording a frame (frames 1..): median {:.3}, max {:.3}",
            median(host.clone()),
            host.iter().fold(0.0f64, |a, &b| a.max(b))
        );
    }
    Ok(())
}
