//! The default backend: `obvhs`' compressed wide BVH (CWBVH, Ylitie et al. 2017) built with
//! PLOC, traversed on the CPU. Triangles are stored in BVH order so a leaf's triangles are
//! contiguous in memory; hits are reported by the original index.

use glam::{Vec2, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::{intersect_triangle, Backend, Hit, Ray, RayCaster, Triangles};

/// `obvhs` CWBVH over the scene triangles.
pub struct ObvhsCaster {
    bvh: CwBvh,
    /// Triangles in BVH primitive order.
    verts: Vec<[glam::Vec3; 3]>,
    /// Original index of each triangle in BVH order.
    original: Vec<u32>,
}

impl ObvhsCaster {
    /// Builds the BVH (medium-quality preset).
    pub fn new(tris: &Triangles) -> Self {
        let t: Vec<Triangle> = tris
            .verts
            .iter()
            .map(|v| Triangle {
                v0: Vec3A::from(v[0]),
                v1: Vec3A::from(v[1]),
                v2: Vec3A::from(v[2]),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &t,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let original = bvh.primitive_indices.clone();
        let verts = original.iter().map(|&i| tris.verts[i as usize]).collect();
        Self {
            bvh,
            verts,
            original,
        }
    }

    /// The ray in `obvhs`' type. A direction component of `-0.0` is made `+0.0` first:
    /// `obvhs` 0.4 takes the traversal octant from the component's comparison with 0 (`-0.0`
    /// counts as positive) but its inverse from `signum` (`-0.0` gives `-1/ε`), and with the
    /// two disagreeing the ray misses every triangle. A sun straight overhead or a light
    /// direction negated from an axis-aligned one (`-(0, -1.5, -1)`) has such a component.
    #[inline]
    fn to_obvhs(ray: &Ray) -> obvhs::ray::Ray {
        // IEEE 754: -0.0 + 0.0 = +0.0; every other value is unchanged.
        let dir = ray.dir + glam::Vec3::ZERO;
        obvhs::ray::Ray::new(
            Vec3A::from(ray.origin),
            Vec3A::from(dir),
            ray.t_min,
            ray.t_max,
        )
    }
}

impl RayCaster for ObvhsCaster {
    fn backend(&self) -> Backend {
        Backend::Obvhs
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut rh = obvhs::ray::RayHit::none();
        let mut best = Vec2::ZERO;
        let r = Self::to_obvhs(ray);
        let hit = self.bvh.ray_traverse(r, &mut rh, |orr, id| {
            let q = Ray {
                origin: ray.origin,
                dir: ray.dir,
                t_min: ray.t_min,
                t_max: orr.tmax,
            };
            match intersect_triangle(&q, &self.verts[id]) {
                Some((t, u, v)) if t < orr.tmax => {
                    best = Vec2::new(u, v);
                    t
                }
                _ => f32::INFINITY,
            }
        });
        hit.then(|| Hit {
            t: rh.t,
            tri: self.original[rh.primitive_id as usize],
            bary: best,
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let r = Self::to_obvhs(ray);
        !self.bvh.ray_traverse_miss(r, |_, id| {
            intersect_triangle(ray, &self.verts[id]).map_or(f32::INFINITY, |h| h.0)
        })
    }
}
