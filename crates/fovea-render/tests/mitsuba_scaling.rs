//! Many-shape Mitsuba scenes load whole (issue 21, item 5): 2,000, 4,000 and 8,000 generated
//! cubes (each with its own transform and a shared BSDF by reference), and the same 8,000 split
//! over 20 includes. How the load time grows with the shape count is a benchmark, not a test
//! (times are not asserted in tests: the machines are shared):
//! `cargo run --release -p fovea-render --example mitsuba_scaling` prints the times and their
//! ratio, measured side by side, with CPU time and share.

use std::fmt::Write as _;
use std::path::Path;

use fovea_render::scene::mitsuba;

/// `n` cubes 3 units apart on a grid, sharing one BSDF.
fn cubes(n: usize, offset: usize) -> String {
    let mut s = String::new();
    for i in offset..offset + n {
        let (x, z) = ((i % 100) as f32 * 3.0, (i / 100) as f32 * 3.0);
        writeln!(
            s,
            "  <shape type=\"cube\" id=\"c{i}\">\n    <transform name=\"toWorld\">\n      \
             <scale value=\"0.5\"/>\n      <translate x=\"{x}\" y=\"0\" z=\"{z}\"/>\n    \
             </transform>\n    <ref id=\"grey\"/>\n  </shape>"
        )
        .unwrap();
    }
    s
}

fn scene_file(dir: &Path, name: &str, body: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    let text = format!(
        "<?xml version=\"1.0\"?>\n<scene version=\"0.6.0\">\n  <bsdf type=\"diffuse\" \
         id=\"grey\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf>\n{body}</scene>\n"
    );
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn many_shapes_and_includes_load_every_shape() {
    let dir = tempfile::tempdir().unwrap();
    for n in [2000, 4000, 8000] {
        let p = scene_file(dir.path(), &format!("{n}.xml"), &cubes(n, 0));
        assert_eq!(mitsuba::load(&p).unwrap().meshes.len(), n);
    }
    // 8,000 cubes in 20 included files of 400.
    let mut includes = String::new();
    for k in 0..20 {
        let name = format!("part{k}.xml");
        std::fs::write(
            dir.path().join(&name),
            format!(
                "<scene version=\"0.6.0\">\n{}</scene>\n",
                cubes(400, 400 * k)
            ),
        )
        .unwrap();
        writeln!(includes, "  <include filename=\"{name}\"/>").unwrap();
    }
    let included = scene_file(dir.path(), "included.xml", &includes);
    assert_eq!(mitsuba::load(&included).unwrap().meshes.len(), 8000);
}
