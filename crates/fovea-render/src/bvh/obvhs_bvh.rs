//! The default backend: `obvhs`' compressed wide BVH (CWBVH, Ylitie et al. 2017) built with
//! PLOC, traversed on the CPU. Triangles are stored in BVH order so a leaf's triangles are
//! contiguous in memory; hits are reported by the original index.

use glam::{Vec2, Vec3A};
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::BvhBuildParams;

use super::packet::{PacketBvh, LEAF_MAX};
use super::same_box::build_bvh2;
use super::{intersect_triangle, Backend, Distinct, Hit, Ray, RayCaster, Triangles};

/// `obvhs` CWBVH over the scene triangles.
pub struct ObvhsCaster {
    bvh: CwBvh,
    /// Triangles in BVH primitive order.
    verts: Vec<[glam::Vec3; 3]>,
    /// Original index of each triangle in BVH order.
    original: Vec<u32>,
    /// The binary BVH under the CWBVH, for packets of rays (`intersect_batch`).
    packet: PacketBvh,
}

impl ObvhsCaster {
    /// Builds the BVH (medium-quality preset) over the distinct triangles.
    pub fn new(tris: &Triangles) -> Self {
        Self::new_distinct(tris, &Distinct::of(&tris.verts))
    }

    /// Builds the BVH over the triangles `distinct` keeps (exact duplicates left out, see
    /// [`Distinct`]; hits still name the scene's triangle indices).
    pub fn new_distinct(tris: &Triangles, distinct: &Distinct) -> Self {
        // `obvhs::cwbvh::builder::build_cwbvh_from_tris` (no pre-splits) step by step, keeping
        // its binary BVH for the packets: PLOC and reinsertion over the distinct triangles,
        // those sharing a box gathered (`same_box`), then widened to the CWBVH.
        let params = BvhBuildParams::medium_build();
        let mut bvh2 = build_bvh2(&tris.verts, distinct);
        let bvh = bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false);
        // The packets' tree: leaves of up to `LEAF_MAX` triangles.
        collapse(&mut bvh2, LEAF_MAX, params.collapse_traversal_cost);
        let packet = PacketBvh::new(&bvh2, &tris.verts);
        let original = bvh.primitive_indices.clone();
        let verts = original.iter().map(|&i| tris.verts[i as usize]).collect();
        Self {
            bvh,
            verts,
            original,
            packet,
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

    /// The least `(t, triangle index)` in `[t_min, t_max)` (`packet`'s header): a tie in `t`
    /// goes to the lower index whichever leaf `obvhs` meets first.
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut rh = obvhs::ray::RayHit::none();
        let mut best: Option<Hit> = None;
        let r = Self::to_obvhs(ray);
        self.bvh.ray_traverse(r, &mut rh, |orr, id| {
            let q = Ray {
                origin: ray.origin,
                dir: ray.dir,
                t_min: ray.t_min,
                t_max: orr.tmax,
            };
            let tri = self.original[id];
            match intersect_triangle(&q, &self.verts[id]) {
                Some((t, u, v))
                    if t < orr.tmax || best.is_some_and(|b| t == b.t && tri < b.tri) =>
                {
                    best = Some(Hit {
                        t,
                        tri,
                        bary: Vec2::new(u, v),
                    });
                    t
                }
                _ => f32::INFINITY,
            }
        });
        best
    }

    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.packet.intersect_batch(rays, out);
    }

    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        self.packet.occluded_batch(rays, out);
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let r = Self::to_obvhs(ray);
        !self.bvh.ray_traverse_miss(r, |_, id| {
            intersect_triangle(ray, &self.verts[id]).map_or(f32::INFINITY, |h| h.0)
        })
    }
}
