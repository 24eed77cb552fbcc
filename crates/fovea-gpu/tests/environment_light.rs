//! The GPU's environment light against the renderer's
//! (`fovea_render::shade::environment_light` with `EnvLight::Occluded`): the same random
//! numbers — SplitMix64 emulated with u32 pairs, bit for bit against
//! `fovea_core::math::mix64` — and, on the built-in scene's G-buffer (every fourth pixel of the
//! Vive Pro Eye view, each sample keyed by `texel_key` as the renderer keys it), the same
//! estimate per sample with a constant environment and with a procedural map (a sky gradient
//! and a small bright sun, turned and scaled), on the scene's own materials and on the same
//! samples made Lambertian, glossy and metal. The arithmetic is f32 on both sides in the same
//! order but not bit for bit (the GPU's `sin`, `acos`, `atan2`, fused multiply-adds), and a
//! shadow ray that grazes an edge, or a direction that lands on the other side of a map cell's
//! edge, may be answered differently, so: at least 99.9 % of the samples within 1e-4 relative
//! (above 1e-3 absolute), and the environment rays counted alike within 0.01 %.
//!
//! Needs a GPU adapter (lavapipe will do); without one it says SKIPPED on stderr, and fails
//! under FOVEA_REQUIRE_GPU=1.

mod common;

use common::{gpu_or_skip, shout};
use fovea_core::display::DisplayProfile;
use fovea_core::math::mix64;
use fovea_core::units::ScreenPoint;
use fovea_gpu::{GpuEnvironment, GpuError, GpuSurface, GpuTracer};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::scene::{builtin, EnvMap, Environment};
use fovea_render::shade::frame_noise::with_frame;
use fovea_render::shade::{environment_light, texel_key, EnvLight, FrameNoise, RayCounts};
use fovea_render::trace::{trace_sample, GSample};
use fovea_render::world::World;
use glam::{Mat3, Vec3};

#[test]
fn mix64_on_the_gpu_is_bit_exact() {
    let Some(ctx) = gpu_or_skip("mix64_on_the_gpu_is_bit_exact") else {
        return;
    };
    let gpu = GpuTracer::new(&ctx, &[[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]).unwrap();
    // Edge values, every single bit, and a long stretch of hashed values (all carries and
    // high words), 2^18 in all.
    let mut inputs: Vec<u64> = vec![0, 1, u64::MAX, u64::MAX - 1, 1 << 63, u32::MAX as u64];
    inputs.extend((0..64).map(|b| 1u64 << b));
    inputs.extend((0..64).map(|b| !(1u64 << b)));
    let mut z = 0x1234_5678_9ABC_DEF0u64;
    while inputs.len() < 1 << 18 {
        z = mix64(z);
        inputs.push(z);
        inputs.push(z >> (z % 64));
    }
    let got = gpu.mix64(&inputs).unwrap();
    assert_eq!(got.len(), inputs.len());
    let wrong: Vec<(u64, u64, u64)> = inputs
        .iter()
        .zip(&got)
        .filter(|(&x, &y)| mix64(x) != y)
        .map(|(&x, &y)| (x, y, mix64(x)))
        .take(5)
        .collect();
    shout(&format!(
        "[fovea-gpu] mix64 of {} values on the GPU: {} differ",
        inputs.len(),
        wrong.len()
    ));
    assert!(wrong.is_empty(), "(input, gpu, cpu): {wrong:x?}");
    assert!(gpu.mix64(&[]).unwrap().is_empty());
}

/// A 64 × 32 map: a sky gradient, a darker ground and a small bright sun.
fn sun_and_sky() -> EnvMap {
    let (w, h) = (64u32, 32u32);
    let pixels = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            if (18..=19).contains(&i) && (7..=8).contains(&j) {
                Vec3::new(400.0, 360.0, 300.0)
            } else if j < h / 2 {
                Vec3::new(0.3, 0.45, 0.9) * (1.2 - j as f32 / h as f32)
            } else {
                Vec3::new(0.08, 0.07, 0.05)
            }
        })
        .collect();
    EnvMap::new("sun-and-sky", w, h, pixels)
        .unwrap()
        .with_rotation(Mat3::from_rotation_y(0.6) * Mat3::from_rotation_x(-0.2))
        .unwrap()
        .scaled(0.8)
        .unwrap()
}

/// The material variants the samples are shaded with: the scene's own, Lambertian, glossy
/// dielectric, rough and polished metal.
fn variant(g: &GSample, v: usize) -> GSample {
    let mut g = *g;
    match v {
        0 => {}
        1 => {
            g.metallic = 0.0;
            g.specular = Vec3::ZERO;
            g.roughness = 1.0;
        }
        2 => {
            g.metallic = 0.0;
            g.specular = Vec3::splat(0.04);
            g.roughness = 0.2;
        }
        3 => {
            g.metallic = 1.0;
            g.roughness = 0.5;
        }
        _ => {
            g.metallic = 1.0;
            g.roughness = 0.08;
        }
    }
    g
}

/// The built-in scene with `env`, its G-buffer of every fourth pixel with each sample's key.
fn scene_samples(env: Environment) -> (World, Vec<(GSample, u64)>) {
    let mut scene = builtin::depth_range().unwrap();
    scene.environment = env;
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let camera = EyeCamera::from_desc(&desc, &display).unwrap();
    let gs: Vec<(GSample, u64)> = (0..display.height_px)
        .step_by(4)
        .flat_map(|y| (0..display.width_px).step_by(4).map(move |x| (x, y)))
        .map(|(x, y)| {
            let ray = camera.ray(ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5));
            // Frames and eyes vary from sample to sample, so the frame's rotation is checked.
            let noise = FrameNoise::new(u64::from(x / 4 + 3 * (y / 4)) % 97, (x / 4) & 1);
            let key = with_frame(texel_key(0, x, y), noise);
            (trace_sample(&world, &ray, 1e-3), key)
        })
        .filter(|(g, _)| g.is_hit())
        .enumerate()
        .map(|(k, (g, key))| (variant(&g, k % 5), key))
        .collect();
    (world, gs)
}

/// Compares the GPU's estimate with the CPU's on every sample: (samples beyond 1e-4
/// relative, the worst relative error, GPU rays, CPU rays).
fn compare(name: &str, env: Environment, samples: u32) {
    let Some(ctx) = gpu_or_skip(name) else {
        return;
    };
    let (world, gs) = scene_samples(env);
    assert!(gs.len() > 50_000, "{} hits", gs.len());
    let gpu = GpuTracer::new(&ctx, &world.tris.vertex_arrays()).unwrap();
    let genv = GpuEnvironment::new(&ctx, &world.scene.environment).unwrap();
    let surfaces: Vec<GpuSurface> = gs.iter().map(|(g, k)| GpuSurface::keyed(g, *k)).collect();
    assert!(surfaces.iter().zip(&gs).all(|(s, (_, k))| s.key() == *k));
    let (got, times) = gpu
        .environment_light_timed(&surfaces, &genv, samples)
        .unwrap();
    assert_eq!(got.len(), gs.len());
    let mut counts = RayCounts::default();
    let mode = EnvLight::Occluded { samples };
    let (mut off, mut gpu_rays, mut worst, mut lit) = (0usize, 0u64, 0.0f32, 0usize);
    let mut per_variant = [0usize; 5];
    for (k, ((g, key), e)) in gs.iter().zip(&got).enumerate() {
        let want = environment_light(&world, g, mode, *key, &mut counts);
        let have = Vec3::from(e.radiance);
        let err = (have - want).abs().max_element() / want.max_element().max(1e-3);
        worst = worst.max(err);
        if err > 1e-4 {
            off += 1;
            per_variant[k % 5] += 1;
        }
        lit += usize::from(want.max_element() > 0.0);
        gpu_rays += u64::from(e.rays);
    }
    shout(&format!(
        "[fovea-gpu] {name}: environment light of {} samples ({lit} lit), {samples} rays \
         each: {off} beyond 1e-4 relative (by material {per_variant:?}, worst {worst:.3e}); \
         rays GPU {gpu_rays}, CPU {}; pass {:?} ms",
        gs.len(),
        counts.environment,
        times.gpu_pass_ms
    ));
    assert!(lit * 2 > gs.len(), "only {lit} samples lit");
    assert!(
        off * 1000 <= gs.len(),
        "{off} of {} samples differ",
        gs.len()
    );
    let (a, b) = (gpu_rays as f64, counts.environment as f64);
    assert!((a - b).abs() <= 1e-4 * b, "rays GPU {a}, CPU {b}");
}

#[test]
fn the_environment_light_of_a_constant_on_the_gpu_is_the_renderers() {
    compare(
        "environment_light_constant",
        Environment::Constant(Vec3::new(0.6, 0.8, 1.0)),
        8,
    );
}

#[test]
fn the_environment_light_of_a_map_on_the_gpu_is_the_renderers() {
    compare("environment_light_map", Environment::Map(sun_and_sky()), 8);
}

#[test]
fn the_environment_light_refuses_bad_input_and_skips_black_environments() {
    let Some(ctx) = gpu_or_skip("environment_light_refuses_bad_input") else {
        return;
    };
    let tri = [[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]]];
    let gpu = GpuTracer::new(&ctx, &tri).unwrap();
    let s = GpuSurface {
        position: [0.0, 0.0, 0.0],
        normal: [0.0, 0.0, 1.0],
        face_normal: [0.0, 0.0, 1.0],
        to_eye: [0.0, 0.0, 1.0],
        albedo: [0.5; 3],
        roughness: 1.0,
        t: 1.0,
        ..GpuSurface::default()
    };
    let white = GpuEnvironment::new(&ctx, &Environment::Constant(Vec3::ONE)).unwrap();
    // A Lambertian surface under a constant sky: every ray adds albedo · L / n exactly.
    let (out, _) = gpu.environment_light_timed(&[s], &white, 4).unwrap();
    assert_eq!(out[0].rays, 4);
    assert!(
        out[0].radiance.iter().all(|&c| (c - 0.5).abs() < 1e-4),
        "{out:?}"
    );
    // No rays: black, none cast.
    let black = GpuEnvironment::new(&ctx, &Environment::Constant(Vec3::ZERO)).unwrap();
    for (env, n) in [(&black, 4), (&white, 0)] {
        let (out, _) = gpu.environment_light_timed(&[s], env, n).unwrap();
        assert_eq!((out[0].radiance, out[0].rays), ([0.0; 3], 0));
    }
    assert!(gpu
        .environment_light_timed(&[], &white, 4)
        .unwrap()
        .0
        .is_empty());
    let bad = GpuSurface { t: f32::NAN, ..s };
    match gpu.environment_light_timed(&[s, bad], &white, 4) {
        Err(GpuError::Input(m)) => assert!(m.contains("surface sample 1"), "{m}"),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        gpu.environment_light_timed(&[s], &white, 100_000),
        Err(GpuError::Input(_))
    ));
}
