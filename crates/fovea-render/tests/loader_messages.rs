//! Messages that say what is wrong (issue 21, item 12): Draco used but not required, UTF-16
//! OBJ files, OBJ parse errors with their line, PLY errors on one line without padding, and
//! coordinates too large to compute with called what they are.

use fovea_render::scene::Scene;
use fovea_render::RenderError;

fn load_err(dir: &std::path::Path, name: &str, bytes: &[u8]) -> RenderError {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    let e = Scene::load(&p).expect_err(name);
    println!("{name}: {e}");
    e
}

/// One line, no tab, no leading or trailing blanks in what follows the path.
fn assert_one_clean_line(e: &RenderError) {
    let s = e.to_string();
    assert!(!s.contains('\n') && !s.contains('\t'), "{s:?}");
    assert_eq!(s.trim(), s, "{s:?}");
    if let RenderError::BadInput { what, .. } = e {
        assert_eq!(what.trim(), what, "{what:?}");
        assert!(!what.contains("  "), "{what:?}");
    }
}

/// A glTF whose only primitive carries `KHR_draco_mesh_compression` (declared in
/// `extensionsUsed`, not required); with `fallback`, its accessors also have uncompressed
/// data.
fn draco_gltf(fallback: bool) -> String {
    let bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let b64: String = {
        const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        bin.chunks(3)
            .flat_map(|c| {
                let n = (u32::from(c[0]) << 16)
                    | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
                    | u32::from(*c.get(2).unwrap_or(&0));
                (0..4).map(move |k| {
                    if k <= c.len() {
                        A[((n >> (18 - 6 * k)) & 63) as usize] as char
                    } else {
                        '='
                    }
                })
            })
            .collect()
    };
    let view = if fallback { r#""bufferView":0,"# } else { "" };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_draco_mesh_compression"],
        "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},
            "extensions":{{"KHR_draco_mesh_compression":{{"bufferView":0,"attributes":{{"POSITION":0}}}}}}}}]}}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}],
        "accessors":[{{{view}"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}]}}"#
    )
}

#[test]
fn draco_used_but_not_required_says_draco() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_err(dir.path(), "draco.gltf", draco_gltf(false).as_bytes());
    assert!(matches!(e, RenderError::Unsupported(_)), "{e}");
    assert!(e.to_string().contains("Draco"), "{e}");
    // With the uncompressed fallback the file loads, and a warning names Draco.
    let p = dir.path().join("fallback.gltf");
    std::fs::write(&p, draco_gltf(true)).unwrap();
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert!(
        s.warnings.iter().any(|w| w.contains("Draco")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn utf16_obj_files_are_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let le: Vec<u8> = text.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
    let be: Vec<u8> = text.encode_utf16().flat_map(|u| u.to_be_bytes()).collect();
    for (name, bom, body) in [
        ("le_bom.obj", &[0xFF, 0xFE][..], &le),
        ("be_bom.obj", &[0xFE, 0xFF][..], &be),
        ("le.obj", &[][..], &le),
    ] {
        let bytes = [bom, body.as_slice()].concat();
        let e = load_err(dir.path(), name, &bytes);
        assert!(matches!(e, RenderError::Unsupported(_)), "{e}");
        assert!(e.to_string().contains("UTF-16"), "{e}");
    }
}

#[test]
fn obj_parse_errors_name_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases = [
        ("v 0 0\n", 1),
        ("v 0 zero 0\n", 1),
        ("v 0 0 0 0\n", 1),
        ("v 0 0 0 1 1\n", 1),
        ("v 0 0 0 1 1 x\n", 1),
        ("v 0 0 0\nvt 0.5\n", 2),
        ("v 0 0 0\nvn 0 0\n", 2),
        ("# c\n# c\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", 6),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n", 4),
    ];
    for (k, (body, line)) in cases.iter().enumerate() {
        let e = load_err(dir.path(), &format!("c{k}.obj"), body.as_bytes());
        assert!(matches!(e, RenderError::BadInput { .. }), "{e}");
        assert!(e.to_string().contains(&format!("line {line}:")), "{k}: {e}");
        assert_one_clean_line(&e);
    }
    // A valid file with a weight and with colours still loads.
    let p = dir.path().join("ok.obj");
    std::fs::write(&p, format!("{tri}v 0 0 1 2\nf 1 2 3\n")).unwrap();
    assert_eq!(Scene::load(&p).unwrap().triangle_count(), 1);
}

#[test]
fn ply_errors_are_one_line_without_padding() {
    let dir = tempfile::tempdir().unwrap();
    let header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                  property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                  end_header\n";
    let cases: [(&str, String); 6] = [
        ("magic.ply", "solid cube\nfacet normal 0 0 1\n".into()),
        ("format.ply", "ply\nformat foo 1.0\nend_header\n".into()),
        (
            "header.ply",
            "ply\nformat ascii 1.0\nelement vertex\nend_header\n".into(),
        ),
        (
            "value.ply",
            format!("{header}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"),
        ),
        ("short.ply", format!("{header}0 0 0\n1 0 0\n")),
        (
            "index.ply",
            format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
        ),
    ];
    for (name, body) in cases {
        let e = load_err(dir.path(), name, body.as_bytes());
        assert!(matches!(e, RenderError::BadInput { .. }), "{name}: {e}");
        assert_one_clean_line(&e);
        // The file's content is not quoted.
        assert!(!e.to_string().contains("solid cube"), "{e}");
    }
    // Truncated binary data.
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
property float y\nproperty float z\nend_header\n"
        .to_vec();
    bin.extend([0u8; 20]);
    let e = load_err(dir.path(), "truncated.ply", &bin);
    assert_one_clean_line(&e);
}

#[test]
fn huge_coordinates_are_called_too_large_not_degenerate() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_err(
        dir.path(),
        "huge.obj",
        b"v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nf 1 2 3\n",
    );
    let s = e.to_string();
    assert!(s.contains("too large") && !s.contains("degenerate"), "{s}");
    // Mixed with normal triangles: a warning that says so, the rest loads.
    let p = dir.path().join("mixed.obj");
    std::fs::write(
        &p,
        "v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 4 5\n",
    )
    .unwrap();
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert!(
        s.warnings.iter().any(|w| w.contains("too large")),
        "{:?}",
        s.warnings
    );
}
