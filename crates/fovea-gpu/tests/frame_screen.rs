//! The resident screen side (`fovea_gpu::frame::ScreenContext`) against the CPU's chain on
//! the same samples: `fovea_post::inverse_map::reconstruct_into`, then the eye's CoC map and
//! the scatter-as-gather filter (`fovea_post::dof`), then `fovea_post::tonemap::to_srgb8`.
//!
//! Samples go up once (`DeviceSamples::upload`), the screen side is recorded into one encoder
//! and submitted, and the image is read back once (`ScreenContext::read_srgb8`). Bounds:
//!
//! * the 8-bit output: luma PSNR ≥ 40 dB against the CPU's (luma of the sRGB codes, as
//!   `fovea_eval::metrics::luma_psnr`), VaFR at the Vive Pro Eye, gazes at the centre and
//!   near a corner, random texels and a frame rendered by the CPU renderer;
//! * the linear reconstruction before the DOF: the per-call path's bounds
//!   (`tests/reconstruct.rs`): per channel max |GPU − CPU| ≤ 2/64 + 2e-3, mean ≤ 1.5e-3,
//!   differing depths ≤ 1 % of the pixels;
//! * a steady-state frame (the second, the gaze moved): 0 buffers and bind groups created,
//!   ≤ 64 KiB uploaded, 0 bytes read back, no submission while recording.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1. `--nocapture` prints the measured figures.

mod common;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::{build, FoveationMapping, MappingConfig, Method};
use fovea_core::optics::EyeModel;
use fovea_core::units::Metres;
use fovea_core::Image;
use fovea_gpu::frame::{
    DeviceSamples, FrameTimer, ScreenConfig, ScreenContext, ScreenDof, ScreenInput, ScreenLimits,
    SCREEN_PASSES,
};
use fovea_gpu::SampleFilter;
use fovea_gpu::{GpuContext, GpuError};
use fovea_post::dof::coc::{coc_map, CocParams};
use fovea_post::dof::gather::ScatterAsGather;
use fovea_post::dof::{DofFilter, DofInput};
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::{
    minified_columns, reconstruct_into, ReconstructFilter, SampleBuffers,
};
use fovea_post::tonemap::{to_srgb8, ToneCurve};
use fovea_post::Rgb;

const PSNR_MIN_DB: f64 = 40.0;
const STEADY_UPLOAD_MAX: u64 = 64 * 1024;

fn display() -> DisplayProfile {
    DisplayProfile::preset("vive-pro-eye").unwrap()
}

fn vafr(display: &DisplayProfile, gaze: Gaze) -> Box<dyn FoveationMapping> {
    build(Method::Vafr, display, gaze, &MappingConfig::default()).unwrap()
}

fn dof_of(display: &DisplayProfile) -> ScreenDof {
    ScreenDof {
        filter: ScatterAsGather::default(),
        coc: CocParams::thin_lens(EyeModel::default(), display.focal_y_px()),
    }
}

fn config(filter: ReconstructFilter, dof: Option<ScreenDof>) -> ScreenConfig {
    ScreenConfig {
        aa: None,
        filter,
        dof,
        exposure_stops: 0.5,
        texture: false,
        curve: ToneCurve::Reinhard,
        inset_smoothing: fovea_post::inset_smoothing::Smoothing::ALPHA_BLEND,
    }
}

/// Limits for every gaze of `display`: the VaFR buffers at the centre and the four corners.
fn limits(display: &DisplayProfile) -> ScreenLimits {
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let maps: Vec<Box<dyn FoveationMapping>> =
        [(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(fx, fy)| {
                vafr(
                    display,
                    display.gaze(fx * (w - 1.0), fy * (h - 1.0)).unwrap(),
                )
            })
            .collect();
    let refs: Vec<&dyn FoveationMapping> = maps.iter().map(|m| m.as_ref()).collect();
    ScreenLimits::of(&refs)
}

/// Random colours with depths that vary smoothly with the column (0.4 to 4.4 m) and misses on
/// every 97th row, so that the DOF has near, far and empty pixels.
fn random_samples(mapping: &dyn FoveationMapping, seed: u64) -> SampleBuffers {
    let mut s = SampleBuffers::random(mapping, seed).unwrap();
    for d in &mut s.depth {
        let w = d.width();
        for (k, v) in d.data_mut().iter_mut().enumerate() {
            let (i, j) = (k as u32 % w, k as u32 / w);
            *v = if j % 97 == 0 {
                f32::INFINITY
            } else {
                0.4 + 4.0 * i as f32 / w as f32
            };
        }
    }
    s
}

/// Stage 5 as `fovea_render::pipeline::sample_post::anti_alias` runs it when `cfg` has AA: the
/// filter on the polar grid, then the minified columns restored (footprint filter).
fn cpu_aa(
    mapping: &dyn FoveationMapping,
    mut s: SampleBuffers,
    cfg: &ScreenConfig,
) -> SampleBuffers {
    if let Some(aa) = cfg.aa {
        let layout = mapping.polar_layout().unwrap();
        let grid = Grid::polar(&layout);
        let c = &s.color[0];
        let mut out = match aa {
            SampleFilter::Fxaa(p) => fxaa(c, &grid, &p),
            SampleFilter::Gaussian => gaussian_3x3(c, &grid),
        };
        if cfg.filter == ReconstructFilter::Footprint {
            let keep = minified_columns(mapping).unwrap();
            let bw = c.width() as usize;
            for (k, px) in out.data_mut().iter_mut().enumerate() {
                if keep.get(k % bw).copied().unwrap_or(false) {
                    *px = c.data()[k];
                }
            }
        }
        s.color[0] = out;
    }
    s
}

/// The CPU's chain: reconstruction, then the DOF (with a focus), then the tone map.
fn cpu_chain(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    samples: &SampleBuffers,
    cfg: &ScreenConfig,
    focus: Option<Metres>,
) -> (Image<Rgb>, Image<f32>, Vec<u8>) {
    let (w, h) = (display.width_px, display.height_px);
    let mut color = Image::new(w, h, [0.0f32; 3]).unwrap();
    let mut depth = Image::new(w, h, 0.0f32).unwrap();
    let mut s = cpu_aa(mapping, samples.clone(), cfg);
    reconstruct_into(mapping, display, &mut s, &mut color, &mut depth, cfg.filter).unwrap();
    let post = match (&cfg.dof, focus) {
        (Some(d), Some(f)) => {
            let coc = coc_map(&d.coc, f, &depth).unwrap();
            d.filter
                .apply(&DofInput {
                    color: &color,
                    depth_m: &depth,
                    coc_px: &coc,
                    focus_m: f.0 as f32,
                    px_per_dioptre: 0.0,
                    gaze_px: [0.0, 0.0],
                    px_per_degree: 17.0,
                })
                .unwrap()
        }
        _ => color.clone(),
    };
    let bytes = to_srgb8(&post, cfg.exposure_stops, cfg.curve);
    (color, depth, bytes)
}

/// Luma PSNR of two 8-bit sRGB images (luma of the codes / 255, Rec. 601 weights, as
/// `fovea_eval::metrics::luma_psnr`), dB.
fn luma_psnr(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let luma = |p: &[u8]| (0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64) / 255.0;
    let n = a.len() / 3;
    let mse = a
        .chunks_exact(3)
        .zip(b.chunks_exact(3))
        .map(|(x, y)| (luma(x) - luma(y)).powi(2))
        .sum::<f64>()
        / n as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    }
}

/// The linear reconstruction against the CPU's: max and mean channel difference, share of
/// pixels whose depth differs.
fn linear_diff(gpu: &(Image<Rgb>, Image<f32>), cpu: &(Image<Rgb>, Image<f32>)) -> (f32, f64, f64) {
    let (mut worst, mut sum) = (0.0f32, 0.0f64);
    for (g, c) in gpu.0.data().iter().zip(cpu.0.data()) {
        for k in 0..3 {
            let d = (g[k] - c[k]).abs();
            if d.is_nan() || d > worst {
                worst = if d.is_nan() { f32::INFINITY } else { d };
            }
            sum += d as f64;
        }
    }
    let n = gpu.0.data().len();
    let depths = gpu
        .1
        .data()
        .iter()
        .zip(cpu.1.data())
        .filter(|(g, c)| g.to_bits() != c.to_bits())
        .count();
    (worst, sum / (3 * n) as f64, depths as f64 / n as f64)
}

/// Records one frame of `screen` on `samples`, submits it, and returns the image.
fn frame(
    ctx: &GpuContext,
    screen: &mut ScreenContext,
    samples: &DeviceSamples,
    mapping: &dyn FoveationMapping,
    focus: Option<Metres>,
) -> Vec<u8> {
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    screen
        .record(&mut encoder, samples, &ScreenInput { mapping, focus }, None)
        .unwrap();
    ctx.submit([encoder.finish()]);
    screen.read_srgb8().unwrap()
}

fn check(
    name: &str,
    ctx: &GpuContext,
    screen: &mut ScreenContext,
    mapping: &dyn FoveationMapping,
    samples: &SampleBuffers,
    cfg: &ScreenConfig,
    focus: Option<Metres>,
) {
    let display = display();
    let device = DeviceSamples::for_mapping(ctx, mapping).unwrap();
    device.upload(ctx, samples).unwrap();
    let gpu = frame(ctx, screen, &device, mapping, focus);
    let gpu_linear = screen.read_linear().unwrap();
    let (c, d, cpu) = cpu_chain(mapping, &display, samples, cfg, focus);
    let psnr = luma_psnr(&gpu, &cpu);
    let codes = gpu.iter().zip(&cpu).filter(|(a, b)| a != b).count();
    // The per-call path (the CPU's padded, prefiltered columns uploaded) on the same samples:
    // the resident column pass must give the same screen.
    // (Full resolution has no per-call reconstruction: its samples are the screen.)
    // With AA, on the CPU's anti-aliased samples (the per-call AA equals the CPU's within
    // 1e-5, tests/sample_aa.rs).
    let per_call = match mapping.polar_layout() {
        Some(_) => {
            let f = fovea_gpu::GpuReconstructor::new(ctx)
                .unwrap()
                .reconstruct(
                    mapping,
                    &display,
                    &cpu_aa(mapping, samples.clone(), cfg),
                    cfg.filter,
                )
                .unwrap()
                .0;
            (f.color, f.depth)
        }
        None => (samples.color[0].clone(), samples.depth[0].clone()),
    };
    let (same_max, _, same_depths) = linear_diff(&gpu_linear, &per_call);
    let peak = c
        .data()
        .iter()
        .flatten()
        .fold(1.0f32, |m, &v| m.max(v.abs()));
    let (max, mean, depths) = linear_diff(&gpu_linear, &(c, d));
    println!(
        "{name}: luma PSNR {psnr:.2} dB ({codes} of {} codes differ); linear vs CPU: max \
         {max:.2e} (peak value {peak:.2}), mean {mean:.2e}, depth differs at {:.4} % of pixels; \
         vs the per-call GPU path: max {same_max:.2e}, depth {:.4} %; DOF {}",
        gpu.len(),
        depths * 100.0,
        same_depths * 100.0,
        screen.last_ran_dof()
    );
    assert!(psnr >= PSNR_MIN_DB, "{name}: {psnr} dB");
    // The per-call bounds hold for colours in [0, 1) (a coordinate off by 1/64 texel moves
    // a value by at most 1/64 of its neighbours' difference); scaled by the peak for HDR.
    assert!(max <= (2.0 / 64.0 + 2e-3) * peak, "{name}: max {max}");
    assert!(mean <= 1.5e-3 * f64::from(peak), "{name}: mean {mean}");
    assert!(depths <= 0.01, "{name}: depths {depths}");
    assert!(
        same_max <= 1e-5 * peak,
        "{name}: {same_max} from the per-call path"
    );
    assert_eq!(same_depths, 0.0, "{name}");
}

#[test]
fn vafr_screen_side_equals_the_cpu_chain_on_random_samples() {
    let Some(ctx) = common::gpu_or_skip("vafr_screen_side_equals_the_cpu_chain_on_random_samples")
    else {
        return;
    };
    let display = display();
    let limits = limits(&display);
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let gazes = [("centre", w / 2.0, h / 2.0), ("corner", 0.08 * w, 0.9 * h)];
    for filter in [ReconstructFilter::Footprint, ReconstructFilter::Bilinear] {
        for dof in [None, Some(dof_of(&display))] {
            let cfg = config(filter, dof.clone());
            let mut screen =
                ScreenContext::new(&ctx, &display, Method::Vafr, cfg.clone(), limits).unwrap();
            for (k, &(gname, gx, gy)) in gazes.iter().enumerate() {
                let mapping = vafr(&display, display.gaze(gx, gy).unwrap());
                let samples = random_samples(mapping.as_ref(), 7 + k as u64);
                let focus = dof.as_ref().map(|_| Metres(1.2));
                let name = format!("random {filter:?} dof={} {gname}", dof.is_some());
                check(
                    &name,
                    &ctx,
                    &mut screen,
                    mapping.as_ref(),
                    &samples,
                    &cfg,
                    focus,
                );
            }
        }
    }
}

#[test]
fn the_other_polar_mappings_equal_the_cpu_chain() {
    let Some(ctx) = common::gpu_or_skip("the_other_polar_mappings_equal_the_cpu_chain") else {
        return;
    };
    let display = display();
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    for method in [Method::Kfr, Method::Lafr, Method::VisualPolar] {
        let at = |x: f64, y: f64| {
            build(
                method,
                &display,
                display.gaze(x, y).unwrap(),
                &MappingConfig::default(),
            )
            .unwrap()
        };
        let corners: Vec<Box<dyn FoveationMapping>> =
            [(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]
                .iter()
                .map(|&(fx, fy)| at(fx * (w - 1.0), fy * (h - 1.0)))
                .collect();
        let refs: Vec<&dyn FoveationMapping> = corners.iter().map(|m| m.as_ref()).collect();
        let cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
        let mut screen =
            ScreenContext::new(&ctx, &display, method, cfg.clone(), ScreenLimits::of(&refs))
                .unwrap();
        let mapping = at(0.3 * w, 0.6 * h);
        let samples = random_samples(mapping.as_ref(), 21);
        check(
            &format!("{method} off-centre"),
            &ctx,
            &mut screen,
            mapping.as_ref(),
            &samples,
            &cfg,
            Some(Metres(1.5)),
        );
    }
}

#[test]
fn sample_space_aa_on_the_device_equals_the_cpus() {
    let Some(ctx) = common::gpu_or_skip("sample_space_aa_on_the_device_equals_the_cpus") else {
        return;
    };
    let display = display();
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    for (method, aa) in [
        (Method::Vafr, SampleFilter::Fxaa(FxaaParams::default())),
        (Method::Kfr, SampleFilter::Gaussian),
    ] {
        let at = |x: f64, y: f64| {
            build(
                method,
                &display,
                display.gaze(x, y).unwrap(),
                &MappingConfig::default(),
            )
            .unwrap()
        };
        let corners: Vec<Box<dyn FoveationMapping>> =
            [(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]
                .iter()
                .map(|&(fx, fy)| at(fx * (w - 1.0), fy * (h - 1.0)))
                .collect();
        let refs: Vec<&dyn FoveationMapping> = corners.iter().map(|m| m.as_ref()).collect();
        for filter in [ReconstructFilter::Footprint, ReconstructFilter::Bilinear] {
            let mut cfg = config(filter, Some(dof_of(&display)));
            cfg.aa = Some(aa);
            let mut screen =
                ScreenContext::new(&ctx, &display, method, cfg.clone(), ScreenLimits::of(&refs))
                    .unwrap();
            for (gname, gx, gy) in [("centre", 0.5 * w, 0.5 * h), ("corner", 0.1 * w, 0.85 * h)] {
                let mapping = at(gx, gy);
                let samples = random_samples(mapping.as_ref(), 31);
                check(
                    &format!("{method} AA {aa:?} {filter:?} {gname}"),
                    &ctx,
                    &mut screen,
                    mapping.as_ref(),
                    &samples,
                    &cfg,
                    Some(Metres(1.5)),
                );
            }
        }
    }
}

#[test]
fn vafr_screen_side_equals_the_cpu_chain_on_a_rendered_frame() {
    use fovea_render::bvh::Backend;
    use fovea_render::camera::EyeCamera;
    use fovea_render::pipeline::{render_frame, FrameSettings};
    use fovea_render::scene::builtin;
    use fovea_render::shade::ShadingMode;
    use fovea_render::world::World;
    let Some(ctx) =
        common::gpu_or_skip("vafr_screen_side_equals_the_cpu_chain_on_a_rendered_frame")
    else {
        return;
    };
    let display = display();
    let scene = builtin::depth_range().unwrap();
    let cam = EyeCamera::from_desc(&scene.cameras[0], &display).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let limits = limits(&display);
    let cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
    let mut screen = ScreenContext::new(&ctx, &display, Method::Vafr, cfg.clone(), limits).unwrap();
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    for (gname, gx, gy) in [("centre", w / 2.0, h / 2.0), ("corner", 0.1 * w, 0.12 * h)] {
        let gaze = display.gaze(gx, gy).unwrap();
        let mut s = FrameSettings::new(Method::Vafr);
        s.shading = ShadingMode::NOISE_FREE;
        s.periphery_rays = 1;
        s.keep_samples = true;
        let f = render_frame(&world, &cam, &s, gaze, &|_, _| {}).unwrap();
        let samples = f.samples.expect("kept samples");
        let mapping = build(Method::Vafr, &display, gaze, &s.mapping).unwrap();
        for focus in [None, Some(Metres(0.8))] {
            let name = format!("rendered {gname} focus={focus:?}");
            check(
                &name,
                &ctx,
                &mut screen,
                mapping.as_ref(),
                &samples,
                &cfg,
                focus,
            );
        }
    }
}

#[test]
fn a_steady_state_frame_creates_nothing_and_reads_nothing_back() {
    let Some(ctx) =
        common::gpu_or_skip("a_steady_state_frame_creates_nothing_and_reads_nothing_back")
    else {
        return;
    };
    let display = display();
    let limits = limits(&display);
    let mut cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
    cfg.aa = Some(SampleFilter::Fxaa(FxaaParams::default()));
    let mut screen = ScreenContext::new(&ctx, &display, Method::Vafr, cfg.clone(), limits).unwrap();
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    // A saccade-sized step mirrored about the screen's vertical centre line: the farthest
    // corner is as far from both gazes, so the screen-covering buffer keeps its size and the
    // frame's sample buffers are reused (a resized buffer is the sample side's reallocation).
    let first = vafr(&display, display.gaze(0.5 * w - 160.0, 0.45 * h).unwrap());
    let second = vafr(&display, display.gaze(0.5 * w + 160.0, 0.45 * h).unwrap());
    assert_eq!(first.buffers(), second.buffers());
    let device = DeviceSamples::for_mapping(&ctx, first.as_ref()).unwrap();
    device
        .upload(&ctx, &random_samples(first.as_ref(), 1))
        .unwrap();
    let focus = Some(Metres(1.0));
    frame(&ctx, &mut screen, &device, first.as_ref(), focus);

    let samples = random_samples(second.as_ref(), 2);
    device.upload(&ctx, &samples).unwrap();
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    let before = ctx.traffic();
    let t = std::time::Instant::now();
    screen
        .record(
            &mut encoder,
            &device,
            &ScreenInput {
                mapping: second.as_ref(),
                focus,
            },
            None,
        )
        .unwrap();
    let host_ms = t.elapsed().as_secs_f64() * 1e3;
    let moved = ctx.traffic().since(&before);
    let tables = screen.last_table_upload();
    let (lut_bytes, column_bytes) = screen.table_bytes();
    println!(
        "steady-state frame (gaze moved 320 px): {moved:?}; tables rebuilt {}, sent {} B of \
         u(r) ({lut_bytes} B held) and {} B of columns ({column_bytes} B held); recording {host_ms:.2} ms",
        tables.rebuilt, tables.lut_bytes, tables.column_bytes
    );
    assert_eq!(moved.buffers_created, 0, "{moved:?}");
    assert_eq!(moved.bind_groups_created, 0, "{moved:?}");
    assert_eq!(moved.bytes_read_back, 0, "{moved:?}");
    assert_eq!(moved.buffer_maps, 0, "{moved:?}");
    assert_eq!(moved.blocking_waits, 0, "{moved:?}");
    assert_eq!(moved.submissions, 0, "{moved:?}");
    assert!(moved.bytes_uploaded <= STEADY_UPLOAD_MAX, "{moved:?}");
    assert!(moved.bytes_uploaded > 0, "the uniforms go up: {moved:?}");
    ctx.submit([encoder.finish()]);
    let gpu = screen.read_srgb8().unwrap();
    let (_, _, cpu) = cpu_chain(second.as_ref(), &display, &samples, &cfg, focus);
    let psnr = luma_psnr(&gpu, &cpu);
    println!("steady-state frame: luma PSNR {psnr:.2} dB");
    assert!(psnr >= PSNR_MIN_DB, "{psnr}");

    // The same mapping again: nothing but the uniforms goes up.
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    let before = ctx.traffic();
    screen
        .record(
            &mut encoder,
            &device,
            &ScreenInput {
                mapping: second.as_ref(),
                focus,
            },
            None,
        )
        .unwrap();
    let moved = ctx.traffic().since(&before);
    println!("same gaze again: {} B uploaded", moved.bytes_uploaded);
    assert!(!screen.last_table_upload().rebuilt);
    assert!(moved.bytes_uploaded <= 256, "{moved:?}");

    // A gaze that changes the buffer's size (centre to corner): what the tables then send.
    let corner = vafr(&display, display.gaze(0.1 * w, 0.1 * h).unwrap());
    let device2 = DeviceSamples::for_mapping(&ctx, corner.as_ref()).unwrap();
    device2
        .upload(&ctx, &random_samples(corner.as_ref(), 3))
        .unwrap();
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    let before = ctx.traffic();
    screen
        .record(
            &mut encoder,
            &device2,
            &ScreenInput {
                mapping: corner.as_ref(),
                focus,
            },
            None,
        )
        .unwrap();
    let moved = ctx.traffic().since(&before);
    let tables = screen.last_table_upload();
    println!(
        "gaze to a corner (buffer {:?} -> {:?}): {} B uploaded ({} B u(r), {} B columns), {} \
         bind groups (the new sample buffer's), {} buffers",
        second.buffers(),
        corner.buffers(),
        moved.bytes_uploaded,
        tables.lut_bytes,
        tables.column_bytes,
        moved.bind_groups_created,
        moved.buffers_created
    );
    assert_eq!(moved.buffers_created, 0);
    ctx.submit([encoder.finish()]);
}

#[test]
fn timestamps_arrive_late_without_waiting() {
    let Some(ctx) = common::gpu_or_skip("timestamps_arrive_late_without_waiting") else {
        return;
    };
    let display = display();
    let limits = limits(&display);
    let mut cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
    cfg.aa = Some(SampleFilter::Fxaa(FxaaParams::default()));
    let mut screen = ScreenContext::new(&ctx, &display, Method::Vafr, cfg, limits).unwrap();
    let Some(mut timer) = FrameTimer::new(&ctx, &SCREEN_PASSES, 3).unwrap() else {
        println!("the device has no timestamps: nothing to check");
        return;
    };
    let mapping = vafr(&display, display.gaze(700.0, 800.0).unwrap());
    let device = DeviceSamples::for_mapping(&ctx, mapping.as_ref()).unwrap();
    device
        .upload(&ctx, &random_samples(mapping.as_ref(), 5))
        .unwrap();
    let mut got = Vec::new();
    for k in 0..8 {
        let before = ctx.traffic();
        let mut encoder = ctx
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        timer.begin_frame();
        screen
            .record(
                &mut encoder,
                &device,
                &ScreenInput {
                    mapping: mapping.as_ref(),
                    focus: (k % 2 == 0).then_some(Metres(1.0)),
                },
                Some(&mut timer),
            )
            .unwrap();
        timer.end_frame(&mut encoder);
        ctx.submit([encoder.finish()]);
        timer.submitted();
        got.extend(timer.poll().unwrap());
        let moved = ctx.traffic().since(&before);
        assert_eq!(moved.blocking_waits, 0, "frame {k}: {moved:?}");
        assert_eq!(moved.buffers_created, 0, "frame {k}: {moved:?}");
    }
    // Let the last frames finish (a test may wait; a renderer would poll on its next frame).
    ctx.wait_idle("the timed frames").unwrap();
    got.extend(timer.poll().unwrap());
    println!("untimed frames (ring full): {}", timer.untimed_frames());
    for t in &got {
        println!("frame {}: {:?}", t.frame, t.passes);
    }
    assert!(!got.is_empty());
    for t in &got {
        let dof = t.passes.iter().find(|p| p.0 == "dof").unwrap().1;
        assert_eq!(dof.is_some(), t.frame % 2 == 0, "frame {}", t.frame);
        for (name, ms) in &t.passes {
            if let Some(ms) = ms {
                assert!(ms.is_finite() && *ms >= 0.0, "{name}: {ms}");
            }
        }
    }
}

#[test]
fn the_presenter_texture_holds_the_tone_mapped_frame() {
    let Some(ctx) = common::gpu_or_skip("the_presenter_texture_holds_the_tone_mapped_frame") else {
        return;
    };
    let display = display();
    let limits = limits(&display);
    let mut cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
    cfg.texture = true;
    let mut screen = ScreenContext::new(&ctx, &display, Method::Vafr, cfg, limits).unwrap();
    let mapping = vafr(&display, display.gaze(600.0, 900.0).unwrap());
    let device = DeviceSamples::for_mapping(&ctx, mapping.as_ref()).unwrap();
    device
        .upload(&ctx, &random_samples(mapping.as_ref(), 41))
        .unwrap();
    let before = ctx.traffic();
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    screen
        .record(
            &mut encoder,
            &device,
            &ScreenInput {
                mapping: mapping.as_ref(),
                focus: Some(Metres(1.0)),
            },
            None,
        )
        .unwrap();
    let moved = ctx.traffic().since(&before);
    assert_eq!(moved.bytes_read_back, 0);
    assert_eq!(moved.submissions, 0);
    // The texture read back with the test's own (uncounted) buffer.
    let (w, h) = (display.width_px, display.height_px);
    let row = (4 * w).div_ceil(256) * 256;
    let read = ctx.device().create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: u64::from(row) * u64::from(h),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        screen.texture().unwrap().as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &read,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    ctx.submit([encoder.finish()]);
    let rgb = screen.read_srgb8().unwrap();
    read.map_async(wgpu::MapMode::Read, .., |r| r.unwrap());
    ctx.wait_idle("the texture's readback").unwrap();
    let texels = read.get_mapped_range(..).unwrap().to_vec();
    let mut differ = 0usize;
    for y in 0..h as usize {
        for x in 0..w as usize {
            let t = &texels[y * row as usize + 4 * x..][..4];
            let c = &rgb[3 * (y * w as usize + x)..][..3];
            if t[..3] != *c || t[3] != 255 {
                differ += 1;
            }
        }
    }
    println!(
        "presenter texture: {differ} of {} pixels differ from read_srgb8",
        w * h
    );
    assert_eq!(differ, 0);
}

#[test]
fn both_eyes_record_into_one_encoder_and_one_submission() {
    let Some(ctx) = common::gpu_or_skip("both_eyes_record_into_one_encoder_and_one_submission")
    else {
        return;
    };
    let display = display();
    let limits = limits(&display);
    let cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
    // Each eye its own context, samples and gaze (the eyes' gazes differ by vergence).
    let eyes = [(640.0, 780.0, 51u64), (700.0, 780.0, 52u64)];
    let mut screens: Vec<ScreenContext> = eyes
        .iter()
        .map(|_| ScreenContext::new(&ctx, &display, Method::Vafr, cfg.clone(), limits).unwrap())
        .collect();
    let mappings: Vec<Box<dyn FoveationMapping>> = eyes
        .iter()
        .map(|&(x, y, _)| vafr(&display, display.gaze(x, y).unwrap()))
        .collect();
    let samples: Vec<SampleBuffers> = eyes
        .iter()
        .zip(&mappings)
        .map(|(&(_, _, seed), m)| random_samples(m.as_ref(), seed))
        .collect();
    let devices: Vec<DeviceSamples> = mappings
        .iter()
        .zip(&samples)
        .map(|(m, s)| {
            let d = DeviceSamples::for_mapping(&ctx, m.as_ref()).unwrap();
            d.upload(&ctx, s).unwrap();
            d
        })
        .collect();
    let focus = Some(Metres(1.1));
    let before = ctx.traffic();
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("binocular screen side"),
        });
    for ((screen, device), m) in screens.iter_mut().zip(&devices).zip(&mappings) {
        screen
            .record(
                &mut encoder,
                device,
                &ScreenInput {
                    mapping: m.as_ref(),
                    focus,
                },
                None,
            )
            .unwrap();
    }
    ctx.submit([encoder.finish()]);
    let moved = ctx.traffic().since(&before);
    println!("both eyes: {moved:?}");
    assert_eq!(moved.submissions, 1, "{moved:?}");
    assert_eq!(moved.bytes_read_back, 0, "{moved:?}");
    assert_eq!(moved.blocking_waits, 0, "{moved:?}");
    for (k, ((screen, m), s)) in screens.iter_mut().zip(&mappings).zip(&samples).enumerate() {
        let gpu = screen.read_srgb8().unwrap();
        let (_, _, cpu) = cpu_chain(m.as_ref(), &display, s, &cfg, focus);
        let psnr = luma_psnr(&gpu, &cpu);
        println!("eye {k}: luma PSNR {psnr:.2} dB");
        assert!(psnr >= PSNR_MIN_DB, "eye {k}: {psnr}");
    }
}

#[test]
fn unsupported_methods_and_mismatched_frames_are_refused_before_recording() {
    let Some(ctx) = common::gpu_or_skip("unsupported_methods_and_mismatched_frames_are_refused")
    else {
        return;
    };
    let display = display();
    let limits = limits(&display);
    let cfg = config(ReconstructFilter::Footprint, None);
    // Weier's pull-push, and sample-space AA on Guenter's layers.
    let with_aa = ScreenConfig {
        aa: Some(SampleFilter::Gaussian),
        ..cfg.clone()
    };
    for (method, c) in [(Method::Weier, cfg.clone()), (Method::Guenter, with_aa)] {
        let e = ScreenContext::new(&ctx, &display, method, c, limits)
            .err()
            .unwrap();
        assert!(matches!(e, GpuError::Unsupported(_)), "{method}: {e}");
        assert!(!e.to_string().contains('\n'));
    }
    let mut screen = ScreenContext::new(&ctx, &display, Method::Vafr, cfg, limits).unwrap();
    let gaze = display.gaze(700.0, 800.0).unwrap();
    let kfr = build(Method::Kfr, &display, gaze, &MappingConfig::default()).unwrap();
    let device = DeviceSamples::for_mapping(&ctx, kfr.as_ref()).unwrap();
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    let before = ctx.traffic();
    let e = screen
        .record(
            &mut encoder,
            &device,
            &ScreenInput {
                mapping: kfr.as_ref(),
                focus: None,
            },
            None,
        )
        .unwrap_err();
    assert!(matches!(e, GpuError::Unsupported(_)), "{e}");
    // A VaFR mapping with another mapping's sample buffers: an input error, nothing sent.
    let v = vafr(&display, gaze);
    let e = screen
        .record(
            &mut encoder,
            &device,
            &ScreenInput {
                mapping: v.as_ref(),
                focus: None,
            },
            None,
        )
        .unwrap_err();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    let moved = ctx.traffic().since(&before);
    assert_eq!(moved.bytes_uploaded, 0, "{moved:?}");
    assert!(!screen.fits(kfr.as_ref()));
    assert!(screen.fits(v.as_ref()));
}

#[test]
fn full_resolution_samples_are_the_screen() {
    let Some(ctx) = common::gpu_or_skip("full_resolution_samples_are_the_screen") else {
        return;
    };
    let display = display();
    let gaze = display.gaze(500.0, 600.0).unwrap();
    let full = build(Method::Full, &display, gaze, &MappingConfig::default()).unwrap();
    let limits = ScreenLimits::of(&[full.as_ref()]);
    let cfg = config(ReconstructFilter::Footprint, Some(dof_of(&display)));
    let mut screen = ScreenContext::new(&ctx, &display, Method::Full, cfg.clone(), limits).unwrap();
    for focus in [None, Some(Metres(0.9))] {
        let samples = random_samples(full.as_ref(), 11);
        check(
            &format!("full focus={focus:?}"),
            &ctx,
            &mut screen,
            full.as_ref(),
            &samples,
            &cfg,
            focus,
        );
    }
}
