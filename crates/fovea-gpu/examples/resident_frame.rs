//! The resident frame's sample side against the staged GPU path, per binocular frame (issue
//! 37): both eyes of the built-in scene at a display preset, direct shading (the environment
//! through its default occluded rays), one ray per texel, the gaze moving by a saccade-sized
//! step (about 8°) every frame.
//!
//! * resident: `fovea_gpu::frame::ResidentSamples::render_eyes` — both eyes' tables and
//!   uniforms written, both passes recorded into one encoder, one submission — then a wait for
//!   the device (here only, to time the frame's wall clock);
//! * staged: `fovea_render::pipeline::trace_shade::trace_and_shade` of each eye with the GPU's
//!   passes lent one call at a time (surfaces, direct and environment light through
//!   `GpuTracer`'s `*_timed` calls, records going back to the CPU between them), as
//!   `fovea render --backend gpu` runs them.
//!
//! For each: wall ms, host ms (resident: preparing and recording, without the submission and
//! the wait), submissions, blocking waits, bytes up and back, buffers and bind groups
//! created — the device's own counters (`GpuContext::traffic`). The plans (`FramePlan::new`,
//! the mapping at each gaze) are built beforehand and timed apart.
//!
//! ```sh
//! XDG_RUNTIME_DIR=$(mktemp -d) cargo run --release -p fovea-gpu --example resident_frame -- \
//!     [frames=4] [method=vafr] [headset=vive-pro-eye] [lights=1]
//! ```

#[path = "common/binocular_view.rs"]
mod binocular_view;

use binocular_view::{binocular_view, direct_settings};

use std::time::Instant;

use fovea_core::mapping::Method;
use fovea_core::Image;
use fovea_gpu::frame::ResidentSamples;
use fovea_gpu::{GpuContext, GpuRequest, TrafficCounts};
use fovea_post::inverse_map::SampleBuffers;
use fovea_render::eye::EyeState;
use fovea_render::pipeline::trace_shade::trace_and_shade;
use fovea_render::pipeline::{StageBackends, StageTimes};
use fovea_render::plan::FramePlan;
use fovea_render::shade::FrameNoise;

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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = args.first().map_or(Ok(4), |a| a.parse())?;
    let method = Method::parse(args.get(1).map_or("vafr", String::as_str))?;
    let headset = args.get(2).map_or("vive-pro-eye", String::as_str);
    let lights: usize = args.get(3).map_or(Ok(1), |a| a.parse())?;

    let (world, cams, display) = binocular_view(headset, lights)?;
    let settings = direct_settings(method);

    let ctx = GpuContext::new(&GpuRequest::default())?;
    println!(
        "{} at {headset} ({}x{}), both eyes, {} light(s), direct shading; on {}",
        method,
        display.width_px,
        display.height_px,
        world.lights.len(),
        ctx.adapter()
    );
    let t = Instant::now();
    let mut resident = ResidentSamples::new(&ctx, &world)?;
    println!(
        "resident scene built in {:.1} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    // The staged path: the library's GPU executors lent to the CPU pipeline.
    let mut staged = fovea_gpu::executors::GpuExecutors::new(&ctx, &world)?.first;

    // The gaze moves ~8° (200 px at the Vive Pro Eye's ~25 px/°) every frame, around a circle.
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let step_px = 8.0 / display.c_r().atan().to_degrees();
    let gaze_at = |f: usize, eye: usize| {
        let a = f as f64 * step_px / (0.2 * h);
        let x = 0.5 * w + 0.2 * h * a.cos() + eye as f64 * 0.02 * w;
        let y = 0.5 * h + 0.2 * h * a.sin();
        display.gaze(x, y)
    };
    println!(
        "| frame | wall ms | host ms | submissions | waits | MB up | MB back | buffers | bind groups |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for f in 0..frames {
        let t = Instant::now();
        let plans: Vec<FramePlan> = (0..2)
            .map(|e| {
                Ok(FramePlan::new(
                    &world,
                    &cams[e],
                    &settings,
                    &EyeState::looking_at(gaze_at(f, e)?),
                    [0.0, 0.0],
                )?
                .with_noise(FrameNoise::new(f as u64, e as u32)))
            })
            .collect::<Result<_, Box<dyn std::error::Error>>>()?;
        let plan_ms = t.elapsed().as_secs_f64() * 1e3;
        let eyes = [(&cams[0], &plans[0]), (&cams[1], &plans[1])];

        let before = ctx.traffic();
        let t = Instant::now();
        let times = resident.render_eyes(&world, &eyes)?;
        // Here only, to time the frame's wall clock (counted in `waits`).
        ctx.wait_idle("the resident frame")?;
        let wall = t.elapsed().as_secs_f64() * 1e3;
        let moved = ctx.traffic().since(&before);
        line(
            &format!(
                "{f} resident (tables {:.2} ms of the host's; plans {plan_ms:.1} ms apart)",
                times.tables_ms
            ),
            wall,
            Some(times.host_ms),
            &moved,
        );

        let before = ctx.traffic();
        let t = Instant::now();
        for e in 0..2 {
            let mut s = SampleBuffers {
                color: plans[e]
                    .buffers
                    .iter()
                    .map(|b| Image::new(b.width, b.height, [0.0f32; 3]))
                    .collect::<Result<_, _>>()?,
                depth: plans[e]
                    .buffers
                    .iter()
                    .map(|b| Image::new(b.width, b.height, f32::INFINITY))
                    .collect::<Result<_, _>>()?,
            };
            let mut st = StageTimes::default();
            let backends = StageBackends::decide(&staged, &world, &plans[e]);
            trace_and_shade(
                &world,
                &cams[e],
                &plans[e],
                None,
                &mut s,
                None,
                &mut st,
                staged.tracer.as_deref_mut(),
                &backends,
                &|_, _| {},
            )?;
        }
        let wall = t.elapsed().as_secs_f64() * 1e3;
        let moved = ctx.traffic().since(&before);
        line(&format!("{f} staged"), wall, None, &moved);
    }
    Ok(())
}
