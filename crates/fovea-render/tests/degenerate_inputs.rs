//! Issue 39's loader cases: a deep glTF node chain flattens with the right transform, values
//! outside their physical range are refused or clamped with a warning naming the field and
//! the file, lights beyond the bound are cut to the strongest, and an environment map over
//! the memory budget is reduced with its mean radiance kept.

use std::path::{Path, PathBuf};

use glam::Vec3;

use fovea_render::scene::environment::file::decode_within;
use fovea_render::scene::{Environment, Light, LoadLimits, Scene};

/// A triangle's positions (0,0,0), (1,0,0), (0,1,0) as little-endian f32.
fn triangle_bin() -> Vec<u8> {
    [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// A glTF document with `nodes`, one triangle mesh (mesh 0) and the extra top-level members
/// `extra` (lights, cameras), written with its buffer into `dir`.
fn write_gltf(dir: &Path, name: &str, scene_nodes: &str, nodes: &str, extra: &str) -> PathBuf {
    std::fs::write(dir.join("tri.bin"), triangle_bin()).unwrap();
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_lights_punctual"],
        "scene":0,"scenes":[{{"nodes":[{scene_nodes}]}}],"nodes":[{nodes}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"uri":"tri.bin","byteLength":36}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
        "min":[0,0,0],"max":[1,1,0]}}]{extra}}}"#
    );
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn err_text<T: std::fmt::Debug>(r: fovea_render::Result<T>) -> String {
    r.unwrap_err().to_string()
}

#[test]
fn a_deep_node_chain_composes_every_transform() {
    let dir = tempfile::tempdir().unwrap();
    let n = 200_000usize;
    // Node k translates by (1, 0, 0) and has node k + 1 as its child; the last holds the mesh.
    let nodes: Vec<String> = (0..n)
        .map(|k| {
            if k + 1 < n {
                format!(r#"{{"translation":[1,0,0],"children":[{}]}}"#, k + 1)
            } else {
                r#"{"translation":[1,0,0],"mesh":0}"#.to_string()
            }
        })
        .collect();
    let p = write_gltf(dir.path(), "chain.gltf", "0", &nodes.join(","), "");
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.meshes.len(), 1);
    let x = s.meshes[0].positions[0].x;
    // Every translation is exact in f32 up to 2^24.
    assert_eq!(x, n as f32, "the mesh sits at the sum of {n} translations");
    // The same chain closed into a cycle (the last node points back to the first) is refused,
    // naming the cycle.
    let mut cyc = nodes.clone();
    cyc[n - 1] = r#"{"translation":[1,0,0],"mesh":0,"children":[0]}"#.to_string();
    let p = write_gltf(dir.path(), "cycle.gltf", "0", &cyc.join(","), "");
    let e = err_text(Scene::load(&p));
    assert!(e.contains("cycle"), "{e}");
}

/// One node with the mesh, and one with light 0 / camera 0.
fn with_light(dir: &Path, light: &str) -> PathBuf {
    write_gltf(
        dir,
        "light.gltf",
        "0,1",
        r#"{"mesh":0},{"translation":[0,0,2],"extensions":{"KHR_lights_punctual":{"light":0}}}"#,
        &format!(r#","extensions":{{"KHR_lights_punctual":{{"lights":[{light}]}}}}"#),
    )
}

#[test]
fn negative_and_non_finite_light_is_clamped_or_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let p = with_light(
        dir.path(),
        r#"{"type":"point","intensity":-1000,"color":[1,1,1]}"#,
    );
    let s = Scene::load(&p).unwrap();
    let w = s
        .warnings
        .iter()
        .find(|w| w.contains("intensity"))
        .unwrap_or_else(|| panic!("no warning naming the intensity: {:?}", s.warnings));
    assert!(w.contains("light.gltf") && w.contains("negative"), "{w}");
    match &s.lights[0] {
        Light::Point { intensity, .. } => assert_eq!(*intensity, Vec3::ZERO),
        l => panic!("{l:?}"),
    }
    // 1e39 overflows f32: infinite, refused with the field and the file named.
    let p = with_light(dir.path(), r#"{"type":"point","intensity":1e39}"#);
    let e = err_text(Scene::load(&p));
    assert!(e.contains("intensity") && e.contains("light.gltf"), "{e}");
}

#[test]
fn an_unusable_yfov_is_named_in_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    for yfov in ["0", "3.2", "1e39", "-1"] {
        let p = write_gltf(
            dir.path(),
            "cam.gltf",
            "0,1",
            r#"{"mesh":0},{"translation":[0,0,3],"camera":0}"#,
            &format!(
                r#","cameras":[{{"type":"perspective","perspective":{{"yfov":{yfov},"znear":0.1}}}}]"#
            ),
        );
        match Scene::load(&p) {
            Ok(s) => {
                assert!(
                    s.warnings
                        .iter()
                        .any(|w| w.contains("yfov") && w.contains("cam.gltf")),
                    "yfov {yfov}: {:?}",
                    s.warnings
                );
                assert!(s.cameras.iter().all(|c| c.yfov_deg.is_none()));
            }
            // The glTF crate's own validation may refuse it; it must name the field then.
            Err(e) => assert!(e.to_string().contains("yfov"), "yfov {yfov}: {e}"),
        }
    }
    // A usable one gives no warning.
    let p = write_gltf(
        dir.path(),
        "cam.gltf",
        "0,1",
        r#"{"mesh":0},{"translation":[0,0,3],"camera":0}"#,
        r#","cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.1}}]"#,
    );
    let s = Scene::load(&p).unwrap();
    assert!(
        !s.warnings.iter().any(|w| w.contains("yfov")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn negative_colours_in_mtl_and_mitsuba_lights_are_clamped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl red\nKd -1 0.5 0.5\nKe 0 -2 0\n",
    )
    .unwrap();
    let obj = dir.path().join("neg.obj");
    std::fs::write(
        &obj,
        "mtllib m.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let s = Scene::load(&obj).unwrap();
    for field in ["base colour", "emission"] {
        assert!(
            s.warnings
                .iter()
                .any(|w| w.contains(field) && w.contains("neg.obj") && w.contains("`red`")),
            "{field}: {:?}",
            s.warnings
        );
    }
    let red = s.materials.iter().find(|m| m.name == "red").unwrap();
    assert!(red.base_color.min_element() >= 0.0 && red.emissive.min_element() >= 0.0);

    let xml = dir.path().join("neg.xml");
    std::fs::write(
        &xml,
        r#"<scene version="3.0.0">
  <shape type="obj"><string name="filename" value="neg.obj"/></shape>
  <emitter type="point"><point name="position" x="0" y="1" z="2"/>
    <rgb name="intensity" value="-100"/></emitter>
</scene>"#,
    )
    .unwrap();
    let s = Scene::load(&xml).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("intensity") && w.contains("neg.xml")),
        "{:?}",
        s.warnings
    );
    match &s.lights[0] {
        Light::Point { intensity, .. } => assert_eq!(*intensity, Vec3::ZERO),
        l => panic!("{l:?}"),
    }
}

#[test]
fn lights_beyond_the_bound_keep_the_strongest() {
    let dir = tempfile::tempdir().unwrap();
    let n = 1000usize;
    let lights: Vec<String> = (0..n)
        .map(|k| format!(r#"{{"type":"point","intensity":{}}}"#, k + 1))
        .collect();
    let nodes: Vec<String> = std::iter::once(r#"{"mesh":0}"#.to_string())
        .chain((0..n).map(|k| {
            format!(r#"{{"translation":[0,0,{}],"extensions":{{"KHR_lights_punctual":{{"light":{k}}}}}}}"#, 1 + k % 7)
        }))
        .collect();
    let roots: Vec<String> = (0..=n).map(|k| k.to_string()).collect();
    let p = write_gltf(
        dir.path(),
        "many.gltf",
        &roots.join(","),
        &nodes.join(","),
        &format!(
            r#","extensions":{{"KHR_lights_punctual":{{"lights":[{}]}}}}"#,
            lights.join(",")
        ),
    );
    let s = Scene::load(&p).unwrap();
    let max = fovea_render::scene::ranges::MAX_FILE_LIGHTS;
    assert_eq!(s.lights.len(), max);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("1000 lights") && w.contains("many.gltf")),
        "{:?}",
        s.warnings
    );
    // The strongest: intensities n − max + 1 ..= n, in file order.
    let kept: Vec<f32> = s
        .lights
        .iter()
        .map(|l| match l {
            Light::Point { intensity, .. } => intensity.x,
            l => panic!("{l:?}"),
        })
        .collect();
    let want: Vec<f32> = ((n - max + 1)..=n).map(|k| k as f32).collect();
    assert_eq!(kept, want);
}

/// A latitude-longitude map whose radiance varies with both angles (so a wrong weighting of
/// the rows would move the mean), written as Radiance RGBE by the `image` crate.
fn write_hdr(dir: &Path, w: u32, h: u32) -> PathBuf {
    let px: Vec<f32> = (0..w * h)
        .flat_map(|k| {
            let (i, j) = (k % w, k / w);
            let v = j as f32 / h as f32;
            let u = i as f32 / w as f32;
            [
                1.0 + 4.0 * (v * 3.1).cos().powi(2),
                0.5 + u,
                if (i / 8 + j / 8) % 2 == 0 { 2.0 } else { 0.1 },
            ]
        })
        .collect();
    let img = image::Rgb32FImage::from_raw(w, h, px).unwrap();
    let p = dir.join("sky.hdr");
    image::DynamicImage::ImageRgb32F(img).save(&p).unwrap();
    p
}

#[test]
fn an_environment_map_over_the_budget_is_reduced_keeping_its_mean() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (512u32, 256u32);
    let p = write_hdr(dir.path(), w, h);
    let bytes = std::fs::read(&p).unwrap();
    let (full, note) = decode_within(&p, &bytes, u64::MAX).unwrap();
    assert!(note.is_none());
    assert_eq!((full.width(), full.height()), (w, h));
    // 2 MiB of memory: the map may take 1 MiB, 32 bytes a pixel, beside one scanline.
    let budget = 2u64 << 20;
    let (small, note) = decode_within(&p, &bytes, budget).unwrap();
    let note = note.expect("a note when reduced");
    assert!(
        note.starts_with("note: ") && note.contains("sky.hdr"),
        "{note}"
    );
    let px = u64::from(small.width()) * u64::from(small.height());
    assert!(
        px * fovea_render::scene::environment::file::ENVMAP_BYTES_PER_PIXEL <= budget / 2,
        "{}x{}",
        small.width(),
        small.height()
    );
    assert_eq!((small.width(), small.height()), (171, 86), "factor 3");
    let (a, b) = (full.mean(), small.mean());
    let rel = ((a - b).abs() / a).max_element();
    println!("mean radiance {a} full size, {b} reduced: relative difference {rel:.2e}");
    assert!(rel < 0.01, "{a} vs {b}");
    // A factor that divides the height keeps the mean to rounding.
    let (quarter, _) = decode_within(&p, &bytes, 600 << 10).unwrap();
    assert_eq!(quarter.height(), 64);
    let rel = ((a - quarter.mean()).abs() / a).max_element();
    assert!(rel < 1e-4, "{a} vs {}", quarter.mean());
    // Through a Mitsuba scene and its load limits: reduced, with the note among the
    // warnings.
    std::fs::write(
        dir.path().join("t.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let xml = dir.path().join("env.xml");
    std::fs::write(
        &xml,
        r#"<scene version="3.0.0">
  <shape type="obj"><string name="filename" value="t.obj"/></shape>
  <emitter type="envmap"><string name="filename" value="sky.hdr"/></emitter>
</scene>"#,
    )
    .unwrap();
    let limits = LoadLimits {
        max_memory_bytes: budget,
        ..LoadLimits::default()
    };
    let s = Scene::load_with_limits(&xml, &limits).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.starts_with("note: ")),
        "{:?}",
        s.warnings
    );
    match &s.environment {
        Environment::Map(m) => assert_eq!((m.width(), m.height()), (171, 86)),
        e => panic!("{e:?}"),
    }
    // A memory limit too small for even one scanline is refused, naming the file.
    let e = err_text(decode_within(&p, &bytes, 1000));
    assert!(e.contains("sky.hdr") && e.contains("max-memory"), "{e}");
}

#[test]
fn a_texture_over_the_memory_budget_falls_back_to_its_flat_colour() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(256, 256, image::Rgb([200, 10, 10]))
        .save(dir.path().join("t.png"))
        .unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl tex\nKd 1 1 1\nmap_Kd t.png\n",
    )
    .unwrap();
    let obj = dir.path().join("tex.obj");
    std::fs::write(
        &obj,
        "mtllib m.mtl\nusemtl tex\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    // 256 x 256 texels need 2.5 MiB: they fit 8 MiB of memory (half for the texture)...
    let limits = |mib: u64| LoadLimits {
        max_memory_bytes: mib << 20,
        ..LoadLimits::default()
    };
    let s = Scene::load_with_limits(&obj, &limits(8)).unwrap();
    assert_eq!(s.textures.len(), 1, "{:?}", s.warnings);
    // ...not 4 MiB: refused from the header, named in a warning, the flat colour used.
    let s = Scene::load_with_limits(&obj, &limits(4)).unwrap();
    assert!(s.textures.is_empty());
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("t.png") && w.contains("max-memory")),
        "{:?}",
        s.warnings
    );
}
