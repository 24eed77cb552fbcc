//! Mesh primitives → meshes in their local frame: `POSITION`, `NORMAL`, `TEXCOORD_0`,
//! `TANGENT`, `COLOR_0` and the indices (or `0..n`); triangle lists, strips and fans (with the spec's
//! winding). Points, lines and primitives without `POSITION` are skipped and listed in one
//! warning per kind.

use ::gltf::mesh::{Mode, Semantic};
use glam::{Vec2, Vec3, Vec4};

use super::accessor::{read_attribute, read_indices};
use super::Loader;
use crate::error::{RenderError, Result};
use crate::scene::{MaterialId, Mesh};

impl Loader<'_> {
    /// Decodes one primitive in its local frame; `None` when it is skipped (with a warning
    /// recorded). Errors are problems with POSITION or the indices.
    pub(super) fn read_primitive(
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
        // COLOR_0: VEC3 or VEC4 (alpha dropped), float or normalized integers, linear.
        let color_dims = prim
            .get(&Semantic::Colors(0))
            .map_or(3, |acc| match acc.dimensions() {
                ::gltf::accessor::Dimensions::Vec4 => 4,
                _ => 3,
            });
        let colors = optional(Semantic::Colors(0), color_dims)
            .chunks_exact(color_dims)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
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
            colors,
            indices,
            material,
        }))
    }
}
