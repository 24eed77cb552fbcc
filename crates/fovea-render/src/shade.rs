//! Shading of G-buffer samples: direct lighting from every light with a shadow ray each, a
//! GGX microfacet specular lobe plus a Lambertian diffuse lobe (the glTF metallic-roughness
//! model), the environment gathered through shadow rays (module `env_light`), and emission.
//! The optional path-traced mode ([`path_trace`]) replaces the environment rays by `N`
//! bounces with next-event estimation, as VaFR Sec. 8 does to test heavier shading.
//!
//! BRDF (Walter et al. 2007; Karis 2013): `f = (1 − F)(1 − metallic)·albedo/π +
//! D·G·F / (4 (n·l)(n·v))` with GGX `D`, height-correlated Smith `G` (Heitz 2014) and Schlick
//! `F`, `F0 = lerp(specular, albedo, metallic)`, `α = roughness²`.
//!
//! Lights (see [`crate::scene::Light`]): point and spot radiance `I/d²`, a spot's smooth
//! cone falloff, directional irradiance `E`; each contributes `f · radiance · (n·l)` when its
//! shadow ray is unoccluded. Shadow rays start `ε = 1e-4 · (1 + t)` off the surface along the
//! geometric normal.
//!
//! Environment ([`crate::scene::Environment`]): in direct shading, [`EnvLight::Occluded`]
//! (the default, [`DEFAULT_ENV_SAMPLES`] rays) estimates `∫ V · f · cos θ · L_env dω` with
//! shadow rays to infinity (BRDF sampling, cosine-weighted and GGX, for a constant; MIS of
//! map and BRDF sampling for a map; see `env_light`), [`EnvLight::Unshadowed`] adds the old ambient term
//! `mean · albedo · (1 − metallic)` without rays. The path tracer's escaped bounces and every
//! primary ray that misses see the environment's radiance in their direction.

use glam::Vec3;

use crate::bvh::Ray;
use crate::scene::Light;

mod bounce;
mod env_light;
pub mod frame_noise;
mod shadow_batch;

use crate::trace::{trace_sample, GSample};
use crate::world::World;
pub use bounce::{
    bounce_env_key_mask, bounce_env_light, indirect, BOUNCE_ENV_SAMPLES, BOUNCE_LATER_SALT,
    BOUNCE_SALT, BOUNCE_SPREAD_RAD, DEFAULT_BOUNCES, ROULETTE_MAX,
};
pub use env_light::{
    env_constants, environment_light, subsample_key, texel_key, unoccluded_estimate, EnvLight,
    DEFAULT_ENV_SAMPLES, MAX_ENV_SAMPLES,
};
pub use frame_noise::FrameNoise;
pub use shadow_batch::{direct_batch, shade_direct_batch, ShadowRays};

/// Ray counts of one shading call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Shadow (any-hit) rays towards lights.
    pub shadow: u64,
    /// Shadow (any-hit) rays towards the environment (direct shading, [`EnvLight::Occluded`]).
    pub environment: u64,
    /// Bounce (closest-hit) rays of the path-traced mode.
    pub bounce: u64,
}

impl RayCounts {
    /// All rays counted.
    pub fn total(&self) -> u64 {
        self.shadow + self.environment + self.bounce
    }
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: Self) {
        self.shadow += o.shadow;
        self.environment += o.environment;
        self.bounce += o.bounce;
    }
}

/// How samples are shaded.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShadingMode {
    /// Direct lighting with shadows, the environment (through shadow rays by default) and
    /// emission.
    Direct {
        /// How the environment lights surfaces.
        env_light: EnvLight,
    },
    /// Direct shading (as [`ShadingMode::Direct`]) plus indirect light: `bounces` bounces
    /// with next-event estimation at every bounce, the environment included ([`indirect`]):
    /// an interior lit through its windows is lit beyond the sunlit patches.
    Indirect {
        /// How the environment lights surfaces at the primary hit (each bounce's surface takes
        /// [`BOUNCE_ENV_SAMPLES`] occluded rays, none where this casts none:
        /// [`bounce_env_light`]).
        env_light: EnvLight,
        /// Bounces of indirect light (1–16; default [`DEFAULT_BOUNCES`]).
        bounces: u32,
    },
    /// Path tracing with next-event estimation: `bounces` indirect bounces, `spp` paths per
    /// sample, deterministic for a given `seed`.
    Path {
        /// Indirect bounces (1–16).
        bounces: u32,
        /// Paths per sample (1–1024).
        spp: u32,
        /// Random seed.
        seed: u64,
    },
}

impl ShadingMode {
    /// Direct shading with the default environment light ([`EnvLight::DEFAULT`]).
    pub const DIRECT: ShadingMode = ShadingMode::Direct {
        env_light: EnvLight::DEFAULT,
    };

    /// Direct shading without Monte Carlo noise: the environment as the unshadowed ambient term
    /// ([`EnvLight::Unshadowed`]), every other term exact. For measurements that compare
    /// differently sampled frames pixel by pixel (a foveated frame against full resolution,
    /// frame-to-frame flicker, a thin-lens reference), where the occluded environment light's
    /// noise would be measured instead of the method: the evaluation experiments, the report's
    /// quality section and such tests use it.
    pub const NOISE_FREE: ShadingMode = ShadingMode::Direct {
        env_light: EnvLight::Unshadowed,
    };

    /// The default: direct shading with the default environment light plus
    /// [`DEFAULT_BOUNCES`] bounces of indirect light ([`ShadingMode::Indirect`]).
    pub const DEFAULT: ShadingMode = ShadingMode::Indirect {
        env_light: EnvLight::DEFAULT,
        bounces: DEFAULT_BOUNCES,
    };

    /// Whether this is direct shading.
    pub fn is_direct(&self) -> bool {
        matches!(self, ShadingMode::Direct { .. })
    }

    /// The environment light of the primary hit in direct shading, with or without a bounce.
    pub fn direct_env_light(&self) -> Option<EnvLight> {
        match *self {
            ShadingMode::Direct { env_light } | ShadingMode::Indirect { env_light, .. } => {
                Some(env_light)
            }
            ShadingMode::Path { .. } => None,
        }
    }

    /// Checks the ranges: 0–[`MAX_ENV_SAMPLES`] environment rays, 1–16 bounces and 1–1024
    /// paths per sample.
    pub fn validate(&self) -> crate::error::Result<()> {
        if let Some(env_light) = self.direct_env_light() {
            env_light.validate()?;
        }
        if let ShadingMode::Indirect { bounces, .. } = *self {
            if !(1..=16).contains(&bounces) {
                return Err(crate::error::RenderError::invalid(
                    "bounces", bounces, "1 to 16",
                ));
            }
        }
        if let ShadingMode::Path { bounces, spp, .. } = *self {
            if !(1..=16).contains(&bounces) {
                return Err(crate::error::RenderError::invalid(
                    "bounces", bounces, "1 to 16",
                ));
            }
            if !(1..=1024).contains(&spp) {
                return Err(crate::error::RenderError::invalid("spp", spp, "1 to 1024"));
            }
        }
        Ok(())
    }
}

/// The shading model's constants, named so another executor of the model (the GPU's
/// `direct_light` pass, `fovea-gpu`) uploads these values instead of deriving its own.
pub mod constants {
    /// Shadow rays start `SHADOW_OFFSET_PER_T · (1 + min(t, SHADOW_OFFSET_T_CAP))` off the
    /// surface along its geometric normal (`t`: the primary ray's distance, metres).
    pub const SHADOW_OFFSET_PER_T: f32 = 1e-4;
    /// See [`SHADOW_OFFSET_PER_T`].
    pub const SHADOW_OFFSET_T_CAP: f32 = 1e4;
    /// A shadow ray towards a point or spot light `d` away stops at `d · (1 − SHADOW_SHORTEN)`.
    pub const SHADOW_SHORTEN: f32 = 1e-4;
    /// A point or spot light nearer than this (metres) lights nothing.
    pub const MIN_LIGHT_DISTANCE: f32 = 1e-6;
    /// A spot's `cos_inner − cos_outer` is taken at least this wide.
    pub const SPOT_MIN_WIDTH: f32 = 1e-6;
    /// `n·v` is taken at least this large in the BRDF.
    pub const MIN_NV: f32 = 1e-4;
    /// The GGX `D`'s denominator `π (…)²` is taken at least this large.
    pub const GGX_D_FLOOR: f32 = 1e-12;
    /// The Smith visibility's denominator is taken at least this large.
    pub const VIS_FLOOR: f32 = 1e-8;
}
use constants::*;

#[inline]
fn offset_origin(g: &GSample) -> Vec3 {
    g.position + g.face_normal * (SHADOW_OFFSET_PER_T * (1.0 + g.t.min(SHADOW_OFFSET_T_CAP)))
}

/// GGX + Lambert BRDF times `n·l`, for unit `l` towards the light. Always inlined: its callers
/// (each light, each environment ray) are the shade stage's hot loops, and left to itself the
/// compiler stopped inlining it once it had a third caller (measured: the shade stage 1.2×
/// slower, classroom at 1080p, 12 lights).
#[inline(always)]
pub fn brdf_cos(g: &GSample, l: Vec3) -> Vec3 {
    let n = g.normal;
    let v = g.to_eye;
    let nl = n.dot(l);
    let nv = n.dot(v).max(MIN_NV);
    if nl <= 0.0 {
        return Vec3::ZERO;
    }
    let h = (l + v).normalize_or_zero();
    let nh = n.dot(h).max(0.0);
    let vh = v.dot(h).max(0.0);
    let a = g.roughness * g.roughness;
    let a2 = a * a;
    let d = a2 / (std::f32::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2)).max(GGX_D_FLOOR);
    let vis = 0.5
        / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt())
            .max(VIS_FLOOR);
    let f0 = g.specular.lerp(g.albedo, g.metallic);
    let f = f0 + (Vec3::ONE - f0) * (1.0 - vh).powi(5);
    let spec = d * vis * f;
    let diffuse = (Vec3::ONE - f) * (1.0 - g.metallic) * g.albedo / std::f32::consts::PI;
    (diffuse + spec) * nl
}

/// Direct light at `g` from every light, with one shadow ray per light facing the surface.
pub fn direct(world: &World, g: &GSample, counts: &mut RayCounts) -> Vec3 {
    direct_with_visibility(world, g, counts).0
}

/// [`direct`] and which lights reached the surface: bit `l` of the mask is set when light `l`
/// (of the first 64) contributes and its shadow ray is unoccluded.
pub fn direct_with_visibility(world: &World, g: &GSample, counts: &mut RayCounts) -> (Vec3, u64) {
    let origin = offset_origin(g);
    let mut sum = Vec3::ZERO;
    let mut mask = 0u64;
    for_each_light(world, g, |index, l, dist, c| {
        counts.shadow += 1;
        if !world.caster.occluded(&shadow_ray(origin, l, dist)) {
            sum += c;
            if index < 64 {
                mask |= 1 << index;
            }
        }
    });
    (sum, mask)
}

/// Direct light at `g` as if nothing cast a shadow: no rays, only the BRDF and the lights.
pub fn direct_unshadowed(world: &World, g: &GSample) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for_each_light(world, g, |_, _, _, c| sum += c);
    sum
}

/// Each light's unshadowed contribution at `g`, as `(light index, radiance)`, lights that
/// contribute nothing left out. No rays.
pub fn direct_per_light(world: &World, g: &GSample) -> Vec<(u32, Vec3)> {
    let mut out = Vec::new();
    for_each_light(world, g, |index, _, _, c| out.push((index as u32, c)));
    out
}

/// What a sample skipped by DOF-aware culling can still afford, as `(offset, basis)`: its
/// radiance is reconstructed as `offset + basis · r`, with `r` interpolated from shaded
/// neighbours' `(L − offset)/basis`. Direct shading: `offset` = emission (+ the ambient term
/// of [`EnvLight::Unshadowed`]), `basis` = the unshadowed direct light plus
/// [`culled_env_basis`] (`r` is then the lights' and the environment's visibility, Heitz et
/// al. 2018's ratio estimator). Path tracing: `offset` = emission, `basis` = the albedo
/// (demodulation).
pub fn culled_basis(world: &World, g: &GSample, mode: ShadingMode) -> (Vec3, Vec3) {
    if !g.is_hit() {
        return (world.scene.environment.radiance(-g.to_eye), Vec3::ZERO);
    }
    match mode {
        ShadingMode::Direct { env_light } => {
            let ambient = match env_light {
                EnvLight::Unshadowed => {
                    environment_light(world, g, env_light, 0, &mut RayCounts::default())
                }
                EnvLight::Occluded { .. } => Vec3::ZERO,
            };
            (
                g.emissive + ambient,
                direct_unshadowed(world, g) + culled_env_basis(world, g, mode),
            )
        }
        ShadingMode::Path { .. } | ShadingMode::Indirect { .. } => (g.emissive, g.albedo),
    }
}

/// The part of [`culled_basis`]'s basis that stands for the occluded environment light: the
/// no-ray [`unoccluded_estimate`] in direct shading with [`EnvLight::Occluded`] and at least
/// one ray, zero otherwise.
pub fn culled_env_basis(world: &World, g: &GSample, mode: ShadingMode) -> Vec3 {
    match mode {
        ShadingMode::Direct {
            env_light: EnvLight::Occluded { samples },
        } if samples > 0 && g.is_hit() => unoccluded_estimate(world, g),
        _ => Vec3::ZERO,
    }
}

/// Calls `f(light index, direction to the light, distance, unshadowed radiance)` for every
/// light that lights the surface at `g` (in range, in its cone, in front, non-zero BRDF).
fn for_each_light(world: &World, g: &GSample, mut f: impl FnMut(usize, Vec3, f32, Vec3)) {
    let origin = offset_origin(g);
    for (index, light) in world.lights.iter().enumerate() {
        if let Some((l, dist, c)) = light_at(light, g, origin) {
            f(index, l, dist, c);
        }
    }
}

/// What `light` gives the surface at `g` seen from `origin` (its offset position): the
/// direction to the light, its distance and the unshadowed radiance (BRDF × cos × the light's
/// falloff), or `None` when it does not light it (out of range or cone, behind, zero BRDF).
#[inline]
fn light_at(light: &Light, g: &GSample, origin: Vec3) -> Option<(Vec3, f32, Vec3)> {
    // The unit direction to a light at `position` and its distance, within `range`.
    let towards = |position: Vec3, range: f32| -> Option<(Vec3, f32)> {
        let d = position - origin;
        let dist = d.length();
        if dist > range || dist < MIN_LIGHT_DISTANCE {
            None
        } else {
            Some((d / dist, dist))
        }
    };
    let (l, dist, radiance) = match *light {
        Light::Point {
            position,
            intensity,
            range,
        } => {
            let (l, dist) = towards(position, range)?;
            (l, dist, intensity / (dist * dist))
        }
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
            range,
        } => {
            let (l, dist) = towards(position, range)?;
            let c = (-l).dot(direction);
            let k = ((c - cos_outer) / (cos_inner - cos_outer).max(SPOT_MIN_WIDTH)).clamp(0.0, 1.0);
            if k <= 0.0 {
                return None;
            }
            (l, dist, intensity * (k * k) / (dist * dist))
        }
        Light::Directional {
            direction,
            irradiance,
        } => (-direction, f32::INFINITY, irradiance),
    };
    if g.face_normal.dot(l) <= 0.0 && g.normal.dot(l) <= 0.0 {
        return None;
    }
    let brdf = brdf_cos(g, l);
    if brdf == Vec3::ZERO {
        return None;
    }
    Some((l, dist, brdf * radiance))
}

/// The shadow ray from `origin` towards a light `dist` away along `l` (stopping just short
/// of it; unbounded for a directional light).
#[inline]
fn shadow_ray(origin: Vec3, l: Vec3, dist: f32) -> Ray {
    Ray {
        origin,
        dir: l,
        t_min: 0.0,
        t_max: if dist.is_finite() {
            dist * (1.0 - SHADOW_SHORTEN)
        } else {
            f32::INFINITY
        },
    }
}

/// Radiance towards the eye of one G-buffer sample.
pub fn shade(
    world: &World,
    g: &GSample,
    mode: ShadingMode,
    key: u64,
    counts: &mut RayCounts,
) -> Vec3 {
    shade_parts(world, g, mode, key, counts).0
}

/// The part of a direct-shading value estimated by Monte Carlo: the occluded environment's
/// (`env`, from [`environment_light`]); the unshadowed ambient term is exact (zero).
#[inline]
pub fn monte_carlo_part(env_light: EnvLight, env: Vec3) -> Vec3 {
    match env_light {
        EnvLight::Occluded { .. } => env,
        EnvLight::Unshadowed => Vec3::ZERO,
    }
}

/// [`shade`] and the part of it estimated by Monte Carlo — what the sample-space denoiser
/// filters (`fovea_post::denoise`): in direct shading the occluded environment's
/// ([`monte_carlo_part`]; the lights' shadow rays and emission are exact), in path tracing
/// everything but emission; zero for a miss.
pub fn shade_parts(
    world: &World,
    g: &GSample,
    mode: ShadingMode,
    key: u64,
    counts: &mut RayCounts,
) -> (Vec3, Vec3) {
    if !g.is_hit() {
        return (world.scene.environment.radiance(-g.to_eye), Vec3::ZERO);
    }
    match mode {
        ShadingMode::Direct { env_light } => {
            let d = direct(world, g, counts);
            let env = environment_light(world, g, env_light, key, counts);
            (g.emissive + d + env, monte_carlo_part(env_light, env))
        }
        ShadingMode::Indirect { env_light, bounces } => {
            let d = direct(world, g, counts);
            let env = environment_light(world, g, env_light, key, counts);
            // The bounces' light is Monte Carlo throughout.
            let bounced = indirect(world, g, env_light, bounces, key, counts);
            (
                g.emissive + d + env + bounced,
                monte_carlo_part(env_light, env) + bounced,
            )
        }
        ShadingMode::Path { bounces, spp, seed } => {
            let mut acc = Vec3::ZERO;
            // The first bounce's numbers are rotated by the frame's point (`frame_noise`).
            let rotation = frame_noise::frame_rotation(frame_noise::key_frame(key));
            for s in 0..spp {
                acc += path_trace_rotated(
                    world,
                    g,
                    bounces,
                    fovea_core::math::mix64(
                        seed ^ key.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ s as u64,
                    ),
                    rotation,
                    counts,
                );
            }
            let c = acc / spp as f32;
            (c, c - g.emissive)
        }
    }
}

/// One path from a primary hit: next-event estimation at every vertex, `bounces` cosine- or
/// glossy-sampled continuations, environment radiance when a bounce escapes.
pub fn path_trace(
    world: &World,
    first: &GSample,
    bounces: u32,
    seed: u64,
    counts: &mut RayCounts,
) -> Vec3 {
    path_trace_rotated(world, first, bounces, seed, [0, 0], counts)
}

/// [`path_trace`] with the first bounce direction's two random numbers rotated by
/// `rotation / 2^24` (a Cranley-Patterson rotation: the frame's point,
/// [`frame_noise::frame_rotation`]), so that successive frames of a sample stratify its first
/// bounce.
pub fn path_trace_rotated(
    world: &World,
    first: &GSample,
    bounces: u32,
    seed: u64,
    rotation: [u32; 2],
    counts: &mut RayCounts,
) -> Vec3 {
    let mut rng = fovea_core::math::mix64(seed);
    let mut draws = 0u32;
    let mut next = || {
        rng = fovea_core::math::mix64(rng);
        let bits = (rng >> 40) as u32;
        // Draws 2 and 3 are the first bounce's direction (draw 1 picks its lobe).
        draws += 1;
        let r = match draws {
            2 => rotation[0],
            3 => rotation[1],
            _ => 0,
        };
        frame_noise::rotated_unit(bits, r)
    };
    let mut g = *first;
    let mut throughput = Vec3::ONE;
    let mut radiance = g.emissive;
    for depth in 0..=bounces {
        radiance += throughput * direct(world, &g, counts);
        if depth == bounces {
            break;
        }
        // Choose a lobe: mirror-ish reflection for metals, cosine-weighted diffuse otherwise.
        let n = g.normal;
        let (dir, weight) = if next() < g.metallic {
            let r = (-g.to_eye).reflect(n);
            let jitter = cosine_hemisphere(n, next(), next()) * g.roughness * g.roughness;
            let d = (r + jitter).normalize_or_zero();
            (d, g.albedo)
        } else {
            (cosine_hemisphere(n, next(), next()), g.albedo)
        };
        if dir.dot(g.face_normal) <= 0.0 || dir == Vec3::ZERO {
            break;
        }
        throughput *= weight;
        if throughput.max_element() < 1e-4 {
            break;
        }
        counts.bounce += 1;
        let ray = Ray {
            origin: offset_origin(&g),
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        // Bounce footprints are wide: use a coarse texture level.
        let h = trace_sample(world, &ray, 0.05);
        if !h.is_hit() {
            radiance += throughput * world.scene.environment.radiance(dir);
            break;
        }
        radiance += throughput * h.emissive;
        g = h;
    }
    radiance
}

/// Cosine-weighted direction around `n` from two uniform numbers.
fn cosine_hemisphere(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let (x, y) = (r * phi.cos(), r * phi.sin());
    let z = (1.0 - u1).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (t * x + b * y + n * z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(albedo: Vec3, roughness: f32, metallic: f32) -> GSample {
        GSample {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            face_normal: Vec3::Z,
            to_eye: Vec3::Z,
            albedo,
            metallic,
            roughness,
            specular: Vec3::splat(0.04),
            emissive: Vec3::ZERO,
            t: 1.0,
            material: 0,
        }
    }

    #[test]
    fn brdf_conserves_energy_and_lambert_limit_holds() {
        // Integrate f·cos over the hemisphere numerically for a white surface: ≤ 1.
        for (r, m) in [(1.0, 0.0), (0.5, 0.0), (0.2, 1.0), (0.05, 0.0)] {
            let g = sample(Vec3::ONE, r, m);
            let n = 400;
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    // Uniform in (cos θ, φ): dω = d cosθ dφ.
                    let ct = (i as f32 + 0.5) / n as f32;
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / n as f32;
                    let st = (1.0 - ct * ct).sqrt();
                    let l = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                    sum += brdf_cos(&g, l).x * std::f32::consts::TAU / (n * n) as f32;
                }
            }
            assert!(sum <= 1.02, "roughness {r} metallic {m}: albedo {sum}");
            assert!(sum > 0.5, "roughness {r} metallic {m}: albedo {sum}");
        }
        // Light from below the surface contributes nothing.
        assert_eq!(brdf_cos(&sample(Vec3::ONE, 0.5, 0.0), -Vec3::Z), Vec3::ZERO);
    }

    #[test]
    fn cosine_samples_lie_in_the_hemisphere_with_mean_cosine_two_thirds() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut mean = 0.0;
        let k = 64;
        for i in 0..k {
            for j in 0..k {
                let d =
                    cosine_hemisphere(n, (i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                assert!(d.dot(n) >= 0.0);
                mean += d.dot(n) / (k * k) as f32;
            }
        }
        assert!((mean - 2.0 / 3.0).abs() < 0.01, "{mean}");
    }
}
