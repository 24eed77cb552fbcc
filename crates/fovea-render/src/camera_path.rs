//! A camera path for sequences: keyframes of eye position and look-at point over time,
//! interpolated linearly (positions and look-at points separately), held before the first and
//! after the last keyframe.
//!
//! Text format (CSV, header required, `#` comments and blank lines skipped, comma, semicolon
//! or tab separated): `t,x,y,z,look_x,look_y,look_z` with time in seconds and coordinates in
//! the scene's metres (after `--scene-scale`); an optional `up_x,up_y,up_z` triple sets the up
//! vector (default +y). Times must strictly increase; every value must be finite, and
//! coordinates within ±10⁹ m ([`MAX_COORDINATE_M`]); a look-at point equal to the position, or
//! an up vector along the view direction, is an error naming the keyframe and its line. At
//! most 1,000,000 keyframes.

use glam::Vec3;

use crate::error::{RenderError, Result};

/// One keyframe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time, seconds.
    pub t_s: f64,
    /// Eye position, metres.
    pub position: Vec3,
    /// Point looked at, metres.
    pub look_at: Vec3,
    /// Up vector.
    pub up: Vec3,
}

/// Keyframes in time order.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    keys: Vec<Keyframe>,
}

const MAX_KEYFRAMES: usize = 1_000_000;

/// Largest coordinate of a position or look-at point, metres. A camera's basis is built in
/// `f32` from `look_at − position`; far beyond this its squared length overflows (at
/// ~1.8·10¹⁹ m) and `f32`'s spacing (64 m at 10⁹ m) has long stopped resolving a scene.
pub const MAX_COORDINATE_M: f32 = 1e9;

/// `(x, y, z)` for messages, large values in scientific notation (`1e30`, not 31 digits).
fn show(v: Vec3) -> String {
    let c = |x: f32| {
        if x.abs() >= 1e6 {
            format!("{x:e}")
        } else {
            format!("{x}")
        }
    };
    format!("({}, {}, {})", c(v.x), c(v.y), c(v.z))
}

impl CameraPath {
    /// A path through `keys` (at least one, strictly increasing times, finite values within
    /// [`MAX_COORDINATE_M`], each keyframe a valid camera: look-at away from the position, up
    /// not along the view).
    pub fn new(keys: Vec<Keyframe>) -> Result<Self> {
        Self::checked(keys, None)
    }

    /// [`CameraPath::new`], with the text line of each keyframe for messages.
    fn checked(keys: Vec<Keyframe>, lines: Option<&[usize]>) -> Result<Self> {
        let name = |i: usize| match lines.and_then(|l| l.get(i)) {
            Some(line) => format!("camera path keyframe {i} (line {line})"),
            None => format!("camera path keyframe {i}"),
        };
        if keys.is_empty() || keys.len() > MAX_KEYFRAMES {
            return Err(RenderError::invalid(
                "camera path",
                format!("{} keyframes", keys.len()),
                format!("1 to {MAX_KEYFRAMES} keyframes"),
            ));
        }
        for (i, k) in keys.iter().enumerate() {
            if !(k.t_s.is_finite()
                && k.position.is_finite()
                && k.look_at.is_finite()
                && k.up.is_finite())
            {
                return Err(RenderError::invalid(
                    name(i),
                    format!(
                        "t {} s, position {}, look-at {}, up {}",
                        k.t_s,
                        show(k.position),
                        show(k.look_at),
                        show(k.up)
                    ),
                    "finite time, position, look-at and up (in f32)",
                ));
            }
            let far = |v: Vec3| v.abs().max_element() > MAX_COORDINATE_M;
            if far(k.position) || far(k.look_at) {
                return Err(RenderError::invalid(
                    name(i),
                    format!("position {}, look-at {}", show(k.position), show(k.look_at)),
                    format!("coordinates within ±{MAX_COORDINATE_M:e} m"),
                ));
            }
            let forward = (k.look_at - k.position).normalize_or_zero();
            if forward == Vec3::ZERO {
                return Err(RenderError::invalid(
                    name(i),
                    format!(
                        "position {} = look-at {}",
                        show(k.position),
                        show(k.look_at)
                    ),
                    "a look-at point away from the position",
                ));
            }
            if forward.cross(k.up).normalize_or_zero() == Vec3::ZERO {
                return Err(RenderError::invalid(
                    name(i),
                    format!(
                        "up {} along the view direction {}",
                        show(k.up),
                        show(forward)
                    ),
                    "a non-zero up vector not parallel to look-at − position",
                ));
            }
            if i > 0 && k.t_s <= keys[i - 1].t_s {
                return Err(RenderError::invalid(
                    name(i),
                    format!("{} s after {} s", k.t_s, keys[i - 1].t_s),
                    "strictly increasing times",
                ));
            }
        }
        Ok(Self { keys })
    }

    /// Parses the CSV text described in the module header.
    pub fn parse(text: &str) -> Result<Self> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim_start_matches('\u{feff}').trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        let (_, header) = lines.next().ok_or_else(|| {
            RenderError::invalid(
                "camera path",
                "an empty file",
                "a header t,x,y,z,look_x,look_y,look_z and one row per keyframe",
            )
        })?;
        let sep = if header.contains('\t') {
            '\t'
        } else if header.contains(';') {
            ';'
        } else {
            ','
        };
        let names: Vec<String> = header
            .split(sep)
            .map(|s| s.trim().trim_matches('"').to_ascii_lowercase())
            .collect();
        let col = |n: &str| names.iter().position(|c| c == n);
        let need = ["t", "x", "y", "z", "look_x", "look_y", "look_z"];
        let mut idx = Vec::new();
        for n in need {
            idx.push(col(n).ok_or_else(|| {
                RenderError::invalid(
                    "camera path header",
                    fovea_core::error::shorten(header, fovea_core::error::ECHO_CHARS),
                    "columns t,x,y,z,look_x,look_y,look_z (optional up_x,up_y,up_z)",
                )
            })?);
        }
        let up_idx = match (col("up_x"), col("up_y"), col("up_z")) {
            (Some(a), Some(b), Some(c)) => Some([a, b, c]),
            _ => None,
        };
        let mut keys = Vec::new();
        let mut key_lines = Vec::new();
        for (line_no, line) in lines {
            if keys.len() >= MAX_KEYFRAMES {
                return Err(RenderError::invalid(
                    "camera path",
                    "more rows",
                    format!("at most {MAX_KEYFRAMES} keyframes"),
                ));
            }
            let cells: Vec<&str> = line
                .split(sep)
                .map(|c| c.trim().trim_matches('"'))
                .collect();
            let num = |i: usize| -> Result<f64> {
                let cell = cells.get(i).copied().unwrap_or("");
                cell.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        RenderError::invalid(
                            format!("camera path line {line_no}, column {}", names[i]),
                            if cell.is_empty() {
                                "(empty)".into()
                            } else {
                                fovea_core::error::shorten(cell, fovea_core::error::ECHO_CHARS)
                            },
                            "a finite number",
                        )
                    })
            };
            let v3 = |a: usize, b: usize, c: usize| -> Result<Vec3> {
                Ok(Vec3::new(num(a)? as f32, num(b)? as f32, num(c)? as f32))
            };
            key_lines.push(line_no);
            keys.push(Keyframe {
                t_s: num(idx[0])?,
                position: v3(idx[1], idx[2], idx[3])?,
                look_at: v3(idx[4], idx[5], idx[6])?,
                up: match up_idx {
                    Some([a, b, c]) => v3(a, b, c)?,
                    None => Vec3::Y,
                },
            });
        }
        Self::checked(keys, Some(&key_lines))
    }

    /// The keyframes.
    pub fn keys(&self) -> &[Keyframe] {
        &self.keys
    }

    /// The pose at `t_s`: `(position, look_at, up)`, linear between keyframes, held outside.
    pub fn at(&self, t_s: f64) -> (Vec3, Vec3, Vec3) {
        let k = &self.keys;
        let first = k[0];
        let last = k[k.len() - 1];
        if t_s.is_nan() || t_s <= first.t_s {
            return (first.position, first.look_at, first.up);
        }
        if t_s >= last.t_s {
            return (last.position, last.look_at, last.up);
        }
        let i = k.partition_point(|key| key.t_s <= t_s);
        let (a, b) = (k[i - 1], k[i]);
        let f = ((t_s - a.t_s) / (b.t_s - a.t_s)) as f32;
        (
            a.position.lerp(b.position, f),
            a.look_at.lerp(b.look_at, f),
            a.up.lerp(b.up, f).normalize_or(Vec3::Y),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_interpolates() {
        let p = CameraPath::parse(
            "# a dolly\nt,x,y,z,look_x,look_y,look_z\n0,0,1,5,0,1,0\n2,2,1,5,2,1,0\n",
        )
        .unwrap();
        let (pos, look, up) = p.at(1.0);
        assert!((pos - Vec3::new(1.0, 1.0, 5.0)).length() < 1e-6);
        assert!((look - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
        assert_eq!(up, Vec3::Y);
        assert_eq!(p.at(-1.0).0, Vec3::new(0.0, 1.0, 5.0));
        assert_eq!(p.at(9.0).0, Vec3::new(2.0, 1.0, 5.0));
        assert_eq!(p.at(f64::NAN).0, Vec3::new(0.0, 1.0, 5.0));
        let semi = CameraPath::parse(
            // Looking down (−y) with +z up (an up along the view is refused).
            "t;x;y;z;look_x;look_y;look_z;up_x;up_y;up_z\n0;0;0;0;0;-1;0;0;0;1\n",
        )
        .unwrap();
        assert_eq!(semi.at(0.0).2, Vec3::Z);
    }

    #[test]
    fn bad_paths_are_errors() {
        for text in [
            "",
            "t,x,y,z\n0,0,0,0\n",
            "t,x,y,z,look_x,look_y,look_z\n",
            "t,x,y,z,look_x,look_y,look_z\n0,0,0,0,0,0,0\n",
            "t,x,y,z,look_x,look_y,look_z\n0,0,0,0,0,0,1\n0,1,0,0,0,0,1\n",
            "t,x,y,z,look_x,look_y,look_z\n0,0,0,0,0,0,1\n1,NaN,0,0,0,0,1\n",
            "t,x,y,z,look_x,look_y,look_z\n0,0,0,0,0,0\n",
        ] {
            assert!(CameraPath::parse(text).is_err(), "{text:?}");
        }
    }

    /// A far position or a degenerate keyframe names the keyframe, its line and the problem,
    /// in one line; a huge header is echoed cut short.
    #[test]
    fn bad_keyframes_name_their_line_and_problem() {
        let head = "# far away\nt,x,y,z,look_x,look_y,look_z\n0,0,0,5,0,0,0\n";
        let e = CameraPath::parse(&format!("{head}1,1e30,0,0,0,0,0\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("keyframe 1 (line 4)"), "{e}");
        assert!(e.contains("within ±1e9 m"), "{e}");
        assert!(!e.contains("parallel"), "{e}");
        let e = CameraPath::parse(&format!("{head}1,0,5,0,0,0,0\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("keyframe 1 (line 4)") && e.contains("along the view"),
            "{e}"
        );
        let e = CameraPath::parse(&format!("{head}1,0,0,5,0,0,5\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("away from the position"), "{e}");
        // 1e39 is finite in f64 but not in f32.
        let e = CameraPath::parse(&format!("{head}1,1e39,0,0,0,0,0\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("keyframe 1 (line 4)") && e.contains("finite"),
            "{e}"
        );
        // Just inside the bound is a path.
        assert!(CameraPath::parse(&format!("{head}1,1e9,0,0,0,0,0\n")).is_ok());
        let header: String = (0..10_000).map(|i| format!("c{i},")).collect();
        let e = CameraPath::parse(&format!("{header}\n1,2\n"))
            .unwrap_err()
            .to_string();
        assert_eq!(e.lines().count(), 1);
        assert!(e.len() < 600, "{} chars: {e}", e.len());
        assert!(e.contains('…'), "{e}");
    }
}
