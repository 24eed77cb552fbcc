//! Mitsuba loading is linear in the number of shapes (issue 21, item 5): 2,000 and 8,000
//! generated cubes (each with its own transform and a shared BSDF by reference), and the same
//! 8,000 split over 20 includes. The bound is on the ratio of the two load times, not on a
//! wall-clock time: a quadratic loader takes about 16× as long for 4× the shapes, a linear
//! one about 4×.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

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

/// The fastest of five loads, seconds (the minimum is the least noisy on a shared machine),
/// and the number of meshes.
fn time_load(path: &Path) -> (f64, usize) {
    let mut best = f64::INFINITY;
    let mut meshes = 0;
    for _ in 0..5 {
        let t = Instant::now();
        let s = mitsuba::load(path).unwrap();
        best = best.min(t.elapsed().as_secs_f64());
        meshes = s.meshes.len();
    }
    (best, meshes)
}

#[test]
fn loading_time_grows_linearly_with_the_shape_count() {
    let dir = tempfile::tempdir().unwrap();
    let small = scene_file(dir.path(), "small.xml", &cubes(2000, 0));
    let medium = scene_file(dir.path(), "medium.xml", &cubes(4000, 0));
    let large = scene_file(dir.path(), "large.xml", &cubes(8000, 0));
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

    let (t_small, n_small) = time_load(&small);
    let (t_medium, n_medium) = time_load(&medium);
    let (t_large, n_large) = time_load(&large);
    let (t_inc, n_inc) = time_load(&included);
    assert_eq!(
        (n_small, n_medium, n_large, n_inc),
        (2000, 4000, 8000, 8000)
    );
    let ratio = t_large / t_small;
    println!(
        "Mitsuba load: 2,000 cubes {t_small:.3} s, 4,000 {t_medium:.3} s, 8,000 {t_large:.3} s \
         (ratio 8,000/2,000 {ratio:.2}), 8,000 cubes in 20 includes {t_inc:.3} s"
    );
    assert!(ratio < 8.0, "time(8000)/time(2000) = {ratio:.2}");
}
