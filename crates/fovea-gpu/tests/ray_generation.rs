//! Primary rays generated on the GPU (`ray_generation.wgsl`) against the CPU's: for VaFR,
//! KFR and visual-polar at the Vive Pro Eye with an off-centre gaze, one ray per texel of
//! every other column and row, placed from the mapping's rings (`Ring::polar` on the GPU,
//! `Ring::point` and `EyeCamera::ray` on the CPU) and traced through the built-in scene.
//! Both sides are f32 after the f64 ring, so: every direction within 1e-6 rad of the CPU's,
//! at least 99.9 % of the rays hitting the same triangle (a ray grazing an edge may go either
//! way), and those within 1e-4 relative in `t`.
//!
//! Needs a GPU adapter (lavapipe will do); without one it says SKIPPED on stderr, and fails
//! under FOVEA_REQUIRE_GPU=1.

mod common;

use common::{gpu_or_skip, shout};
use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{build, MappingConfig, Method};
use fovea_gpu::{GpuError, GpuPolarRay, GpuTracer, RayGenCamera};
use fovea_render::bvh::Backend;
use fovea_render::camera::EyeCamera;
use fovea_render::scene::builtin;
use fovea_render::world::World;

#[test]
fn rays_generated_on_the_gpu_are_the_cpus() {
    let Some(ctx) = gpu_or_skip("rays_generated_on_the_gpu_are_the_cpus") else {
        return;
    };
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let camera = EyeCamera::from_desc(&desc, &display).unwrap();
    let gpu = GpuTracer::new(&ctx, &world.tris.vertex_arrays()).unwrap();
    let gaze = display.gaze(700.0, 1100.0).unwrap();
    for method in [Method::Vafr, Method::Kfr, Method::VisualPolar] {
        let mapping = build(method, &display, gaze, &MappingConfig::default()).unwrap();
        let b = mapping.buffers()[0];
        let (mut polar, mut points) = (Vec::new(), Vec::new());
        for i in (0..b.width).step_by(2) {
            let Some(ring) = mapping.ring(0, i as f64 + 0.5) else {
                continue;
            };
            for j in (0..b.height).step_by(2) {
                let v = j as f64 + 0.5;
                if !mapping.is_shaded(0, i, j) {
                    continue;
                }
                if let (Some((r_px, turn)), Some(p)) = (ring.polar(v), ring.point(v)) {
                    polar.push(GpuPolarRay {
                        r_px: r_px as f32,
                        turn: turn as f32,
                    });
                    points.push(p);
                }
            }
        }
        assert!(polar.len() > 50_000, "{method}: {} rays", polar.len());
        let c = mapping.polar_layout().unwrap().centre;
        let cam = RayGenCamera::new(
            camera.position.into(),
            [camera.forward.into(), camera.right.into(), camera.up.into()],
            camera.focal_px(),
            camera.principal_point_px(),
            [c.x_px, c.y_px],
        );
        let (got, times) = gpu.closest_hits_polar_timed(&cam, &polar).unwrap();
        assert_eq!(got.len(), polar.len());
        let (mut worst_rad, mut same, mut hits, mut worst_t) = (0.0f64, 0usize, 0usize, 0.0f32);
        for ((dir, hit), p) in got.iter().zip(&points) {
            let ray = camera.ray(*p);
            let dot: f64 = (0..3).map(|k| dir[k] as f64 * ray.dir[k] as f64).sum();
            let cross = glam::DVec3::from(dir.map(f64::from))
                .cross(ray.dir.as_dvec3())
                .length();
            worst_rad = worst_rad.max(cross.atan2(dot));
            let cpu = world.caster.intersect(&ray);
            match (hit, cpu) {
                (Some(g), Some(c)) => {
                    hits += 1;
                    if g.tri == c.tri {
                        same += 1;
                        worst_t = worst_t.max((g.t - c.t).abs() / c.t.max(1e-6));
                    }
                }
                (None, None) => same += 1,
                _ => {}
            }
        }
        let agree = same as f64 / got.len() as f64;
        shout(&format!(
            "[fovea-gpu] {method} ray generation: {} rays ({hits} hits), direction within \
             {worst_rad:.2e} rad of the CPU's, {:.4} % the same triangle, t within {worst_t:.2e} \
             relative; {} batch(es), pass {:?} ms",
            got.len(),
            100.0 * agree,
            times.batches,
            times.gpu_pass_ms
        ));
        assert!(worst_rad <= 1e-6, "{method}: direction {worst_rad} rad off");
        assert!(agree >= 0.999, "{method}: {agree} of the rays agree");
        assert!(worst_t <= 1e-4, "{method}: t {worst_t} relative");
        assert!(hits > polar.len() / 2, "{method}: only {hits} hits");
    }
}

#[test]
fn non_finite_rays_and_cameras_are_input_errors() {
    let Some(ctx) = gpu_or_skip("non_finite_rays_and_cameras_are_input_errors") else {
        return;
    };
    let tri = [[[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [0.0, 1.0, -1.0]]];
    let gpu = GpuTracer::new(&ctx, &tri).unwrap();
    let axes = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let cam = RayGenCamera::new(
        [0.0; 3],
        axes,
        (500.0, 500.0),
        (320.0, 240.0),
        [320.0, 240.0],
    );
    let bad = [
        GpuPolarRay::default(),
        GpuPolarRay {
            r_px: f32::NAN,
            turn: 0.1,
        },
    ];
    let e = gpu.closest_hits_polar_timed(&cam, &bad).unwrap_err();
    assert!(
        matches!(e, GpuError::Input(_)) && e.to_string().contains("polar ray 1"),
        "{e}"
    );
    let nan_cam = RayGenCamera::new(
        [f32::NAN, 0.0, 0.0],
        axes,
        (500.0, 500.0),
        (320.0, 240.0),
        [320.0, 240.0],
    );
    let e = gpu
        .closest_hits_polar_timed(&nan_cam, &bad[..1])
        .unwrap_err();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    // The pole looks along the view axis when the centre is the principal point.
    let (got, _) = gpu.closest_hits_polar_timed(&cam, &bad[..1]).unwrap();
    let d = got[0].0;
    assert!((d[2] + 1.0).abs() < 1e-6 && d[0].abs() < 1e-6, "{d:?}");
    assert!(
        got[0].1.is_some(),
        "the triangle in front of the eye is hit"
    );
}
