//! Sensors → cameras: `perspective` / `thinlens` look along +z of their `toWorld` frame;
//! `fov` with `fovAxis` (or `focalLength` on a 36 × 24 mm film) becomes a vertical field of
//! view for the `<film>`'s aspect; `orthographic` becomes a camera without a field of view
//! (warning); a mirrored transform is read unmirrored (warning).

use glam::{Mat3, Vec3};

use super::transform::to_world;
use super::tree::XNode;
use super::{bad, Loader};
use crate::error::Result;
use crate::scene::CameraDesc;

impl<'t> Loader<'t> {
    pub(super) fn sensor(&mut self, node: &'t XNode) -> Result<()> {
        let ty = node.ty();
        let yfov = match ty {
            "perspective" | "thinlens" | "perspective_rdist" => {
                let (w, h) = match node.children.iter().find(|c| c.tag == "film") {
                    Some(f) => (
                        self.float_param(f, &["width"], 768.0)?,
                        self.float_param(f, &["height"], 576.0)?,
                    ),
                    None => (768.0, 576.0),
                };
                if !(w >= 1.0 && h >= 1.0) {
                    return Err(bad(
                        &node.file,
                        format!("line {}: film size {w}x{h}", node.line),
                    ));
                }
                let aspect = w / h;
                let (fov, axis) = if node.children.iter().any(|c| c.named(&["fov"])) {
                    let axis = Self::string_param(node, &["fovAxis"]).unwrap_or_else(|| "x".into());
                    (self.float_param(node, &["fov"], 45.0)?, axis)
                } else {
                    let f =
                        Self::string_param(node, &["focalLength"]).unwrap_or_else(|| "50mm".into());
                    let f = f.trim().trim_end_matches("mm").trim();
                    let f: f32 = f.parse().map_err(|_| {
                        bad(
                            &node.file,
                            format!("line {}: focal length `{f}`", node.line),
                        )
                    })?;
                    let diag = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
                    (
                        (2.0 * (diag / (2.0 * f)).atan()).to_degrees(),
                        "diagonal".into(),
                    )
                };
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(bad(
                        &node.file,
                        format!("line {}: field of view {fov}° not in (0, 180)", node.line),
                    ));
                }
                let t = (fov.to_radians() * 0.5).tan();
                let tan_x = match axis.to_ascii_lowercase().as_str() {
                    "x" => t,
                    "y" => t * aspect,
                    "diagonal" => t / (1.0 + 1.0 / (aspect * aspect)).sqrt(),
                    "smaller" => {
                        if aspect > 1.0 {
                            t * aspect
                        } else {
                            t
                        }
                    }
                    "larger" => {
                        if aspect > 1.0 {
                            t
                        } else {
                            t * aspect
                        }
                    }
                    other => {
                        self.warn(format!("{}: fovAxis `{other}` unknown, using x", node.at()));
                        t
                    }
                };
                Some((2.0 * (tan_x / aspect).atan()).to_degrees())
            }
            "orthographic" | "telecentric" => {
                self.warn(format!(
                    "{}: {ty} sensor read as a perspective camera without a field of view",
                    node.at()
                ));
                None
            }
            other => {
                self.warn(format!("{}: sensor `{other}` ignored", node.at()));
                return Ok(());
            }
        };
        let m = to_world(node, &mut self.warnings)?;
        let position = m.transform_point3(Vec3::ZERO);
        let forward = m.transform_vector3(Vec3::Z).normalize_or_zero();
        let up0 = m.transform_vector3(Vec3::Y);
        let up = (up0 - forward * up0.dot(forward)).normalize_or_zero();
        if forward == Vec3::ZERO || up == Vec3::ZERO || !position.is_finite() {
            return Err(bad(
                &node.file,
                format!("line {}: degenerate camera transform", node.line),
            ));
        }
        if Mat3::from_mat4(m).determinant() < 0.0 {
            self.warn(format!(
                "{}: mirrored camera transform (the image would be flipped left-right), read unmirrored",
                node.at()
            ));
        }
        let name = node
            .attr("id")
            .map(str::to_string)
            .unwrap_or_else(|| format!("sensor {}", self.cameras.len()));
        self.cameras.push(CameraDesc {
            name,
            position,
            forward,
            up,
            yfov_deg: yfov,
        });
        Ok(())
    }
}
