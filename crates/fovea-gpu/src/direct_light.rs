//! Direct light on the GPU (`shaders/direct_light.wgsl`, part of the trace module): for a
//! batch of surface samples, the renderer's shading model — every light's BRDF-weighted
//! radiance behind an unoccluded shadow ray, `fovea_render::shade::direct` — with the shadow
//! rays cast through the tracer's BVH in the same invocation, so the G-buffer goes up once and
//! one colour per sample comes back instead of one ray and one answer per light.
//!
//! The renderer's records and lights become [`GpuSurface`] and [`GpuLight`] here
//! ([`GpuSurface::of`], [`GpuLight::of`]), and [`DirectLightModel::RENDERER`] holds
//! `fovea_render::shade::constants`, so the shader derives none of the model's numbers.

use bytemuck::{Pod, Zeroable};
use fovea_render::scene::Light;
use fovea_render::shade::constants as model;
use fovea_render::trace::GSample;

use crate::error::{GpuError, Result};
use crate::trace::{
    DirectLightModel, GpuTracer, ScenePass, TraceTimes, TraceUniform, MAX_DISTANCE,
};
use crate::transfer::batch_len;

impl DirectLightModel {
    /// The renderer's model (`fovea_render::shade::constants`).
    pub const RENDERER: DirectLightModel = DirectLightModel {
        pi: std::f32::consts::PI,
        offset_per_t: model::SHADOW_OFFSET_PER_T,
        offset_t_cap: model::SHADOW_OFFSET_T_CAP,
        shadow_shorten: model::SHADOW_SHORTEN,
        min_light_distance: model::MIN_LIGHT_DISTANCE,
        spot_min_width: model::SPOT_MIN_WIDTH,
        min_nv: model::MIN_NV,
        d_floor: model::GGX_D_FLOOR,
        vis_floor: model::VIS_FLOOR,
    };
}

/// A surface sample as `direct_light.wgsl` and `environment_light.wgsl` read it (`Surface`):
/// the renderer's G-buffer record less what they do not read, and the sample's key.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSurface {
    /// Hit position, world space.
    pub position: [f32; 3],
    /// Distance along the primary ray.
    pub t: f32,
    /// Shading normal.
    pub normal: [f32; 3],
    /// Metalness.
    pub metallic: f32,
    /// Geometric normal.
    pub face_normal: [f32; 3],
    /// Perceptual roughness.
    pub roughness: f32,
    /// Unit vector towards the eye.
    pub to_eye: [f32; 3],
    /// The low word of the sample's key (`fovea_render::shade::texel_key`: the seed of the
    /// environment light's random numbers, [`crate::environment_light`]).
    pub key_lo: u32,
    /// Base colour, linear RGB.
    pub albedo: [f32; 3],
    /// The key's high word.
    pub key_hi: u32,
    /// Dielectric specular reflectance at normal incidence.
    pub specular: [f32; 3],
    /// Padding.
    pub pad2: f32,
}

/// A light as `direct_light.wgsl` reads it (`Light`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// World position (point, spot).
    pub position: [f32; 3],
    /// [`GpuLight::POINT`], [`GpuLight::SPOT`] or [`GpuLight::DIRECTIONAL`].
    pub kind: u32,
    /// Unit direction the spot points to, or the directional light travels along.
    pub direction: [f32; 3],
    /// Range beyond which the light is ignored (made finite on upload).
    pub range: f32,
    /// Radiant intensity (point, spot) or irradiance (directional).
    pub intensity: [f32; 3],
    /// Cosine of a spot's inner cone.
    pub cos_inner: f32,
    /// Cosine of a spot's outer cone.
    pub cos_outer: f32,
    /// Padding.
    pub pad: [f32; 3],
}

impl GpuSurface {
    /// The renderer's G-buffer record `g` (a hit).
    pub fn of(g: &GSample) -> Self {
        Self {
            position: g.position.to_array(),
            t: g.t,
            normal: g.normal.to_array(),
            metallic: g.metallic,
            face_normal: g.face_normal.to_array(),
            roughness: g.roughness,
            to_eye: g.to_eye.to_array(),
            albedo: g.albedo.to_array(),
            specular: g.specular.to_array(),
            ..Self::default()
        }
    }

    /// The record `g` with its key (the environment light's seed).
    pub fn keyed(g: &GSample, key: u64) -> Self {
        Self {
            key_lo: key as u32,
            key_hi: (key >> 32) as u32,
            ..Self::of(g)
        }
    }

    /// The key.
    pub fn key(&self) -> u64 {
        u64::from(self.key_lo) | (u64::from(self.key_hi) << 32)
    }

    /// Whether every float field is finite (WGSL may assume it).
    pub fn is_finite(&self) -> bool {
        [
            self.position,
            self.normal,
            self.face_normal,
            self.to_eye,
            self.albedo,
            self.specular,
        ]
        .iter()
        .flatten()
        .chain([&self.t, &self.metallic, &self.roughness, &self.pad2])
        .all(|v| v.is_finite())
    }
}

impl GpuLight {
    /// The renderer's light `l`.
    pub fn of(l: &Light) -> Self {
        match *l {
            Light::Point {
                position,
                intensity,
                range,
            } => Self {
                position: position.to_array(),
                kind: Self::POINT,
                intensity: intensity.to_array(),
                range,
                ..Self::default()
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
                range,
            } => Self {
                position: position.to_array(),
                kind: Self::SPOT,
                direction: direction.to_array(),
                range,
                intensity: intensity.to_array(),
                cos_inner,
                cos_outer,
                ..Self::default()
            },
            Light::Directional {
                direction,
                irradiance,
            } => Self {
                kind: Self::DIRECTIONAL,
                direction: direction.to_array(),
                intensity: irradiance.to_array(),
                ..Self::default()
            },
        }
    }

    /// `kind` of an isotropic point light.
    pub const POINT: u32 = 0;
    /// `kind` of a spot light.
    pub const SPOT: u32 = 1;
    /// `kind` of a directional light.
    pub const DIRECTIONAL: u32 = 2;
}

/// The direct light of one sample, and the shadow rays it cast (one per light that faces it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectLight {
    /// Radiance, linear RGB.
    pub radiance: [f32; 3],
    /// Shadow rays cast.
    pub shadow_rays: u32,
}

const SURFACE_BYTES: u64 = std::mem::size_of::<GpuSurface>() as u64;
const OUT_BYTES: u64 = 16;

impl GpuTracer {
    /// Direct light from `lights` at every surface sample (module header), and where its time
    /// went. Non-finite samples or lights are refused (`GpuError::Input`), as WGSL may assume
    /// none.
    pub fn direct_light_timed(
        &self,
        surfaces: &[GpuSurface],
        lights: &[GpuLight],
        model: &DirectLightModel,
    ) -> Result<(Vec<DirectLight>, TraceTimes)> {
        let t = std::time::Instant::now();
        let mut times = TraceTimes::default();
        let dark = DirectLight {
            radiance: [0.0; 3],
            shadow_rays: 0,
        };
        if let Some(k) = surfaces.iter().position(|s| !s.is_finite()) {
            return Err(GpuError::Input(format!(
                "surface sample {k} has a non-finite field"
            )));
        }
        let lights: Vec<GpuLight> = lights
            .iter()
            .map(|l| GpuLight {
                range: l.range.min(MAX_DISTANCE),
                ..*l
            })
            .collect();
        if let Some(k) = lights.iter().position(|l| {
            [l.position, l.direction, l.intensity]
                .iter()
                .flatten()
                .chain([&l.cos_inner, &l.cos_outer, &l.range])
                .any(|v| !v.is_finite())
        }) {
            return Err(GpuError::Input(format!("light {k} has a non-finite field")));
        }
        let (Some(scene), false, false) = (&self.scene, lights.is_empty(), surfaces.is_empty())
        else {
            // No triangles still lets lights shine; no lights or samples: nothing to do.
            if self.scene.is_none() && !lights.is_empty() && !surfaces.is_empty() {
                return Err(GpuError::Input(
                    "direct light needs a scene with triangles on the GPU".into(),
                ));
            }
            times.total_ms = t.elapsed().as_secs_f64() * 1e3;
            return Ok((vec![dark; surfaces.len()], times));
        };
        let ctx = &self.ctx;
        let light_bytes = std::mem::size_of_val(lights.as_slice()) as u64;
        ctx.check_storage_binding("the lights", light_bytes)?;
        let batch = batch_len(ctx, SURFACE_BYTES.max(OUT_BYTES));
        let mut out = Vec::with_capacity(surfaces.len());
        for chunk in surfaces.chunks(batch) {
            let what = format!(
                "shading {} surface samples with {} lights",
                chunk.len(),
                lights.len()
            );
            ctx.check_storage_binding(&what, chunk.len() as u64 * SURFACE_BYTES)?;
            let block = TraceUniform::new(chunk.len(), lights.len(), *model);
            let storage = wgpu::BufferUsages::STORAGE;
            let (raw, ms) = self.run_scene_pass(
                scene,
                &scene.direct,
                ScenePass {
                    what: &what,
                    block,
                    inputs: &[
                        (6, bytemuck::cast_slice(chunk), storage),
                        (7, bytemuck::cast_slice(&lights), storage),
                    ],
                    resident: &[],
                    items: chunk.len(),
                    out_bytes: OUT_BYTES,
                },
            )?;
            times.add_batch(ms);
            out.extend(
                bytemuck::cast_slice::<u32, [f32; 4]>(&raw)
                    .iter()
                    .take(chunk.len())
                    .map(|v| DirectLight {
                        radiance: [v[0], v[1], v[2]],
                        shadow_rays: v[3] as u32,
                    }),
            );
        }
        times.total_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((out, times))
    }
}
