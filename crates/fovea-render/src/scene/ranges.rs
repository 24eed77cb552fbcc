//! Physical ranges of what a scene file gives, applied by [`Scene::validate`] after every
//! loader (glTF, OBJ/MTL, PLY, Mitsuba), so one rule holds for all:
//!
//! * a light's intensity (point, spot) or irradiance (directional), position or direction
//!   that is NaN or infinite → error naming the light, the field and the file;
//! * a negative component of a light's intensity or irradiance → clamped to 0, with a
//!   warning naming the light, the field and the file (negative light would render negative
//!   radiance into the EXR and a black PNG);
//! * a material's base colour or emission that is negative or not finite → clamped to
//!   `[0, ∞)` (a non-finite value becomes the default, 0.8 grey or no emission), with a
//!   warning naming the material, the field and the file;
//! * more than [`MAX_FILE_LIGHTS`] lights → the strongest kept (directional lights first,
//!   then point and spot lights by radiant flux Φ = I·Ω, `Ω` = 4π for a point light and
//!   2π(1 − cos θ_outer) for a spot; ties to the earlier light), with a warning. Direct
//!   shading casts one shadow ray per light and sample, so 10,000 lights cost 40 times 256:
//!   minutes for a 64×64 frame. The bound is the one `--lights` has.
//!
//! The environment is checked by `Scene::validate` itself (refused when negative or not
//! finite); a camera's field of view by its loader (a warning naming the field).

use std::f32::consts::{PI, TAU};
use std::path::Path;

use glam::Vec3;

use super::{Light, Material, Scene};
use crate::error::{RenderError, Result};

/// Most lights a scene file may bring (as many as `--lights` may generate:
/// `lights::MAX_LIGHTS` is this value).
pub const MAX_FILE_LIGHTS: usize = 256;

/// The light's kind, its intensity-like field and that field's name.
fn power_field(l: &mut Light) -> (&'static str, &'static str, &mut Vec3) {
    match l {
        Light::Point { intensity, .. } => ("point", "intensity", intensity),
        Light::Spot { intensity, .. } => ("spot", "intensity", intensity),
        Light::Directional { irradiance, .. } => ("directional", "irradiance", irradiance),
    }
}

/// Checks every light's values (see the module header): errors for non-finite ones, clamps
/// negative intensities with a warning.
pub(super) fn check_lights(scene: &mut Scene, source: &Path) -> Result<()> {
    let mut warnings = Vec::new();
    for (k, l) in scene.lights.iter_mut().enumerate() {
        let geometry = match *l {
            Light::Point { position, .. } => [("position", position), ("position", position)],
            Light::Spot {
                position,
                direction,
                ..
            } => [("position", position), ("direction", direction)],
            Light::Directional { direction, .. } => {
                [("direction", direction), ("direction", direction)]
            }
        };
        let (kind, field, value) = power_field(l);
        for (name, v) in geometry.into_iter().chain([(field, *value)]) {
            if !v.is_finite() {
                return Err(RenderError::bad(
                    source,
                    format!("{kind} light {k}: {name} {v} is not finite"),
                ));
            }
        }
        if value.min_element() < 0.0 {
            warnings.push(format!(
                "{}: {kind} light {k}: negative {field} {value}, clamped to 0",
                source.display()
            ));
            *value = value.max(Vec3::ZERO);
        }
    }
    scene.warnings.extend(warnings);
    Ok(())
}

/// Clamps every material's base colour and emission to `[0, ∞)` (see the module header).
pub(super) fn check_materials(materials: &mut [Material], source: &Path) -> Vec<String> {
    let mut warnings = Vec::new();
    for m in materials {
        for (field, value, fallback) in [
            ("base colour", &mut m.base_color, Vec3::splat(0.8)),
            ("emission", &mut m.emissive, Vec3::ZERO),
        ] {
            if !value.is_finite() {
                warnings.push(format!(
                    "{}: material `{}`: {field} {value} is not finite, using {fallback}",
                    source.display(),
                    m.name
                ));
                *value = fallback;
            } else if value.min_element() < 0.0 {
                warnings.push(format!(
                    "{}: material `{}`: negative {field} {value}, clamped to 0",
                    source.display(),
                    m.name
                ));
                *value = value.max(Vec3::ZERO);
            }
        }
    }
    warnings
}

/// Luminance of linear Rec. 709 RGB.
fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The order in which lights are kept: directional ones (`None`) first, then by flux,
/// larger first.
fn flux(l: &Light) -> Option<f32> {
    match *l {
        Light::Directional { .. } => None,
        Light::Point { intensity, .. } => Some(4.0 * PI * luminance(intensity)),
        Light::Spot {
            intensity,
            cos_outer,
            ..
        } => Some(TAU * (1.0 - cos_outer.clamp(-1.0, 1.0)) * luminance(intensity)),
    }
}

/// Keeps at most `max` lights, the strongest (see the module header), in their file order;
/// returns the warning when some were dropped.
pub fn bound_lights(lights: &mut Vec<Light>, max: usize, source: &Path) -> Option<String> {
    let n = lights.len();
    if n <= max {
        return None;
    }
    let mut order: Vec<usize> = (0..n).collect();
    // Directional first (None sorts after Some, so compare reversed), then larger flux;
    // the sort is stable, so ties keep the file order.
    order.sort_by(|&a, &b| match (flux(&lights[a]), flux(&lights[b])) {
        (None, None) => std::cmp::Ordering::Equal,
        (None, Some(_)) => std::cmp::Ordering::Less,
        (Some(_), None) => std::cmp::Ordering::Greater,
        (Some(x), Some(y)) => y.total_cmp(&x),
    });
    let mut keep = vec![false; n];
    for &i in &order[..max] {
        keep[i] = true;
    }
    let mut k = 0;
    lights.retain(|_| {
        k += 1;
        keep[k - 1]
    });
    Some(format!(
        "{}: {n} lights, more than the {max} direct shading takes (one shadow ray per light \
         and sample): kept the {max} strongest (directional first, then by radiant flux)",
        source.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(i: f32) -> Light {
        Light::Point {
            position: Vec3::ZERO,
            intensity: Vec3::splat(i),
            range: f32::INFINITY,
        }
    }

    #[test]
    fn the_strongest_lights_are_kept_in_file_order() {
        let sun = Light::Directional {
            direction: Vec3::NEG_Y,
            irradiance: Vec3::splat(0.001),
        };
        let mut lights = vec![point(1.0), point(5.0), sun.clone(), point(3.0), point(5.0)];
        let w = bound_lights(&mut lights, 3, Path::new("a.gltf")).unwrap();
        assert!(w.contains("5 lights") && w.contains("a.gltf"), "{w}");
        assert_eq!(lights, vec![point(5.0), sun, point(5.0)]);
        assert!(bound_lights(&mut lights, 3, Path::new("a.gltf")).is_none());
    }
}
