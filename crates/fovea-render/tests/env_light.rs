//! The environment in direct shading goes through visibility (issue 17): scenes built in code
//! from triangles, checked against closed forms.
//!
//! * A closed box with a bright sky outside is black inside (every pixel exactly 0: every
//!   environment ray is occluded), while the old unshadowed ambient term lights it.
//! * A single upward quad under a constant sky `L` receives the whole sky: radiance
//!   `albedo · L` for a rough dielectric with `specular = 0` (Lambertian up to Schlick's
//!   grazing Fresnel term for the near-normal views used; cosine sampling is then exact per
//!   ray). Tolerance 0.5 % per pixel; measured 0.05 %.
//! * A room with one window, a partition with a doorway, a sun and a constant sky: the
//!   window wall's inner face and the part of the back room that sees neither the window nor
//!   the sun are exactly black; the floor under the window gets the window's projected solid
//!   angle × the sky × albedo/π (closed form by quadrature; within 5 %, measured 0.6 % with
//!   262,144 rays); the sun patch gets exactly the sun's `E cos θ · albedo/π` (0.5 %).
//! * The same room under an HDR environment map (a sky gradient and a small sun, written as
//!   OpenEXR and read back), default direct shading (4 rays): the frame's mean luma is within
//!   5 % of a one-bounce path-traced frame of the same view (the same integral, estimated by
//!   cosine sampling alone; measured ratio 1.03) and within a factor 2 of a 3-bounce one
//!   (measured 0.62: direct light leaves out the interreflections), and few pixels clip after
//!   the display tone curve (measured 0).

use std::f32::consts::PI;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_core::Image;
use fovea_post::Rgb;
use fovea_render::bvh::{Backend, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, AaMode, FrameSettings};
use fovea_render::scene::environment::file::load as load_envmap;
use fovea_render::scene::{CameraDesc, Environment, Light, Material, Mesh, Scene};
use fovea_render::shade::{shade, texel_key, EnvLight, RayCounts, ShadingMode};
use fovea_render::thin_lens::{render_window, Window};
use fovea_render::trace::trace_sample;
use fovea_render::world::World;
use glam::Vec3;

/// Triangles of a mesh under construction.
#[derive(Default)]
struct Builder {
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
}

impl Builder {
    /// The quad `origin + a·du + b·dv`, `a, b ∈ [0, 1]`.
    fn quad(&mut self, origin: Vec3, du: Vec3, dv: Vec3) -> &mut Self {
        let k = self.positions.len() as u32;
        self.positions
            .extend([origin, origin + du, origin + du + dv, origin + dv]);
        self.indices.push([k, k + 1, k + 2]);
        self.indices.push([k, k + 2, k + 3]);
        self
    }

    /// The axis-aligned box `[min, max]`, all six faces.
    fn cuboid(&mut self, min: Vec3, max: Vec3) -> &mut Self {
        let e = max - min;
        let (x, y, z) = (Vec3::X * e.x, Vec3::Y * e.y, Vec3::Z * e.z);
        self.quad(min, x, y)
            .quad(min + z, x, y)
            .quad(min, y, z)
            .quad(min + x, y, z)
            .quad(min, x, z)
            .quad(min + y, x, z)
    }

    fn mesh(&self, name: &str) -> Mesh {
        Mesh {
            name: name.into(),
            positions: self.positions.clone(),
            indices: self.indices.clone(),
            material: 0,
            ..Default::default()
        }
    }
}

/// A rough grey dielectric without specular reflectance: Lambertian up to Schlick's grazing
/// term.
fn matte(albedo: f32) -> Material {
    Material {
        specular: Vec3::ZERO,
        ..Material::diffuse("matte", Vec3::splat(albedo))
    }
}

fn scene(mesh: Mesh, albedo: f32, lights: Vec<Light>, environment: Environment) -> Scene {
    let mut s = Scene {
        name: "test".into(),
        meshes: vec![mesh],
        materials: vec![matte(albedo)],
        lights,
        environment,
        metres_per_unit: 1.0,
        ..Default::default()
    };
    s.validate().unwrap();
    s
}

fn direct(samples: u32) -> ShadingMode {
    ShadingMode::Direct {
        env_light: EnvLight::Occluded { samples },
    }
}

fn camera(position: Vec3, target: Vec3, w: u32, h: u32, fov_deg: f32) -> EyeCamera {
    let d = DisplayProfile::with_vertical_fov("test", w, h, Degrees(fov_deg as f64)).unwrap();
    let desc = CameraDesc::look_at("cam", position, target, None).unwrap();
    EyeCamera::from_desc(&desc, &d).unwrap()
}

fn window_frame(world: &World, cam: &EyeCamera, shading: ShadingMode) -> (Image<Rgb>, u64) {
    let d = &cam.display;
    let r = render_window(
        world,
        cam,
        Window::full(d.width_px, d.height_px),
        None,
        1,
        shading,
        &|_, _| {},
    )
    .unwrap();
    (r.color, r.rays)
}

fn luma(c: Rgb) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

#[test]
fn a_closed_box_under_a_bright_sky_is_black_inside() {
    let mut b = Builder::default();
    b.cuboid(Vec3::splat(-1.0), Vec3::splat(1.0));
    let env = Environment::Constant(Vec3::new(50.0, 60.0, 80.0));
    let world = World::new(scene(b.mesh("box"), 0.8, vec![], env), Backend::Obvhs).unwrap();
    let cam = camera(
        Vec3::new(0.2, -0.1, 0.3),
        Vec3::new(-0.5, -0.4, -1.0),
        48,
        36,
        100.0,
    );

    // Default direct shading (occluded, 4 rays), and many rays per sample.
    for shading in [ShadingMode::DIRECT, direct(32)] {
        let (img, rays) = window_frame(&world, &cam, shading);
        let worst = img
            .data()
            .iter()
            .flat_map(|c| c.iter().copied())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-6, "{shading:?}: a pixel reads {worst}");
        // The environment rays were cast (and counted) and all of them were occluded.
        assert!(rays > 48 * 36 * 2, "{rays} rays");
    }
    // The pipeline too (full resolution, no AA).
    let mut settings = FrameSettings::new(Method::Full);
    settings.aa = AaMode::None;
    let gaze = cam.display.gaze(24.0, 18.0).unwrap();
    let f = render_frame(&world, &cam, &settings, gaze, &|_, _| {}).unwrap();
    assert!(f
        .color
        .data()
        .iter()
        .all(|c| c.iter().all(|&v| v.abs() < 1e-6)));
    assert!(f.stats.rays_environment > 0);

    // The old ambient term lights the inside of the box through its walls.
    let (img, _) = window_frame(
        &world,
        &cam,
        ShadingMode::Direct {
            env_light: EnvLight::Unshadowed,
        },
    );
    assert!(img.data().iter().all(|c| c[0] > 1.0));
}

#[test]
fn an_open_plane_receives_the_whole_sky() {
    let mut b = Builder::default();
    b.quad(
        Vec3::new(-1000.0, 0.0, 1000.0),
        Vec3::new(2000.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2000.0),
    );
    let sky = Vec3::new(1.0, 0.5, 0.25);
    let albedo = 0.5;
    let world = World::new(
        scene(b.mesh("ground"), albedo, vec![], Environment::Constant(sky)),
        Backend::Obvhs,
    )
    .unwrap();
    // Looking straight down from 1 m, a 30° field: views within 15° of the normal.
    let cam = camera(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, -1e-3),
        32,
        32,
        30.0,
    );
    let want = sky * albedo;
    let mut worst = 0.0f32;
    for samples in [1, 4, 16] {
        let (img, _) = window_frame(&world, &cam, direct(samples));
        for c in img.data() {
            let rel = ((Vec3::from_array(*c) - want) / want).abs().max_element();
            worst = worst.max(rel);
        }
    }
    eprintln!("open plane: largest relative deviation from albedo · L = {worst:.2e}");
    assert!(worst < 5e-3, "{worst}");
}

/// A 4 × 3 × 4 m room (x, y, z), a 1 × 1 m window in the wall z = 4 (x 1.5–2.5, y 1–2), a
/// partition at z = 2 with a 1 × 2 m doorway at x 0–1 (materials are two-sided).
fn window_room() -> Mesh {
    let mut b = Builder::default();
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    b.quad(Vec3::ZERO, 4.0 * x, 4.0 * z) // floor
        .quad(3.0 * y, 4.0 * x, 4.0 * z) // ceiling
        .quad(Vec3::ZERO, 3.0 * y, 4.0 * z) // wall x = 0
        .quad(4.0 * x, 3.0 * y, 4.0 * z) // wall x = 4
        .quad(Vec3::ZERO, 4.0 * x, 3.0 * y); // back wall z = 0
                                             // Window wall z = 4 around the opening.
    let w0 = 4.0 * z;
    b.quad(w0, 1.5 * x, 3.0 * y)
        .quad(w0 + 2.5 * x, 1.5 * x, 3.0 * y)
        .quad(w0 + 1.5 * x, x, y)
        .quad(w0 + 1.5 * x + 2.0 * y, x, y);
    // Partition z = 2 with the doorway.
    let p0 = 2.0 * z;
    b.quad(p0 + x, 3.0 * x, 3.0 * y).quad(p0 + 2.0 * y, x, y);
    b.mesh("room")
}

/// The surface sample seen from `from` towards `to`.
fn surface(world: &World, from: Vec3, to: Vec3) -> fovea_render::trace::GSample {
    let g = trace_sample(
        world,
        &Ray {
            origin: from,
            dir: (to - from).normalize(),
            t_min: 0.0,
            t_max: f32::INFINITY,
        },
        0.0,
    );
    assert!(
        g.is_hit() && (g.position - to).length() < 1e-3,
        "{from} → {to}"
    );
    g
}

/// Mean over `keys` shading calls of `g` (different random numbers each).
fn mean_shade(
    world: &World,
    g: &fovea_render::trace::GSample,
    mode: ShadingMode,
    keys: u64,
) -> Vec3 {
    let mut counts = RayCounts::default();
    let sum: Vec3 = (0..keys)
        .map(|k| shade(world, g, mode, k * 7919 + 13, &mut counts))
        .sum();
    sum / keys as f32
}

/// `∫ cos θ_p cos θ_w / r² dA` over the window seen from `p` with normal `n`: the window's
/// projected solid angle (irradiance per unit sky radiance), by a 400 × 400 midpoint rule.
fn window_irradiance_per_radiance(p: Vec3, n: Vec3) -> f32 {
    let m = 400;
    let mut sum = 0.0f64;
    for i in 0..m {
        for j in 0..m {
            let q = Vec3::new(
                1.5 + (i as f32 + 0.5) / m as f32,
                1.0 + (j as f32 + 0.5) / m as f32,
                4.0,
            );
            let r = q - p;
            let d2 = r.length_squared();
            let rh = r / d2.sqrt();
            let cos_p = n.dot(rh).max(0.0);
            let cos_w = rh.z.max(0.0);
            sum += (cos_p * cos_w / d2) as f64 / (m * m) as f64;
        }
    }
    sum as f32
}

#[test]
fn a_room_is_lit_only_through_its_window() {
    let sky = Vec3::new(0.4, 0.5, 0.7);
    let sun_e = Vec3::new(3.0, 2.9, 2.7);
    let sun_dir = Vec3::new(0.0, -1.5, -1.0).normalize();
    let albedo = 0.6;
    let lights = vec![Light::Directional {
        direction: sun_dir,
        irradiance: sun_e,
    }];
    let world = World::new(
        scene(window_room(), albedo, lights, Environment::Constant(sky)),
        Backend::Obvhs,
    )
    .unwrap();
    let mode = direct(256);
    let centre = Vec3::new(2.0, 1.5, 3.0);

    // Black: the window wall's inner face (coplanar with the opening, facing away from the
    // sun), the back room's back wall and floor at x = 3.5 (the partition hides the window
    // from them; module header).
    let back = Vec3::new(3.0, 1.5, 1.0);
    for (from, p) in [
        (centre, Vec3::new(0.5, 2.5, 4.0)),
        (centre, Vec3::new(3.6, 0.5, 4.0)),
        (back, Vec3::new(3.5, 1.5, 0.0)),
        (back, Vec3::new(3.5, 0.0, 1.0)),
    ] {
        let g = surface(&world, from, p);
        let v = mean_shade(&world, &g, mode, 4);
        assert!(v.max_element() < 1e-6, "{p}: {v}");
    }

    // The floor under the window: sky through the window only (the sun is blocked by the
    // wall below the window), against the window's form factor.
    let c = Vec3::new(2.0, 0.0, 3.8);
    let g = surface(&world, centre, c);
    let v = mean_shade(&world, &g, mode, 1024);
    let want = sky * albedo / PI * window_irradiance_per_radiance(c, Vec3::Y);
    let rel = ((v - want) / want).abs().max_element();
    eprintln!(
        "floor under the window: {v} vs closed form {want} ({:.1} %)",
        rel * 100.0
    );
    assert!(rel < 0.05, "{v} vs {want}");

    // In the sun patch the sun adds exactly E cos θ · albedo/π (one shadow ray, no noise).
    let d = Vec3::new(2.0, 0.0, 3.0);
    let g = surface(&world, centre, d);
    let sun_only = mean_shade(&world, &g, direct(0), 1);
    let want_sun = sun_e * albedo / PI * (-sun_dir).dot(Vec3::Y);
    let rel = ((sun_only - want_sun) / want_sun).abs().max_element();
    assert!(rel < 5e-3, "sun: {sun_only} vs {want_sun}");
    let with_sky = mean_shade(&world, &g, mode, 8);
    assert!(
        with_sky.x > sun_only.x && with_sky.x < sun_only.x + 0.2,
        "{with_sky}"
    );
}

/// The environment rays of a 4×4 tile of texels are stratified over the tile (the module
/// header of `shade::env_light`): on the floor under the window, where the sky is visible
/// through the window only, the mean of a tile's 16 texels (4 rays each) lands much closer to
/// the window's form factor than the mean of 16 texels of 16 different tiles, and both are
/// unbiased.
#[test]
fn a_tile_of_texels_stratifies_its_environment_rays() {
    let sky = Vec3::new(0.4, 0.5, 0.7);
    let albedo = 0.6;
    let world = World::new(
        scene(window_room(), albedo, vec![], Environment::Constant(sky)),
        Backend::Obvhs,
    )
    .unwrap();
    let mode = direct(4);
    let c = Vec3::new(2.0, 0.0, 3.0);
    let g = surface(&world, Vec3::new(2.0, 1.5, 3.0), c);
    let want = (sky * albedo / PI * window_irradiance_per_radiance(c, Vec3::Y)).x as f64;
    let mut counts = RayCounts::default();
    let mut value = |key: u64| shade(&world, &g, mode, key, &mut counts).x as f64;
    let tiles = 256u32;
    // The mean of 16 texels: the 16 of tile `t`, or rank 0 of 16 different tiles.
    let (mut tile_err2, mut spread_err2, mut tile_sum, mut spread_sum) = (0.0, 0.0, 0.0, 0.0);
    for t in 0..tiles {
        let tile: f64 = (0..16)
            .map(|k| value(texel_key(0, 4 * t + k % 4, k / 4)))
            .sum::<f64>()
            / 16.0;
        let spread: f64 = (0..16)
            .map(|k| value(texel_key(0, 4 * (16 * t + k), 4)))
            .sum::<f64>()
            / 16.0;
        tile_err2 += (tile - want).powi(2);
        spread_err2 += (spread - want).powi(2);
        tile_sum += tile;
        spread_sum += spread;
    }
    let n = tiles as f64;
    let (tile_rms, spread_rms) = (
        (tile_err2 / n).sqrt() / want,
        (spread_err2 / n).sqrt() / want,
    );
    let (tile_mean, spread_mean) = (tile_sum / n / want, spread_sum / n / want);
    eprintln!(
        "16 texels of one tile: RMS {:.2} %, mean {tile_mean:.4}; of 16 tiles: RMS {:.2} %, \
         mean {spread_mean:.4} (× the closed form)",
        tile_rms * 100.0,
        spread_rms * 100.0
    );
    // Unbiased: within 3 standard errors of the mean (plus the quadrature's 1 %).
    assert!(
        (tile_mean - 1.0).abs() < 3.0 * tile_rms / n.sqrt() + 0.01,
        "{tile_mean}"
    );
    assert!(
        (spread_mean - 1.0).abs() < 3.0 * spread_rms / n.sqrt() + 0.01,
        "{spread_mean}"
    );
    assert!(tile_rms < 0.6 * spread_rms, "{tile_rms} vs {spread_rms}");
}

/// A 64 × 32 lat-long sky: a blue gradient above the horizon, a dim brown ground below, and a
/// 3 × 3-pixel sun of radiance 400 at 40° elevation towards +Z (the window's side).
fn sky_map_pixels() -> (u32, u32, Vec<f32>) {
    let (w, h) = (64u32, 32u32);
    let mut px = Vec::with_capacity((w * h * 3) as usize);
    for j in 0..h {
        for _ in 0..w {
            let v = (j as f32 + 0.5) / h as f32;
            let elevation_deg = 90.0 - 180.0 * v;
            let c = if elevation_deg > 0.0 {
                let t = elevation_deg / 90.0;
                Vec3::new(0.5, 0.7, 1.2) * (1.0 - 0.5 * t)
            } else {
                Vec3::new(0.12, 0.09, 0.06)
            };
            px.extend(c.to_array());
        }
    }
    // +Z is the image centre (u = 1/2); 40° elevation is v = 50/180.
    let (si, sj) = (32i64, (50.0 / 180.0 * h as f32) as i64);
    for dj in -1..=1 {
        for di in -1..=1 {
            let k = (((sj + dj) * w as i64 + si + di) * 3) as usize;
            px[k..k + 3].copy_from_slice(&[400.0, 380.0, 340.0]);
        }
    }
    (w, h, px)
}

#[test]
fn an_hdr_map_through_a_window_matches_path_tracing_in_the_mean() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h, px) = sky_map_pixels();
    let path = dir.path().join("sky.exr");
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::from_raw(w, h, px).unwrap())
        .save(&path)
        .unwrap();
    let map = load_envmap(&path).unwrap();
    assert_eq!((map.width(), map.height()), (64, 32));
    let world = World::new(
        scene(window_room(), 0.5, vec![], Environment::Map(map)),
        Backend::Obvhs,
    )
    .unwrap();
    // From the back of the front room towards the window and the floor below it.
    let cam = camera(
        Vec3::new(2.5, 1.6, 2.2),
        Vec3::new(2.0, 0.8, 3.9),
        128,
        96,
        70.0,
    );
    // The default: 4 environment rays per sample (2 from the map, 2 cosine-weighted).
    let (direct_img, _) = window_frame(&world, &cam, ShadingMode::DIRECT);
    let path = |bounces, spp| {
        window_frame(
            &world,
            &cam,
            ShadingMode::Path {
                bounces,
                spp,
                seed: 7,
            },
        )
        .0
    };
    let mean = |img: &Image<Rgb>| {
        img.data().iter().map(|&c| luma(c)).sum::<f64>() / img.data().len() as f64
    };
    // One bounce without lights is the environment's direct light, estimated by cosine
    // sampling alone: the same quantity as direct shading's MIS estimate.
    let (md, m1, m3) = (mean(&direct_img), mean(&path(1, 256)), mean(&path(3, 128)));
    eprintln!(
        "HDR map through a window: mean luma direct {md:.4}, path traced 1 bounce {m1:.4} \
         (ratio {:.3}), 3 bounces {m3:.4} (ratio {:.3})",
        md / m1,
        md / m3
    );
    assert!(
        (md / m1 - 1.0).abs() < 0.05,
        "direct {md} vs one bounce {m1}"
    );
    // Direct lighting leaves out the interreflections; within a factor 2 of the full path
    // tracer.
    assert!(
        (0.5..=1.0).contains(&(md / m3)),
        "direct {md} vs 3 bounces {m3}"
    );
    // Few pixels clip after the display tone curve (the sun itself may).
    let bytes = fovea_eval::metrics::display_srgb8(&direct_img);
    let clipped = bytes.chunks_exact(3).filter(|c| c.contains(&255)).count();
    let share = clipped as f64 / (bytes.len() / 3) as f64;
    eprintln!(
        "clipped pixels after the tone curve: {clipped} ({:.2} %)",
        share * 100.0
    );
    assert!(share < 0.02, "{share}");
}
