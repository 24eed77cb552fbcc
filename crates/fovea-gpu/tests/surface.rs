//! The G-buffer records the GPU interpolates (`surface.wgsl`) against the CPU's
//! `fovea_render::trace::surface` for the same rays:
//!
//! * the built-in scene with every branch of the surface model switched on — its textured
//!   materials given a metallic-roughness texture and a normal map, one mesh vertex colours,
//!   another mesh tangents (the rest derive their tangent frames from their UVs) — through
//!   screen rays over the whole Vive Pro Eye screen and polar rays around an off-centre gaze,
//!   with ray cones from 0 to 60 px wide (levels of detail from the base level to the
//!   coarsest, trilinear between);
//! * the classroom and the flight helmet (textures with mips, normal maps, tangents), when
//!   `../shared/scenes` is there.
//!
//! The CPU reference re-traces each ray along the direction the GPU cast it (`-to_eye` of the
//! record) and interpolates the surface at the CPU's hit. Both are f32, in a different order
//! of operations, so: at least 99.9 % of the rays agree on what they hit (the same material,
//! `t` within 1e-4 relative; a ray grazing an edge may go either way), and of those at least
//! 99.9 % have every field within 1e-5 (positions relative to `t`) and all within 2e-2 (a
//! level of detail on a mip boundary or the trilinear threshold may pick the other side).
//!
//! Needs a GPU adapter (lavapipe will do); without one it says SKIPPED on stderr, and fails
//! under FOVEA_REQUIRE_GPU=1.

mod common;

use std::path::Path;

use common::{gpu_or_skip, shout};
use fovea_core::display::DisplayProfile;
use fovea_gpu::{GpuContext, GpuSurfaceRay, GpuSurfaces, GpuTracer, RayGenCamera};
use fovea_render::bvh::{Backend, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::scene::{builtin, CameraDesc, Scene, Texture};
use fovea_render::trace::{surface, GSample};
use fovea_render::world::World;
use glam::{Vec3, Vec4};

/// The built-in scene with every attribute the surface model reads.
fn every_branch() -> Scene {
    let mut scene = builtin::depth_range().unwrap();
    let n = 16u32;
    // G: roughness, B: metalness, varying across the texture.
    let mr: Vec<Vec4> = (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f32 / n as f32, (k / n) as f32 / n as f32);
            Vec4::new(1.0, 0.2 + 0.8 * x, y, 1.0)
        })
        .collect();
    // A bumpy normal map (tangent space, encoded in [0, 1]).
    let normals: Vec<Vec4> = (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f32, (k / n) as f32);
            let t = Vec3::new((x * 0.7).sin() * 0.5, (y * 0.9).cos() * 0.5, 1.0).normalize();
            (t * 0.5 + Vec3::splat(0.5)).extend(1.0)
        })
        .collect();
    let mr_id = scene.textures.len() as u32;
    scene
        .textures
        .push(Texture::from_linear("mr", n, n, mr).unwrap());
    scene
        .textures
        .push(Texture::from_linear("normals", n, n, normals).unwrap());
    let mut textured = 0;
    for m in &mut scene.materials {
        if m.base_color_texture.is_some() {
            m.metallic = 0.6;
            m.metallic_roughness_texture = Some(mr_id);
            m.normal_texture = Some(mr_id + 1);
            m.normal_scale = 0.8;
            textured += 1;
        }
    }
    assert!(textured > 0, "the built-in scene has textured materials");
    let with_uvs: Vec<usize> = (0..scene.meshes.len())
        .filter(|&i| !scene.meshes[i].uvs.is_empty())
        .collect();
    assert!(with_uvs.len() >= 2, "two meshes with UVs");
    // Vertex colours on the first, tangents on the second.
    let m = &mut scene.meshes[with_uvs[0]];
    m.colors = (0..m.positions.len())
        .map(|k| Vec3::new(0.5 + 0.5 * (k % 2) as f32, 0.7, 0.3 + 0.1 * (k % 5) as f32))
        .collect();
    let m = &mut scene.meshes[with_uvs[1]];
    m.tangents = (0..m.positions.len())
        .map(|k| {
            let t = Vec3::new(1.0, 0.3 * (k % 3) as f32, 0.2).normalize();
            t.extend(if k % 2 == 0 { 1.0 } else { -1.0 })
        })
        .collect();
    scene
}

/// The camera block of `camera`, the rays' coordinates around `centre` (screen pixels).
fn block(camera: &EyeCamera, centre: [f64; 2]) -> RayGenCamera {
    RayGenCamera::new(
        camera.position.into(),
        [camera.forward.into(), camera.right.into(), camera.up.into()],
        camera.focal_px(),
        camera.principal_point_px(),
        centre,
    )
}

/// The ray cone of ray `k`: 0, then 0.5 to 60 pixels wide at the display's focal length.
fn spread(k: usize, focal_px: f32) -> f32 {
    let px = [0.0, 0.5, 1.0, 2.7, 7.0, 20.0, 60.0][k % 7];
    px / focal_px
}

/// How the GPU's records compare with the CPU's.
#[derive(Debug, Default)]
struct Agreement {
    rays: usize,
    hits: usize,
    /// Rays both sides hit the same surface with (or both missed).
    same: usize,
    /// Rays both sides hit the same surface with.
    shared: usize,
    /// Of the shared hits: every field within 1e-5.
    close: usize,
    /// The largest field difference of a shared hit.
    worst: f32,
}

fn largest_difference(a: &GSample, b: &GSample) -> f32 {
    let v = |x: Vec3, y: Vec3| (x - y).abs().max_element();
    [
        v(a.position, b.position) / a.t.max(1.0),
        v(a.normal, b.normal),
        v(a.face_normal, b.face_normal),
        v(a.to_eye, b.to_eye),
        v(a.albedo, b.albedo),
        v(a.specular, b.specular),
        v(a.emissive, b.emissive),
        (a.metallic - b.metallic).abs(),
        (a.roughness - b.roughness).abs(),
    ]
    .into_iter()
    .fold(0.0, f32::max)
}

/// The GPU's records `got` against the CPU's surfaces along the same directions.
fn compare(world: &World, camera: &EyeCamera, got: &[GSample], spreads: &[f32]) -> Agreement {
    let mut a = Agreement {
        rays: got.len(),
        ..Agreement::default()
    };
    for (g, &s) in got.iter().zip(spreads) {
        let ray = Ray {
            origin: camera.position,
            dir: -g.to_eye,
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let cpu = match world.caster.intersect(&ray) {
            Some(hit) => surface(world, &ray, &hit, s),
            None => GSample::miss(ray.dir),
        };
        if !cpu.is_hit() || !g.is_hit() {
            if cpu.is_hit() == g.is_hit() {
                a.same += 1;
                assert_eq!(g, &cpu, "a miss is GSample::miss of the direction");
            }
            continue;
        }
        a.hits += 1;
        if cpu.material != g.material || (cpu.t - g.t).abs() > 1e-4 * cpu.t {
            continue;
        }
        a.same += 1;
        a.shared += 1;
        let d = largest_difference(&cpu, g);
        assert!(
            d <= 2e-2,
            "field difference {d}\nGPU {g:?}\nCPU {cpu:?} (spread {s})"
        );
        a.worst = a.worst.max(d);
        if d <= 1e-5 {
            a.close += 1;
        }
    }
    a
}

fn check(what: &str, a: &Agreement) {
    shout(&format!(
        "[fovea-gpu] {what}: {} rays, {} hits; same surface {:.4} %, of those within 1e-5 \
         {:.4} %, worst field difference {:.2e}",
        a.rays,
        a.hits,
        100.0 * a.same as f64 / a.rays as f64,
        100.0 * a.close as f64 / (a.shared.max(1)) as f64,
        a.worst
    ));
    assert!(a.hits >= 1000, "{what}: a thousand rays hit ({a:?})");
    assert!(a.same as f64 >= 0.999 * a.rays as f64, "{what}: {a:?}");
    assert!(a.close as f64 >= 0.999 * a.shared as f64, "{what}: {a:?}");
}

/// Screen rays every `step` pixels over `display`'s whole screen, and polar rays around an
/// off-centre point, through `world`'s surfaces on the GPU against the CPU's.
fn screen_and_polar(ctx: &GpuContext, what: &str, world: &World, desc: &CameraDesc, step: usize) {
    let display = DisplayProfile::preset("vive-pro-eye").unwrap();
    let camera = EyeCamera::from_desc(desc, &display).unwrap();
    let tracer = GpuTracer::new(ctx, &world.tris.vertex_arrays()).unwrap();
    let surfaces = GpuSurfaces::new(&tracer, world).unwrap();
    let s = surfaces.stats();
    shout(&format!(
        "[fovea-gpu] {what}: {} triangles, {} vertices, {} materials, {} textures in {} \
         levels, {:.1} MB uploaded ({:.1} MB texels) in {:.0} ms",
        s.triangles,
        s.vertices,
        s.materials,
        s.textures,
        s.mip_levels,
        s.bytes as f64 / 1e6,
        s.texel_bytes as f64 / 1e6,
        s.upload_ms
    ));
    let focal = camera.focal_px().0;
    let (w, h) = (display.width_px as usize, display.height_px as usize);
    let rays: Vec<GpuSurfaceRay> = (0..h)
        .step_by(step)
        .flat_map(|y| (0..w).step_by(step).map(move |x| (x, y)))
        .enumerate()
        .map(|(k, (x, y))| GpuSurfaceRay::screen(x as f64 + 0.5, y as f64 + 0.5, spread(k, focal)))
        .collect();
    let spreads: Vec<f32> = rays.iter().map(|r| r.spread).collect();
    let (got, _) = tracer
        .surfaces_screen_timed(&surfaces, &block(&camera, [0.0, 0.0]), &rays)
        .unwrap();
    check(
        &format!("{what}, screen rays"),
        &compare(world, &camera, &got, &spreads),
    );
    // Polar rays: rings around a point off the centre, out to the corners.
    let centre = [0.3 * w as f64, 0.6 * h as f64];
    let reach = (w as f32).hypot(h as f32);
    let rings = (reach / step as f32) as usize;
    let rays: Vec<GpuSurfaceRay> = (0..rings)
        .flat_map(|i| (0..97).map(move |j| (i, j)))
        .enumerate()
        .map(|(k, (i, j))| {
            let (r_px, turn) = (i as f64 * step as f64, j as f64 / 97.0);
            GpuSurfaceRay::polar(r_px, turn, spread(k, focal)).unwrap()
        })
        .collect();
    let spreads: Vec<f32> = rays.iter().map(|r| r.spread).collect();
    let (got, _) = tracer
        .surfaces_polar_timed(&surfaces, &block(&camera, centre), &rays)
        .unwrap();
    check(
        &format!("{what}, polar rays"),
        &compare(world, &camera, &got, &spreads),
    );
}

#[test]
fn every_branch_of_the_surface_model_matches_the_cpu() {
    let Some(ctx) = gpu_or_skip("every_branch_of_the_surface_model_matches_the_cpu") else {
        return;
    };
    let scene = every_branch();
    let desc = scene.cameras[0].clone();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    screen_and_polar(&ctx, "built-in, every branch", &world, &desc, 5);
}

/// A camera of `world`: the scene's first, or one looking at its bounds' centre from outside.
fn camera_of(world: &World) -> CameraDesc {
    if let Some(c) = world.scene.cameras.first() {
        return c.clone();
    }
    let (lo, hi) = world.tris.verts.iter().flatten().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &v| (lo.min(v), hi.max(v)),
    );
    let centre = (lo + hi) * 0.5;
    let radius = (hi - lo).length() * 0.5;
    CameraDesc::look_at(
        "test",
        centre + Vec3::new(0.3, 0.2, 1.0).normalize() * radius * 0.9,
        centre,
        None,
    )
    .unwrap()
}

#[test]
fn shared_scenes_surfaces_match_the_cpu() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if !dir.is_dir() {
        shout("[fovea-gpu] shared_scenes_surfaces_match_the_cpu: skipping, ../shared/scenes not found");
        return;
    }
    let Some(ctx) = gpu_or_skip("shared_scenes_surfaces_match_the_cpu") else {
        return;
    };
    for (what, file) in [
        ("classroom", "japanese-classroom/scene.xml"),
        ("flight helmet", "flight-helmet/FlightHelmet.gltf"),
    ] {
        let scene = Scene::load(&dir.join(file)).unwrap();
        let world = World::new(scene, Backend::Obvhs).unwrap();
        let desc = camera_of(&world);
        screen_and_polar(&ctx, what, &world, &desc, 9);
    }
}

#[test]
fn surfaces_of_another_world_are_refused() {
    let Some(ctx) = gpu_or_skip("surfaces_of_another_world_are_refused") else {
        return;
    };
    let world = World::new(builtin::depth_range().unwrap(), Backend::Obvhs).unwrap();
    let mut fewer = world.tris.vertex_arrays();
    fewer.pop();
    let tracer = GpuTracer::new(&ctx, &fewer).unwrap();
    let e = GpuSurfaces::new(&tracer, &world).err().unwrap().to_string();
    assert!(e.contains("same world"), "{e}");
}
