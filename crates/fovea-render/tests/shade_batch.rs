//! Batched shading (issue 20, coherent shadow rays): the lights' shadow rays of neighbouring
//! samples cast light by light as one batch give the same radiance as shading each sample
//! alone, bit for bit; and a whole frame rendered with the batches is the frame of the
//! one-sample path.

use glam::Vec3;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_render::bvh::{Backend, Ray};
use fovea_render::camera::{Eye, HmdRig};
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::{builtin, Light};
use fovea_render::shade::{
    direct, direct_batch, shade, shade_direct_batch, EnvLight, RayCounts, ShadingMode, ShadowRays,
};
use fovea_render::trace::{trace_sample, GSample};
use fovea_render::world::World;

/// The built-in scene (a sun and four point lights) with a spot light added, and the
/// G-buffer of a grid of primary rays over its camera's view (hits and misses).
fn scene(backend: Backend) -> (World, Vec<GSample>) {
    let mut scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    scene.lights.push(Light::Spot {
        position: desc.position + Vec3::new(0.3, 0.5, 0.0),
        direction: desc.forward,
        intensity: Vec3::splat(30.0),
        cos_inner: 0.95,
        cos_outer: 0.8,
        range: 50.0,
    });
    let world = World::new(scene, backend).unwrap();
    let display = DisplayProfile::new("t", 96, 64, Degrees(100.0), Degrees(70.0)).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Centre, &display).unwrap();
    let mut gs = Vec::new();
    for y in 0..64 {
        for x in 0..96 {
            let ray: Ray = camera.ray(fovea_core::units::ScreenPoint::new(
                x as f64 + 0.5,
                y as f64 + 0.5,
            ));
            gs.push(trace_sample(&world, &ray, 1e-3));
        }
    }
    (world, gs)
}

#[test]
fn batched_direct_light_is_the_one_sample_direct_light_bit_for_bit() {
    for backend in [Backend::Obvhs, Backend::BruteForce] {
        let (world, gs) = scene(backend);
        assert!(world.lights.len() >= 5);
        let hits: Vec<&GSample> = gs.iter().filter(|g| g.is_hit()).collect();
        assert!(hits.len() > 1000, "{} hits", hits.len());
        for batch in [1usize, 7, 256, hits.len()] {
            let (mut one, mut many) = (RayCounts::default(), RayCounts::default());
            for chunk in hits.chunks(batch) {
                let mut out = vec![Vec3::NAN; chunk.len()];
                direct_batch(&world, chunk, &mut out, &mut many);
                for (g, got) in chunk.iter().zip(&out) {
                    let want = direct(&world, g, &mut one);
                    assert_eq!(
                        want.to_array().map(f32::to_bits),
                        got.to_array().map(f32::to_bits)
                    );
                }
            }
            assert_eq!(one.shadow, many.shadow, "{backend:?}, batches of {batch}");
        }
    }
}

#[test]
fn batched_direct_shading_is_shade_bit_for_bit_hits_and_misses() {
    let (world, gs) = scene(Backend::Obvhs);
    let refs: Vec<&GSample> = gs.iter().collect();
    assert!(refs.iter().any(|g| !g.is_hit()), "the view has no miss");
    for env_light in [EnvLight::Occluded { samples: 4 }, EnvLight::Unshadowed] {
        let mode = ShadingMode::Direct { env_light };
        let keys: Vec<u64> = (0..refs.len() as u64).map(|k| k * 7919).collect();
        let mut out = vec![Vec3::NAN; refs.len()];
        let mut many = RayCounts::default();
        shade_direct_batch(&world, &refs, &keys, env_light, &mut out, None, &mut many);
        let mut one = RayCounts::default();
        for ((g, &key), got) in refs.iter().zip(&keys).zip(&out) {
            let want = shade(&world, g, mode, key, &mut one);
            assert_eq!(
                want.to_array().map(f32::to_bits),
                got.to_array().map(f32::to_bits)
            );
        }
        assert_eq!(one.total(), many.total());
    }
}

/// The shadow rays gathered for another executor ([`ShadowRays`]), answered ray by ray by the
/// CPU's BVH, shade every sample as `shade` does, bit for bit, and count the same rays; so do
/// the lights' part given from `direct` with only the environment's rays gathered (what an
/// executor that computes direct light gets).
#[test]
fn gathered_shadow_rays_shade_as_shade_does_bit_for_bit() {
    let (world, gs) = scene(Backend::Obvhs);
    let refs: Vec<&GSample> = gs.iter().collect();
    for env_light in [EnvLight::Occluded { samples: 4 }, EnvLight::Unshadowed] {
        let mode = ShadingMode::Direct { env_light };
        let keys: Vec<u64> = (0..refs.len() as u64).map(|k| k * 7919).collect();
        let answer = |rays: &ShadowRays| -> Vec<bool> {
            rays.rays.iter().map(|r| world.caster.occluded(r)).collect()
        };
        let mut many = RayCounts::default();
        let rays = ShadowRays::gather(&world, &refs, &keys, env_light, (true, true), &mut many);
        let mut out = vec![Vec3::NAN; refs.len()];
        rays.shade(&world, &refs, env_light, &answer(&rays), &mut out);
        let mut env_only = RayCounts::default();
        let env_rays = ShadowRays::gather(
            &world,
            &refs,
            &keys,
            env_light,
            (false, true),
            &mut env_only,
        );
        let given: Vec<Vec3> = refs
            .iter()
            .map(|g| direct(&world, g, &mut env_only))
            .collect();
        let mut out_given = vec![Vec3::NAN; refs.len()];
        env_rays.shade_given_direct(
            &world,
            &refs,
            env_light,
            &given,
            &answer(&env_rays),
            &mut out_given,
        );
        let mut one = RayCounts::default();
        for ((g, &key), (a, b)) in refs.iter().zip(&keys).zip(out.iter().zip(&out_given)) {
            let want = shade(&world, g, mode, key, &mut one)
                .to_array()
                .map(f32::to_bits);
            assert_eq!(want, a.to_array().map(f32::to_bits));
            assert_eq!(want, b.to_array().map(f32::to_bits));
        }
        assert_eq!(one.total(), many.total());
        assert_eq!(one.total(), env_only.total());
    }
}

/// A full-resolution frame (its shade stage takes the batched path: direct shading, one ray
/// per texel, no culling) casts the shadow rays that shading its pixels one at a time casts.
/// That its pixels are unchanged is `tests/golden.rs`.
#[test]
fn a_frame_counts_the_same_shadow_rays() {
    let (world, _) = scene(Backend::Obvhs);
    let desc = world.scene.cameras[0].clone();
    let display = DisplayProfile::new("t", 160, 120, Degrees(100.0), Degrees(80.0)).unwrap();
    let rig = HmdRig::new(desc.position, desc.forward, desc.up, 0.063).unwrap();
    let camera = rig.eye(Eye::Centre, &display).unwrap();
    let mut settings = FrameSettings::new(Method::Full);
    settings.shading = ShadingMode::Direct {
        env_light: EnvLight::Unshadowed,
    };
    let frame = render_frame(
        &world,
        &camera,
        &settings,
        display.centre_gaze(),
        &|_, _| {},
    )
    .unwrap();
    // Count one sample at a time over the same pixels.
    let mut rc = RayCounts::default();
    for y in 0..120 {
        for x in 0..160 {
            let ray = camera.ray(fovea_core::units::ScreenPoint::new(
                x as f64 + 0.5,
                y as f64 + 0.5,
            ));
            let g = trace_sample(&world, &ray, 1e-3);
            if g.is_hit() {
                direct(&world, &g, &mut rc);
            }
        }
    }
    assert_eq!(frame.stats.rays_shadow, rc.shadow);
}
