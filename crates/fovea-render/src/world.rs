//! A scene prepared for ray casting: flattened triangles, the acceleration structure, per-
//! triangle data the shader needs (UV-to-world scale for texture level of detail) and the
//! lights in use.

use std::time::Instant;

use glam::Vec3;

use crate::bvh::{self, Backend, RayCaster, Triangles};
use crate::error::Result;
use crate::scene::{Light, Scene};

/// A scene ready to render.
pub struct World {
    /// The scene (world space, metres).
    pub scene: Scene,
    /// Flattened triangles.
    pub tris: Triangles,
    /// The acceleration structure.
    pub caster: Box<dyn RayCaster>,
    /// Per triangle: `√(UV area / world area)`, UV units per metre (0 without UVs).
    pub uv_per_metre: Vec<f32>,
    /// Lights used for shading (the scene's, or generated ones, see `crate::lights`).
    pub lights: Vec<Light>,
    /// BVH build time, milliseconds (the search for exact duplicates included).
    pub build_ms: f64,
    /// Exact duplicate triangles, held once by the BVH (see [`bvh::Distinct`]).
    pub duplicate_triangles: usize,
    /// FNV-1a of the triangles' vertex bits: which geometry another executor of the trace
    /// stage must have been built from (see `pipeline::TraceExecutor::serves`).
    pub tris_fingerprint: u64,
}

impl World {
    /// Flattens `scene`, builds the BVH of `backend` and takes the scene's lights. Exact
    /// duplicate triangles are held once by the BVH, with a warning pushed to
    /// `scene.warnings` (see [`bvh::Distinct`]).
    pub fn new(mut scene: Scene, backend: Backend) -> Result<Self> {
        let tris = Triangles::of_scene(&scene);
        let t0 = Instant::now();
        let distinct = bvh::Distinct::of(&tris.verts);
        if let Some(w) = distinct.warning() {
            scene.warnings.push(w);
        }
        let caster = bvh::build_distinct(backend, &tris, &distinct)?;
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        let uv_per_metre = tris
            .source
            .iter()
            .zip(&tris.verts)
            .map(|(&(mi, ti), v)| {
                let m = &scene.meshes[mi as usize];
                if m.uvs.is_empty() {
                    return 0.0;
                }
                let idx = m.indices[ti as usize];
                let uv = idx.map(|i| m.uvs[i as usize]);
                let uv_area = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]).abs();
                let w_area = (v[1] - v[0]).cross(v[2] - v[0]).length();
                if w_area > 0.0 {
                    (uv_area / w_area).sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        let lights = scene.lights.clone();
        let tris_fingerprint = tris.fingerprint();
        Ok(Self {
            scene,
            tris,
            caster,
            uv_per_metre,
            lights,
            build_ms,
            duplicate_triangles: distinct.duplicates,
            tris_fingerprint,
        })
    }

    /// Geometric (face) normal of triangle `tri`, unit length.
    #[inline]
    pub fn face_normal(&self, tri: u32) -> Vec3 {
        let v = &self.tris.verts[tri as usize];
        (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero()
    }
}

impl World {
    /// Whether `point` seems enclosed by geometry seen from inside: of 26 rays cast from it
    /// (axes, face and cube diagonals), at least 20 hit something and at least 90 % of those
    /// hit a triangle's back face. Returns the name of the mesh hit most often. Closed rooms
    /// whose walls face inwards are not reported (their hits are front faces).
    pub fn enclosing_mesh(&self, point: Vec3) -> Option<String> {
        let mut dirs = Vec::with_capacity(26);
        for x in -1i32..=1 {
            for y in -1i32..=1 {
                for z in -1i32..=1 {
                    if (x, y, z) != (0, 0, 0) {
                        dirs.push(Vec3::new(x as f32, y as f32, z as f32).normalize());
                    }
                }
            }
        }
        let mut hits = 0;
        let mut back = 0;
        let mut meshes = std::collections::HashMap::<u32, u32>::new();
        for d in dirs {
            let ray = crate::bvh::Ray {
                origin: point,
                dir: d,
                t_min: 0.0,
                t_max: f32::INFINITY,
            };
            if let Some(h) = self.caster.intersect(&ray) {
                hits += 1;
                if self.face_normal(h.tri).dot(d) > 0.0 {
                    back += 1;
                    *meshes
                        .entry(self.tris.source[h.tri as usize].0)
                        .or_default() += 1;
                }
            }
        }
        if hits >= 20 && back * 10 >= hits * 9 {
            let m = meshes.into_iter().max_by_key(|&(_, c)| c).map(|(m, _)| m)?;
            Some(self.scene.meshes[m as usize].name.clone())
        } else {
            None
        }
    }
}
