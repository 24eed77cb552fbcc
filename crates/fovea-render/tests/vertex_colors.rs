//! Features that used to be dropped in silence (issue 21, item 6): vertex colours of glTF
//! (`COLOR_0`), OBJ (`v x y z r g b`) and PLY (`red green blue`) files are kept on the mesh
//! and multiplied into the albedo the shader reads, so a frame shows them; the glTF camera's
//! field of view is kept (and a warning says the display decides it); morph targets and a
//! Mitsuba shape's vertex colours are warnings.

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_render::bvh::{Backend, Ray};
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::scene::{texture::srgb_to_linear, Light, Scene};
use fovea_render::trace::trace_sample;
use fovea_render::world::World;
use glam::Vec3;

/// The quad x, y ∈ [-1, 1] at z = 0 facing +z, as four vertices and two triangles.
const QUAD: [[f32; 3]; 4] = [
    [-1.0, -1.0, 0.0],
    [1.0, -1.0, 0.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
];
const QUAD_TRIS: [u16; 6] = [0, 1, 2, 0, 2, 3];

/// A glTF of the quad with `COLOR_0` = `color` on every vertex, as float VEC3 (`u8 =
/// false`) or normalized unsigned-byte VEC4; a perspective camera with `yfov` 0.7 rad; and,
/// with `morph`, a morph target.
fn gltf_quad(color: [f32; 3], u8_colors: bool, morph: bool) -> String {
    let mut bin: Vec<u8> = QUAD
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let pos_len = bin.len();
    bin.extend(QUAD_TRIS.iter().flat_map(|i| i.to_le_bytes()));
    let color_offset = bin.len();
    let (color_accessor, color_len) = if u8_colors {
        for _ in 0..4 {
            bin.extend(color.map(|c| (c * 255.0).round() as u8));
            bin.push(255);
        }
        (
            r#"{"bufferView":2,"componentType":5121,"normalized":true,"count":4,"type":"VEC4"}"#,
            16,
        )
    } else {
        for _ in 0..4 {
            bin.extend(color.iter().flat_map(|f| f.to_le_bytes()));
        }
        (
            r#"{"bufferView":2,"componentType":5126,"count":4,"type":"VEC3"}"#,
            48,
        )
    };
    let targets = if morph {
        r#","targets":[{"POSITION":0}]"#
    } else {
        ""
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0}},{{"camera":0,"name":"view","translation":[0,0,3]}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.7,"znear":0.1}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"COLOR_0":2}},"indices":1{targets}}}]}}],
        "buffers":[{{"byteLength":{len},"uri":"data:application/octet-stream;base64,{b64}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}},
            {{"buffer":0,"byteOffset":{pos_len},"byteLength":12}},
            {{"buffer":0,"byteOffset":{color_offset},"byteLength":{color_len}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3",
            "min":[-1,-1,0],"max":[1,1,0]}},
            {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}},
            {color_accessor}]}}"#,
        len = bin.len(),
        b64 = base64::encode(&bin),
    )
}

/// The G-buffer albedo at the centre of the quad, seen from +z, under the default material.
fn albedo_at_centre(scene: Scene) -> Vec3 {
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let ray = Ray {
        origin: Vec3::new(0.1, 0.2, 3.0),
        dir: Vec3::NEG_Z,
        t_min: 0.0,
        t_max: f32::INFINITY,
    };
    let g = trace_sample(&world, &ray, 1e-3);
    assert!(g.is_hit());
    g.albedo
}

fn assert_close(a: Vec3, b: Vec3, tol: f32) {
    assert!((a - b).abs().max_element() <= tol, "{a} vs {b}");
}

#[test]
fn gltf_color_0_multiplies_the_albedo_and_shows_in_a_frame() {
    let dir = tempfile::tempdir().unwrap();
    let red = [0.9, 0.1, 0.05];
    for u8_colors in [false, true] {
        let p = dir.path().join(format!("quad{u8_colors}.gltf"));
        std::fs::write(&p, gltf_quad(red, u8_colors, false)).unwrap();
        let s = Scene::load(&p).unwrap();
        assert_eq!(s.meshes[0].colors.len(), 4);
        let tol = if u8_colors { 1.0 / 255.0 } else { 1e-6 };
        assert_close(s.meshes[0].colors[0], Vec3::from(red), tol);
        // Default material: grey 0.8 × the vertex colour (glTF: factor × texture × COLOR_0).
        let a = albedo_at_centre(s);
        assert_close(a, 0.8 * Vec3::from(red), 0.8 * tol + 1e-6);
    }
    // A frame of the file's own view: the quad is red in the middle of the image.
    let p = dir.path().join("quadfalse.gltf");
    let mut scene = Scene::load(&p).unwrap();
    scene.lights.push(Light::Directional {
        direction: Vec3::NEG_Z,
        irradiance: Vec3::splat(3.0),
    });
    let display = DisplayProfile::with_vertical_fov("t", 48, 32, Degrees(40.0)).unwrap();
    let camera = EyeCamera::from_desc(&scene.cameras[0], &display).unwrap();
    let world = World::new(scene, Backend::Obvhs).unwrap();
    let frame = render_frame(
        &world,
        &camera,
        &FrameSettings::new(Method::Full),
        display.centre_gaze(),
        &|_, _| {},
    )
    .unwrap();
    let c = frame.color.get(24, 16);
    assert!(c[0] > 5.0 * c[1] && c[0] > 5.0 * c[2], "{c:?}");
}

#[test]
fn obj_and_ply_vertex_colours_reach_the_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // OBJ: linear colours as written.
    let obj: String = QUAD
        .iter()
        .map(|v| format!("v {} {} {} 0.2 0.6 1.0\n", v[0], v[1], v[2]))
        .collect::<String>()
        + "f 1 2 3 4\n";
    std::fs::write(d.join("quad.obj"), &obj).unwrap();
    let s = Scene::load(&d.join("quad.obj")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.meshes[0].colors, vec![Vec3::new(0.2, 0.6, 1.0); 4]);
    assert_close(albedo_at_centre(s), 0.8 * Vec3::new(0.2, 0.6, 1.0), 1e-6);

    // OBJ with colours on some vertices only: ignored with a warning.
    let mixed = obj.replacen(" 0.2 0.6 1.0", "", 1);
    std::fs::write(d.join("mixed.obj"), mixed).unwrap();
    let s = Scene::load(&d.join("mixed.obj")).unwrap();
    assert!(s.meshes[0].colors.is_empty());
    assert!(
        s.warnings.iter().any(|w| w.contains("3 of 4 vertices")),
        "{:?}",
        s.warnings
    );

    // PLY: 8-bit colours are sRGB-encoded, float colours linear.
    for (ty, values, expect) in [
        (
            "uchar",
            "255 128 0",
            Vec3::new(1.0, srgb_to_linear(128.0 / 255.0), 0.0),
        ),
        ("float", "0.25 0.5 0.75", Vec3::new(0.25, 0.5, 0.75)),
    ] {
        let mut ply = format!(
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
             property float z\nproperty {ty} red\nproperty {ty} green\nproperty {ty} blue\n\
             element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        );
        for v in QUAD {
            ply += &format!("{} {} {} {values}\n", v[0], v[1], v[2]);
        }
        ply += "4 0 1 2 3\n";
        let p = d.join(format!("quad_{ty}.ply"));
        std::fs::write(&p, ply).unwrap();
        let s = Scene::load(&p).unwrap();
        assert_close(s.meshes[0].colors[0], expect, 1e-6);
        assert_close(albedo_at_centre(s), 0.8 * expect, 1e-6);
    }

    // Through Mitsuba, which shows vertex colours only through a texture: a warning.
    std::fs::write(
        d.join("scene.xml"),
        r#"<scene version="0.6.0"><shape type="ply"><string name="filename" value="quad_float.ply"/></shape></scene>"#,
    )
    .unwrap();
    let s = Scene::load(&d.join("scene.xml")).unwrap();
    assert!(s.meshes[0].colors.is_empty());
    assert!(
        s.warnings.iter().any(|w| w.contains("vertex colours")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn a_mesh_without_colours_keeps_its_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("plain.obj");
    std::fs::write(&p, "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n").unwrap();
    let s = Scene::load(&p).unwrap();
    assert!(s.meshes[0].colors.is_empty());
    assert_eq!(albedo_at_centre(s), Vec3::splat(0.8));
}

#[test]
fn gltf_camera_fov_is_kept_and_morph_targets_are_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("morph.gltf");
    std::fs::write(&p, gltf_quad([1.0; 3], false, true)).unwrap();
    let s = Scene::load(&p).unwrap();
    let fov = s.cameras[0].yfov_deg.unwrap();
    assert!((fov - 0.7f32.to_degrees()).abs() < 1e-4);
    // Used by the CLI for `--res` displays (tests/render_cli.rs), so no warning.
    assert!(
        !s.warnings.iter().any(|w| w.contains("field of view")),
        "{:?}",
        s.warnings
    );
    assert!(
        s.warnings.iter().any(|w| w.contains("morph targets")),
        "{:?}",
        s.warnings
    );
}
