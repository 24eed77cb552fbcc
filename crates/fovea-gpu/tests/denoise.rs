//! The GPU denoiser against its CPU twin `fovea_post::denoise::denoise` (issue 38: "CPU and
//! GPU versions agree (≥ 40 dB)"), on lavapipe or any adapter:
//!
//! * on the real inputs of a frame — the built-in scene with the default indirect shading
//!   (Monte Carlo noise in every sample), its G-buffer guides and its Monte Carlo part,
//!   captured from the pipeline by a recording executor — for VaFR's polar buffer (the filter
//!   wraps around the angle axis and crosses the fovea half a turn on) and the
//!   full-resolution screen, with both kernels; PSNR of the display-encoded luma ≥ 40 dB, the
//!   same texels filtered;
//! * on a small synthetic polar grid whose every tap at steps up to 32 crosses a seam;
//! * a second `record` over the same buffers creates no buffer and no bind group;
//! * the frame through `render_planned` with the GPU executor plugged in reports the `gpu`
//!   denoise backend and matches the CPU's frame (≥ 40 dB).

mod common;

use std::sync::{Arc, Mutex};

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{BufferSize, Method};
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_gpu::executors::GpuDenoiseExecutor;
use fovea_gpu::frame::DeviceSamples;
use fovea_gpu::{DeviceGuides, GpuContext, GpuDenoiser};
use fovea_post::denoise::{DenoiseGuides, DenoiseParams, DenoiseScratch, DenoiseStats, Kernel};
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{
    plan_frame, render_planned, DenoiseExecutor, Frame, FrameContext, FrameInputs, FrameSettings,
};
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::world::World;

/// The inputs the pipeline handed its denoiser.
type Inputs = (SampleBuffers, DenoiseGuides, Vec<Grid>, DenoiseParams);

/// A denoise executor that records its inputs and filters on the CPU.
struct Capture {
    inputs: Arc<Mutex<Option<Inputs>>>,
}

impl DenoiseExecutor for Capture {
    fn backend(&self) -> &str {
        "capture"
    }
    fn supports(&self, _: &[(u32, u32)]) -> bool {
        true
    }
    fn denoise(
        &mut self,
        params: &DenoiseParams,
        grids: &[Grid],
        samples: &mut SampleBuffers,
        guides: &DenoiseGuides,
    ) -> Result<DenoiseStats, String> {
        *self.inputs.lock().unwrap() =
            Some((samples.clone(), guides.clone(), grids.to_vec(), *params));
        Ok(cpu_denoise(samples, guides, grids, params))
    }
}

fn cpu_denoise(
    samples: &mut SampleBuffers,
    guides: &DenoiseGuides,
    grids: &[Grid],
    params: &DenoiseParams,
) -> DenoiseStats {
    let mut scratch = DenoiseScratch::default();
    let mut stats = DenoiseStats::default();
    for (l, ((c, d), grid)) in samples
        .color
        .iter_mut()
        .zip(&samples.depth)
        .zip(grids)
        .enumerate()
    {
        stats += fovea_post::denoise::denoise_with_variance(
            c,
            d,
            &guides.albedo[l],
            &guides.normal[l],
            guides.noisy.get(l),
            guides.variance.get(l),
            grid,
            params,
            &mut scratch,
        )
        .unwrap();
    }
    stats
}

fn setup(w: u32, h: u32) -> (World, EyeCamera) {
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let d = DisplayProfile::new("t", w, h, Degrees(100.0), Degrees(110.0)).unwrap();
    let camera = EyeCamera::from_desc(&world.scene.cameras[0], &d).unwrap();
    (world, camera)
}

fn settings(method: Method, params: DenoiseParams) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = ShadingMode::DEFAULT;
    s.denoise = Some(params);
    s
}

fn render(
    ctx: &mut FrameContext,
    world: &World,
    camera: &EyeCamera,
    s: &FrameSettings,
    gaze_px: (f64, f64),
) -> Frame {
    let gaze = camera.display.gaze(gaze_px.0, gaze_px.1).unwrap();
    let (plan, times) = plan_frame(world, camera, s, gaze, [0.0, 0.0]).unwrap();
    render_planned(
        ctx,
        world,
        camera,
        &plan,
        FrameInputs::default(),
        times,
        &|_, _| {},
    )
    .unwrap()
    .clone()
}

/// Display-encoded luma of a linear colour (clamped to [0, 1], gamma 2.2).
fn encoded_luma(c: &Rgb) -> f64 {
    let y = (0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]).clamp(0.0, 1.0) as f64;
    y.powf(1.0 / 2.2)
}

/// PSNR of the display-encoded luma (peak 1) of `a` against `b` over the texels `keep`
/// accepts where both are finite, dB (∞ when equal), and the largest absolute difference in
/// linear colour.
fn psnr(a: &[Rgb], b: &[Rgb], keep: impl Fn(usize) -> bool) -> (f64, f32) {
    let (mut se, mut n, mut worst) = (0.0f64, 0usize, 0.0f32);
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        let finite = |c: &Rgb| c.iter().all(|v| v.is_finite());
        if !keep(k) || !finite(x) || !finite(y) {
            continue;
        }
        se += (encoded_luma(x) - encoded_luma(y)).powi(2);
        n += 1;
        for ch in 0..3 {
            worst = worst.max((x[ch] - y[ch]).abs());
        }
    }
    let mse = se / n.max(1) as f64;
    (10.0 * (1.0 / mse).log10(), worst)
}

fn sizes_of(samples: &SampleBuffers) -> Vec<BufferSize> {
    samples
        .color
        .iter()
        .map(|c| BufferSize {
            width: c.width(),
            height: c.height(),
        })
        .collect()
}

/// The colours of every layer, one slice.
fn colours(s: &SampleBuffers) -> Vec<Rgb> {
    s.color.iter().flat_map(|c| c.data().to_vec()).collect()
}

/// Whether texel `k` (over all layers) is a surface sample the denoiser filters.
fn surface_mask(s: &SampleBuffers, g: &DenoiseGuides, grids: &[Grid]) -> Vec<bool> {
    let mut mask = Vec::new();
    for (l, d) in s.depth.iter().enumerate() {
        for j in 0..d.height() {
            for i in 0..d.width() {
                let n = *g.normal[l].get(i, j);
                mask.push(grids[l].valid(i, j) && d.get(i, j).is_finite() && n != [0.0; 3]);
            }
        }
    }
    mask
}

/// GPU against CPU on `inputs`: (PSNR GPU vs CPU, PSNR input vs CPU, worst difference).
fn compare(gpu: &GpuContext, inputs: &Inputs, params: &DenoiseParams, what: &str) -> f64 {
    let (samples, guides, grids, _) = inputs;
    let mut cpu_out = samples.clone();
    let cpu_stats = cpu_denoise(&mut cpu_out, guides, grids, params);
    let mut gpu_out = samples.clone();
    let mut denoiser = GpuDenoiser::new(gpu).unwrap();
    let (gpu_stats, t) = denoiser.run(&mut gpu_out, guides, grids, params).unwrap();
    let mask = surface_mask(samples, guides, grids);
    let (c, g, input) = (colours(&cpu_out), colours(&gpu_out), colours(samples));
    let (agree, worst) = psnr(&g, &c, |k| mask[k]);
    let (moved, _) = psnr(&input, &c, |k| mask[k]);
    let (all, _) = psnr(&g, &c, |_| true);
    // Outside the surface samples the GPU leaves every texel exactly as it was.
    for (k, (x, y)) in g.iter().zip(&input).enumerate() {
        if !mask[k] {
            assert_eq!(
                x.map(f32::to_bits),
                y.map(f32::to_bits),
                "{what}: texel {k}"
            );
        }
    }
    // The same texels finite (a NaN receiver refilled on both or neither).
    for (k, (x, y)) in g.iter().zip(&c).enumerate() {
        let finite = |c: &Rgb| c.iter().all(|v| v.is_finite());
        assert_eq!(finite(x), finite(y), "{what}: texel {k}");
    }
    // Depth untouched.
    for (a, b) in gpu_out.depth.iter().zip(&samples.depth) {
        assert_eq!(a.data(), b.data());
    }
    common::shout(&format!(
        "[denoise] {what}: {:?} texels, {} filtered ({} cpu), {} clamped ({} cpu); luma PSNR \
         GPU vs CPU {agree:.1} dB over the surface samples ({all:.1} dB all texels), largest \
         difference {worst:.2e}; the filter itself moved the CPU's frame to {moved:.1} dB of \
         its input; gpu {:.1} ms",
        sizes_of(samples),
        gpu_stats.filtered,
        cpu_stats.filtered,
        gpu_stats.clamped,
        cpu_stats.clamped,
        t.total_ms
    ));
    assert_eq!(gpu_stats.filtered, cpu_stats.filtered, "{what}");
    let dc = gpu_stats.clamped.abs_diff(cpu_stats.clamped) as f64;
    assert!(
        dc <= 0.01 * cpu_stats.clamped.max(100) as f64,
        "{what}: clamped"
    );
    assert!(agree >= 40.0, "{what}: GPU vs CPU only {agree:.2} dB");
    // Not vacuous: the filter changed the frame far more than the two twins differ.
    assert!(moved < agree - 10.0, "{what}: {moved:.1} vs {agree:.1} dB");
    agree
}

fn captured(method: Method, params: DenoiseParams, gaze_px: (f64, f64)) -> Inputs {
    let (world, camera) = setup(160, 180);
    let inputs = Arc::new(Mutex::new(None));
    let mut ctx = FrameContext::new();
    ctx.set_denoiser(Box::new(Capture {
        inputs: inputs.clone(),
    }));
    let f = render(
        &mut ctx,
        &world,
        &camera,
        &settings(method, params),
        gaze_px,
    );
    assert_eq!(f.stats.denoise_backend, "capture");
    let got = inputs.lock().unwrap().take();
    got.expect("the denoiser ran")
}

#[test]
fn gpu_matches_cpu_on_a_vafr_frame_with_indirect_light() {
    let Some(gpu) = common::gpu_or_skip("denoise vafr") else {
        return;
    };
    let mut crossed = 0;
    for (kernel, gaze) in [
        (Kernel::Linear3x3, (80.0, 90.0)),
        (Kernel::B3Spline5x5, (120.0, 60.0)),
    ] {
        let params = DenoiseParams {
            kernel,
            ..DenoiseParams::default()
        };
        let inputs = captured(Method::Vafr, params, gaze);
        assert!(matches!(inputs.2[0], Grid::Polar { .. }));
        // The seams are exercised: surface samples in columns whose taps cross the fovea
        // (column i, a step of more than i columns inwards: the last iteration's step is 8)
        // and in columns whose first and last rows are both surface samples (their taps wrap).
        let Grid::Polar { rows, .. } = &inputs.2[0] else {
            unreachable!()
        };
        let n = &inputs.1.normal[0];
        let surface = |i: u32, j: u32| *n.get(i, j) != [0.0; 3];
        let crossing = (0..8u32)
            .map(|i| (0..rows[i as usize]).filter(|&j| surface(i, j)).count())
            .sum::<usize>();
        let wrapping = (0..rows.len() as u32)
            .filter(|&i| {
                let r = rows[i as usize];
                r > 0 && surface(i, 0) && surface(i, r - 1)
            })
            .count();
        common::shout(&format!(
            "[denoise] VaFR grid: rows of the first columns {:?}; {crossing} surface samples in \
             the 8 innermost columns, {wrapping} columns with surface on both sides of the \
             angular seam",
            &rows[..8]
        ));
        assert!(wrapping > 0);
        crossed += crossing;
        compare(
            &gpu,
            &inputs,
            &params,
            &format!("VaFR, {kernel:?}, gaze {gaze:?}"),
        );
    }
    assert!(crossed > 0, "no surface sample near the fovea's centre");
}

#[test]
fn gpu_matches_cpu_on_a_full_resolution_frame_with_indirect_light() {
    let Some(gpu) = common::gpu_or_skip("denoise full") else {
        return;
    };
    let params = DenoiseParams::default();
    let inputs = captured(Method::Full, params, (80.0, 90.0));
    assert!(matches!(inputs.2[0], Grid::Rect { .. }));
    compare(&gpu, &inputs, &params, "full resolution, Linear3x3");
}

/// A noisy frame on the synthetic polar grid of `fovea_post::denoise`'s own tests: light
/// with multiplicative noise on a checker albedo, a depth slope and a normal crease, a NaN
/// and a firefly, and a Monte Carlo part that is half the colour.
fn synthetic_polar(seed: u64) -> Inputs {
    let rows = vec![6u32, 9, 14, 20, 27, 33, 40, 46, 53, 60];
    let period: Vec<f64> = rows.iter().map(|&r| r as f64 + 0.37).collect();
    let (w, h) = (rows.len() as u32 + 2, 64u32);
    let mut state = seed;
    let mut rand = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        ((state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
    };
    let valid = |i: u32, j: u32| rows.get(i as usize).is_some_and(|&r| j < r);
    let mut color = Image::new(w, h, [0.0f32; 3]).unwrap();
    let mut depth = Image::new(w, h, f32::INFINITY).unwrap();
    let mut albedo = Image::new(w, h, [0.0f32; 3]).unwrap();
    let mut normal = Image::new(w, h, [0.0f32; 3]).unwrap();
    let mut noisy = Image::new(w, h, [f32::NAN; 3]).unwrap();
    for j in 0..h {
        for i in 0..w {
            if !valid(i, j) {
                continue;
            }
            let a = if (i + j / 3) % 2 == 0 {
                [0.8, 0.5, 0.3]
            } else {
                [0.2, 0.4, 0.6]
            };
            let l = 1.0 + 0.8 * (rand() - 0.5);
            let exact = 0.3 * (j % 7) as f32;
            let c: Rgb = std::array::from_fn(|k| l * a[k] + exact);
            *color.get_mut(i, j) = c;
            *albedo.get_mut(i, j) = a;
            *depth.get_mut(i, j) = 2.0 + 0.05 * i as f32;
            *normal.get_mut(i, j) = if j < rows[i as usize] / 2 {
                [0.0, 0.0, 1.0]
            } else {
                [0.0, 0.6, 0.8]
            };
            // Every third texel's part unknown (the whole colour filtered).
            if (i * 7 + j) % 3 != 0 {
                *noisy.get_mut(i, j) = std::array::from_fn(|k| l * a[k]);
            }
        }
    }
    *color.get_mut(3, 5) = [40.0; 3];
    *color.get_mut(5, 11) = [f32::NAN, 0.2, 0.2];
    let samples = SampleBuffers {
        color: vec![color],
        depth: vec![depth],
    };
    let guides = DenoiseGuides {
        albedo: vec![albedo],
        normal: vec![normal],
        noisy: vec![noisy],
        variance: Vec::new(),
    };
    let grids = vec![Grid::Polar { rows, period }];
    (samples, guides, grids, DenoiseParams::default())
}

#[test]
fn gpu_matches_cpu_across_the_polar_seams_at_every_step() {
    let Some(gpu) = common::gpu_or_skip("denoise synthetic polar") else {
        return;
    };
    for (kernel, iterations, sigma_luminance) in [
        (Kernel::Linear3x3, 6, 4.0),
        (Kernel::B3Spline5x5, 6, 4.0),
        (Kernel::B3Spline5x5, 2, 0.5),
    ] {
        let params = DenoiseParams {
            kernel,
            iterations,
            sigma_luminance,
            ..DenoiseParams::default()
        };
        let inputs = synthetic_polar(7);
        compare(
            &gpu,
            &inputs,
            &params,
            &format!("synthetic polar, {kernel:?} x{iterations}, sigma_l {sigma_luminance}"),
        );
    }
    // With no Monte Carlo part (noise-free shading) the colours come back bit for bit.
    let (mut samples, mut guides, grids, params) = synthetic_polar(9);
    *samples.color[0].get_mut(5, 11) = [0.5; 3];
    guides.noisy[0] = Image::new(12, 64, [0.0; 3]).unwrap();
    let before = samples.clone();
    GpuDenoiser::new(&gpu)
        .unwrap()
        .run(&mut samples, &guides, &grids, &params)
        .unwrap();
    for (a, b) in samples.color[0].data().iter().zip(before.color[0].data()) {
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
    }
}

#[test]
fn gpu_reads_the_temporal_variance_as_the_cpu() {
    let Some(gpu) = common::gpu_or_skip("denoise temporal variance") else {
        return;
    };
    // A temporal variance per texel, as `SampleHistory` gives it: none (NaN) on every fifth
    // texel (the spatial estimate), zero on every seventh (a converged history: the filter
    // stops at every luminance difference), a negative one (none) on one, else large (the
    // filter runs across the noise).
    let (samples, mut guides, grids, params) = synthetic_polar(11);
    let (w, h) = (samples.color[0].width(), samples.color[0].height());
    let mut variance = Image::new(w, h, 0.0f32).unwrap();
    for j in 0..h {
        for i in 0..w {
            let k = j * w + i;
            *variance.get_mut(i, j) = match (k % 5, k % 7) {
                (0, _) => f32::NAN,
                (_, 0) => 0.0,
                _ => 0.5 + 0.01 * (k % 13) as f32,
            };
        }
    }
    *variance.get_mut(2, 3) = -1.0;
    let spatial = guides.clone();
    guides.variance = vec![variance];
    let inputs = (samples, guides, grids, params);
    compare(&gpu, &inputs, &params, "synthetic polar, temporal variance");
    // Not vacuous: the given variance moves the CPU's frame away from the spatial one's.
    let (samples, guides, grids, _) = &inputs;
    let (mut with, mut without) = (samples.clone(), samples.clone());
    cpu_denoise(&mut with, guides, grids, &params);
    cpu_denoise(&mut without, &spatial, grids, &params);
    let mask = surface_mask(samples, guides, grids);
    let (apart, _) = psnr(&colours(&with), &colours(&without), |k| mask[k]);
    common::shout(&format!(
        "[denoise] the temporal variance moved the CPU's frame to {apart:.1} dB of the spatial \
         estimate's"
    ));
    assert!(apart < 40.0, "the variance changed little: {apart:.1} dB");
}

#[test]
fn a_second_record_creates_no_buffers_and_no_bind_groups() {
    let Some(gpu) = common::gpu_or_skip("denoise counters") else {
        return;
    };
    let (samples, guides, grids, params) = synthetic_polar(3);
    let sizes = sizes_of(&samples);
    let dev_samples = DeviceSamples::new(&gpu, &sizes).unwrap();
    let dev_guides = DeviceGuides::new(&gpu, &sizes).unwrap();
    dev_samples.upload(&gpu, &samples).unwrap();
    dev_guides.upload(&gpu, &guides).unwrap();
    let mut denoiser = GpuDenoiser::new(&gpu).unwrap();
    let mut record = || {
        let before = gpu.traffic();
        let mut encoder = gpu
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        denoiser
            .record(&mut encoder, &dev_samples, &dev_guides, &grids, &params)
            .unwrap();
        gpu.queue().submit([encoder.finish()]);
        gpu.wait_idle("denoise").unwrap();
        gpu.traffic().since(&before)
    };
    let first = record();
    let second = record();
    let third = record();
    common::shout(&format!(
        "[denoise] record: first call {} buffers, {} bind groups; second {} and {}",
        first.buffers_created,
        first.bind_groups_created,
        second.buffers_created,
        second.bind_groups_created
    ));
    assert!(first.buffers_created > 0 && first.bind_groups_created > 0);
    for t in [second, third] {
        assert_eq!(t.buffers_created, 0);
        assert_eq!(t.bind_groups_created, 0);
    }
    // The recorded passes filtered the device's buffers as the CPU filters its own.
    let out = dev_samples.read(&gpu).unwrap();
    let mut cpu = samples.clone();
    // Three passes: the device buffer was filtered three times.
    for _ in 0..3 {
        cpu_denoise(&mut cpu, &guides, &grids, &params);
    }
    let mask = surface_mask(&samples, &guides, &grids);
    let (agree, _) = psnr(&colours(&out), &colours(&cpu), |k| mask[k]);
    assert!(agree >= 40.0, "{agree}");
}

#[test]
fn the_frame_with_the_gpu_denoiser_reports_it_and_matches_the_cpu() {
    let Some(gpu) = common::gpu_or_skip("denoise frame") else {
        return;
    };
    let (world, camera) = setup(160, 180);
    for method in [Method::Vafr, Method::Full] {
        let s = settings(method, DenoiseParams::default());
        let mut cpu_ctx = FrameContext::new();
        let cpu = render(&mut cpu_ctx, &world, &camera, &s, (70.0, 100.0));
        let mut gpu_ctx = FrameContext::new();
        let executor = GpuDenoiseExecutor::new(&gpu).unwrap();
        let times = executor.times();
        gpu_ctx.set_denoiser(Box::new(executor));
        let on_gpu = render(&mut gpu_ctx, &world, &camera, &s, (70.0, 100.0));
        let mut off = s.clone();
        off.denoise = None;
        let raw = render(
            &mut FrameContext::new(),
            &world,
            &camera,
            &off,
            (70.0, 100.0),
        );
        assert_eq!(cpu.stats.denoise_backend, "cpu");
        assert_eq!(on_gpu.stats.denoise_backend, "gpu");
        assert_eq!(
            on_gpu.stats.denoise,
            cpu.stats.denoise.map(|d| DenoiseStats {
                clamped: on_gpu.stats.denoise.unwrap().clamped,
                ..d
            })
        );
        let t = times.lock().unwrap().expect("the GPU denoiser ran");
        let (agree, worst) = psnr(on_gpu.color.data(), cpu.color.data(), |_| true);
        let (moved, _) = psnr(raw.color.data(), cpu.color.data(), |_| true);
        common::shout(&format!(
            "[denoise] {method} frame {}x{}: luma PSNR GPU vs CPU denoiser {agree:.1} dB \
             (largest difference {worst:.2e}); without denoising {moved:.1} dB; gpu stage \
             {:.1} ms (upload {:.1}, run and readback {:.1})",
            cpu.color.width(),
            cpu.color.height(),
            t.total_ms,
            t.upload_ms,
            t.run_and_readback_ms
        ));
        assert!(agree >= 40.0, "{method}: {agree:.2} dB");
        assert!(moved < agree - 10.0, "{method}: {moved:.1} vs {agree:.1}");
    }
}
