//! Environment light in direct shading: the environment's radiance gathered at a surface point
//! through shadow rays, so that it reaches a surface only where the surface sees it (issue 17:
//! before, an unshadowed ambient term lit every wall of a closed room through its walls).
//!
//! The estimator is the direct-lighting Monte Carlo estimator with multiple importance
//! sampling by the balance heuristic (Veach and Guibas 1995, Sec. 3, Eq. 7–8; Veach's thesis
//! Sec. 9.2.2, the multi-sample model): with `n_s` rays from strategy `s`,
//!
//! `L ≈ Σ_rays V(ω) · f(ω) cos θ · L_env(ω) / Σ_s n_s p_s(ω)`,
//!
//! where `f cos θ` is the shading model's BRDF times the cosine ([`super::brdf_cos`]: the
//! diffuse and the GGX lobe both see the environment), `V` the visibility of an any-hit shadow
//! ray from the offset surface point to infinity, and the strategies are
//! * the BRDF: a mixture of cosine-weighted directions about the shading normal (the diffuse
//!   lobe, `p = cos θ / π`) and GGX half-vector sampling (the specular lobe, Walter et al.
//!   2007 Eq. 35–36 with the Jacobian of Eq. 14: `p = D(h) (n·h) / (4 (v·h))`), each ray
//!   choosing the specular lobe with probability `q = Y(F0) / (Y(F0) + Y(albedo)(1 − metallic))`
//!   (`F0 = lerp(specular, albedo, metallic)`, `Y` luminance), so its density is
//!   `q p_ggx + (1 − q) p_cos`. A Lambertian surface (`F0 = 0`) uses cosine sampling alone, and
//!   every unoccluded ray from a constant environment `L` then contributes exactly
//!   `albedo · L`; a metal uses GGX alone, which keeps sharp reflections of the sky free of
//!   fireflies;
//! * a map ([`crate::scene::EnvMap`]) also: `⌈N/2⌉` directions from the map's importance
//!   sampling (luminance × solid angle) and `⌊N/2⌋` from the BRDF mixture, every ray weighted
//!   by the balance heuristic over both, so a small bright sun and a dim wide sky are both
//!   found. A constant environment spends all `N` rays on the BRDF mixture.
//!
//! Directions below the geometric surface are occluded by the surface itself and cast no ray.
//! The random numbers are deterministic per shading sample, so a frame is the same every time
//! it is rendered. Each strategy walks the R2 low-discrepancy sequence (Roberts 2018),
//! stratified over 4×4 tiles of neighbouring texels (interleaved sampling, Keller and Heidrich
//! 2001): the texel of rank `r` in its tile ([`texel_key`], Bayer order) takes the points
//! `r·n … r·n + n − 1` of the sequence, and the whole tile shares one offset hashed from the
//! tile (Cranley-Patterson rotation). The 16 texels of a tile together draw the first `16 n`
//! points of one sequence instead of 16 independent sets of `n`, so where a pixel averages
//! several texels (the footprint reconstruction of the polar methods' fovea) their errors
//! cancel, and elsewhere the remaining noise is of high spatial frequency. Tiles are
//! independent, so the error carries no pattern larger than a tile. From frame to frame both
//! shifts are rotated once more by the frame's point of the (0, 2)-sequence
//! (`frame_noise`), so each ray of a texel is stratified over successive frames and temporal
//! accumulation converges; frame 0's rotation is zero.

use std::f32::consts::PI;

use glam::Vec3;
use serde::Serialize;

use super::constants::GGX_D_FLOOR;
use super::frame_noise::{frame_rotation, key_frame, rotated_unit, without_frame};
use super::{brdf_cos, cosine_hemisphere, offset_origin, RayCounts};
use crate::bvh::Ray;
use crate::error::{RenderError, Result};
use crate::trace::GSample;
use crate::world::World;

/// Default environment rays per shading sample ([`EnvLight::Occluded`]).
pub const DEFAULT_ENV_SAMPLES: u32 = 4;
/// Most environment rays per shading sample.
pub const MAX_ENV_SAMPLES: u32 = 256;

/// The estimator's constants, named so another executor of it (the GPU's
/// `environment_light` pass, `fovea-gpu`) uploads these values instead of deriving its own.
pub mod env_constants {
    /// Salt of the environment rays' random numbers (keeps them apart from the path tracer's).
    pub const ENV_SALT: u64 = 0x656E_765F_6C69_6768;
    /// The R2 sequence's steps (Roberts 2018: `1/φ₂` and `1/φ₂²`, `φ₂` the plastic number).
    pub const R2_ALPHAS: [f64; 2] = [0.754_877_666_246_692_7, 0.569_840_290_998_053_2];
    /// A random number is the top `RANDOM_BITS` bits of a [`fovea_core::math::mix64`] state
    /// over `2^RANDOM_BITS`.
    pub const RANDOM_BITS: u32 = 24;
    /// Rec. 709 luminance weights of linear RGB (the lobe weights).
    pub const LUMINANCE: [f32; 3] = [0.2126, 0.7152, 0.0722];
    /// GGX `α²` is taken at least this large when sampling.
    pub const GGX_A2_FLOOR: f32 = 1e-8;
    /// The largest random number below 1 a sampler takes (`1 − ε`).
    pub const BELOW_ONE: f32 = 1.0 - f32::EPSILON;
}
use env_constants::*;

/// Rank of each texel of a 4×4 tile (`[j % 4][i % 4]`) in its tile's stratified sequence:
/// the Bayer matrix, so every 2×2 block of a tile also spreads its ranks (module header).
const TILE_RANK: [[u64; 4]; 4] = [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]];

/// The shading key of texel `(i, j)` of buffer `layer` (below 64 layers, `i`, `j` below 2¹⁶)
/// in frame 0 of eye 0: bits 0–3 the texel's rank in its 4×4 tile, bits 4–17 the tile's
/// column, 18–31 its row, 32–37 a sub-sample ([`subsample_key`]), 38 the eye and 39–57 the
/// frame ([`super::frame_noise::with_frame`] sets them), 58–63 the layer. Distinct texels get
/// distinct keys; every random number of a sample is drawn from its key, and the environment
/// rays also read the tile, the rank and the frame from it (module header). Any other key is
/// valid too: its low four bits are taken as the rank.
pub fn texel_key(layer: u32, i: u32, j: u32) -> u64 {
    const MASK14: u64 = (1 << 14) - 1;
    let rank = TILE_RANK[(j % 4) as usize][(i % 4) as usize];
    ((u64::from(layer) & 63) << 58)
        | ((u64::from(j / 4) & MASK14) << 18)
        | ((u64::from(i / 4) & MASK14) << 4)
        | rank
}

/// The key of sub-sample `s` (below 64) of the texel keyed `key` ([`texel_key`]): its own
/// random numbers, in the same place of its own tile's sequence.
pub fn subsample_key(key: u64, s: usize) -> u64 {
    key ^ ((s as u64 & 63) << 32)
}

/// How direct shading lights a surface with the environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EnvLight {
    /// The environment's mean radiance as an unshadowed ambient term,
    /// `mean · albedo · (1 − metallic)`, no rays. Not physical: closed rooms are lit through
    /// their walls. Kept for comparison with frames rendered before issue 17.
    Unshadowed,
    /// `samples` shadow rays per shading sample towards the environment (module header);
    /// 0 leaves the environment out of direct shading (it still shows as the background).
    Occluded {
        /// Rays per shading sample, 0 to [`MAX_ENV_SAMPLES`] (default
        /// [`DEFAULT_ENV_SAMPLES`]).
        samples: u32,
    },
}

impl EnvLight {
    /// The default: occluded, [`DEFAULT_ENV_SAMPLES`] rays.
    pub const DEFAULT: EnvLight = EnvLight::Occluded {
        samples: DEFAULT_ENV_SAMPLES,
    };

    /// Checks the ray count: 0 to [`MAX_ENV_SAMPLES`].
    pub fn validate(&self) -> Result<()> {
        if let EnvLight::Occluded { samples } = *self {
            if samples > MAX_ENV_SAMPLES {
                return Err(RenderError::invalid(
                    "env-samples",
                    samples,
                    format!("0 to {MAX_ENV_SAMPLES} environment rays per sample"),
                ));
            }
        }
        Ok(())
    }
}

impl Default for EnvLight {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The environment's light at the surface sample `g` towards the eye (module header).
/// `key` seeds the sample's random numbers; environment rays are counted in
/// `counts.environment`.
pub fn environment_light(
    world: &World,
    g: &GSample,
    env_light: EnvLight,
    key: u64,
    counts: &mut RayCounts,
) -> Vec3 {
    match env_light {
        EnvLight::Unshadowed => world.scene.environment.mean() * g.albedo * (1.0 - g.metallic),
        EnvLight::Occluded { samples: 0 } => Vec3::ZERO,
        EnvLight::Occluded { samples } => occluded(world, g, samples, key, counts),
    }
}

/// A no-ray stand-in for the environment light at `g` as if nothing occluded it:
/// `mean · (albedo · (1 − metallic) + F0)` with `F0 = lerp(specular, albedo, metallic)`. DOF
/// culling rebuilds a culled sample's environment light as this times its neighbours'
/// visibility ratio (`crate::cull_fill`).
pub fn unoccluded_estimate(world: &World, g: &GSample) -> Vec3 {
    let f0 = g.specular.lerp(g.albedo, g.metallic);
    world.scene.environment.mean() * (g.albedo * (1.0 - g.metallic) + f0)
}

/// The `i`-th point of the R2 sequence shifted by `shift` (wrapped to `[0, 1)²`).
#[inline]
fn r2_shifted(i: u32, shift: [f32; 2]) -> [f32; 2] {
    let [a1, a2] = R2_ALPHAS;
    let x = (0.5 + i as f64 * a1 + shift[0] as f64).fract() as f32;
    let y = (0.5 + i as f64 * a2 + shift[1] as f64).fract() as f32;
    [x.min(BELOW_ONE), y.min(BELOW_ONE)]
}

/// Luminance of linear Rec. 709 RGB.
#[inline]
fn luminance(c: Vec3) -> f32 {
    LUMINANCE[0] * c.x + LUMINANCE[1] * c.y + LUMINANCE[2] * c.z
}

/// The BRDF side of the estimator: cosine-weighted and GGX sampling mixed by the lobes'
/// weights (module header).
pub(super) struct BrdfSampler {
    n: Vec3,
    v: Vec3,
    tangent: Vec3,
    bitangent: Vec3,
    /// GGX `α²` (`α = roughness²`), kept above 1e-8.
    a2: f32,
    /// Probability of sampling the specular lobe.
    q_spec: f32,
}

impl BrdfSampler {
    pub(super) fn new(g: &GSample) -> Self {
        let f0 = g.specular.lerp(g.albedo, g.metallic);
        let w_spec = luminance(f0).max(0.0);
        let w_diff = (luminance(g.albedo) * (1.0 - g.metallic)).max(0.0);
        let q_spec = if w_spec + w_diff > 0.0 {
            w_spec / (w_spec + w_diff)
        } else {
            0.5
        };
        let (tangent, bitangent) = g.normal.any_orthonormal_pair();
        let a = g.roughness * g.roughness;
        Self {
            n: g.normal,
            v: g.to_eye,
            tangent,
            bitangent,
            a2: (a * a).max(GGX_A2_FLOOR),
            q_spec,
        }
    }

    /// A direction from `u ∈ [0, 1)²` (`u[0]` also picks the lobe); `None` when the mirrored
    /// GGX direction points below the surface.
    pub(super) fn sample(&self, u: [f32; 2]) -> Option<Vec3> {
        if u[0] >= self.q_spec {
            let u0 = ((u[0] - self.q_spec) / (1.0 - self.q_spec)).min(BELOW_ONE);
            return Some(cosine_hemisphere(self.n, u0, u[1]));
        }
        let u0 = u[0] / self.q_spec;
        // GGX: tan² θ_h = α² u / (1 − u).
        let cos2 = (1.0 - u0) / (1.0 + (self.a2 - 1.0) * u0);
        let cos_h = cos2.clamp(0.0, 1.0).sqrt();
        let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
        let (sp, cp) = (std::f32::consts::TAU * u[1]).sin_cos();
        let h = self.tangent * (sin_h * cp) + self.bitangent * (sin_h * sp) + self.n * cos_h;
        let vh = self.v.dot(h);
        let l = (2.0 * vh * h - self.v).normalize_or_zero();
        (vh > 0.0 && l.dot(self.n) > 0.0).then_some(l)
    }

    /// Density of [`Self::sample`] at `l`: `q p_ggx + (1 − q) p_cos`.
    pub(super) fn pdf(&self, l: Vec3) -> f32 {
        let nl = self.n.dot(l);
        if nl <= 0.0 {
            return 0.0;
        }
        let p_cos = nl / PI;
        if self.q_spec <= 0.0 {
            return p_cos;
        }
        let h = (l + self.v).normalize_or_zero();
        let (nh, vh) = (self.n.dot(h), self.v.dot(h));
        let p_ggx = if nh > 0.0 && vh > 0.0 {
            let d = self.a2 / (PI * (nh * nh * (self.a2 - 1.0) + 1.0).powi(2)).max(GGX_D_FLOOR);
            d * nh / (4.0 * vh)
        } else {
            0.0
        };
        self.q_spec * p_ggx + (1.0 - self.q_spec) * p_cos
    }
}

/// The MIS estimator of the module header with `n` rays, each shadow ray cast here.
fn occluded(world: &World, g: &GSample, n: u32, key: u64, counts: &mut RayCounts) -> Vec3 {
    let mut sum = Vec3::ZERO;
    environment_rays(world, g, n, key, |ray, c| {
        counts.environment += 1;
        if !world.caster.occluded(&ray) {
            sum += c;
        }
    });
    sum
}

/// The shadow rays of the MIS estimator of the module header with `n` rays at `g`, in the
/// order the estimator sums them: `emit(ray, c)` for each, where `c` is what the ray adds to
/// the estimate when it is unoccluded. Rays that would add nothing (below the surface, a
/// black direction, a zero density) are not emitted.
pub(crate) fn environment_rays(
    world: &World,
    g: &GSample,
    n: u32,
    key: u64,
    mut emit: impl FnMut(Ray, Vec3),
) {
    let env = &world.scene.environment;
    if env.is_black() {
        return;
    }
    // The tile's offset and the texel's place in the tile's sequence, rotated by the frame's
    // point (module header).
    let rank = (key & 15) as u32;
    let mut rng = fovea_core::math::mix64((without_frame(key) >> 4) ^ ENV_SALT);
    let mut next = || {
        rng = fovea_core::math::mix64(rng);
        (rng >> (64 - RANDOM_BITS)) as u32
    };
    let frame = frame_rotation(key_frame(key));
    let mut shift = || {
        [
            rotated_unit(next(), frame[0]),
            rotated_unit(next(), frame[1]),
        ]
    };
    let shift_map = shift();
    let shift_brdf = shift();
    let map = env.as_map();
    let n_map = if map.is_some() { n.div_ceil(2) } else { 0 };
    let n_brdf = n - n_map;
    let brdf = BrdfSampler::new(g);
    let origin = offset_origin(g);
    for i in 0..n {
        let (dir, radiance) = match map {
            Some(m) if i < n_map => match m.sample(r2_shifted(rank * n_map + i, shift_map)) {
                Some(s) => (s.direction, s.radiance),
                None => continue,
            },
            _ => match brdf.sample(r2_shifted(rank * n_brdf + i - n_map, shift_brdf)) {
                Some(d) => (d, env.radiance(d)),
                None => continue,
            },
        };
        if dir.dot(g.face_normal) <= 0.0 || radiance.max_element() <= 0.0 {
            continue;
        }
        let f = brdf_cos(g, dir);
        if f == Vec3::ZERO {
            continue;
        }
        let p_map = map.map_or(0.0, |m| m.pdf(dir));
        let denom = n_map as f32 * p_map + n_brdf as f32 * brdf.pdf(dir);
        if !(denom > 0.0 && denom.is_finite()) {
            continue;
        }
        let ray = Ray {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        emit(ray, f * radiance / denom);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn settings_are_range_checked() {
        assert!(EnvLight::DEFAULT.validate().is_ok());
        assert!(EnvLight::Occluded { samples: 0 }.validate().is_ok());
        let e = EnvLight::Occluded {
            samples: MAX_ENV_SAMPLES + 1,
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("env-samples"), "{e}");
    }

    fn sample_at(albedo: Vec3, roughness: f32, metallic: f32, specular: f32) -> GSample {
        GSample {
            position: Vec3::ZERO,
            normal: Vec3::Y,
            face_normal: Vec3::Y,
            to_eye: Vec3::new(0.3, 0.9, -0.2).normalize(),
            albedo,
            metallic,
            roughness,
            specular: Vec3::splat(specular),
            emissive: Vec3::ZERO,
            t: 1.0,
            material: 0,
        }
    }

    #[test]
    fn the_brdf_mixture_density_integrates_to_one_and_follows_its_samples() {
        for (albedo, rough, metal, spec) in [
            (Vec3::splat(0.8), 1.0, 0.0, 0.0),
            (Vec3::splat(0.8), 0.5, 0.0, 0.04),
            (Vec3::splat(0.9), 0.3, 1.0, 0.04),
            (Vec3::new(0.9, 0.6, 0.2), 0.15, 0.5, 0.04),
        ] {
            let g = sample_at(albedo, rough, metal, spec);
            let s = BrdfSampler::new(&g);
            // ∫ p dω over the hemisphere (midpoint rule in cos θ, φ), the mass the mixture
            // puts above the surface: 1 minus the mirrored GGX directions that fall below it.
            let m = 800;
            let mut integral = 0.0f64;
            for i in 0..m {
                for j in 0..m {
                    let ct = (i as f32 + 0.5) / m as f32;
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / m as f32;
                    let st = (1.0 - ct * ct).sqrt();
                    let l = Vec3::new(st * phi.cos(), ct, st * phi.sin());
                    integral += (s.pdf(l) * std::f32::consts::TAU / (m * m) as f32) as f64;
                }
            }
            let k = 256;
            let mut below = 0;
            let mut f_over_p = Vec3::ZERO;
            for i in 0..k {
                for j in 0..k {
                    let u = [(i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32];
                    match s.sample(u) {
                        Some(l) => f_over_p += brdf_cos(&g, l) / s.pdf(l) / (k * k) as f32,
                        None => below += 1,
                    }
                }
            }
            let above = 1.0 - below as f64 / (k * k) as f64;
            assert!(
                (integral - above).abs() < 0.02,
                "{albedo} r {rough} m {metal}: ∫p = {integral}, sampled above {above}"
            );
            // The estimate of ∫ f cos dω (directional albedo) matches a quadrature of it.
            let mut albedo_q = Vec3::ZERO;
            for i in 0..m {
                for j in 0..m {
                    let ct = (i as f32 + 0.5) / m as f32;
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / m as f32;
                    let st = (1.0 - ct * ct).sqrt();
                    let l = Vec3::new(st * phi.cos(), ct, st * phi.sin());
                    albedo_q += brdf_cos(&g, l) * (std::f32::consts::TAU / m as f32);
                }
            }
            let albedo_q = albedo_q / m as f32;
            let rel = ((f_over_p - albedo_q) / albedo_q).abs().max_element();
            assert!(rel < 0.03, "r {rough} m {metal}: {f_over_p} vs {albedo_q}");
        }
    }

    #[test]
    fn r2_points_stay_in_the_unit_square_and_spread() {
        let mut cells = [false; 16];
        for i in 0..16 {
            let u = r2_shifted(i, [0.9, 0.99]);
            assert!((0.0..1.0).contains(&u[0]) && (0.0..1.0).contains(&u[1]));
            cells[(u[0] * 4.0) as usize + 4 * (u[1] * 4.0) as usize] = true;
        }
        assert!(cells.iter().filter(|&&c| c).count() >= 12);
    }
}
