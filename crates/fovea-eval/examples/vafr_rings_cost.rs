//! What the real-time preset's VaFR rings cost (issue 37): VaFR with Eq. 3's rings in one
//! buffer for any gaze (`VafrRings::Eq3AnyGaze`, `--quality realtime`'s layout, whose tables
//! the resident GPU frame builds once per display) against the exact rings
//! (`VafrRings::Exact`, the offline default, each ring sized at the true eccentricity of the
//! screen points it crosses and rebuilt per gaze), both scored against a full-resolution
//! reference with many rays per pixel, at the centre, 25° and near-corner gazes
//! ([`fovea_eval::experiments::periphery_flip::standard_gazes`]).
//!
//! Printed per gaze and layout: the shaded samples, luma PSNR (display-encoded) and ꟻLIP over
//! the whole frame and ꟻLIP in the report's bands (0–5°, 5–15°, 15–30°, beyond 30°;
//! [`fovea_eval::bands::band_quality`]).
//!
//! ```sh
//! cargo run --release -p fovea-eval --example vafr_rings_cost -- \
//!     [depth-range|SCENE] [PRESET] [REFERENCE_RAYS_PER_PIXEL] [noise-free|viewer]
//! ```
//!
//! Defaults: the built-in scene, `vive-pro-eye`, 16 rays per pixel, `noise-free` shading (the
//! unshadowed environment, no Monte Carlo noise, no denoiser: the mapping's error alone).
//! `viewer` scores the real-time shading with the denoiser, one frame, against a reference of
//! that shading (its noise then adds to both layouts' error alike).

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{Method, VafrRings};
use fovea_eval::bands::{band_quality, whole_frame, REPORT_BANDS_DEG};
use fovea_eval::experiments::periphery_flip::standard_gazes;
use fovea_eval::reference::{render_seeded, MeasuredShading};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::FrameSettings;
use fovea_render::scene::builtin;
use fovea_render::world::World;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_arg = args.first().map_or("depth-range", String::as_str);
    let preset = args.get(1).map_or("vive-pro-eye", String::as_str);
    let rays: u32 = args.get(2).map_or(Ok(16), |s| s.parse())?;
    let shading = MeasuredShading::parse(args.get(3).map_or("noise-free", String::as_str))?;
    let display = DisplayProfile::preset(preset)?;
    let scene = if std::path::Path::new(scene_arg).extension().is_some() {
        fovea_render::scene::Scene::load(std::path::Path::new(scene_arg))?
    } else {
        builtin::by_name(scene_arg)?
    };
    let desc = scene
        .cameras
        .first()
        .ok_or("the scene has no camera")?
        .clone();
    let world = World::new(scene, Backend::best_available())?;
    let camera = EyeCamera::from_desc(&desc, &display)?;
    let t0 = std::time::Instant::now();
    let reference = render_seeded(
        &world,
        &camera,
        &shading.reference_settings(rays),
        display.centre_gaze(),
        0,
    )?;
    eprintln!(
        "[{:>6.1} s] reference: full resolution, {rays} rays per pixel",
        t0.elapsed().as_secs_f64()
    );
    println!(
        "{} on {} ({}x{}), {} shading, reference: full resolution with {rays} rays per pixel\n",
        world.scene.name,
        display.name,
        display.width_px,
        display.height_px,
        shading.name()
    );
    println!(
        "| gaze | rings | samples | luma PSNR dB | ꟻLIP | ꟻLIP 0–5° | 5–15° | 15–30° | > 30° |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let fmt = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.4}"));
    for (name, gaze) in standard_gazes(&display)? {
        for rings in [VafrRings::Exact, VafrRings::Eq3AnyGaze] {
            let mut s = FrameSettings::new(Method::Vafr);
            shading.apply(&mut s);
            s.mapping.vafr.rings = rings;
            let f = render_seeded(&world, &camera, &s, gaze, 0)?;
            let bands = band_quality(
                &reference.color,
                &f.color,
                None,
                &display,
                &gaze,
                &REPORT_BANDS_DEG,
            )?;
            let whole = whole_frame(&bands).ok_or("an empty frame")?;
            println!(
                "| {name} ({:.0}, {:.0}) | {} | {} | {:.2} | {:.4} | {} | {} | {} | {} |",
                gaze.point.x_px,
                gaze.point.y_px,
                rings.name(),
                f.stats.samples,
                whole.psnr_db.unwrap_or(f64::NAN),
                whole.flip.unwrap_or(f64::NAN),
                fmt(bands[0].flip),
                fmt(bands[1].flip),
                fmt(bands[2].flip),
                fmt(bands[3].flip),
            );
            eprintln!(
                "[{:>6.1} s] {name}, {}",
                t0.elapsed().as_secs_f64(),
                rings.name()
            );
        }
    }
    Ok(())
}
