//! Direct shading of a batch of neighbouring samples with its shadow rays gathered first and
//! cast together ([`ShadowRays`]): issue 20's coherent shadow rays on the CPU, and issue 18's
//! shadow rays on another executor (the GPU's any-hit traversal), which casts the rays of a
//! whole chunk of samples in one call while the shading arithmetic stays here.
//!
//! The estimator is [`super::shade`]'s in [`super::ShadingMode::Direct`], term for term: the
//! lights' contributions `f · radiance · (n·l)` behind one shadow ray each (module
//! [`super`]) and the environment's MIS estimate behind its rays (`env_light`). Gathering
//! only reorders the casting: the lights' rays go light by light over the batch (rays from
//! nearby points towards one light traverse the same BVH nodes, where shading one sample at a
//! time alternates between the lights), then each sample's environment rays. Each sample still
//! sums its lights in the world's order and its environment rays in the estimator's order,
//! so the radiance is [`super::shade`]'s bit for bit whoever casts the rays, as long as they
//! answer each ray's visibility alike (`tests/shade_batch.rs`).

use glam::Vec3;

use super::env_light::environment_rays;
use super::{environment_light, light_at, offset_origin, shadow_ray, EnvLight, RayCounts};
use crate::bvh::Ray;
use crate::trace::GSample;
use crate::world::World;

/// Which term of a sample's radiance a shadow ray belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Term {
    /// A light's.
    Light,
    /// The environment's.
    Environment,
}

/// The shadow rays of a batch of samples' direct shading, and what each adds to its sample
/// when it is unoccluded (module header). Built by [`Self::gather`], cast by anyone
/// ([`Self::cast`] on the world's BVH, or another executor on [`Self::rays`]), summed by
/// [`Self::shade`] or [`Self::direct`].
#[derive(Clone, Debug, Default)]
pub struct ShadowRays {
    /// The rays: light by light (the world's order) over the batch's surface samples, then each
    /// surface sample's environment rays.
    pub rays: Vec<Ray>,
    /// Per ray: its sample (an index into the batch), its term, and what it adds unoccluded.
    adds: Vec<(u32, Term, Vec3)>,
}

impl ShadowRays {
    /// The shadow rays of direct shading with `env_light` of the batch `gs` (misses have
    /// none; `keys[s]` seeds sample `s`'s environment rays, see
    /// [`super::texel_key`]), counted in `counts` (`shadow`, `environment`).
    pub fn gather(
        world: &World,
        gs: &[&GSample],
        keys: &[u64],
        env_light: EnvLight,
        counts: &mut RayCounts,
    ) -> Self {
        let mut out = Self::default();
        out.push_lights(world, gs, counts);
        out.push_environment(world, gs, keys, env_light, counts);
        out
    }

    /// The environment's shadow rays alone (for an executor that computes the lights' part,
    /// [`crate::pipeline::TraceExecutor::direct_light`]; sum with [`Self::shade_given_direct`]).
    pub fn gather_environment(
        world: &World,
        gs: &[&GSample],
        keys: &[u64],
        env_light: EnvLight,
        counts: &mut RayCounts,
    ) -> Self {
        let mut out = Self::default();
        out.push_environment(world, gs, keys, env_light, counts);
        out
    }

    /// The lights' rays, light by light over the batch's surface samples.
    fn push_lights(&mut self, world: &World, gs: &[&GSample], counts: &mut RayCounts) {
        let origins: Vec<Option<Vec3>> = gs
            .iter()
            .map(|g| g.is_hit().then(|| offset_origin(g)))
            .collect();
        let out = self;
        let before = out.rays.len();
        for light in &world.lights {
            for (s, (g, origin)) in gs.iter().zip(&origins).enumerate() {
                let Some(origin) = *origin else { continue };
                if let Some((l, dist, c)) = light_at(light, g, origin) {
                    out.rays.push(shadow_ray(origin, l, dist));
                    out.adds.push((s as u32, Term::Light, c));
                }
            }
        }
        counts.shadow += (out.rays.len() - before) as u64;
    }

    /// Each surface sample's environment rays.
    fn push_environment(
        &mut self,
        world: &World,
        gs: &[&GSample],
        keys: &[u64],
        env_light: EnvLight,
        counts: &mut RayCounts,
    ) {
        let EnvLight::Occluded { samples } = env_light else {
            return;
        };
        let before = self.rays.len();
        for (s, (g, &key)) in gs.iter().zip(keys).enumerate() {
            if g.is_hit() && samples > 0 {
                environment_rays(world, g, samples, key, |ray, c| {
                    self.rays.push(ray);
                    self.adds.push((s as u32, Term::Environment, c));
                });
            }
        }
        counts.environment += (self.rays.len() - before) as u64;
    }

    /// Casts every ray on the world's BVH as one [`crate::bvh::RayCaster::occluded_batch`]:
    /// whether each is occluded.
    pub fn cast(&self, world: &World) -> Vec<bool> {
        let mut blocked = vec![false; self.rays.len()];
        world.caster.occluded_batch(&self.rays, &mut blocked);
        blocked
    }

    /// The lights' part of each sample's radiance ([`super::direct`]) into `out` (one per
    /// sample of the batch), given each ray's occlusion (`blocked`, as [`Self::rays`]).
    pub fn direct(&self, blocked: &[bool], out: &mut [Vec3]) {
        out.iter_mut().for_each(|o| *o = Vec3::ZERO);
        self.sum(Term::Light, blocked, out);
    }

    /// Each sample's radiance towards the eye into `out` ([`super::shade`] in direct shading
    /// with `env_light`, what [`Self::gather`] was given), given each ray's occlusion
    /// (`blocked`, as [`Self::rays`]): emission, the lights and the environment for a
    /// surface, the environment's radiance for a miss.
    pub fn shade(
        &self,
        world: &World,
        gs: &[&GSample],
        env_light: EnvLight,
        blocked: &[bool],
        out: &mut [Vec3],
    ) {
        let mut direct = vec![Vec3::ZERO; gs.len()];
        self.sum(Term::Light, blocked, &mut direct);
        self.shade_given_direct(world, gs, env_light, &direct, blocked, out);
    }

    /// [`Self::shade`] with the lights' part of each sample given (`direct`, one per sample
    /// of the batch; e.g. computed by another executor) rather than summed from the rays.
    pub fn shade_given_direct(
        &self,
        world: &World,
        gs: &[&GSample],
        env_light: EnvLight,
        direct: &[Vec3],
        blocked: &[bool],
        out: &mut [Vec3],
    ) {
        let mut env = vec![Vec3::ZERO; gs.len()];
        match env_light {
            EnvLight::Occluded { .. } => self.sum(Term::Environment, blocked, &mut env),
            // No rays: the ambient term.
            EnvLight::Unshadowed => {
                for (e, g) in env.iter_mut().zip(gs) {
                    *e = environment_light(world, g, env_light, 0, &mut RayCounts::default());
                }
            }
        }
        for (s, (g, o)) in gs.iter().zip(out.iter_mut()).enumerate() {
            *o = if g.is_hit() {
                g.emissive + direct[s] + env[s]
            } else {
                world.scene.environment.radiance(-g.to_eye)
            };
        }
    }

    /// Adds the unoccluded rays of `term` to their samples, in the rays' order.
    fn sum(&self, term: Term, blocked: &[bool], out: &mut [Vec3]) {
        for (&(s, t, c), &b) in self.adds.iter().zip(blocked) {
            if t == term && !b {
                out[s as usize] += c;
            }
        }
    }
}

/// [`super::direct`] of a batch of surface samples (neighbours in a chunk), into `out`, its
/// shadow rays cast light by light as one [`crate::bvh::RayCaster::occluded_batch`]
/// ([`ShadowRays`]). The same values as [`super::direct`], bit for bit
/// (`tests/shade_batch.rs`).
pub fn direct_batch(world: &World, gs: &[&GSample], out: &mut [Vec3], counts: &mut RayCounts) {
    let lights_only = EnvLight::Occluded { samples: 0 };
    let rays = ShadowRays::gather(world, gs, &[], lights_only, counts);
    rays.direct(&rays.cast(world), out);
}

/// [`super::shade`] in [`super::ShadingMode::Direct`] of a batch of G-buffer samples (hits
/// and misses; `keys[s]` is sample `s`'s key), into `out`, every shadow ray of the batch
/// cast as one [`crate::bvh::RayCaster::occluded_batch`] ([`ShadowRays`]). The same values as
/// [`super::shade`], bit for bit.
pub fn shade_direct_batch(
    world: &World,
    gs: &[&GSample],
    keys: &[u64],
    env_light: EnvLight,
    out: &mut [Vec3],
    counts: &mut RayCounts,
) {
    let rays = ShadowRays::gather(world, gs, keys, env_light, counts);
    rays.shade(world, gs, env_light, &rays.cast(world), out);
}
