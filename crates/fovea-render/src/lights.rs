//! Light rigs for experiments: the papers compare shading cost with 1, 12, 21 and 31 lights
//! (VaFR Sec. 8), so the renderer can replace a scene's lights by `N` generated point lights.
//!
//! Placement guarantees free space: light `k` is put at 60 % of the way from the eye to the
//! first surface seen in direction `d_k`, where `d_k` runs over a Halton set inside the
//! central ¾ of the view frustum, tilted upwards (a segment from the eye to the first hit holds
//! no geometry). Rays that escape place their light 5 m out. All lights are white with
//! intensity `I = 2 · m² / N` (W/sr), `m` the median first-hit distance, so the total light on
//! what is in view stays similar whatever `N` is.

use glam::Vec3;

use fovea_core::math::halton2;

use crate::bvh::Ray;
use crate::camera::EyeCamera;
use crate::error::{RenderError, Result};
use crate::scene::Light;
use crate::world::World;

/// Most generated lights (as many as a scene file may bring, `scene::ranges`).
pub const MAX_LIGHTS: u32 = crate::scene::ranges::MAX_FILE_LIGHTS as u32;

/// `n` point lights in free space in front of `camera`.
pub fn view_lights(world: &World, camera: &EyeCamera, n: u32) -> Result<Vec<Light>> {
    if n == 0 || n > MAX_LIGHTS {
        return Err(RenderError::invalid(
            "lights",
            n,
            format!("1 to {MAX_LIGHTS} generated point lights"),
        ));
    }
    let d = &camera.display;
    let (w, h) = (d.width_px as f32, d.height_px as f32);
    let mut placed = Vec::with_capacity(n as usize);
    let mut dists = Vec::with_capacity(n as usize);
    for k in 0..n {
        let (a, b) = halton2(k as u64 + 1, (0.0, 0.0));
        // Central ¾ of the screen, upper part favoured (lights above the view).
        let x = w * (0.125 + 0.75 * a as f32);
        let y = h * (0.05 + 0.6 * b as f32);
        let dir = camera.direction(x, y);
        let ray = Ray {
            origin: camera.position,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let t = world.caster.intersect(&ray).map_or(5.0, |h| h.t);
        dists.push(t);
        placed.push(camera.position + dir * (0.6 * t));
    }
    let mut sorted = dists.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let m = sorted[sorted.len() / 2].max(0.1);
    let intensity = Vec3::splat(2.0 * m * m / n as f32);
    Ok(placed
        .into_iter()
        .map(|position| Light::Point {
            position,
            intensity,
            range: f32::INFINITY,
        })
        .collect())
}
