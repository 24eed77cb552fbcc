//! Direct shading of a batch of neighbouring samples with its shadow rays cast together:
//! issue 20's coherent shadow rays on the CPU ([`shade_direct_batch`]: each light's rays of
//! the batch as one packet-traversed batch), and issue 18's shadow rays on another executor
//! ([`ShadowRays`]: gathered first, then cast by the GPU's any-hit traversal for a whole group
//! of samples in one call while the shading arithmetic stays here).
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
use crate::scene::Light;
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
/// when it is unoccluded (module header). Built by [`Self::gather`], cast by another executor
/// (its [`crate::pipeline::TraceExecutor::occluded`] on [`Self::rays`]), summed by
/// [`Self::shade`]. (The CPU casts the same rays as it goes:
/// [`shade_direct_batch`].)
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
    /// none; `keys[s]` seeds sample `s`'s environment rays, see [`super::texel_key`]),
    /// counted in `counts` (`shadow`, `environment`). Without `lights` no light's rays (for
    /// an executor that computes the lights' part,
    /// [`crate::pipeline::TraceExecutor::direct_light`]; sum with [`Self::shade_given`]),
    /// without `environment` no environment ray (for one that computes the environment's
    /// part, [`crate::pipeline::TraceExecutor::environment_light`]).
    pub fn gather(
        world: &World,
        gs: &[&GSample],
        keys: &[u64],
        env_light: EnvLight,
        (lights, environment): (bool, bool),
        counts: &mut RayCounts,
    ) -> Self {
        let mut out = Self::default();
        if lights {
            out.push_lights(world, gs, counts);
        }
        if environment {
            out.push_environment(world, gs, keys, env_light, counts);
        }
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
        out.rays.reserve(gs.len() * world.lights.len());
        out.adds.reserve(gs.len() * world.lights.len());
        for light in &world.lights {
            light_rays(light, gs, &origins, |s, ray, c| {
                out.rays.push(ray);
                out.adds.push((s as u32, Term::Light, c));
            });
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
        self.rays.reserve(gs.len() * samples as usize);
        self.adds.reserve(gs.len() * samples as usize);
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

    /// The lights' part of each of the batch's `samples` samples, summed from the unoccluded
    /// rays (`blocked`, as [`Self::rays`]).
    pub fn light_sums(&self, blocked: &[bool], samples: usize) -> Vec<Vec3> {
        let mut direct = vec![Vec3::ZERO; samples];
        self.sum(Term::Light, blocked, &mut direct);
        direct
    }

    /// The occluded environment's part of each of the batch's `samples` samples, summed from
    /// the unoccluded rays (`blocked`, as [`Self::rays`]).
    pub fn environment_sums(&self, blocked: &[bool], samples: usize) -> Vec<Vec3> {
        let mut env = vec![Vec3::ZERO; samples];
        self.sum(Term::Environment, blocked, &mut env);
        env
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
        self.shade_given(world, gs, env_light, (direct, None), blocked, out);
    }

    /// [`Self::shade_given_direct`] with the environment's part of each sample given too
    /// (`environment`, one per sample of the batch, for [`EnvLight::Occluded`]; e.g.
    /// computed by another executor) rather than summed from the rays.
    pub fn shade_given(
        &self,
        world: &World,
        gs: &[&GSample],
        env_light: EnvLight,
        (direct, environment): (&[Vec3], Option<&[Vec3]>),
        blocked: &[bool],
        out: &mut [Vec3],
    ) {
        let mut env = vec![Vec3::ZERO; gs.len()];
        match env_light {
            EnvLight::Occluded { .. } => match environment {
                Some(given) => env.copy_from_slice(given),
                None => self.sum(Term::Environment, blocked, &mut env),
            },
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

/// Calls `emit(sample, ray, c)` for the shadow ray towards `light` of every surface sample
/// of `gs` it lights (`origins`: each sample's offset origin, `None` for a miss), in the
/// samples' order; `c` is what the ray adds unoccluded.
fn light_rays(
    light: &Light,
    gs: &[&GSample],
    origins: &[Option<Vec3>],
    mut emit: impl FnMut(usize, Ray, Vec3),
) {
    for (s, (g, origin)) in gs.iter().zip(origins).enumerate() {
        let Some(origin) = *origin else { continue };
        if let Some((l, dist, c)) = light_at(light, g, origin) {
            emit(s, shadow_ray(origin, l, dist), c);
        }
    }
}

/// [`super::direct`] of a batch of surface samples (neighbours in a chunk), into `out`: the
/// shadow rays are cast light by light, each light's rays of the whole batch as one
/// [`crate::bvh::RayCaster::occluded_batch`] — rays from nearby points towards one light
/// traverse the same BVH nodes (the backends take them as packets or streams), where
/// [`super::direct`] alternates between the lights at every sample. Each sample sums its
/// lights in [`super::direct`]'s order, so the values are the same, bit for bit
/// (`tests/shade_batch.rs`). This is the CPU's path; [`ShadowRays`] gathers the same rays for
/// another executor.
pub fn direct_batch(world: &World, gs: &[&GSample], out: &mut [Vec3], counts: &mut RayCounts) {
    let origins: Vec<Option<Vec3>> = gs
        .iter()
        .map(|g| g.is_hit().then(|| offset_origin(g)))
        .collect();
    out.iter_mut().for_each(|o| *o = Vec3::ZERO);
    let mut rays = Vec::with_capacity(gs.len());
    let mut lit = Vec::with_capacity(gs.len());
    let mut blocked = Vec::with_capacity(gs.len());
    for light in &world.lights {
        rays.clear();
        lit.clear();
        light_rays(light, gs, &origins, |s, ray, c| {
            rays.push(ray);
            lit.push((s, c));
        });
        counts.shadow += rays.len() as u64;
        blocked.clear();
        blocked.resize(rays.len(), false);
        world.caster.occluded_batch(&rays, &mut blocked);
        for (&(s, c), &b) in lit.iter().zip(&blocked) {
            if !b {
                out[s] += c;
            }
        }
    }
}

/// [`super::shade`] in [`super::ShadingMode::Direct`] of a batch of G-buffer samples (hits
/// and misses; `keys[s]` is sample `s`'s key), into `out`: the lights' shadow rays are cast per
/// light over the batch ([`direct_batch`]), the environment's per sample as in
/// [`super::shade`] (random directions: one at a time; in the lights' packets they made the
/// shade stage 1.5× slower, classroom at 1080p, 12 lights). The same values as
/// [`super::shade`], bit for bit. With `noisy`, each sample's Monte Carlo part goes there too
/// (as [`super::shade_parts`]).
pub fn shade_direct_batch(
    world: &World,
    gs: &[&GSample],
    keys: &[u64],
    env_light: EnvLight,
    out: &mut [Vec3],
    mut noisy: Option<&mut [Vec3]>,
    counts: &mut RayCounts,
) {
    let hits: Vec<&GSample> = gs.iter().copied().filter(|g| g.is_hit()).collect();
    let mut direct = vec![Vec3::ZERO; hits.len()];
    direct_batch(world, &hits, &mut direct, counts);
    let mut direct = direct.into_iter();
    for (s, ((g, &key), o)) in gs.iter().zip(keys).zip(out.iter_mut()).enumerate() {
        let (value, mc) = if g.is_hit() {
            let d = direct.next().unwrap_or(Vec3::ZERO);
            let env = environment_light(world, g, env_light, key, counts);
            (
                g.emissive + d + env,
                super::monte_carlo_part(env_light, env),
            )
        } else {
            (world.scene.environment.radiance(-g.to_eye), Vec3::ZERO)
        };
        *o = value;
        if let Some(n) = noisy.as_deref_mut().and_then(|n| n.get_mut(s)) {
            *n = mc;
        }
    }
}
