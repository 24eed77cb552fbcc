//! The environment light on the GPU (`shaders/environment_light.wgsl`, part of the trace
//! module): for a batch of surface samples, the renderer's Monte-Carlo estimator of the
//! environment's light — `fovea_render::shade::environment_light` with
//! `EnvLight::Occluded { samples }`: multiple importance sampling by the balance heuristic
//! (Veach and Guibas 1995, Eq. 7–8) over the BRDF mixture (cosine and GGX half-vector
//! sampling, Walter et al. 2007 Eq. 35–36) and, for a map, the map's importance sampling
//! (pbrt-v4 `PiecewiseConstant2D`, luminance × solid angle), each ray's any-hit shadow ray to
//! infinity cast through the tracer's BVH in the same invocation.
//!
//! The same random numbers as the CPU: the sample's key ([`GpuSurface::keyed`]) seeds
//! SplitMix64 (`fovea_core::math::mix64`, emulated bit for bit with u32 pairs; checked by
//! [`GpuTracer::mix64`]), which gives the tile's Cranley-Patterson shifts of the R2 sequence
//! (Roberts 2018), walked from the texel's rank. [`GpuEnvironment`] holds the environment on
//! the device: a constant, or a map's pixels and its sampling tables exactly as
//! `fovea_render::scene::EnvMap` built them (the conditional and marginal CDFs, bin values and
//! integrals, the rows' edge cosines). Every constant of the estimator (the hash's, the salt,
//! the R2 steps in 0.64 fixed point, the floors, the tables' offsets) is uploaded from
//! `fovea_render` and `fovea_core` ([`EnvUniform`]); the shader derives none.
//!
//! The result differs from the CPU's only by f32 rounding (the GPU's `sin`, `acos`, fused
//! multiply-adds) and where such a difference flips a shadow ray's occlusion at a grazing
//! edge, or moves an R2 point across a sampling decision (`tests/environment_light.rs`
//! measures both).

use bytemuck::{Pod, Zeroable};
use fovea_core::math::mix64_constants;
use fovea_render::scene::Environment;
use fovea_render::shade::env_constants as model;

use crate::device::GpuContext;
use crate::direct_light::GpuSurface;
use crate::error::{GpuError, Result};
use crate::trace::{DirectLightModel, GpuTracer, ScenePass, TraceTimes, TraceUniform, SHADER};
use crate::transfer::{batch_len, run_1d_at, upload};

/// `EnvParams` of `environment_light.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct EnvUniform {
    pub(crate) samples: u32,
    pub(crate) n_map: u32,
    pub(crate) n_brdf: u32,
    pub(crate) kind: u32,
    pub(crate) salt: [u32; 2],
    pub(crate) mix_increment: [u32; 2],
    pub(crate) mix_mul0: [u32; 2],
    pub(crate) mix_mul1: [u32; 2],
    pub(crate) mix_shifts: [u32; 4],
    pub(crate) r2_a1: [u32; 2],
    pub(crate) r2_a2: [u32; 2],
    pub(crate) r2_half: [u32; 2],
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) luminance: [f32; 4],
    pub(crate) constant: [f32; 4],
    pub(crate) map_from_world: [[f32; 4]; 3],
    pub(crate) world_from_map: [[f32; 4]; 3],
    pub(crate) tau: f32,
    pub(crate) below_one: f32,
    pub(crate) x_max: f32,
    pub(crate) turns_per_rad: f32,
    pub(crate) off_marginal_cdf: u32,
    pub(crate) off_marginal_func: u32,
    pub(crate) off_cond_cdf: u32,
    pub(crate) off_cond_func: u32,
    pub(crate) off_cond_int: u32,
    pub(crate) off_cos_edge: u32,
    pub(crate) marginal_int: f32,
    /// The shading key's frame field in its high word (`fovea_render::shade::frame_noise`).
    pub(crate) frame_mask_hi: u32,
}

/// `kind` of a constant environment.
const ENV_CONSTANT: u32 = 0;
/// `kind` of a map.
const ENV_MAP: u32 = 1;

/// A u64 as the shader's `vec2<u32>` (low word first).
fn words(v: u64) -> [u32; 2] {
    [v as u32, (v >> 32) as u32]
}

/// `a ∈ [0, 1)` in 0.64 fixed point, exactly (an f64 below 1 has no bits below 2⁻⁶⁴ unless it
/// is below 2⁻¹¹, and those are dropped).
fn fixed64(a: f64) -> [u32; 2] {
    words((a * 18_446_744_073_709_551_616.0) as u64)
}

/// A matrix column as a WGSL `mat3x3` column (16 bytes).
fn column(c: [f32; 3]) -> [f32; 4] {
    [c[0], c[1], c[2], 0.0]
}

/// The environment on the device: [`EnvUniform`] less the per-call ray counts, the map's
/// pixels and its sampling tables.
pub struct GpuEnvironment {
    block: EnvUniform,
    /// Whether no direction carries radiance (no rays are cast).
    black: bool,
    pub(crate) pixels: wgpu::Buffer,
    pub(crate) tables: wgpu::Buffer,
}

impl GpuEnvironment {
    /// Uploads `env` (a constant, or a map with its sampling tables). Errors when a table is
    /// larger than the adapter binds.
    pub fn new(ctx: &GpuContext, env: &Environment) -> Result<Self> {
        let mut block = constants();
        let (pixels, tables): (Vec<f32>, Vec<f32>) = match env {
            Environment::Constant(v) => {
                block.kind = ENV_CONSTANT;
                block.constant = [v.x, v.y, v.z, 1.0];
                (vec![0.0], vec![0.0])
            }
            Environment::Map(m) => {
                block.kind = ENV_MAP;
                block.width = m.width();
                block.height = m.height();
                block.constant = [0.0, 0.0, 0.0, m.scale()];
                let (mw, wm) = (m.map_from_world(), m.world_from_map());
                block.map_from_world =
                    [mw.x_axis, mw.y_axis, mw.z_axis].map(|c| column(c.to_array()));
                block.world_from_map =
                    [wm.x_axis, wm.y_axis, wm.z_axis].map(|c| column(c.to_array()));
                let pixels: Vec<f32> = m.pixels().iter().flat_map(|p| p.to_array()).collect();
                let d = m.distribution();
                let mut tables = Vec::new();
                let at = |tables: &mut Vec<f32>, part: &[f32]| {
                    let off = tables.len() as u32;
                    tables.extend_from_slice(part);
                    off
                };
                block.off_marginal_cdf = at(&mut tables, d.marginal().cdf());
                block.off_marginal_func = at(&mut tables, d.marginal().values());
                block.marginal_int = d.marginal().integral();
                block.off_cond_cdf = tables.len() as u32;
                for c in d.conditionals() {
                    tables.extend_from_slice(c.cdf());
                }
                block.off_cond_func = tables.len() as u32;
                for c in d.conditionals() {
                    tables.extend_from_slice(c.values());
                }
                let ints: Vec<f32> = d.conditionals().iter().map(|c| c.integral()).collect();
                block.off_cond_int = at(&mut tables, &ints);
                block.off_cos_edge = at(&mut tables, m.cos_edges());
                (pixels, tables)
            }
        };
        if !(pixels.iter().chain(&tables).all(|v| v.is_finite())
            && block.constant.iter().all(|v| v.is_finite()))
        {
            return Err(GpuError::Input(
                "the environment has a non-finite value".into(),
            ));
        }
        let bytes = |v: &[f32]| std::mem::size_of_val(v) as u64;
        ctx.check_storage_binding("the environment map's pixels", bytes(&pixels))?;
        ctx.check_storage_binding("the environment map's sampling tables", bytes(&tables))?;
        if tables.len() > u32::MAX as usize {
            return Err(GpuError::Input(
                "the environment map's sampling tables exceed 2^32 entries".into(),
            ));
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let (pixels, tables) = ctx.scoped("uploading the environment", || {
            (
                upload(
                    ctx,
                    "environment pixels",
                    bytemuck::cast_slice(&pixels),
                    storage,
                ),
                upload(
                    ctx,
                    "environment tables",
                    bytemuck::cast_slice(&tables),
                    storage,
                ),
            )
        })?;
        Ok(Self {
            block,
            black: env.is_black(),
            pixels,
            tables,
        })
    }
}

impl GpuEnvironment {
    /// The block of a call with `samples` rays per sample (none for a black environment): of
    /// them ⌈samples/2⌉ from a map's importance sampling, the rest from the BRDF's.
    pub(crate) fn uniform(&self, samples: u32) -> EnvUniform {
        let samples = if self.black { 0 } else { samples };
        let n_map = if self.block.kind == ENV_MAP {
            samples.div_ceil(2)
        } else {
            0
        };
        EnvUniform {
            samples,
            n_map,
            n_brdf: samples - n_map,
            ..self.block
        }
    }
}

/// The model's part of [`EnvUniform`]: the hash's and the estimator's constants.
fn constants() -> EnvUniform {
    let [inc, m0, m1] = [
        mix64_constants::INCREMENT,
        mix64_constants::MULTIPLIERS[0],
        mix64_constants::MULTIPLIERS[1],
    ]
    .map(words);
    let [s0, s1, s2] = mix64_constants::SHIFTS;
    EnvUniform {
        salt: words(model::ENV_SALT),
        mix_increment: inc,
        mix_mul0: m0,
        mix_mul1: m1,
        mix_shifts: [s0, s1, s2, model::RANDOM_BITS],
        r2_a1: fixed64(model::R2_ALPHAS[0]),
        r2_a2: fixed64(model::R2_ALPHAS[1]),
        r2_half: fixed64(0.5),
        luminance: [
            model::LUMINANCE[0],
            model::LUMINANCE[1],
            model::LUMINANCE[2],
            model::GGX_A2_FLOOR,
        ],
        tau: std::f32::consts::TAU,
        turns_per_rad: 1.0 / std::f32::consts::TAU,
        below_one: model::BELOW_ONE,
        x_max: fovea_render::scene::environment::distribution::Distribution1D::X_MAX,
        frame_mask_hi: (fovea_render::shade::frame_noise::FRAME_MASK >> 32) as u32,
        ..EnvUniform::zeroed()
    }
}

/// The environment light of one sample, and the rays it cast.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// Radiance, linear RGB.
    pub radiance: [f32; 3],
    /// Environment (shadow) rays cast.
    pub rays: u32,
}

const SURFACE_BYTES: u64 = std::mem::size_of::<GpuSurface>() as u64;
const OUT_BYTES: u64 = 16;

impl GpuTracer {
    /// The environment's light at every surface sample with `samples` rays each (module
    /// header; each surface's key seeds its random numbers, [`GpuSurface::keyed`]), and where
    /// its time went. Non-finite samples are refused (`GpuError::Input`), as WGSL may assume
    /// none; more than `fovea_render::shade::MAX_ENV_SAMPLES` rays too.
    pub fn environment_light_timed(
        &self,
        surfaces: &[GpuSurface],
        env: &GpuEnvironment,
        samples: u32,
    ) -> Result<(Vec<EnvironmentLight>, TraceTimes)> {
        let t = std::time::Instant::now();
        let mut times = TraceTimes::default();
        if samples > fovea_render::shade::MAX_ENV_SAMPLES {
            return Err(GpuError::Input(format!(
                "{samples} environment rays per sample (at most {})",
                fovea_render::shade::MAX_ENV_SAMPLES
            )));
        }
        if let Some(k) = surfaces.iter().position(|s| !s.is_finite()) {
            return Err(GpuError::Input(format!(
                "surface sample {k} has a non-finite field"
            )));
        }
        let dark = EnvironmentLight {
            radiance: [0.0; 3],
            rays: 0,
        };
        let Some(scene) = self.scene.as_ref().filter(|_| !env.black && samples > 0) else {
            if self.scene.is_none() && !env.black && samples > 0 && !surfaces.is_empty() {
                return Err(GpuError::Input(
                    "the environment light needs a scene with triangles on the GPU".into(),
                ));
            }
            times.total_ms = t.elapsed().as_secs_f64() * 1e3;
            return Ok((vec![dark; surfaces.len()], times));
        };
        let n_map = if env.block.kind == ENV_MAP {
            samples.div_ceil(2)
        } else {
            0
        };
        let block = EnvUniform {
            samples,
            n_map,
            n_brdf: samples - n_map,
            ..env.block
        };
        let batch = batch_len(&self.ctx, SURFACE_BYTES.max(OUT_BYTES));
        let mut out = Vec::with_capacity(surfaces.len());
        for chunk in surfaces.chunks(batch) {
            let what = format!(
                "the environment light of {} surface samples, {samples} rays each",
                chunk.len()
            );
            self.ctx
                .check_storage_binding(&what, chunk.len() as u64 * SURFACE_BYTES)?;
            let (raw, ms) = self.run_scene_pass(
                scene,
                &scene.environment,
                ScenePass {
                    what: &what,
                    block: TraceUniform::new(chunk.len(), 0, DirectLightModel::RENDERER),
                    inputs: &[
                        (6, bytemuck::cast_slice(chunk), wgpu::BufferUsages::STORAGE),
                        (16, bytemuck::bytes_of(&block), wgpu::BufferUsages::UNIFORM),
                    ],
                    resident: &[(17, &env.pixels), (18, &env.tables)],
                    items: chunk.len(),
                    out_bytes: OUT_BYTES,
                },
            )?;
            times.add_batch(ms);
            out.extend(
                bytemuck::cast_slice::<u32, [f32; 4]>(&raw)
                    .iter()
                    .take(chunk.len())
                    .map(|v| EnvironmentLight {
                        radiance: [v[0], v[1], v[2]],
                        rays: v[3] as u32,
                    }),
            );
        }
        times.total_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((out, times))
    }

    /// `fovea_core::math::mix64` of every value, computed by the shader's emulation (the
    /// check that the GPU draws the CPU's random numbers, `tests/environment_light.rs`).
    pub fn mix64(&self, values: &[u64]) -> Result<Vec<u64>> {
        if values.is_empty() {
            return Ok(Vec::new());
        }
        let ctx = &self.ctx;
        let what = format!("hashing {} values", values.len());
        ctx.check_storage_binding(&what, values.len() as u64 * 8)?;
        if values.len() > batch_len(ctx, 8) {
            return Err(GpuError::Input(format!(
                "{} values in one hash check (at most {})",
                values.len(),
                batch_len(ctx, 8)
            )));
        }
        let pipeline = match self.mix64.get() {
            Some(p) => p,
            None => {
                let built = ctx.scoped("building the hash check", || {
                    SHADER
                        .pipelines_of(ctx.device(), &["mix64_check"])
                        .into_iter()
                        .next()
                })?;
                let Some(p) = built else {
                    return Err(GpuError::Input(
                        "the trace module lacks its mix64_check entry point".into(),
                    ));
                };
                self.mix64.get_or_init(|| p)
            }
        };
        let env_block = constants();
        let input: Vec<[u32; 2]> = values.iter().map(|&v| words(v)).collect();
        let block = TraceUniform::new(values.len(), 0, DirectLightModel::RENDERER);
        let (uniform, env_uniform, input_buf) = ctx.scoped(&what, || {
            (
                upload(
                    ctx,
                    "trace parameters",
                    bytemuck::bytes_of(&block),
                    wgpu::BufferUsages::UNIFORM,
                ),
                upload(
                    ctx,
                    "environment parameters",
                    bytemuck::bytes_of(&env_block),
                    wgpu::BufferUsages::UNIFORM,
                ),
                upload(
                    ctx,
                    "hash inputs",
                    bytemuck::cast_slice(&input),
                    wgpu::BufferUsages::STORAGE,
                ),
            )
        })?;
        let (raw, _) = run_1d_at(
            ctx,
            &what,
            pipeline,
            &[
                (0, uniform.as_entire_binding()),
                (16, env_uniform.as_entire_binding()),
                (20, input_buf.as_entire_binding()),
            ],
            19,
            values.len() as u64,
            8,
            false,
        )?;
        Ok(bytemuck::cast_slice::<u32, [u32; 2]>(&raw)
            .iter()
            .take(values.len())
            .map(|w| u64::from(w[0]) | (u64::from(w[1]) << 32))
            .collect())
    }
}
