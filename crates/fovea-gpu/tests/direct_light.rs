//! The GPU's direct light against the renderer's (`fovea_render::shade::direct`): the
//! built-in scene (a sun and four point lights) with a spot light added, the G-buffer of every
//! other pixel of the Vive Pro Eye view, each sample's radiance and shadow-ray count. The
//! shading arithmetic is f32 on both sides in the same order, but not bit for bit (the GPU may
//! fuse multiply-adds), and a shadow ray that grazes an edge may be answered differently, so:
//! at least 99.9 % of the samples within 1e-4 relative (above 1e-3 absolute), and the shadow
//! rays counted alike within 0.01 %.
//!
//! Needs a GPU adapter (lavapipe will do); without one it says SKIPPED on stderr, and fails
//! under FOVEA_REQUIRE_GPU=1.

mod common;

use common::{gpu_or_skip, shout};
use fovea_core::display::DisplayProfile;
use fovea_core::units::ScreenPoint;
use fovea_gpu::{DirectLightModel, GpuError, GpuLight, GpuSurface, GpuTracer};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::scene::{builtin, Light};
use fovea_render::shade::{direct, RayCounts};
use fovea_render::trace::{trace_sample, GSample};
use fovea_render::world::World;
use glam::Vec3;

#[test]
fn direct_light_on_the_gpu_is_the_renderers() {
    let Some(ctx) = gpu_or_skip("direct_light_on_the_gpu_is_the_renderers") else {
        return;
    };
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
    let world = World::new(scene, Backend::Obvhs).unwrap();
    assert!(world.lights.len() >= 6);
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let camera = EyeCamera::from_desc(&desc, &display).unwrap();
    let gs: Vec<GSample> = (0..display.height_px)
        .step_by(2)
        .flat_map(|y| (0..display.width_px).step_by(2).map(move |x| (x, y)))
        .map(|(x, y)| {
            let ray = camera.ray(ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5));
            trace_sample(&world, &ray, 1e-3)
        })
        .filter(GSample::is_hit)
        .collect();
    assert!(gs.len() > 100_000, "{} hits", gs.len());
    let gpu = GpuTracer::new(&ctx, &world.tris.vertex_arrays()).unwrap();
    let surfaces: Vec<GpuSurface> = gs.iter().map(GpuSurface::of).collect();
    let lights: Vec<GpuLight> = world.lights.iter().map(GpuLight::of).collect();
    let (got, times) = gpu
        .direct_light_timed(&surfaces, &lights, &DirectLightModel::RENDERER)
        .unwrap();
    assert_eq!(got.len(), gs.len());
    assert!(times.batches >= 1);
    let mut counts = RayCounts::default();
    let (mut off, mut gpu_rays, mut worst) = (0usize, 0u64, 0.0f32);
    for (g, d) in gs.iter().zip(&got) {
        let want = direct(&world, g, &mut counts);
        let have = Vec3::from(d.radiance);
        let err = (have - want).abs().max_element() / want.max_element().max(1e-3);
        worst = worst.max(err);
        off += usize::from(err > 1e-4);
        gpu_rays += u64::from(d.shadow_rays);
    }
    shout(&format!(
        "[fovea-gpu] direct light of {} samples, {} lights: {off} beyond 1e-4 relative \
         (worst {worst:.3e}); shadow rays GPU {gpu_rays}, CPU {}; pass {:?} ms",
        gs.len(),
        lights.len(),
        counts.shadow,
        times.gpu_pass_ms
    ));
    assert!(
        off * 1000 <= gs.len(),
        "{off} of {} samples differ",
        gs.len()
    );
    let (a, b) = (gpu_rays as f64, counts.shadow as f64);
    assert!((a - b).abs() <= 1e-4 * b, "shadow rays GPU {a}, CPU {b}");
}

#[test]
fn direct_light_refuses_non_finite_input_and_handles_empty_batches() {
    let Some(ctx) = gpu_or_skip("direct_light_refuses_non_finite_input") else {
        return;
    };
    let tri = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
    let gpu = GpuTracer::new(&ctx, &tri).unwrap();
    let model = DirectLightModel::RENDERER;
    let light = GpuLight {
        position: [0.0, 0.0, 2.0],
        kind: GpuLight::POINT,
        intensity: [1.0; 3],
        range: f32::INFINITY,
        ..GpuLight::default()
    };
    let lit = GpuSurface {
        position: [0.2, 0.2, 0.0],
        normal: [0.0, 0.0, 1.0],
        face_normal: [0.0, 0.0, 1.0],
        to_eye: [0.0, 0.0, 1.0],
        albedo: [0.5; 3],
        roughness: 0.5,
        t: 1.0,
        ..GpuSurface::default()
    };
    // An unbounded range is made finite on upload; the sample sees the light.
    let (out, _) = gpu.direct_light_timed(&[lit], &[light], &model).unwrap();
    assert_eq!(out[0].shadow_rays, 1);
    assert!(out[0].radiance.iter().all(|&c| c > 0.0), "{out:?}");
    // Empty batches, no lights.
    assert!(gpu
        .direct_light_timed(&[], &[light], &model)
        .unwrap()
        .0
        .is_empty());
    let (dark, _) = gpu.direct_light_timed(&[lit], &[], &model).unwrap();
    assert_eq!(dark[0].radiance, [0.0; 3]);
    // NaN anywhere is refused with the sample's or the light's index.
    let bad = GpuSurface { t: f32::NAN, ..lit };
    match gpu.direct_light_timed(&[lit, bad], &[light], &model) {
        Err(GpuError::Input(m)) => assert!(m.contains("surface sample 1"), "{m}"),
        other => panic!("{other:?}"),
    }
    let bad_light = GpuLight {
        intensity: [f32::NAN, 1.0, 1.0],
        ..light
    };
    match gpu.direct_light_timed(&[lit], &[light, bad_light], &model) {
        Err(GpuError::Input(m)) => assert!(m.contains("light 1"), "{m}"),
        other => panic!("{other:?}"),
    }
}
