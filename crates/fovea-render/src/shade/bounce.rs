//! Indirect light (issue 38: "light that reaches the room"): the light that reaches a surface
//! after one or more reflections off other surfaces, by a path tracer (Kajiya 1986) with
//! next-event estimation at every bounce — the lights' shadow rays and the environment's
//! (Veach's thesis Sec. 9.2: the direct light at every vertex, the continuation only for what
//! it hits).
//!
//! From the primary hit `x_0` with outgoing direction `v`, each bounce draws a direction `ω`
//! from the BRDF mixture the environment light samples with (`env_light`: cosine-weighted
//! diffuse and GGX specular, density `p(ω)`), multiplies the path's throughput by
//! `f(x_k, ω, v_k) cos θ / p(ω)`, finds the surface `x_{k+1}` the ray hits, and adds
//!
//! `throughput · (L_e(x_{k+1}) + L_lights(x_{k+1}) + L_env(x_{k+1}))`,
//!
//! where `L_lights` is [`super::direct`] (one shadow ray per light) and `L_env` the
//! environment light with [`BOUNCE_ENV_SAMPLES`] shadow ray ([`super::environment_light`]). A
//! bounce that escapes adds nothing: the environment seen from `x_k` is the environment
//! light's estimator's at `x_k`, which samples the same BRDF and the map, so adding the escaped
//! ray's radiance would count it twice. From the second bounce on, Russian roulette (Arvo and
//! Kirk 1990) ends a path with probability `1 − min(max(throughput), 0.95)` and divides the
//! survivors' throughput by the survival probability, so the estimate stays unbiased for the
//! bounces it has.
//!
//! The first bounce's two random numbers are hashed from the sample's key without its frame
//! and rotated by the frame's point of the (0, 2)-sequence (`frame_noise`), so a texel's first
//! bounces are stratified over successive frames; later ones are hashed with the frame.

use glam::Vec3;

use super::env_light::BrdfSampler;
use super::frame_noise::{frame_rotation, key_frame, rotated_unit, without_frame, UNIT_BITS};
use super::{brdf_cos, direct, environment_light, offset_origin, EnvLight, RayCounts};
use crate::bvh::Ray;
use crate::trace::{trace_sample, GSample};
use crate::world::World;

/// Environment rays at the bounce's surface.
pub const BOUNCE_ENV_SAMPLES: u32 = 1;
/// Salt of the bounce direction's random numbers.
pub const BOUNCE_SALT: u64 = 0x626F_756E_6365_2131;
/// Salt of the numbers hashed with the frame (the bounces after the first, the roulette).
pub const BOUNCE_LATER_SALT: u64 = BOUNCE_SALT.rotate_left(17);
/// Xor-ed (rotated by the bounce) into the sample's key for the environment rays at a bounce,
/// within [`BOUNCE_ENV_KEY_FIELDS`], so they draw other numbers than the primary's.
pub const BOUNCE_ENV_KEY: u64 = 0x0000_0015_A5A5_A5A0;
/// The key's tile and sub-sample fields (bits 4–37): the rank, the eye and the frame stay.
pub const BOUNCE_ENV_KEY_FIELDS: u64 = ((1 << 38) - 1) & !15;
/// What the bounce at depth `depth` (0: the first) xors into the sample's key for the
/// environment rays at the surface it reaches.
#[inline]
pub fn bounce_env_key_mask(depth: u32) -> u64 {
    BOUNCE_ENV_KEY.rotate_left(4 * depth) & BOUNCE_ENV_KEY_FIELDS
}
/// Largest survival probability of the Russian roulette.
pub const ROULETTE_MAX: f32 = 0.95;
/// Default bounces of [`super::ShadingMode::Indirect`] (docs/rendering.md has the
/// measurement that chose it).
pub const DEFAULT_BOUNCES: u32 = 3;
/// Texture footprint of the bounce ray (radians): wide, a coarse mip level, as the path
/// tracer's.
pub const BOUNCE_SPREAD_RAD: f32 = 0.05;

/// The environment light at a bounce's surface when the primary hit's is `primary`:
/// [`BOUNCE_ENV_SAMPLES`] occluded rays, none where the primary casts none (0 rays: no
/// environment light; [`EnvLight::Unshadowed`]: its ambient term, no rays).
pub fn bounce_env_light(primary: EnvLight) -> EnvLight {
    match primary {
        EnvLight::Occluded { samples: 0 } | EnvLight::Unshadowed => primary,
        EnvLight::Occluded { .. } => EnvLight::Occluded {
            samples: BOUNCE_ENV_SAMPLES,
        },
    }
}

/// The indirect light reaching the eye from the surface sample `g` over `bounces` bounces
/// (module header), the primary hit's environment light being `env_light` (the bounces' is
/// [`bounce_env_light`]); `key` seeds the random numbers. Bounce rays are counted in
/// `counts.bounce`, the shadow rays at the bounces in `counts.shadow` and
/// `counts.environment`.
pub fn indirect(
    world: &World,
    g: &GSample,
    env_light: EnvLight,
    bounces: u32,
    key: u64,
    counts: &mut RayCounts,
) -> Vec3 {
    if !g.is_hit() || bounces == 0 {
        return Vec3::ZERO;
    }
    // The first bounce's numbers: hashed without the frame, rotated by it.
    let mut first = fovea_core::math::mix64(without_frame(key) ^ BOUNCE_SALT);
    // Every later number: hashed with the frame.
    let mut later = fovea_core::math::mix64(key ^ BOUNCE_LATER_SALT);
    let step = |rng: &mut u64| {
        *rng = fovea_core::math::mix64(*rng);
        (*rng >> (64 - UNIT_BITS)) as u32
    };
    let rotation = frame_rotation(key_frame(key));
    let env = bounce_env_light(env_light);
    let mut at = *g;
    let mut throughput = Vec3::ONE;
    let mut sum = Vec3::ZERO;
    for depth in 0..bounces {
        let u = if depth == 0 {
            [
                rotated_unit(step(&mut first), rotation[0]),
                rotated_unit(step(&mut first), rotation[1]),
            ]
        } else {
            [
                rotated_unit(step(&mut later), 0),
                rotated_unit(step(&mut later), 0),
            ]
        };
        let sampler = BrdfSampler::new(&at);
        let Some(dir) = sampler.sample(u) else {
            break;
        };
        if dir.dot(at.face_normal) <= 0.0 {
            break;
        }
        let pdf = sampler.pdf(dir);
        let f = brdf_cos(&at, dir);
        if !(pdf > 0.0 && pdf.is_finite()) || f == Vec3::ZERO {
            break;
        }
        throughput *= f / pdf;
        if depth > 0 {
            let survive = throughput.max_element().min(ROULETTE_MAX);
            if survive.is_nan() || survive <= 0.0 || rotated_unit(step(&mut later), 0) >= survive {
                break;
            }
            throughput /= survive;
        }
        counts.bounce += 1;
        let ray = Ray {
            origin: offset_origin(&at),
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let h = trace_sample(world, &ray, BOUNCE_SPREAD_RAD);
        if !h.is_hit() {
            break;
        }
        let env_key = key ^ bounce_env_key_mask(depth);
        sum += throughput
            * (h.emissive
                + direct(world, &h, counts)
                + environment_light(world, &h, env, env_key, counts));
        at = h;
    }
    sum
}
