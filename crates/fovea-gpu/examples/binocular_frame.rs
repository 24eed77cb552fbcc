//! The whole binocular resident frame against today's staged `--backend gpu` path, side by
//! side in one run (issue 37): both eyes of the built-in scene at a display preset, direct
//! shading (the environment through its default occluded rays), one ray per texel, the
//! method's own AA, the footprint reconstruction, the tone map; the gaze moving by a
//! saccade-sized step (about 8°) every frame.
//!
//! * resident: `fovea_gpu::frame::ResidentFrame::render` — both eyes' every pass recorded
//!   into one encoder, one submission — then a wait for the device (here only, outside the
//!   counted frame, to time its wall clock); per-pass GPU ms from its late timers;
//! * staged: `fovea_render::pipeline::render_planned` of each eye with the GPU's per-call
//!   passes as the executors (trace, surfaces, direct and environment light, AA,
//!   reconstruction; `fovea_gpu::executors::GpuExecutors`), then its tone map of each eye, as
//!   `fovea render --backend gpu` runs them (records and images going back and forth).
//!
//! * denoised (with `denoise=both`, the default, or `on`): the same resident frame with the
//!   sample-space denoiser on (issue 38; its defaults, 3×3 × 4 iterations: the GPU twin
//!   recorded after each eye's shading, before the screen side), the same gazes — its
//!   `left denoise` / `right denoise` GPU ms beside the frame's total with and without it.
//!
//! For each, per binocular frame: wall ms, host ms (resident: checking, tables, uniforms and
//! recording, without the submission), submissions, blocking waits, bytes up and back —
//! the device's own counters (`GpuContext::traffic`); then the median wall ratio. The plans
//! (`FramePlan::cached`, both eyes' mappings at their gazes, one `PlanCache`) are built
//! beforehand and timed apart; the median of plans + host is the render thread's whole
//! preparation of a frame (issue 37's host bar).
//!
//! `temporal=on` both paths accumulate (the default `TemporalSettings`: the resident frame's
//! pass, `ResidentFrame::set_temporal`; the staged path's CPU `TemporalAccumulator` per eye).
//!
//! `rings` picks VaFR's rings (`VafrRings`): `eq3-any-gaze` (default; the layout the resident
//! frame builds its tables from once, only the pole and the shaded runs following the gaze),
//! `exact` (the CPU path's default: rings and buffer follow the gaze) or `eq3`.
//!
//! ```sh
//! XDG_RUNTIME_DIR=$(mktemp -d) cargo run --release -p fovea-gpu --example binocular_frame -- \
//!     [frames=4] [method=vafr] [res=vive-pro-eye|4k|8k|retinal] [lights=1] [staged=on|off] \
//!     [rings=eq3-any-gaze|exact|eq3] [temporal=off|on] [denoise=both|on|off]
//! ```

#[path = "common/binocular_view.rs"]
mod binocular_view;

use binocular_view::{binocular_view, direct_settings};

use std::time::Instant;

use fovea_core::mapping::{Method, VafrRings};
use fovea_gpu::executors::GpuExecutors;
use fovea_gpu::frame::{FrameGpuTimes, ResidentFrame, ToneSettings};
use fovea_gpu::{GpuContext, GpuRequest, TrafficCounts};
use fovea_post::denoise::DenoiseParams;
use fovea_post::tonemap::ToneCurve;
use fovea_render::eye::EyeState;
use fovea_render::pipeline::{render_planned, FrameContext, FrameInputs, StageTimes};
use fovea_render::plan::{FramePlan, PlanCache};
use fovea_render::shade::FrameNoise;
use fovea_render::temporal::{TemporalAccumulator, TemporalSettings};

const TONE: ToneSettings = ToneSettings {
    exposure_stops: 0.0,
    curve: ToneCurve::Reinhard,
};

fn line(what: &str, wall_ms: f64, host_ms: Option<f64>, t: &TrafficCounts) {
    let host = host_ms.map_or("—".to_string(), |h| format!("{h:.2}"));
    println!(
        "| {what} | {wall_ms:.1} | {host} | {} | {} | {:.3} | {:.3} | {} | {} |",
        t.submissions,
        t.blocking_waits,
        t.bytes_uploaded as f64 / 1e6,
        t.bytes_read_back as f64 / 1e6,
        t.buffers_created,
        t.bind_groups_created
    );
}

/// One line of a frame's per-pass GPU ms.
fn gpu_line(g: &FrameGpuTimes) -> String {
    let passes: Vec<String> = g
        .passes
        .iter()
        .filter_map(|(n, ms)| ms.map(|ms| format!("{n} {ms:.2}")))
        .collect();
    format!(
        "frame {}: total {:.2} GPU ms; {}",
        g.frame,
        g.total_ms(),
        passes.join(", ")
    )
}

/// The GPU ms of the passes named `name` in `g`, summed (`None`: none ran or arrived).
fn pass_ms(g: &FrameGpuTimes, name: &str) -> Option<f64> {
    g.passes
        .iter()
        .filter(|(n, _)| *n == name)
        .filter_map(|(_, ms)| *ms)
        .reduce(|a, b| a + b)
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = args.first().map_or(Ok(4), |a| a.parse())?;
    let method = Method::parse(args.get(1).map_or("vafr", String::as_str))?;
    let res = args.get(2).map_or("vive-pro-eye", String::as_str);
    let lights: usize = args.get(3).map_or(Ok(1), |a| a.parse())?;
    let with_staged = match args.get(4).map_or("on", String::as_str) {
        "on" => true,
        "off" => false,
        other => return Err(format!("staged={other} (on or off)").into()),
    };
    let temporal = match args.get(6).map_or("off", String::as_str) {
        "on" => Some(TemporalSettings::default()),
        "off" => None,
        other => return Err(format!("temporal={other} (on or off)").into()),
    };
    let (plain_on, denoised_on) = match args.get(7).map_or("both", String::as_str) {
        "both" => (true, true),
        "on" => (false, true),
        "off" => (true, false),
        other => return Err(format!("denoise={other} (both, on or off)").into()),
    };

    let rings = match args.get(5).map_or("eq3-any-gaze", String::as_str) {
        "eq3-any-gaze" => VafrRings::Eq3AnyGaze,
        "exact" => VafrRings::Exact,
        "eq3" => VafrRings::Eq3,
        other => return Err(format!("rings={other} (eq3-any-gaze, exact or eq3)").into()),
    };

    let (world, cams, display) = binocular_view(res, lights)?;
    let mut settings = direct_settings(method);
    settings.mapping.vafr.rings = rings;
    let mut denoise_settings = settings.clone();
    denoise_settings.denoise = Some(DenoiseParams::default());

    let ctx = GpuContext::new(&GpuRequest::default())?;
    println!(
        "{method} at {res} ({}x{}), both eyes, {} light(s), direct shading, VaFR rings {}, \
         temporal {}; on {}",
        display.width_px,
        display.height_px,
        world.lights.len(),
        rings.name(),
        if temporal.is_some() { "on" } else { "off" },
        ctx.adapter()
    );

    // The gaze moves ~8° every frame, around a circle of a fifth of the screen's height.
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let step_px = 8.0 / display.c_r().atan().to_degrees();
    let gaze_at = |f: usize, eye: usize| {
        let a = f as f64 * step_px / (0.2 * h);
        let x = 0.5 * w + 0.2 * h * a.cos() + eye as f64 * 0.02 * w;
        let y = 0.5 * h + 0.2 * h * a.sin();
        display.gaze(x, y)
    };
    let plans_with = |f: usize,
                      settings: &fovea_render::pipeline::FrameSettings,
                      cache: &mut PlanCache|
     -> Result<Vec<FramePlan>, Box<dyn std::error::Error>> {
        (0..2)
            .map(|e| {
                Ok(FramePlan::cached(
                    &world,
                    &cams[e],
                    settings,
                    &EyeState::looking_at(gaze_at(f, e)?),
                    [0.0, 0.0],
                    cache,
                )?
                .with_noise(FrameNoise::new(f as u64, e as u32)))
            })
            .collect()
    };
    let (mut cache, mut denoise_cache) = (PlanCache::new(), PlanCache::new());
    let mut plans_of = |f: usize| plans_with(f, &settings, &mut cache);

    let t = Instant::now();
    let p0 = plans_of(0)?;
    let mut resident =
        ResidentFrame::new(&ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE)?;
    resident.set_temporal(temporal)?;
    let mut accumulators = match temporal {
        Some(t) => Some([TemporalAccumulator::new(t)?, TemporalAccumulator::new(t)?]),
        None => None,
    };
    println!(
        "resident frame built in {:.1} ms (scene, both screen sides, timers)",
        t.elapsed().as_secs_f64() * 1e3
    );
    // The same frame with the sample-space denoiser on (its own scene, buffers and timers).
    let mut denoised = if denoised_on {
        let p0 = plans_with(0, &denoise_settings, &mut denoise_cache)?;
        let mut d = ResidentFrame::new(&ctx, &world, [&p0[0], &p0[1]], [&cams[0], &cams[1]], TONE)?;
        d.set_temporal(temporal)?;
        Some(d)
    } else {
        None
    };
    let mut staged = if with_staged {
        // The staged path: the library's GPU executors lent to the CPU pipeline.
        let gx = GpuExecutors::new(&ctx, &world)?;
        let mut fc = FrameContext::new();
        fc.set_executors(gx.first);
        Some((fc, gx.tone_map))
    } else {
        None
    };

    println!(
        "| frame | wall ms | host ms | submissions | waits | MB up | MB back | buffers | bind groups |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let (mut walls, mut staged_walls, mut hosts) = (Vec::new(), Vec::new(), Vec::new());
    let mut prepares = Vec::new();
    let mut gpu_lines = Vec::new();
    let (mut denoised_walls, mut denoised_lines) = (Vec::new(), Vec::new());
    // GPU ms per frame: the plain frame's total; the denoised frame's total and its denoiser.
    let (mut plain_gpu, mut denoised_gpu, mut denoise_gpu) = (Vec::new(), Vec::new(), Vec::new());
    for f in 0..frames {
        let t = Instant::now();
        let plans = plans_of(f)?;
        let plan_ms = t.elapsed().as_secs_f64() * 1e3;

        if let Some(d) = &mut denoised {
            let plans = plans_with(f, &denoise_settings, &mut denoise_cache)?;
            let before = ctx.traffic();
            let t = Instant::now();
            let times = d.render(&world, [&plans[0], &plans[1]], [&cams[0], &cams[1]])?;
            let moved = ctx.traffic().since(&before);
            ctx.wait_idle("the denoised resident frame")?;
            let wall = t.elapsed().as_secs_f64() * 1e3;
            line(
                &format!("{f} resident, denoised"),
                wall,
                Some(times.host_ms),
                &moved,
            );
            if f > 0 {
                denoised_walls.push(wall);
            }
            for g in d.poll_gpu_times()? {
                if g.frame > 0 {
                    denoised_gpu.push(g.total_ms());
                    let l = pass_ms(&g, "left denoise");
                    let r = pass_ms(&g, "right denoise");
                    if let (Some(l), Some(r)) = (l, r) {
                        denoise_gpu.push((l, r));
                    }
                }
                denoised_lines.push(gpu_line(&g));
            }
        }
        if !plain_on {
            continue;
        }

        let before = ctx.traffic();
        let t = Instant::now();
        let times = resident.render(&world, [&plans[0], &plans[1]], [&cams[0], &cams[1]])?;
        let moved = ctx.traffic().since(&before);
        // Here only, to time the frame's wall clock (outside the counted frame).
        ctx.wait_idle("the resident frame")?;
        let wall = t.elapsed().as_secs_f64() * 1e3;
        line(
            &format!(
                "{f} resident (tables {:.2} ms of the host's; plans {plan_ms:.1} ms apart)",
                times.tables_ms
            ),
            wall,
            Some(times.host_ms),
            &moved,
        );
        if f > 0 {
            walls.push(wall);
            hosts.push(times.host_ms);
            prepares.push(plan_ms + times.host_ms);
        }
        for g in resident.poll_gpu_times()? {
            if g.frame > 0 {
                plain_gpu.push(g.total_ms());
            }
            gpu_lines.push(gpu_line(&g));
        }

        if let Some((fc, tone)) = &mut staged {
            let before = ctx.traffic();
            let t = Instant::now();
            for e in 0..2 {
                let frame = render_planned(
                    fc,
                    &world,
                    &cams[e],
                    &plans[e],
                    FrameInputs {
                        accumulator: accumulators.as_mut().map(|a| &mut a[e]),
                        prefill: None,
                    },
                    StageTimes::default(),
                    &|_, _| {},
                )?;
                let _bytes = tone.to_srgb8(&frame.color, TONE.exposure_stops, TONE.curve)?;
            }
            let wall = t.elapsed().as_secs_f64() * 1e3;
            let moved = ctx.traffic().since(&before);
            line(&format!("{f} staged"), wall, None, &moved);
            if f > 0 {
                staged_walls.push(wall);
            }
        }
    }
    println!();
    println!("resident per-pass GPU ms (timestamps read frames late, without waiting):");
    if !resident.timed() {
        println!("(the device has no timestamp queries)");
    }
    for l in gpu_lines {
        println!("  {l}");
    }
    if denoised.is_some() {
        println!("resident with the denoiser, per-pass GPU ms:");
        for l in denoised_lines {
            println!("  {l}");
        }
        let (l, r): (Vec<f64>, Vec<f64>) = denoise_gpu.iter().copied().unzip();
        println!(
            "denoiser (3x3 x4) GPU ms per pass, median over frames 1..{frames}: left {:.2}, right \
             {:.2}; frame GPU ms without the denoiser {:.2}, with it {:.2}; wall ms without {:.1}, \
             with {:.1}",
            median(l),
            median(r),
            median(plain_gpu.clone()),
            median(denoised_gpu.clone()),
            median(walls.clone()),
            median(denoised_walls.clone())
        );
    }
    if walls.is_empty() {
        println!("one frame: no steady frames to take the median of (ask for 2 or more)");
        return Ok(());
    }
    let (rw, sw) = (median(walls), median(staged_walls.clone()));
    let staged = match staged_walls.is_empty() {
        true => "staged not run".to_string(),
        false => format!("staged {sw:.1} ms wall; staged / resident {:.2}", sw / rw),
    };
    println!(
        "median over frames 1..{frames}: resident {rw:.1} ms wall ({:.1} fps binocular), host \
         {:.2} ms (plans + host {:.2} ms); {staged}",
        1e3 / rw,
        median(hosts),
        median(prepares),
    );
    Ok(())
}
