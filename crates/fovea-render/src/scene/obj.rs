//! Wavefront OBJ + MTL loader (through `tobj`).
//!
//! Format facts used here:
//! * `v x y z [w]` positions (or `v x y z r g b`: a vertex colour, linear, stored in
//!   [`Mesh::colors`] and multiplied into the base colour; colours on some vertices only are
//!   ignored with a warning), `vt u v` texture coordinates (OBJ's `v` axis points **up** the
//!   image, so it is converted to the glTF convention used by [`Mesh::uvs`]:
//!   `uv = (u, 1 − v)`), `vn` normals, `f` faces with 1-based (or negative, relative) indices
//!   `v/vt/vn`; polygons are fan-triangulated by `tobj`, points (`p`, one-vertex faces) and
//!   lines (`l`, two-vertex faces) are ignored. `o`/`g` split the file into objects, each
//!   becomes one [`Mesh`] per material.
//! * `mtllib` names material libraries relative to the OBJ file; `usemtl` selects a material.
//!   The OBJ, its MTL files and textures are read within the load's [`LoadLimits`]: regular
//!   files only, of bounded size, inside the OBJ's folder tree unless allowed (an MTL or
//!   texture refused that way is a warning, like a missing one).
//!
//! Material mapping (MTL → [`Material`]):
//! * `Kd` → `base_color` (default 0.8 grey), `Ks` → `specular` (clamped to [0, 1]; default
//!   0.04), `Ns` → `roughness` through [`Material::roughness_from_phong`] (default 0.8),
//!   `Ke` → `emissive`; the PBR extension's `Pr` (roughness) and `Pm` (metallic) override
//!   `Ns` and set `metallic`.
//! * `map_Kd` → `base_color_texture`, decoded as sRGB and multiplied by `Kd` as the MTL
//!   specification says, except that a missing or black `Kd` counts as white (some exporters
//!   write `Kd 0 0 0` next to a texture); `map_Ks`, `map_Ns`, `map_d` and `d`/`Tr`
//!   (transparency) are ignored.
//! * `norm` → normal map (linear). `map_Bump`/`bump` are height maps in the MTL
//!   specification but many exporters write tangent-space normal maps there: the image is
//!   used as a normal map only when it looks like one (mean colour bluish: B > 0.6, R and G
//!   within 0.15 of 0.5), otherwise it is ignored with a warning. Texture options (`-bm 0.5`,
//!   `-s 1 1 1`, …) before the file name are skipped.
//! * Every texture file is decoded once (cache by path), textures in parallel.
//!
//! Fallbacks (never errors): a missing or malformed MTL → a warning and a default grey
//! material; a missing or undecodable texture → a warning and the flat colour; malformed
//! colour lines in an MTL (`Kd 0.5` with one value is read as grey; two values or a spectral
//! curve → the line is dropped) → a warning. Objects without `usemtl` get a default grey
//! material.
//!
//! Errors: an unreadable file → [`RenderError::Io`]; UTF-16 text →
//! [`RenderError::Unsupported`] naming the encoding; malformed OBJ content (a `v`, `vt`, `vn`
//! with too few or unparsable numbers, a malformed face vertex, face indices out of range,
//! all checked here with their line number, without quoting the line, before `tobj` sees
//! them) → [`RenderError::BadInput`]. The parser is additionally run under
//! `catch_unwind`, so a panic inside `tobj` on some input we did not anticipate becomes a
//! `BadInput` error instead of aborting. NaN vertices are rejected later by
//! [`Scene::validate`].
//!
//! Units: OBJ has none; `metres_per_unit` is 1.

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::files::SceneFiles;
use super::limits::LoadLimits;
use super::{Material, MaterialId, Mesh, Scene, Texture, TextureId};
use crate::error::{RenderError, Result};

/// Environment radiance given to scenes whose file defines none (a dim grey constant,
/// [`crate::scene::Environment::Constant`]).
pub const DEFAULT_ENVIRONMENT: Vec3 = Vec3::splat(0.05);

// `..Default::default()` keeps this compiling if feature unification turns on `tobj`'s
// `merging`/`reordering` options (extra fields).
#[allow(clippy::needless_update)]
fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    }
}

/// Loads an OBJ file with its MTL libraries as a scene: one mesh per object and material,
/// materials from the MTL (see the module docs for the mapping and fallbacks), within the
/// default [`LoadLimits`].
pub fn load(path: &Path) -> Result<Scene> {
    load_with_limits(path, &LoadLimits::default())
}

/// [`load`] within `limits` (file sizes, files outside the scene's folder).
pub fn load_with_limits(path: &Path, limits: &LoadLimits) -> Result<Scene> {
    let files = SceneFiles::new(path, limits)?;
    let bytes = files.read_scene_file()?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let (models, materials, mut warnings) = parse(&files, path, &bytes, true)?;
    let materials = materials.unwrap_or_default();

    // Textures: collect distinct files, decode in parallel.
    let mut tex_paths: Vec<(PathBuf, bool)> = Vec::new();
    let mut tex_index: HashMap<(PathBuf, bool), usize> = HashMap::new();
    let mut request = |file: &str, srgb: bool| -> usize {
        let p = resolve_texture_path(&dir, file);
        let key = (p, srgb);
        *tex_index.entry(key.clone()).or_insert_with(|| {
            tex_paths.push(key);
            tex_paths.len() - 1
        })
    };
    struct Pending {
        base: Option<usize>,
        normal: Option<(usize, bool)>, // (texture, from `bump` → check it looks like a normal map)
    }
    let mut out_materials = Vec::with_capacity(materials.len() + 1);
    let mut pending = Vec::with_capacity(materials.len());
    for m in &materials {
        let mut mat = Material {
            name: m.name.clone(),
            two_sided: true,
            ..Material::default()
        };
        mat.base_color = match (m.diffuse, &m.diffuse_texture) {
            // Negative values are clamped with a warning by `Scene::validate` (`ranges`).
            (Some(kd), _) => Vec3::from_array(kd),
            (None, Some(_)) => Vec3::ONE,
            (None, None) => mat.base_color,
        };
        if let Some(ks) = m.specular {
            mat.specular = Vec3::from_array(ks).clamp(Vec3::ZERO, Vec3::ONE);
        }
        if let Some(ns) = m.shininess {
            mat.roughness = Material::roughness_from_phong(ns);
        }
        if let Some(ke) = m.emissive {
            mat.emissive = Vec3::from_array(ke);
        }
        if let Some(pr) = m
            .unknown_param
            .get("Pr")
            .and_then(|s| s.parse::<f32>().ok())
        {
            if pr.is_finite() {
                mat.roughness = pr.clamp(0.02, 1.0);
            }
        }
        if let Some(pm) = m
            .unknown_param
            .get("Pm")
            .and_then(|s| s.parse::<f32>().ok())
        {
            if pm.is_finite() {
                mat.metallic = pm.clamp(0.0, 1.0);
            }
        }
        let base = m
            .diffuse_texture
            .as_deref()
            .and_then(texture_file_name)
            .map(|f| request(f, true));
        let normal = if let Some(f) = m
            .unknown_param
            .get("norm")
            .and_then(|s| texture_file_name(s))
        {
            Some((request(f, false), false))
        } else {
            m.normal_texture
                .as_deref()
                .and_then(texture_file_name)
                .map(|f| (request(f, false), true))
        };
        out_materials.push(mat);
        pending.push(Pending { base, normal });
    }

    let decoded: Vec<Result<Texture>> = tex_paths
        .par_iter()
        .map(|(p, srgb)| Texture::load_in(&files, p, *srgb))
        .collect();
    let mut textures = Vec::new();
    let mut tex_ids: Vec<Option<TextureId>> = Vec::with_capacity(decoded.len());
    let mut looks_like_normal_map = Vec::with_capacity(decoded.len());
    for ((p, _), t) in tex_paths.iter().zip(decoded) {
        match t {
            Ok(t) => {
                looks_like_normal_map.push(is_normal_map_like(&t));
                tex_ids.push(Some(textures.len() as TextureId));
                textures.push(t);
            }
            Err(e) => {
                warnings.push(format!(
                    "texture {}: {e}; using the flat colour",
                    p.display()
                ));
                looks_like_normal_map.push(false);
                tex_ids.push(None);
            }
        }
    }
    for (mat, pend) in out_materials.iter_mut().zip(&pending) {
        if let Some(i) = pend.base {
            if let Some(id) = tex_ids[i] {
                mat.base_color_texture = Some(id);
                if mat.base_color.max_element() < 0.01 {
                    mat.base_color = Vec3::ONE;
                }
            }
        }
        if let Some((i, from_bump)) = pend.normal {
            if let Some(id) = tex_ids[i] {
                if !from_bump || looks_like_normal_map[i] {
                    mat.normal_texture = Some(id);
                } else {
                    warnings.push(format!(
                        "material `{}`: bump map {} looks like a height map, ignored",
                        mat.name,
                        tex_paths[i].0.display()
                    ));
                }
            }
        }
    }

    let mut default_material: Option<MaterialId> = None;
    let mut meshes = Vec::with_capacity(models.len());
    for model in models {
        let material = match model.mesh.material_id {
            Some(i) if i < out_materials.len() => i as MaterialId,
            _ => *default_material.get_or_insert_with(|| {
                out_materials.push(Material::default());
                (out_materials.len() - 1) as MaterialId
            }),
        };
        let mut w = Vec::new();
        let mesh = convert(model, material, &mut w);
        warnings.extend(w);
        if !mesh.indices.is_empty() {
            meshes.push(mesh);
        }
    }

    Ok(Scene {
        name: String::new(),
        source: Some(path.to_path_buf()),
        meshes,
        materials: out_materials,
        textures,
        lights: Vec::new(),
        cameras: Vec::new(),
        environment: DEFAULT_ENVIRONMENT.into(),
        light_units: super::LightUnits::Relative,
        metres_per_unit: 1.0,
        warnings,
    })
}

/// Loads all objects of an OBJ file as one mesh with the given material; `mtllib`/`usemtl`
/// are ignored (the Mitsuba loader assigns materials itself). Texture coordinates are
/// converted to the glTF convention (`v` down). Errors as [`load`].
pub fn load_mesh(path: &Path, material: MaterialId) -> Result<Mesh> {
    let files = SceneFiles::new(path, &LoadLimits::default())?;
    let bytes = files.read_scene_file()?;
    mesh_of(&files, path, &bytes, material)
}

/// [`load_mesh`] for a file a scene names, read through the scene's `files`.
pub(crate) fn load_mesh_in(files: &SceneFiles, path: &Path, material: MaterialId) -> Result<Mesh> {
    let bytes = files.read(path, None)?;
    mesh_of(files, path, &bytes, material)
}

fn mesh_of(files: &SceneFiles, path: &Path, bytes: &[u8], material: MaterialId) -> Result<Mesh> {
    let (models, _, _) = parse(files, path, bytes, false)?;
    let mut out = Mesh {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        material,
        ..Mesh::default()
    };
    let mut all_normals = true;
    let mut all_uvs = true;
    let mut all_colors = true;
    let mut meshes = Vec::with_capacity(models.len());
    for model in models {
        let mut w = Vec::new();
        let m = convert(model, material, &mut w);
        if m.indices.is_empty() {
            continue;
        }
        all_normals &= !m.normals.is_empty();
        all_uvs &= !m.uvs.is_empty();
        all_colors &= !m.colors.is_empty();
        meshes.push(m);
    }
    if meshes.len() == 1 {
        if let Some(mut m) = meshes.pop() {
            m.name = out.name;
            return Ok(m);
        }
    }
    for m in meshes {
        let base = out.positions.len() as u32;
        out.positions.extend_from_slice(&m.positions);
        if all_normals {
            out.normals.extend_from_slice(&m.normals);
        }
        if all_uvs {
            out.uvs.extend_from_slice(&m.uvs);
        }
        if all_colors {
            out.colors.extend_from_slice(&m.colors);
        }
        out.indices.extend(
            m.indices
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }
    Ok(out)
}

/// Checks the text (encoding, statements, face indices; errors with line numbers), runs
/// `tobj` (with the MTL libraries when `with_mtl`, read through `files`).
#[allow(clippy::type_complexity)]
fn parse(
    files: &SceneFiles,
    path: &Path,
    bytes: &[u8],
    with_mtl: bool,
) -> Result<(Vec<tobj::Model>, Option<Vec<tobj::Material>>, Vec<String>)> {
    if let Some(encoding) = utf16_encoding(bytes) {
        return Err(RenderError::Unsupported(format!(
            "{} is {encoding} text; OBJ files are read as UTF-8 or ASCII: convert it (e.g. \
             `iconv -f UTF-16 -t UTF-8`)",
            path.display()
        )));
    }
    let text = String::from_utf8_lossy(bytes);
    let counts = check_lines(&text).map_err(|what| RenderError::bad(path, what))?;
    let mut early_warnings = Vec::new();
    // tobj needs colours on every vertex or none (it indexes them like positions).
    let text = if counts.colored > 0 && counts.colored < counts.vertices {
        early_warnings.push(format!(
            "vertex colours on {} of {} vertices only, ignored",
            counts.colored, counts.vertices
        ));
        std::borrow::Cow::Owned(strip_vertex_colors(&text))
    } else {
        text
    };
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let warnings = RefCell::new(early_warnings);
    let mtl_loader = |p: &Path| -> tobj::MTLLoadResult {
        if !with_mtl {
            return Err(tobj::LoadError::OpenFileFailed);
        }
        let full = dir.join(p);
        let mut err = None;
        let mut notes = Vec::new();
        let r = load_mtl(files, &full, &mut err, &mut notes);
        for n in notes {
            warnings
                .borrow_mut()
                .push(format!("material library {}: {n}", full.display()));
        }
        if let Some(msg) = err {
            warnings.borrow_mut().push(format!(
                "material library {}: {msg}; flat colours",
                full.display()
            ));
        }
        r
    };
    let mut reader = Cursor::new(text.as_bytes());
    let result = catch_unwind(AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut reader, &load_options(), mtl_loader)
    }));
    let (models, mats) = match result {
        Ok(Ok(x)) => x,
        Ok(Err(e)) => return Err(RenderError::bad(path, format!("malformed OBJ: {e}"))),
        Err(_) => {
            return Err(RenderError::bad(
                path,
                "malformed OBJ (the OBJ parser gave up on this input)",
            ))
        }
    };
    let mut warnings = warnings.into_inner();
    let mats = match mats {
        Ok(m) => Some(m),
        Err(_) => {
            if with_mtl && warnings.is_empty() {
                warnings.push("material library unusable; flat colours".into());
            }
            None
        }
    };
    Ok((models, mats, warnings))
}

/// Reads an MTL file, repairs or drops malformed lines (see [`sanitize_mtl`]; `notes` receives
/// what was changed) and parses it with `tobj`; on failure `err` receives the reason.
fn load_mtl(
    files: &SceneFiles,
    path: &Path,
    err: &mut Option<String>,
    notes: &mut Vec<String>,
) -> tobj::MTLLoadResult {
    let bytes = match files.read(path, None) {
        Ok(b) => b,
        Err(e) => {
            *err = Some(format!("not read ({e})"));
            return Err(tobj::LoadError::OpenFileFailed);
        }
    };
    if let Some(encoding) = utf16_encoding(&bytes) {
        *err = Some(format!(
            "{encoding} text, not read (MTL files are UTF-8 or ASCII)"
        ));
        return Err(tobj::LoadError::OpenFileFailed);
    }
    let (text, n) = sanitize_mtl(&String::from_utf8_lossy(&bytes));
    *notes = n;
    let mut reader = Cursor::new(text.as_bytes());
    match catch_unwind(AssertUnwindSafe(|| tobj::load_mtl_buf(&mut reader))) {
        Ok(Ok(x)) => Ok(x),
        Ok(Err(e)) => {
            *err = Some(format!("malformed ({e})"));
            Err(e)
        }
        Err(_) => {
            *err = Some("malformed (the MTL parser gave up on it)".into());
            Err(tobj::LoadError::MaterialParseError)
        }
    }
}

/// Rewrites lines `tobj` would reject or panic on, returning the text and one note per
/// change: colour lines with one value are expanded to grey; colour lines with two values or
/// non-numeric values (`Kd spectral …`), number lines (`Ns`, `Ni`, `d`, `illum`) without a
/// number and texture lines without a file name are dropped.
fn sanitize_mtl(text: &str) -> (String, Vec<String>) {
    let mut out = String::with_capacity(text.len() + 16);
    let mut notes = Vec::new();
    for (lineno, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or("");
        let rest: Vec<&str> = words.collect();
        let nums: Vec<f32> = rest.iter().map_while(|w| w.parse::<f32>().ok()).collect();
        let mut dropped = false;
        match key {
            "Ka" | "Kd" | "Ks" | "Ke" => {
                if nums.len() >= 3 {
                    out.push_str(&format!("{key} {} {} {}", nums[0], nums[1], nums[2]));
                } else if nums.len() == 1 {
                    out.push_str(&format!("{key} {0} {0} {0}", nums[0]));
                    notes.push(format!(
                        "line {}: `{}` read as grey",
                        lineno + 1,
                        line.trim()
                    ));
                } else {
                    dropped = true;
                }
            }
            "Ns" | "Ni" | "d" => match nums.first() {
                Some(v) => out.push_str(&format!("{key} {v}")),
                None => dropped = true,
            },
            "illum" => match rest.first().and_then(|w| w.parse::<u8>().ok()) {
                Some(v) => out.push_str(&format!("illum {v}")),
                None => dropped = true,
            },
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Ns" | "map_ns" | "map_NS" | "map_d"
            | "map_Bump" | "map_bump" | "bump" | "norm"
                if rest.is_empty() =>
            {
                dropped = true
            }
            "newmtl" if rest.is_empty() => {
                out.push_str("newmtl unnamed");
                notes.push(format!("line {}: `newmtl` without a name", lineno + 1));
            }
            _ => out.push_str(line),
        }
        if dropped {
            notes.push(format!(
                "line {}: malformed `{}` ignored",
                lineno + 1,
                line.trim()
            ));
        }
        out.push('\n');
    }
    (out, notes)
}

/// What [`check_lines`] counted.
#[derive(Debug, Default, PartialEq)]
struct LineCounts {
    /// `v` statements.
    vertices: usize,
    /// `v` statements with a colour (`v x y z r g b`).
    colored: usize,
}

/// The encoding of UTF-16 text (by its byte-order mark, or NUL bytes in every other place
/// of the first line), which `tobj` would read as garbage.
fn utf16_encoding(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(&[0xFF, 0xFE]) {
        return Some("UTF-16 (little-endian)");
    }
    if bytes.starts_with(&[0xFE, 0xFF]) {
        return Some("UTF-16 (big-endian)");
    }
    let head = &bytes[..bytes.len().min(64)];
    if head.len() >= 4 {
        let nul_odd = head.iter().skip(1).step_by(2).all(|&b| b == 0);
        let nul_even = head.iter().step_by(2).all(|&b| b == 0);
        if nul_odd && !nul_even {
            return Some("UTF-16 (little-endian, no byte-order mark)");
        }
        if nul_even && !nul_odd {
            return Some("UTF-16 (big-endian, no byte-order mark)");
        }
    }
    None
}

/// Checks the statements `tobj` would reject (`v`, `vt`, `vn`, `f`, `l`) and every face
/// index against the number of `v`/`vt`/`vn` entries, so that problems are reported with
/// their line (without echoing the line) instead of a bare parser error; counts the
/// vertices and those with a colour.
fn check_lines(text: &str) -> std::result::Result<LineCounts, String> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    let mut counts = LineCounts::default();
    // Largest positive index of each kind and its line, checked against the final counts.
    let mut max_pos: [(i64, usize); 3] = [(0, 0); 3];
    let is_num = |w: &str| w.parse::<f32>().is_ok();
    for (lineno, line) in text.lines().enumerate() {
        let n = lineno + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let rest: Vec<&str> = words.collect();
                if rest.len() < 3 || !rest[..3].iter().all(|w| is_num(w)) {
                    return Err(format!(
                        "line {n}: a vertex (`v`) needs three numbers x y z"
                    ));
                }
                match rest.len() {
                    3 => {}
                    4 => match rest[3].parse::<f32>() {
                        Ok(w) if w != 0.0 => {}
                        Ok(_) => return Err(format!("line {n}: vertex weight w is 0")),
                        Err(_) => return Err(format!("line {n}: vertex weight w is not a number")),
                    },
                    6 if rest[3..].iter().all(|w| is_num(w)) => counts.colored += 1,
                    6 => return Err(format!("line {n}: vertex colour r g b is not 3 numbers")),
                    k => {
                        return Err(format!(
                            "line {n}: a vertex (`v`) has {k} values; expected 3 (x y z), 4 \
                             (x y z w) or 6 (x y z r g b)"
                        ))
                    }
                }
                counts.vertices += 1;
                nv += 1;
            }
            Some("vt") => {
                let rest: Vec<&str> = words.take(2).collect();
                if rest.len() < 2 || !rest.iter().all(|w| is_num(w)) {
                    return Err(format!(
                        "line {n}: a texture coordinate (`vt`) needs two numbers u v"
                    ));
                }
                nvt += 1;
            }
            Some("vn") => {
                let rest: Vec<&str> = words.take(3).collect();
                if rest.len() < 3 || !rest.iter().all(|w| is_num(w)) {
                    return Err(format!("line {n}: a normal (`vn`) needs three numbers"));
                }
                nvn += 1;
            }
            Some(kw @ ("f" | "l")) => {
                let words: Vec<&str> = words.collect();
                if words.is_empty() {
                    return Err(format!(
                        "line {n}: a face (`{kw}`) without vertex indices; expected e.g. `{kw} 1 2 3`"
                    ));
                }
                for token in words {
                    let parts: Vec<&str> = token.split('/').collect();
                    // As `tobj`: empty parts are skipped, a fourth non-empty one is an error.
                    if parts.iter().skip(3).any(|p| !p.is_empty()) || parts[0].is_empty() {
                        return Err(format!(
                            "line {n}: face (`{kw}`) vertex is not v, v/vt, v//vn or v/vt/vn"
                        ));
                    }
                    for (k, part) in parts.iter().enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(x) = part.parse::<i64>() else {
                            return Err(format!("line {n}: face (`{kw}`) index is not an integer"));
                        };
                        let count = [nv, nvt, nvn][k];
                        let kind = ["vertex", "texture coordinate", "normal"][k];
                        if x < 0 {
                            if count + x < 0 {
                                return Err(format!(
                                    "line {n}: relative {kind} index {x} but only {count} defined so far"
                                ));
                            }
                        } else if x == 0 {
                            if k == 0 {
                                return Err(format!(
                                    "line {n}: vertex index 0 (OBJ indices start at 1)"
                                ));
                            }
                        } else if x > max_pos[k].0 {
                            max_pos[k] = (x, n);
                        }
                    }
                }
            }
            _ => {}
        }
    }
    for (k, &(x, line)) in max_pos.iter().enumerate() {
        let count = [nv, nvt, nvn][k];
        // A texture-coordinate or normal index in a file without any is ignored by the parser.
        if x > count && (k == 0 || count > 0) {
            let kind = ["vertex", "texture coordinate", "normal"][k];
            return Err(format!(
                "line {line}: {kind} index {x} out of range (the file has {count})"
            ));
        }
    }
    Ok(counts)
}

/// The text with the colours of `v x y z r g b` statements removed.
fn strip_vertex_colors(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        if words.next() == Some("v") {
            let rest: Vec<&str> = words.collect();
            if rest.len() == 6 {
                out.push_str("v ");
                out.push_str(&rest[..3].join(" "));
                out.push('\n');
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Converts one `tobj` model to a mesh (uv `v` flipped to point down the image).
fn convert(model: tobj::Model, material: MaterialId, warnings: &mut Vec<String>) -> Mesh {
    let m = model.mesh;
    let positions: Vec<Vec3> = m
        .positions
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    let n = positions.len();
    let mut normals: Vec<Vec3> = m
        .normals
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero())
        .collect();
    if !normals.is_empty() && normals.len() != n {
        warnings.push(format!(
            "object `{}`: normals on some vertices only, using geometric normals",
            model.name
        ));
        normals.clear();
    }
    let mut uvs: Vec<Vec2> = m
        .texcoords
        .chunks_exact(2)
        .map(|c| Vec2::new(c[0], 1.0 - c[1]))
        .collect();
    if !uvs.is_empty() && uvs.len() != n {
        warnings.push(format!(
            "object `{}`: texture coordinates on some vertices only, ignored",
            model.name
        ));
        uvs.clear();
    }
    let mut colors: Vec<Vec3> = m
        .vertex_color
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    if !colors.is_empty() && colors.len() != n {
        warnings.push(format!(
            "object `{}`: vertex colours on some vertices only, ignored",
            model.name
        ));
        colors.clear();
    }
    let indices = m
        .indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    Mesh {
        name: model.name,
        positions,
        normals,
        uvs,
        tangents: Vec::new(),
        colors,
        indices,
        material,
    }
}

/// The file name of an MTL texture statement, skipping options such as `-bm 0.5` or
/// `-s 1 1 1` (an option is a token starting with `-` followed by its numeric or on/off
/// arguments).
fn texture_file_name(spec: &str) -> Option<&str> {
    let mut rest = spec.trim();
    loop {
        if !rest.starts_with('-') || rest.parse::<f32>().is_ok() {
            break;
        }
        // Drop the option name.
        let (_, after) = rest.split_once(char::is_whitespace)?;
        rest = after.trim_start();
        // Drop its arguments.
        while let Some((word, after)) = rest.split_once(char::is_whitespace) {
            let is_arg = word.parse::<f32>().is_ok()
                || matches!(word, "on" | "off" | "r" | "g" | "b" | "m" | "l" | "z");
            if !is_arg {
                break;
            }
            rest = after.trim_start();
        }
    }
    let rest = rest.trim();
    (!rest.is_empty()).then_some(rest)
}

/// Texture file relative to the MTL's directory; backslashes (Windows exporters) are
/// converted when the path as written does not exist.
fn resolve_texture_path(dir: &Path, file: &str) -> PathBuf {
    let p = dir.join(file);
    if !p.exists() && file.contains('\\') {
        let alt = dir.join(file.replace('\\', "/"));
        if alt.exists() {
            return alt;
        }
    }
    p
}

/// Whether a texture's mean colour looks like a tangent-space normal map.
fn is_normal_map_like(t: &Texture) -> bool {
    let mean: Vec4 = t.sample(Vec2::splat(0.5), 64.0);
    mean.z > 0.6 && (mean.x - 0.5).abs() < 0.15 && (mean.y - 0.5).abs() < 0.15
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_options_are_skipped() {
        assert_eq!(texture_file_name("wood.png"), Some("wood.png"));
        assert_eq!(texture_file_name("-bm 0.5 n.png"), Some("n.png"));
        assert_eq!(
            texture_file_name("-s 1 1 1 -clamp on my file.jpg"),
            Some("my file.jpg")
        );
        assert_eq!(texture_file_name("-bm"), None);
        assert_eq!(texture_file_name(""), None);
    }

    #[test]
    fn index_check_reports_lines() {
        let check_indices = check_lines;
        assert!(check_indices("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").is_ok());
        assert!(check_indices("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
        let e = check_indices("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert!(e.contains("line 4"), "{e}");
        assert!(check_indices("v 0 0 0\nf -2 1 1\n").is_err());
        assert!(check_indices("v 0 0 0\nvt 0 0\nf 1/1 1/-9 1/1\n").is_err());
        assert!(check_indices("v 0 0 0\nvn 0 0 1\nf 1//9223372036854775807 1//1 1//1\n").is_err());
        // A normal index in a file without normals is ignored by the parser.
        assert!(check_indices("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//5 2//5 3//5\n").is_ok());
        assert!(check_indices("v 0 0 0\nf 0 1 1\n").is_err());
        // A trailing slash is accepted (as `tobj` does), a fourth index is not.
        assert!(check_indices("v 0 0 0\nvt 0 0\nvn 0 0 1\nf 1/1/1/ 1/1/1 1/1/1\n").is_ok());
        assert!(check_indices("v 0 0 0\nf 1/1/1/1 1 1\n").is_err());
        // A bare `f` (or `l`) names its line.
        for kw in ["f", "l"] {
            let e = check_indices(&format!("v 0 0 0\n{kw}\nf 1 1 1\n")).unwrap_err();
            assert!(e.starts_with("line 2: a face"), "{e}");
        }
        // Statements tobj would reject come with their line.
        assert!(check_indices("v 0 0 0\nv 1 2\n")
            .unwrap_err()
            .starts_with("line 2:"));
        assert_eq!(
            check_indices("v 0 0 0 1 0 0\nv 0 0 0\n").unwrap(),
            LineCounts {
                vertices: 2,
                colored: 1
            }
        );
    }

    #[test]
    fn mtl_sanitizer_repairs_colours() {
        let (s, notes) =
            sanitize_mtl("newmtl a\nKd 0.5\nKs 1 2\nKe spectral x.spd\nNs\nillum 2\nmap_Kd\n");
        assert_eq!(notes.len(), 5, "{notes:?}");
        assert!(!s.contains("map_Kd"));
        assert!(s.contains("Kd 0.5 0.5 0.5"));
        assert!(!s.contains("Ks"));
        assert!(!s.contains("Ke"));
        assert!(!s.contains("Ns"));
        assert!(s.contains("illum 2"));
    }
}
