//! A linear scan over every triangle: the reference for BVH tests.

use super::{intersect_triangle, Backend, Hit, Ray, RayCaster, Triangles};

/// Tests every triangle for every ray.
pub struct BruteForce {
    verts: Vec<[glam::Vec3; 3]>,
}

impl BruteForce {
    /// Copies the triangles.
    pub fn new(tris: &Triangles) -> Self {
        Self {
            verts: tris.verts.clone(),
        }
    }
}

impl RayCaster for BruteForce {
    fn backend(&self) -> Backend {
        Backend::BruteForce
    }

    /// The least `(t, triangle index)` in `[t_min, t_max)`, as the BVHs report it.
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut r = *ray;
        for (k, v) in self.verts.iter().enumerate() {
            if let Some((t, u, w)) = intersect_triangle(&r, v).filter(|h| h.0 < r.t_max) {
                r.t_max = t;
                best = Some(Hit {
                    t,
                    tri: k as u32,
                    bary: glam::Vec2::new(u, w),
                });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.verts
            .iter()
            .any(|v| intersect_triangle(ray, v).is_some())
    }
}
