//! The GPU trace (`GpuTracer`, `shaders/trace.wgsl`) against brute force over every triangle
//! and against the CPU renderer's BVH (obvhs' compressed wide BVH) on the built-in scene.
//!
//! Tolerances: `t` within 1e-4 relative (f32, the shader may fuse multiply-adds where the CPU
//! rounds each product); the same triangle except where another lies at the same distance
//! within that tolerance (a ray through a shared edge hits either); a hit on one side and a
//! miss on the other for at most 1 ray in 10,000 (a ray grazing an edge, decided by the last
//! bit of a barycentric coordinate).

mod common;

use common::gpu_or_skip;
use fovea_core::display::DisplayProfile;
use fovea_core::units::ScreenPoint;
use fovea_gpu::{GpuError, GpuRay, GpuTracer};
use fovea_render::bvh::{intersect_triangle, Backend, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::scene::builtin;
use fovea_render::world::World;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

type Tri = [[f32; 3]; 3];

fn ray_of(r: &GpuRay) -> Ray {
    Ray {
        origin: Vec3::from(r.origin),
        dir: Vec3::from(r.dir),
        t_min: r.t_min,
        t_max: r.t_max,
    }
}

/// The closest hit over every triangle: `(t, triangle)`, the first triangle on a tie.
fn brute_closest(tris: &[Tri], r: &GpuRay) -> Option<(f32, u32)> {
    let ray = ray_of(r);
    let mut best: Option<(f32, u32)> = None;
    for (k, t) in tris.iter().enumerate() {
        let v = [Vec3::from(t[0]), Vec3::from(t[1]), Vec3::from(t[2])];
        if let Some((d, _, _)) = intersect_triangle(&ray, &v) {
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, k as u32));
            }
        }
    }
    best
}

/// `t` of `tri` along `r`, if it is hit.
fn t_of(tris: &[Tri], tri: u32, r: &GpuRay) -> Option<f32> {
    let t = tris[tri as usize];
    let v = [Vec3::from(t[0]), Vec3::from(t[1]), Vec3::from(t[2])];
    intersect_triangle(&ray_of(r), &v).map(|h| h.0)
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-4 * a.abs().max(b.abs()).max(1.0)
}

/// 2,000 triangles with centres in a 10 m cube and edges up to 1 m.
fn soup(rng: &mut Pcg64) -> Vec<Tri> {
    (0..2000)
        .map(|_| {
            let c: [f32; 3] = std::array::from_fn(|_| rng.random_range(-5.0..5.0));
            std::array::from_fn(|_| std::array::from_fn(|k| c[k] + rng.random_range(-0.5..0.5)))
        })
        .collect()
}

/// Random rays from a 16 m cube, plus axis-aligned ones with ±0 components (the slab test's
/// hard case), some with finite `t_max`.
fn rays(rng: &mut Pcg64, n: usize) -> Vec<GpuRay> {
    (0..n)
        .map(|i| {
            let origin: [f32; 3] = std::array::from_fn(|_| rng.random_range(-8.0..8.0));
            let dir: [f32; 3] = if i % 10 == 0 {
                let axis = i / 10 % 3;
                let sign = if i / 30 % 2 == 0 { 1.0 } else { -1.0 };
                std::array::from_fn(|k| {
                    if k == axis {
                        sign
                    } else if i % 20 == 0 {
                        -0.0
                    } else {
                        0.0
                    }
                })
            } else {
                let d = Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize_or(Vec3::Z);
                d.into()
            };
            let t_max = if i % 3 == 0 {
                rng.random_range(1.0..20.0)
            } else {
                f32::INFINITY
            };
            GpuRay {
                origin,
                t_min: 1e-4,
                dir,
                t_max,
            }
        })
        .collect()
}

#[test]
fn closest_hits_on_the_gpu_equal_brute_force() {
    let Some(ctx) = gpu_or_skip("closest_hits_on_the_gpu_equal_brute_force") else {
        return;
    };
    let mut rng = Pcg64::seed_from_u64(18);
    let tris = soup(&mut rng);
    let rays = rays(&mut rng, 20_000);
    let gpu = GpuTracer::new(&ctx, &tris).unwrap();
    let stats = gpu.stats();
    assert_eq!(stats.triangles, tris.len());
    assert!(stats.depth > 5 && stats.depth <= 65, "{stats:?}");
    let hits = gpu.closest_hits(&rays).unwrap();
    assert_eq!(hits.len(), rays.len());
    // The timed call: the same hits, one batch, and where the device writes timestamps the
    // pass's time, positive and finite (no time is compared).
    let (timed, times) = gpu.closest_hits_timed(&rays).unwrap();
    assert_eq!(timed, hits);
    assert_eq!(times.batches, 1, "{times:?}");
    assert!(
        times.total_ms.is_finite() && times.total_ms > 0.0,
        "{times:?}"
    );
    match times.gpu_pass_ms {
        Some(ms) => assert!(ms.is_finite() && ms > 0.0, "{times:?}"),
        None => assert!(!ctx.has_timestamps(), "{times:?}"),
    }
    let (mut hit_count, mut disagree) = (0, 0);
    for (r, (g, c)) in rays.iter().zip(
        hits.iter()
            .zip(rays.iter().map(|r| brute_closest(&tris, r))),
    ) {
        match (g, c) {
            (None, None) => {}
            (Some(g), Some((t, tri))) => {
                hit_count += 1;
                assert!(close(g.t, t), "{r:?}: GPU t {} against {t}", g.t);
                if g.tri != tri {
                    let other = t_of(&tris, g.tri, r).expect("the GPU's triangle is hit");
                    assert!(
                        close(other, t),
                        "{r:?}: GPU tri {} at {other}, CPU {tri} at {t}",
                        g.tri
                    );
                }
                let [u, v] = g.bary;
                assert!(u >= 0.0 && v >= 0.0 && u + v <= 1.0 + 1e-6, "{g:?}");
            }
            _ => disagree += 1,
        }
    }
    println!(
        "{hit_count} of {} rays hit; {disagree} hit on one side only; {stats:?}",
        rays.len()
    );
    assert!(
        hit_count > rays.len() / 10,
        "too few hits to test anything: {hit_count}"
    );
    assert!(
        disagree * 10_000 <= rays.len(),
        "{disagree} rays disagree on hit/miss"
    );
}

#[test]
fn occlusion_on_the_gpu_equals_brute_force() {
    let Some(ctx) = gpu_or_skip("occlusion_on_the_gpu_equals_brute_force") else {
        return;
    };
    let mut rng = Pcg64::seed_from_u64(21);
    let tris = soup(&mut rng);
    let rays = rays(&mut rng, 20_000);
    let gpu = GpuTracer::new(&ctx, &tris).unwrap();
    let occluded = gpu.occluded(&rays).unwrap();
    let disagree = rays
        .iter()
        .zip(&occluded)
        .filter(|(r, &o)| o != brute_closest(&tris, r).is_some())
        .count();
    let blocked = occluded.iter().filter(|&&o| o).count();
    println!(
        "{blocked} of {} rays occluded; {disagree} disagree",
        rays.len()
    );
    assert!(blocked > rays.len() / 10 && blocked < rays.len());
    assert!(disagree * 10_000 <= rays.len(), "{disagree} rays disagree");
}

#[test]
fn the_built_in_scene_traces_as_the_cpu_renderer_does() {
    let Some(ctx) = gpu_or_skip("the_built_in_scene_traces_as_the_cpu_renderer_does") else {
        return;
    };
    let scene = builtin::depth_range().unwrap();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let camera = EyeCamera::from_desc(&desc, &display).unwrap();
    let tris: Vec<Tri> = world.tris.vertex_arrays();
    let gpu = GpuTracer::new(&ctx, &tris).unwrap();
    // Primary rays through every 3rd pixel each way.
    let primary: Vec<GpuRay> = (0..display.height_px)
        .step_by(3)
        .flat_map(|y| (0..display.width_px).step_by(3).map(move |x| (x, y)))
        .map(|(x, y)| {
            let r = camera.ray(ScreenPoint {
                x_px: x as f64 + 0.5,
                y_px: y as f64 + 0.5,
            });
            GpuRay {
                origin: r.origin.into(),
                t_min: r.t_min,
                dir: r.dir.into(),
                t_max: r.t_max,
            }
        })
        .collect();
    let hits = gpu.closest_hits(&primary).unwrap();
    let (mut hit_count, mut other_tri, mut disagree) = (0, 0, 0);
    let mut shadow = Vec::new();
    let light = Vec3::new(0.3, 2.5, 1.0);
    for (r, g) in primary.iter().zip(&hits) {
        let c = world.caster.intersect(&ray_of(r));
        match (g, c) {
            (None, None) => {}
            (Some(g), Some(c)) => {
                hit_count += 1;
                assert!(close(g.t, c.t), "{r:?}: GPU {g:?}, CPU {c:?}");
                if g.tri != c.tri {
                    other_tri += 1;
                    let t = t_of(&tris, g.tri, r).expect("the GPU's triangle is hit");
                    assert!(close(t, c.t), "{r:?}: GPU {g:?}, CPU {c:?}");
                }
                // A shadow ray from the hit towards a point light above the scene.
                let p = Vec3::from(r.origin) + Vec3::from(r.dir) * c.t;
                let n = world.face_normal(c.tri);
                let n = if n.dot(Vec3::from(r.dir)) > 0.0 {
                    -n
                } else {
                    n
                };
                let o = p + n * 1e-3;
                let to = light - o;
                shadow.push(GpuRay {
                    origin: o.into(),
                    t_min: 0.0,
                    dir: to.normalize().into(),
                    t_max: to.length(),
                });
            }
            _ => disagree += 1,
        }
    }
    println!(
        "{hit_count} of {} primary rays hit; {other_tri} on another triangle at the same t; \
         {disagree} hit on one side only",
        primary.len()
    );
    assert!(hit_count > primary.len() / 2);
    assert!(
        disagree * 10_000 <= primary.len(),
        "{disagree} rays disagree"
    );
    assert!(
        other_tri * 1_000 <= hit_count,
        "{other_tri} hits on other triangles"
    );
    let occluded = gpu.occluded(&shadow).unwrap();
    let shadow_disagree = shadow
        .iter()
        .zip(&occluded)
        .filter(|(r, &o)| o != world.caster.occluded(&ray_of(r)))
        .count();
    let blocked = occluded.iter().filter(|&&o| o).count();
    println!(
        "{blocked} of {} shadow rays occluded; {shadow_disagree} disagree",
        shadow.len()
    );
    assert!(blocked > 0 && blocked < shadow.len());
    assert!(
        shadow_disagree * 10_000 <= shadow.len(),
        "{shadow_disagree} shadow rays disagree"
    );
}

#[test]
fn empty_scenes_bad_triangles_and_bad_rays() {
    let Some(ctx) = gpu_or_skip("empty_scenes_bad_triangles_and_bad_rays") else {
        return;
    };
    let ray = GpuRay {
        origin: [0.0, 0.0, 1.0],
        t_min: 0.0,
        dir: [0.0, 0.0, -1.0],
        t_max: f32::INFINITY,
    };
    let empty = GpuTracer::new(&ctx, &[]).unwrap();
    assert_eq!(empty.closest_hits(&[ray]).unwrap(), vec![None]);
    assert_eq!(empty.occluded(&[ray]).unwrap(), vec![false]);
    let bad = [[[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]]];
    match GpuTracer::new(&ctx, &bad) {
        Err(GpuError::Input(m)) => assert!(m.contains("triangle 0"), "{m}"),
        other => panic!(
            "expected an input error, got {:?}",
            other.map(|t| t.stats())
        ),
    }
    let one = GpuTracer::new(
        &ctx,
        &[[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]]],
    )
    .unwrap();
    let nan = GpuRay {
        origin: [f32::NAN, 0.0, 1.0],
        ..ray
    };
    let backwards = GpuRay {
        t_min: 2.0,
        t_max: 1.0,
        ..ray
    };
    let hits = one.closest_hits(&[ray, nan, backwards]).unwrap();
    let h = hits[0].expect("the straight ray hits the triangle");
    assert!((h.t - 1.0).abs() < 1e-6 && h.tri == 0, "{h:?}");
    assert_eq!(&hits[1..], &[None, None]);
    assert_eq!(one.closest_hits(&[]).unwrap(), vec![]);
}

/// Degenerate geometry (issue 39): 20,000 copies of one triangle, 5,000 different triangles
/// sharing one box, and a soup. The tree is built over one copy and a balanced subtree per
/// box (`fovea_render::bvh::same_box`), stays shallow, and the GPU's closest hits match brute
/// force's (a copy's hit is reported as its first occurrence, which brute force also picks).
#[test]
fn duplicate_and_same_box_triangles_trace_as_brute_force() {
    let Some(ctx) = gpu_or_skip("duplicate_and_same_box_triangles_trace_as_brute_force") else {
        return;
    };
    let mut rng = Pcg64::seed_from_u64(39);
    let mut tris = soup(&mut rng);
    let one: Tri = [[-2.0, -2.0, 0.5], [3.0, -1.0, 0.5], [0.0, 3.0, 0.6]];
    tris.extend(std::iter::repeat_n(one, 20_000));
    tris.extend((0..5000).map(|k| {
        let s = 0.4 * k as f32 / 5000.0;
        [
            [-4.0, -4.0, -1.0],
            [4.0, 4.0, -1.0],
            [-4.0 + 8.0 * s, 4.0 - 8.0 * s, -1.0],
        ]
    }));
    let gpu = GpuTracer::new(&ctx, &tris).unwrap();
    let stats = gpu.stats();
    assert_eq!(stats.triangles, tris.len());
    assert!(stats.depth <= 65, "{stats:?}");
    let rays = rays(&mut rng, 4000);
    let hits = gpu.closest_hits(&rays).unwrap();
    let (mut hit_count, mut disagree) = (0, 0);
    for (r, g) in rays.iter().zip(&hits) {
        match (g, brute_closest(&tris, r)) {
            (None, None) => {}
            (Some(g), Some((t, tri))) => {
                hit_count += 1;
                assert!(close(g.t, t), "{r:?}: GPU t {} against {t}", g.t);
                if g.tri != tri {
                    let other = t_of(&tris, g.tri, r).expect("the GPU's triangle is hit");
                    assert!(
                        close(other, t),
                        "{r:?}: GPU tri {} at {other}, CPU {tri}",
                        g.tri
                    );
                }
                // Never a later copy of the repeated triangle.
                assert!(tris[g.tri as usize] != one || g.tri == 2000, "{g:?}");
            }
            _ => disagree += 1,
        }
    }
    println!(
        "{hit_count} of {} rays hit; {disagree} on one side only; {stats:?}",
        rays.len()
    );
    assert!(hit_count > rays.len() / 10, "{hit_count}");
    assert!(
        disagree * 1000 <= rays.len(),
        "{disagree} rays disagree on hit/miss"
    );
}
