//! Shared by the measurement examples: a scene (a file or a built-in name) seen from its file
//! camera on a display of the camera's vertical field of view.

use std::path::Path;

use fovea_core::display::DisplayProfile;
use fovea_core::units::Degrees;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::scene::{builtin, Scene};
use fovea_render::world::World;

/// `scene_arg` loaded (a path with an extension, else a built-in scene's name), its first
/// camera on a `w`×`h` display of the camera's vertical field of view (`default_vfov_deg`
/// where the file gives none).
pub fn file_view(
    scene_arg: &str,
    (w, h): (u32, u32),
    default_vfov_deg: f64,
) -> Result<(World, EyeCamera, DisplayProfile), Box<dyn std::error::Error>> {
    let scene = if Path::new(scene_arg).extension().is_some() {
        Scene::load(Path::new(scene_arg))?
    } else {
        builtin::by_name(scene_arg)?
    };
    let desc = scene
        .cameras
        .first()
        .ok_or("the scene has no camera")?
        .clone();
    let vfov = desc.yfov_deg.map_or(default_vfov_deg, f64::from);
    let display = DisplayProfile::with_vertical_fov("measure", w, h, Degrees(vfov))?;
    let world = World::new(scene, Backend::best_available())?;
    let camera = EyeCamera::from_desc(&desc, &display)?;
    Ok((world, camera, display))
}

/// `WxH` parsed, or `default` when absent.
pub fn resolution(
    arg: Option<&String>,
    default: (u32, u32),
) -> Result<(u32, u32), Box<dyn std::error::Error>> {
    match arg {
        Some(r) => {
            let (a, b) = r.split_once('x').ok_or("resolution WxH")?;
            Ok((a.parse()?, b.parse()?))
        }
        None => Ok(default),
    }
}
