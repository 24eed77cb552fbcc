//! Emitters → lights and the environment: `point`, `spot`, `directional`, `sun` / `sky` /
//! `sunsky` (the sun's direction from the `sun` module; the sky a constant environment),
//! `constant` (a constant environment), `envmap` (a latitude-longitude map read from its
//! file, or a constant 0.5 grey with a warning when it cannot be read), and the point light
//! that stands for an `area` emitter on a shape (placed at the area-weighted centroid,
//! intensity `L · max(|Σ Aᵢ nᵢ|, A/4)`; see "Emitters" in the module docs of the loader).

use glam::{Mat3, Vec3};

use super::sun::{sun_position, SunTime};
use super::transform::to_world;
use super::tree::XNode;
use super::{bad, Loader, SKY_RADIANCE_PER_SCALE, SUN_IRRADIANCE_PER_SCALE};
use crate::error::Result;
use crate::scene::environment::file::load_in;
use crate::scene::{Environment, Light, Mesh};

impl<'t> Loader<'t> {
    fn set_environment(&mut self, node: &XNode, v: impl Into<Environment>) {
        if self.environment.is_some() {
            self.warn(format!(
                "{}: several environment emitters, the last is used",
                node.at()
            ));
        }
        self.environment = Some(v.into());
    }

    pub(super) fn emitter(&mut self, node: &'t XNode) -> Result<()> {
        let ty = node.ty().to_string();
        match ty.as_str() {
            "point" => {
                let m = to_world(node, &mut self.warnings)?;
                let position =
                    Self::point_param(node, &["position"], m.transform_point3(Vec3::ZERO))?;
                let intensity = self.const_param(node, &["intensity"], Vec3::ONE)?;
                self.lights.push(Light::Point {
                    position,
                    intensity,
                    range: f32::INFINITY,
                });
            }
            "spot" => {
                let m = to_world(node, &mut self.warnings)?;
                let position = m.transform_point3(Vec3::ZERO);
                let direction = m.transform_vector3(Vec3::Z).normalize_or_zero();
                if direction == Vec3::ZERO {
                    return Err(bad(
                        &node.file,
                        format!("line {}: spot without direction", node.line),
                    ));
                }
                let intensity = self.const_param(node, &["intensity"], Vec3::ONE)?;
                let cutoff = self.float_param(node, &["cutoffAngle"], 20.0)?;
                let beam = self.float_param(node, &["beamWidth"], cutoff * 0.75)?;
                let cutoff = cutoff.clamp(0.01, 90.0);
                let beam = beam.clamp(0.0, cutoff);
                self.lights.push(Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner: beam.to_radians().cos(),
                    cos_outer: cutoff.to_radians().cos(),
                    range: f32::INFINITY,
                });
            }
            "directional" => {
                let m = to_world(node, &mut self.warnings)?;
                let d = Self::point_param(node, &["direction"], m.transform_vector3(Vec3::Z))?;
                let direction = d.normalize_or_zero();
                if direction == Vec3::ZERO {
                    return Err(bad(
                        &node.file,
                        format!("line {}: zero direction", node.line),
                    ));
                }
                let irradiance = self.const_param(node, &["irradiance"], Vec3::ONE)?;
                self.lights.push(Light::Directional {
                    direction,
                    irradiance,
                });
            }
            "sun" | "sunsky" | "sky" => {
                let scale = self.float_param(node, &["scale"], 1.0)?;
                if ty != "sky" {
                    let sun_scale = if ty == "sunsky" {
                        self.float_param(node, &["sunScale"], 1.0)?
                    } else {
                        1.0
                    };
                    let to_sun = self.sun_direction(node)?;
                    if to_sun.y < 0.0 {
                        self.warn(format!("{}: the sun is below the horizon", node.at()));
                    }
                    self.lights.push(Light::Directional {
                        direction: -to_sun,
                        irradiance: SUN_IRRADIANCE_PER_SCALE * sun_scale * scale,
                    });
                }
                if ty != "sun" {
                    let sky_scale = if ty == "sunsky" {
                        self.float_param(node, &["skyScale"], 1.0)?
                    } else {
                        1.0
                    };
                    self.set_environment(node, SKY_RADIANCE_PER_SCALE * sky_scale * scale);
                }
            }
            "constant" => {
                let v = self.const_param(node, &["radiance"], Vec3::ONE)?;
                self.set_environment(node, v);
            }
            "envmap" => {
                let scale = self.float_param(node, &["scale"], 1.0)?;
                if !(scale.is_finite() && scale >= 0.0) {
                    return Err(bad(
                        &node.file,
                        format!(
                            "line {}: envmap scale {scale}: expected a number ≥ 0",
                            node.line
                        ),
                    ));
                }
                let fallback = Vec3::splat(0.5) * scale;
                let Some(f) = Self::string_param(node, &["filename"]) else {
                    self.warn(format!(
                        "{}: envmap without `filename`, using a constant {:?}",
                        node.at(),
                        fallback.to_array()
                    ));
                    self.set_environment(node, fallback);
                    return Ok(());
                };
                let p = self.resolve(&f);
                let m = to_world(node, &mut self.warnings)?;
                let map = match load_in(self.files, &p) {
                    Ok((map, note)) => {
                        // A map reduced to fit the memory limit: a note, not a warning.
                        self.warnings.extend(note);
                        map.scaled(scale)?
                    }
                    Err(e) => {
                        self.warn(format!(
                            "{}: environment map {}: {e}; using a constant {:?}",
                            node.at(),
                            p.display(),
                            fallback.to_array()
                        ));
                        self.set_environment(node, fallback);
                        return Ok(());
                    }
                };
                let map = match map.clone().with_rotation(Mat3::from_mat4(m)) {
                    Ok(turned) => turned,
                    Err(e) => {
                        self.warn(format!("{}: {e}; the map is not turned", node.at()));
                        map
                    }
                };
                self.set_environment(node, Environment::Map(map));
            }
            "area" => {
                self.warn(format!(
                    "{}: area emitter outside a shape ignored",
                    node.at()
                ));
            }
            other => {
                self.warn(format!(
                    "{}: emitter `{other}` unsupported, ignored",
                    node.at()
                ));
            }
        }
        Ok(())
    }

    /// Unit vector towards the sun (world space).
    fn sun_direction(&mut self, node: &'t XNode) -> Result<Vec3> {
        if node
            .children
            .iter()
            .any(|c| c.named(&["sunDirection", "direction"]))
        {
            let d = Self::point_param(node, &["sunDirection", "direction"], Vec3::Y)?;
            let d = d.normalize_or_zero();
            if d == Vec3::ZERO {
                return Err(bad(
                    &node.file,
                    format!("line {}: zero sun direction", node.line),
                ));
            }
            return Ok(d);
        }
        let mut f = |n: &str, d: f32| self.float_param(node, &[n], d);
        let date = SunTime {
            year: f("year", 2010.0)?,
            month: f("month", 7.0)?,
            day: f("day", 10.0)?,
            hour: f("hour", 15.0)?,
            minute: f("minute", 0.0)?,
            second: f("second", 0.0)?,
            latitude: f("latitude", 35.6894)?,
            longitude: f("longitude", 139.6917)?,
            timezone: f("timezone", 9.0)?,
        };
        let local = sun_position(&date);
        let m = to_world(node, &mut self.warnings)?;
        Ok(m.transform_vector3(local).normalize_or(Vec3::Y))
    }

    /// The point light standing for an area emitter (see the module docs).
    pub(super) fn area_light(&mut self, mesh: &Mesh, radiance: Vec3) -> Option<Light> {
        let mut area = 0.0f64;
        let mut centroid = glam::DVec3::ZERO;
        let mut normal_sum = glam::DVec3::ZERO;
        for t in &mesh.indices {
            let p = |i: u32| mesh.positions.get(i as usize).map(|v| v.as_dvec3());
            let (Some(a), Some(b), Some(c)) = (p(t[0]), p(t[1]), p(t[2])) else {
                continue;
            };
            let cr = (b - a).cross(c - a);
            let ai = 0.5 * cr.length();
            if !ai.is_finite() {
                continue;
            }
            area += ai;
            centroid += ai * (a + b + c) / 3.0;
            normal_sum += 0.5 * cr;
        }
        if area <= 0.0 {
            self.warnings.push(format!(
                "area emitter on `{}` has no area, no light added",
                mesh.name
            ));
            return None;
        }
        let centroid = (centroid / area).as_vec3();
        let projected = (normal_sum.length().max(area / 4.0)) as f32;
        let closed = normal_sum.length() < 0.25 * area;
        let position = if closed {
            self.warnings.push(format!(
                "area emitter on `{}` is a closed shape: its point light sits inside it",
                mesh.name
            ));
            centroid
        } else {
            centroid + 0.01 * normal_sum.normalize().as_vec3()
        };
        Some(Light::Point {
            position,
            intensity: radiance * projected,
            range: f32::INFINITY,
        })
    }
}
