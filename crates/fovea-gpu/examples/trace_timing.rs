//! Times the GPU trace (`GpuTracer`: a binary BVH from obvhs walked in WGSL) against the CPU
//! renderer's (obvhs' compressed wide BVH, rayon over all cores), side by side, on the primary
//! rays of a display and the shadow rays from their hits to a point light, and the primary
//! rays with the surface at each hit (the trace stage's G-buffer records: interpolated on the
//! device by `GpuSurfaces`, or from the device's hits on the CPU, or all on the CPU); median
//! of several runs after one warm-up each:
//!
//! ```sh
//! XDG_RUNTIME_DIR=$(mktemp -d) cargo run --release -p fovea-gpu --example trace_timing \
//!     [-- SCENE [PRESET [runs]]]
//! ```
//!
//! SCENE: a built-in scene name (default `depth-range`) or a scene file (its first camera, or
//! a framing view); PRESET: a display preset (default `vive-pro-eye`). Per executor and ray
//! kind: wall ms, Mrays/s, process CPU ms (summed over threads; on lavapipe the "GPU" is CPU
//! threads of this process, so its work shows there) and the CPU share (CPU ms / (wall ms ×
//! cores)), as `fovea bench` reports them. The GPU's time includes uploading the rays and
//! reading the hits back. Timing only; correctness is `tests/trace.rs`.

use std::path::Path;
use std::time::Instant;

use fovea_core::display::DisplayProfile;
use fovea_core::units::ScreenPoint;
use fovea_gpu::{GpuContext, GpuRay, GpuRequest, GpuTracer};
use fovea_render::bvh::{Backend, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::scene::{builtin, CameraDesc, Scene};
use fovea_render::trace::surface;
use fovea_render::world::World;
use glam::Vec3;
use rayon::prelude::*;

mod common;

use common::{cpu_ms, median};

/// Median wall and CPU ms of `runs` runs of `f` after one warm-up.
fn time(runs: usize, mut f: impl FnMut()) -> (f64, f64) {
    f();
    let (mut wall, mut cpu) = (Vec::new(), Vec::new());
    for _ in 0..runs {
        let (t, c) = (Instant::now(), cpu_ms());
        f();
        wall.push(t.elapsed().as_secs_f64() * 1e3);
        cpu.push(cpu_ms() - c);
    }
    (median(wall), median(cpu))
}

fn gpu_ray(r: &Ray) -> GpuRay {
    GpuRay {
        origin: r.origin.into(),
        t_min: r.t_min,
        dir: r.dir.into(),
        t_max: r.t_max,
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let scene_arg = args.next().unwrap_or_else(|| "depth-range".into());
    let preset = args.next().unwrap_or_else(|| "vive-pro-eye".into());
    let runs: usize = args.next().map_or(Ok(5), |r| r.parse())?;
    let runs = runs.max(1);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let scene = if scene_arg.contains('.') {
        Scene::load(Path::new(&scene_arg))?
    } else {
        builtin::by_name(&scene_arg)?
    };
    let desc = match scene.cameras.first() {
        Some(c) => c.clone(),
        None => {
            let b = scene.bounds().ok_or("the scene is empty")?;
            let c = b.centre();
            let e = b.extent().max_element();
            CameraDesc::look_at("framing", c + Vec3::new(0.0, 0.25 * e, 1.2 * e), c, None)?
        }
    };
    let world = World::new(scene, Backend::Obvhs)?;
    let display = DisplayProfile::preset(&preset)?;
    let camera = EyeCamera::from_desc(&desc, &display)?;
    let ctx = GpuContext::new(&GpuRequest::default())?;
    let tris = world.tris.vertex_arrays();
    let gpu = GpuTracer::new(&ctx, &tris)?;
    let s = gpu.stats();
    println!(
        "GPU: {} — {}; {cores} CPU cores; median of {runs} runs\nscene {} ({} triangles); \
         GPU BVH: {} nodes, depth {}, built in {:.0} ms; CPU BVH built in {:.0} ms",
        ctx.adapter(),
        ctx.adapter().driver,
        world.scene.name,
        s.triangles,
        s.nodes,
        s.depth,
        s.build_ms,
        world.build_ms
    );
    let primary: Vec<Ray> = (0..display.height_px)
        .flat_map(|y| (0..display.width_px).map(move |x| (x, y)))
        .map(|(x, y)| {
            camera.ray(ScreenPoint {
                x_px: x as f64 + 0.5,
                y_px: y as f64 + 0.5,
            })
        })
        .collect();
    let hits: Vec<_> = primary
        .par_iter()
        .map(|r| world.caster.intersect(r))
        .collect();
    let b = world.scene.bounds().ok_or("the scene is empty")?;
    let light = b.centre() + Vec3::new(0.0, 0.75 * b.extent().y, 0.0);
    let shadow: Vec<Ray> = primary
        .iter()
        .zip(&hits)
        .filter_map(|(r, h)| {
            let h = h.as_ref()?;
            let n = world.face_normal(h.tri);
            let n = if n.dot(r.dir) > 0.0 { -n } else { n };
            let o = r.origin + r.dir * h.t + n * 1e-3;
            let to = light - o;
            Some(Ray {
                origin: o,
                dir: to.normalize(),
                t_min: 0.0,
                t_max: to.length(),
            })
        })
        .collect();
    let gp: Vec<GpuRay> = primary.iter().map(gpu_ray).collect();
    let gs: Vec<GpuRay> = shadow.iter().map(gpu_ray).collect();
    println!(
        "\n{} {}x{}: {} primary rays ({} hit), {} shadow rays\n",
        display.name,
        display.width_px,
        display.height_px,
        primary.len(),
        shadow.len(),
        shadow.len()
    );
    println!("| rays | executor | wall ms | Mrays/s | CPU ms | CPU share |");
    println!("|---|---|---:|---:|---:|---:|");
    let row = |kind: &str, who: &str, n: usize, (wall, cpu): (f64, f64)| {
        println!(
            "| {kind} | {who} | {wall:.1} | {:.2} | {cpu:.1} | {:.0} % |",
            n as f64 / wall / 1e3,
            100.0 * cpu / (wall * cores as f64)
        );
    };
    let mut failed = None;
    let t = time(runs, || {
        if let Err(e) = gpu.closest_hits(&gp) {
            failed = Some(e);
        }
    });
    row("primary", "GPU", gp.len(), t);
    let t = time(runs, || {
        let _: Vec<_> = primary
            .par_iter()
            .map(|r| world.caster.intersect(r))
            .collect();
    });
    row("primary", "CPU", primary.len(), t);
    let t = time(runs, || {
        if let Err(e) = gpu.occluded(&gs) {
            failed = Some(e);
        }
    });
    row("shadow", "GPU", gs.len(), t);
    let t = time(runs, || {
        let _: Vec<_> = shadow
            .par_iter()
            .map(|r| world.caster.occluded(r))
            .collect();
    });
    row("shadow", "CPU", shadow.len(), t);
    // Primary rays with the surface at each hit (the G-buffer records of the trace stage),
    // generated from their screen points: interpolated on the device (`GpuSurfaces`), or hits
    // from the device and surfaces interpolated on the CPU (rayon), or all on the CPU.
    let surfaces = fovea_gpu::GpuSurfaces::new(&gpu, &world)?;
    let block = fovea_gpu::RayGenCamera::new(
        camera.position.into(),
        [camera.forward.into(), camera.right.into(), camera.up.into()],
        camera.focal_px(),
        camera.principal_point_px(),
        [0.0, 0.0],
    );
    let spread = 1.0 / camera.focal_px().0;
    let points: Vec<ScreenPoint> = (0..display.height_px)
        .flat_map(|y| (0..display.width_px).map(move |x| (x, y)))
        .map(|(x, y)| ScreenPoint {
            x_px: x as f64 + 0.5,
            y_px: y as f64 + 0.5,
        })
        .collect();
    let with_cones: Vec<fovea_gpu::GpuSurfaceRay> = points
        .iter()
        .map(|p| fovea_gpu::GpuSurfaceRay::screen(p.x_px, p.y_px, spread))
        .collect();
    let bare: Vec<fovea_gpu::GpuScreenRay> = points
        .iter()
        .map(|p| fovea_gpu::GpuScreenRay {
            x_px: p.x_px as f32,
            y_px: p.y_px as f32,
        })
        .collect();
    let t = time(runs, || {
        if let Err(e) = gpu.surfaces_screen_timed(&surfaces, &block, &with_cones) {
            failed = Some(e);
        }
    });
    row("primary + surfaces", "GPU", points.len(), t);
    let t = time(runs, || {
        match gpu.closest_hits_screen_timed(&block, &bare) {
            Ok((hits, _)) => {
                let _: Vec<_> = hits
                    .par_iter()
                    .map(|(dir, hit)| {
                        let ray = Ray {
                            origin: camera.position,
                            dir: Vec3::from(*dir),
                            t_min: 0.0,
                            t_max: f32::INFINITY,
                        };
                        hit.map(|h| {
                            let hit = fovea_render::bvh::Hit {
                                t: h.t,
                                tri: h.tri,
                                bary: h.bary.into(),
                            };
                            surface(&world, &ray, &hit, spread)
                        })
                    })
                    .collect();
            }
            Err(e) => failed = Some(e),
        }
    });
    row(
        "primary + surfaces",
        "GPU hits, CPU surfaces",
        points.len(),
        t,
    );
    let t = time(runs, || {
        let _: Vec<_> = points
            .par_iter()
            .map(|&p| {
                let ray = camera.ray(p);
                world
                    .caster
                    .intersect(&ray)
                    .map(|h| surface(&world, &ray, &h, spread))
            })
            .collect();
    });
    row("primary + surfaces", "CPU", points.len(), t);
    match failed {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}
