//! Stanford PLY loader (through `ply-rs-bw`), ASCII and binary (either endianness).
//!
//! Format facts used here:
//! * element `vertex` with scalar properties `x`, `y`, `z` (any numeric type), optional
//!   normals `nx`, `ny`, `nz`, optional texture coordinates named `u`/`v`, `s`/`t`,
//!   `texture_u`/`texture_v` or `texture_s`/`texture_t`;
//! * optional vertex colours `red`, `green`, `blue` (or `diffuse_red`, …): 8- and 16-bit
//!   integers are sRGB-encoded values (as MeshLab and scanners write them) and are decoded to
//!   linear, floats are taken as linear values in [0, 1]; stored in [`Mesh::colors`] and
//!   multiplied into the base colour;
//! * element `face` with a list property `vertex_indices` (or `vertex_index`) of any integer
//!   type; polygons with more than three vertices are fan-triangulated, faces with fewer are
//!   skipped; other elements (`edge`, `material`, …) and properties (alpha, …) are ignored.
//!
//! Texture coordinates: PLY does not fix the direction of `v`; the files met in practice
//! (Blender, MeshLab) store OpenGL-style coordinates with `v` up the image, so `v` is flipped
//! to the glTF convention of [`Mesh::uvs`] (`uv = (u, 1 − v)`). The Mitsuba loader flips it
//! back, because Mitsuba reads PLY coordinates as they are.
//!
//! Errors: an unreadable file → [`RenderError::Io`]; a malformed header or payload
//! (truncated binary data, a header that announces more elements than there are, a face
//! index out of range, a negative index, a vertex without `x`/`y`/`z`, no vertex element)
//! → [`RenderError::BadInput`] with the first line of the parser's message (never the file's
//! content); a file that does not start with `ply` is refused before parsing. The file is
//! read within the load's [`LoadLimits`] (a regular file, at most `max_file_bytes`). When a
//! vertex normal is zero, the
//! normals are dropped and geometric normals used (non-finite ones are dropped by
//! [`Scene::validate`] with a warning). The parser caps its pre-allocation, so a header
//! announcing billions of elements fails at the end of the data instead of allocating.
//!
//! Units: PLY has none; `metres_per_unit` is 1.

use std::io::{BufRead, Read};
use std::path::Path;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{Property, PropertyAccess, PropertyAccessResult};

use super::files::SceneFiles;
use super::limits::LoadLimits;
use super::texture::srgb_to_linear;
use super::{Material, MaterialId, Mesh, Scene};
use crate::error::{RenderError, Result};

/// One PLY element as read: the vertex fields and the face index list this loader uses.
#[derive(Debug, Default)]
struct Element {
    /// x, y, z, nx, ny, nz, u, v, and the linear colour r, g, b.
    f: [f32; 11],
    /// Bit `i` set when `f[i]` was present.
    set: u16,
    /// Face indices (`None` inside when one was negative).
    indices: Option<Vec<u32>>,
    negative_index: bool,
}

const X: usize = 0;
const NX: usize = 3;
const U: usize = 6;
const R: usize = 8;

/// Colour slot of a property name.
fn color_slot(name: &str) -> Option<usize> {
    Some(match name {
        "red" | "diffuse_red" => R,
        "green" | "diffuse_green" => R + 1,
        "blue" | "diffuse_blue" => R + 2,
        _ => return None,
    })
}

/// A colour component → linear: integers are sRGB-encoded, floats linear.
fn color_value(property: &Property) -> Option<f32> {
    let srgb = |x: f32| srgb_to_linear(x.clamp(0.0, 1.0));
    Some(match *property {
        Property::UChar(v) => srgb(f32::from(v) / 255.0),
        Property::Char(v) => srgb(f32::from(v.max(0)) / 127.0),
        Property::UShort(v) => srgb(f32::from(v) / 65535.0),
        Property::Short(v) => srgb(f32::from(v.max(0)) / 32767.0),
        Property::Float(v) => v,
        Property::Double(v) => v as f32,
        _ => return None,
    })
}

fn slot(name: &str) -> Option<usize> {
    Some(match name {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        "nx" => 3,
        "ny" => 4,
        "nz" => 5,
        "u" | "s" | "texture_u" | "texture_s" => 6,
        "v" | "t" | "texture_v" | "texture_t" => 7,
        _ => return None,
    })
}

fn signed_list<T: Copy + TryInto<u32>>(v: &[T], e: &mut Element) {
    let mut out = Vec::with_capacity(v.len());
    for &x in v {
        match x.try_into() {
            Ok(i) => out.push(i),
            Err(_) => e.negative_index = true,
        }
    }
    e.indices = Some(out);
}

impl PropertyAccess for Element {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name == "vertex_indices" || name == "vertex_index" {
            match property {
                Property::ListUChar(v) => {
                    self.indices = Some(v.iter().map(|&i| i as u32).collect())
                }
                Property::ListUShort(v) => {
                    self.indices = Some(v.iter().map(|&i| i as u32).collect())
                }
                Property::ListUInt(v) => self.indices = Some(v),
                Property::ListChar(v) => signed_list(&v, self),
                Property::ListShort(v) => signed_list(&v, self),
                Property::ListInt(v) => signed_list(&v, self),
                _ => return PropertyAccessResult::UnsupportedType,
            }
            return PropertyAccessResult::Set;
        }
        if let Some(i) = color_slot(name) {
            if let Some(x) = color_value(&property) {
                self.f[i] = x;
                self.set |= 1 << i;
                return PropertyAccessResult::Set;
            }
            return PropertyAccessResult::Ignored;
        }
        if let Some(i) = slot(name) {
            if let Some(x) = property.to_f32_lossy() {
                self.f[i] = x;
                self.set |= 1 << i;
                return PropertyAccessResult::Set;
            }
        }
        PropertyAccessResult::Ignored
    }
}

/// Loads a PLY file as one mesh with the given material (see the module docs), within the
/// default [`LoadLimits`].
pub fn load_mesh(path: &Path, material: MaterialId) -> Result<Mesh> {
    let files = SceneFiles::new(path, &LoadLimits::default())?;
    mesh_from(path, files.open_scene_file()?, material)
}

/// [`load_mesh`] for a file a scene names, read through the scene's `files`.
pub(crate) fn load_mesh_in(files: &SceneFiles, path: &Path, material: MaterialId) -> Result<Mesh> {
    mesh_from(path, files.open(path)?, material)
}

/// The first line of a parser message, without the tab-indented lines after it (which
/// quote the file's content) and without padding.
fn first_line(message: &str) -> String {
    message
        .lines()
        .next()
        .unwrap_or("")
        .trim()
        .trim_end_matches('.')
        .to_string()
}

fn mesh_from(path: &Path, file: impl Read, material: MaterialId) -> Result<Mesh> {
    let mut reader = std::io::BufReader::new(file);
    // The magic number first: the parser's own message would quote the first line.
    let head = reader.fill_buf().map_err(|e| RenderError::io(path, &e))?;
    if !(head.starts_with(b"ply") && head.get(3).is_some_and(|c| c.is_ascii_whitespace())) {
        return Err(RenderError::bad(
            path,
            "not a PLY file (it does not start with the line `ply`)",
        ));
    }
    let ply = Parser::<Element>::new()
        .read_ply(&mut reader)
        .map_err(|e| {
            RenderError::bad(
                path,
                format!("malformed PLY: {}", first_line(&e.to_string())),
            )
        })?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| RenderError::bad(path, "PLY without a `vertex` element"))?;
    let n = vertices.len();
    let mut positions = Vec::with_capacity(n);
    let has = |bits: u16| vertices.iter().all(|v| v.set & bits == bits);
    if !has(0b111) {
        return Err(RenderError::bad(
            path,
            "PLY vertices without `x`, `y` and `z` properties",
        ));
    }
    let with_normals = n > 0 && has(0b111 << NX);
    let with_uvs = n > 0 && has(0b11 << U);
    let with_colors = n > 0 && has(0b111 << R);
    let mut normals = Vec::with_capacity(if with_normals { n } else { 0 });
    let mut uvs = Vec::with_capacity(if with_uvs { n } else { 0 });
    let mut colors = Vec::with_capacity(if with_colors { n } else { 0 });
    for v in vertices {
        positions.push(Vec3::new(v.f[X], v.f[X + 1], v.f[X + 2]));
        if with_normals {
            normals.push(Vec3::new(v.f[NX], v.f[NX + 1], v.f[NX + 2]).normalize_or_zero());
        }
        if with_uvs {
            uvs.push(Vec2::new(v.f[U], 1.0 - v.f[U + 1]));
        }
        if with_colors {
            colors.push(Vec3::new(v.f[R], v.f[R + 1], v.f[R + 2]));
        }
    }
    if normals.contains(&Vec3::ZERO) {
        normals.clear();
    }
    let mut indices = Vec::new();
    if let Some(faces) = ply.payload.get("face") {
        indices.reserve(faces.len());
        for (k, f) in faces.iter().enumerate() {
            if f.negative_index {
                return Err(RenderError::bad(
                    path,
                    format!("PLY face {k} has a negative vertex index"),
                ));
            }
            let Some(idx) = &f.indices else {
                return Err(RenderError::bad(
                    path,
                    "PLY faces without a `vertex_indices` list",
                ));
            };
            if let Some(bad) = idx.iter().find(|&&i| i as usize >= n) {
                return Err(RenderError::bad(
                    path,
                    format!("PLY face {k} uses vertex {bad} but there are only {n} vertices"),
                ));
            }
            for j in 2..idx.len() {
                indices.push([idx[0], idx[j - 1], idx[j]]);
            }
        }
    }
    Ok(Mesh {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        positions,
        normals,
        uvs,
        tangents: Vec::new(),
        colors,
        indices,
        material,
    })
}

/// Loads a PLY file as a scene: one mesh with a default grey material, no lights or
/// cameras, a dim grey environment, `metres_per_unit` 1 (default [`LoadLimits`]).
pub fn load_scene(path: &Path) -> Result<Scene> {
    load_scene_with_limits(path, &LoadLimits::default())
}

/// [`load_scene`] within `limits`.
pub fn load_scene_with_limits(path: &Path, limits: &LoadLimits) -> Result<Scene> {
    let files = SceneFiles::new(path, limits)?;
    let mesh = mesh_from(path, files.open_scene_file()?, 0)?;
    Ok(Scene {
        name: String::new(),
        source: Some(path.to_path_buf()),
        meshes: vec![mesh],
        materials: vec![Material::default()],
        textures: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
        environment: super::obj::DEFAULT_ENVIRONMENT.into(),
        light_units: super::LightUnits::Relative,
        metres_per_unit: 1.0,
        warnings: Vec::new(),
    })
}
