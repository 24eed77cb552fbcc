//! The staged `--backend gpu` path for the examples that compare the resident frame with it:
//! the GPU's passes lent to the CPU pipeline one call at a time, as `fovea render --backend
//! gpu` runs them (the CLI's executors, crates/fovea-cli/src/backend.rs, are not reachable
//! from fovea-gpu's examples, so the same per-call fovea-gpu passes are wrapped here):
//! ray generation, trace, surfaces, direct and environment light ([`Staged`] as the
//! `TraceExecutor`), sample-space AA ([`StagedAa`]), the polar reconstruction
//! ([`StagedReconstruct`]); the tone map is `GpuToneMap::to_srgb8`, called by the example.

#![allow(dead_code)]

use fovea_core::units::ScreenPoint;
use fovea_gpu::{
    DirectLightModel, GpuEnvironment, GpuLight, GpuPolarRay, GpuRay, GpuReconstructor, GpuSampleAa,
    GpuScreenRay, GpuSurface, GpuSurfaceRay, GpuSurfaces, GpuTracer, RayGenCamera, SampleFilter,
};
use fovea_render::bvh::{Hit, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{AaExecutor, AaMode, PolarRay, ReconstructExecutor, TraceExecutor};
use fovea_render::scene::Light;
use fovea_render::trace::GSample;
use fovea_render::world::World;
use glam::{Vec2, Vec3};

/// The staged path: `GpuTracer`'s passes lent to the CPU pipeline one call at a time.
pub struct Staged {
    pub gpu: GpuTracer,
    pub surfaces: GpuSurfaces,
    pub environment: GpuEnvironment,
    pub fingerprint: u64,
}

fn ray_gen(camera: &EyeCamera, origin: [f64; 2]) -> RayGenCamera {
    RayGenCamera::new(
        camera.position.into(),
        [camera.forward.into(), camera.right.into(), camera.up.into()],
        camera.focal_px(),
        camera.principal_point_px(),
        origin,
    )
}

fn generated(out: Vec<([f32; 3], Option<fovea_gpu::GpuHit>)>) -> Vec<(Vec3, Option<Hit>)> {
    out.into_iter()
        .map(|(d, h)| {
            (
                Vec3::from(d),
                h.map(|h| Hit {
                    t: h.t,
                    tri: h.tri,
                    bary: Vec2::from(h.bary),
                }),
            )
        })
        .collect()
}

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

impl TraceExecutor for Staged {
    fn backend(&self) -> &str {
        "gpu (staged)"
    }
    fn serves(&self, world: &World) -> bool {
        world.tris_fingerprint == self.fingerprint
    }
    fn closest_hits(&mut self, rays: &[Ray]) -> Result<Vec<Option<Hit>>, String> {
        let hits = self
            .gpu
            .closest_hits(&gpu_rays(rays))
            .map_err(|e| e.to_string())?;
        Ok(hits
            .into_iter()
            .map(|h| {
                h.map(|h| Hit {
                    t: h.t,
                    tri: h.tri,
                    bary: Vec2::from(h.bary),
                })
            })
            .collect())
    }
    fn occluded(&mut self, rays: &[Ray]) -> Result<Vec<bool>, String> {
        self.gpu
            .occluded(&gpu_rays(rays))
            .map_err(|e| e.to_string())
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
        let polar: Vec<GpuPolarRay> = rays
            .iter()
            .map(|r| GpuPolarRay {
                r_px: r.r_px as f32,
                turn: r.turn as f32,
            })
            .collect();
        let cam = ray_gen(camera, [centre.x_px, centre.y_px]);
        let (out, _) = self
            .gpu
            .closest_hits_polar_timed(&cam, &polar)
            .map_err(|e| e.to_string())?;
        Ok(generated(out))
    }
    fn closest_hits_screen(
        &mut self,
        camera: &EyeCamera,
        points: &[ScreenPoint],
    ) -> Result<Vec<(Vec3, Option<Hit>)>, String> {
        let screen: Vec<GpuScreenRay> = points
            .iter()
            .map(|p| GpuScreenRay {
                x_px: p.x_px as f32,
                y_px: p.y_px as f32,
            })
            .collect();
        let (out, _) = self
            .gpu
            .closest_hits_screen_timed(&ray_gen(camera, [0.0, 0.0]), &screen)
            .map_err(|e| e.to_string())?;
        Ok(generated(out))
    }
    fn interpolates_surfaces(&self) -> bool {
        true
    }
    fn surfaces_polar(
        &mut self,
        camera: &EyeCamera,
        centre: ScreenPoint,
        rays: &[PolarRay],
        spreads: &[f32],
    ) -> Result<Vec<GSample>, String> {
        let rays: Vec<GpuSurfaceRay> = rays
            .iter()
            .zip(spreads)
            .map(|(r, &spread)| GpuSurfaceRay {
                a: r.r_px as f32,
                b: r.turn as f32,
                spread,
            })
            .collect();
        let cam = ray_gen(camera, [centre.x_px, centre.y_px]);
        let (out, _) = self
            .gpu
            .surfaces_polar_timed(&self.surfaces, &cam, &rays)
            .map_err(|e| e.to_string())?;
        Ok(out)
    }
    fn surfaces_screen(
        &mut self,
        camera: &EyeCamera,
        points: &[ScreenPoint],
        spreads: &[f32],
    ) -> Result<Vec<GSample>, String> {
        let rays: Vec<GpuSurfaceRay> = points
            .iter()
            .zip(spreads)
            .map(|(p, &spread)| GpuSurfaceRay {
                a: p.x_px as f32,
                b: p.y_px as f32,
                spread,
            })
            .collect();
        let (out, _) = self
            .gpu
            .surfaces_screen_timed(&self.surfaces, &ray_gen(camera, [0.0, 0.0]), &rays)
            .map_err(|e| e.to_string())?;
        Ok(out)
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
        let (out, _) = self
            .gpu
            .direct_light_timed(&surfaces, &lights, &DirectLightModel::RENDERER)
            .map_err(|e| e.to_string())?;
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
        let surfaces: Vec<GpuSurface> = hits
            .iter()
            .zip(keys)
            .map(|(g, &k)| GpuSurface::keyed(g, k))
            .collect();
        let (out, _) = self
            .gpu
            .environment_light_timed(&surfaces, &self.environment, samples)
            .map_err(|e| e.to_string())?;
        Ok(out
            .into_iter()
            .map(|e| (Vec3::from(e.radiance), e.rays))
            .collect())
    }
}

/// `GpuSampleAa::run` as the pipeline's AA executor (one call, its own upload and readback,
/// per layer).
pub struct StagedAa(pub GpuSampleAa);

impl AaExecutor for StagedAa {
    fn backend(&self) -> &str {
        "gpu (staged)"
    }
    fn supports(&self, mode: AaMode, grid: &fovea_post::grid::Grid) -> bool {
        matches!(mode, AaMode::Fxaa | AaMode::Gaussian) && self.0.fits(grid)
    }
    fn anti_alias(
        &mut self,
        mode: AaMode,
        params: &fovea_post::fxaa::FxaaParams,
        grid: &fovea_post::grid::Grid,
        color: &fovea_core::Image<fovea_post::Rgb>,
    ) -> Result<fovea_core::Image<fovea_post::Rgb>, String> {
        let filter = match mode {
            AaMode::Fxaa => SampleFilter::Fxaa(*params),
            AaMode::Gaussian => SampleFilter::Gaussian,
            other => return Err(format!("AA mode {other:?} is not a filter")),
        };
        let (out, _) = self.0.run(color, grid, filter).map_err(|e| e.to_string())?;
        Ok(out)
    }
}

/// `GpuReconstructor::reconstruct_into` as the pipeline's reconstruction executor.
pub struct StagedReconstruct(pub GpuReconstructor);

impl ReconstructExecutor for StagedReconstruct {
    fn backend(&self) -> &str {
        "gpu (staged)"
    }
    fn supports(&self, mapping: &dyn fovea_core::mapping::FoveationMapping) -> bool {
        GpuReconstructor::supports(mapping) && self.0.fits(mapping)
    }
    fn reconstruct_into(
        &mut self,
        mapping: &dyn fovea_core::mapping::FoveationMapping,
        display: &fovea_core::display::DisplayProfile,
        samples: &fovea_post::inverse_map::SampleBuffers,
        filter: fovea_post::inverse_map::ReconstructFilter,
        color: &mut fovea_core::Image<fovea_post::Rgb>,
        depth: &mut fovea_core::Image<f32>,
    ) -> Result<(), String> {
        self.0
            .reconstruct_into(mapping, display, samples, filter, color, depth)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}
