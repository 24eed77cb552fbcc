//! Shapes → shape jobs, built (files read, meshes transformed) in parallel when the scene is
//! assembled: `obj` and `ply` files through the OBJ / PLY loaders (`faceNormals`,
//! `flipTexCoords`), the analytic `rectangle`, `cube`, `sphere` (`center`, `radius`), `disk`
//! and `cylinder` (`p0`, `p1`, `radius`) from the shared primitive meshes, `shapegroup` +
//! `instance`, `flipNormals`, `toWorld`, and the shape's BSDF and `area` emitter.

use std::path::PathBuf;

use glam::{Mat4, Vec2, Vec3};

use super::transform::to_world;
use super::tree::XNode;
use super::{bad, Loader, MAX_DEPTH};
use crate::error::Result;
use crate::scene::files::SceneFiles;
use crate::scene::primitives::{self, Poles, UvLayout};
use crate::scene::{MaterialId, Mesh};

/// Segments of tessellated spheres, disks and cylinders around their axis.
const SEGMENTS: u32 = 64;
/// Rings of tessellated spheres (pole to pole).
const RINGS: u32 = 32;

/// Mitsuba's `rectangle`: the [-1, 1]² quad in z = 0 facing +z, uv = ((x+1)/2, (y+1)/2).
fn rectangle() -> Mesh {
    primitives::quad(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        Vec2::ONE,
        UvLayout::VAlongAxis,
    )
}

/// Mitsuba's `cube`: [-1, 1]³, 24 vertices, 12 triangles, outward normals.
fn cube() -> Mesh {
    let faces = primitives::box_faces_by_axis();
    primitives::cuboid(Vec3::ZERO, Vec3::ONE, faces, UvLayout::VAlongAxis)
}

/// Where a shape's mesh comes from.
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

/// A shape to build: its geometry, transform, material and area emitter.
pub(super) struct ShapeJob {
    name: String,
    geometry: Geometry,
    to_world: Mat4,
    pub(super) material: MaterialId,
    flip_normals: bool,
    pub(super) emitter: Option<Vec3>,
}

impl ShapeJob {
    pub(super) fn build(&self, files: &SceneFiles) -> Result<Mesh> {
        let mut mesh = match &self.geometry {
            Geometry::Obj {
                path,
                face_normals,
                flip_tex,
            } => {
                let mut m = crate::scene::obj::load_mesh_in(files, path, self.material)?;
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
                let mut m = crate::scene::ply::load_mesh_in(files, path, self.material)?;
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

impl<'t> Loader<'t> {
    pub(super) fn shape(&mut self, node: &'t XNode, parent: Mat4, depth: u32) -> Result<()> {
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
            // Existence only: the reader refuses what is not a regular file, or lies
            // outside the scene's folder, with its own message.
            if !p.exists() {
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
            "disk" => (
                Geometry::Builtin(primitives::disk(SEGMENTS)),
                Mat4::IDENTITY,
            ),
            "sphere" => {
                let c = Self::point_param(node, &["center"], Vec3::ZERO)?;
                let r = self.float_param(node, &["radius"], 1.0)?;
                if !(r.is_finite() && r > 0.0) {
                    return Err(bad(&node.file, format!("{label}: radius {r} is not > 0")));
                }
                (
                    Geometry::Builtin(primitives::uv_sphere(SEGMENTS, RINGS, Poles::Z)),
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
                (Geometry::Builtin(primitives::open_tube(SEGMENTS)), frame)
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
}
