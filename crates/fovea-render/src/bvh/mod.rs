//! Ray casting against the scene's triangles: closest hit for primary and bounce rays, any
//! hit for shadow rays.
//!
//! Backends implement [`RayCaster`]:
//! * [`obvhs_bvh::ObvhsCaster`], the default: the pure-Rust `obvhs` compressed-wide BVH
//!   (PLOC build, 8-wide nodes), no system dependency; batches go as packets of 64 rays
//!   through the binary BVH under it ([`packet`]).
//! * `embree_bvh::EmbreeCaster` (cargo feature `embree`): Intel Embree 3 through the
//!   `embree` crate, needs Debian's `libembree-dev`.
//! * [`brute::BruteForce`]: a linear scan over every triangle, the reference the tests check
//!   the BVHs against.
//!
//! All report hits by the triangle's index in [`Triangles`], the flattened scene. The BVH
//! backends hold every distinct triangle once ([`distinct`]): exact duplicates stay out of
//! the tree, which keeps the builds O(n log n) on repeated geometry and changes no hit; the
//! obvhs tree gathers the triangles that share one bounding box first ([`same_box`]).

pub use distinct::Distinct;

use glam::{Vec2, Vec3};

use crate::scene::Scene;

pub mod brute;
pub mod distinct;
#[cfg(feature = "embree")]
pub mod embree_bvh;
pub mod obvhs_bvh;
pub mod packet;
pub mod same_box;

/// A ray: origin, unit direction and the parametric interval `[t_min, t_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin, world space.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Nearest accepted distance.
    pub t_min: f32,
    /// Farthest accepted distance.
    pub t_max: f32,
}

impl Ray {
    /// A ray from `origin` along `dir` (normalised here) over `[t_min, t_max]`.
    pub fn new(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Self {
            origin,
            dir: dir.normalize(),
            t_min,
            t_max,
        }
    }
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// Triangle index in [`Triangles`].
    pub tri: u32,
    /// Barycentric coordinates of vertices 1 and 2 (vertex 0 has `1 − u − v`).
    pub bary: Vec2,
}

/// Which acceleration structure to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// Pure-Rust `obvhs` CWBVH (default).
    Obvhs,
    /// Intel Embree 3 (feature `embree`).
    Embree,
    /// Linear scan (tests only: O(triangles) per ray).
    BruteForce,
}

impl Backend {
    /// Name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Obvhs => "obvhs",
            Backend::Embree => "embree",
            Backend::BruteForce => "brute-force",
        }
    }

    /// Parses a backend name.
    pub fn parse(s: &str) -> crate::Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "obvhs" => Ok(Backend::Obvhs),
            "embree" => Ok(Backend::Embree),
            "brute" | "brute-force" => Ok(Backend::BruteForce),
            _ => Err(crate::RenderError::invalid(
                "bvh",
                s,
                "obvhs, embree (with the `embree` feature) or brute-force",
            )),
        }
    }

    /// Whether this build can use the backend.
    pub fn available(self) -> bool {
        self != Backend::Embree || cfg!(feature = "embree")
    }

    /// The fastest backend in this build (Embree when compiled in, see README's
    /// measurements).
    pub fn best_available() -> Self {
        if cfg!(feature = "embree") {
            Backend::Embree
        } else {
            Backend::Obvhs
        }
    }
}

/// Closest-hit and any-hit queries.
pub trait RayCaster: Send + Sync {
    /// Which backend this is.
    fn backend(&self) -> Backend;
    /// The closest hit in `[t_min, t_max]`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything lies in `[t_min, t_max]` (shadow rays).
    fn occluded(&self, ray: &Ray) -> bool;
    /// [`RayCaster::intersect`] of every ray of a batch, into `out` (the same length). The
    /// renderer hands over coherent batches (primary rays of neighbouring texels); the default
    /// casts one ray at a time, a backend with packet or stream traversal (Embree, obvhs)
    /// overrides it.
    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.intersect(r);
        }
    }
    /// [`RayCaster::occluded`] of every ray of a batch, into `out` (the same length): the
    /// renderer hands over the shadow rays of neighbouring samples towards one light.
    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.occluded(r);
        }
    }
}

/// The scene's triangles flattened in one array, with where each came from.
#[derive(Clone, Debug, Default)]
pub struct Triangles {
    /// Vertex positions of every triangle.
    pub verts: Vec<[Vec3; 3]>,
    /// `(mesh index, triangle index in the mesh)` of every triangle.
    pub source: Vec<(u32, u32)>,
}

impl Triangles {
    /// Flattens a scene.
    pub fn of_scene(scene: &Scene) -> Self {
        let n = scene.triangle_count();
        let mut verts = Vec::with_capacity(n);
        let mut source = Vec::with_capacity(n);
        for (mi, m) in scene.meshes.iter().enumerate() {
            for (ti, t) in m.indices.iter().enumerate() {
                verts.push(t.map(|i| m.positions[i as usize]));
                source.push((mi as u32, ti as u32));
            }
        }
        Self { verts, source }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.verts.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.verts.is_empty()
    }

    /// Every triangle's vertices as plain arrays (what `fovea-gpu`'s tracer uploads).
    pub fn vertex_arrays(&self) -> Vec<[[f32; 3]; 3]> {
        self.verts
            .iter()
            .map(|v| [v[0].to_array(), v[1].to_array(), v[2].to_array()])
            .collect()
    }

    /// FNV-1a over the bits of every vertex coordinate, in order: equal for the same
    /// triangles, different (with overwhelming likelihood) for others.
    pub fn fingerprint(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for c in self.verts.iter().flatten().flat_map(|v| v.to_array()) {
            h ^= u64::from(c.to_bits());
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        h ^ self.verts.len() as u64
    }
}

/// Möller–Trumbore ray/triangle test: `(t, u, v)` of the hit in `[t_min, t_max]`, both faces.
/// Always inlined: it is the inner loop of every backend's traversal.
#[inline(always)]
pub fn intersect_triangle(ray: &Ray, v: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - v[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let w = ray.dir.dot(q) * inv;
    if w < 0.0 || u + w > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t >= ray.t_min && t <= ray.t_max).then_some((t, u, w))
}

/// Builds the requested backend (the exact duplicates found here, see [`build_distinct`]).
pub fn build(backend: Backend, tris: &Triangles) -> crate::Result<Box<dyn RayCaster>> {
    let distinct = match backend {
        Backend::BruteForce => Distinct::all(),
        _ => Distinct::of(&tris.verts),
    };
    build_distinct(backend, tris, &distinct)
}

/// Builds the requested backend over the triangles `distinct` keeps (from
/// [`Distinct::of`]`(&tris.verts)`); the brute-force scan takes every triangle.
pub fn build_distinct(
    backend: Backend,
    tris: &Triangles,
    distinct: &Distinct,
) -> crate::Result<Box<dyn RayCaster>> {
    Ok(match backend {
        Backend::Obvhs => Box::new(obvhs_bvh::ObvhsCaster::new_distinct(tris, distinct)),
        Backend::BruteForce => Box::new(brute::BruteForce::new(tris)),
        #[cfg(feature = "embree")]
        Backend::Embree => Box::new(embree_bvh::EmbreeCaster::new_distinct(tris, distinct)?),
        #[cfg(not(feature = "embree"))]
        Backend::Embree => return Err(crate::RenderError::Unsupported(
            "the Embree backend: rebuild with `--features embree` (needs Debian's libembree-dev)"
                .into(),
        )),
    })
}
