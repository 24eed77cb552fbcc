//! Times the polar reconstruction on the GPU against the CPU's, side by side, on a synthetic
//! VaFR sample buffer (random texels), median of several runs after one warm-up each:
//!
//! ```sh
//! XDG_RUNTIME_DIR=$(mktemp -d) cargo run --release -p fovea-gpu --example reconstruct_timing \
//!     [-- vive-pro-eye,2k [footprint|bilinear [runs]]]
//! ```
//!
//! Per executor: wall ms, process CPU ms (summed over threads; on lavapipe the "GPU" is CPU
//! threads of this process, so its work shows there) and the CPU share (CPU ms / (wall ms ×
//! cores)), as `fovea bench` reports them. For the GPU also its parts: the tables built on the
//! CPU, upload and submission, run and readback, and the compute pass alone from timestamp
//! queries where the device has them. Timing only; correctness is `tests/reconstruct.rs`.

use std::time::Instant;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, MappingConfig, Method};
use fovea_core::Image;
use fovea_gpu::{GpuContext, GpuReconstructor, GpuRequest, ReconstructTimes};
use fovea_post::inverse_map::{reconstruct_into, ReconstructFilter, SampleBuffers};

mod common;

use common::{cpu_ms, median};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let presets = args.next().unwrap_or_else(|| "vive-pro-eye,2k".into());
    let filter = match args.next().as_deref() {
        None | Some("footprint") => ReconstructFilter::Footprint,
        Some("bilinear") => ReconstructFilter::Bilinear,
        Some(other) => {
            return Err(format!("filter `{other}`: expected footprint or bilinear").into())
        }
    };
    let runs: usize = args.next().map_or(Ok(5), |r| r.parse())?;
    let runs = runs.max(1);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let ctx = GpuContext::new(&GpuRequest::default())?;
    let gpu = GpuReconstructor::new(&ctx)?;
    println!(
        "GPU: {} — {}; timestamps: {}; {cores} CPU cores; {filter:?}; median of {runs} runs",
        ctx.adapter(),
        ctx.adapter().driver,
        if ctx.has_timestamps() { "yes" } else { "no" }
    );
    for name in presets.split(',') {
        let d = DisplayProfile::preset(name)?;
        let m = build(Method::Vafr, &d, d.centre_gaze(), &MappingConfig::default())?;
        let mut bufs = SampleBuffers::random(m.as_ref(), 0)?;
        let mut color = Image::new(d.width_px, d.height_px, [0.0f32; 3])?;
        let mut depth = Image::new(d.width_px, d.height_px, 0.0f32)?;
        let (mut cpu_wall, mut cpu_cpu) = (Vec::new(), Vec::new());
        let (mut gpu_wall, mut gpu_cpu, mut gpu_parts) = (Vec::new(), Vec::new(), Vec::new());
        for run in 0..=runs {
            let (t, c) = (Instant::now(), cpu_ms());
            reconstruct_into(m.as_ref(), &d, &mut bufs, &mut color, &mut depth, filter)?;
            let (w1, c1) = (t.elapsed().as_secs_f64() * 1e3, cpu_ms() - c);
            let (t, c) = (Instant::now(), cpu_ms());
            let parts =
                gpu.reconstruct_into(m.as_ref(), &d, &bufs, filter, &mut color, &mut depth)?;
            let (w2, c2) = (t.elapsed().as_secs_f64() * 1e3, cpu_ms() - c);
            if run > 0 {
                cpu_wall.push(w1);
                cpu_cpu.push(c1);
                gpu_wall.push(w2);
                gpu_cpu.push(c2);
                gpu_parts.push(parts);
            }
        }
        let line = |who: &str, wall: f64, cpu: f64| {
            println!(
                "  {who:>3}: {wall:>8.1} ms wall, {cpu:>8.1} ms CPU ({:>3.0} % of {cores} cores)",
                100.0 * cpu / (wall * cores as f64)
            )
        };
        println!(
            "VaFR {name} {}x{} (buffer {:?}):",
            d.width_px,
            d.height_px,
            m.buffers()
                .iter()
                .map(|b| (b.width, b.height))
                .collect::<Vec<_>>()
        );
        line("CPU", median(cpu_wall), median(cpu_cpu));
        line("GPU", median(gpu_wall), median(gpu_cpu));
        let part = |f: fn(&ReconstructTimes) -> f64| median(gpu_parts.iter().map(f).collect());
        let pass = gpu_parts
            .iter()
            .filter_map(|p| p.gpu_pass_ms)
            .collect::<Vec<_>>();
        println!(
            "       GPU parts: tables on the CPU {:.1} ms, upload + submit {:.1} ms, run + \
             readback {:.1} ms, compute pass {} ({} band(s))",
            part(|p| p.tables_ms),
            part(|p| p.upload_ms),
            part(|p| p.run_and_readback_ms),
            if pass.is_empty() {
                "n/a (no timestamps)".to_string()
            } else {
                format!("{:.1} ms (timestamps)", median(pass))
            },
            gpu_parts[0].bands
        );
    }
    Ok(())
}
