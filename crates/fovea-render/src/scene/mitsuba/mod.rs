//! Mitsuba scene XML loader (version 0.6 as in Bitterli's "Rendering resources"; the
//! snake_case parameter names of Mitsuba 2/3 are accepted too).
//!
//! # What is read
//!
//! The file is parsed with `roxmltree`; `<include filename=".."/>` elements are replaced by
//! the root children of the included file (resolved against the including file's directory,
//! then the scene's; depth ≤ 16, cycles rejected). Every file (scene, includes, meshes,
//! textures) is read within the load's [`LoadLimits`]: regular files only, of bounded size,
//! includes and `filename`s inside the scene file's folder tree unless allowed, and
//! elements nested at most `max_nesting` deep (includes spliced in). Building the tree is
//! linear in the file's size (line numbers from a table of line starts). `<default name="n" value="v"/>` entries
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
//! BSDF element becomes one [`Material`](super::Material), named by its id):
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
//! * `phong` (exponent → [`Material::roughness_from_phong`](super::Material::roughness_from_phong)), `ward` (√α), `principled`
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
//!   flipped) and `ply` through the OBJ / PLY loaders ([`super::obj::load_mesh`] /
//!   [`super::ply::load_mesh`], within this load's limits), loaded in parallel (rayon)
//!   together with the textures. Their vertex colours are dropped with a warning, as Mitsuba
//!   shows them only through a `vertexcolors` texture (not supported).
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
//!   `scale`, a constant sky blue (the sun of `sunsky` stays a directional light with its
//!   shadow ray; direct shading gathers the sky through shadow rays too, so an interior is
//!   lit through its openings only).
//! * `constant`: `radiance` (1) → a constant environment.
//! * `envmap`: `filename` (OpenEXR `.exr`, Radiance `.hdr`: linear; PNG/JPEG: sRGB-decoded)
//!   → a latitude-longitude [`EnvMap`](crate::scene::EnvMap) in Mitsuba's orientation (+Y
//!   up, `u` along the azimuth, `−Z` at the image's left edge, `+Z` at its centre), times
//!   `scale` (1), turned by the rotation of `toWorld` (uniform scale dropped; shear or
//!   non-uniform scale: a warning and no rotation). A map file that is missing, outside the
//!   scene's folder, too large or not decodable is treated like a missing texture: a warning
//!   naming the file and the reason, and a constant 0.5 grey × `scale` instead. `gamma` and
//!   `cache` are ignored.
//! * Several environment emitters: the last wins, with a warning. Without any, the
//!   environment is a dim grey constant ([`super::obj::DEFAULT_ENVIRONMENT`]).
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
//! Malformed XML (or UTF-16 text) → [`RenderError::BadInput`] with `roxmltree`'s message and
//! position; XML nested deeper than `max_nesting` → [`RenderError::ResourceLimit`]; a file
//! outside the scene's folder → `BadInput`, one that is not a regular file → `Io`;
//! a root other than `<scene>`, a number that does not parse, a `<ref>` to an undefined id,
//! a shape without a file or whose file does not exist (message names the shape, its line
//! and the file) → `BadInput`; errors of the OBJ/PLY loaders are passed on. Unknown
//! elements, shape/BSDF/emitter types → warnings.
//!
//! # Code
//!
//! One job per file: `tree` (XML, includes, `<default>` / `$name` substitution, ids),
//! `values` (numbers, booleans, colours, spectra, points and the typed parameter look-ups),
//! `transform` (`toWorld`), `textures`, `bsdf` (materials), `shapes`, `sensor` (cameras),
//! `emitters` (lights, environment, the point light of an area emitter) and `sun` (the sun
//! position). The analytic meshes come from the scene's shared primitive-mesh module. This
//! file holds the entry point, the loader state and the final assembly.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use rayon::prelude::*;

use super::files::SceneFiles;
use super::limits::LoadLimits;
use super::{CameraDesc, Environment, Light, MaterialId, Mesh, Scene, Texture, TextureId};
use crate::error::{RenderError, Result};

mod bsdf;
mod emitters;
mod sensor;
mod shapes;
mod sun;
mod textures;
mod transform;
mod tree;
mod values;

use bsdf::{MatBuild, Slot};
use shapes::ShapeJob;
use tree::{collect_defaults, collect_ids, substitute_tree, TreeReader, XNode};
use values::req_attr;

/// Irradiance of a `sun` / `sunsky` emitter per unit of `sunScale` × `scale` (our constant,
/// a warm white; the physical sun model of Mitsuba is not reproduced).
pub const SUN_IRRADIANCE_PER_SCALE: Vec3 = Vec3::new(1.0, 0.95, 0.9);

/// Constant environment radiance of a `sky` / `sunsky` emitter per unit of `skyScale` ×
/// `scale`: a sky blue `(0.4, 0.5, 0.7) × 0.1` (our constant), so that the sky lights a
/// horizontal surface with roughly a quarter of the sun's irradiance when both scales are
/// equal.
pub const SKY_RADIANCE_PER_SCALE: Vec3 = Vec3::new(0.04, 0.05, 0.07);

/// Deepest `<include>` nesting / `<ref>` chain.
const MAX_DEPTH: u32 = 16;

/// A [`RenderError::BadInput`] about `file`.
fn bad(file: &Path, what: impl Into<String>) -> RenderError {
    RenderError::bad(file, what)
}

/// State of one load: the parsed tree's ids, the materials, texture requests and shape jobs
/// collected so far, and the lights, cameras and environment.
struct Loader<'t> {
    path: PathBuf,
    files: &'t SceneFiles,
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
    environment: Option<Environment>,
    shape_count: usize,
}

/// Loads a Mitsuba scene file (see the module docs for what is read and how), within the
/// default [`LoadLimits`].
pub fn load(path: &Path) -> Result<Scene> {
    load_with_limits(path, &LoadLimits::default())
}

/// [`load`] within `limits`: file sizes, XML nesting (`max_nesting`), files outside the
/// scene's folder.
pub fn load_with_limits(path: &Path, limits: &LoadLimits) -> Result<Scene> {
    let files = SceneFiles::new(path, limits)?;
    let scene_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut reader = TreeReader {
        files: &files,
        stack: Vec::new(),
        dirs: vec![scene_dir],
    };
    let mut tree = reader.read_tree(path, true, 0)?;
    let dirs = reader.dirs;
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
        files: &files,
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

    /// Builds the shapes and decodes the textures (in parallel), then assembles the scene:
    /// texture ids, an emissive copy of the material of each area emitter and its point
    /// light, materials with their textures.
    fn finish(mut self) -> Result<Scene> {
        let jobs = std::mem::take(&mut self.jobs);
        let requests = std::mem::take(&mut self.tex_requests);
        let files = self.files;
        let (meshes, textures): (Vec<Result<Mesh>>, Vec<Result<Texture>>) = rayon::join(
            || jobs.par_iter().map(|j| j.build(files)).collect(),
            || {
                requests
                    .par_iter()
                    .map(|(p, srgb)| Texture::load_in(files, p, *srgb))
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
        let mut colored = Vec::new();
        for (job, mesh) in jobs.iter().zip(meshes) {
            let mut mesh = mesh?;
            if !mesh.colors.is_empty() {
                // Mitsuba shows vertex colours only through a `vertexcolors` texture.
                colored.push(mesh.name.clone());
                mesh.colors.clear();
            }
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

        if !colored.is_empty() {
            self.warnings.push(format!(
                "vertex colours of {} shape(s) ignored, as Mitsuba does without a \
                 `vertexcolors` texture ({}{})",
                colored.len(),
                colored
                    .iter()
                    .take(5)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", "),
                if colored.len() > 5 { ", …" } else { "" }
            ));
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
            environment: self
                .environment
                .unwrap_or(Environment::Constant(super::obj::DEFAULT_ENVIRONMENT)),
            light_units: crate::scene::LightUnits::Relative,
            metres_per_unit: 1.0,
            warnings: self.warnings,
        })
    }
}
