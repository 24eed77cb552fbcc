//! Shared by the resident-frame examples: the built-in scene with `lights` lights at a display
//! preset, both eyes' cameras (the right eye 63 mm to the right of the file camera), and the
//! settings the resident frame serves.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::FrameSettings;
use fovea_render::scene::builtin;
use fovea_render::shade::ShadingMode;
use fovea_render::world::World;

/// The built-in scene at display `preset` with its first `lights` lights, and both eyes.
pub fn binocular_view(
    preset: &str,
    lights: usize,
) -> Result<(World, [EyeCamera; 2], DisplayProfile), Box<dyn std::error::Error>> {
    let scene = builtin::depth_range()?;
    let desc = scene.cameras[0].clone();
    let mut world = World::new(scene, Backend::Obvhs)?;
    world.lights.truncate(lights);
    let display = DisplayProfile::preset(preset)?;
    let left = EyeCamera::from_desc(&desc, &display)?;
    let right = EyeCamera::new(
        desc.position + left.right * 0.063,
        desc.forward,
        desc.up,
        &display,
    )?;
    Ok((world, [left, right], display))
}

/// `method` with direct shading and one ray per texel (what the resident frame serves).
pub fn direct_settings(method: Method) -> FrameSettings {
    let mut settings = FrameSettings::new(method);
    settings.shading = ShadingMode::DIRECT;
    settings.periphery_rays = 1;
    settings
}
