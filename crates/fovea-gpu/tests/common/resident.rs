//! Shared by the resident-frame tests (`frame_shade.rs`, `frame_binocular.rs`,
//! `frame_temporal.rs`): the built-in scene at the Vive Pro Eye with both eyes' cameras, the
//! plans they render, and the luma PSNR they compare images by.

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
#[allow(dead_code)] // `frame_8k.rs` sets its own display
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

/// Luma PSNR of two 8-bit sRGB images (Rec. 601 luma of the codes / 255), dB.
#[allow(dead_code)] // not every test file that shares this module compares images
pub fn luma_psnr(a: &[u8], b: &[u8]) -> f64 {
    let mse = luma_mse(a, b);
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    }
}

/// Mean squared difference of the Rec. 601 luma of two 8-bit sRGB images (codes / 255).
#[allow(dead_code)]
pub fn luma_mse(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let luma = |p: &[u8]| (0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64) / 255.0;
    let n = a.len() / 3;
    a.chunks_exact(3)
        .zip(b.chunks_exact(3))
        .map(|(x, y)| (luma(x) - luma(y)).powi(2))
        .sum::<f64>()
        / n as f64
}
