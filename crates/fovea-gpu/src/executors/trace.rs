//! [`GpuTracer`] as the pipeline's trace executor (`fovea_render::pipeline::TraceExecutor`):
//! every method's primary rays generated and cast on the device (polar or screen-aligned),
//! the surfaces at their hits interpolated there when the scene's surfaces fit
//! ([`GpuSurfaces`]), the shade stage's shadow rays, and the lights' and the environment's
//! part of direct shading.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use fovea_core::units::ScreenPoint;
use fovea_render::bvh::{Hit, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{PolarRay, TraceExecutor};
use fovea_render::scene::Light;
use fovea_render::trace::GSample;
use fovea_render::world::World;

use super::times::{GpuTraceMs, Slot};
use crate::ray_generation::GeneratedHit;
use crate::{
    DirectLightModel, GpuEnvironment, GpuLight, GpuPolarRay, GpuRay, GpuScreenRay, GpuSurface,
    GpuSurfaceRay, GpuSurfaces, GpuTracer, RayGenCamera,
};

/// The trace executor of one world (its triangles' fingerprint).
#[derive(Clone)]
pub struct GpuTraceExecutor {
    pub(crate) gpu: Arc<GpuTracer>,
    /// The world's surfaces on the device (`None`: interpolated on the CPU).
    pub(crate) surfaces: Option<Arc<GpuSurfaces>>,
    /// Why they are not (the device could not hold them).
    pub(crate) no_surfaces: Option<String>,
    pub(crate) fingerprint: u64,
    /// The world's environment on the device.
    pub(crate) environment: Arc<GpuEnvironment>,
    /// The primary rays' times.
    pub(crate) times: Slot<GpuTraceMs>,
    /// The shadow rays' times.
    pub(crate) shadow_times: Slot<GpuTraceMs>,
    /// The direct-light passes' times.
    pub(crate) direct_times: Slot<GpuTraceMs>,
    /// The environment-light passes' times.
    pub(crate) environment_times: Slot<GpuTraceMs>,
}

/// `camera` as the ray-generation shader reads it, screen points measured from `origin_px`.
fn ray_gen_camera(camera: &EyeCamera, origin_px: [f64; 2]) -> RayGenCamera {
    RayGenCamera::new(
        camera.position.into(),
        [camera.forward.into(), camera.right.into(), camera.up.into()],
        camera.focal_px(),
        camera.principal_point_px(),
        origin_px,
    )
}

/// The rays in the GPU's layout.
fn gpu_rays(rays: &[Ray]) -> Vec<GpuRay> {
    rays.iter()
        .map(|r| GpuRay {
            origin: r.origin.into(),
            t_min: r.t_min,
            dir: r.dir.into(),
            t_max: r.t_max,
        })
        .collect()
}

/// A GPU hit in the renderer's type.
fn hit(h: crate::GpuHit) -> Hit {
    Hit {
        t: h.t,
        tri: h.tri,
        bary: Vec2::from(h.bary),
    }
}

/// The generated rays' directions and hits in the renderer's types.
fn generated_hits(out: Vec<GeneratedHit>) -> Vec<(Vec3, Option<Hit>)> {
    out.into_iter()
        .map(|(dir, h)| (Vec3::from(dir), h.map(hit)))
        .collect()
}

impl GpuTraceExecutor {
    /// The surface pass over `rays` (polar around `origin_px`, or screen points from the
    /// screen's origin).
    fn surfaces_of(
        &mut self,
        camera: &EyeCamera,
        origin_px: [f64; 2],
        rays: Vec<GpuSurfaceRay>,
        polar: bool,
    ) -> Result<Vec<GSample>, String> {
        let surfaces = self.surfaces.as_ref().ok_or("no surfaces on the GPU")?;
        let cam = ray_gen_camera(camera, origin_px);
        let run = if polar {
            GpuTracer::surfaces_polar_timed
        } else {
            GpuTracer::surfaces_screen_timed
        };
        let (out, t) = run(&self.gpu, surfaces, &cam, &rays).map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.times, t);
        Ok(out)
    }
}

impl TraceExecutor for GpuTraceExecutor {
    fn backend(&self) -> &str {
        "gpu"
    }

    fn serves(&self, world: &World) -> bool {
        world.tris_fingerprint == self.fingerprint
    }

    fn closest_hits(&mut self, rays: &[Ray]) -> Result<Vec<Option<Hit>>, String> {
        let (hits, t) = self
            .gpu
            .closest_hits_timed(&gpu_rays(rays))
            .map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.times, t);
        Ok(hits.into_iter().map(|h| h.map(hit)).collect())
    }

    fn occluded(&mut self, rays: &[Ray]) -> Result<Vec<bool>, String> {
        let (blocked, t) = self
            .gpu
            .occluded_timed(&gpu_rays(rays))
            .map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.shadow_times, t);
        Ok(blocked)
    }

    fn generates_rays(&self) -> bool {
        true
    }

    fn closest_hits_polar(
        &mut self,
        camera: &EyeCamera,
        centre: ScreenPoint,
        rays: &[PolarRay],
    ) -> Result<Vec<(Vec3, Option<Hit>)>, String> {
        let cam = ray_gen_camera(camera, [centre.x_px, centre.y_px]);
        let polar = rays
            .iter()
            .map(|r| GpuPolarRay::new(r.r_px, r.turn))
            .collect::<crate::Result<Vec<_>>>()
            .map_err(|e| e.to_string())?;
        let (out, t) = self
            .gpu
            .closest_hits_polar_timed(&cam, &polar)
            .map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.times, t);
        Ok(generated_hits(out))
    }

    fn closest_hits_screen(
        &mut self,
        camera: &EyeCamera,
        points: &[ScreenPoint],
    ) -> Result<Vec<(Vec3, Option<Hit>)>, String> {
        let cam = ray_gen_camera(camera, [0.0, 0.0]);
        // Rounded to f32 as `EyeCamera::ray` rounds them.
        let screen: Vec<GpuScreenRay> = points
            .iter()
            .map(|p| GpuScreenRay {
                x_px: p.x_px as f32,
                y_px: p.y_px as f32,
            })
            .collect();
        let (out, t) = self
            .gpu
            .closest_hits_screen_timed(&cam, &screen)
            .map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.times, t);
        Ok(generated_hits(out))
    }

    fn interpolates_surfaces(&self) -> bool {
        self.surfaces.is_some()
    }

    fn why_no_surfaces(&self) -> Option<String> {
        self.no_surfaces.clone()
    }

    fn surfaces_polar(
        &mut self,
        camera: &EyeCamera,
        centre: ScreenPoint,
        rays: &[PolarRay],
        spreads: &[f32],
    ) -> Result<Vec<GSample>, String> {
        let rays = rays
            .iter()
            .zip(spreads)
            .map(|(r, &spread)| GpuSurfaceRay::polar(r.r_px, r.turn, spread))
            .collect::<crate::Result<Vec<_>>>()
            .map_err(|e| e.to_string())?;
        self.surfaces_of(camera, [centre.x_px, centre.y_px], rays, true)
    }

    fn surfaces_screen(
        &mut self,
        camera: &EyeCamera,
        points: &[ScreenPoint],
        spreads: &[f32],
    ) -> Result<Vec<GSample>, String> {
        let rays = points
            .iter()
            .zip(spreads)
            .map(|(p, &spread)| GpuSurfaceRay::screen(p.x_px, p.y_px, spread))
            .collect();
        self.surfaces_of(camera, [0.0, 0.0], rays, false)
    }

    fn shades_direct_light(&self) -> bool {
        true
    }

    fn direct_light(
        &mut self,
        hits: &[&GSample],
        lights: &[Light],
    ) -> Result<Vec<(Vec3, u32)>, String> {
        let surfaces: Vec<GpuSurface> = hits.iter().map(|g| GpuSurface::of(g)).collect();
        let lights: Vec<GpuLight> = lights.iter().map(GpuLight::of).collect();
        let (out, t) = self
            .gpu
            .direct_light_timed(&surfaces, &lights, &DirectLightModel::RENDERER)
            .map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.direct_times, t);
        Ok(out
            .into_iter()
            .map(|d| (Vec3::from(d.radiance), d.shadow_rays))
            .collect())
    }

    fn shades_environment(&self) -> bool {
        true
    }

    fn environment_light(
        &mut self,
        hits: &[&GSample],
        keys: &[u64],
        samples: u32,
    ) -> Result<Vec<(Vec3, u32)>, String> {
        if keys.len() != hits.len() {
            return Err(format!(
                "{} keys for {} surface samples",
                keys.len(),
                hits.len()
            ));
        }
        let surfaces: Vec<GpuSurface> = hits
            .iter()
            .zip(keys)
            .map(|(g, &k)| GpuSurface::keyed(g, k))
            .collect();
        let (out, t) = self
            .gpu
            .environment_light_timed(&surfaces, &self.environment, samples)
            .map_err(|e| e.to_string())?;
        GpuTraceMs::add_to(&self.environment_times, t);
        Ok(out
            .into_iter()
            .map(|e| (Vec3::from(e.radiance), e.rays))
            .collect())
    }
}
