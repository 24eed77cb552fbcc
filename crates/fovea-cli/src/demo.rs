//! `fovea demo`: what a new user runs first. The built-in scene on a headset preset, along a
//! short built-in gaze trajectory (fixation, pursuit, saccade), VaFR foveation with auto focus
//! through the accommodation filter and the default DOF filter; writes the frames, the
//! full-resolution reference of the middle frame, a side-by-side, a sample-density overlay and
//! `index.html` to the output folder.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use fovea_core::mapping::Method;
use fovea_core::optics::AccommodationParams;
use fovea_core::Image;
use fovea_eval::experiments::scenario::GazeScenario;
use fovea_post::dof::FilterKind;
use fovea_post::tonemap::ToneCurve;
use fovea_post::Rgb;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::dof::{DofSettings, FocusMode};
use fovea_render::pipeline::{density_view, render_for_eye, FrameSettings};
use fovea_render::plan::FramePlan;
use fovea_render::scene::builtin;
use fovea_render::sequence::{Sequence, SequenceDriver, Track};
use fovea_render::world::World;

use crate::choices::{BackendArg, Headset};
use crate::common::preset;
use crate::output::{difference_map, html_escape, mark_ring, side_by_side, write_rgb, zoomed_crop};
use crate::sequence::gaze_trajectory;

/// Options of `fovea demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Headset or resolution preset.
    #[arg(long, value_enum, ignore_case = true, default_value_t = Headset::VivePro)]
    pub headset: Headset,
    /// Frames along the built-in gaze trajectory (30 per second of gaze).
    #[arg(long, default_value_t = 12)]
    pub frames: u32,
    /// Temporal accumulation of the foveated frames (reprojection of the previous frame,
    /// default settings): on (default) or off.
    #[arg(long, value_enum, ignore_case = true, default_value_t = crate::choices::Switch::On)]
    pub temporal: crate::choices::Switch,
    /// Output folder.
    #[arg(long, default_value = "fovea-out")]
    pub out: PathBuf,
    /// Which executor casts the foveated frames' primary rays and reconstructs them: cpu, gpu
    /// or auto, as `fovea render --backend` (the GPU needs a fovea built with `--features
    /// gpu`; the full-resolution reference always runs on the CPU).
    #[arg(long, value_enum, ignore_case = true, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub denoise: crate::common::DenoiseArgs,
}

pub fn run(args: DemoArgs) -> Result<()> {
    if !(1..=240).contains(&args.frames) {
        bail!(
            "invalid parameter `frames` = {}: expected 1 to 240",
            args.frames
        );
    }
    let t0 = std::time::Instant::now();
    let display = preset(args.headset)?;
    let scene = builtin::depth_range()?;
    let camera = EyeCamera::from_desc(&scene.cameras[0], &display)?;
    let world = World::new(scene, Backend::best_available())?;
    let fps = 30.0;
    let gazes = gaze_trajectory(
        None,
        GazeScenario::SaccadePursuit,
        1,
        true,
        &display,
        args.frames as f64 / fps,
    )?
    .resample(fps, args.frames as usize)?;
    let dir = args.out.join("demo");
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create directory {}", dir.display()))?;
    let pb = if args.quiet {
        ProgressBar::hidden()
    } else {
        let pb = ProgressBar::new(args.frames as u64 + 1);
        pb.set_style(
            ProgressStyle::with_template("{msg:>6} [{bar:40}] {pos}/{len} frames, eta {eta}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        pb.set_message("demo");
        pb
    };
    // The eye state of every frame: auto focus at the gaze through the accommodation filter.
    let mut settings = FrameSettings::new(Method::Vafr);
    settings.dof = Some(DofSettings::new(Some(FilterKind::Gather), FocusMode::Auto));
    args.denoise.apply(&mut settings);
    let cameras = vec![camera.clone(); gazes.len()];
    let seq = Sequence::plan(
        &world,
        cameras,
        gazes,
        settings.dof.as_ref(),
        fps,
        AccommodationParams::default(),
        None,
    )?;
    let middle = args.frames as usize / 2;
    // Which executors cast the primary rays and reconstruct (`--backend`), decided before
    // any frame is rendered.
    let mut backend = crate::backend::resolve(args.backend, &world)?;
    if !args.quiet {
        println!("backend: {}", backend.describe);
    }
    let temporal = args
        .temporal
        .is_on()
        .then(fovea_render::temporal::TemporalSettings::default);
    let mut track = Track::new("vafr", settings.clone(), temporal)?;
    backend.install(track.context_mut());
    let mut driver = SequenceDriver::new(&world, &seq, vec![track])?;
    let mut kept = None;
    let mut samples = 0;
    driver.run(
        &|_| false,
        &mut |e| {
            let f = e.frames[0];
            samples = f.stats.samples;
            write_rgb(
                &dir.join(format!("frame_{:05}.png", e.index)),
                &f.color,
                0.0,
                ToneCurve::Reinhard,
            )?;
            if e.index == middle {
                kept = Some(f.clone());
            }
            Ok::<(), anyhow::Error>(())
        },
        &mut |_| pb.inc(1),
    )?;
    let fov = kept.context("no frame rendered")?;
    let eye = seq.eyes[middle];
    let focus = eye.focus.map_or(f64::INFINITY, |f| f.metres());
    // Where the middle frame's samples went.
    let density = {
        let plan = FramePlan::new(&world, &camera, &settings, &eye, [0.0, 0.0])?;
        density_view(plan.mapping(), &display, &eye.gaze)?
    };
    // The reference: the same frame at full resolution, with the same eye and depth of field.
    let mut rs = settings.clone();
    rs.method = Method::Full;
    let reference = render_for_eye(&world, &camera, &rs, &eye, &|_, _| {})?;
    pb.inc(1);
    pb.finish_and_clear();
    write_rgb(
        &dir.join("reference.png"),
        &reference.color,
        0.0,
        ToneCurve::Reinhard,
    )?;
    let (w, h) = (display.width_px, display.height_px);
    let (gx, gy) = (eye.gaze.point.x_px, eye.gaze.point.y_px);
    // The gaze point, ringed on both halves (a ring, not a dot: the pixels under it stay
    // visible). Linear values far above 1 come out bright yellow through the Reinhard curve.
    let ring_px = (0.012 * h as f64).max(6.0);
    let yellow = [60.0, 40.0, 0.0];
    let mut both = side_by_side(&fov.color, &reference.color)?;
    mark_ring(&mut both, gx, gy, ring_px, yellow);
    mark_ring(&mut both, gx + w as f64, gy, ring_px, yellow);
    write_rgb(
        &dir.join("side-by-side.png"),
        &both,
        0.0,
        ToneCurve::Reinhard,
    )?;
    // Zoomed crops, foveated | reference: around the gaze, and 30° out from it towards the
    // screen's far side (the periphery as it is rendered, not as the eye sees it).
    let crop = (h / 12).clamp(16, 160);
    let zoom = (360 / crop).max(2);
    let far = {
        let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
        let (dx, dy) = (cx - gx, cy - gy);
        let len = dx.hypot(dy);
        let (ux, uy) = if len > 1.0 {
            (dx / len, dy / len)
        } else {
            (1.0, 0.0)
        };
        let r = display.radius_px(fovea_core::units::Degrees(30.0));
        (
            (gx + ux * r).clamp(0.0, w as f64 - 1.0),
            (gy + uy * r).clamp(0.0, h as f64 - 1.0),
        )
    };
    for (name, (x, y)) in [("crop-gaze.png", (gx, gy)), ("crop-periphery.png", far)] {
        let pair = side_by_side(
            &zoomed_crop(&fov.color, x, y, crop, zoom)?,
            &zoomed_crop(&reference.color, x, y, crop, zoom)?,
        )?;
        write_rgb(&dir.join(name), &pair, 0.0, ToneCurve::Reinhard)?;
    }
    let gain = 4.0;
    let (mut diff, mean_diff) = difference_map(&fov.color, &reference.color, gain)?;
    mark_ring(&mut diff, gx, gy, ring_px, [0.0, 0.3, 1.0]);
    write_rgb(&dir.join("difference.png"), &diff, 0.0, ToneCurve::Clamp)?;
    let mut overlay = density_overlay(&fov.color, Some(&density))?;
    mark_ring(&mut overlay, gx, gy, ring_px, [1.0, 1.0, 1.0]);
    write_rgb(
        &dir.join("density-overlay.png"),
        &overlay,
        0.0,
        ToneCurve::Clamp,
    )?;
    let full_px = display.pixel_count();
    let html = format!(
        r#"<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>fovea demo</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto}}img{{max-width:100%}}</style></head>
<body>
<h1>fovea demo — {name}, {w}×{h} per eye</h1>
<p>Foveated frames rendered on: {backend_line}.</p>
<p>Left: what the eye gets when the renderer knows where it looks — VaFR shades {samples} samples per frame ({share:.0} % of the {full_px} pixels), densest at the gaze, and blurs what lies outside the depth the eye focuses on (auto focus, {focus:.2} m here). Right: every pixel ray-traced at full resolution with the same blur.</p>
<p>The yellow ring marks where the eye looks in this frame, ({gx:.0}, {gy:.0}); the frames below follow a gaze that fixates, pursues and jumps.</p>
<h2>Foveated | full resolution (frame {middle})</h2><img src="side-by-side.png" alt="foveated and full-resolution frames side by side, the gaze ringed">
<h2>Up close, foveated | full resolution, ×{zoom}</h2>
<p>{crop}×{crop} pixels around the gaze:</p><img src="crop-gaze.png" alt="zoomed crops around the gaze">
<p>{crop}×{crop} pixels 30° from the gaze, at ({fx:.0}, {fy:.0}), where VaFR spends few samples and the eye resolves little:</p><img src="crop-periphery.png" alt="zoomed crops in the periphery">
<h2>Difference</h2>
<p>How far the foveated frame is from the full-resolution one as displayed: |display luma difference| × {gain} (black = none, red → yellow → white = a quarter of the range or more); mean difference {mean_pct:.2} % of the range. The blue ring is the gaze. The environment light is sampled with a few rays per sample, so its Monte Carlo noise differs between the two frames and shows as a faint red haze everywhere; edges and fine texture that foveation changes stand out above it.</p>
<img src="difference.png" alt="difference image">
<h2>Samples per pixel</h2>
<p>Each pixel is tinted by how many samples VaFR spends on it:</p>
<div style="display:flex;align-items:center;gap:.5em;max-width:600px"><span>≤ 1/64</span><div style="flex:1;height:14px;background:linear-gradient(to right,rgb(0,0,255),rgb(0,255,0),rgb(255,0,0))"></div><span>≥ 1 per pixel</span></div>
<p style="max-width:600px;display:flex;justify-content:space-between;margin-top:0"><span></span><span>1/8</span><span></span></p>
<img src="density-overlay.png" alt="sample density over the frame">
<h2>Frames</h2>{frames}
</body></html>
"#,
        name = display.name,
        backend_line = html_escape(&backend.describe),
        share = 100.0 * samples as f64 / full_px as f64,
        fx = far.0,
        fy = far.1,
        mean_pct = 100.0 * mean_diff,
        frames = (0..args.frames)
            .map(|i| format!(r#"<img src="frame_{i:05}.png" width="220" alt="frame {i}">"#))
            .collect::<Vec<_>>()
            .join("\n"),
    );
    let index = dir.join("index.html");
    crate::output::write_file(&index, html.as_bytes())?;
    println!(
        "{} frames of the built-in scene on {} ({w}x{h}), VaFR + auto-focus depth of field, in {:.0} s",
        args.frames,
        display.name,
        t0.elapsed().as_secs_f64()
    );
    println!("open {}", index.display());
    Ok(())
}

/// The frame in grey with the sample density as a colour tint: red where VaFR shades a
/// sample or more per pixel, through green, to blue where it shades 1/64 or fewer.
fn density_overlay(color: &Image<Rgb>, density: Option<&Image<f32>>) -> Result<Image<Rgb>> {
    let d = density.context("the density view was not rendered")?;
    let mut out = Image::new(color.width(), color.height(), [0.0f32; 3])?;
    for ((o, c), &s) in out.data_mut().iter_mut().zip(color.data()).zip(d.data()) {
        let grey = fovea_post::tonemap::linear_to_srgb(
            fovea_post::luma(*c).clamp(0.0, 1.0) / (1.0 + fovea_post::luma(*c).clamp(0.0, 1.0)),
        );
        // t = 1 at ≥ 1 sample per pixel, 0 at ≤ 1/64.
        let t = ((s.max(1e-6).log2() + 6.0) / 6.0).clamp(0.0, 1.0);
        let tint = if t > 0.5 {
            [2.0 * t - 1.0, 2.0 - 2.0 * t, 0.0]
        } else {
            [0.0, 2.0 * t, 1.0 - 2.0 * t]
        };
        *o = std::array::from_fn(|k| {
            let enc = 0.55 * grey + 0.45 * tint[k];
            // write_rgb encodes to sRGB: pass linear values.
            fovea_post::tonemap::srgb_to_linear(enc)
        });
    }
    Ok(out)
}
