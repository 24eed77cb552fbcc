//! Gaze-contingent level of detail (Liu et al., Eq. 14) in a scene of many objects.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::optics::EyeModel;
use fovea_core::units::Degrees;
use fovea_eval::metrics::{luma_psnr, Region};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::lod::{LodParams, LodScene};
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::{builtin, Mesh};
use fovea_render::world::World;
use glam::{Vec2, Vec3};

/// A UV sphere of `seg × seg/2` quads.
fn uv_sphere(name: &str, c: Vec3, r: f32, seg: u32, material: u32) -> Mesh {
    let rings = seg / 2;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=seg {
            let ph = std::f32::consts::TAU * j as f32 / seg as f32;
            let n = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            positions.push(c + r * n);
            normals.push(n);
        }
    }
    let mut indices = Vec::new();
    let row = seg + 1;
    for i in 0..rings {
        for j in 0..seg {
            let (a, b) = (i * row + j, (i + 1) * row + j);
            indices.push([a, b, a + 1]);
            indices.push([a + 1, b, b + 1]);
        }
    }
    Mesh {
        name: name.into(),
        uvs: vec![Vec2::ZERO; positions.len()],
        positions,
        normals,
        tangents: vec![],
        colors: vec![],
        indices,
        material,
    }
}

#[test]
fn lod_simplifies_outside_the_fovea_and_keeps_the_fixated_object() {
    let d = DisplayProfile::with_vertical_fov("t", 320, 240, Degrees(90.0)).unwrap();
    let mut scene = builtin::depth_range().unwrap();
    let cam_desc = scene.cameras[0].clone();
    let cam = EyeCamera::from_desc(&cam_desc, &d).unwrap();
    // 7 × 5 spheres of 2,048 triangles at 1 to 7 m, 0.6 m apart sideways.
    let mat = 0;
    let mut fixated = 0;
    for zi in 0..7 {
        for xi in 0..5 {
            let dist = 1.0 + zi as f32;
            let c = cam.position + dist * cam.forward + (xi as f32 - 2.0) * 0.6 * cam.right
                - 0.3 * cam.up;
            if zi == 0 && xi == 2 {
                fixated = scene.meshes.len();
            }
            scene
                .meshes
                .push(uv_sphere(&format!("s{zi}{xi}"), c, 0.12, 64, mat));
        }
    }
    let target = cam.position + 1.0 * cam.forward - 0.3 * cam.up;
    let q = cam.screen_point_of(target - cam.position).unwrap();
    let gaze = d.gaze(q.x_px, q.y_px).unwrap();
    let lod = LodScene::new(scene.clone(), LodParams::default()).unwrap();
    let eye = EyeModel::default();
    let focus = (target - cam.position).length() as f64 - 0.12;
    let gaze_dir = (target - cam.position).normalize();
    let limits = eye.dof_limits(fovea_core::units::Metres(focus)).unwrap();
    let flags = lod.flags(&cam, gaze_dir, &limits);
    assert!(flags[fixated], "the fixated sphere keeps full detail");
    let (world_lod, stats) = lod.world(&flags, Backend::Obvhs).unwrap();
    let saved = 1.0 - stats.triangles as f64 / stats.triangles_full as f64;
    println!(
        "{} of {} meshes at full detail; triangles {} of {} ({:.1} % fewer); DOF {:.2}–{:.2} m",
        stats.full_detail,
        stats.full_detail + stats.simplified,
        stats.triangles,
        stats.triangles_full,
        100.0 * saved,
        limits.near.0,
        limits.far.0
    );
    assert!(saved > 0.4, "{saved}");
    assert!(stats.simplified > 30);
    // The fixated sphere renders exactly as at full detail.
    let mut world_full = World::new(scene, Backend::Obvhs).unwrap();
    world_full.lights = world_lod.lights.clone();
    let s = FrameSettings::new(Method::Full);
    let a = render_frame(&world_full, &cam, &s, gaze, &|_, _| {}).unwrap();
    let b = render_frame(&world_lod, &cam, &s, gaze, &|_, _| {}).unwrap();
    let r = d.radius_px(Degrees(2.0));
    let centre = Region::around(q.x_px, q.y_px, r, d.width_px, d.height_px);
    let psnr = luma_psnr(&a.color, &b.color, centre).unwrap();
    println!("fixated sphere (2° around the gaze): PSNR {psnr:.2} dB against full detail");
    assert!(psnr.is_infinite() || psnr > 50.0, "{psnr}");
}
