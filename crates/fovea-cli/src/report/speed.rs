//! The speed table of `fovea bench` with per-stage timings (as Weier Table 1), and the BVH
//! backends' primary-ray throughput.

use anyhow::Result;
use clap::ValueEnum;

use fovea_core::mapping::Method;
use fovea_eval::experiments::bench::BenchParams;

use crate::bench::measure_on;
use crate::common::display_of;

use super::doc::{Cell, Section, Table};
use super::Ctx;

/// Stages in pipeline order; any other stage a frame reports follows these.
const STAGE_ORDER: [&str; 5] = ["plan", "trace", "shade", "aa", "reconstruct"];

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let args = ctx.args;
    let headset = args
        .display
        .res
        .clone()
        .unwrap_or_else(|| ctx.display.name.clone());
    let res = match (&args.bench_res, args.quick) {
        (Some(r), _) => r.clone(),
        (None, true) => headset,
        (None, false) => format!("{headset},2k,4k"),
    };
    let vfov = args.display.vfov_deg();
    let methods = if args.quick {
        vec![Method::Vafr, Method::Kfr, Method::Weier]
    } else {
        Method::ALL
            .into_iter()
            .filter(|&m| m != Method::Full)
            .collect()
    };
    let params = BenchParams {
        displays: res
            .split(',')
            .map(|t| display_of(t, vfov))
            .collect::<Result<_>>()?,
        methods,
        bvh_rays: if args.quick { 200_000 } else { 2_000_000 },
        ..BenchParams::default()
    };
    params.validate()?;
    // `measure` sets the lights for each resolution; the next section sees the report's view
    // again, whether or not the benchmark finished.
    let measured = measure_on(
        &mut ctx.loaded,
        &args.scene,
        &params,
        args.backend,
        &ctx.backend,
        args.quiet,
    );
    ctx.restore_view()?;
    let result = measured?;

    // Stages in pipeline order, then any other stage as the runs first report it (each run's
    // by name, as the JSON lists them).
    let mut stages: Vec<String> = STAGE_ORDER.iter().map(|s| s.to_string()).collect();
    for r in &result.runs {
        let mut names: Vec<&str> = r.stats.stages_ms.iter().map(|(s, _)| s.name()).collect();
        names.sort_unstable();
        for k in names {
            if !stages.iter().any(|s| s == k) {
                stages.push(k.to_string());
            }
        }
    }
    let mut cols: Vec<String> = ["resolution", "method", "samples", "rays"]
        .map(String::from)
        .to_vec();
    cols.extend(stages.iter().map(|s| format!("{s} (ms)")));
    cols.extend(["total (ms)", "CPU (ms)", "speedup (wall)", "speedup (CPU)"].map(String::from));
    // Where the rays and the reconstruction ran, and the GPU passes' own times, when a GPU
    // ran any (`--backend`).
    let on_gpu = result.runs.iter().any(|r| !r.device_pass_ms.is_empty());
    const PASSES: [&str; 5] = [
        "trace",
        "direct_light",
        "environment_light",
        "shadow",
        "reconstruct",
    ];
    if on_gpu {
        cols.extend(["rays on", "reconstruct on"].map(String::from));
        cols.extend(PASSES.map(|p| format!("GPU {p} pass (ms)")));
    }
    let col_refs: Vec<&str> = cols.iter().map(String::as_str).collect();
    let mut t = Table::new(
        "speed",
        format!(
            "One frame per method and resolution, {} threads; speedup = full resolution's time over the method's, measured in the same run",
            result.threads
        ),
        &col_refs,
    );
    // Non-finite numbers are missing, as in the JSON.
    let num = |v: f64, d: usize| Cell::Num(if v.is_finite() { v } else { f64::NAN }, d);
    for r in &result.runs {
        let s = &r.stats;
        let mut cells = vec![
            Cell::text(format!("{}×{}", s.width, s.height)),
            Cell::text(s.method.clone()),
            Cell::Int(s.samples),
            Cell::Int(s.rays),
        ];
        for name in &stages {
            let ms = s
                .stages_ms
                .iter()
                .find(|(st, _)| st.name() == name)
                .map_or(0.0, |(_, v)| v);
            cells.push(Cell::Num(if ms.is_finite() { ms } else { 0.0 }, 1));
        }
        cells.extend([
            num(s.total_ms, 1),
            num(s.total_cpu_ms, 1),
            num(r.speedup, 2),
            num(r.speedup_cpu, 2),
        ]);
        if on_gpu {
            cells.push(Cell::text(format!(
                "primary {}, shadow {}, direct light {}",
                s.trace_backend, s.shadow_backend, s.direct_light_backend
            )));
            cells.push(Cell::text(s.reconstruct_backend.clone()));
            for p in PASSES {
                cells.push(
                    r.device_pass_ms
                        .get(p)
                        .map_or(Cell::text("—"), |&ms| num(ms, 2)),
                );
            }
        }
        t.row(cells);
    }
    sec.table(t);
    let emulated = if ctx.backend.cpu_emulated {
        "; its times are CPU-emulated (the adapter is a CPU device)"
    } else {
        ""
    };
    sec.text(match (&ctx.backend.adapter, on_gpu) {
        (Some(adapter), true) => format!(
            "Backend: GPU ({adapter}){emulated}. Every method cast its primary and shadow rays \
             and computed its direct light there, and polar methods reconstructed there; \
             surfaces, the environment's estimator, AA and post ran on the CPU. The GPU pass \
             columns are the passes' own times from timestamps, summed over the frame's calls."
        ),
        _ => format!(
            "Backend: {} — every stage on the CPU.",
            ctx.backend.describe
        ),
    });
    sec.text(
        "Weier Table 1 (GPU, 1280×1440, primary rays and simple shading): ray tracing 3.09 ms foveated against 5.52 ms full (1.79×), 7.64 against 8.68 ms in total (1.14×), 558,945 of 1,843,200 samples (30.3 %). Here every sample also casts shadow rays to each light, so tracing and shading dominate.",
    );

    let mut bvh = Table::new(
        "bvh",
        "Primary-ray throughput of each BVH backend on this scene",
        &[
            "backend",
            "in this build",
            "build (ms)",
            "Mrays/s",
            "chosen",
        ],
    );
    for r in &result.bvh_throughput {
        let (build, mrays) = match (r.available, r.build_ms, r.primary_mrays_per_s) {
            (true, Some(b), Some(m)) => (num(b, 0), num(m, 2)),
            _ => (Cell::text("—"), Cell::text("—")),
        };
        bvh.row(vec![
            Cell::text(r.backend),
            Cell::text(if r.available { "yes" } else { "no" }),
            build,
            mrays,
            Cell::text(if r.chosen { "yes" } else { "" }),
        ]);
    }
    sec.table(bvh);
    let method_names: Vec<&str> = params.methods.iter().map(|m| m.name()).collect();
    sec.text(format!(
        "Reproduce: fovea bench {} --res {} --vfov {} --methods {} --bvh-rays {} --backend {}.",
        super::scene_flags(&args.scene),
        res,
        vfov,
        method_names.join(","),
        params.bvh_rays,
        args.backend
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_string())
    ));
    sec.data = result.to_json();
    Ok(())
}
