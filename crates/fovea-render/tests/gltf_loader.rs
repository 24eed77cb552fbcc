//! glTF loader tests: tiny files built in code, a corpus of malformed files
//! (`tests/corpus/gltf/`), byte-level corruption of a valid GLB, and the real scenes in
//! `../shared/scenes` when that folder exists.

use std::path::{Path, PathBuf};
use std::time::Instant;

use fovea_render::scene::{gltf, texture::srgb_to_linear, Light, Scene};
use fovea_render::RenderError;
use glam::{Vec2, Vec3, Vec4};
use serde_json::{json, Value};

// ---------------------------------------------------------------------------------------------
// Building tiny glTF files
// ---------------------------------------------------------------------------------------------

/// Accumulates one binary buffer with its views and accessors.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn push_view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.push(json!({
            "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()
        }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn floats(&mut self, data: &[f32], ty: &str, count: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": count, "type": ty
        }));
        self.accessors.len() - 1
    }

    fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let flat: Vec<f32> = p.iter().flatten().copied().collect();
        let a = self.floats(&flat, "VEC3", p.len());
        let finite: Vec<&[f32; 3]> = p
            .iter()
            .filter(|v| v.iter().all(|c| c.is_finite()))
            .collect();
        let (mut lo, mut hi) = ([0f32; 3], [0f32; 3]);
        for (k, (l, h)) in lo.iter_mut().zip(hi.iter_mut()).enumerate() {
            *l = finite.iter().map(|v| v[k]).fold(f32::INFINITY, f32::min);
            *h = finite
                .iter()
                .map(|v| v[k])
                .fold(f32::NEG_INFINITY, f32::max);
        }
        self.accessors[a]["min"] = json!(lo);
        self.accessors[a]["max"] = json!(hi);
        a
    }

    fn indices(&mut self, i: &[u32]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": i.len(), "type": "SCALAR"
        }));
        self.accessors.len() - 1
    }

    /// Adds `buffers`, `bufferViews`, `accessors` (buffer as a base64 data URI) to `doc`.
    fn finish(self, mut doc: Value) -> Value {
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{
            "byteLength": self.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64::encode(&self.bin))
        }]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        doc
    }

    /// The same as a GLB, the buffer in the BIN chunk.
    fn finish_glb(self, mut doc: Value) -> Vec<u8> {
        let mut bin = self.bin.clone();
        doc = self.finish(doc);
        doc["buffers"] = json!([{ "byteLength": bin.len() }]);
        let mut j = serde_json::to_vec(&doc).unwrap();
        while j.len() % 4 != 0 {
            j.push(b' ');
        }
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let total = 12 + 8 + j.len() + 8 + bin.len();
        let mut out = b"glTF".to_vec();
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((j.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(j);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(bin);
        out
    }
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// A document with one indexed triangle mesh (mesh 0) and the given nodes.
fn one_triangle(nodes: Value) -> (Builder, Value) {
    let mut b = Builder::default();
    let pos = b.positions(&TRI);
    let idx = b.indices(&[0, 1, 2]);
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}],
    });
    (b, doc)
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn write_json(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    write(
        dir,
        name,
        serde_json::to_string_pretty(doc).unwrap().as_bytes(),
    )
}

fn assert_close(a: Vec3, b: Vec3, tol: f32) {
    assert!(
        (a - b).abs().max_element() <= tol,
        "{a} vs {b} (tolerance {tol})"
    );
}

fn png_data_uri(rgba: [u8; 4]) -> String {
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba(rgba));
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    format!("data:image/png;base64,{}", base64::encode(&bytes))
}

// ---------------------------------------------------------------------------------------------
// Geometry, transforms, lights, cameras
// ---------------------------------------------------------------------------------------------

#[test]
fn node_transforms_are_composed_and_baked() {
    let dir = tempfile::tempdir().unwrap();
    let (mut b, mut doc) = one_triangle(json!([
        {"name": "parent", "translation": [1.0, 2.0, 3.0], "children": [1]},
        {"name": "child", "scale": [2.0, 2.0, 2.0], "mesh": 0}
    ]));
    let n = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3", 3);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(n);
    let path = write_json(dir.path(), "t.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangle_count(), 1);
    let bounds = scene.bounds().unwrap();
    assert_close(bounds.min, Vec3::new(1.0, 2.0, 3.0), 1e-6);
    assert_close(bounds.max, Vec3::new(3.0, 4.0, 3.0), 1e-6);
    assert_eq!(scene.meshes[0].normals, vec![Vec3::Z; 3]);
    assert_eq!(scene.metres_per_unit, 1.0);
    assert_eq!(scene.name, "t");
    // No material on the primitive → one default material.
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(scene.meshes[0].material, 0);
}

#[test]
fn rotation_applies_to_positions_and_normals_and_instances_share_a_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let (mut b, mut doc) = one_triangle(json!([
        {"children": [1, 2]},
        {"rotation": [0.0, s, 0.0, s], "mesh": 0},
        {"translation": [10.0, 0.0, 0.0], "mesh": 0}
    ]));
    let n = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3", 3);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(n);
    let path = write_json(dir.path(), "r.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.meshes.len(), 2);
    // +90° about Y: x → −z, z → x.
    let m = &scene.meshes[0];
    assert_close(m.positions[1], Vec3::new(0.0, 0.0, -1.0), 1e-6);
    assert_close(m.normals[0], Vec3::X, 1e-6);
    assert_close(
        scene.meshes[1].positions[1],
        Vec3::new(11.0, 0.0, 0.0),
        1e-6,
    );
}

#[test]
fn punctual_lights_and_camera_are_in_world_space() {
    let dir = tempfile::tempdir().unwrap();
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let (b, mut doc) = one_triangle(json!([
        {"mesh": 0, "children": [1, 2, 3, 4, 5]},
        {"translation": [0.0, 5.0, 0.0], "children": [6]},
        {"name": "eye", "translation": [1.0, 2.0, 3.0], "rotation": [-s, 0.0, 0.0, s], "camera": 0},
        {"rotation": [0.0, s, 0.0, s], "translation": [0.0, 1.0, 0.0],
         "extensions": {"KHR_lights_punctual": {"light": 1}}},
        {"extensions": {"KHR_lights_punctual": {"light": 2}}},
        {"camera": 1},
        {"translation": [1.0, 0.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}
    ]));
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensionsRequired"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 10.0, "range": 7.0},
        {"type": "spot", "intensity": 2.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.4}},
        {"type": "directional", "intensity": 3.0}
    ]}});
    doc["cameras"] = json!([
        {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}},
        {"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.0, "zfar": 1.0}}
    ]);
    let path = write_json(dir.path(), "l.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();

    assert_eq!(scene.cameras.len(), 1, "orthographic camera skipped");
    assert!(scene.warnings.iter().any(|w| w.contains("orthographic")));
    let cam = &scene.cameras[0];
    assert_eq!(cam.name, "eye");
    assert_close(cam.position, Vec3::new(1.0, 2.0, 3.0), 1e-6);
    assert_close(cam.forward, Vec3::new(0.0, -1.0, 0.0), 1e-6);
    assert_close(cam.up, Vec3::new(0.0, 0.0, -1.0), 1e-6);
    assert!((cam.yfov_deg.unwrap() - 0.8f32.to_degrees()).abs() < 1e-4);

    assert_eq!(scene.lights.len(), 3);
    // Document order: the point light sits under node 1 (pre-order), before the spot.
    let mut point = None;
    let mut spot = None;
    let mut sun = None;
    for l in &scene.lights {
        match l {
            Light::Point { .. } => point = Some(l.clone()),
            Light::Spot { .. } => spot = Some(l.clone()),
            Light::Directional { .. } => sun = Some(l.clone()),
        }
    }
    assert_eq!(
        point.unwrap(),
        Light::Point {
            position: Vec3::new(1.0, 5.0, 0.0),
            intensity: Vec3::new(10.0, 5.0, 2.5),
            range: 7.0
        }
    );
    let Some(Light::Spot {
        position,
        direction,
        intensity,
        cos_inner,
        cos_outer,
        range,
    }) = spot
    else {
        panic!("no spot light")
    };
    assert_close(position, Vec3::new(0.0, 1.0, 0.0), 1e-6);
    assert_close(direction, Vec3::new(-1.0, 0.0, 0.0), 1e-6);
    assert_eq!(intensity, Vec3::splat(2.0));
    assert!((cos_inner - 0.2f32.cos()).abs() < 1e-6);
    assert!((cos_outer - 0.4f32.cos()).abs() < 1e-6);
    assert_eq!(range, f32::INFINITY);
    assert_eq!(
        sun.unwrap(),
        Light::Directional {
            direction: Vec3::NEG_Z,
            irradiance: Vec3::splat(3.0)
        }
    );
}

#[test]
fn non_triangle_primitives_are_skipped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let (mut b, mut doc) = one_triangle(json!([{"mesh": 0}]));
    let lines = b.positions(&[[0.0, 0.0, 0.0], [5.0, 5.0, 5.0]]);
    doc["meshes"][0]["primitives"]
        .as_array_mut()
        .unwrap()
        .push(json!({"attributes": {"POSITION": lines}, "mode": 1}));
    let path = write_json(dir.path(), "lines.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangle_count(), 1);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("non-triangle") && w.contains("Lines")),
        "{:?}",
        scene.warnings
    );
    assert!(
        scene.bounds().unwrap().max.x <= 1.0,
        "line vertices not used"
    );
}

#[test]
fn triangle_strips_and_fans_are_triangulated_with_consistent_winding() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let strip = b.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 2.0, 0.0],
    ]);
    let fan = b.positions(&[
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ]);
    let fan_idx = b.indices(&[0, 1, 2, 3]);
    let doc = b.finish(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": strip}, "mode": 5},
            {"attributes": {"POSITION": fan}, "indices": fan_idx, "mode": 6}
        ]}]
    }));
    let path = write_json(dir.path(), "strip.gltf", &doc);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.meshes.len(), 2);
    assert_eq!(scene.meshes[0].indices.len(), 3, "strip of 5 vertices");
    assert_eq!(scene.meshes[1].indices.len(), 2, "fan of 4 vertices");
    for m in &scene.meshes {
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!(
                (b - a).cross(c - a).z > 0.0,
                "{} triangle {t:?} faces −Z",
                m.name
            );
        }
    }
}

#[test]
fn non_indexed_sparse_and_quantized_accessors_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    // Base positions all at the origin except through a sparse substitution of vertex 1 and 2.
    let pos_view = b.push_view(&[0u8; 36]);
    let sparse_idx = b.push_view(&[1u8, 2u8]);
    let sparse_val: Vec<u8> = [1f32, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let sparse_val = b.push_view(&sparse_val);
    // Normalized unsigned-short UVs.
    let uv_bytes: Vec<u8> = [0u16, 0, 65535, 0, 0, 65535]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let uv_view = b.push_view(&uv_bytes);
    b.accessors.push(json!({
        "bufferView": pos_view, "componentType": 5126, "count": 3, "type": "VEC3",
        "min": [0, 0, 0], "max": [1, 1, 0],
        "sparse": {"count": 2,
                   "indices": {"bufferView": sparse_idx, "componentType": 5121},
                   "values": {"bufferView": sparse_val}}
    }));
    b.accessors.push(json!({
        "bufferView": uv_view, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC2"
    }));
    let doc = b.finish(json!({
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}}]}]
    }));
    let path = write_json(dir.path(), "sparse.gltf", &doc);
    let scene = Scene::load(&path).unwrap();
    let m = &scene.meshes[0];
    assert_eq!(m.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
    assert_eq!(m.indices, vec![[0, 1, 2]]);
    assert_eq!(m.uvs, vec![Vec2::ZERO, Vec2::X, Vec2::Y]);
}

// ---------------------------------------------------------------------------------------------
// Materials and textures
// ---------------------------------------------------------------------------------------------

#[test]
fn materials_and_embedded_textures_are_decoded_once_per_colour_space() {
    let dir = tempfile::tempdir().unwrap();
    let (b, mut doc) = one_triangle(json!([{"mesh": 0}]));
    let p = &mut doc["meshes"][0]["primitives"];
    p[0]["material"] = json!(0);
    p.as_array_mut().unwrap().push(json!({
        "attributes": {"POSITION": 0}, "indices": 1, "material": 1
    }));
    doc["images"] = json!([{"uri": png_data_uri([128, 128, 255, 255]), "name": "grey"}]);
    doc["textures"] = json!([{"source": 0}, {"source": 0}]);
    doc["materials"] = json!([
        {"name": "a", "doubleSided": true,
         "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 1.0],
                                  "baseColorTexture": {"index": 0},
                                  "metallicFactor": 0.3, "roughnessFactor": 0.6,
                                  "metallicRoughnessTexture": {"index": 1}},
         "normalTexture": {"index": 1, "scale": 0.5},
         "emissiveFactor": [1.0, 2.0, 0.0]},
        {"name": "b", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}}
    ]);
    let path = write_json(dir.path(), "m.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.materials.len(), 2, "no default material needed");
    // One image, used as colour (sRGB) and as data (linear): two textures.
    assert_eq!(scene.textures.len(), 2);
    let a = &scene.materials[0];
    assert_eq!(a.name, "a");
    assert_eq!(a.base_color, Vec3::new(0.5, 0.25, 1.0));
    assert_eq!((a.metallic, a.roughness), (0.3, 0.6));
    assert_eq!(a.normal_scale, 0.5);
    assert_eq!(a.emissive, Vec3::new(1.0, 2.0, 0.0));
    assert!(a.two_sided);
    assert!(!scene.materials[1].two_sided);
    let (bc, mr, nt) = (
        a.base_color_texture.unwrap(),
        a.metallic_roughness_texture.unwrap(),
        a.normal_texture.unwrap(),
    );
    assert_ne!(bc, mr);
    assert_eq!(mr, nt);
    assert_eq!(scene.materials[1].base_color_texture, Some(bc));
    let uv = Vec2::splat(0.5);
    let srgb = scene.textures[bc as usize].sample(uv, 0.0);
    let lin = scene.textures[mr as usize].sample(uv, 0.0);
    let expect = |c: f32| Vec4::new(c, c, 1.0, 1.0);
    assert!(
        (srgb - expect(srgb_to_linear(128.0 / 255.0)))
            .abs()
            .max_element()
            < 1e-6
    );
    assert!((lin - expect(128.0 / 255.0)).abs().max_element() < 1e-6);
}

#[test]
fn missing_external_texture_warns_and_loads_with_flat_colour() {
    let dir = tempfile::tempdir().unwrap();
    let (b, mut doc) = one_triangle(json!([{"mesh": 0}]));
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["images"] = json!([{"uri": "textures/gone%20missing.png"}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"name": "paint",
        "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1.0],
                                 "baseColorTexture": {"index": 0}}}]);
    let path = write_json(dir.path(), "tex.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.materials[0].base_color_texture, None);
    assert_eq!(scene.materials[0].base_color, Vec3::new(0.2, 0.4, 0.6));
    assert!(scene.textures.is_empty());
    let w = scene
        .warnings
        .iter()
        .find(|w| w.contains("missing texture"))
        .expect("a missing-texture warning");
    assert!(w.contains("using flat colour"), "{w}");
    assert!(
        w.contains("gone missing.png"),
        "percent-decoded path in {w}"
    );
}

#[test]
fn emissive_texture_becomes_its_mean_colour() {
    let dir = tempfile::tempdir().unwrap();
    let (b, mut doc) = one_triangle(json!([{"mesh": 0}]));
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["images"] = json!([{"uri": png_data_uri([255, 0, 0, 255])}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    doc["materials"] = json!([{"emissiveFactor": [1.0, 1.0, 1.0],
        "emissiveTexture": {"index": 0},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}]);
    let path = write_json(dir.path(), "e.gltf", &b.finish(doc));
    let scene = Scene::load(&path).unwrap();
    assert_close(scene.materials[0].emissive, Vec3::new(4.0, 0.0, 0.0), 1e-5);
    assert!(scene.textures.is_empty(), "emissive-only image not kept");
}

// ---------------------------------------------------------------------------------------------
// Errors
// ---------------------------------------------------------------------------------------------

#[test]
fn draco_required_is_unsupported_before_buffers_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let (b, mut doc) = one_triangle(json!([{"mesh": 0}]));
    let mut doc2 = {
        doc["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
        doc["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
        b.finish(doc)
    };
    doc2["buffers"][0]["uri"] = json!("not-there.bin");
    let path = write_json(dir.path(), "d.gltf", &doc2);
    match Scene::load(&path) {
        Err(RenderError::Unsupported(m)) => {
            assert!(
                m.contains("Draco") && m.contains("KHR_draco_mesh_compression"),
                "{m}"
            )
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

#[test]
fn truncated_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (b, doc) = one_triangle(json!([{"mesh": 0}]));
    let glb = b.finish_glb(doc.clone());
    let path = write(dir.path(), "ok.glb", &glb);
    assert_eq!(Scene::load(&path).unwrap().triangle_count(), 1);
    let path = write(dir.path(), "half.glb", &glb[..glb.len() / 2]);
    assert!(matches!(
        Scene::load(&path),
        Err(RenderError::BadInput { .. })
    ));

    let (b, doc) = one_triangle(json!([{"mesh": 0}]));
    let text = serde_json::to_vec_pretty(&b.finish(doc)).unwrap();
    let path = write(dir.path(), "ok.gltf", &text);
    assert_eq!(Scene::load(&path).unwrap().triangle_count(), 1);
    let path = write(dir.path(), "half.gltf", &text[..text.len() / 2]);
    match Scene::load(&path) {
        Err(RenderError::BadInput { what, .. }) => assert!(what.contains("JSON"), "{what}"),
        other => panic!("expected BadInput, got {other:?}"),
    }
}

#[test]
fn nan_vertex_is_rejected_by_validation() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.positions(&[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let doc = b.finish(json!({
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]
    }));
    let path = write_json(dir.path(), "nan.gltf", &doc);
    match Scene::load(&path) {
        Err(RenderError::BadInput { what, .. }) => assert!(what.contains("non-finite"), "{what}"),
        other => panic!("expected BadInput, got {other:?}"),
    }
}

#[test]
fn garbage_and_missing_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let noise: Vec<u8> = (0..1000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    for name in ["noise.gltf", "noise.glb"] {
        let path = write(dir.path(), name, &noise);
        assert!(matches!(
            Scene::load(&path),
            Err(RenderError::BadInput { .. })
        ));
    }
    let mut fake = b"glTF".to_vec();
    fake.extend_from_slice(&noise);
    let path = write(dir.path(), "fake.glb", &fake);
    assert!(Scene::load(&path).is_err());
    let path = write(dir.path(), "empty.gltf", b"");
    assert!(matches!(
        Scene::load(&path),
        Err(RenderError::BadInput { .. })
    ));
    let missing = dir.path().join("nope.gltf");
    assert!(matches!(gltf::load(&missing), Err(RenderError::Io { .. })));
    assert!(matches!(Scene::load(&missing), Err(RenderError::Io { .. })));
}

#[test]
fn every_truncation_and_byte_corruption_of_a_glb_is_handled_without_panicking() {
    let (mut b, mut doc) = one_triangle(json!([
        {"translation": [1.0, 0.0, 0.0], "children": [1]},
        {"mesh": 0, "camera": 0, "extensions": {"KHR_lights_punctual": {"light": 0}}}
    ]));
    let n = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3", 3);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(n);
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [{"type": "point"}]}});
    doc["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}]);
    let glb = b.finish_glb(doc);
    let path = Path::new("corrupt.glb");
    let mut ok = 0;
    let mut check = |bytes: &[u8]| {
        if let Ok(mut scene) = gltf::load_from_bytes(path, bytes) {
            if scene.validate().is_ok() {
                ok += 1;
            }
        }
    };
    check(&glb);
    for len in 0..glb.len() {
        check(&glb[..len]);
    }
    for at in 0..glb.len() {
        for v in [0x00, 0xFF, glb[at] ^ 0x20, glb[at].wrapping_add(1)] {
            let mut c = glb.clone();
            c[at] = v;
            check(&c);
        }
    }
    assert!(ok > 0, "the unmodified file loads");
}

// ---------------------------------------------------------------------------------------------
// Corpus of malformed files
// ---------------------------------------------------------------------------------------------

/// What loading a corpus file must give.
#[derive(Debug)]
enum Expect {
    Io,
    BadInput(&'static str),
    Unsupported(&'static str),
    ResourceLimit,
    /// Loads; a warning contains the text.
    OkWarning(&'static str),
    Ok,
}

const CORPUS: &[(&str, Expect)] = &[
    (
        "accessor-out-of-bounds.gltf",
        Expect::BadInput("do not fit"),
    ),
    ("bad-base64.gltf", Expect::BadInput("base64")),
    ("bad-json.gltf", Expect::BadInput("JSON")),
    ("bad-percent-uri.gltf", Expect::Io),
    ("buffer-too-short.gltf", Expect::BadInput("byteLength")),
    ("draco-required.gltf", Expect::Unsupported("Draco")),
    ("empty.gltf", Expect::BadInput("JSON")),
    ("exponential-instancing.gltf", Expect::ResourceLimit),
    ("float-indices.gltf", Expect::BadInput("unsigned")),
    ("garbage.glb", Expect::BadInput("JSON")),
    ("glb-chunk-too-long.glb", Expect::BadInput("truncated")),
    ("glb-header-length-too-small.glb", Expect::BadInput("GLB")),
    ("glb-version-1.glb", Expect::BadInput("version 1")),
    ("gltf-1.gltf", Expect::Unsupported("glTF 1.0")),
    ("http-buffer.gltf", Expect::Unsupported("http")),
    (
        "index-accessor-out-of-bounds.gltf",
        Expect::BadInput("do not fit"),
    ),
    (
        "index-out-of-range.gltf",
        Expect::BadInput("only 3 vertices"),
    ),
    ("invalid-mode.gltf", Expect::BadInput("mode")),
    (
        "light-index-out-of-range.gltf",
        Expect::BadInput("Index out of bounds"),
    ),
    (
        "lines-only.gltf",
        Expect::BadInput("no (non-degenerate) triangles"),
    ),
    (
        "meshopt-required.gltf",
        Expect::Unsupported("EXT_meshopt_compression"),
    ),
    ("missing-buffer.gltf", Expect::Io),
    ("missing-texture.gltf", Expect::OkWarning("missing texture")),
    ("nan-vertex.gltf", Expect::BadInput("non-finite")),
    ("node-cycle.gltf", Expect::BadInput("cycle")),
    (
        "position-index-out-of-range.gltf",
        Expect::BadInput("POSITION"),
    ),
    (
        "primitive-without-position.gltf",
        Expect::OkWarning("without POSITION"),
    ),
    ("stride-too-small.gltf", Expect::BadInput("byteStride")),
    ("truncated.glb", Expect::BadInput("truncated")),
    ("truncated.gltf", Expect::BadInput("JSON")),
    (
        "undecodable-texture.gltf",
        Expect::OkWarning("missing texture"),
    ),
    ("valid-triangle.glb", Expect::Ok),
    ("valid-triangle.gltf", Expect::Ok),
    (
        "wrong-position-type.gltf",
        Expect::BadInput("expected 3 components"),
    ),
    (
        "zero-count.gltf",
        Expect::BadInput("no (non-degenerate) triangles"),
    ),
];

#[test]
fn corpus_of_malformed_files_gives_the_documented_results() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/gltf");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".gltf") || n.ends_with(".glb"))
        .collect();
    on_disk.sort();
    let listed: Vec<String> = CORPUS.iter().map(|(n, _)| n.to_string()).collect();
    assert_eq!(
        on_disk, listed,
        "every corpus file has an expectation (sorted)"
    );
    for (name, expect) in CORPUS {
        let path = dir.join(name);
        assert!(
            std::fs::metadata(&path).unwrap().len() < 4096,
            "{name} ≥ 4 KB"
        );
        let got = Scene::load(&path);
        let ok = match (&got, expect) {
            (Err(RenderError::Io { .. }), Expect::Io) => true,
            (Err(RenderError::BadInput { what, .. }), Expect::BadInput(s)) => what.contains(s),
            (Err(RenderError::Unsupported(m)), Expect::Unsupported(s)) => m.contains(s),
            (Err(RenderError::ResourceLimit { .. }), Expect::ResourceLimit) => true,
            (Ok(scene), Expect::OkWarning(s)) => scene.warnings.iter().any(|w| w.contains(s)),
            (Ok(scene), Expect::Ok) => scene.triangle_count() == 1,
            _ => false,
        };
        assert!(ok, "{name}: expected {expect:?}, got {got:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Real scenes
// ---------------------------------------------------------------------------------------------

fn shared_scenes() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipping: ../shared/scenes not found");
        None
    }
}

#[test]
fn flight_helmet_loads_with_its_textures() {
    let Some(dir) = shared_scenes() else { return };
    let t = Instant::now();
    let scene = Scene::load(&dir.join("flight-helmet/FlightHelmet.gltf")).unwrap();
    println!(
        "FlightHelmet.gltf: {} triangles, {} textures in {:.3} s; warnings {:?}",
        scene.triangle_count(),
        scene.textures.len(),
        t.elapsed().as_secs_f64(),
        scene.warnings
    );
    assert_eq!(scene.triangle_count(), 94_722);
    assert_eq!(scene.materials.len(), 6);
    assert!(scene
        .materials
        .iter()
        .all(|m| m.base_color_texture.is_some()
            && m.normal_texture.is_some()
            && m.metallic_roughness_texture.is_some()));
    assert_eq!(scene.textures.len(), 15);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let b = scene.bounds().unwrap();
    assert_close(b.min, Vec3::new(-0.204, 0.000, -0.172), 1e-3);
    assert_close(b.max, Vec3::new(0.163, 0.716, 0.200), 1e-3);
}

#[test]
fn chess_board_plain_loads_and_the_draco_original_is_unsupported() {
    let Some(dir) = shared_scenes() else { return };
    let file = dir.join("chess-board/chess-board.plain.glb");
    // Before validation: every triangle of the file (SOURCE.md: 178,848).
    let raw = gltf::load(&file).unwrap();
    assert_eq!(raw.triangle_count(), 178_848);
    let t = Instant::now();
    let scene = Scene::load(&file).unwrap();
    println!(
        "chess-board.plain.glb: {} triangles, {} textures in {:.3} s; warnings {:?}",
        scene.triangle_count(),
        scene.textures.len(),
        t.elapsed().as_secs_f64(),
        scene.warnings
    );
    // Scene::validate drops 3 zero-area triangles of the file, with a warning.
    assert_eq!(scene.triangle_count(), 178_845);
    assert!(scene
        .warnings
        .iter()
        .any(|w| w.contains("dropped 3 degenerate")));
    assert_eq!(scene.materials.len(), 3);
    assert_eq!(scene.textures.len(), 8);
    let b = scene.bounds().unwrap();
    assert_close(b.min, Vec3::new(-157.49, -1.35, -136.49), 0.05);
    assert_close(b.max, Vec3::new(179.57, 42.25, 136.49), 0.05);
    assert!(scene.meshes.iter().any(|m| !m.tangents.is_empty()));

    match Scene::load(&dir.join("chess-board/chess-board.glb")) {
        Err(RenderError::Unsupported(m)) => assert!(m.contains("Draco"), "{m}"),
        other => panic!("expected Unsupported, got {:?}", other.map(|s| s.name)),
    }
}
