//! `toWorld` / `to_world` transforms: `<translate>`, `<scale>` (uniform or per axis),
//! `<rotate>` (axis and degrees), `<matrix>` (16 or 9 numbers, row-major) and `<lookat>`
//! (Mitsuba's `lookAt` frame: columns left = up × dir, up, dir, origin), composed as Mitsuba
//! does: each new operation multiplied on the left. Animated transforms are ignored with a
//! warning.

use glam::{Mat3, Mat4, Vec3};

use super::bad;
use super::tree::XNode;
use super::values::{number, numbers, req_attr, xyz};
use crate::error::Result;

fn look_at(node: &XNode) -> Result<Mat4> {
    let p = |k: &str| -> Result<Option<Vec3>> {
        match node.attr(k) {
            None => Ok(None),
            Some(s) => {
                let n = numbers(node, s)?;
                match n.as_slice() {
                    [x, y, z] => Ok(Some(Vec3::new(*x, *y, *z))),
                    _ => Err(bad(
                        &node.file,
                        format!("line {}: lookat `{k}` needs 3 numbers", node.line),
                    )),
                }
            }
        }
    };
    let origin = p("origin")?.unwrap_or(Vec3::ZERO);
    let target = p("target")?.unwrap_or(Vec3::Z);
    let dir = (target - origin).normalize_or_zero();
    let mut up = p("up")?.unwrap_or(Vec3::Y);
    if dir == Vec3::ZERO {
        return Err(bad(
            &node.file,
            format!("line {}: lookat origin and target coincide", node.line),
        ));
    }
    if up.cross(dir).length_squared() < 1e-12 {
        up = if dir.y.abs() < 0.9 { Vec3::Y } else { Vec3::Z };
    }
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    Ok(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// Parses a `<transform>` element.
fn transform(node: &XNode, warnings: &mut Vec<String>) -> Result<Mat4> {
    let mut m = Mat4::IDENTITY;
    for op in &node.children {
        let t = match op.tag.as_str() {
            "translate" => Mat4::from_translation(xyz(op, 0.0, "value")?),
            "scale" => Mat4::from_scale(xyz(op, 1.0, "value")?),
            "rotate" => {
                let axis = if op.attr("value").is_some() {
                    xyz(op, 0.0, "value")?
                } else {
                    xyz(op, 0.0, "axis")?
                };
                let angle = number(op, req_attr(op, "angle")?)?;
                if axis.length_squared() < 1e-20 || !axis.is_finite() {
                    return Err(bad(
                        &op.file,
                        format!("line {}: rotation about a zero axis", op.line),
                    ));
                }
                Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = numbers(op, req_attr(op, "value")?)?;
                match v.len() {
                    16 => {
                        let mut a = [0.0f32; 16];
                        a.copy_from_slice(&v);
                        Mat4::from_cols_array(&a).transpose()
                    }
                    9 => {
                        let mut a = [0.0f32; 9];
                        a.copy_from_slice(&v);
                        Mat4::from_mat3(Mat3::from_cols_array(&a).transpose())
                    }
                    n => {
                        return Err(bad(
                            &op.file,
                            format!(
                                "line {}: <matrix> has {n} numbers, expected 16 or 9",
                                op.line
                            ),
                        ))
                    }
                }
            }
            "lookat" | "lookAt" => look_at(op)?,
            other => {
                warnings.push(format!("{}: transform <{other}> ignored", op.at()));
                continue;
            }
        };
        m = t * m;
    }
    if !m.is_finite() {
        return Err(bad(
            &node.file,
            format!("line {}: transform has non-finite entries", node.line),
        ));
    }
    Ok(m)
}

/// The `toWorld` / `to_world` transform of an element (identity when absent).
pub(super) fn to_world(node: &XNode, warnings: &mut Vec<String>) -> Result<Mat4> {
    if let Some(a) = node.param(&["animation"], &["toWorld"]) {
        warnings.push(format!("{}: animated transform ignored", a.at()));
    }
    match node.param(&["transform"], &["toWorld"]) {
        Some(t) => transform(t, warnings),
        None => Ok(Mat4::IDENTITY),
    }
}
