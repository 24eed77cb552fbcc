//! Mitsuba scene XML loader (version 0.6 as in Bitterli's "Rendering resources"; the
//! snake_case parameter names of Mitsuba 2/3 are accepted too).
//!
//! # What is read
//!
//! The file is parsed with `roxmltree`; `<include filename=".."/>` elements are replaced by
//! the root children of the included file (resolved against the including file's directory,
//! then the scene's; depth ≤ 16, cycles rejected). `<default name="n" value="v"/>` entries
//! (anywhere, first wins) define parameters, and `$n` is substituted in every attribute
//! value; an unknown `$x` is left as written (the classroom's `<integrator type="$method">`
//! lines are ignored anyway). Parameter names are compared without case and underscores,
//! so `toWorld` = `to_world`, `diffuseReflectance` = `diffuse_reflectance`.
//!
//! Values: `<float>`/`<integer>`/`<boolean>`/`<string>` by `value`; colours as
//! `<rgb value="r, g, b"/>` (commas or spaces; one value = grey; `#rrggbb` = sRGB hex),
//! `<srgb>` (sRGB-decoded), `<spectrum value="0.5"/>` (grey) or
//! `value="400:0.1, 500:0.3, …"` (mean over 400–500 / 500–600 / 600–700 nm → B / G / R), a
//! `<float>` (grey); `<blackbody>` and spectrum files → white × scale with a warning;
//! `<point>`/`<vector>` by `x`/`y`/`z` (missing = 0) or `value`.
//!
//! Transforms (`toWorld`/`to_world`): children applied in order, each new one multiplied
//! on the left (`T = op · T`, as Mitsuba does): `<matrix value="16 numbers, row-major"/>` (or
//! 9 for a 3×3), `<translate x y z/>` or `value`, `<scale value="s"/>` (uniform),
//! `value="x y z"` or `x y z` (missing = 1), `<rotate x y z angle/>` (axis, degrees;
//! Mitsuba 3's `value` axis too), `<lookat origin target up/>` (Mitsuba's `lookAt`: columns
//! left = up × dir, up, dir, origin).
//!
//! # Mapping
//!
//! BSDFs (top level with `id`, referenced by `<ref id>`, or inline in a shape; each distinct
//! BSDF element becomes one [`Material`], named by its id):
//! * `twosided` → the wrapped BSDF with `two_sided = true`; BSDFs not wrapped are one-sided
//!   (`two_sided = false`), as in Mitsuba, except dielectrics.
//! * `diffuse`/`roughdiffuse`: `reflectance` (default 0.5) → `base_color`, roughness 1,
//!   specular 0 (pure Lambert).
//! * `plastic`/`roughplastic`: `diffuseReflectance` (0.5) → `base_color`; specular
//!   `F0 = ((η_int − η_ext)/(η_int + η_ext))²` from `intIOR` (1.49) / `extIOR` (1.000277)
//!   (≈ 0.04) × `specularReflectance`; roughness √α with `alpha` (0.1) for `roughplastic`,
//!   0.05 for the smooth `plastic`. All roughnesses are at least 0.05 (a sharper GGX lobe
//!   only aliases under point lights).
//! * `conductor`/`roughconductor`: metallic 1; `base_color` = F0 of the complex IOR
//!   `((η−1)² + k²)/((η+1)² + k²)` when `eta` and `k` are given, else a table of linear F0
//!   values for the `material` name (Al, Ag, Au, Cu, Cr, Fe, Ni, Ti, Pt, W, Hg, none), else a
//!   silver-like grey 0.9 (Mitsuba's own default is copper; a neutral grey is less
//!   surprising); multiplied by `specularReflectance` (default 1; a texture becomes the base
//!   colour texture), as Mitsuba multiplies its Fresnel term by it; roughness √α (`alpha`
//!   0.1, `alphaU`/`alphaV` averaged) for the rough one, 0.05 for the smooth one.
//! * `dielectric`/`roughdielectric`/`thindielectric`: **approximated as an opaque**,
//!   two-sided, near-white (0.9) glossy dielectric (F0 from the IORs, roughness 0.05 or √α)
//!   with a warning: the shading model has no transmission, so glass blocks light.
//! * `phong` (exponent → [`Material::roughness_from_phong`]), `ward` (√α), `principled`
//!   (Mitsuba 3: `base_color`, `metallic`, `roughness`, `specular` → F0 = 0.08·specular).
//! * `bumpmap`, `mask`, `coating`, `roughcoating`, `blendbsdf`, `mixturebsdf` → the first
//!   nested BSDF, with a warning; `normalmap` → the nested BSDF plus its `normalmap`
//!   texture as a (linear) normal map; `null` → the shape is skipped (invisible in Mitsuba);
//!   anything else → diffuse 0.5 grey with a warning.
//! * Textures: `<texture type="bitmap">` with `filename` → a texture decoded as sRGB (linear
//!   when `gamma` is 1 or `raw` is true), cached by path, decoded in parallel; it may be
//!   declared at top level with an `id` and referenced by `<ref name=".." id=".."/>`.
//!   UV scale/offset parameters are not supported (warning). A missing or undecodable file →
//!   a warning and a flat 0.5 grey. `scale` textures → the inner texture (scale dropped,
//!   warning), `checkerboard` → the mean of its two colours (warning). A texture where a
//!   number is expected (roughness…) → the default, with a warning.
//!
//! Shapes (`toWorld` applied; `flipNormals` flips normals and winding; no BSDF → Mitsuba's
//! default diffuse 0.5):
//! * `obj` (`filename`; `faceNormals` true → normals dropped; `flipTexCoords` false → `v` not
//!   flipped) and `ply` through [`super::obj::load_mesh`] / [`super::ply::load_mesh`],
//!   loaded in parallel (rayon) together with the textures.
//! * `rectangle`: the [-1, 1]² quad in z = 0, normal +z, uv = ((x+1)/2, (y+1)/2).
//! * `cube`: [-1, 1]³, 24 vertices, 12 triangles, outward normals.
//! * `sphere`: `center` (0) and `radius` (1) then `toWorld`; a UV sphere of 64 × 32
//!   segments with analytic normals, uv = (φ/2π, θ/π).
//! * `disk`: unit disk in z = 0, normal +z, 64 segments, planar uv ((x+1)/2, (y+1)/2).
//! * `cylinder`: `p0` (0,0,0), `p1` (0,0,1), `radius` (1); an open tube of 64 segments.
//! * `shapegroup` (with `id`) + `instance` (`<ref>` to the group, own `toWorld`): the group's
//!   shapes copied under the instance's transform.
//! * anything else (`serialized`, `hair`, `heightfield`, …) → skipped with a warning.
//!
//! Emitters:
//! * `area` inside a shape → the shape gets a copy of its material with
//!   `emissive = radiance`, **and** a point light is added (the renderer has no area
//!   lights): placed at the shape's area-weighted centroid, moved 1 cm along the mean
//!   normal so that it is not inside the geometry, with intensity `L · A⊥` where `A⊥ =
//!   max(|Σ Aᵢ nᵢ|, A/4)`: for a flat emitter that is its area `A`, the on-axis radiant
//!   intensity `L·A` of a Lambertian emitter (an isotropic point light of that intensity
//!   emits 4× the power of the one-sided emitter, but matches it straight ahead); for a
//!   closed emitter (sphere, cube) it is the mean projected area `A/4`, and the light sits at
//!   the centre, inside the shape (a warning says so: such a light is occluded by its own
//!   shape if shadow rays hit emitters).
//! * `point`: `position` or the `toWorld` translation, `intensity` (1).
//! * `spot`: `toWorld` (looks along +z), `intensity` (1), `cutoffAngle` (20°) → outer cone,
//!   `beamWidth` (¾ cutoff) → inner cone.
//! * `directional`: `direction` (or `toWorld` +z; the direction light travels), `irradiance`
//!   (1).
//! * `sun`, `sunsky`: a directional light travelling along −`sunDirection` (`sunDirection`
//!   points to the sun); without it the sun position is computed from `year`, `month`,
//!   `day`, `hour`, `minute`, `second`, `latitude`, `longitude`, `timezone` (Mitsuba's
//!   defaults: Tokyo, 2010-07-10 15:00) with the PSA algorithm (Blanco-Muriel et al. 2001),
//!   in Mitsuba's sky frame (+y up, north = −z, east = +x) and `toWorld`. Irradiance
//!   [`SUN_IRRADIANCE_PER_SCALE`] × `sunScale` × `scale` (our constant: the physical sun model
//!   is not reproduced).
//! * `sky`, `sunsky`: the environment becomes [`SKY_RADIANCE_PER_SCALE`] × `skyScale` ×
//!   `scale`, a constant sky blue.
//! * `constant`: `radiance` (1) → environment.
//! * `envmap`: its mean colour × `scale` when the image decodes (PNG/JPEG), otherwise
//!   0.5 grey × `scale`; always with a warning (no environment maps).
//! * Several environment emitters: the last wins, with a warning. Without any, the
//!   environment is a dim grey ([`super::obj::DEFAULT_ENVIRONMENT`]).
//!
//! Sensors (`perspective`, `thinlens`): Mitsuba's camera looks along +z of its `toWorld`
//! frame with +x to the image's left and +y up; position, forward and up come from the
//! matrix columns. `fov` with `fovAxis` (`x` default, `y`, `diagonal`, `smaller`, `larger`)
//! is converted to a vertical fov with the aspect of the `<film>` (`width`/`height`,
//! default 768 × 576); without `fov`, `focalLength` (default 50 mm, a 36 × 24 mm film
//! diagonal) is used. A mirrored `toWorld` is reported as a warning (the image would be
//! flipped). `orthographic` → a camera without fov, with a warning. `<integrator>`,
//! `<sampler>`, `<rfilter>`, `<medium>`, `<phase>` and the rest of `<film>` are ignored.
//!
//! Units: Mitsuba has none; `metres_per_unit` is 1 (Bitterli's scenes are roughly in
//! metres). The up axis is the file's (not converted).
//!
//! # Errors
//!
//! Malformed XML → [`RenderError::BadInput`] with `roxmltree`'s message and position;
//! a root other than `<scene>`, a number that does not parse, a `<ref>` to an undefined id,
//! a shape without a file or whose file does not exist (message names the shape, its line
//! and the file) → `BadInput`; errors of the OBJ/PLY loaders are passed on. Unknown
//! elements, shape/BSDF/emitter types → warnings.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Mat3, Mat4, Vec2, Vec3};
use rayon::prelude::*;

use super::texture::srgb_to_linear;
use super::{CameraDesc, Light, Material, MaterialId, Mesh, Scene, Texture, TextureId};
use crate::error::{RenderError, Result};

/// Irradiance of a `sun` / `sunsky` emitter per unit of `sunScale` × `scale` (our constant,
/// a warm white; the physical sun model of Mitsuba is not reproduced).
pub const SUN_IRRADIANCE_PER_SCALE: Vec3 = Vec3::new(1.0, 0.95, 0.9);

/// Constant environment radiance of a `sky` / `sunsky` emitter per unit of `skyScale` ×
/// `scale`: a sky blue `(0.4, 0.5, 0.7) × 0.1` (our constant), so that the sky lights a
/// horizontal surface with roughly a quarter of the sun's irradiance when both scales are
/// equal.
pub const SKY_RADIANCE_PER_SCALE: Vec3 = Vec3::new(0.04, 0.05, 0.07);

/// Segments of tessellated spheres, disks and cylinders around their axis.
const SEGMENTS: u32 = 64;
/// Rings of tessellated spheres (pole to pole).
const RINGS: u32 = 32;
/// Roughness of the smooth (`plastic`, `conductor`, `dielectric`) BSDFs and lower bound of
/// the rough ones: sharper GGX lobes only alias under point lights.
const MIN_ROUGHNESS: f32 = 0.05;
/// Deepest `<include>` nesting / `<ref>` chain.
const MAX_DEPTH: u32 = 16;

// ---------------------------------------------------------------------------------------
// Owned XML tree
// ---------------------------------------------------------------------------------------

/// An XML element with includes spliced in and `$` parameters substituted.
#[derive(Debug)]
struct XNode {
    tag: String,
    attrs: Vec<(String, String)>,
    children: Vec<XNode>,
    file: Arc<PathBuf>,
    line: u32,
}

impl XNode {
    fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// `file:line` for messages.
    fn at(&self) -> String {
        format!(
            "{} line {}",
            self.file
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            self.line
        )
    }

    /// `type` attribute or "".
    fn ty(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// Whether the `name` attribute matches one of `names` (case and `_` ignored).
    fn named(&self, names: &[&str]) -> bool {
        self.attr("name")
            .is_some_and(|n| names.iter().any(|w| norm_eq(n, w)))
    }

    /// First child with the given tag whose `name` matches.
    fn param(&self, tags: &[&str], names: &[&str]) -> Option<&XNode> {
        self.children
            .iter()
            .find(|c| tags.contains(&c.tag.as_str()) && c.named(names))
    }
}

fn norm_eq(a: &str, b: &str) -> bool {
    let mut x = a.chars().filter(|c| *c != '_');
    let mut y = b.chars().filter(|c| *c != '_');
    loop {
        match (x.next(), y.next()) {
            (None, None) => return true,
            (Some(p), Some(q)) if p.eq_ignore_ascii_case(&q) => {}
            _ => return false,
        }
    }
}

fn bad(file: &Path, what: impl Into<String>) -> RenderError {
    RenderError::bad(file, what)
}

/// Reads and parses `path` into an owned tree, splicing includes.
fn read_tree(path: &Path, stack: &mut Vec<PathBuf>, dirs: &mut Vec<PathBuf>) -> Result<XNode> {
    let bytes = std::fs::read(path).map_err(|e| RenderError::io(path, &e))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        bad(
            path,
            format!(
                "malformed XML: not UTF-8 text (byte {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })?;
    let doc =
        roxmltree::Document::parse(&text).map_err(|e| bad(path, format!("malformed XML: {e}")))?;
    let file = Arc::new(path.to_path_buf());
    let root = doc.root_element();
    stack.push(path.canonicalize().unwrap_or_else(|_| path.to_path_buf()));
    let out = convert_node(&doc, root, &file, stack, dirs);
    stack.pop();
    out
}

fn convert_node(
    doc: &roxmltree::Document,
    node: roxmltree::Node,
    file: &Arc<PathBuf>,
    stack: &mut Vec<PathBuf>,
    dirs: &mut Vec<PathBuf>,
) -> Result<XNode> {
    let line = doc.text_pos_at(node.range().start).row;
    let mut out = XNode {
        tag: node.tag_name().name().to_string(),
        attrs: node
            .attributes()
            .map(|a| (a.name().to_string(), a.value().to_string()))
            .collect(),
        children: Vec::new(),
        file: file.clone(),
        line,
    };
    for child in node.children().filter(|c| c.is_element()) {
        if child.tag_name().name() == "include" {
            let Some(rel) = child.attribute("filename") else {
                return Err(bad(
                    file,
                    format!(
                        "line {}: <include> without a filename",
                        doc.text_pos_at(child.range().start).row
                    ),
                ));
            };
            if stack.len() as u32 >= MAX_DEPTH {
                return Err(bad(
                    file,
                    format!("<include> nested deeper than {MAX_DEPTH}"),
                ));
            }
            let here = file.parent().map(Path::to_path_buf).unwrap_or_default();
            let mut target = here.join(rel);
            if !target.exists() {
                if let Some(alt) = dirs.iter().map(|d| d.join(rel)).find(|p| p.exists()) {
                    target = alt;
                }
            }
            if !target.exists() {
                return Err(bad(
                    file,
                    format!(
                        "line {}: included file {} does not exist",
                        doc.text_pos_at(child.range().start).row,
                        target.display()
                    ),
                ));
            }
            let canon = target.canonicalize().unwrap_or_else(|_| target.clone());
            if stack.contains(&canon) {
                return Err(bad(
                    file,
                    format!("<include> cycle through {}", target.display()),
                ));
            }
            if let Some(d) = target.parent() {
                if !dirs.iter().any(|x| x == d) {
                    dirs.push(d.to_path_buf());
                }
            }
            let sub = read_tree(&target, stack, dirs)?;
            out.children.extend(sub.children);
        } else {
            out.children
                .push(convert_node(doc, child, file, stack, dirs)?);
        }
    }
    Ok(out)
}

fn collect_defaults(node: &XNode, out: &mut HashMap<String, String>) {
    if node.tag == "default" {
        if let (Some(n), Some(v)) = (node.attr("name"), node.attr("value")) {
            out.entry(n.to_string()).or_insert_with(|| v.to_string());
        }
    }
    for c in &node.children {
        collect_defaults(c, out);
    }
}

/// Replaces `$name` by the parameter's value; unknown names are left as written.
fn substitute(s: &str, params: &HashMap<String, String>) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let len = after
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(after.len());
        let name = &after[..len];
        match params.get(name) {
            Some(v) if !name.is_empty() => out.push_str(v),
            _ => {
                out.push('$');
                out.push_str(name);
            }
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    out
}

fn substitute_tree(node: &mut XNode, params: &HashMap<String, String>) {
    for (_, v) in &mut node.attrs {
        if v.contains('$') {
            *v = substitute(v, params);
        }
    }
    for c in &mut node.children {
        substitute_tree(c, params);
    }
}

fn collect_ids<'t>(
    node: &'t XNode,
    ids: &mut HashMap<&'t str, &'t XNode>,
    warnings: &mut Vec<String>,
) {
    for c in &node.children {
        if c.tag != "ref" {
            if let Some(id) = c.attr("id") {
                if ids.contains_key(id) {
                    warnings.push(format!(
                        "{}: duplicate id `{id}`, the first is used",
                        c.at()
                    ));
                } else {
                    ids.insert(id, c);
                }
            }
        }
        collect_ids(c, ids, warnings);
    }
}

// ---------------------------------------------------------------------------------------
// Value parsing
// ---------------------------------------------------------------------------------------

fn numbers(node: &XNode, s: &str) -> Result<Vec<f32>> {
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

fn number(node: &XNode, s: &str) -> Result<f32> {
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

fn req_attr<'a>(node: &'a XNode, name: &str) -> Result<&'a str> {
    node.attr(name).ok_or_else(|| {
        bad(
            &node.file,
            format!("line {}: <{}> without `{name}`", node.line, node.tag),
        )
    })
}

/// `x`/`y`/`z` attributes (missing = `default`) or a `value` with 1 (uniform) or 3 numbers.
fn xyz(node: &XNode, default: f32, value_key: &str) -> Result<Vec3> {
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

fn parse_bool(node: &XNode) -> Result<bool> {
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

fn float_of(node: &XNode) -> Result<f32> {
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

// ---------------------------------------------------------------------------------------
// Transforms
// ---------------------------------------------------------------------------------------

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
fn to_world(node: &XNode, warnings: &mut Vec<String>) -> Result<Mat4> {
    if let Some(a) = node.param(&["animation"], &["toWorld"]) {
        warnings.push(format!("{}: animated transform ignored", a.at()));
    }
    match node.param(&["transform"], &["toWorld"]) {
        Some(t) => transform(t, warnings),
        None => Ok(Mat4::IDENTITY),
    }
}

// ---------------------------------------------------------------------------------------
// Built-in shapes
// ---------------------------------------------------------------------------------------

fn rectangle() -> Mesh {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let uvs = positions
        .iter()
        .map(|p| Vec2::new(0.5 * (p.x + 1.0), 0.5 * (p.y + 1.0)))
        .collect();
    Mesh {
        name: "rectangle".into(),
        normals: vec![Vec3::Z; 4],
        positions,
        uvs,
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..Mesh::default()
    }
}

fn cube() -> Mesh {
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ];
    let mut m = Mesh {
        name: "cube".into(),
        ..Mesh::default()
    };
    for (n, u, v) in faces {
        let base = m.positions.len() as u32;
        for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push(n + s * u + t * v);
            m.normals.push(n);
            m.uvs.push(Vec2::new(0.5 * (s + 1.0), 0.5 * (t + 1.0)));
        }
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base + 2, base + 3]);
    }
    m
}

fn sphere() -> Mesh {
    let (s, r) = (SEGMENTS, RINGS);
    let mut m = Mesh {
        name: "sphere".into(),
        ..Mesh::default()
    };
    for i in 0..=r {
        let theta = std::f32::consts::PI * i as f32 / r as f32;
        for j in 0..=s {
            let phi = std::f32::consts::TAU * j as f32 / s as f32;
            let p = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            m.positions.push(p);
            m.normals.push(p);
            m.uvs
                .push(Vec2::new(j as f32 / s as f32, i as f32 / r as f32));
        }
    }
    for i in 0..r {
        for j in 0..s {
            let a = i * (s + 1) + j;
            let (b, c) = (a + 1, a + s + 1);
            let d = c + 1;
            if i != 0 {
                m.indices.push([a, c, b]);
            }
            if i != r - 1 {
                m.indices.push([b, c, d]);
            }
        }
    }
    m
}

fn disk() -> Mesh {
    let mut m = Mesh {
        name: "disk".into(),
        positions: vec![Vec3::ZERO],
        normals: vec![Vec3::Z],
        uvs: vec![Vec2::splat(0.5)],
        ..Mesh::default()
    };
    for k in 0..SEGMENTS {
        let phi = std::f32::consts::TAU * k as f32 / SEGMENTS as f32;
        let p = Vec3::new(phi.cos(), phi.sin(), 0.0);
        m.positions.push(p);
        m.normals.push(Vec3::Z);
        m.uvs.push(Vec2::new(0.5 * (p.x + 1.0), 0.5 * (p.y + 1.0)));
        m.indices.push([0, 1 + k, 1 + (k + 1) % SEGMENTS]);
    }
    m
}

/// Open unit tube along +z from z = 0 to 1, radius 1.
fn tube() -> Mesh {
    let s = SEGMENTS;
    let mut m = Mesh {
        name: "cylinder".into(),
        ..Mesh::default()
    };
    for j in 0..=s {
        let phi = std::f32::consts::TAU * j as f32 / s as f32;
        let (x, y) = (phi.cos(), phi.sin());
        for z in [0.0, 1.0] {
            m.positions.push(Vec3::new(x, y, z));
            m.normals.push(Vec3::new(x, y, 0.0));
            m.uvs.push(Vec2::new(j as f32 / s as f32, z));
        }
    }
    for j in 0..s {
        let a = 2 * j;
        let (c, b) = (a + 1, a + 2);
        let d = b + 1;
        m.indices.push([a, b, c]);
        m.indices.push([b, d, c]);
    }
    m
}

// ---------------------------------------------------------------------------------------
// Materials
// ---------------------------------------------------------------------------------------

/// A texture a material waits for: slot, request index.
#[derive(Clone, Copy, Debug)]
enum Slot {
    BaseColor,
    Normal,
}

/// A colour parameter: constant or a (pending) texture.
#[derive(Clone, Copy, Debug)]
enum Color {
    Const(Vec3),
    Texture(usize),
}

#[derive(Clone, Debug)]
struct MatBuild {
    mat: Material,
    tex: Vec<(Slot, usize)>,
    invisible: bool,
}

/// Linear F0 of common conductors (Hoffman, "Physics and Math of Shading", sRGB primaries).
fn conductor_f0(name: &str) -> Option<Vec3> {
    let n = name.trim().to_ascii_lowercase();
    let n = n.strip_prefix("a-").unwrap_or(&n);
    Some(match n {
        "al" | "aluminium" | "aluminum" => Vec3::new(0.913, 0.922, 0.924),
        "ag" | "silver" => Vec3::new(0.972, 0.960, 0.915),
        "au" | "gold" => Vec3::new(1.000, 0.766, 0.336),
        "cu" | "copper" | "cu2o" | "cuo" => Vec3::new(0.955, 0.638, 0.538),
        "cr" | "chromium" => Vec3::new(0.550, 0.556, 0.554),
        "fe" | "iron" => Vec3::new(0.562, 0.565, 0.578),
        "ni" | "nickel" => Vec3::new(0.660, 0.609, 0.526),
        "ti" | "titanium" => Vec3::new(0.542, 0.497, 0.449),
        "pt" | "platinum" => Vec3::new(0.673, 0.637, 0.585),
        "w" | "tungsten" => Vec3::new(0.504, 0.498, 0.478),
        "hg" | "mercury" => Vec3::new(0.781, 0.779, 0.779),
        "none" => Vec3::ONE,
        _ => return None,
    })
}

/// Index of refraction by Mitsuba's names.
fn ior_by_name(name: &str) -> Option<f32> {
    Some(match name.trim().to_ascii_lowercase().as_str() {
        "vacuum" => 1.0,
        "helium" => 1.000_036,
        "hydrogen" => 1.000_132,
        "air" => 1.000_277,
        "carbon dioxide" => 1.000_45,
        "water" => 1.333,
        "acetone" => 1.36,
        "ethanol" => 1.361,
        "carbon tetrachloride" => 1.461,
        "glycerol" => 1.4729,
        "benzene" => 1.501,
        "silicone oil" => 1.52045,
        "bromine" => 1.661,
        "water ice" => 1.31,
        "fused quartz" => 1.458,
        "pyrex" => 1.470,
        "acrylic glass" => 1.49,
        "polypropylene" => 1.49,
        "bk7" => 1.5046,
        "sodium chloride" => 1.544,
        "amber" => 1.55,
        "pet" => 1.5750,
        "diamond" => 2.419,
        _ => return None,
    })
}

// ---------------------------------------------------------------------------------------
// The loader
// ---------------------------------------------------------------------------------------

enum Geometry {
    Obj {
        path: PathBuf,
        face_normals: bool,
        flip_tex: bool,
    },
    Ply {
        path: PathBuf,
        face_normals: bool,
    },
    Builtin(Mesh),
}

struct ShapeJob {
    name: String,
    geometry: Geometry,
    to_world: Mat4,
    material: MaterialId,
    flip_normals: bool,
    emitter: Option<Vec3>,
}

impl ShapeJob {
    fn build(&self) -> Result<Mesh> {
        let mut mesh = match &self.geometry {
            Geometry::Obj {
                path,
                face_normals,
                flip_tex,
            } => {
                let mut m = super::obj::load_mesh(path, self.material)?;
                if *face_normals {
                    m.normals.clear();
                }
                if !flip_tex {
                    for uv in &mut m.uvs {
                        uv.y = 1.0 - uv.y;
                    }
                }
                m
            }
            Geometry::Ply { path, face_normals } => {
                let mut m = super::ply::load_mesh(path, self.material)?;
                if *face_normals {
                    m.normals.clear();
                }
                // Mitsuba reads PLY texture coordinates as stored (v down the image).
                for uv in &mut m.uvs {
                    uv.y = 1.0 - uv.y;
                }
                m
            }
            Geometry::Builtin(m) => m.clone(),
        };
        mesh.name = self.name.clone();
        mesh.material = self.material;
        if self.flip_normals {
            for n in &mut mesh.normals {
                *n = -*n;
            }
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
        }
        mesh.transform(self.to_world);
        Ok(mesh)
    }
}

struct Loader<'t> {
    path: PathBuf,
    dirs: Vec<PathBuf>,
    ids: HashMap<&'t str, &'t XNode>,
    warnings: Vec<String>,
    materials: Vec<MatBuild>,
    /// BSDF element (by address) → material.
    bsdf_memo: HashMap<usize, (MaterialId, bool)>,
    default_material: Option<MaterialId>,
    tex_requests: Vec<(PathBuf, bool)>,
    tex_memo: HashMap<(PathBuf, bool), usize>,
    jobs: Vec<ShapeJob>,
    lights: Vec<Light>,
    cameras: Vec<CameraDesc>,
    environment: Option<Vec3>,
    shape_count: usize,
}

/// Loads a Mitsuba scene file (see the module docs for what is read and how).
pub fn load(path: &Path) -> Result<Scene> {
    let scene_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut dirs = vec![scene_dir];
    let mut tree = read_tree(path, &mut Vec::new(), &mut dirs)?;
    if tree.tag != "scene" {
        return Err(bad(
            path,
            format!("the root element is <{}>, expected <scene>", tree.tag),
        ));
    }
    let mut params = HashMap::new();
    collect_defaults(&tree, &mut params);
    substitute_tree(&mut tree, &params);

    let mut warnings = Vec::new();
    let mut ids = HashMap::new();
    collect_ids(&tree, &mut ids, &mut warnings);
    let mut l = Loader {
        path: path.to_path_buf(),
        dirs,
        ids,
        warnings,
        materials: Vec::new(),
        bsdf_memo: HashMap::new(),
        default_material: None,
        tex_requests: Vec::new(),
        tex_memo: HashMap::new(),
        jobs: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
        environment: None,
        shape_count: 0,
    };
    for node in &tree.children {
        l.top_level(node)?;
    }
    l.finish()
}

impl<'t> Loader<'t> {
    fn warn(&mut self, msg: String) {
        self.warnings.push(msg);
    }

    /// A file named in the scene: absolute, or relative to the scene's directory or to an
    /// included file's; Windows separators are tried as `/` when the name does not exist.
    fn resolve(&self, rel: &str) -> PathBuf {
        let p = Path::new(rel);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        let unix = rel.replace('\\', "/");
        let candidates = [rel, unix.as_str()];
        self.dirs
            .iter()
            .flat_map(|d| candidates.iter().map(move |c| d.join(c)))
            .find(|c| c.exists())
            .unwrap_or_else(|| self.dirs.first().cloned().unwrap_or_default().join(rel))
    }

    fn lookup(&self, r: &XNode) -> Result<&'t XNode> {
        let id = req_attr(r, "id")?;
        self.ids.get(id).copied().ok_or_else(|| {
            bad(
                &r.file,
                format!("line {}: <ref id=\"{id}\"> to an undefined id", r.line),
            )
        })
    }

    fn top_level(&mut self, node: &'t XNode) -> Result<()> {
        match node.tag.as_str() {
            "shape" => self.shape(node, Mat4::IDENTITY, 0),
            "sensor" | "camera" => self.sensor(node),
            "emitter" => self.emitter(node),
            // Declarations used through <ref>; shape groups are instanced.
            "bsdf" | "texture" | "default" => Ok(()),
            "integrator" | "sampler" | "film" | "rfilter" | "medium" | "phase" | "subsurface"
            | "volume" => Ok(()),
            other => {
                self.warn(format!("{}: <{other}> ignored", node.at()));
                Ok(())
            }
        }
    }

    // ----- textures and values -----

    fn request_texture(&mut self, path: PathBuf, srgb: bool) -> usize {
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
    fn texture(&mut self, node: &'t XNode, depth: u32) -> Result<Color> {
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

    /// A constant colour element (`rgb`, `srgb`, `spectrum`, `float`, `blackbody`).
    fn constant_color(&mut self, c: &XNode) -> Result<Vec3> {
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
    fn color_param(&mut self, node: &'t XNode, names: &[&str], default: Vec3) -> Result<Color> {
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
    fn const_param(&mut self, node: &'t XNode, names: &[&str], default: Vec3) -> Result<Vec3> {
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
    fn float_param(&mut self, node: &'t XNode, names: &[&str], default: f32) -> Result<f32> {
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

    fn string_param(node: &XNode, names: &[&str]) -> Option<String> {
        node.param(&["string"], names)
            .and_then(|s| s.attr("value"))
            .map(str::to_string)
    }

    fn bool_param(node: &XNode, names: &[&str], default: bool) -> Result<bool> {
        match node.param(&["boolean"], names) {
            Some(b) => parse_bool(b),
            None => Ok(default),
        }
    }

    fn point_param(node: &XNode, names: &[&str], default: Vec3) -> Result<Vec3> {
        match node.param(&["point", "vector"], names) {
            Some(p) => xyz(p, 0.0, "value"),
            None => Ok(default),
        }
    }

    fn ior(&mut self, node: &'t XNode, names: &[&str], default: f32) -> Result<f32> {
        if let Some(s) = node.param(&["string"], names) {
            let v = req_attr(s, "value")?;
            return Ok(match ior_by_name(v) {
                Some(x) => x,
                None => {
                    self.warn(format!("{}: unknown IOR name `{v}`, using 1.5", s.at()));
                    1.5
                }
            });
        }
        let v = self.float_param(node, names, default)?;
        Ok(if v.is_finite() && v > 0.0 { v } else { default })
    }

    fn alpha_roughness(&mut self, node: &'t XNode, default_alpha: f32) -> Result<f32> {
        let alpha = if node.children.iter().any(|c| c.named(&["alpha"])) {
            self.float_param(node, &["alpha"], default_alpha)?
        } else if node.children.iter().any(|c| c.named(&["alphaU", "alphaV"])) {
            let u = self.float_param(node, &["alphaU"], default_alpha)?;
            let v = self.float_param(node, &["alphaV"], default_alpha)?;
            0.5 * (u + v)
        } else {
            default_alpha
        };
        Ok(alpha.max(0.0).sqrt().clamp(MIN_ROUGHNESS, 1.0))
    }

    /// The first BSDF nested in `node` (inline or by reference).
    fn inner_bsdf(&self, node: &'t XNode) -> Result<Option<&'t XNode>> {
        for c in &node.children {
            if c.tag == "bsdf" {
                return Ok(Some(c));
            }
            if c.tag == "ref" {
                let t = self.lookup(c)?;
                if t.tag == "bsdf" {
                    return Ok(Some(t));
                }
            }
        }
        Ok(None)
    }

    /// Builds the material of a `<bsdf>` element (not registered).
    fn build_bsdf(&mut self, node: &'t XNode, depth: u32) -> Result<MatBuild> {
        if depth > MAX_DEPTH {
            return Err(bad(
                &node.file,
                format!(
                    "line {}: BSDF nesting too deep (reference cycle?)",
                    node.line
                ),
            ));
        }
        let name = node
            .attr("id")
            .map(str::to_string)
            .unwrap_or_else(|| format!("{} ({})", node.ty(), node.at()));
        let mut b = MatBuild {
            mat: Material {
                name: name.clone(),
                two_sided: false,
                ..Material::default()
            },
            tex: Vec::new(),
            invisible: false,
        };
        let ty = node.ty().to_string();
        let set_base = |b: &mut MatBuild, c: Color| match c {
            Color::Const(v) => b.mat.base_color = v,
            Color::Texture(i) => {
                b.mat.base_color = Vec3::ONE;
                b.tex.push((Slot::BaseColor, i));
            }
        };
        match ty.as_str() {
            "twosided" => {
                let mut inner = match self.inner_bsdf(node)? {
                    Some(i) => self.build_bsdf(i, depth + 1)?,
                    None => {
                        self.warn(format!("{}: empty twosided BSDF, using diffuse", node.at()));
                        MatBuild {
                            mat: Material::diffuse(name.clone(), Vec3::splat(0.5)),
                            tex: Vec::new(),
                            invisible: false,
                        }
                    }
                };
                inner.mat.two_sided = true;
                if node.attr("id").is_some() {
                    inner.mat.name = name;
                }
                return Ok(inner);
            }
            "diffuse" | "roughdiffuse" | "difftrans" => {
                let names: &[&str] = if ty == "difftrans" {
                    &["transmittance"]
                } else {
                    &["reflectance"]
                };
                let c = self.color_param(node, names, Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.roughness = 1.0;
                b.mat.specular = Vec3::ZERO;
                if ty == "difftrans" {
                    self.warn(format!("{}: difftrans approximated by diffuse", node.at()));
                }
            }
            "plastic" | "roughplastic" => {
                let c = self.color_param(node, &["diffuseReflectance"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                let int = self.ior(node, &["intIOR"], 1.49)?;
                let ext = self.ior(node, &["extIOR"], 1.000_277)?;
                let f0 = ((int - ext) / (int + ext)).powi(2);
                let ks = self.const_param(node, &["specularReflectance"], Vec3::ONE)?;
                b.mat.specular = (ks * f0).clamp(Vec3::ZERO, Vec3::ONE);
                b.mat.roughness = if ty == "plastic" {
                    MIN_ROUGHNESS
                } else {
                    self.alpha_roughness(node, 0.1)?
                };
            }
            "conductor" | "roughconductor" => {
                b.mat.metallic = 1.0;
                let has = |n: &str| node.children.iter().any(|c| c.named(&[n]));
                let mut f0 = if has("eta") && has("k") {
                    let eta = self.const_param(node, &["eta"], Vec3::ONE)?;
                    let k = self.const_param(node, &["k"], Vec3::ZERO)?;
                    let num = (eta - Vec3::ONE) * (eta - Vec3::ONE) + k * k;
                    let den = (eta + Vec3::ONE) * (eta + Vec3::ONE) + k * k;
                    (num / den.max(Vec3::splat(1e-6))).clamp(Vec3::ZERO, Vec3::ONE)
                } else if let Some(m) = Self::string_param(node, &["material"]) {
                    match conductor_f0(&m) {
                        Some(v) => v,
                        None => {
                            self.warn(format!(
                                "{}: conductor `{m}` not in the table, using grey 0.9",
                                node.at()
                            ));
                            Vec3::splat(0.9)
                        }
                    }
                } else {
                    Vec3::splat(0.9)
                };
                match self.color_param(node, &["specularReflectance"], Vec3::ONE)? {
                    Color::Const(v) => f0 *= v,
                    Color::Texture(i) => b.tex.push((Slot::BaseColor, i)),
                }
                b.mat.base_color = f0;
                b.mat.roughness = if ty == "conductor" {
                    MIN_ROUGHNESS
                } else {
                    self.alpha_roughness(node, 0.1)?
                };
            }
            "dielectric" | "roughdielectric" | "thindielectric" => {
                let int = self.ior(node, &["intIOR"], 1.5046)?;
                let ext = self.ior(node, &["extIOR"], 1.000_277)?;
                b.mat.base_color = Vec3::splat(0.9);
                b.mat.specular = Vec3::splat(((int - ext) / (int + ext)).powi(2));
                b.mat.roughness = if ty == "roughdielectric" {
                    self.alpha_roughness(node, 0.1)?
                } else {
                    MIN_ROUGHNESS
                };
                b.mat.two_sided = true;
                self.warn(format!(
                    "{}: {ty} `{name}` approximated as an opaque glossy white surface (no transmission)",
                    node.at()
                ));
            }
            "phong" => {
                let c = self.color_param(node, &["diffuseReflectance"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.specular = self
                    .const_param(node, &["specularReflectance"], Vec3::splat(0.2))?
                    .clamp(Vec3::ZERO, Vec3::ONE);
                let e = self.float_param(node, &["exponent"], 30.0)?;
                b.mat.roughness = Material::roughness_from_phong(e);
            }
            "ward" => {
                let c = self.color_param(node, &["diffuseReflectance"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.specular = self
                    .const_param(node, &["specularReflectance"], Vec3::splat(0.2))?
                    .clamp(Vec3::ZERO, Vec3::ONE);
                b.mat.roughness = self.alpha_roughness(node, 0.1)?;
            }
            "principled" => {
                let c = self.color_param(node, &["base_color"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.metallic = self.float_param(node, &["metallic"], 0.0)?.clamp(0.0, 1.0);
                b.mat.roughness = self
                    .float_param(node, &["roughness"], 0.5)?
                    .clamp(MIN_ROUGHNESS, 1.0);
                b.mat.specular =
                    Vec3::splat(0.08 * self.float_param(node, &["specular"], 0.5)?.clamp(0.0, 1.0));
            }
            "null" => {
                b.invisible = true;
            }
            "bumpmap" | "normalmap" | "mask" | "coating" | "roughcoating" | "blendbsdf"
            | "mixturebsdf" => {
                let mut inner = match self.inner_bsdf(node)? {
                    Some(i) => self.build_bsdf(i, depth + 1)?,
                    None => {
                        self.warn(format!("{}: {ty} without a nested BSDF", node.at()));
                        MatBuild {
                            mat: Material::diffuse(name.clone(), Vec3::splat(0.5)),
                            tex: Vec::new(),
                            invisible: false,
                        }
                    }
                };
                let mut used = false;
                if ty == "normalmap" {
                    if let Some(t) = node.children.iter().find(|c| c.tag == "texture") {
                        if let Some(file) = t
                            .param(&["string"], &["filename"])
                            .and_then(|s| s.attr("value"))
                        {
                            let p = self.resolve(file);
                            let i = self.request_texture(p, false);
                            inner.tex.push((Slot::Normal, i));
                            used = true;
                        }
                    }
                }
                if !used {
                    self.warn(format!(
                        "{}: {ty} not supported, using the nested BSDF only",
                        node.at()
                    ));
                }
                if node.attr("id").is_some() {
                    inner.mat.name = name;
                }
                return Ok(inner);
            }
            other => {
                self.warn(format!(
                    "{}: BSDF type `{other}` unsupported, using diffuse 0.5",
                    node.at()
                ));
                b.mat.base_color = Vec3::splat(0.5);
                b.mat.roughness = 1.0;
                b.mat.specular = Vec3::ZERO;
            }
        }
        Ok(b)
    }

    /// The registered material of a `<bsdf>` element, built once per element.
    fn material_of(&mut self, node: &'t XNode) -> Result<(MaterialId, bool)> {
        let key = node as *const XNode as usize;
        if let Some(&m) = self.bsdf_memo.get(&key) {
            return Ok(m);
        }
        let b = self.build_bsdf(node, 0)?;
        let invisible = b.invisible;
        self.materials.push(b);
        let id = (self.materials.len() - 1) as MaterialId;
        self.bsdf_memo.insert(key, (id, invisible));
        Ok((id, invisible))
    }

    fn default_material(&mut self) -> MaterialId {
        if let Some(m) = self.default_material {
            return m;
        }
        self.materials.push(MatBuild {
            mat: Material {
                two_sided: false,
                specular: Vec3::ZERO,
                ..Material::diffuse("default", Vec3::splat(0.5))
            },
            tex: Vec::new(),
            invisible: false,
        });
        let id = (self.materials.len() - 1) as MaterialId;
        self.default_material = Some(id);
        id
    }

    // ----- shapes -----

    fn shape(&mut self, node: &'t XNode, parent: Mat4, depth: u32) -> Result<()> {
        self.shape_count += 1;
        let index = self.shape_count;
        let ty = node.ty().to_string();
        let label = match node.attr("id") {
            Some(id) => format!("shape `{id}` ({ty}, {})", node.at()),
            None => format!("shape #{index} ({ty}, {})", node.at()),
        };
        if ty == "shapegroup" {
            return Ok(()); // instanced through <shape type="instance">
        }
        let to_world = parent * to_world(node, &mut self.warnings)?;
        if ty == "instance" {
            if depth > MAX_DEPTH {
                return Err(bad(
                    &node.file,
                    format!("{label}: instances nested too deep"),
                ));
            }
            let r = node
                .children
                .iter()
                .find(|c| c.tag == "ref")
                .ok_or_else(|| bad(&node.file, format!("{label}: instance without a <ref>")))?;
            let group = self.lookup(r)?;
            for c in group.children.iter().filter(|c| c.tag == "shape") {
                self.shape(c, to_world, depth + 1)?;
            }
            return Ok(());
        }

        // Material.
        let mut material = None;
        for c in &node.children {
            let target = match c.tag.as_str() {
                "bsdf" => c,
                "ref" => {
                    let t = self.lookup(c)?;
                    if t.tag != "bsdf" {
                        continue; // media, textures…
                    }
                    t
                }
                _ => continue,
            };
            material = Some(self.material_of(target)?);
            break;
        }
        let material = match material {
            Some((_, true)) => {
                self.warn(format!("{label}: null BSDF, shape skipped (invisible)"));
                return Ok(());
            }
            Some((m, false)) => m,
            None => self.default_material(),
        };

        let emitter = match node.children.iter().find(|c| c.tag == "emitter") {
            Some(e) if e.ty() == "area" => Some(
                self.const_param(e, &["radiance"], Vec3::ONE)?
                    .max(Vec3::ZERO),
            ),
            Some(e) => {
                self.warn(format!("{}: shape emitter `{}` ignored", e.at(), e.ty()));
                None
            }
            None => None,
        };
        let flip_normals = Self::bool_param(node, &["flipNormals"], false)?;
        let face_normals = Self::bool_param(node, &["faceNormals"], false)?;

        let file = |this: &Self| -> Result<PathBuf> {
            let rel = Self::string_param(node, &["filename"])
                .ok_or_else(|| bad(&this.path, format!("{label} has no filename")))?;
            let p = this.resolve(&rel);
            if !p.is_file() {
                return Err(bad(
                    &this.path,
                    format!("{label} references {}, which does not exist", p.display()),
                ));
            }
            Ok(p)
        };
        let (geometry, local) = match ty.as_str() {
            "obj" => (
                Geometry::Obj {
                    path: file(self)?,
                    face_normals,
                    flip_tex: Self::bool_param(node, &["flipTexCoords"], true)?,
                },
                Mat4::IDENTITY,
            ),
            "ply" => (
                Geometry::Ply {
                    path: file(self)?,
                    face_normals,
                },
                Mat4::IDENTITY,
            ),
            "rectangle" => (Geometry::Builtin(rectangle()), Mat4::IDENTITY),
            "cube" => (Geometry::Builtin(cube()), Mat4::IDENTITY),
            "disk" => (Geometry::Builtin(disk()), Mat4::IDENTITY),
            "sphere" => {
                let c = Self::point_param(node, &["center"], Vec3::ZERO)?;
                let r = self.float_param(node, &["radius"], 1.0)?;
                if !(r.is_finite() && r > 0.0) {
                    return Err(bad(&node.file, format!("{label}: radius {r} is not > 0")));
                }
                (
                    Geometry::Builtin(sphere()),
                    Mat4::from_translation(c) * Mat4::from_scale(Vec3::splat(r)),
                )
            }
            "cylinder" => {
                let p0 = Self::point_param(node, &["p0"], Vec3::ZERO)?;
                let p1 = Self::point_param(node, &["p1"], Vec3::Z)?;
                let r = self.float_param(node, &["radius"], 1.0)?;
                let d = p1 - p0;
                if !(r.is_finite() && r > 0.0) || d.length_squared() < 1e-20 {
                    return Err(bad(
                        &node.file,
                        format!("{label}: needs radius > 0 and p0 ≠ p1"),
                    ));
                }
                let w = d.normalize();
                let (u, v) = w.any_orthonormal_pair();
                let frame = Mat4::from_cols(
                    (u * r).extend(0.0),
                    (v * r).extend(0.0),
                    d.extend(0.0),
                    p0.extend(1.0),
                );
                // Keep the frame right-handed so that normals stay outward.
                let frame = if u.cross(v).dot(w) < 0.0 {
                    frame * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))
                } else {
                    frame
                };
                (Geometry::Builtin(tube()), frame)
            }
            other => {
                self.warn(format!(
                    "{label}: shape type `{other}` unsupported, skipped"
                ));
                return Ok(());
            }
        };
        let name = node
            .attr("id")
            .map(str::to_string)
            .or_else(|| match &geometry {
                Geometry::Obj { path, .. } | Geometry::Ply { path, .. } => {
                    path.file_stem().map(|s| s.to_string_lossy().into_owned())
                }
                Geometry::Builtin(_) => None,
            })
            .unwrap_or_else(|| format!("{ty} #{index}"));
        self.jobs.push(ShapeJob {
            name,
            geometry,
            to_world: to_world * local,
            material,
            flip_normals,
            emitter,
        });
        Ok(())
    }

    // ----- sensors -----

    fn sensor(&mut self, node: &'t XNode) -> Result<()> {
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

    // ----- emitters -----

    fn set_environment(&mut self, node: &XNode, v: Vec3) {
        if self.environment.is_some() {
            self.warn(format!(
                "{}: several environment emitters, the last is used",
                node.at()
            ));
        }
        self.environment = Some(v);
    }

    fn emitter(&mut self, node: &'t XNode) -> Result<()> {
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
                let mean = match Self::string_param(node, &["filename"]) {
                    Some(f) => {
                        let p = self.resolve(&f);
                        match Texture::load(&p, true) {
                            Ok(t) => t.sample(Vec2::splat(0.5), 64.0).truncate(),
                            Err(_) => Vec3::splat(0.5),
                        }
                    }
                    None => Vec3::splat(0.5),
                };
                self.warn(format!(
                    "{}: environment map replaced by a constant {:?}",
                    node.at(),
                    (mean * scale).to_array()
                ));
                self.set_environment(node, mean * scale);
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

    // ----- assembly -----

    fn finish(mut self) -> Result<Scene> {
        let jobs = std::mem::take(&mut self.jobs);
        let requests = std::mem::take(&mut self.tex_requests);
        let (meshes, textures): (Vec<Result<Mesh>>, Vec<Result<Texture>>) = rayon::join(
            || jobs.par_iter().map(ShapeJob::build).collect(),
            || {
                requests
                    .par_iter()
                    .map(|(p, srgb)| Texture::load(p, *srgb))
                    .collect()
            },
        );

        // Textures → ids.
        let mut scene_textures = Vec::new();
        let mut tex_ids: Vec<Option<TextureId>> = Vec::with_capacity(textures.len());
        for ((p, _), t) in requests.iter().zip(textures) {
            match t {
                Ok(t) => {
                    tex_ids.push(Some(scene_textures.len() as TextureId));
                    scene_textures.push(t);
                }
                Err(e) => {
                    self.warnings.push(format!(
                        "texture {}: {e}; using a flat 0.5 grey",
                        p.display()
                    ));
                    tex_ids.push(None);
                }
            }
        }

        let mut out_meshes = Vec::with_capacity(meshes.len());
        let mut emissive_memo: HashMap<(MaterialId, [u32; 3]), MaterialId> = HashMap::new();
        for (job, mesh) in jobs.iter().zip(meshes) {
            let mut mesh = mesh?;
            if let Some(radiance) = job.emitter {
                let key = (job.material, radiance.to_array().map(f32::to_bits));
                let mid = match emissive_memo.get(&key) {
                    Some(&m) => m,
                    None => {
                        let mut b = self.materials[job.material as usize].clone();
                        b.mat.emissive = radiance;
                        b.mat.name = format!("{} (emitter)", b.mat.name);
                        self.materials.push(b);
                        let m = (self.materials.len() - 1) as MaterialId;
                        emissive_memo.insert(key, m);
                        m
                    }
                };
                mesh.material = mid;
                if let Some(light) = self.area_light(&mesh, radiance) {
                    self.lights.push(light);
                }
            }
            out_meshes.push(mesh);
        }

        let mut materials = Vec::with_capacity(self.materials.len());
        for b in self.materials {
            let mut m = b.mat;
            for (slot, req) in b.tex {
                match (slot, tex_ids.get(req).copied().flatten()) {
                    (Slot::BaseColor, Some(id)) => m.base_color_texture = Some(id),
                    (Slot::BaseColor, None) => m.base_color = Vec3::splat(0.5),
                    (Slot::Normal, Some(id)) => m.normal_texture = Some(id),
                    (Slot::Normal, None) => {}
                }
            }
            materials.push(m);
        }

        Ok(Scene {
            name: String::new(),
            source: Some(self.path),
            meshes: out_meshes,
            materials,
            textures: scene_textures,
            lights: self.lights,
            cameras: self.cameras,
            environment: self.environment.unwrap_or(super::obj::DEFAULT_ENVIRONMENT),
            metres_per_unit: 1.0,
            warnings: self.warnings,
        })
    }

    /// The point light standing for an area emitter (see the module docs).
    fn area_light(&mut self, mesh: &Mesh, radiance: Vec3) -> Option<Light> {
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

// ---------------------------------------------------------------------------------------
// Sun position (PSA algorithm, Blanco-Muriel et al. 2001, as in Mitsuba's sunsky)
// ---------------------------------------------------------------------------------------

struct SunTime {
    year: f32,
    month: f32,
    day: f32,
    hour: f32,
    minute: f32,
    second: f32,
    latitude: f32,
    longitude: f32,
    timezone: f32,
}

/// Direction towards the sun in Mitsuba's sky frame (+y up, north −z, east +x).
fn sun_position(t: &SunTime) -> Vec3 {
    let (year, month, day) = (t.year as i64, t.month as i64, t.day as i64);
    let dec_hours =
        t.hour as f64 - t.timezone as f64 + (t.minute as f64 + t.second as f64 / 60.0) / 60.0;
    let aux1 = (month - 14) / 12;
    let aux2 = (1461 * (year + 4800 + aux1)) / 4 + (367 * (month - 2 - 12 * aux1)) / 12
        - (3 * ((year + 4900 + aux1) / 100)) / 4
        + day
        - 32075;
    let julian = aux2 as f64 - 0.5 + dec_hours / 24.0;
    let n = julian - 2_451_545.0;

    let omega = 2.1429 - 0.001_039_459_4 * n;
    let mean_longitude = 4.895_063_0 + 0.017_202_791_698 * n;
    let anomaly = 6.240_060_0 + 0.017_201_969_9 * n;
    let ecl_longitude =
        mean_longitude + 0.033_416_07 * anomaly.sin() + 0.000_348_94 * (2.0 * anomaly).sin()
            - 0.000_113_4
            - 0.000_020_3 * omega.sin();
    let ecl_obliquity = 0.409_092_8 - 6.214e-9 * n + 0.000_039_6 * omega.cos();

    let sin_el = ecl_longitude.sin();
    let mut ra = (ecl_obliquity.cos() * sin_el).atan2(ecl_longitude.cos());
    if ra < 0.0 {
        ra += std::f64::consts::TAU;
    }
    let declination = (ecl_obliquity.sin() * sin_el).asin();

    let gmst = 6.697_424_324_2 + 0.065_709_828_3 * n + dec_hours;
    let lmst = (gmst * 15.0 + t.longitude as f64).to_radians();
    let lat = (t.latitude as f64).to_radians();
    let hour_angle = lmst - ra;
    let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos()
        + declination.sin() * lat.sin())
    .clamp(-1.0, 1.0)
    .acos();
    let mut azimuth =
        (-hour_angle.sin()).atan2(declination.tan() * lat.cos() - lat.sin() * hour_angle.cos());
    if azimuth < 0.0 {
        azimuth += std::f64::consts::TAU;
    }
    zenith += (6371.01 / 149_597_890.0) * zenith.sin();

    let (st, ct) = zenith.sin_cos();
    let (sp, cp) = azimuth.sin_cos();
    Vec3::new((sp * st) as f32, ct as f32, (-cp * st) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substitution_keeps_unknown_names() {
        let mut p = HashMap::new();
        p.insert("a".to_string(), "1".to_string());
        assert_eq!(substitute("$a", &p), "1");
        assert_eq!(substitute("x$a,$b $", &p), "x1,$b $");
        assert_eq!(substitute("$method", &p), "$method");
    }

    #[test]
    fn norm_eq_ignores_case_and_underscores() {
        assert!(norm_eq("toWorld", "to_world"));
        assert!(norm_eq("diffuse_reflectance", "diffuseReflectance"));
        assert!(!norm_eq("alpha", "alphaU"));
    }

    #[test]
    fn sun_is_up_in_a_tokyo_summer_afternoon() {
        let d = sun_position(&SunTime {
            year: 2010.0,
            month: 7.0,
            day: 10.0,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
        });
        assert!((d.length() - 1.0).abs() < 1e-4);
        // Mid-afternoon in July: elevation ≈ 45°, sun in the west (−x in this frame is west).
        let elevation = d.y.asin().to_degrees();
        assert!(elevation > 30.0 && elevation < 60.0, "{elevation}");
        assert!(d.x < 0.0, "{d}");
    }

    #[test]
    fn builtin_shapes_are_closed_and_outward() {
        for m in [cube(), sphere()] {
            // Σ A n = 0 for a closed surface; outward: the signed volume is positive.
            let mut s = Vec3::ZERO;
            let mut vol = 0.0;
            for t in &m.indices {
                let (a, b, c) = (
                    m.positions[t[0] as usize],
                    m.positions[t[1] as usize],
                    m.positions[t[2] as usize],
                );
                s += (b - a).cross(c - a);
                vol += a.dot(b.cross(c)) / 6.0;
            }
            assert!(s.length() < 1e-3, "{} {s}", m.name);
            assert!(vol > 0.0, "{}", m.name);
        }
        let t = tube();
        let a = t.positions[0];
        let tri = t.indices[0];
        let n = (t.positions[tri[1] as usize] - a).cross(t.positions[tri[2] as usize] - a);
        assert!(n.dot(Vec3::new(a.x, a.y, 0.0)) > 0.0);
    }
}
