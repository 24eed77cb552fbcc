//! The speed table of `fovea bench` with per-stage timings (as Weier Table 1), and the BVH
//! backends' primary-ray throughput.

use anyhow::Result;

use crate::bench::{measure, plan, BenchArgs};
use crate::common::defaults;

use super::doc::{Cell, Section, Table};
use super::Ctx;

/// Stages in pipeline order; any other stage a frame reports follows these.
const STAGE_ORDER: [&str; 5] = ["plan", "trace", "shade", "aa", "reconstruct"];

pub fn run(ctx: &mut Ctx, sec: &mut Section) -> Result<()> {
    let args = ctx.args;
    let mut b: BenchArgs = defaults();
    b.scene = args.scene.clone();
    b.vfov = args.display.vfov;
    let headset = args
        .display
        .res
        .clone()
        .unwrap_or_else(|| ctx.display.name.clone());
    b.res = match (&args.bench_res, args.quick) {
        (Some(r), _) => r.clone(),
        (None, true) => headset,
        (None, false) => format!("{headset},2k,4k"),
    };
    b.methods = if args.quick {
        "vafr,kfr,weier".into()
    } else {
        "vafr,kfr,lafr,visual-polar,guenter,inset,weier".into()
    };
    b.bvh_rays = if args.quick { 200_000 } else { 2_000_000 };
    b.quiet = args.quiet;
    let plan = plan(&b)?;
    // `measure` sets the lights for each resolution; the next section sees the report's view
    // again, whether or not the benchmark finished.
    let measured = measure(&b, &plan, &mut ctx.loaded, false);
    ctx.restore_view()?;
    let json = measured?;

    let runs = json["runs"].as_array().cloned().unwrap_or_default();
    let mut stages: Vec<String> = STAGE_ORDER.iter().map(|s| s.to_string()).collect();
    for r in &runs {
        for k in r["stages_ms"]
            .as_object()
            .into_iter()
            .flatten()
            .map(|(k, _)| k)
        {
            if !stages.contains(k) {
                stages.push(k.clone());
            }
        }
    }
    let mut cols: Vec<String> = ["resolution", "method", "samples", "rays"]
        .map(String::from)
        .to_vec();
    cols.extend(stages.iter().map(|s| format!("{s} (ms)")));
    cols.extend(["total (ms)", "CPU (ms)", "speedup (wall)", "speedup (CPU)"].map(String::from));
    let col_refs: Vec<&str> = cols.iter().map(String::as_str).collect();
    let mut t = Table::new(
        "speed",
        format!(
            "One frame per method and resolution, {} threads; speedup = full resolution's time over the method's, measured in the same run",
            json["threads"]
        ),
        &col_refs,
    );
    let num = |v: &serde_json::Value, d: usize| Cell::Num(v.as_f64().unwrap_or(f64::NAN), d);
    for r in &runs {
        let mut cells = vec![
            Cell::text(format!("{}×{}", r["width"], r["height"])),
            Cell::text(r["method"].as_str().unwrap_or("?")),
            Cell::Int(r["samples"].as_u64().unwrap_or(0)),
            Cell::Int(r["rays"].as_u64().unwrap_or(0)),
        ];
        for s in &stages {
            cells.push(Cell::Num(r["stages_ms"][s].as_f64().unwrap_or(0.0), 1));
        }
        cells.extend([
            num(&r["total_ms"], 1),
            num(&r["cpu_ms"], 1),
            num(&r["speedup_vs_full"], 2),
            num(&r["speedup_vs_full_cpu"], 2),
        ]);
        t.row(cells);
    }
    sec.table(t);
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
    for r in json["bvh_throughput"].as_array().into_iter().flatten() {
        let available = r["available"].as_bool() == Some(true);
        bvh.row(vec![
            Cell::text(r["backend"].as_str().unwrap_or("?")),
            Cell::text(if available { "yes" } else { "no" }),
            if available {
                num(&r["build_ms"], 0)
            } else {
                Cell::text("—")
            },
            if available {
                num(&r["primary_mrays_per_s"], 2)
            } else {
                Cell::text("—")
            },
            Cell::text(if r["chosen"].as_bool() == Some(true) {
                "yes"
            } else {
                ""
            }),
        ]);
    }
    sec.table(bvh);
    sec.text(format!(
        "Reproduce: fovea bench {} --res {} --vfov {} --methods {} --bvh-rays {}.",
        super::scene_flags(&args.scene),
        b.res,
        b.vfov,
        b.methods,
        b.bvh_rays
    ));
    sec.data = json;
    Ok(())
}
