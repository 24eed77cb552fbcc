//! The frame plan's host time per binocular frame with the gaze moving by a saccade-sized step
//! every frame (issue 37's host-time bar): both eyes' plans (`FramePlan::new`) and the tables
//! the polar reconstruction and the AA pass derive from them, at each display, VaFR by default.
//!
//! ```sh
//! cargo run --release -p fovea-render --example plan_host_ms -- [PRESETS] [FRAMES] [METHOD]
//! ```
//!
//! Defaults: `vive-pro-eye,8k`, 12 frames, `vafr` (`vafr-eq3`: VaFR with Eq. 3's rings;
//! `vafr-eq3-any-gaze`: Eq. 3's rings in the buffer for any gaze, the resident frame's). Prints, per display, the mean wall and
//! process CPU ms per binocular frame of every part, and the CPU share (CPU / (wall × cores)):
//! the plans before (`FramePlan::new`, the AA pass's alignment table built texel by texel as
//! `fovea-gpu` did) and after (`FramePlan::cached` with one `PlanCache` for both eyes,
//! `Grid::packed_alignment`) side by side, the plans of a still gaze from the cache, and the
//! reconstruction's tables (the same code in both).

use std::time::Instant;

use cpu_time::ProcessTime;
use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::{build, Method};
use fovea_post::grid::Grid;
use fovea_post::inverse_map::{minified_columns, PolarTables, ReconstructFilter, SampleBuffers};
use fovea_render::bvh::Backend;
use fovea_render::camera::{Eye, HmdRig};
use fovea_render::eye::EyeState;
use fovea_render::pipeline::FrameSettings;
use fovea_render::plan::{FramePlan, PlanCache};
use fovea_render::scene::builtin;
use fovea_render::world::World;

/// Saccade-sized gaze step per frame, degrees of visual angle at the screen centre.
const STEP_DEG: f64 = 8.0;

/// Wall and process CPU ms of a part, summed over frames.
#[derive(Default, Clone, Copy)]
struct Cost {
    wall_ms: f64,
    cpu_ms: f64,
}

fn timed<T>(cost: &mut Cost, f: impl FnOnce() -> T) -> T {
    let (w, c) = (Instant::now(), ProcessTime::now());
    let out = f();
    cost.wall_ms += w.elapsed().as_secs_f64() * 1e3;
    cost.cpu_ms += c.elapsed().as_secs_f64() * 1e3;
    out
}

/// The gaze of frame `k`: a walk across the screen that turns at its edges, `step_px` a frame.
fn gaze_path(display: &DisplayProfile, k: usize, step_px: f64) -> (f64, f64) {
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let bounce = |t: f64, len: f64| {
        let t = t.rem_euclid(2.0 * len);
        if t > len {
            2.0 * len - t
        } else {
            t
        }
    };
    // Directions differ on the two axes so that the walk visits corners and the middle.
    let t = k as f64 * step_px;
    (bounce(0.6 * t + 0.1 * w, w), bounce(0.8 * t + 0.2 * h, h))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let presets = args.first().map_or("vive-pro-eye,8k", String::as_str);
    let frames: usize = args.get(1).map_or(Ok(12), |s| s.parse())?;
    // `vafr-eq3`: VaFR with the paper's Eq. 3 rings instead of the exact ones;
    // `vafr-eq3-any-gaze`: Eq. 3's rings in the buffer for any gaze (the resident frame's).
    let method_arg = args.get(2).map_or("vafr", String::as_str);
    let rings = match method_arg {
        "vafr-eq3" => Some(fovea_core::mapping::VafrRings::Eq3),
        "vafr-eq3-any-gaze" => Some(fovea_core::mapping::VafrRings::Eq3AnyGaze),
        _ => None,
    };
    let method = Method::parse(if rings.is_some() { "vafr" } else { method_arg })?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let scene = builtin::depth_range()?;
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::best_available())?;
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063)?;
    let mut settings = FrameSettings::new(method);
    settings.memory_limit_bytes = u64::MAX;
    if let Some(rings) = rings {
        settings.mapping.vafr.rings = rings;
    }
    // Jittered samples, as with temporal accumulation on.
    let jitter = [0.25, -0.25];
    println!(
        "{method_arg}, {frames} binocular frames per display after one warm-up, the gaze stepping \
         {STEP_DEG}° a frame (the right eye's 12 px to the left of the left eye's), {cores} \
         cores; ms per binocular frame (both eyes): wall / process CPU (CPU share)"
    );
    for name in presets.split(',') {
        let display = DisplayProfile::preset(name)?;
        let step_px = display.radius_px(fovea_core::units::Degrees(STEP_DEG));
        let cams = [
            rig.eye(Eye::Left, &display)?,
            rig.eye(Eye::Right, &display)?,
        ];
        let names = [
            "before: FramePlan::new",
            "  of which the mapping",
            "before: AA align table",
            "after: FramePlan::cached",
            "after: AA align table",
            "after, still gaze: plan",
            "both: minified_columns",
            "both: reconstruct u(r)",
            "both: PolarTables",
        ];
        let mut costs = vec![Cost::default(); names.len()];
        let mut cache = PlanCache::new();
        let mut still = PlanCache::new();
        for k in 0..=frames {
            let (gx, gy) = gaze_path(&display, k, step_px);
            let mut frame = vec![Cost::default(); names.len()];
            for (e, cam) in cams.iter().enumerate() {
                let gaze: Gaze = display.gaze(gx - 12.0 * e as f64, gy)?;
                let eye = EyeState::looking_at(gaze);
                let plan = timed(&mut frame[0], || {
                    FramePlan::new(&world, cam, &settings, &eye, jitter)
                })?;
                timed(&mut frame[1], || {
                    build(method, &display, gaze, &settings.mapping)
                })?;
                let size = plan.buffers[0];
                let grid = plan.mapping().polar_layout().map(|l| Grid::polar(&l));
                if let Some(grid) = &grid {
                    timed(&mut frame[2], || {
                        align_table(grid, (size.width, size.height))
                    });
                }
                let cached = timed(&mut frame[3], || {
                    FramePlan::cached(&world, cam, &settings, &eye, jitter, &mut cache)
                })?;
                if let Some(grid) = &grid {
                    let a = timed(&mut frame[4], || {
                        grid.packed_alignment(size.width, size.height)
                    });
                    assert_eq!(a, Some(align_table(grid, (size.width, size.height))));
                }
                let still_eye = EyeState::looking_at(display.gaze(gx - 12.0 * e as f64, 0.5 * gy)?);
                let _ = FramePlan::cached(&world, cam, &settings, &still_eye, jitter, &mut still)?;
                timed(&mut frame[5], || {
                    FramePlan::cached(&world, cam, &settings, &still_eye, jitter, &mut still)
                })?;
                timed(&mut frame[6], || minified_columns(cached.mapping()));
                if let Some(layout) = cached.mapping().polar_layout() {
                    timed(&mut frame[7], || {
                        u_of_r_table(cached.mapping(), &display, &layout)
                    });
                    let buffers = SampleBuffers::random(cached.mapping(), k as u64)?;
                    timed(&mut frame[8], || {
                        PolarTables::new(
                            cached.mapping(),
                            &display,
                            &buffers,
                            ReconstructFilter::Footprint,
                        )
                    })?;
                }
            }
            if k > 0 {
                for (c, f) in costs.iter_mut().zip(&frame) {
                    c.wall_ms += f.wall_ms;
                    c.cpu_ms += f.cpu_ms;
                }
            }
        }
        println!(
            "\n{} ({}x{}), step {:.0} px; cache: {} hits, {} misses",
            display.name,
            display.width_px,
            display.height_px,
            step_px,
            cache.hits(),
            cache.misses()
        );
        for (n, c) in names.iter().zip(&costs) {
            let (w, cpu) = (c.wall_ms / frames as f64, c.cpu_ms / frames as f64);
            println!(
                "  {n:<26} {w:>8.2} / {cpu:>8.2} ms  ({:>3.0} % of {cores} cores)",
                100.0 * cpu / (w * cores as f64).max(1e-9)
            );
        }
    }
    Ok(())
}

/// The polar reconstruction's `u(r)` lookup table as `PolarTables` builds it: the mapping's
/// forward map every `LUT_STEP_PX` along +x from the pole out past the farthest corner.
fn u_of_r_table(
    mapping: &dyn fovea_core::mapping::FoveationMapping,
    display: &DisplayProfile,
    layout: &fovea_core::mapping::PolarLayout,
) -> Vec<f32> {
    use rayon::prelude::*;
    let c = layout.centre;
    let r_max = display.farthest_corner_px(&display.gaze(c.x_px, c.y_px).unwrap()) + 2.0;
    let step = fovea_post::inverse_map::LUT_STEP_PX;
    let n = (r_max / step).ceil() as usize + 2;
    (0..n)
        .into_par_iter()
        .map(|k| {
            let r = k as f64 * step;
            mapping
                .forward(fovea_core::units::ScreenPoint::new(c.x_px + r, c.y_px))
                .map_or(f32::INFINITY, |s| s.u as f32)
        })
        .collect()
}

/// The AA pass's per-texel alignment table as `fovea-gpu`'s `sample_aa` builds it (serial).
fn align_table(grid: &Grid, (w, h): (u32, u32)) -> Vec<u32> {
    let Grid::Polar { rows, .. } = grid else {
        return vec![0];
    };
    let mut align = vec![0u32; w as usize * h as usize];
    for (i, &r) in rows.iter().enumerate() {
        let i = i as u32;
        for j in 0..r {
            let left = grid.step(i, j, -1, 0).1;
            let right = grid.step(i, j, 1, 0).1;
            align[(j * w + i) as usize] = left | (right << 16);
        }
    }
    align
}
