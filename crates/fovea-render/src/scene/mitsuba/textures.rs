//! `<texture>` elements: a `bitmap` becomes a request for its file (decoded as sRGB unless
//! `gamma` is 1 or `raw` is true; requests are shared by path and colour space and decoded
//! in parallel when the scene is assembled); UV scale/offset and transforms are not supported
//! (warning); `scale` keeps the inner texture (a constant is scaled, a texture's scale is
//! dropped with a warning); `checkerboard` becomes the mean of its two colours (warning).

use std::path::PathBuf;

use glam::Vec3;

use super::tree::XNode;
use super::values::{float_of, parse_bool, Color};
use super::{bad, Loader, MAX_DEPTH};
use crate::error::Result;

impl<'t> Loader<'t> {
    pub(super) fn request_texture(&mut self, path: PathBuf, srgb: bool) -> usize {
        let key = (path, srgb);
        if let Some(&i) = self.tex_memo.get(&key) {
            return i;
        }
        self.tex_requests.push(key.clone());
        let i = self.tex_requests.len() - 1;
        self.tex_memo.insert(key, i);
        i
    }

    /// A `<texture>` element as a colour.
    pub(super) fn texture(&mut self, node: &'t XNode, depth: u32) -> Result<Color> {
        if depth > MAX_DEPTH {
            return Err(bad(
                &node.file,
                format!("line {}: texture nesting too deep", node.line),
            ));
        }
        match node.ty() {
            "bitmap" => {
                let file = node
                    .param(&["string"], &["filename"])
                    .and_then(|s| s.attr("value"))
                    .ok_or_else(|| {
                        bad(
                            &node.file,
                            format!("line {}: bitmap texture without filename", node.line),
                        )
                    })?;
                let mut srgb = true;
                if let Some(g) = node.param(&["float"], &["gamma"]) {
                    let g = float_of(g)?;
                    if (g - 1.0).abs() < 1e-3 {
                        srgb = false;
                    }
                }
                if let Some(r) = node.param(&["boolean"], &["raw"]) {
                    if parse_bool(r)? {
                        srgb = false;
                    }
                }
                for c in &node.children {
                    if c.named(&["uscale", "vscale", "uoffset", "voffset"]) {
                        let v = c.attr("value").unwrap_or("");
                        let default = if c.named(&["uscale", "vscale"]) {
                            "1"
                        } else {
                            "0"
                        };
                        if v.trim() != default {
                            self.warn(format!(
                                "{}: texture `{}` ignored (no UV transforms)",
                                c.at(),
                                c.attr("name").unwrap_or("")
                            ));
                        }
                    }
                    if c.tag == "transform" {
                        self.warn(format!("{}: texture UV transform ignored", c.at()));
                    }
                }
                let p = self.resolve(file);
                Ok(Color::Texture(self.request_texture(p, srgb)))
            }
            "scale" => {
                let inner = node
                    .children
                    .iter()
                    .find(|c| c.tag == "texture" || c.tag == "ref");
                let scale = match node.param(&["float", "rgb", "srgb", "spectrum"], &["scale"]) {
                    Some(s) => self.constant_color(s)?,
                    None => Vec3::ONE,
                };
                match inner {
                    Some(c) => {
                        let t = if c.tag == "ref" {
                            let target = self.lookup(c)?;
                            self.texture(target, depth + 1)?
                        } else {
                            self.texture(c, depth + 1)?
                        };
                        Ok(match t {
                            Color::Const(v) => Color::Const(v * scale),
                            tex => {
                                if scale != Vec3::ONE {
                                    self.warn(format!("{}: texture scale ignored", node.at()));
                                }
                                tex
                            }
                        })
                    }
                    None => Ok(Color::Const(scale)),
                }
            }
            "checkerboard" => {
                let c0 = match node.param(&["rgb", "srgb", "spectrum", "float"], &["color0"]) {
                    Some(c) => self.constant_color(c)?,
                    None => Vec3::splat(0.4),
                };
                let c1 = match node.param(&["rgb", "srgb", "spectrum", "float"], &["color1"]) {
                    Some(c) => self.constant_color(c)?,
                    None => Vec3::splat(0.2),
                };
                self.warn(format!(
                    "{}: checkerboard texture replaced by its mean colour",
                    node.at()
                ));
                Ok(Color::Const(0.5 * (c0 + c1)))
            }
            other => {
                self.warn(format!(
                    "{}: texture type `{other}` unsupported, using 0.5 grey",
                    node.at()
                ));
                Ok(Color::Const(Vec3::splat(0.5)))
            }
        }
    }
}
