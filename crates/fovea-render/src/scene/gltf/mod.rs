//! glTF 2.0 loader: `.gltf` (JSON with external or `data:` URI buffers and images) and `.glb`
//! (binary container, buffers and images embedded).
//!
//! # What is read
//!
//! * **Scene graph**: the default scene (`scene`), else the first scene, else every root node
//!   (a node that is nobody's child). Nodes are walked depth-first in document order and their
//!   transforms (matrix or TRS) composed; every triangle primitive is baked into a world-space
//!   [`Mesh`] with [`Mesh::transform`]. A mesh instanced by several nodes is decoded once.
//! * **Primitives**: `POSITION`, `NORMAL`, `TEXCOORD_0`, `TANGENT`, `COLOR_0` (VEC3 or VEC4,
//!   alpha dropped; linear, multiplied into the base colour), `indices` (a non-indexed
//!   primitive uses `0..n`). Float, normalized and plain integer accessors are accepted
//!   (`KHR_mesh_quantization`), as are sparse accessors. Modes `TRIANGLES`, `TRIANGLE_STRIP`
//!   and `TRIANGLE_FAN` (the last two converted to triangles with the winding the spec gives).
//! * **Materials** (metallic-roughness): base colour factor (already linear) and texture
//!   (sRGB → linear), metallic and roughness factors and texture (linear; G = roughness,
//!   B = metallic), normal texture and its `scale` (linear), emissive factor (times
//!   `KHR_materials_emissive_strength`), `doubleSided`. Every glTF material becomes
//!   `scene.materials[i]` with the same index `i`; primitives without a material share one
//!   [`Material::default`](super::Material::default) (grey diffuse) appended after them. Note: the spec's default
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
//!   - A file with such lights is [`LightUnits::Photometric`]: the frame's values are
//!     luminance in cd/m² (a white diffuse surface 1 m from a 1 cd light shows 1/π), so a real
//!     export (a 6,830 lx Blender sun) is far above the display's 0–1 and the CLI's default
//!     exposure for such scenes is automatic (`--exposure auto`; `--ev100` for a camera's).
//! * **Cameras**: perspective cameras on nodes → [`CameraDesc`](super::CameraDesc) (position = node origin,
//!   forward = node −Z, up = node +Y made orthogonal to forward, `yfov` in degrees in
//!   `yfov_deg`). The first camera in node order is the default view. A display
//!   given as a resolution takes its vertical field of view from `yfov` (the CLI's
//!   `--res WxH` without `--vfov`); a headset preset keeps its own.
//! * **Units**: the glTF unit is the metre, so `metres_per_unit = 1`. glTF has no
//!   environment, so `environment` is the dim grey constant `0.05` every loader uses by
//!   default (direct shading gathers it through shadow rays, so closed rooms stay dark).
//!
//! # Not read (ignored, warned where it changes the picture)
//!
//! Alpha (`alphaMode`, base colour alpha), occlusion textures, texture samplers (the renderer
//! always uses repeat wrap and trilinear filtering), `KHR_texture_transform`, other material
//! extensions (`KHR_materials_clearcoat`, …: one warning lists the ignored extensions),
//! animations, morph targets (meshes shown in their base shape, with a warning naming
//! them), skins (skinned meshes are shown in the pose of their node transforms, with a
//! warning), orthographic cameras (warning), Draco compression used but not required
//! (the uncompressed fallback is read, with a warning).
//!
//! # Errors and fallbacks
//!
//! | input | result |
//! | --- | --- |
//! | file cannot be read, external buffer missing, a buffer or scene file that is not a regular file (FIFO, device, directory) | [`RenderError::Io`] |
//! | a buffer or image outside the scene's folder tree (unless [`LoadLimits::allow_outside_scene_dir`]) | [`RenderError::BadInput`] (an image: warning, flat colour) |
//! | a file over [`LoadLimits::max_file_bytes`], a buffer declaring more, all files over [`LoadLimits::max_total_bytes`] | [`RenderError::ResourceLimit`] (an image: warning) |
//! | malformed JSON or GLB container (truncated, bad chunk), glTF validation errors (index out of range, bad enum), accessor outside its buffer, wrong accessor type, node cycle | [`RenderError::BadInput`] with the `gltf` crate's or our message |
//! | `extensionsRequired` naming an extension we do not implement (Draco, meshopt, Basis…), glTF 1.0 | [`RenderError::Unsupported`] naming it; checked before any buffer is read |
//! | Draco in `extensionsUsed` only, on a primitive without uncompressed fallback data | [`RenderError::Unsupported`] saying Draco is not supported |
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
//!
//! # Code
//!
//! One job per file. The container: `container` (GLB chunks, glTF 1.0 detection, required
//! extensions, Draco fallback, validation, buffers), `uri` (file and `data:` URIs, files
//! read through the load's [`LoadLimits`]: regular files in the scene's folder, a buffer up
//! to its `byteLength`), `accessor` (typed reads
//! from buffer views, sparse accessors, dequantization) and `images` (image sources and
//! decoding with size limits). The scene mapping: `nodes` (the node graph, transforms,
//! lights, cameras), `mesh` (primitives → meshes) and `materials` (materials and their
//! textures). This file holds the entry points and the loader state.

use std::collections::HashMap;
use std::path::Path;

use ::gltf::json;

use super::files::SceneFiles;
use super::limits::LoadLimits;
use super::{LightUnits, MaterialId, Mesh, Scene};
use crate::error::{RenderError, Result};

mod accessor;
mod container;
mod images;
mod materials;
mod mesh;
mod nodes;
mod uri;

use container::{
    check_draco_fallback, check_required_extensions, is_gltf_1, load_buffers, split_glb, validate,
};
use materials::{read_emissive_strengths, Slot};

/// Extensions that may appear in `extensionsRequired`: the ones this loader implements.
pub const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
];

/// Internal result with a message that the caller turns into a [`RenderError`].
type Msg<T> = std::result::Result<T, String>;

/// Loads a glTF 2.0 file (`.gltf` or `.glb`) into a world-space [`Scene`], within the default
/// [`LoadLimits`].
///
/// Does not run [`Scene::validate`]; [`Scene::load`] does. See the module documentation for
/// conventions, errors and fallbacks.
pub fn load(path: &Path) -> Result<Scene> {
    load_with_limits(path, &LoadLimits::default())
}

/// [`load`] within `limits` (file sizes, files outside the scene's folder).
pub fn load_with_limits(path: &Path, limits: &LoadLimits) -> Result<Scene> {
    let files = SceneFiles::new(path, limits)?;
    let bytes = files.read_scene_file()?;
    load_bytes_in(&files, path, &bytes)
}

/// Loads a glTF 2.0 document from its bytes; `path` names the file in messages and its folder
/// resolves relative URIs (read within the default [`LoadLimits`]).
pub fn load_from_bytes(path: &Path, bytes: &[u8]) -> Result<Scene> {
    let files = SceneFiles::new(path, &LoadLimits::default())?;
    load_bytes_in(&files, path, bytes)
}

fn load_bytes_in(files: &SceneFiles, path: &Path, bytes: &[u8]) -> Result<Scene> {
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
    check_draco_fallback(path, &root, json_bytes, &mut warnings)?;
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
    let buffers = load_buffers(files, path, base, &doc, blob)?;

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
    let morphed: Vec<String> = doc
        .meshes()
        .filter(|m| m.primitives().any(|p| p.morph_targets().len() > 0))
        .map(|m| {
            m.name()
                .map(|n| format!("`{n}`"))
                .unwrap_or_else(|| format!("mesh {}", m.index()))
        })
        .collect();
    if !morphed.is_empty() {
        warnings.push(format!(
            "morph targets ignored: {} mesh(es) shown in their base shape ({}{})",
            morphed.len(),
            morphed
                .iter()
                .take(5)
                .cloned()
                .collect::<Vec<_>>()
                .join(", "),
            if morphed.len() > 5 { ", …" } else { "" }
        ));
    }

    let mut loader = Loader {
        files,
        path,
        base,
        doc: &doc,
        buffers: &buffers,
        // The name comes from `Scene::load`, as for every format.
        scene: Scene {
            source: Some(path.to_path_buf()),
            environment: super::obj::DEFAULT_ENVIRONMENT.into(),
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
    if !loader.scene.lights.is_empty() {
        loader.scene.light_units = LightUnits::Photometric;
    }
    Ok(loader.scene)
}

/// State of one load.
struct Loader<'a> {
    files: &'a SceneFiles,
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
    /// Triangles baked so far (checked against [`MAX_TRIANGLES`](nodes::MAX_TRIANGLES)).
    triangles: usize,
}

impl Loader<'_> {
    /// One warning per kind of skipped primitive, naming the first five.
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
