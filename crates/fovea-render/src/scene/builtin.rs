//! Built-in scenes made in code, so the main command needs no input file.
//!
//! **`depth-range`** (after Weier et al. 2018, Fig. 6): a 8 m wide, 4 m high open corridor
//! running 52 m away from a viewer standing at the origin (eyes at 1.6 m, looking down −Z),
//! with
//! * a floor with a 2 m checkerboard carrying 1-texel black lines every 6.25 cm, and walls
//!   with a chirp of vertical stripes (4 to 128 cycles per 2 m tile) — fine, high-contrast
//!   detail that reveals aliasing in sparse peripheral sampling and flicker in motion;
//! * resolution targets (boxes wearing a 36-spoke Siemens star) at 0.3, 0.5, 1, 2, 5, 10 and
//!   20 m, sized to subtend roughly 5–7°, and a back wall with the star at 50 m, so every
//!   depth of field setting has something in and out of focus; two spheres add smooth shading;
//! * a sun (directional light) from the upper left and four point lights along the corridor,
//!   and a sky-blue environment.
//!
//! Distances are along −Z from the eye, in metres; the scene is in metres.

use glam::{Vec2, Vec3, Vec4};

use super::primitives::{self, Poles, UvLayout};
use super::{CameraDesc, Light, Material, Mesh, Scene, Texture};
use crate::error::{RenderError, Result};

/// Names of the built-in scenes.
pub const NAMES: [&str; 1] = ["depth-range"];

/// Distances of the depth-range targets from the eye, metres.
pub const TARGET_DISTANCES_M: [f32; 8] = [0.3, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0];

/// Eye height of the default viewer, metres.
pub const EYE_HEIGHT_M: f32 = 1.6;

/// A built-in scene by name.
pub fn by_name(name: &str) -> Result<Scene> {
    match name.trim().to_ascii_lowercase().as_str() {
        "depth-range" | "builtin" | "built-in" => depth_range(),
        _ => Err(RenderError::invalid(
            "scene",
            name,
            format!("a scene file or a built-in scene ({})", NAMES.join(", ")),
        )),
    }
}

/// An axis-aligned quad from `origin` spanning `du`, `dv`, with UVs `[0, uv_scale]`.
fn quad(name: &str, origin: Vec3, du: Vec3, dv: Vec3, uv_scale: Vec2, material: u32) -> Mesh {
    let mut m = primitives::quad(origin, du, dv, uv_scale, UvLayout::VAgainstAxis);
    m.name = name.into();
    m.material = material;
    m
}

/// An axis-aligned box centred at `c` with half extents `h`; each face maps the full texture.
fn cuboid(name: &str, c: Vec3, h: Vec3, material: u32) -> Mesh {
    let faces = primitives::box_faces_upright();
    let mut m = primitives::cuboid(c, h, faces, UvLayout::VAgainstAxis);
    m.name = name.into();
    m.material = material;
    m
}

/// A UV sphere of 64 segments × 32 rings, poles on ±Y, centred at `c` with radius `r`.
fn sphere(name: &str, c: Vec3, r: f32, material: u32) -> Mesh {
    let mut m = primitives::uv_sphere(64, 32, Poles::Y);
    for p in &mut m.positions {
        *p = c + r * *p;
    }
    m.name = name.into();
    m.material = material;
    m
}

/// Floor: 2×2 checker of light/dark grey with black lines every 32 texels (1024² = 2 m).
fn floor_texture() -> Result<Texture> {
    let n = 1024u32;
    let texels = (0..n * n)
        .map(|k| {
            let (x, y) = (k % n, k / n);
            let check = ((x / 512) + (y / 512)) % 2 == 0;
            let line = x % 32 == 0 || y % 32 == 0;
            let v = if line {
                0.02
            } else if check {
                0.7
            } else {
                0.25
            };
            Vec4::new(v, v, v * 0.95, 1.0)
        })
        .collect();
    Texture::from_linear("floor-checker", n, n, texels)
}

/// Walls: vertical stripes whose frequency doubles every ⅙ of the height (4 → 128 cycles per
/// tile), black on white.
fn wall_texture() -> Result<Texture> {
    let n = 1024u32;
    let texels = (0..n * n)
        .map(|k| {
            let (x, y) = (k % n, k / n);
            let band = (y * 6 / n).min(5);
            let cycles = 4u32 << band;
            let period = n / cycles;
            let on = (x % period) < period / 2;
            let v = if on { 0.85 } else { 0.03 };
            Vec4::new(v, v * 0.97, v * 0.9, 1.0)
        })
        .collect();
    Texture::from_linear("wall-chirp", n, n, texels)
}

/// A 36-spoke Siemens star on white inside a checker border.
fn star_texture() -> Result<Texture> {
    let n = 512u32;
    let texels = (0..n * n)
        .map(|k| {
            let (x, y) = (k % n, k / n);
            let (fx, fy) = (
                x as f32 + 0.5 - n as f32 / 2.0,
                y as f32 + 0.5 - n as f32 / 2.0,
            );
            let r = (fx * fx + fy * fy).sqrt() / (n as f32 / 2.0);
            let border = x < 32 || y < 32 || x >= n - 32 || y >= n - 32;
            let v = if border {
                if ((x / 16) + (y / 16)) % 2 == 0 {
                    0.9
                } else {
                    0.05
                }
            } else if r < 0.85 {
                let a = fy.atan2(fx);
                if (a * 18.0 / std::f32::consts::PI).rem_euclid(2.0) < 1.0 {
                    0.03
                } else {
                    0.9
                }
            } else {
                0.9
            };
            Vec4::new(v, v, v, 1.0)
        })
        .collect();
    Texture::from_linear("siemens-star", n, n, texels)
}

/// The depth-range scene (see the module docs).
pub fn depth_range() -> Result<Scene> {
    let textures = vec![floor_texture()?, wall_texture()?, star_texture()?];
    let materials = vec![
        Material {
            name: "floor".into(),
            base_color: Vec3::ONE,
            base_color_texture: Some(0),
            roughness: 0.6,
            ..Material::default()
        },
        Material {
            name: "wall".into(),
            base_color: Vec3::ONE,
            base_color_texture: Some(1),
            roughness: 0.9,
            ..Material::default()
        },
        Material {
            name: "target".into(),
            base_color: Vec3::ONE,
            base_color_texture: Some(2),
            roughness: 0.5,
            ..Material::default()
        },
        Material {
            name: "red-plastic".into(),
            base_color: Vec3::new(0.8, 0.1, 0.08),
            roughness: 0.25,
            ..Material::default()
        },
        Material {
            name: "metal".into(),
            base_color: Vec3::new(0.95, 0.85, 0.6),
            metallic: 1.0,
            roughness: 0.3,
            ..Material::default()
        },
    ];
    let (half_w, height, near_z, far_z) = (4.0f32, 4.0f32, 2.0f32, -52.0f32);
    let len = near_z - far_z;
    let mut meshes = vec![
        quad(
            "floor",
            Vec3::new(-half_w, 0.0, near_z),
            Vec3::new(2.0 * half_w, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -len),
            Vec2::new(half_w, len / 2.0),
            0,
        ),
        quad(
            "left-wall",
            Vec3::new(-half_w, 0.0, far_z),
            Vec3::new(0.0, 0.0, len),
            Vec3::new(0.0, height, 0.0),
            Vec2::new(len / 2.0, height / 2.0),
            1,
        ),
        quad(
            "right-wall",
            Vec3::new(half_w, 0.0, near_z),
            Vec3::new(0.0, 0.0, -len),
            Vec3::new(0.0, height, 0.0),
            Vec2::new(len / 2.0, height / 2.0),
            1,
        ),
        quad(
            "back-wall",
            Vec3::new(-half_w, 0.0, far_z + 2.0),
            Vec3::new(2.0 * half_w, 0.0, 0.0),
            Vec3::new(0.0, height, 0.0),
            Vec2::new(1.0, 0.5),
            2,
        ),
    ];
    // Targets: (distance, lateral offset, height of centre, half size).
    let targets = [
        (0.3, 0.06, 1.52, 0.012),
        (0.5, -0.12, 1.45, 0.02),
        (1.0, 0.25, 1.35, 0.05),
        (2.0, -0.55, 1.2, 0.1),
        (5.0, 1.1, 1.0, 0.25),
        (10.0, -1.9, 1.3, 0.5),
        (20.0, 1.8, 1.8, 0.9),
    ];
    for (k, (d, x, y, h)) in targets.into_iter().enumerate() {
        meshes.push(cuboid(
            &format!("target-{d}m"),
            Vec3::new(x, y, -d),
            Vec3::splat(h),
            if k == 3 { 3 } else { 2 },
        ));
    }
    meshes.push(sphere("sphere-3m", Vec3::new(-1.2, 0.5, -3.0), 0.5, 4));
    meshes.push(sphere("sphere-8m", Vec3::new(2.2, 0.8, -8.0), 0.8, 3));
    let mut lights = vec![Light::Directional {
        direction: Vec3::new(0.45, -0.8, -0.4).normalize(),
        irradiance: Vec3::new(2.6, 2.45, 2.2),
    }];
    for (k, z) in [-1.5f32, -6.0, -14.0, -30.0].into_iter().enumerate() {
        let s = (z.abs() * 0.6).max(1.5);
        lights.push(Light::Point {
            position: Vec3::new(if k % 2 == 0 { -2.0 } else { 2.0 }, 3.6, z),
            intensity: Vec3::new(1.0, 0.95, 0.85) * s * s * 0.6,
            range: f32::INFINITY,
        });
    }
    let camera = CameraDesc::look_at(
        "viewer",
        Vec3::new(0.0, EYE_HEIGHT_M, 0.0),
        Vec3::new(0.0, EYE_HEIGHT_M - 0.25, -10.0),
        None,
    )?;
    let mut scene = Scene {
        name: "depth-range".into(),
        source: None,
        meshes,
        materials,
        textures,
        lights,
        cameras: vec![camera],
        environment: Vec3::new(0.25, 0.32, 0.45).into(),
        light_units: super::LightUnits::Relative,
        metres_per_unit: 1.0,
        warnings: vec![],
    };
    scene.validate()?;
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_range_has_targets_from_30cm_to_50m() {
        let s = depth_range().unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        let cam = &s.cameras[0];
        for d in TARGET_DISTANCES_M {
            // Some mesh's nearest point along the view axis lies within 10 % of d.
            let found = s.meshes.iter().any(|m| {
                let near = m
                    .positions
                    .iter()
                    .map(|p| cam.position.z - p.z)
                    .fold(f32::INFINITY, f32::min);
                (near - d).abs() <= 0.1 * d && m.name != "floor" && !m.name.ends_with("-wall")
                    || (m.name == "back-wall" && (near - d).abs() < 0.01)
            });
            assert!(found, "no target near {d} m");
        }
        let b = s.bounds().unwrap();
        assert!(b.min.z < -50.0 && b.max.z >= 2.0);
        assert!(by_name("nope").is_err());
    }
}
