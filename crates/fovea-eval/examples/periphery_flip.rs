//! Issue 38's "no magnified noise": ꟻLIP beyond 30° of VaFR (denoised, the viewer's
//! real-time shading) and of the one-ray full-resolution frame without denoising, against a
//! converged full-resolution reference of the same shading, with the reference's noise floor,
//! at the centre, 25° and near-corner gazes ([`fovea_eval::experiments::periphery_flip`]).
//!
//! ```sh
//! cargo run --release -p fovea-eval --example periphery_flip -- \
//!     [SCENE|depth-range] [PRESET] [REFERENCE_RAYS_PER_PIXEL] [--json FILE]
//! ```
//!
//! Defaults: the built-in scene, `vive-pro-eye`, 256 rays per pixel. A scene file's first
//! camera is used; a scene without lights gets 4 generated point lights (as `fovea render`).
//! A scene file that does not exist is skipped with a printed reason (exit 0), so a script can
//! name the classroom of `../shared/scenes` whether or not it is there.

use std::path::Path;

use fovea_core::display::DisplayProfile;
use fovea_eval::experiments::periphery_flip::{run, standard_gazes, PeripheryFlipParams};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::lights::view_lights;
use fovea_render::scene::{builtin, CameraDesc, Scene};
use fovea_render::world::World;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let json_out = match args.iter().position(|a| a == "--json") {
        Some(i) if i + 1 < args.len() => {
            let p = args.remove(i + 1);
            args.remove(i);
            Some(p)
        }
        Some(_) => return Err("--json needs a file".into()),
        None => None,
    };
    let scene_arg = args.first().map_or("depth-range", String::as_str);
    let preset = args.get(1).map_or("vive-pro-eye", String::as_str);
    let mut params = PeripheryFlipParams::default();
    if let Some(n) = args.get(2) {
        params.reference_pixel_samples = n.parse()?;
    }
    params.validate()?;
    let display = DisplayProfile::preset(preset)?;
    let path = Path::new(scene_arg);
    let scene = if path.extension().is_some() {
        if !path.is_file() {
            println!("skipped {scene_arg}: no such file (the shared scenes are not here)");
            return Ok(());
        }
        Scene::load(path)?
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
    let gazes = standard_gazes(&display)?;
    let t0 = std::time::Instant::now();
    let result = run(&world, &camera, &gazes, &params, &|step| {
        eprintln!("[{:>7.1} s] {step}", t0.elapsed().as_secs_f64());
    })?;
    print!("{}", result.markdown());
    println!(
        "reference CPU time {:.0} ms; wall time of the whole run {:.0} s",
        result.reference_cpu_ms,
        t0.elapsed().as_secs_f64()
    );
    if let Some(p) = json_out {
        std::fs::write(&p, serde_json::to_string_pretty(&result)? + "\n")?;
        println!("wrote {p}");
    }
    Ok(())
}
