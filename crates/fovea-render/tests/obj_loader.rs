//! OBJ/MTL and PLY loaders on small files written to a temporary directory.

use std::path::{Path, PathBuf};

use fovea_render::scene::{obj, ply, Material, Scene};
use fovea_render::RenderError;
use glam::{Vec2, Vec3};

fn write(dir: &Path, name: &str, content: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

const QUAD_OBJ: &str = "\
mtllib quad.mtl
o quad
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
usemtl red
f 1/1/1 2/2/1 3/3/1 4/4/1
";

#[test]
fn obj_with_mtl_reads_the_material() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quad.mtl",
        "newmtl red\nKd 0.8 0.1 0.05\nKs 0.5 0.5 0.5\nNs 100\nKe 0 0 2\n",
    );
    let p = write(dir.path(), "quad.obj", QUAD_OBJ);
    let s = Scene::load(&p).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.triangle_count(), 2, "a quad is fan-triangulated");
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.name, "red");
    assert!(
        (m.base_color - Vec3::new(0.8, 0.1, 0.05))
            .abs()
            .max_element()
            < 1e-6
    );
    assert!((m.specular - Vec3::splat(0.5)).abs().max_element() < 1e-6);
    assert!((m.roughness - Material::roughness_from_phong(100.0)).abs() < 1e-6);
    assert_eq!(m.emissive, Vec3::new(0.0, 0.0, 2.0));
    assert_eq!(s.metres_per_unit, 1.0);
    // OBJ's v runs up the image; the mesh stores glTF's v-down coordinates.
    let mesh = &s.meshes[0];
    let i = mesh
        .positions
        .iter()
        .position(|p| *p == Vec3::ZERO)
        .unwrap();
    assert_eq!(mesh.uvs[i], Vec2::new(0.0, 1.0));
    assert_eq!(mesh.normals[i], Vec3::Z);
    assert_eq!(s.name, "quad");
}

#[test]
fn obj_with_missing_mtllib_warns_and_loads_with_a_default_material() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "quad.obj", QUAD_OBJ);
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.triangle_count(), 2);
    assert!(
        s.warnings.iter().any(|w| w.contains("quad.mtl")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.materials.len(), 1);
}

#[test]
fn obj_with_missing_texture_warns_and_keeps_the_flat_colour() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quad.mtl",
        "newmtl red\nKd 0.8 0.1 0.05\nmap_Kd -bm 1 missing.png\n",
    );
    let p = write(dir.path(), "quad.obj", QUAD_OBJ);
    let s = Scene::load(&p).unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("missing.png")));
    let m = &s.materials[0];
    assert_eq!(m.base_color_texture, None);
    assert!(
        (m.base_color - Vec3::new(0.8, 0.1, 0.05))
            .abs()
            .max_element()
            < 1e-6
    );
}

#[test]
fn obj_texture_is_decoded_as_srgb_once() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbImage::from_pixel(4, 4, image::Rgb([128, 128, 128]));
    img.save(dir.path().join("grey.png")).unwrap();
    write(
        dir.path(),
        "quad.mtl",
        "newmtl a\nKd 1 1 1\nmap_Kd grey.png\nnewmtl b\nKd 0 0 0\nmap_Kd grey.png\n",
    );
    let obj = format!(
        "{}usemtl b\nf 1 3 4\n",
        QUAD_OBJ.replace("usemtl red", "usemtl a")
    );
    let p = write(dir.path(), "quad.obj", obj);
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.materials.len(), 2);
    assert_eq!(s.textures.len(), 1, "one decode per file");
    let t = &s.textures[0];
    let v = t.sample(Vec2::splat(0.5), 0.0);
    assert!((v.x - 0.2158605).abs() < 1e-3, "sRGB decoded: {v}");
    for m in s
        .materials
        .iter()
        .filter(|m| m.name == "a" || m.name == "b")
    {
        assert_eq!(m.base_color_texture, Some(0));
        assert_eq!(m.base_color, Vec3::ONE, "white under the texture");
    }
}

#[test]
fn obj_with_out_of_range_indices_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/-7 3/1\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//9223372036854775807 3//1\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n",
        "v 0 0 zero\nf 1 1 1\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/a 2 3\n",
    ];
    for (k, c) in cases.iter().enumerate() {
        let p = write(dir.path(), &format!("bad{k}.obj"), c);
        let e = Scene::load(&p).unwrap_err();
        assert!(matches!(e, RenderError::BadInput { .. }), "case {k}: {e}");
        assert!(obj::load_mesh(&p, 0).is_err(), "case {k}");
    }
}

#[test]
fn obj_with_nan_vertex_is_rejected_by_validation() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "nan.obj",
        "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let e = Scene::load(&p).unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
}

#[test]
fn missing_obj_is_an_io_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nope.obj");
    assert!(matches!(obj::load_mesh(&p, 0), Err(RenderError::Io { .. })));
    assert!(matches!(obj::load(&p), Err(RenderError::Io { .. })));
    assert!(matches!(Scene::load(&p), Err(RenderError::Io { .. })));
}

#[test]
fn malformed_mtl_lines_are_repaired_or_dropped() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quad.mtl",
        "newmtl red\nKd 0.5\nKs 1 1\nKe spectral x.spd\nNs\n",
    );
    let p = write(dir.path(), "quad.obj", QUAD_OBJ);
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.materials[0].base_color, Vec3::splat(0.5));
}

#[test]
fn load_mesh_merges_objects_and_ignores_materials() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "two.obj",
        "mtllib nothing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no a\nf 1 2 3\no b\nusemtl x\nf 1 2 4\nl 1 2\n",
    );
    let m = obj::load_mesh(&p, 7).unwrap();
    assert_eq!(m.indices.len(), 2);
    assert_eq!(m.material, 7);
    assert_eq!(m.name, "two");
    for t in &m.indices {
        assert!(t.iter().all(|&i| (i as usize) < m.positions.len()));
    }
}

fn ply_header(format: &str, nv: usize, nf: usize, extra: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n{extra}element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

const QUAD: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];

#[test]
fn ascii_ply_quad_becomes_two_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = ply_header(
        "ascii",
        4,
        1,
        "property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n",
    );
    for (i, v) in QUAD.iter().enumerate() {
        s += &format!("{} {} {} 0 0 1 {} {}\n", v[0], v[1], v[2], i % 2, i / 2);
    }
    s += "4 0 1 2 3\n";
    let p = write(dir.path(), "quad.ply", s);
    let scene = Scene::load(&p).unwrap();
    assert_eq!(scene.triangle_count(), 2);
    let m = &scene.meshes[0];
    assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.normals, vec![Vec3::Z; 4]);
    assert_eq!(m.uvs[0], Vec2::new(0.0, 1.0), "v flipped to point down");
    assert_eq!(scene.name, "quad");
}

fn binary_quad(big_endian: bool, faces: &[Vec<i32>]) -> Vec<u8> {
    let fmt = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut b = ply_header(fmt, 4, faces.len(), "").into_bytes();
    for v in QUAD {
        for c in v {
            b.extend(if big_endian {
                c.to_be_bytes()
            } else {
                c.to_le_bytes()
            });
        }
    }
    for f in faces {
        b.push(f.len() as u8);
        for &i in f {
            b.extend(if big_endian {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
    }
    b
}

#[test]
fn binary_ply_quad_becomes_two_triangles() {
    let dir = tempfile::tempdir().unwrap();
    for be in [false, true] {
        let p = write(dir.path(), "quad.ply", binary_quad(be, &[vec![0, 1, 2, 3]]));
        let m = ply::load_mesh(&p, 3).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.material, 3);
        assert!(m.normals.is_empty() && m.uvs.is_empty());
        let s = Scene::load(&p).unwrap();
        assert_eq!(s.triangle_count(), 2);
    }
}

#[test]
fn bad_ply_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    // Face index out of range.
    let p = write(dir.path(), "a.ply", binary_quad(false, &[vec![0, 1, 9]]));
    let e = Scene::load(&p).unwrap_err();
    assert!(e.to_string().contains("vertex 9"), "{e}");
    // Negative index.
    let p = write(dir.path(), "b.ply", binary_quad(false, &[vec![0, -1, 2]]));
    assert!(matches!(Scene::load(&p), Err(RenderError::BadInput { .. })));
    // Truncated payload.
    let mut b = binary_quad(false, &[vec![0, 1, 2]]);
    b.truncate(b.len() - 5);
    let p = write(dir.path(), "c.ply", b);
    assert!(matches!(Scene::load(&p), Err(RenderError::BadInput { .. })));
    // Header announces more vertices than there are.
    let mut s = ply_header("ascii", 1_000_000_000, 0, "");
    s += "0 0 0\n1 0 0\n";
    let p = write(dir.path(), "d.ply", s);
    assert!(matches!(Scene::load(&p), Err(RenderError::BadInput { .. })));
    // Not a PLY at all.
    let p = write(dir.path(), "e.ply", "hello\n");
    assert!(matches!(Scene::load(&p), Err(RenderError::BadInput { .. })));
    // Missing file.
    assert!(matches!(
        ply::load_mesh(&dir.path().join("nope.ply"), 0),
        Err(RenderError::Io { .. })
    ));
}
