//! glTF 2.0 loader: `.gltf` (JSON with external or `data:` URI buffers and images) and `.glb`
//! (binary container, buffers and images embedded).
//!
//! # What is read
//!
//! * **Scene graph**: the default scene (`scene`), else the first scene, else every root node
//!   (a node that is nobody's child). Nodes are walked depth-first in document order and their
//!   transforms (matrix or TRS) composed; every triangle primitive is baked into a world-space
//!   [`Mesh`] with [`Mesh::transform`]. A mesh instanced by several nodes is decoded once.
//! * **Primitives**: `POSITION`, `NORMAL`, `TEXCOORD_0`, `TANGENT`, `indices` (a non-indexed
//!   primitive uses `0..n`). Float, normalized and plain integer accessors are accepted
//!   (`KHR_mesh_quantization`), as are sparse accessors. Modes `TRIANGLES`, `TRIANGLE_STRIP`
//!   and `TRIANGLE_FAN` (the last two converted to triangles with the winding the spec gives).
//! * **Materials** (metallic-roughness): base colour factor (already linear) and texture
//!   (sRGB → linear), metallic and roughness factors and texture (linear; G = roughness,
//!   B = metallic), normal texture and its `scale` (linear), emissive factor (times
//!   `KHR_materials_emissive_strength`), `doubleSided`. Every glTF material becomes
//!   `scene.materials[i]` with the same index `i`; primitives without a material share one
//!   [`Material::default`] (grey diffuse) appended after them. Note: the spec's default
//!   material is white metal (metallic = roughness = 1); the grey diffuse default is
//!   deliberate, so untextured test files are visible without an environment map.
//! * **Textures**: each glTF image is decoded once per colour space (the cache key is
//!   `(image index, sRGB?)`, because the same image could serve as colour and as data), from a
//!   buffer view, a `data:` URI or a file next to the glTF, in parallel (rayon). PNG and JPEG.
//! * **Lights** (`KHR_lights_punctual`), in world space: position = node transform of the
//!   origin, direction = node transform of −Z.
//!   - point/spot: glTF intensity is luminous intensity in candela (lm/sr); it is used as
//!     radiant intensity `color · intensity` as is, in relative units (1 cd ≙ 1 unit, no
//!     photometric conversion); spot cones give `cos_inner = cos(innerConeAngle)`,
//!     `cos_outer = cos(outerConeAngle)`;
//!   - directional: illuminance in lux → irradiance `color · intensity`, same convention;
//!   - `range` as given (the spec says node scale does not change it), else infinite.
//! * **Cameras**: perspective cameras on nodes → [`CameraDesc`] (position = node origin,
//!   forward = node −Z, up = node +Y made orthogonal to forward, `yfov` in degrees). The
//!   first camera in node order is the default view.
//! * **Units**: the glTF unit is the metre, so `metres_per_unit = 1`. glTF has no
//!   environment, so `environment` is the dim grey `0.05` every loader uses by default.
//!
//! # Not read (ignored, warned where it changes the picture)
//!
//! Alpha (`alphaMode`, base colour alpha), occlusion textures, texture samplers (the renderer
//! always uses repeat wrap and trilinear filtering), `KHR_texture_transform`, other material
//! extensions (`KHR_materials_clearcoat`, …: one warning lists the ignored extensions),
//! animations, morph targets, skins (skinned meshes are shown in the pose of their node
//! transforms, with a warning), orthographic cameras (warning).
//!
//! # Errors and fallbacks
//!
//! | input | result |
//! | --- | --- |
//! | file cannot be read, external buffer missing | [`RenderError::Io`] |
//! | malformed JSON or GLB container (truncated, bad chunk), glTF validation errors (index out of range, bad enum), accessor outside its buffer, wrong accessor type, node cycle | [`RenderError::BadInput`] with the `gltf` crate's or our message |
//! | `extensionsRequired` naming an extension we do not implement (Draco, meshopt, Basis…), glTF 1.0 | [`RenderError::Unsupported`] naming it; checked before any buffer is read |
//! | non-finite vertex, vertex index out of range, no triangles | [`RenderError::BadInput`] from [`Scene::validate`] (run by [`Scene::load`]) |
//! | image missing or undecodable | warning "missing texture … using flat colour", slot `None` |
//! | texture on a `TEXCOORD_n`, n > 0 | warning, slot `None` |
//! | emissive texture | warning; `emissive` = factor × mean colour of the texture |
//! | points / lines primitive, primitive without `POSITION` | skipped, one warning each kind |
//! | unusable `NORMAL`/`TEXCOORD_0`/`TANGENT` accessor | dropped with a warning |
//! | orthographic camera, camera or light with a degenerate transform | skipped with a warning |
//! | huge instancing (more than 2²⁰ node visits or 2²⁷ triangles) | [`RenderError::ResourceLimit`] |
//!
//! # Robustness
//!
//! The `gltf` crate does the JSON parsing, the validation and the typed document API. The GLB
//! container, buffer and image URIs, accessor reading and image decoding are done here, with
//! every offset checked, because the crate's helpers panic on some malformed inputs (a GLB
//! `length` below 12, an out-of-range `POSITION` index during validation, accessors of
//! `count` 0 or of the wrong type, a URI with invalid percent-encoding) and because
//! `gltf::import` fails as a whole when one image is missing. Validation runs with our own
//! filter: the errors it reports for `extensionsRequired` (handled above) and for a missing
//! `POSITION` or its `min`/`max` (which we do not need) are not fatal.

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::json;
use ::gltf::mesh::{Mode, Semantic};
use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::texture::{srgb_to_linear, MAX_TEXTURE_SIDE};
use super::{CameraDesc, Light, Material, MaterialId, Mesh, Scene, Texture, TextureId};
use crate::error::{RenderError, Result};

/// Extensions that may appear in `extensionsRequired`: the ones this loader implements.
pub const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
];

/// Most node visits while walking the scene graph (guards against exponential instancing).
const MAX_NODE_VISITS: usize = 1 << 20;
/// Most triangles after instancing.
const MAX_TRIANGLES: usize = 1 << 27;
/// Most components of an accessor not backed by a buffer (sparse accessor without a view).
const MAX_UNBACKED_COMPONENTS: usize = 1 << 28;

/// Internal result with a message that the caller turns into a [`RenderError`].
type Msg<T> = std::result::Result<T, String>;

/// Loads a glTF 2.0 file (`.gltf` or `.glb`) into a world-space [`Scene`].
///
/// Does not run [`Scene::validate`]; [`Scene::load`] does. See the module documentation for
/// conventions, errors and fallbacks.
pub fn load(path: &Path) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| RenderError::io(path, &e))?;
    load_from_bytes(path, &bytes)
}

/// Loads a glTF 2.0 document from its bytes; `path` names the file in messages and its folder
/// resolves relative URIs.
pub fn load_from_bytes(path: &Path, bytes: &[u8]) -> Result<Scene> {
    let bad = |what: String| RenderError::bad(path, what);
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") {
        split_glb(bytes).map_err(bad)?
    } else {
        (bytes, None)
    };
    let json_bytes = json_bytes
        .strip_prefix(b"\xEF\xBB\xBF")
        .unwrap_or(json_bytes);
    let root: json::Root = match json::deserialize::from_slice(json_bytes) {
        Ok(root) => root,
        Err(e) => {
            if is_gltf_1(json_bytes) {
                return Err(RenderError::Unsupported(format!(
                    "{} is glTF 1.0; only glTF 2.0 is read (convert it, e.g. with gltf-pipeline)",
                    path.display()
                )));
            }
            return Err(bad(format!("invalid glTF JSON: {e}")));
        }
    };
    check_required_extensions(path, &root)?;
    let mut warnings = Vec::new();
    validate(path, &root, &mut warnings)?;
    let emissive_strength = if root
        .extensions_used
        .iter()
        .any(|e| e == "KHR_materials_emissive_strength")
    {
        read_emissive_strengths(json_bytes)
    } else {
        Vec::new()
    };
    let doc = ::gltf::Document::from_json_without_validation(root);
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    let buffers = load_buffers(path, base, &doc, blob)?;

    let ignored: Vec<&str> = doc
        .extensions_used()
        .filter(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(e))
        .collect();
    if !ignored.is_empty() {
        warnings.push(format!("ignoring glTF extensions: {}", ignored.join(", ")));
    }
    if doc.skins().len() > 0 {
        warnings
            .push("skinning ignored: skinned meshes are shown with their node transforms".into());
    }

    let mut loader = Loader {
        path,
        base,
        doc: &doc,
        buffers: &buffers,
        // The name comes from `Scene::load`, as for every format.
        scene: Scene {
            source: Some(path.to_path_buf()),
            environment: Vec3::splat(0.05),
            metres_per_unit: 1.0,
            warnings,
            ..Scene::default()
        },
        requests: Vec::new(),
        request_of: HashMap::new(),
        slots: Vec::new(),
        default_material: None,
        primitive_cache: HashMap::new(),
        skipped_non_triangle: Vec::new(),
        skipped_no_position: Vec::new(),
        triangles: 0,
    };
    loader.read_materials(&emissive_strength);
    loader.walk_nodes()?;
    loader.decode_textures();
    loader.finish_warnings();
    Ok(loader.scene)
}

/// Whether JSON that failed to parse as glTF 2.0 says `"asset": {"version": "1.x"}` (or is a
/// glTF 1.0 file without `asset.version`, whose top-level objects are dictionaries).
fn is_gltf_1(json_bytes: &[u8]) -> bool {
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(json_bytes) else {
        return false;
    };
    match v.pointer("/asset/version").and_then(|v| v.as_str()) {
        Some(version) => version.starts_with('1'),
        None => v.get("meshes").is_some_and(|m| m.is_object()),
    }
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk, checking every length.
fn split_glb(bytes: &[u8]) -> Msg<(&[u8], Option<Vec<u8>>)> {
    let u32_at = |at: usize| -> Option<u32> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        return Err(format!(
            "truncated GLB: {} bytes, shorter than the 12-byte header",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "GLB container version {version}; only version 2 (glTF 2.0) is read"
        ));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB: the header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    if length < 20 {
        return Err(format!(
            "GLB header length {length} leaves no room for the JSON chunk"
        ));
    }
    let data = &bytes[..length];
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    while at + 8 <= data.len() {
        let (Some(len), Some(kind)) = (u32_at(at), data.get(at + 4..at + 8)) else {
            break;
        };
        let len = len as usize;
        let start = at + 8;
        let end = start
            .checked_add(len)
            .filter(|&e| e <= data.len())
            .ok_or_else(|| {
                format!(
                    "truncated GLB: chunk {:?} at byte {at} claims {len} bytes, {} remain",
                    String::from_utf8_lossy(kind),
                    data.len() - start
                )
            })?;
        let chunk = &data[start..end];
        match kind {
            b"JSON" if json.is_none() => json = Some(chunk),
            b"BIN\0" if json.is_some() && bin.is_none() => bin = Some(chunk.to_vec()),
            _ if json.is_none() => {
                return Err("GLB: the first chunk is not the JSON chunk".to_string());
            }
            _ => {} // unknown chunks are to be ignored (glTF 2.0 §4.4.3.1)
        }
        at = (end + 3) & !3;
    }
    let json = json.ok_or_else(|| "GLB without a JSON chunk".to_string())?;
    Ok((json, bin))
}

/// Refuses files whose `extensionsRequired` lists an extension we do not implement.
fn check_required_extensions(path: &Path, root: &json::Root) -> Result<()> {
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(e))
        .collect();
    let Some(first) = unsupported.first() else {
        return Ok(());
    };
    let hint = match *first {
        "KHR_draco_mesh_compression" => {
            "Draco-compressed meshes cannot be read: decode them first, e.g. with glTF-Transform \
             (read the file with the KHR_draco_mesh_compression extension and a Draco decoder \
             registered, dispose the extension, write it back; that is how \
             chess-board.plain.glb was made from chess-board.glb)"
        }
        "EXT_meshopt_compression" | "KHR_meshopt_compression" => {
            "meshopt-compressed buffers cannot be read: decode them first, e.g. with \
             glTF-Transform"
        }
        "KHR_texture_basisu" | "EXT_texture_webp" | "EXT_texture_avif" | "MSFT_texture_dds" => {
            "only PNG and JPEG textures are read: convert the textures first, e.g. with \
             glTF-Transform"
        }
        _ => "the renderer does not implement it",
    };
    Err(RenderError::Unsupported(format!(
        "{} requires the glTF extension{} {}; {hint}",
        path.display(),
        if unsupported.len() > 1 { "s" } else { "" },
        unsupported.join(", ")
    )))
}

/// Runs the `gltf` crate's validation with our own filter (see the module documentation).
fn validate(path: &Path, root: &json::Root, warnings: &mut Vec<String>) -> Result<()> {
    use json::validation::{Error as VError, Validate};
    // The crate's primitive hook indexes `accessors` with the POSITION index unchecked.
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &prim.attributes {
                if index.value() >= root.accessors.len() {
                    return Err(RenderError::bad(
                        path,
                        format!(
                            "invalid glTF: meshes[{mi}].primitives[{pi}].attributes[\"{}\"] \
                             = {} but there are {} accessors",
                            semantic.to_string(),
                            index.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, json::Path::new, &mut |p, e| errors.push((p(), e)));
    let mut fatal = Vec::new();
    let mut missing_bounds = 0usize;
    for (p, e) in errors {
        let s = p.as_str().trim_start_matches('.');
        if s.starts_with("extensionsRequired") {
            continue; // checked by `check_required_extensions`
        }
        if s.contains("attributes[\"POSITION\"]") && matches!(e, VError::Missing | VError::Invalid)
        {
            if s.ends_with(".min") || s.ends_with(".max") {
                missing_bounds += 1;
            }
            continue; // no POSITION → the primitive is skipped later; min/max are not needed
        }
        fatal.push(format!("{s}: {e}"));
    }
    if missing_bounds > 0 {
        warnings.push(format!(
            "{missing_bounds} POSITION accessor bounds (min/max) missing or invalid; ignored"
        ));
    }
    if fatal.is_empty() {
        return Ok(());
    }
    let n = fatal.len();
    fatal.truncate(8);
    Err(RenderError::bad(
        path,
        format!(
            "invalid glTF ({n} validation error{}): {}{}",
            if n > 1 { "s" } else { "" },
            fatal.join("; "),
            if n > 8 { "; …" } else { "" }
        ),
    ))
}

/// `KHR_materials_emissive_strength` per material (1 where absent), read from the raw JSON
/// because the `gltf` crate is built without that extension.
fn read_emissive_strengths(json_bytes: &[u8]) -> Vec<f32> {
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(json_bytes) else {
        return Vec::new();
    };
    let Some(materials) = v.get("materials").and_then(|m| m.as_array()) else {
        return Vec::new();
    };
    materials
        .iter()
        .map(|m| {
            m.pointer("/extensions/KHR_materials_emissive_strength/emissiveStrength")
                .and_then(|s| s.as_f64())
                .map(|s| s as f32)
                .filter(|s| s.is_finite() && *s >= 0.0)
                .unwrap_or(1.0)
        })
        .collect()
}

/// Why a URI could not be read.
enum UriError {
    /// A file that cannot be read.
    Io(PathBuf, std::io::Error),
    /// Malformed `data:` URI.
    Bad(String),
    /// A scheme we do not fetch (http…).
    Unsupported(String),
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UriError::Io(p, e) => write!(f, "cannot read {}: {e}", p.display()),
            UriError::Bad(m) | UriError::Unsupported(m) => f.write_str(m),
        }
    }
}

/// Reads a buffer or image URI: `data:` (base64 or percent-encoded), `file:`, or a path
/// relative to `base` (percent-decoded).
fn read_uri(base: &Path, uri: &str) -> std::result::Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) = rest
            .split_once(',')
            .ok_or_else(|| UriError::Bad("data URI without a comma".into()))?;
        return if meta.ends_with(";base64") {
            base64_decode(payload).ok_or_else(|| UriError::Bad("invalid base64 in data URI".into()))
        } else {
            Ok(percent_decode(payload))
        };
    }
    let file = if let Some(rest) = uri.strip_prefix("file://").or(uri.strip_prefix("file:")) {
        PathBuf::from(String::from_utf8_lossy(&percent_decode(rest)).into_owned())
    } else if let Some(scheme) = uri_scheme(uri) {
        return Err(UriError::Unsupported(format!(
            "URI scheme `{scheme}:` is not fetched (only relative paths, file: and data:)"
        )));
    } else {
        base.join(String::from_utf8_lossy(&percent_decode(uri)).into_owned())
    };
    std::fs::read(&file).map_err(|e| UriError::Io(file, e))
}

/// The scheme of an absolute URI (`http`, …); `None` for relative references (and Windows
/// drive letters).
fn uri_scheme(uri: &str) -> Option<&str> {
    let scheme = &uri[..uri.find(':')?];
    let ok = scheme.len() >= 2
        && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
    ok.then_some(scheme)
}

/// Percent-decoding (RFC 3986); malformed escapes are kept as they are.
fn percent_decode(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            if let Some(v) = hex {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    out
}

/// Base64 (standard or URL-safe alphabet, padding optional, whitespace ignored).
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for &c in s.as_bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// Reads every buffer (GLB binary chunk, `data:` URI or file).
fn load_buffers(
    path: &Path,
    base: &Path,
    doc: &::gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>> {
    let mut buffers = Vec::with_capacity(doc.buffers().len());
    for buffer in doc.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                RenderError::bad(
                    path,
                    format!("buffer {i} refers to the GLB binary chunk, which is missing"),
                )
            })?,
            ::gltf::buffer::Source::Uri(uri) => read_uri(base, uri).map_err(|e| match e {
                UriError::Io(file, err) => RenderError::Io {
                    path: file,
                    message: format!("buffer {i} of {}: {err}", path.display()),
                },
                UriError::Bad(m) => RenderError::bad(path, format!("buffer {i}: {m}")),
                UriError::Unsupported(m) => {
                    RenderError::Unsupported(format!("{}: buffer {i}: {m}", path.display()))
                }
            })?,
        };
        if data.len() < buffer.length() {
            return Err(RenderError::bad(
                path,
                format!(
                    "buffer {i} has {} bytes but its byteLength is {}",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// The bytes of a buffer view, checked against its buffer.
fn view_bytes<'b>(view: &::gltf::buffer::View, buffers: &'b [Vec<u8>]) -> Msg<&'b [u8]> {
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("bufferView {}: no such buffer", view.index()))?;
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "bufferView {} (bytes {}..+{}) lies outside buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                buffer.len()
            )
        })
}

/// One component, little-endian; `b` holds at least `ty.size()` bytes.
#[inline]
fn component(b: &[u8], ty: DataType) -> f64 {
    match ty {
        DataType::I8 => f64::from(b[0] as i8),
        DataType::U8 => f64::from(b[0]),
        DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    }
}

/// Reads all `count · dims` components of an accessor (dense part and sparse substitution),
/// converting each with `conv`. Every range is checked; nothing is allocated beyond what the
/// buffers back (or [`MAX_UNBACKED_COMPONENTS`]).
fn read_accessor<T: Copy>(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    conv: impl Fn(f64) -> T,
) -> Msg<Vec<T>> {
    let ty = acc.data_type();
    let dims = acc.dimensions().multiplicity();
    let csize = ty.size();
    let elem = dims * csize;
    let count = acc.count();
    let mut out;
    if let Some(view) = acc.view() {
        let data = view_bytes(&view, buffers)?;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "byteStride {stride} is smaller than the element size {elem}"
            ));
        }
        let data = if count == 0 {
            &[][..]
        } else {
            let end = stride
                .checked_mul(count - 1)
                .and_then(|n| n.checked_add(elem))
                .and_then(|n| n.checked_add(acc.offset()));
            end.and_then(|end| data.get(acc.offset()..end))
                .ok_or_else(|| {
                    format!(
                        "{count} elements of {elem} bytes (stride {stride}) from byte {} do not \
                         fit in bufferView {} ({} bytes)",
                        acc.offset(),
                        view.index(),
                        data.len()
                    )
                })?
        };
        out = Vec::with_capacity(count * dims);
        for i in 0..count {
            let e = &data[i * stride..i * stride + elem];
            for c in 0..dims {
                out.push(conv(component(&e[c * csize..], ty)));
            }
        }
    } else {
        let n = count.saturating_mul(dims);
        if n > MAX_UNBACKED_COMPONENTS {
            return Err(format!("{count} elements without a bufferView"));
        }
        out = vec![conv(0.0); n];
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let ity = match indices.index_type() {
            ::gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            ::gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            ::gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let idx_bytes = view_bytes(&indices.view(), buffers)?;
        let idx_bytes = n
            .checked_mul(ity.size())
            .and_then(|len| len.checked_add(indices.offset()))
            .and_then(|end| idx_bytes.get(indices.offset()..end))
            .ok_or_else(|| format!("sparse indices ({n}) outside their bufferView"))?;
        let values = sparse.values();
        let val_bytes = view_bytes(&values.view(), buffers)?;
        let val_bytes = n
            .checked_mul(elem)
            .and_then(|len| len.checked_add(values.offset()))
            .and_then(|end| val_bytes.get(values.offset()..end))
            .ok_or_else(|| format!("sparse values ({n}) outside their bufferView"))?;
        for k in 0..n {
            let target = component(&idx_bytes[k * ity.size()..], ity) as usize;
            if target >= count {
                return Err(format!(
                    "sparse index {target} out of range ({count} elements)"
                ));
            }
            let e = &val_bytes[k * elem..(k + 1) * elem];
            for c in 0..dims {
                out[target * dims + c] = conv(component(&e[c * csize..], ty));
            }
        }
    }
    Ok(out)
}

/// Component → float per the glTF rules for normalized integers.
#[inline]
fn dequantize(v: f64, ty: DataType, normalized: bool) -> f32 {
    if !normalized {
        return v as f32;
    }
    let r = match ty {
        DataType::I8 => (v / 127.0).max(-1.0),
        DataType::U8 => v / 255.0,
        DataType::I16 => (v / 32767.0).max(-1.0),
        DataType::U16 => v / 65535.0,
        DataType::U32 => v / 4_294_967_295.0,
        DataType::F32 => v,
    };
    r as f32
}

/// Reads a float attribute with `dims` components per element.
fn read_attribute(acc: &::gltf::Accessor, buffers: &[Vec<u8>], dims: usize) -> Msg<Vec<f32>> {
    let found = acc.dimensions().multiplicity();
    if found != dims || matches!(acc.dimensions(), Dimensions::Mat2) {
        return Err(format!(
            "accessor {} has type {:?}, expected {dims} components",
            acc.index(),
            acc.dimensions()
        ));
    }
    let (ty, normalized) = (acc.data_type(), acc.normalized());
    read_accessor(acc, buffers, |v| dequantize(v, ty, normalized))
        .map_err(|e| format!("accessor {}: {e}", acc.index()))
}

/// Reads an index accessor (scalar unsigned integers).
fn read_indices(acc: &::gltf::Accessor, buffers: &[Vec<u8>]) -> Msg<Vec<u32>> {
    if acc.dimensions() != Dimensions::Scalar
        || !matches!(
            acc.data_type(),
            DataType::U8 | DataType::U16 | DataType::U32
        )
    {
        return Err(format!(
            "index accessor {} is {:?} {:?}, expected SCALAR unsigned integers",
            acc.index(),
            acc.dimensions(),
            acc.data_type()
        ));
    }
    read_accessor(acc, buffers, |v| v as u32).map_err(|e| format!("accessor {}: {e}", acc.index()))
}

/// The local transform of a node (TRS with the rotation normalised; a zero quaternion is the
/// identity rotation).
fn local_transform(node: &::gltf::Node) -> Mat4 {
    match node.transform() {
        ::gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
        ::gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let q = Quat::from_array(rotation);
            let q = if q.length_squared() > 0.0 && q.is_finite() {
                q.normalize()
            } else {
                Quat::IDENTITY
            };
            Mat4::from_scale_rotation_translation(Vec3::from(scale), q, Vec3::from(translation))
        }
    }
}

/// An image to decode: name, encoded bytes (or why there are none), sRGB?
type ImageSource<'b> = (String, Msg<Cow<'b, [u8]>>, bool);

/// Which material slot a texture request feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    BaseColor,
    MetallicRoughness,
    Normal,
    Emissive,
}

/// State of one load.
struct Loader<'a> {
    path: &'a Path,
    base: &'a Path,
    doc: &'a ::gltf::Document,
    buffers: &'a [Vec<u8>],
    scene: Scene,
    /// Distinct `(image index, sRGB)` pairs to decode, in first-use order.
    requests: Vec<(usize, bool)>,
    request_of: HashMap<(usize, bool), usize>,
    /// `(material, slot, request)`.
    slots: Vec<(usize, Slot, usize)>,
    default_material: Option<MaterialId>,
    /// Local (untransformed) mesh of `(mesh, primitive)`; `None` when skipped.
    primitive_cache: HashMap<(usize, usize), Option<Mesh>>,
    skipped_non_triangle: Vec<String>,
    skipped_no_position: Vec<String>,
    /// Triangles baked so far (checked against [`MAX_TRIANGLES`]).
    triangles: usize,
}

impl Loader<'_> {
    fn request(&mut self, material: usize, slot: Slot, info_tex_coord: u32, tex: ::gltf::Texture) {
        let image = tex.source().index();
        if info_tex_coord != 0 {
            let name = self.scene.materials[material].name.clone();
            self.scene.warnings.push(format!(
                "material `{name}`: {slot:?} texture uses TEXCOORD_{info_tex_coord}; only \
                 TEXCOORD_0 is read, texture ignored"
            ));
            return;
        }
        let srgb = matches!(slot, Slot::BaseColor | Slot::Emissive);
        let next = self.requests.len();
        let r = *self.request_of.entry((image, srgb)).or_insert(next);
        if r == next {
            self.requests.push((image, srgb));
        }
        self.slots.push((material, slot, r));
    }

    /// Converts every glTF material (same indices) and records its texture requests.
    fn read_materials(&mut self, emissive_strength: &[f32]) {
        let doc = self.doc;
        for (i, m) in doc.materials().enumerate() {
            let pbr = m.pbr_metallic_roughness();
            let [r, g, b, _alpha] = pbr.base_color_factor();
            let unit = |x: f32, default: f32| {
                if x.is_finite() {
                    x.clamp(0.0, 1.0)
                } else {
                    default
                }
            };
            let strength = emissive_strength.get(i).copied().unwrap_or(1.0);
            let emissive = Vec3::from(m.emissive_factor()) * strength;
            let normal = m.normal_texture();
            self.scene.materials.push(Material {
                name: m
                    .name()
                    .map(str::to_owned)
                    .unwrap_or_else(|| format!("material {i}")),
                base_color: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
                base_color_texture: None,
                metallic: unit(pbr.metallic_factor(), 1.0),
                roughness: unit(pbr.roughness_factor(), 1.0),
                metallic_roughness_texture: None,
                normal_texture: None,
                normal_scale: normal
                    .as_ref()
                    .map(|n| n.scale())
                    .filter(|s| s.is_finite())
                    .unwrap_or(1.0),
                specular: Vec3::splat(0.04),
                emissive: if emissive.is_finite() {
                    emissive.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                },
                two_sided: m.double_sided(),
            });
            if let Some(t) = pbr.base_color_texture() {
                self.request(i, Slot::BaseColor, t.tex_coord(), t.texture());
            }
            if let Some(t) = pbr.metallic_roughness_texture() {
                self.request(i, Slot::MetallicRoughness, t.tex_coord(), t.texture());
            }
            if let Some(n) = normal {
                self.request(i, Slot::Normal, n.tex_coord(), n.texture());
            }
            if let Some(t) = m.emissive_texture() {
                if self.scene.materials[i].emissive != Vec3::ZERO {
                    self.request(i, Slot::Emissive, t.tex_coord(), t.texture());
                }
            }
        }
    }

    /// The id of the shared default material, appended on first use.
    fn default_material(&mut self) -> MaterialId {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(Material::default());
            (self.scene.materials.len() - 1) as MaterialId
        })
    }

    /// Walks the chosen scene's node trees depth-first (iteratively, with cycle detection):
    /// a counting pass, then the pass that bakes meshes, lights and cameras.
    fn walk_nodes(&mut self) -> Result<()> {
        let doc = self.doc;
        let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                (0..is_child.len()).filter(|&i| !is_child[i]).collect()
            }
        };
        let nodes: Vec<::gltf::Node> = doc.nodes().collect();
        // First pass: only count (cycle and instancing checks before any mesh is baked).
        for bake in [false, true] {
            let mut stack: Vec<(usize, Mat4, usize)> = roots
                .iter()
                .rev()
                .map(|&n| (n, Mat4::IDENTITY, 0))
                .collect();
            let mut ancestors: Vec<usize> = Vec::new();
            let mut visits = 0usize;
            while let Some((index, parent, depth)) = stack.pop() {
                ancestors.truncate(depth);
                if ancestors.contains(&index) {
                    return Err(RenderError::bad(
                        self.path,
                        format!("the node hierarchy has a cycle through node {index}"),
                    ));
                }
                visits += 1;
                if visits > MAX_NODE_VISITS {
                    return Err(RenderError::ResourceLimit {
                        what: format!("scene graph of {}", self.path.display()),
                        needed: format!("more than {MAX_NODE_VISITS} node instances"),
                        limit: format!("{MAX_NODE_VISITS}"),
                    });
                }
                ancestors.push(index);
                let node = &nodes[index];
                let world = if bake {
                    let world = parent * local_transform(node);
                    self.visit(node, world)?;
                    world
                } else {
                    parent
                };
                for child in node.children().collect::<Vec<_>>().into_iter().rev() {
                    stack.push((child.index(), world, depth + 1));
                }
            }
        }
        Ok(())
    }

    /// Adds a node's mesh, light and camera.
    fn visit(&mut self, node: &::gltf::Node, world: Mat4) -> Result<()> {
        let node_name = node
            .name()
            .map(str::to_owned)
            .unwrap_or_else(|| format!("node {}", node.index()));
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let key = (mesh.index(), prim.index());
                if !self.primitive_cache.contains_key(&key) {
                    let local = self.read_primitive(&mesh, &prim)?;
                    self.primitive_cache.insert(key, local);
                }
                let Some(Some(local)) = self.primitive_cache.get(&key) else {
                    continue;
                };
                let total = self.triangles + local.indices.len();
                if total > MAX_TRIANGLES {
                    return Err(RenderError::ResourceLimit {
                        what: format!("triangles of {}", self.path.display()),
                        needed: format!("more than {total}"),
                        limit: format!("{MAX_TRIANGLES}"),
                    });
                }
                self.triangles = total;
                let mut m = local.clone();
                m.transform(world);
                self.scene.meshes.push(m);
            }
        }
        if let Some(light) = node.light() {
            self.add_light(&light, world, &node_name);
        }
        if let Some(camera) = node.camera() {
            self.add_camera(&camera, world, &node_name);
        }
        Ok(())
    }

    /// Decodes one primitive in its local frame; `None` when it is skipped (with a warning
    /// recorded). Errors are problems with POSITION or the indices.
    fn read_primitive(
        &mut self,
        mesh: &::gltf::Mesh,
        prim: &::gltf::Primitive,
    ) -> Result<Option<Mesh>> {
        let mesh_name = mesh
            .name()
            .map(str::to_owned)
            .unwrap_or_else(|| format!("mesh {}", mesh.index()));
        let name = if mesh.primitives().len() > 1 {
            format!("{mesh_name}#{}", prim.index())
        } else {
            mesh_name
        };
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.skipped_non_triangle
                .push(format!("`{name}` ({mode:?})"));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&Semantic::Positions) else {
            self.skipped_no_position.push(format!("`{name}`"));
            return Ok(None);
        };
        let bad = |what: String| RenderError::bad(self.path, format!("mesh `{name}`: {what}"));
        let positions: Vec<Vec3> = read_attribute(&pos_acc, self.buffers, 3)
            .map_err(|e| bad(format!("POSITION: {e}")))?
            .chunks_exact(3)
            .map(Vec3::from_slice)
            .collect();
        let n = positions.len();
        if n > u32::MAX as usize {
            return Err(bad(format!("{n} vertices (at most 2³² − 1)")));
        }
        let mut optional = |semantic: Semantic, dims: usize| -> Vec<f32> {
            let Some(acc) = prim.get(&semantic) else {
                return Vec::new();
            };
            match read_attribute(&acc, self.buffers, dims) {
                Ok(v) if v.len() == n * dims => v,
                Ok(v) => {
                    self.scene.warnings.push(format!(
                        "mesh `{name}`: {semantic:?} has {} elements for {n} vertices, ignored",
                        v.len() / dims
                    ));
                    Vec::new()
                }
                Err(e) => {
                    self.scene.warnings.push(format!(
                        "mesh `{name}`: {semantic:?} unusable ({e}), ignored"
                    ));
                    Vec::new()
                }
            }
        };
        let normals = optional(Semantic::Normals, 3)
            .chunks_exact(3)
            .map(Vec3::from_slice)
            .collect();
        let uvs = optional(Semantic::TexCoords(0), 2)
            .chunks_exact(2)
            .map(Vec2::from_slice)
            .collect();
        let tangents = optional(Semantic::Tangents, 4)
            .chunks_exact(4)
            .map(Vec4::from_slice)
            .collect();
        let order: Vec<u32> = match prim.indices() {
            Some(acc) => {
                read_indices(&acc, self.buffers).map_err(|e| bad(format!("indices: {e}")))?
            }
            None => (0..n as u32).collect(),
        };
        let indices: Vec<[u32; 3]> = match mode {
            Mode::TriangleStrip => (0..order.len().saturating_sub(2))
                .map(|i| {
                    if i % 2 == 0 {
                        [order[i], order[i + 1], order[i + 2]]
                    } else {
                        [order[i + 1], order[i], order[i + 2]]
                    }
                })
                .collect(),
            Mode::TriangleFan => (1..order.len().saturating_sub(1))
                .map(|i| [order[i], order[i + 1], order[0]])
                .collect(),
            _ => order.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        };
        let material = match prim.material().index() {
            Some(i) => i as MaterialId,
            None => self.default_material(),
        };
        Ok(Some(Mesh {
            name,
            positions,
            normals,
            uvs,
            tangents,
            indices,
            material,
        }))
    }

    fn add_light(&mut self, light: &::gltf::khr_lights_punctual::Light, world: Mat4, node: &str) {
        use ::gltf::khr_lights_punctual::Kind;
        let power = Vec3::from(light.color()) * light.intensity();
        let range = light
            .range()
            .filter(|r| r.is_finite() && *r > 0.0)
            .unwrap_or(f32::INFINITY);
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let needs_direction = !matches!(light.kind(), Kind::Point);
        if !position.is_finite() || (needs_direction && direction == Vec3::ZERO) {
            self.scene.warnings.push(format!(
                "light on node `{node}` has a degenerate transform, skipped"
            ));
            return;
        }
        self.scene.lights.push(match light.kind() {
            Kind::Point => Light::Point {
                position,
                intensity: power,
                range,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let cos_outer = outer_cone_angle.cos();
                Light::Spot {
                    position,
                    direction,
                    intensity: power,
                    cos_inner: inner_cone_angle.cos().max(cos_outer),
                    cos_outer,
                    range,
                }
            }
            Kind::Directional => Light::Directional {
                direction,
                irradiance: power,
            },
        });
    }

    fn add_camera(&mut self, camera: &::gltf::Camera, world: Mat4, node: &str) {
        let ::gltf::camera::Projection::Perspective(p) = camera.projection() else {
            self.scene.warnings.push(format!(
                "orthographic camera on node `{node}` skipped (only perspective cameras are read)"
            ));
            return;
        };
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(Vec3::Y);
        let up = (up - forward * up.dot(forward)).normalize_or_zero();
        if !position.is_finite() || forward == Vec3::ZERO || up == Vec3::ZERO {
            self.scene.warnings.push(format!(
                "camera on node `{node}` has a degenerate transform, skipped"
            ));
            return;
        }
        let yfov = p.yfov().to_degrees();
        self.scene.cameras.push(CameraDesc {
            name: camera.name().unwrap_or(node).to_owned(),
            position,
            forward,
            up,
            yfov_deg: (yfov.is_finite() && yfov > 0.0 && yfov < 180.0).then_some(yfov),
        });
    }

    /// Decodes the requested images in parallel and fills the material slots.
    fn decode_textures(&mut self) {
        let doc = self.doc;
        let images: Vec<::gltf::Image> = doc.images().collect();
        // Resolve the sources serially (cheap), decode in parallel.
        let sources: Vec<ImageSource> = self
            .requests
            .iter()
            .map(|&(i, srgb)| {
                let image = &images[i];
                let (name, bytes) = match image.source() {
                    ::gltf::image::Source::View { view, .. } => (
                        image
                            .name()
                            .map(str::to_owned)
                            .unwrap_or_else(|| format!("image {i}")),
                        view_bytes(&view, self.buffers).map(Cow::Borrowed),
                    ),
                    ::gltf::image::Source::Uri { uri, .. } => {
                        let name = match image.name() {
                            Some(n) => n.to_owned(),
                            None if uri.starts_with("data:") => format!("image {i}"),
                            None => uri.to_owned(),
                        };
                        let bytes = read_uri(self.base, uri)
                            .map(Cow::Owned)
                            .map_err(|e| e.to_string());
                        (name, bytes)
                    }
                };
                (name, bytes, srgb)
            })
            .collect();
        let decoded: Vec<(String, Msg<Texture>)> = sources
            .into_par_iter()
            .map(|(name, bytes, srgb)| {
                let tex = bytes.and_then(|b| decode_texture(&name, &b, srgb));
                (name, tex)
            })
            .collect();
        let mut ids: Vec<Option<TextureId>> = vec![None; decoded.len()];
        let mut means: Vec<Option<Vec3>> = vec![None; decoded.len()];
        for (r, (name, tex)) in decoded.into_iter().enumerate() {
            match tex {
                Ok(tex) => {
                    let as_map = self.slots.iter().any(|s| s.2 == r && s.1 != Slot::Emissive);
                    if self.slots.iter().any(|s| s.2 == r && s.1 == Slot::Emissive) {
                        means[r] = Some(tex.sample(Vec2::ZERO, f32::MAX).truncate());
                    }
                    if as_map {
                        ids[r] = Some(self.scene.textures.len() as TextureId);
                        self.scene.textures.push(tex);
                    }
                }
                Err(e) => self
                    .scene
                    .warnings
                    .push(format!("missing texture `{name}` ({e}), using flat colour")),
            }
        }
        for &(m, slot, r) in &self.slots {
            let mat = &mut self.scene.materials[m];
            match slot {
                Slot::BaseColor => mat.base_color_texture = ids[r],
                Slot::MetallicRoughness => mat.metallic_roughness_texture = ids[r],
                Slot::Normal => mat.normal_texture = ids[r],
                Slot::Emissive => {
                    if let Some(mean) = means[r] {
                        mat.emissive *= mean;
                        self.scene.warnings.push(format!(
                            "material `{}`: emissive texture replaced by its mean colour",
                            mat.name
                        ));
                    }
                }
            }
        }
    }

    fn finish_warnings(&mut self) {
        let list = |v: &[String]| {
            let mut s = v.iter().take(5).cloned().collect::<Vec<_>>().join(", ");
            if v.len() > 5 {
                s.push_str(", …");
            }
            s
        };
        if !self.skipped_non_triangle.is_empty() {
            self.scene.warnings.push(format!(
                "skipped {} non-triangle primitive(s) (points/lines): {}",
                self.skipped_non_triangle.len(),
                list(&self.skipped_non_triangle)
            ));
        }
        if !self.skipped_no_position.is_empty() {
            self.scene.warnings.push(format!(
                "skipped {} primitive(s) without POSITION: {}",
                self.skipped_no_position.len(),
                list(&self.skipped_no_position)
            ));
        }
    }
}

/// Decodes PNG/JPEG bytes into a texture (sRGB → linear when `srgb`).
fn decode_texture(name: &str, bytes: &[u8], srgb: bool) -> Msg<Texture> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    if reader.format().is_none() {
        return Err("unrecognised image format (PNG and JPEG are read)".into());
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| format!("cannot decode: {e}"))?;
    texture_from_image(name, img, srgb).map_err(|e| e.to_string())
}

/// Like [`Texture::from_image`], with a lookup table for 8-bit images (the common case),
/// which is several times faster than converting through `f32` and `powf`.
fn texture_from_image(name: &str, img: image::DynamicImage, srgb: bool) -> Result<Texture> {
    use image::DynamicImage as D;
    if !matches!(
        img,
        D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_)
    ) {
        return Texture::from_image(name, img, srgb);
    }
    let lut: [f32; 256] = std::array::from_fn(|i| {
        let c = i as f32 / 255.0;
        if srgb {
            srgb_to_linear(c)
        } else {
            c
        }
    });
    let (w, h) = (img.width(), img.height());
    let rgba = img.into_rgba8();
    let texels = rgba
        .pixels()
        .map(|p| {
            let [r, g, b, a] = p.0;
            Vec4::new(
                lut[r as usize],
                lut[g as usize],
                lut[b as usize],
                f32::from(a) / 255.0,
            )
        })
        .collect();
    Texture::from_linear(name, w, h, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_vectors() {
        assert_eq!(base64_decode("").unwrap(), b"");
        assert_eq!(base64_decode("Zg==").unwrap(), b"f");
        assert_eq!(base64_decode("Zm8=").unwrap(), b"fo");
        assert_eq!(base64_decode("Zm9v").unwrap(), b"foo");
        assert_eq!(base64_decode("Zm9vYmFy").unwrap(), b"foobar");
        assert_eq!(base64_decode("Zm9vYg").unwrap(), b"foob");
        assert!(base64_decode("Zm9v!").is_none());
    }

    #[test]
    fn percent_decoding_keeps_malformed_escapes() {
        assert_eq!(percent_decode("a%20b"), b"a b");
        assert_eq!(percent_decode("%FF%FE"), vec![0xFF, 0xFE]);
        assert_eq!(percent_decode("100%"), b"100%");
        assert_eq!(percent_decode("%G1%2"), b"%G1%2");
    }

    #[test]
    fn uri_schemes_are_recognised() {
        assert_eq!(uri_scheme("http://x/y.bin"), Some("http"));
        assert_eq!(uri_scheme("C:/x.bin"), None);
        assert_eq!(uri_scheme("textures/a.png"), None);
        assert_eq!(uri_scheme("a:b.png"), None);
    }

    #[test]
    fn glb_splitting_checks_lengths() {
        assert!(split_glb(b"glTF").is_err());
        let mut header = b"glTF".to_vec();
        header.extend(2u32.to_le_bytes());
        header.extend(4u32.to_le_bytes()); // length < 12: the gltf crate would underflow
        assert!(split_glb(&header).is_err());
        let json = br#"{"asset":{"version":"2.0"}}"#;
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(((12 + 8 + json.len()) as u32).to_le_bytes());
        glb.extend((json.len() as u32).to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(json);
        let (j, bin) = split_glb(&glb).unwrap();
        assert_eq!(j, json);
        assert!(bin.is_none());
        // Chunk claims more than the file holds.
        let mut lying = glb.clone();
        lying[12] = 200;
        assert!(split_glb(&lying).is_err());
    }

    #[test]
    fn dequantization_follows_the_spec() {
        assert_eq!(dequantize(-128.0, DataType::I8, true), -1.0);
        assert_eq!(dequantize(127.0, DataType::I8, true), 1.0);
        assert_eq!(dequantize(65535.0, DataType::U16, true), 1.0);
        assert_eq!(dequantize(7.0, DataType::U16, false), 7.0);
    }
}
