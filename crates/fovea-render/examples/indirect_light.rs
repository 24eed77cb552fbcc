//! How much of a scene's light the default shading finds (issue 38, "light that reaches the
//! room"): the mean luma of a full-resolution frame from the scene's file camera with direct
//! shading, with direct shading plus 1 to 4 bounces of indirect light (the default: 3), and
//! with path tracing of 8 bounces as the converged reference; also the top eighth of the frame
//! (the ceiling of an interior seen from its file camera), and each frame's CPU time. The last
//! two rows are the real-time preset's candidates (one environment ray, without and with one
//! bounce).
//!
//! ```sh
//! cargo run --release -p fovea-render --example indirect_light -- \
//!     ../shared/scenes/japanese-classroom/scene.xml 180x200 64
//! ```
//!
//! Arguments: the scene (a file or a built-in name), the resolution `WxH` (default 180x200, the
//! Vive Pro Eye's aspect), the path tracer's paths per pixel (default 64).

#[path = "common/file_view.rs"]
mod file_view;

use file_view::{file_view, resolution};
use fovea_core::mapping::Method;
use fovea_core::Image;
use fovea_post::Rgb;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::shade::{EnvLight, ShadingMode};

/// Rec. 709 luma of linear RGB.
fn luma(c: Rgb) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

/// Mean luma of the whole frame and of its top eighth.
fn means(img: &Image<Rgb>) -> (f64, f64) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let all = img.data().iter().map(|&c| luma(c)).sum::<f64>() / (w * h) as f64;
    let top_rows = (h / 8).max(1);
    let top = img.data()[..w * top_rows]
        .iter()
        .map(|&c| luma(c))
        .sum::<f64>()
        / (w * top_rows) as f64;
    (all, top)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_arg = args.first().map_or("depth-range", String::as_str);
    let (w, h) = resolution(args.get(1), (180, 200))?;
    let spp: u32 = args.get(2).map_or(Ok(64), |s| s.parse())?;
    let (world, camera, display) = file_view(scene_arg, (w, h), 90.0)?;
    let vfov = display.vfov.0;
    let gaze = display.centre_gaze();
    let run = |shading: ShadingMode, pixel_samples: u32| -> Result<_, Box<dyn std::error::Error>> {
        let mut s = FrameSettings::new(Method::Full);
        s.shading = shading;
        s.pixel_samples = pixel_samples;
        let f = render_frame(&world, &camera, &s, gaze, &|_, _| {})?;
        Ok((means(&f.color), f.stats.total_cpu_ms))
    };
    println!(
        "{} from its file camera, {w}x{h}, vertical fov {vfov:.1}°, full resolution",
        world.scene.name
    );
    let ((ref_all, ref_top), ref_ms) = run(
        ShadingMode::Path {
            bounces: 8,
            spp,
            seed: 1,
        },
        1,
    )?;
    println!(
        "  path tracing, 8 bounces, {spp} paths: mean luma {ref_all:.4}, top eighth {ref_top:.4} \
         ({ref_ms:.0} ms cpu)"
    );
    let indirect = |bounces| ShadingMode::Indirect {
        env_light: EnvLight::DEFAULT,
        bounces,
    };
    for (name, shading, samples) in [
        ("direct".to_string(), ShadingMode::DIRECT, 16),
        ("indirect, 1 bounce".into(), indirect(1), 16),
        ("indirect, 2 bounces".into(), indirect(2), 16),
        ("indirect, 3 bounces".into(), indirect(3), 16),
        ("indirect, 4 bounces".into(), indirect(4), 16),
        // The real-time preset's choices: one environment ray at the primary hit, with and
        // without one bounce (`fovea_render::quality`).
        (
            "direct, 1 environment ray".into(),
            ShadingMode::Direct {
                env_light: EnvLight::Occluded { samples: 1 },
            },
            16,
        ),
        (
            "indirect, 1 bounce, 1 environment ray".into(),
            ShadingMode::Indirect {
                env_light: EnvLight::Occluded { samples: 1 },
                bounces: 1,
            },
            16,
        ),
    ] {
        let ((all, top), ms) = run(shading, samples)?;
        println!(
            "  {name}, {samples} rays per pixel: mean luma {all:.4} ({:.3}× the path tracer's), \
             top eighth {top:.4} ({:.3}×) ({ms:.0} ms cpu)",
            all / ref_all,
            top / ref_top
        );
    }
    Ok(())
}
