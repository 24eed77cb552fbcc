//! What the real-time preset costs in quality and buys in time against the offline default
//! (issue 37, item 10; `fovea_render::quality`): one view of a scene from its file camera,
//! VaFR at the gaze in the middle of the display, denoised as `render` and `sequence` do.
//!
//! Printed per preset: the CPU time of one frame, its mean luma against the offline frame's
//! (the light the real-time shading leaves out: the bounces past its one), and its luma PSNR
//! against the offline frame (display-encoded, so noise and missing light both count); for the
//! real-time preset also frames 0 and 15 of a still sequence with temporal accumulation (its
//! one environment ray per sample averaged over frames).
//!
//! ```sh
//! cargo run --release -p fovea-render --example quality_presets -- \
//!     ../shared/scenes/japanese-classroom/scene.xml 720x800
//! cargo run --release -p fovea-render --example quality_presets -- depth-range 720x800
//! ```
//!
//! Arguments: the scene (a file or a built-in name), the resolution `WxH` (default 720x800,
//! the Vive Pro Eye's aspect at half its size).

#[path = "common/file_view.rs"]
mod file_view;

use file_view::{file_view, resolution};
use fovea_core::mapping::Method;
use fovea_core::Image;
use fovea_post::Rgb;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::quality::Quality;
use fovea_render::sequence::{Sequence, SequenceDriver, Track};
use fovea_render::temporal::TemporalSettings;

/// Rec. 709 luma of linear RGB.
fn luma(c: Rgb) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

fn mean_luma(img: &Image<Rgb>) -> f64 {
    img.data().iter().map(|&c| luma(c)).sum::<f64>() / img.data().len() as f64
}

/// Luma PSNR (dB) of `a` against `b`, both clamped to [0, 1] and sRGB-encoded.
fn psnr(a: &Image<Rgb>, b: &Image<Rgb>) -> f64 {
    let enc = |c: Rgb| {
        let l = luma(c).clamp(0.0, 1.0);
        if l <= 0.003_130_8 {
            12.92 * l
        } else {
            1.055 * l.powf(1.0 / 2.4) - 0.055
        }
    };
    let mse = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(&x, &y)| (enc(x) - enc(y)).powi(2))
        .sum::<f64>()
        / a.data().len() as f64;
    10.0 * (1.0 / mse.max(1e-12)).log10()
}

/// The settings of `quality` as `render` makes them: VaFR, the preset's shading, denoised.
fn settings(quality: Quality) -> FrameSettings {
    let mut s = FrameSettings::new(Method::Vafr);
    s.shading = quality.shading();
    s.denoise = Some(Default::default());
    s
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_arg = args.first().map_or("depth-range", String::as_str);
    let (w, h) = resolution(args.get(1), (720, 800))?;
    let (world, camera, display) = file_view(scene_arg, (w, h), 110.0)?;
    let vfov = display.vfov.0;
    let (x, y) = (w as f64 / 2.0, h as f64 / 2.0);
    let gaze = display.gaze(x, y)?;
    println!(
        "{} from its file camera, {w}x{h}, vertical fov {vfov:.1}°, VaFR, gaze at the centre",
        world.scene.name
    );

    let offline = render_frame(
        &world,
        &camera,
        &settings(Quality::Offline),
        gaze,
        &|_, _| {},
    )?;
    let off_luma = mean_luma(&offline.color);
    println!(
        "  offline  (indirect, 3 bounces, 4 env rays): {:>7.0} ms cpu, mean luma {off_luma:.4}",
        offline.stats.total_cpu_ms
    );
    let rt = render_frame(
        &world,
        &camera,
        &settings(Quality::Realtime),
        gaze,
        &|_, _| {},
    )?;
    println!(
        "  realtime (1 bounce, 1 env ray), one frame:   {:>7.0} ms cpu ({:.2}x less), mean luma \
         {:.4} ({:.3}x offline's), luma PSNR against offline {:.2} dB",
        rt.stats.total_cpu_ms,
        offline.stats.total_cpu_ms / rt.stats.total_cpu_ms,
        mean_luma(&rt.color),
        mean_luma(&rt.color) / off_luma,
        psnr(&rt.color, &offline.color)
    );

    // A still view: 16 frames of the real-time preset with temporal accumulation.
    let frames = 16;
    let gazes = (0..frames)
        .map(|i| fovea_core::gaze::GazeSample::new(i as f64 / 90.0, x, y))
        .collect();
    let seq = Sequence::plan(
        &world,
        vec![camera.clone(); frames],
        gazes,
        None,
        90.0,
        Default::default(),
        None,
    )?;
    let track = Track::new(
        "realtime",
        settings(Quality::Realtime),
        Some(TemporalSettings::default()),
    )?;
    let mut driver = SequenceDriver::new(&world, &seq, vec![track])?;
    let mut out: Vec<(Image<Rgb>, f64)> = Vec::new();
    driver.run::<fovea_render::error::RenderError>(
        &|_| false,
        &mut |e| {
            let f = &e.frames[0];
            out.push((f.color.clone(), f.stats.total_cpu_ms));
            Ok(())
        },
        &mut |_| {},
    )?;
    for k in [0, frames - 1] {
        let (img, ms) = &out[k];
        println!(
            "  realtime, still sequence with accumulation, frame {k:>2}: {ms:>7.0} ms cpu, mean \
             luma {:.4} ({:.3}x offline's), luma PSNR against offline {:.2} dB",
            mean_luma(img),
            mean_luma(img) / off_luma,
            psnr(img, &offline.color)
        );
    }
    Ok(())
}
