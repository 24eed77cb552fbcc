//! Shared by the resident-frame tests (`frame_shade.rs`, `frame_binocular.rs`): the built-in
//! scene at the Vive Pro Eye with both eyes' cameras, and the plans they render.

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::eye::EyeState;
use fovea_render::pipeline::FrameSettings;
use fovea_render::plan::FramePlan;
use fovea_render::scene::builtin;
use fovea_render::shade::{FrameNoise, ShadingMode};
use fovea_render::world::World;

/// The built-in scene at the Vive Pro Eye, and both eyes' cameras (the right eye 63 mm to the
/// right of the file camera).
pub fn setup() -> (World, [EyeCamera; 2]) {
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let left = EyeCamera::from_desc(&desc, &display).unwrap();
    let right = EyeCamera::new(
        desc.position + left.right * 0.063,
        desc.forward,
        desc.up,
        &display,
    )
    .unwrap();
    (world, [left, right])
}

/// `method` with `shading`, one ray per texel (what the resident frame serves).
pub fn settings(method: Method, shading: ShadingMode) -> FrameSettings {
    let mut s = FrameSettings::new(method);
    s.shading = shading;
    s.periphery_rays = 1;
    s
}

/// The plan of `settings` at `gaze`, keyed with `frame` and `eye`.
pub fn plan(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    gaze: Gaze,
    frame: u64,
    eye: u32,
) -> FramePlan {
    FramePlan::new(
        world,
        camera,
        settings,
        &EyeState::looking_at(gaze),
        [0.0, 0.0],
    )
    .unwrap()
    .with_noise(FrameNoise::new(frame, eye))
}
