//! Quality per ray of several primary rays per sample (`FrameSettings::pixel_samples`): each
//! method at 1, 2, 4 and 9 rays per texel against a 16-ray supersampled full-resolution frame,
//! ꟻLIP and luma PSNR per eccentricity band, with the rays and CPU time of each frame.
//!
//! ```sh
//! cargo run --release -p fovea-render --example subsample_quality -- \
//!     [SCENE|depth-range] [PRESET] [GAZE_X,GAZE_Y] [METHODS]
//! ```
//!
//! Defaults: the built-in scene, `vive-pro-eye`, the screen centre, `vafr,kfr`. A scene file
//! gets 4 generated point lights when it has none.

use std::path::Path;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_eval::bands::{band_quality, REPORT_BANDS_DEG};
use fovea_post::inverse_map::ReconstructFilter;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::lights::view_lights;
use fovea_render::pipeline::{render_frame, FrameSettings, Stage};
use fovea_render::scene::{builtin, CameraDesc, Scene};
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
    let gaze = match args.get(2) {
        Some(t) => {
            let v: Vec<f64> = t.split(',').map(str::parse).collect::<Result<_, _>>()?;
            display.gaze(v[0], v[1])?
        }
        None => display.centre_gaze(),
    };
    let methods: Vec<Method> = args
        .get(3)
        .map_or("vafr,kfr", String::as_str)
        .split(',')
        .map(Method::parse)
        .collect::<Result<_, _>>()?;

    let mut reference = FrameSettings::new(Method::Full);
    reference.pixel_samples = 16;
    let r = render_frame(&world, &camera, &reference, gaze, &|_, _| {})?;
    println!(
        "{} on {} ({}x{}), gaze {:.0},{:.0}; reference: full resolution, 16 rays per pixel ({:.0} ms cpu)",
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
        "| method | rays/texel | primary rays | cpu ms | trace+shade cpu ms | ꟻLIP {} | PSNR {} |",
        bands.join(" / "),
        bands.join(" / ")
    );
    println!("|---|---|---|---|---|---|---|");
    for m in std::iter::once(Method::Full).chain(methods) {
        for (n, filter, periphery) in [
            (1u32, ReconstructFilter::Bilinear, 1u32),
            (1, ReconstructFilter::Footprint, 1),
            (1, ReconstructFilter::Footprint, 2),
            (1, ReconstructFilter::Footprint, 4),
            (1, ReconstructFilter::Footprint, 9),
            (4, ReconstructFilter::Footprint, 1),
        ] {
            let mut s = FrameSettings::new(m);
            s.pixel_samples = n;
            s.reconstruct_filter = filter;
            s.periphery_rays = periphery;
            let f = render_frame(&world, &camera, &s, gaze, &|_, _| {})?;
            let q = band_quality(&r.color, &f.color, None, &display, &gaze, &REPORT_BANDS_DEG)?;
            let flip: Vec<String> = q
                .iter()
                .map(|b| b.flip.map_or("–".into(), |v| format!("{v:.4}")))
                .collect();
            let psnr: Vec<String> = q
                .iter()
                .map(|b| b.psnr_db.map_or("–".into(), |v| format!("{v:.2}")))
                .collect();
            let st = &f.stats;
            println!(
                "| {m} | {n}, {filter:?}, periphery ≤ {periphery} | {} | {:.0} | {:.0} | {} | {} |",
                st.rays_primary,
                st.total_cpu_ms,
                st.stages_cpu_ms.get(Stage::Trace) + st.stages_cpu_ms.get(Stage::Shade),
                flip.join(" / "),
                psnr.join(" / ")
            );
        }
    }
    Ok(())
}
