//! Parameter values: numbers and number lists (commas or spaces), `x`/`y`/`z` triples or a
//! `value`, booleans, colours (`<rgb>` with one or three numbers or `#rrggbb`, `<srgb>`
//! decoded from sRGB, `<spectrum>` as a grey value or `λ:value` pairs averaged over
//! 400–500 / 500–600 / 600–700 nm into B / G / R, `<blackbody>` as white × scale), and the
//! loader's typed look-ups of a named parameter (constant colour, colour or texture, float,
//! string, boolean, point/vector), each with its default.

use glam::Vec3;

use super::tree::XNode;
use super::{bad, Loader};
use crate::error::Result;
use crate::scene::texture::srgb_to_linear;

/// A colour parameter: constant or a (pending) texture.
#[derive(Clone, Copy, Debug)]
pub(super) enum Color {
    Const(Vec3),
    Texture(usize),
}

/// The numbers of a list separated by commas and/or whitespace.
pub(super) fn numbers(node: &XNode, s: &str) -> Result<Vec<f32>> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|w| !w.is_empty())
        .map(|w| {
            w.parse::<f32>().map_err(|_| {
                bad(
                    &node.file,
                    format!(
                        "line {}: <{}> value `{s}` is not a list of numbers",
                        node.line, node.tag
                    ),
                )
            })
        })
        .collect()
}

pub(super) fn number(node: &XNode, s: &str) -> Result<f32> {
    let v = numbers(node, s)?;
    match v.as_slice() {
        [x] => Ok(*x),
        _ => Err(bad(
            &node.file,
            format!(
                "line {}: <{}> value `{s}` is not one number",
                node.line, node.tag
            ),
        )),
    }
}

pub(super) fn req_attr<'a>(node: &'a XNode, name: &str) -> Result<&'a str> {
    node.attr(name).ok_or_else(|| {
        bad(
            &node.file,
            format!("line {}: <{}> without `{name}`", node.line, node.tag),
        )
    })
}

/// `x`/`y`/`z` attributes (missing = `default`) or a `value` with 1 (uniform) or 3 numbers.
pub(super) fn xyz(node: &XNode, default: f32, value_key: &str) -> Result<Vec3> {
    if let Some(v) = node.attr(value_key) {
        let n = numbers(node, v)?;
        return match n.as_slice() {
            [s] => Ok(Vec3::splat(*s)),
            [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
            _ => Err(bad(
                &node.file,
                format!(
                    "line {}: <{}> `{v}` needs 1 or 3 numbers",
                    node.line, node.tag
                ),
            )),
        };
    }
    let mut out = Vec3::splat(default);
    for (i, k) in ["x", "y", "z"].iter().enumerate() {
        if let Some(s) = node.attr(k) {
            out[i] = number(node, s)?;
        }
    }
    Ok(out)
}

pub(super) fn parse_bool(node: &XNode) -> Result<bool> {
    let v = req_attr(node, "value")?;
    match v.trim().to_ascii_lowercase().as_str() {
        "true" | "1" | "yes" => Ok(true),
        "false" | "0" | "no" => Ok(false),
        _ => Err(bad(
            &node.file,
            format!(
                "line {}: boolean value `{v}` is not true or false",
                node.line
            ),
        )),
    }
}

pub(super) fn float_of(node: &XNode) -> Result<f32> {
    number(node, req_attr(node, "value")?)
}

fn hex_color(s: &str) -> Option<Vec3> {
    let h = s.trim().strip_prefix('#')?;
    if h.len() != 6 || !h.is_ascii() {
        return None;
    }
    let c = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
    Some(Vec3::new(
        srgb_to_linear(c(0)? as f32 / 255.0),
        srgb_to_linear(c(2)? as f32 / 255.0),
        srgb_to_linear(c(4)? as f32 / 255.0),
    ))
}

/// Spectrum `value`: one number (grey) or `λ:v` pairs averaged into RGB bands.
fn spectrum_value(node: &XNode, s: &str) -> Result<Vec3> {
    if !s.contains(':') {
        let n = numbers(node, s)?;
        return match n.as_slice() {
            [x] => Ok(Vec3::splat(*x)),
            [r, g, b] => Ok(Vec3::new(*r, *g, *b)),
            _ => Err(bad(
                &node.file,
                format!(
                    "line {}: spectrum `{s}` needs one value or λ:value pairs",
                    node.line
                ),
            )),
        };
    }
    let mut sums = [0.0f32; 3];
    let mut counts = [0u32; 3];
    let mut all = (0.0f32, 0u32);
    for pair in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (l, v) = pair.split_once(':').ok_or_else(|| {
            bad(
                &node.file,
                format!("line {}: spectrum entry `{pair}` is not λ:value", node.line),
            )
        })?;
        let l = number(node, l.trim())?;
        let v = number(node, v.trim())?;
        all.0 += v;
        all.1 += 1;
        let band = if (400.0..500.0).contains(&l) {
            2
        } else if (500.0..600.0).contains(&l) {
            1
        } else if (600.0..=700.0).contains(&l) {
            0
        } else {
            continue;
        };
        sums[band] += v;
        counts[band] += 1;
    }
    let mean = if all.1 > 0 { all.0 / all.1 as f32 } else { 0.0 };
    let band = |i: usize| {
        if counts[i] > 0 {
            sums[i] / counts[i] as f32
        } else {
            mean
        }
    };
    Ok(Vec3::new(band(0), band(1), band(2)))
}

impl<'t> Loader<'t> {
    /// A constant colour element (`rgb`, `srgb`, `spectrum`, `float`, `blackbody`).
    pub(super) fn constant_color(&mut self, c: &XNode) -> Result<Vec3> {
        let v = match c.tag.as_str() {
            "rgb" | "color" => {
                let s = req_attr(c, "value")?;
                if let Some(h) = hex_color(s) {
                    h
                } else {
                    let n = numbers(c, s)?;
                    match n.as_slice() {
                        [x] => Vec3::splat(*x),
                        [r, g, b] => Vec3::new(*r, *g, *b),
                        _ => {
                            return Err(bad(
                                &c.file,
                                format!("line {}: rgb `{s}` needs 1 or 3 numbers", c.line),
                            ))
                        }
                    }
                }
            }
            "srgb" => {
                let s = req_attr(c, "value")?;
                if let Some(h) = hex_color(s) {
                    h
                } else {
                    let n = numbers(c, s)?;
                    let v = match n.as_slice() {
                        [x] => Vec3::splat(*x),
                        [r, g, b] => Vec3::new(*r, *g, *b),
                        _ => {
                            return Err(bad(
                                &c.file,
                                format!("line {}: srgb `{s}` needs 1 or 3 numbers", c.line),
                            ))
                        }
                    };
                    let v = if v.max_element() > 1.0 { v / 255.0 } else { v };
                    Vec3::new(
                        srgb_to_linear(v.x),
                        srgb_to_linear(v.y),
                        srgb_to_linear(v.z),
                    )
                }
            }
            "spectrum" => {
                if let Some(s) = c.attr("value") {
                    spectrum_value(c, s)?
                } else {
                    self.warn(format!("{}: spectrum file not read, using white", c.at()));
                    Vec3::ONE
                }
            }
            "float" | "integer" => Vec3::splat(float_of(c)?),
            "blackbody" => {
                let scale = match c.attr("scale") {
                    Some(s) => number(c, s)?,
                    None => 1.0,
                };
                self.warn(format!(
                    "{}: blackbody spectrum approximated by white",
                    c.at()
                ));
                Vec3::splat(scale)
            }
            other => {
                return Err(bad(
                    &c.file,
                    format!("line {}: <{other}> is not a colour", c.line),
                ))
            }
        };
        if !v.is_finite() {
            return Err(bad(&c.file, format!("line {}: non-finite colour", c.line)));
        }
        Ok(v)
    }

    /// A colour parameter of `node` named one of `names` (constant, inline texture or
    /// `<ref>` to a texture), or `default`.
    pub(super) fn color_param(
        &mut self,
        node: &'t XNode,
        names: &[&str],
        default: Vec3,
    ) -> Result<Color> {
        let Some(c) = node.children.iter().find(|c| c.named(names)) else {
            return Ok(Color::Const(default));
        };
        match c.tag.as_str() {
            "texture" => self.texture(c, 0),
            "ref" => {
                let target = self.lookup(c)?;
                if target.tag == "texture" {
                    self.texture(target, 0)
                } else {
                    self.constant_color(target).map(Color::Const)
                }
            }
            _ => self.constant_color(c).map(Color::Const),
        }
    }

    /// A colour parameter used as a constant (textures → `default` with a warning).
    pub(super) fn const_param(
        &mut self,
        node: &'t XNode,
        names: &[&str],
        default: Vec3,
    ) -> Result<Vec3> {
        match self.color_param(node, names, default)? {
            Color::Const(v) => Ok(v),
            Color::Texture(_) => {
                self.warn(format!(
                    "{}: textured `{}` unsupported, using the default",
                    node.at(),
                    names[0]
                ));
                Ok(default)
            }
        }
    }

    /// A float parameter (a texture or a non-number → `default` with a warning).
    pub(super) fn float_param(
        &mut self,
        node: &'t XNode,
        names: &[&str],
        default: f32,
    ) -> Result<f32> {
        let Some(c) = node.children.iter().find(|c| c.named(names)) else {
            return Ok(default);
        };
        match c.tag.as_str() {
            "float" | "integer" => float_of(c),
            "texture" | "ref" => {
                self.warn(format!(
                    "{}: textured `{}` unsupported, using {default}",
                    c.at(),
                    names[0]
                ));
                Ok(default)
            }
            _ => Ok(self.constant_color(c)?.element_sum() / 3.0),
        }
    }

    pub(super) fn string_param(node: &XNode, names: &[&str]) -> Option<String> {
        node.param(&["string"], names)
            .and_then(|s| s.attr("value"))
            .map(str::to_string)
    }

    pub(super) fn bool_param(node: &XNode, names: &[&str], default: bool) -> Result<bool> {
        match node.param(&["boolean"], names) {
            Some(b) => parse_bool(b),
            None => Ok(default),
        }
    }

    pub(super) fn point_param(node: &XNode, names: &[&str], default: Vec3) -> Result<Vec3> {
        match node.param(&["point", "vector"], names) {
            Some(p) => xyz(p, 0.0, "value"),
            None => Ok(default),
        }
    }
}
