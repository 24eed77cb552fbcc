//! The glTF container: the GLB binary container (header, JSON and BIN chunks, every length
//! checked), glTF 1.0 detection, the `extensionsRequired` check (before any buffer is read),
//! the `gltf` crate's validation with our own filter, and the buffers (GLB chunk, `data:`
//! URI or file, at least `byteLength` bytes each).

use std::path::Path;

use ::gltf::json;

use super::uri::{read_uri, UriError};
use super::{Msg, SUPPORTED_REQUIRED_EXTENSIONS};
use crate::error::{RenderError, Result};
use crate::scene::files::SceneFiles;

/// Whether JSON that failed to parse as glTF 2.0 says `"asset": {"version": "1.x"}` (or is a
/// glTF 1.0 file without `asset.version`, whose top-level objects are dictionaries).
pub(super) fn is_gltf_1(json_bytes: &[u8]) -> bool {
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(json_bytes) else {
        return false;
    };
    match v.pointer("/asset/version").and_then(|v| v.as_str()) {
        Some(version) => version.starts_with('1'),
        None => v.get("meshes").is_some_and(|m| m.is_object()),
    }
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk, checking every length.
pub(super) fn split_glb(bytes: &[u8]) -> Msg<(&[u8], Option<Vec<u8>>)> {
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

/// How to read a Draco-compressed file.
const DRACO_HINT: &str = "Draco-compressed meshes cannot be read: decode them first, e.g. with \
     glTF-Transform (read the file with the KHR_draco_mesh_compression extension and a Draco \
     decoder registered, dispose the extension, write it back; that is how \
     chess-board.plain.glb was made from chess-board.glb)";

/// Draco used but not required (`extensionsUsed` only): the spec then asks for uncompressed
/// fallback data in the primitives' accessors. Primitives with a fallback are read from it
/// (one warning says Draco is unsupported); a Draco primitive without one (its `POSITION` or
/// `indices` accessor has no `bufferView`) makes the file [`RenderError::Unsupported`], with
/// the hint of [`check_required_extensions`], instead of a missing-data error later.
pub(super) fn check_draco_fallback(
    path: &Path,
    root: &json::Root,
    json_bytes: &[u8],
    warnings: &mut Vec<String>,
) -> Result<()> {
    const DRACO: &str = "KHR_draco_mesh_compression";
    if !root.extensions_used.iter().any(|e| e == DRACO) {
        return Ok(());
    }
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(json_bytes) else {
        return Ok(());
    };
    let accessors = v.get("accessors").and_then(|a| a.as_array());
    let has_view = |index: &serde_json::Value| -> bool {
        index
            .as_u64()
            .and_then(|i| accessors?.get(i as usize))
            .is_some_and(|a| a.get("bufferView").is_some())
    };
    let mut compressed = 0usize;
    let mut without_fallback = Vec::new();
    let meshes = v.get("meshes").and_then(|m| m.as_array());
    for (mi, mesh) in meshes.into_iter().flatten().enumerate() {
        let prims = mesh.get("primitives").and_then(|p| p.as_array());
        for (pi, prim) in prims.into_iter().flatten().enumerate() {
            if prim.pointer(&format!("/extensions/{DRACO}")).is_none() {
                continue;
            }
            compressed += 1;
            let position_ok = prim.pointer("/attributes/POSITION").is_some_and(has_view);
            let indices_ok = prim.get("indices").is_none_or(has_view);
            if !(position_ok && indices_ok) {
                without_fallback.push(format!("meshes[{mi}].primitives[{pi}]"));
            }
        }
    }
    if let Some(first) = without_fallback.first() {
        return Err(RenderError::Unsupported(format!(
            "{} uses Draco mesh compression ({DRACO}) without uncompressed fallback data \
             ({first}{}); Draco is not supported. {DRACO_HINT}",
            path.display(),
            if without_fallback.len() > 1 {
                format!(" and {} more", without_fallback.len() - 1)
            } else {
                String::new()
            }
        )));
    }
    if compressed > 0 {
        warnings.push(format!(
            "{compressed} Draco-compressed primitive(s): Draco is not supported, their \
             uncompressed fallback data is used"
        ));
    }
    Ok(())
}

/// Refuses files whose `extensionsRequired` lists an extension we do not implement.
pub(super) fn check_required_extensions(path: &Path, root: &json::Root) -> Result<()> {
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
        "KHR_draco_mesh_compression" => DRACO_HINT,
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
pub(super) fn validate(path: &Path, root: &json::Root, warnings: &mut Vec<String>) -> Result<()> {
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

/// Reads every buffer (GLB binary chunk, `data:` URI or file).
pub(super) fn load_buffers(
    files: &SceneFiles,
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
            ::gltf::buffer::Source::Uri(uri) => {
                read_uri(files, base, uri, Some(buffer.length() as u64)).map_err(|e| match e {
                    UriError::File(RenderError::Io {
                        path: file,
                        message,
                    }) => RenderError::Io {
                        path: file,
                        message: format!("buffer {i} of {}: {message}", path.display()),
                    },
                    UriError::File(other) => other,
                    UriError::Bad(m) => RenderError::bad(path, format!("buffer {i}: {m}")),
                    UriError::Unsupported(m) => {
                        RenderError::Unsupported(format!("{}: buffer {i}: {m}", path.display()))
                    }
                })?
            }
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
