//! The sample-space denoiser's quality and cost (issue 38): full resolution, VaFR and
//! visual-polar with and without `fovea_post::denoise`, in the default (noisy) shading — the
//! environment through occluded shadow rays — against a full-resolution reference of the same
//! primary rays with 64 environment rays per sample; ꟻLIP and luma PSNR over the whole frame
//! and per eccentricity band, with each frame's CPU time and its denoise stage's.
//!
//! ```sh
//! cargo run --release -p fovea-render --example denoise_quality -- \
//!     [SCENE|depth-range] [PRESET] [GAZE_X,GAZE_Y | 25] [METHODS]
//! ```
//!
//! Defaults: the built-in scene, `vive-pro-eye`, the screen centre (`25`: 25° right of it),
//! `full,vafr,visual-polar`. A scene file gets 4 generated point lights when it has none.

use std::path::Path;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_eval::bands::{band_quality, whole_frame, REPORT_BANDS_DEG};
use fovea_post::denoise::{DenoiseParams, Kernel};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::lights::view_lights;
use fovea_render::pipeline::{render_frame, FrameSettings, Stage};
use fovea_render::scene::{builtin, CameraDesc, Scene};
use fovea_render::shade::{EnvLight, ShadingMode};
use fovea_render::world::World;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_arg = args.first().map_or("depth-range", String::as_str);
    let preset = args.get(1).map_or("vive-pro-eye", String::as_str);
    let display = DisplayProfile::preset(preset)?;
    let scene = if Path::new(scene_arg).extension().is_some() {
        Scene::load(Path::new(scene_arg))?
    } else {
        builtin::by_name(scene_arg)?
    };
    let desc = match scene.cameras.first() {
        Some(c) => c.clone(),
        None => {
            let b = scene.bounds().ok_or("empty scene")?;
            let c = b.centre();
            let pos = c + glam::Vec3::new(0.0, 0.25 * b.extent().y, 1.2 * b.extent().max_element());
            CameraDesc::look_at("framing", pos, c, None)?
        }
    };
    let mut world = World::new(scene, Backend::best_available())?;
    let camera = EyeCamera::from_desc(&desc, &display)?;
    if world.lights.is_empty() {
        world.lights = view_lights(&world, &camera, 4)?;
    }
    let c = display.centre_gaze().point;
    let gaze = match args.get(2).map(String::as_str) {
        Some("25") => display.gaze(c.x_px + display.radius_px(Degrees(25.0)), c.y_px)?,
        Some(t) => {
            let v: Vec<f64> = t.split(',').map(str::parse).collect::<Result<_, _>>()?;
            display.gaze(v[0], v[1])?
        }
        None => display.centre_gaze(),
    };
    let methods: Vec<Method> = args
        .get(3)
        .map_or("full,vafr,visual-polar", String::as_str)
        .split(',')
        .map(Method::parse)
        .collect::<Result<_, _>>()?;

    let mut reference = FrameSettings::new(Method::Full);
    reference.shading = ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples: 64 },
    };
    let r = render_frame(&world, &camera, &reference, gaze, &|_, _| {})?;
    println!(
        "{} on {} ({}x{}), gaze {:.0},{:.0}; reference: full resolution, 64 environment rays per sample ({:.0} ms cpu)",
        world.scene.name,
        display.name,
        display.width_px,
        display.height_px,
        gaze.point.x_px,
        gaze.point.y_px,
        r.stats.total_cpu_ms
    );
    let bands: Vec<String> = REPORT_BANDS_DEG
        .iter()
        .zip(REPORT_BANDS_DEG.iter().skip(1).map(Some).chain([None]))
        .map(|(lo, hi)| hi.map_or(format!("> {lo}°"), |hi| format!("{lo}–{hi}°")))
        .collect();
    println!(
        "| method | denoise | cpu ms | denoise cpu ms (share) | ꟻLIP frame | PSNR frame | ꟻLIP {} |",
        bands.join(" / "),
    );
    println!("|---|---|---|---|---|---|---|");
    for m in methods {
        for variant in [
            None,
            Some((Kernel::Linear3x3, 4)),
            Some((Kernel::B3Spline5x5, 4)),
        ] {
            let mut s = FrameSettings::new(m);
            s.denoise = variant.map(|(kernel, iterations)| DenoiseParams {
                kernel,
                iterations,
                ..DenoiseParams::default()
            });
            let f = render_frame(&world, &camera, &s, gaze, &|_, _| {})?;
            let q = band_quality(&r.color, &f.color, None, &display, &gaze, &REPORT_BANDS_DEG)?;
            let all = whole_frame(&q).ok_or("empty frame")?;
            let flip: Vec<String> = q
                .iter()
                .map(|b| b.flip.map_or("–".into(), |v| format!("{v:.4}")))
                .collect();
            let st = &f.stats;
            let dn = st.stages_cpu_ms.get(Stage::Denoise);
            println!(
                "| {m} | {} | {:.0} | {:.0} ({:.1} %) | {:.4} | {:.2} | {} |",
                variant.map_or("off".into(), |(k, n)| format!("{k:?} x{n}")),
                st.total_cpu_ms,
                dn,
                100.0 * dn / st.total_cpu_ms,
                all.flip.unwrap_or(f64::NAN),
                all.psnr_db.unwrap_or(f64::NAN),
                flip.join(" / "),
            );
        }
    }
    Ok(())
}
