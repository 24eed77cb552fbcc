//! Scenes: triangle meshes in world space, materials, textures, lights and cameras.
//!
//! Every loader (glTF 2.0, Wavefront OBJ/MTL, Mitsuba 0.6 XML, PLY) and the built-in
//! procedural scenes produce the same [`Scene`]: meshes are baked into world space (node and
//! `toWorld` transforms applied), colours are linear RGB, textures are decoded to linear RGBA
//! (sRGB decoding where the format says the image is sRGB). World units are metres after
//! [`Scene::scale_to_metres`]; every loader records the unit it read in
//! [`Scene::metres_per_unit`] and the CLI's `--scene-scale` overrides it.
//!
//! Conventions: right-handed, +Y up (glTF's convention; loaders convert), cameras look down
//! their `forward` vector.
//!
//! Validation ([`Scene::validate`]) rejects what would make rendering meaningless (NaN or
//! infinite vertices, index out of range, a scene without triangles) with
//! [`RenderError::BadInput`], and drops degenerate (zero-area) triangles with a warning, which
//! is the documented fallback.
//!
//! Reading: every loader reads its files within [`LoadLimits`] (module `limits`; defaults
//! there): regular files only (no FIFO, device or directory, also behind a symbolic link), at
//! most the declared size or `max_file_bytes` per file and `max_total_bytes` per load, XML
//! nested at most `max_nesting` deep, and files named by the scene inside the scene file's
//! folder tree unless `allow_outside_scene_dir`. [`Scene::load`] uses the defaults,
//! [`Scene::load_with_limits`] others.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec2, Vec3, Vec4};
use serde::Serialize;

use crate::error::{RenderError, Result};

pub mod builtin;
pub mod environment;
pub(crate) mod files;
pub mod gltf;
pub mod limits;
pub mod mitsuba;
pub mod obj;
pub mod ply;
mod primitives;
pub mod ranges;
pub mod texture;

pub use environment::{EnvMap, Environment};
pub use limits::LoadLimits;
pub use texture::{Texture, TextureId};

/// Index of a material in [`Scene::materials`].
pub type MaterialId = u32;

/// A triangle mesh in world space with one material.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name from the file (node or object name), for messages.
    pub name: String,
    /// Vertex positions, world space.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, world space, unit length; empty → geometric normals.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates (glTF convention: v down the image); empty → none.
    pub uvs: Vec<Vec2>,
    /// Per-vertex tangents (xyz world space, w = bitangent sign); empty → derived from UVs.
    pub tangents: Vec<Vec4>,
    /// Per-vertex colours, linear RGB, multiplied into the material's base colour (glTF
    /// `COLOR_0`, OBJ `v x y z r g b`, PLY `red green blue`); empty → none.
    pub colors: Vec<Vec3>,
    /// Triangles as vertex indices.
    pub indices: Vec<[u32; 3]>,
    /// Material of every triangle.
    pub material: MaterialId,
}

impl Mesh {
    /// Applies `world_from_local` to positions, normals (inverse transpose) and tangents.
    pub fn transform(&mut self, world_from_local: Mat4) {
        for p in &mut self.positions {
            *p = world_from_local.transform_point3(*p);
        }
        let normal_m = world_from_local.inverse().transpose();
        for n in &mut self.normals {
            *n = normal_m.transform_vector3(*n).normalize_or_zero();
        }
        for t in &mut self.tangents {
            let v = world_from_local
                .transform_vector3(t.truncate())
                .normalize_or_zero();
            *t = v.extend(t.w);
        }
        // A mirroring transform flips the winding.
        if world_from_local.determinant() < 0.0 {
            for tri in &mut self.indices {
                tri.swap(1, 2);
            }
        }
    }
}

/// How a surface reflects light. One parameter set covers what the loaders read: glTF's
/// metallic-roughness model, OBJ/MTL's Phong terms and Mitsuba's BSDF types.
#[derive(Clone, Debug, Serialize)]
pub struct Material {
    /// Name from the file.
    pub name: String,
    /// Base colour (diffuse albedo for dielectrics, F0 for metals), linear RGB in [0, 1].
    pub base_color: Vec3,
    /// Texture multiplied into `base_color` (linear RGBA after sRGB decoding).
    pub base_color_texture: Option<TextureId>,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (GGX α = roughness²).
    pub roughness: f32,
    /// glTF metallic-roughness texture (G = roughness, B = metallic), linear.
    pub metallic_roughness_texture: Option<TextureId>,
    /// Tangent-space normal map (linear, glTF convention: +Y up in texture space).
    pub normal_texture: Option<TextureId>,
    /// Scale of the normal map's XY.
    pub normal_scale: f32,
    /// Specular reflectance at normal incidence for dielectrics (0.04 for most; OBJ's Ks).
    pub specular: Vec3,
    /// Emitted radiance, linear RGB (W·sr⁻¹·m⁻² in scene units, relative).
    pub emissive: Vec3,
    /// Whether back faces are shaded like front faces (Mitsuba `twosided`, glTF
    /// `doubleSided`).
    pub two_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            base_color: Vec3::splat(0.8),
            base_color_texture: None,
            metallic: 0.0,
            roughness: 0.8,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            specular: Vec3::splat(0.04),
            emissive: Vec3::ZERO,
            two_sided: true,
        }
    }
}

impl Material {
    /// A flat diffuse material.
    pub fn diffuse(name: impl Into<String>, color: Vec3) -> Self {
        Self {
            name: name.into(),
            base_color: color,
            roughness: 1.0,
            ..Self::default()
        }
    }

    /// Phong exponent → perceptual roughness (Walter et al. 2007: α = √(2/(n+2))).
    pub fn roughness_from_phong(exponent: f32) -> f32 {
        let alpha = (2.0 / (exponent.max(0.0) + 2.0)).sqrt();
        alpha.sqrt().clamp(0.02, 1.0)
    }
}

/// A light source. Intensities are linear RGB in scene-relative units; the shading model
/// documents how each is used.
#[derive(Clone, Debug, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Light {
    /// Isotropic point light: radiant intensity `intensity` (W/sr); irradiance falls with 1/d².
    Point {
        /// World position.
        position: Vec3,
        /// Radiant intensity per channel.
        intensity: Vec3,
        /// Range beyond which the light is ignored (`f32::INFINITY` = none).
        range: f32,
    },
    /// Spot light: a point light restricted to a cone with a smooth falloff.
    Spot {
        /// World position.
        position: Vec3,
        /// Unit direction the spot points to.
        direction: Vec3,
        /// Radiant intensity on the axis.
        intensity: Vec3,
        /// Cosine of the inner cone angle (full intensity inside).
        cos_inner: f32,
        /// Cosine of the outer cone angle (zero outside).
        cos_outer: f32,
        /// Range beyond which the light is ignored.
        range: f32,
    },
    /// Directional light (sun): irradiance `irradiance` from the unit direction `direction`
    /// the light travels along.
    Directional {
        /// Unit direction of travel of the light.
        direction: Vec3,
        /// Irradiance on a surface facing the light (W/m²).
        irradiance: Vec3,
    },
}

/// A camera read from a file or given on the command line.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CameraDesc {
    /// Name from the file.
    pub name: String,
    /// Eye position, world space.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up vector (orthogonal to `forward`).
    pub up: Vec3,
    /// Vertical field of view in degrees, when the file gives one.
    pub yfov_deg: Option<f32>,
}

impl CameraDesc {
    /// Camera at `position` looking at `target` with world up +Y (or +Z when looking straight
    /// up or down). Errors when the two points coincide or are not finite.
    pub fn look_at(
        name: &str,
        position: Vec3,
        target: Vec3,
        yfov_deg: Option<f32>,
    ) -> Result<Self> {
        let f = target - position;
        if !position.is_finite() || !target.is_finite() || f.length() < 1e-9 {
            return Err(RenderError::invalid(
                "camera",
                format!("position {position}, look-at {target}"),
                "finite, distinct points",
            ));
        }
        let forward = f.normalize();
        let world_up = if forward.y.abs() > 0.999 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(world_up).normalize();
        Ok(Self {
            name: name.into(),
            position,
            forward,
            up: right.cross(forward),
            yfov_deg,
        })
    }
}

/// A loaded scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Human-readable name (file stem or built-in name).
    pub name: String,
    /// File it came from (`None` for built-in scenes).
    pub source: Option<PathBuf>,
    /// Meshes in world space.
    pub meshes: Vec<Mesh>,
    /// Materials; meshes refer to them by index.
    pub materials: Vec<Material>,
    /// Textures; materials refer to them by index.
    pub textures: Vec<Texture>,
    /// Lights from the file (may be empty; the renderer adds lights on request).
    pub lights: Vec<Light>,
    /// Cameras from the file; the first is the default view.
    pub cameras: Vec<CameraDesc>,
    /// Radiance from infinitely far away, seen by rays that miss and gathered by direct
    /// shading through shadow rays: a constant (Mitsuba `constant`/`sky`/`sunsky`, otherwise
    /// a dim grey) or a latitude-longitude map (Mitsuba `envmap`), linear RGB.
    pub environment: Environment,
    /// Metres per scene unit as read (1 for glTF, whose unit is the metre).
    pub metres_per_unit: f32,
    /// The units of the light values, which decide how the frame is exposed by default.
    pub light_units: LightUnits,
    /// Non-fatal problems met while loading (missing texture → flat colour, ignored
    /// extension, dropped degenerate triangles), printed by the CLI.
    pub warnings: Vec<String>,
}

/// The units a scene's light values are in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum LightUnits {
    /// Relative radiometric units (OBJ, PLY, Mitsuba, the built-in scenes): a white surface
    /// facing a unit light at 1 m is about 1/π, shown as is.
    #[default]
    Relative,
    /// Photometric (glTF `KHR_lights_punctual`: point and spot lights in candela, directional
    /// lights in lux): the frame's values are luminance in cd/m², shown through an exposure.
    Photometric,
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Bounds {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Bounds {
    /// Centre point.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
    /// Extent along each axis.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
}

impl Scene {
    /// Loads a scene file within the default [`LoadLimits`], choosing the loader by
    /// extension: `.gltf`/`.glb`, `.obj`, `.xml` (Mitsuba), `.ply`.
    pub fn load(path: &Path) -> Result<Scene> {
        Self::load_with_limits(path, &LoadLimits::default())
    }

    /// [`Scene::load`] within `limits`: file sizes, XML nesting, files outside the scene's
    /// folder (see [`LoadLimits`]).
    pub fn load_with_limits(path: &Path, limits: &LoadLimits) -> Result<Scene> {
        if !path.exists() {
            return Err(RenderError::Io {
                path: path.to_path_buf(),
                message: "file not found".into(),
            });
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .unwrap_or_default();
        let mut scene = match ext.as_str() {
            "gltf" | "glb" => gltf::load_with_limits(path, limits)?,
            "obj" => obj::load_with_limits(path, limits)?,
            "xml" => mitsuba::load_with_limits(path, limits)?,
            "ply" => ply::load_scene_with_limits(path, limits)?,
            _ => {
                return Err(RenderError::Unsupported(format!(
                    "scene format of {} (expected .gltf, .glb, .obj, .xml (Mitsuba) or .ply)",
                    path.display()
                )))
            }
        };
        scene.source = Some(path.to_path_buf());
        if scene.name.is_empty() {
            // The file's stem, or its folder's name for generic stems (`scene.xml` of
            // Bitterli's archive: `japanese-classroom`).
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let folder = path.canonicalize().ok().and_then(|p| {
                p.parent()?
                    .file_name()
                    .map(|f| f.to_string_lossy().into_owned())
            });
            scene.name = match folder {
                Some(f) if matches!(stem.as_str(), "scene" | "model" | "main") => f,
                _ => stem,
            };
        }
        scene.validate()?;
        Ok(scene)
    }

    /// Total number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }

    /// Bounds of all vertices (`None` for an empty scene).
    pub fn bounds(&self) -> Option<Bounds> {
        let mut it = self.meshes.iter().flat_map(|m| m.positions.iter().copied());
        let first = it.next()?;
        let (min, max) = it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)));
        Some(Bounds { min, max })
    }

    /// Multiplies every position, light position and camera position by `factor` so that one
    /// unit becomes `factor` of the old units; with `factor = metres_per_unit` the scene ends
    /// in metres. Errors for a non-positive or non-finite factor.
    pub fn scale(&mut self, factor: f32) -> Result<()> {
        if !(factor.is_finite() && factor > 0.0) {
            return Err(RenderError::invalid(
                "scene-scale",
                factor,
                "a finite number > 0 (metres per scene unit)",
            ));
        }
        for m in &mut self.meshes {
            for p in &mut m.positions {
                *p *= factor;
            }
        }
        for l in &mut self.lights {
            match l {
                Light::Point {
                    position, range, ..
                }
                | Light::Spot {
                    position, range, ..
                } => {
                    *position *= factor;
                    *range *= factor;
                }
                Light::Directional { .. } => {}
            }
        }
        for c in &mut self.cameras {
            c.position *= factor;
        }
        self.metres_per_unit /= factor;
        Ok(())
    }

    /// Converts the scene to metres with the given metres-per-unit (or the loader's own).
    pub fn scale_to_metres(&mut self, metres_per_unit: Option<f32>) -> Result<()> {
        let m = metres_per_unit.unwrap_or(self.metres_per_unit);
        self.metres_per_unit = m;
        self.scale(m)?;
        self.metres_per_unit = 1.0;
        Ok(())
    }

    /// Checks the scene and applies the documented fallbacks:
    /// * NaN / infinite vertex, index out of range, material out of range → error naming the
    ///   mesh;
    /// * zero-area triangles → dropped, with a warning giving the count;
    /// * triangles whose (finite) coordinates are so large that their area overflows `f32`
    ///   → dropped, with a warning that says so (an error when no triangle is left);
    /// * a normal / UV / tangent / colour array whose length does not match the positions →
    ///   dropped with a warning (normals fall back to geometric normals; tangents silently);
    /// * a texture index out of range → the texture is ignored with a warning;
    /// * lights and materials outside their physical ranges, and more than
    ///   [`ranges::MAX_FILE_LIGHTS`] lights → see [`ranges`] (errors, or clamps and bounds
    ///   with a warning naming the field and the file);
    /// * no triangles at all → error.
    pub fn validate(&mut self) -> Result<()> {
        let source = self
            .source
            .clone()
            .unwrap_or_else(|| PathBuf::from(&self.name));
        let n_mat = self.materials.len() as u32;
        if self.materials.is_empty() {
            self.materials.push(Material::default());
        }
        let mut dropped = 0usize;
        let (mut huge, mut largest) = (0usize, 0.0f32);
        for m in &mut self.meshes {
            if let Some(p) = m.positions.iter().find(|p| !p.is_finite()) {
                return Err(RenderError::BadInput {
                    path: source.clone(),
                    what: format!("mesh `{}` has a non-finite vertex position {p}", m.name),
                });
            }
            let nv = m.positions.len() as u32;
            if let Some(t) = m.indices.iter().find(|t| t.iter().any(|&i| i >= nv)) {
                return Err(RenderError::BadInput {
                    path: source.clone(),
                    what: format!(
                        "mesh `{}` has triangle {:?} but only {nv} vertices",
                        m.name, t
                    ),
                });
            }
            if n_mat > 0 && m.material >= n_mat {
                return Err(RenderError::BadInput {
                    path: source.clone(),
                    what: format!("mesh `{}` uses material {} of {n_mat}", m.name, m.material),
                });
            }
            if !m.normals.is_empty()
                && (m.normals.len() != m.positions.len()
                    || m.normals.iter().any(|n| !n.is_finite()))
            {
                self.warnings.push(format!(
                    "mesh `{}`: normals unusable (count or NaN), using geometric normals",
                    m.name
                ));
                m.normals.clear();
            }
            if !m.uvs.is_empty()
                && (m.uvs.len() != m.positions.len() || m.uvs.iter().any(|n| !n.is_finite()))
            {
                self.warnings.push(format!(
                    "mesh `{}`: texture coordinates unusable, ignored",
                    m.name
                ));
                m.uvs.clear();
            }
            if !m.tangents.is_empty()
                && (m.tangents.len() != m.positions.len()
                    || m.tangents.iter().any(|n| !n.is_finite()))
            {
                m.tangents.clear();
            }
            if !m.colors.is_empty()
                && (m.colors.len() != m.positions.len() || m.colors.iter().any(|c| !c.is_finite()))
            {
                self.warnings.push(format!(
                    "mesh `{}`: vertex colours unusable (count or NaN), ignored",
                    m.name
                ));
                m.colors.clear();
            }
            if m.colors.iter().any(|c| c.min_element() < 0.0) {
                self.warnings.push(format!(
                    "{}: mesh `{}`: negative vertex colours, clamped to 0",
                    source.display(),
                    m.name
                ));
                for c in &mut m.colors {
                    *c = c.max(Vec3::ZERO);
                }
            }
            let before = m.indices.len();
            let pos = &m.positions;
            let mut overflowed = 0usize;
            m.indices.retain(|t| {
                let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
                let area2 = (b - a).cross(c - a).length();
                let edge2 = (b - a)
                    .length_squared()
                    .max((c - a).length_squared())
                    .max(1e-30);
                if !(area2.is_finite() && edge2.is_finite()) {
                    // Finite coordinates whose products overflow f32: not degenerate, too big.
                    overflowed += 1;
                    return false;
                }
                area2 > 1e-12 * edge2 && area2 > 0.0
            });
            dropped += before - m.indices.len() - overflowed;
            if overflowed > 0 {
                huge += overflowed;
                largest = m
                    .positions
                    .iter()
                    .fold(largest, |l, p| l.max(p.abs().max_element()));
            }
        }
        if dropped > 0 {
            self.warnings.push(format!(
                "dropped {dropped} degenerate (zero-area) triangles"
            ));
        }
        let huge_text = (huge > 0).then(|| {
            format!(
                "{huge} triangle(s) with coordinates too large to compute with in single \
                 precision (up to {largest:e}; edge lengths squared overflow above about \
                 1.8e19): rescale the model"
            )
        });
        if let Some(t) = &huge_text {
            self.warnings.push(format!("dropped {t}"));
        }
        self.meshes.retain(|m| !m.indices.is_empty());
        let n_tex = self.textures.len() as u32;
        for mat in &mut self.materials {
            for (slot, label) in [
                (&mut mat.base_color_texture, "base colour"),
                (&mut mat.metallic_roughness_texture, "metallic-roughness"),
                (&mut mat.normal_texture, "normal"),
            ] {
                if slot.is_some_and(|t| t >= n_tex) {
                    self.warnings.push(format!(
                        "material `{}`: {label} texture missing, using flat values",
                        mat.name
                    ));
                    *slot = None;
                }
            }
        }
        let range_warnings = ranges::check_materials(&mut self.materials, &source);
        self.warnings.extend(range_warnings);
        if self.triangle_count() == 0 {
            return Err(RenderError::BadInput {
                path: source,
                what: match huge_text {
                    Some(t) if dropped == 0 => format!("the scene has no usable triangles: {t}"),
                    _ => "the scene has no (non-degenerate) triangles".into(),
                },
            });
        }
        if !self.environment.is_valid() {
            return Err(RenderError::BadInput {
                path: source,
                what: format!(
                    "the environment ({}) is not finite and non-negative",
                    self.environment.describe()
                ),
            });
        }
        ranges::check_lights(self, &source)?;
        if let Some(w) = ranges::bound_lights(&mut self.lights, ranges::MAX_FILE_LIGHTS, &source) {
            self.warnings.push(w);
        }
        Ok(())
    }
}
