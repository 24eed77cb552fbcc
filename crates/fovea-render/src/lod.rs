//! Gaze-contingent level of detail (Liu, Mantel, Forchhammer, Sec. 3.3.3, Eq. 14).
//!
//! Offline, every mesh gets a simplified level built with quadric-error simplification
//! (meshoptimizer's `meshopt_simplify` through the `meshopt` crate; Liu et al. use Garland &
//! Heckbert's quadrics, "which reduces the triangle number of an object by 50 %–80 %", with two
//! levels). Per frame, Eq. 14 flags each object:
//!
//! `w_s(o) = 1` if `α(CEO→o, CGR) ≤ 5°` and `D_Nv ≤ D_o ≤ D_Fv`, else 0,
//!
//! the angle between the gaze ray and the ray from the eye to the object, and whether the
//! object lies within the eye's depth of field (limits from the thin-lens eye at the focus).
//! Flagged objects (in fovea and in focus) keep full detail; all others use the simplified
//! level. The paper leaves "the ray to the object" and "the depth of the object" open; here an
//! object is its bounding sphere: the angle is to the sphere's centre less its angular radius
//! (so an object the gaze ray passes through counts as at 0°), and it is in focus when the
//! sphere's depth range `[d − r, d + r]` overlaps `[D_Nv, D_Fv]`.
//!
//! The frame's world (BVH) is built from the chosen levels; "triangles traced" is its
//! triangle count.

use glam::Vec3;
use serde::Serialize;

use fovea_core::optics::{DofLimits, EyeModel};
use fovea_core::units::Metres;

use crate::bvh::Backend;
use crate::camera::EyeCamera;
use crate::dof::auto_focus_m;
use crate::error::{RenderError, Result};
use crate::eye::EyeState;
use crate::scene::{Mesh, Scene};
use crate::world::World;

/// Options of the level of detail.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LodParams {
    /// Share of the triangles the simplified level keeps (Liu: 50–80 % fewer → 0.2–0.5).
    pub keep_ratio: f32,
    /// Largest simplification error, relative to the mesh's extent (meshoptimizer's
    /// `target_error`).
    pub max_error: f32,
    /// Angular radius of the fovea for Eq. 14, degrees (5°).
    pub fovea_deg: f32,
}

impl Default for LodParams {
    fn default() -> Self {
        Self {
            keep_ratio: 0.3,
            max_error: 0.05,
            fovea_deg: 5.0,
        }
    }
}

impl LodParams {
    /// Checks `keep_ratio` in (0, 1], `max_error` in (0, 1], `fovea_deg` in [0, 90].
    pub fn validate(&self) -> Result<()> {
        if !(self.keep_ratio > 0.0 && self.keep_ratio <= 1.0) {
            return Err(RenderError::invalid(
                "lod-keep",
                self.keep_ratio,
                "a share of triangles in (0, 1], e.g. 0.3",
            ));
        }
        if !(self.max_error > 0.0 && self.max_error <= 1.0) {
            return Err(RenderError::invalid(
                "lod-error",
                self.max_error,
                "a relative error in (0, 1]",
            ));
        }
        if !(0.0..=90.0).contains(&self.fovea_deg) {
            return Err(RenderError::invalid(
                "lod-fovea",
                self.fovea_deg,
                "degrees in [0, 90]",
            ));
        }
        Ok(())
    }
}

/// A scene with a simplified level per mesh and each mesh's bounding sphere.
pub struct LodScene {
    scene: Scene,
    simplified: Vec<Vec<[u32; 3]>>,
    spheres: Vec<(Vec3, f32)>,
    params: LodParams,
}

/// What Eq. 14 chose for one frame.
#[derive(Clone, Debug, Serialize)]
pub struct LodStats {
    /// Meshes kept at full detail (in fovea and in focus).
    pub full_detail: usize,
    /// Meshes at the simplified level.
    pub simplified: usize,
    /// Triangles of the frame's world.
    pub triangles: usize,
    /// Triangles at full detail everywhere.
    pub triangles_full: usize,
}

impl LodScene {
    /// Builds the simplified level of every mesh (offline step).
    pub fn new(scene: Scene, params: LodParams) -> Result<Self> {
        params.validate()?;
        let mut simplified = Vec::with_capacity(scene.meshes.len());
        let mut spheres = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            simplified.push(simplify(m, &params)?);
            spheres.push(bounding_sphere(m));
        }
        Ok(Self {
            scene,
            simplified,
            spheres,
            params,
        })
    }

    /// The full-detail scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Triangles of mesh `k` at the simplified level.
    pub fn simplified_triangles(&self, k: usize) -> usize {
        self.simplified.get(k).map_or(0, Vec::len)
    }

    /// Eq. 14 for every mesh: `true` = full detail.
    pub fn flags(&self, camera: &EyeCamera, gaze_dir: Vec3, limits: &DofLimits) -> Vec<bool> {
        let g = gaze_dir.normalize_or_zero();
        let fovea = self.params.fovea_deg.to_radians();
        self.spheres
            .iter()
            .map(|&(c, r)| {
                let to = c - camera.position;
                let d = to.length();
                if d <= r {
                    // The eye is inside the bounding sphere.
                    return true;
                }
                let angle = g.angle_between(to / d) - (r / d).clamp(-1.0, 1.0).asin();
                let (near, far) = (limits.near.0 as f32, limits.far.0 as f32);
                angle <= fovea && d + r >= near && d - r <= far
            })
            .collect()
    }

    /// The frame's world: flagged meshes at full detail, the others simplified.
    pub fn world(&self, flags: &[bool], backend: Backend) -> Result<(World, LodStats)> {
        let mut scene = self.scene.clone();
        let mut full_detail = 0;
        let triangles_full = self.scene.triangle_count();
        for (k, m) in scene.meshes.iter_mut().enumerate() {
            if flags.get(k).copied().unwrap_or(true) {
                full_detail += 1;
            } else {
                m.indices = self.simplified[k].clone();
            }
        }
        let n = scene.meshes.len();
        let world = World::new(scene, backend)?;
        let stats = LodStats {
            full_detail,
            simplified: n - full_detail,
            triangles: world.tris.len(),
            triangles_full,
        };
        Ok((world, stats))
    }

    /// Eq. 14 with the eye focused at `focus_m` (pupil and criterion of `eye`), and the
    /// frame's world.
    pub fn frame_world(
        &self,
        camera: &EyeCamera,
        gaze_dir: Vec3,
        eye: &EyeModel,
        focus_m: f64,
        backend: Backend,
    ) -> Result<(World, LodStats)> {
        let limits = eye.dof_limits(Metres(focus_m))?;
        let flags = self.flags(camera, gaze_dir, &limits);
        self.world(&flags, backend)
    }

    /// [`Self::frame_world`] for a frame of `world` seen by `camera` in `state`: the eye
    /// focused where the state says (auto focus at its gaze when it has no focus, a frame
    /// without depth of field), the pupil and criterion of `eye`, `world`'s BVH backend and
    /// lights.
    pub fn world_for(
        &self,
        world: &World,
        camera: &EyeCamera,
        eye: &EyeModel,
        state: &EyeState,
    ) -> Result<(World, LodStats)> {
        let focus = match state.focus {
            Some(f) => f.metres(),
            None => auto_focus_m(world, camera, &state.gaze)?,
        };
        let gaze_dir = camera.ray(state.gaze.point).dir;
        let (mut w, st) = self.frame_world(camera, gaze_dir, eye, focus, world.caster.backend())?;
        w.lights = world.lights.clone();
        Ok((w, st))
    }
}

/// Quadric simplification of `m` to `keep_ratio` of its triangles (never more than it has;
/// meshes of fewer than 8 triangles stay as they are).
fn simplify(m: &Mesh, p: &LodParams) -> Result<Vec<[u32; 3]>> {
    if m.indices.len() < 8 {
        return Ok(m.indices.clone());
    }
    let flat: Vec<f32> = m.positions.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
    let adapter = meshopt::VertexDataAdapter::new(meshopt::typed_to_bytes(&flat), 12, 0)
        .map_err(|e| RenderError::Unsupported(format!("mesh `{}`: {e}", m.name)))?;
    let indices: Vec<u32> = m.indices.iter().flatten().copied().collect();
    let target = ((indices.len() as f32 * p.keep_ratio) as usize / 3).max(1) * 3;
    let out = meshopt::simplify(
        &indices,
        &adapter,
        target,
        p.max_error,
        meshopt::SimplifyOptions::empty(),
        None,
    );
    if out.is_empty() {
        // Simplified away entirely (a tiny object): keep the full mesh.
        return Ok(m.indices.clone());
    }
    Ok(out.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect())
}

/// Centre of the bounding box and the radius of the sphere around it holding every vertex.
fn bounding_sphere(m: &Mesh) -> (Vec3, f32) {
    let (lo, hi) = m.positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    if !lo.is_finite() || !hi.is_finite() {
        return (Vec3::ZERO, 0.0);
    }
    let c = 0.5 * (lo + hi);
    let r = m
        .positions
        .iter()
        .map(|p| p.distance(c))
        .fold(0.0f32, f32::max);
    (c, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;

    #[test]
    fn simplified_levels_have_fewer_triangles_and_valid_indices() {
        let scene = builtin::depth_range().unwrap();
        let lod = LodScene::new(scene, LodParams::default()).unwrap();
        let s = lod.scene();
        let mut any_smaller = false;
        for (k, m) in s.meshes.iter().enumerate() {
            let n = lod.simplified_triangles(k);
            assert!(n >= 1 && n <= m.indices.len(), "{}: {n}", m.name);
            for t in &lod.simplified[k] {
                assert!(t.iter().all(|&i| (i as usize) < m.positions.len()));
            }
            any_smaller |= n < m.indices.len();
        }
        assert!(any_smaller);
    }

    #[test]
    fn bad_parameters_are_errors() {
        for p in [
            LodParams {
                keep_ratio: 0.0,
                ..Default::default()
            },
            LodParams {
                max_error: f32::NAN,
                ..Default::default()
            },
            LodParams {
                fovea_deg: -1.0,
                ..Default::default()
            },
        ] {
            assert!(LodScene::new(builtin::depth_range().unwrap(), p).is_err());
        }
    }
}
