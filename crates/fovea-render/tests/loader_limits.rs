//! Hostile files for every loader (issue 21, items 1, 2 and 4), generated in a temporary
//! folder: files that are not regular files (a FIFO, `/dev/zero`, a directory, a symbolic
//! link to a device), files larger than they declare or than the limits, paths that leave
//! the scene's folder, error messages that could quote a foreign file, and XML nested
//! 20,000 deep. Every case ends in a typed error or a warning, promptly: none hangs, reads
//! without bound or overflows the stack.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use fovea_render::scene::{gltf, mitsuba, obj, LoadLimits, Scene};
use fovea_render::RenderError;

/// A triangle as a 36-byte little-endian float buffer.
fn triangle_bin() -> Vec<u8> {
    [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect()
}

/// A glTF with one triangle whose buffer is `buffer_uri` (`byte_length` declared) and,
/// optionally, a base-colour texture at `image_uri`.
fn gltf_text(buffer_uri: &str, byte_length: u64, image_uri: Option<&str>) -> String {
    let (images, textures, material) = match image_uri {
        Some(u) => (
            format!(r#","images":[{{"uri":"{u}"}}]"#),
            r#","textures":[{"source":0}]"#.to_string(),
            r#","materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}]"#
                .to_string(),
        ),
        None => (String::new(), String::new(), String::new()),
    };
    let mat_ref = if image_uri.is_some() {
        r#","material":0"#
    } else {
        ""
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}{mat_ref}}}]}}],
        "buffers":[{{"uri":"{buffer_uri}","byteLength":{byte_length}}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
        "min":[0,0,0],"max":[1,1,0]}}]{images}{textures}{material}}}"#
    )
}

const OBJ_TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn allow_outside() -> LoadLimits {
    LoadLimits {
        allow_outside_scene_dir: true,
        ..LoadLimits::default()
    }
}

/// Runs `f` on another thread and fails if it takes longer than 20 s (a FIFO opened for
/// reading would block forever).
fn promptly<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("{what}: no result within 20 s"))
}

/// A FIFO at `path` (`None` where `mkfifo` is not available).
fn fifo(path: &Path) -> Option<PathBuf> {
    let ok = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        println!("skipping FIFO cases: mkfifo failed");
    }
    ok.then(|| path.to_path_buf())
}

#[cfg(unix)]
fn symlink(target: &Path, link: &Path) {
    std::os::unix::fs::symlink(target, link).unwrap();
}

fn err_text<T: std::fmt::Debug>(r: Result<T, RenderError>) -> String {
    let e = r.expect_err("expected an error").to_string();
    println!("error: {e}");
    e
}

#[cfg(unix)]
#[test]
fn non_regular_files_are_refused_without_reading_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    let fifo_path = fifo(&d.join("pipe.bin"));
    symlink(Path::new("/dev/zero"), &d.join("zero.bin"));
    std::fs::create_dir(d.join("folder.bin")).unwrap();

    // glTF buffers: a symlink to /dev/zero (outside the folder by default; a device when
    // allowed), a directory, a FIFO.
    let scene = d.join("zero.gltf");
    std::fs::write(&scene, gltf_text("zero.bin", 36, None)).unwrap();
    let e = err_text(Scene::load(&scene));
    assert!(e.contains("outside the scene's folder"), "{e}");
    let e = err_text(Scene::load_with_limits(&scene, &allow_outside()));
    assert!(e.contains("character device"), "{e}");
    let scene = d.join("folder.gltf");
    std::fs::write(&scene, gltf_text("folder.bin", 36, None)).unwrap();
    assert!(err_text(Scene::load(&scene)).contains("directory"));
    // An absolute file: URI to the device itself.
    let scene = d.join("devzero.gltf");
    std::fs::write(&scene, gltf_text("file:///dev/zero", 36, None)).unwrap();
    let e = err_text(Scene::load_with_limits(&scene, &allow_outside()));
    assert!(e.contains("character device"), "{e}");
    if let Some(p) = &fifo_path {
        let scene = d.join("fifo.gltf");
        std::fs::write(&scene, gltf_text(p.to_str().unwrap(), 36, None)).unwrap();
        let e = promptly("glTF buffer FIFO", move || err_text(Scene::load(&scene)));
        assert!(e.contains("FIFO"), "{e}");
    }

    // A glTF image: a warning and the flat colour.
    std::fs::write(d.join("tri.bin"), triangle_bin()).unwrap();
    let scene = d.join("image.gltf");
    std::fs::write(&scene, gltf_text("tri.bin", 36, Some("folder.bin"))).unwrap();
    let s = Scene::load(&scene).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("directory")),
        "{:?}",
        s.warnings
    );
    if fifo_path.is_some() {
        let scene = d.join("image_fifo.gltf");
        std::fs::write(&scene, gltf_text("tri.bin", 36, Some("pipe.bin"))).unwrap();
        let s = promptly("glTF image FIFO", move || Scene::load(&scene).unwrap());
        assert!(
            s.warnings.iter().any(|w| w.contains("FIFO")),
            "{:?}",
            s.warnings
        );
    }

    // The scene file itself: a .glb symlinked to /dev/zero, a FIFO named .ply, a directory.
    symlink(Path::new("/dev/zero"), &d.join("endless.glb"));
    let e = err_text(Scene::load(&d.join("endless.glb")));
    assert!(e.contains("character device"), "{e}");
    if fifo_path.is_some() {
        assert!(fifo(&d.join("pipe.ply")).is_some());
        let p = d.join("pipe.ply");
        let e = promptly("PLY FIFO", move || err_text(Scene::load(&p)));
        assert!(e.contains("FIFO"), "{e}");
    }
    std::fs::create_dir(d.join("dir.obj")).unwrap();
    assert!(err_text(Scene::load(&d.join("dir.obj"))).contains("directory"));

    // OBJ: an `mtllib` that is a FIFO and a texture that is /dev/zero → warnings.
    if fifo_path.is_some() {
        assert!(fifo(&d.join("pipe.mtl")).is_some());
        let p = d.join("mtl_fifo.obj");
        std::fs::write(&p, format!("mtllib pipe.mtl\n{OBJ_TRIANGLE}")).unwrap();
        let s = promptly("OBJ mtllib FIFO", move || Scene::load(&p).unwrap());
        assert!(
            s.warnings.iter().any(|w| w.contains("FIFO")),
            "{:?}",
            s.warnings
        );
    }
    std::fs::write(d.join("zero.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd zero.bin\n").unwrap();
    let p = d.join("tex_zero.obj");
    std::fs::write(&p, format!("mtllib zero.mtl\nusemtl m\n{OBJ_TRIANGLE}")).unwrap();
    let s = Scene::load_with_limits(&p, &allow_outside()).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("character device")),
        "{:?}",
        s.warnings
    );

    // Mitsuba: a shape file that is /dev/zero (through a link) or a FIFO, an include that
    // is a directory.
    symlink(Path::new("/dev/zero"), &d.join("zero.ply"));
    let p = d.join("shape_zero.xml");
    std::fs::write(
        &p,
        r#"<scene version="0.6.0"><shape type="ply"><string name="filename" value="zero.ply"/></shape></scene>"#,
    )
    .unwrap();
    let e = err_text(mitsuba::load_with_limits(&p, &allow_outside()));
    assert!(e.contains("character device"), "{e}");
    if fifo_path.is_some() {
        assert!(fifo(&d.join("pipe.obj")).is_some());
        let p = d.join("shape_fifo.xml");
        std::fs::write(
            &p,
            r#"<scene version="0.6.0"><shape type="obj"><string name="filename" value="pipe.obj"/></shape></scene>"#,
        )
        .unwrap();
        let e = promptly("Mitsuba shape FIFO", move || err_text(Scene::load(&p)));
        assert!(e.contains("FIFO"), "{e}");
    }
    std::fs::create_dir(d.join("inc.xml")).unwrap();
    let p = d.join("include_dir.xml");
    std::fs::write(
        &p,
        r#"<scene version="0.6.0"><include filename="inc.xml"/></scene>"#,
    )
    .unwrap();
    assert!(err_text(Scene::load(&p)).contains("directory"));
}

#[test]
fn reads_stop_at_the_declared_size_and_the_limits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 4 MiB buffer file of which the glTF declares 36 bytes: only those are read, so a
    // total limit far below the file's size still loads it.
    let mut big = triangle_bin();
    big.resize(4 << 20, 0);
    std::fs::write(d.join("big.bin"), &big).unwrap();
    let scene = d.join("declared.gltf");
    std::fs::write(&scene, gltf_text("big.bin", 36, None)).unwrap();
    let tight = LoadLimits {
        max_total_bytes: 64 << 10,
        ..LoadLimits::default()
    };
    let s = Scene::load_with_limits(&scene, &tight).unwrap();
    assert_eq!(s.triangle_count(), 1);
    // The same file undeclared (as a texture) is over the total limit.
    let scene = d.join("undeclared.gltf");
    std::fs::write(d.join("tri.bin"), triangle_bin()).unwrap();
    std::fs::write(&scene, gltf_text("tri.bin", 36, Some("big.bin"))).unwrap();
    let s = Scene::load_with_limits(&scene, &tight).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("max_total_bytes") && w.contains("big.bin")),
        "{:?}",
        s.warnings
    );
    // A buffer that declares more than max_file_bytes is refused before it is read.
    let scene = d.join("huge_declared.gltf");
    std::fs::write(&scene, gltf_text("tri.bin", 1 << 40, None)).unwrap();
    let e = Scene::load(&scene).unwrap_err();
    assert!(
        matches!(&e, RenderError::ResourceLimit { needed, .. } if needed.contains("declared")),
        "{e}"
    );
    // A sparse 16 GiB file as a texture, a PLY and an OBJ: refused by its size, at once.
    let huge = d.join("huge.ply");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(16 << 30)
        .unwrap();
    let e = Scene::load(&huge).unwrap_err();
    assert!(
        matches!(&e, RenderError::ResourceLimit { limit, .. } if limit.contains("max_file_bytes")),
        "{e}"
    );
    std::fs::hard_link(&huge, d.join("huge.obj")).unwrap();
    assert!(matches!(
        Scene::load(&d.join("huge.obj")),
        Err(RenderError::ResourceLimit { .. })
    ));
    let p = d.join("huge_tex.obj");
    std::fs::write(d.join("huge.mtl"), "newmtl m\nmap_Kd huge.ply\n").unwrap();
    std::fs::write(&p, format!("mtllib huge.mtl\nusemtl m\n{OBJ_TRIANGLE}")).unwrap();
    let s = Scene::load(&p).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("max_file_bytes")),
        "{:?}",
        s.warnings
    );
    // Limits that make no sense are named.
    let bad = LoadLimits {
        max_nesting: 0,
        ..LoadLimits::default()
    };
    let e = err_text(Scene::load_with_limits(&p, &bad));
    assert!(e.contains("max_nesting"), "{e}");
}

#[test]
fn files_outside_the_scene_folder_are_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path();
    let d = outside.join("scene");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(outside.join("tri.bin"), triangle_bin()).unwrap();
    std::fs::write(outside.join("red.mtl"), "newmtl red\nKd 1 0 0\n").unwrap();
    std::fs::write(outside.join("tri.obj"), OBJ_TRIANGLE).unwrap();
    std::fs::write(
        outside.join("part.xml"),
        r#"<scene version="0.6.0"><shape type="cube"/></scene>"#,
    )
    .unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    std::fs::write(d.join("sub/tri.bin"), triangle_bin()).unwrap();

    // glTF buffer `../tri.bin`; a percent-encoded `..`; a file inside a subfolder is fine.
    for uri in ["../tri.bin", "%2E%2E/tri.bin", "sub/../../tri.bin"] {
        let scene = d.join("up.gltf");
        std::fs::write(&scene, gltf_text(uri, 36, None)).unwrap();
        let e = Scene::load(&scene).unwrap_err();
        assert!(
            matches!(&e, RenderError::BadInput { what, .. } if what.contains("outside the scene's folder")),
            "{uri}: {e}"
        );
        assert_eq!(
            Scene::load_with_limits(&scene, &allow_outside())
                .unwrap()
                .triangle_count(),
            1
        );
    }
    let scene = d.join("sub.gltf");
    std::fs::write(&scene, gltf_text("sub/tri.bin", 36, None)).unwrap();
    assert_eq!(Scene::load(&scene).unwrap().triangle_count(), 1);

    // OBJ `mtllib ../red.mtl`: a warning and grey; red when allowed.
    let p = d.join("up.obj");
    std::fs::write(&p, format!("mtllib ../red.mtl\nusemtl red\n{OBJ_TRIANGLE}")).unwrap();
    let s = Scene::load(&p).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("outside the scene's folder")),
        "{:?}",
        s.warnings
    );
    assert_ne!(s.materials[0].base_color, glam::Vec3::X);
    let s = obj::load_with_limits(&p, &allow_outside()).unwrap();
    assert_eq!(s.materials[0].base_color, glam::Vec3::X);

    // Mitsuba `filename` and `<include>` leaving the folder.
    let p = d.join("up.xml");
    std::fs::write(
        &p,
        r#"<scene version="0.6.0"><shape type="obj"><string name="filename" value="../tri.obj"/></shape></scene>"#,
    )
    .unwrap();
    let e = err_text(Scene::load(&p));
    assert!(e.contains("outside the scene's folder"), "{e}");
    assert_eq!(
        Scene::load_with_limits(&p, &allow_outside())
            .unwrap()
            .triangle_count(),
        1
    );
    let p = d.join("up_include.xml");
    std::fs::write(
        &p,
        r#"<scene version="0.6.0"><include filename="../part.xml"/></scene>"#,
    )
    .unwrap();
    let e = err_text(Scene::load(&p));
    assert!(e.contains("outside the scene's folder"), "{e}");
    assert_eq!(
        Scene::load_with_limits(&p, &allow_outside())
            .unwrap()
            .triangle_count(),
        12
    );
    // A symbolic link inside the folder that points out of it is outside too.
    #[cfg(unix)]
    {
        symlink(&outside.join("tri.bin"), &d.join("link.bin"));
        let scene = d.join("link.gltf");
        std::fs::write(&scene, gltf_text("link.bin", 36, None)).unwrap();
        assert!(err_text(Scene::load(&scene)).contains("outside the scene's folder"));
    }
}

#[test]
fn errors_never_quote_a_foreign_file() {
    const MARK: &str = "SECRET-LINE-7c1f";
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path();
    let d = outside.join("scene");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(
        outside.join("passwd"),
        format!("{MARK}:x:0:0:root:/root:/bin/bash\nv {MARK}\n"),
    )
    .unwrap();
    // As a Mitsuba PLY, OBJ and include, and as a glTF buffer/image, with and without the
    // permission to read it.
    let cases = [
        (
            "ply.xml",
            r#"<shape type="ply"><string name="filename" value="../passwd"/></shape>"#,
        ),
        (
            "obj.xml",
            r#"<shape type="obj"><string name="filename" value="../passwd"/></shape>"#,
        ),
        ("inc.xml", r#"<include filename="../passwd"/>"#),
    ];
    for (name, body) in cases {
        let p = d.join(name);
        std::fs::write(&p, format!("<scene version=\"0.6.0\">{body}</scene>")).unwrap();
        for limits in [LoadLimits::default(), allow_outside()] {
            let e = err_text(Scene::load_with_limits(&p, &limits));
            println!("{name}: {e}");
            assert!(!e.contains(MARK), "{name}: {e}");
            assert!(!e.contains('\n'), "{name}: one line: {e}");
        }
    }
    let scene = d.join("img.gltf");
    std::fs::write(d.join("tri.bin"), triangle_bin()).unwrap();
    std::fs::write(&scene, gltf_text("tri.bin", 36, Some("../passwd"))).unwrap();
    for limits in [LoadLimits::default(), allow_outside()] {
        let s = Scene::load_with_limits(&scene, &limits).unwrap();
        assert!(
            s.warnings.iter().all(|w| !w.contains(MARK)),
            "{:?}",
            s.warnings
        );
    }
    let p = d.join("mtl.obj");
    std::fs::write(&p, format!("mtllib ../passwd\n{OBJ_TRIANGLE}")).unwrap();
    let s = Scene::load_with_limits(&p, &allow_outside()).unwrap();
    assert!(
        s.warnings.iter().all(|w| !w.contains(MARK)),
        "{:?}",
        s.warnings
    );
}

/// `depth` nested `<a>` elements inside a cube shape.
fn nested_xml(depth: usize) -> String {
    let mut s = String::with_capacity(depth * 8 + 100);
    s.push_str("<scene version=\"0.6.0\"><shape type=\"cube\">");
    for _ in 0..depth {
        s.push_str("<a>");
    }
    for _ in 0..depth {
        s.push_str("</a>");
    }
    s.push_str("</shape></scene>");
    s
}

#[test]
fn deep_xml_nesting_is_a_typed_error_not_a_stack_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("deep.xml");
    std::fs::write(&p, nested_xml(20_000)).unwrap();
    let e = Scene::load(&p).unwrap_err();
    assert!(
        matches!(&e, RenderError::ResourceLimit { limit, .. } if limit.contains("max_nesting")),
        "{e}"
    );
    // 200,000 levels in an include: the parser itself does not recurse.
    std::fs::write(dir.path().join("deeper.xml"), nested_xml(200_000)).unwrap();
    let p = dir.path().join("outer.xml");
    std::fs::write(
        &p,
        r#"<scene version="0.6.0"><include filename="deeper.xml"/></scene>"#,
    )
    .unwrap();
    assert!(matches!(
        Scene::load(&p),
        Err(RenderError::ResourceLimit { .. })
    ));
    // Within the limit it loads; a lower limit refuses the same file.
    let p = dir.path().join("fine.xml");
    std::fs::write(&p, nested_xml(100)).unwrap();
    assert_eq!(Scene::load(&p).unwrap().triangle_count(), 12);
    let low = LoadLimits {
        max_nesting: 50,
        ..LoadLimits::default()
    };
    assert!(matches!(
        mitsuba::load_with_limits(&p, &low),
        Err(RenderError::ResourceLimit { .. })
    ));
    // The deepest nesting the limits accept runs on a test thread's stack.
    let max = LoadLimits {
        max_nesting: fovea_render::scene::limits::MAX_NESTING_CAP,
        ..LoadLimits::default()
    };
    let p = dir.path().join("cap.xml");
    std::fs::write(&p, nested_xml(max.max_nesting as usize - 3)).unwrap();
    assert_eq!(
        Scene::load_with_limits(&p, &max).unwrap().triangle_count(),
        12
    );
}

#[test]
fn gltf_from_bytes_uses_the_same_limits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("scene");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(dir.path().join("tri.bin"), triangle_bin()).unwrap();
    let text = gltf_text("../tri.bin", 36, None);
    let e = gltf::load_from_bytes(&d.join("x.gltf"), text.as_bytes()).unwrap_err();
    assert!(e.to_string().contains("outside the scene's folder"), "{e}");
}
