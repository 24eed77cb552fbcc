//! How Mitsuba loading time grows with the shape count (issue 21, item 5): 2,000, 4,000 and
//! 8,000 generated cubes, each with its own transform and a shared BSDF by reference, loaded
//! side by side in one run (best of five each; wall and CPU time, and the process's CPU
//! share). A linear loader takes about 4× as long for 4× the shapes, a quadratic one 16×:
//! `cargo run --release -p fovea-render --example mitsuba_scaling`.

use std::fmt::Write as _;
use std::time::Instant;

use cpu_time::ProcessTime;
use fovea_render::scene::mitsuba;

fn cubes(n: usize) -> String {
    let mut s = String::new();
    for i in 0..n {
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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let mut rows = Vec::new();
    for n in [2000usize, 4000, 8000] {
        let path = dir.path().join(format!("{n}.xml"));
        std::fs::write(
            &path,
            format!(
                "<?xml version=\"1.0\"?>\n<scene version=\"0.6.0\">\n  <bsdf type=\"diffuse\" \
                 id=\"grey\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf>\n{}</scene>\n",
                cubes(n)
            ),
        )?;
        let (mut wall, mut cpu) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..5 {
            let (t, c) = (Instant::now(), ProcessTime::now());
            let scene = mitsuba::load(&path)?;
            let (w, p) = (t.elapsed().as_secs_f64(), c.elapsed().as_secs_f64());
            assert_eq!(scene.meshes.len(), n);
            if w < wall {
                (wall, cpu) = (w, p);
            }
        }
        rows.push((n, wall, cpu));
    }
    println!("| cubes | wall (s) | CPU (s) | CPU share | time / time(2,000) |");
    println!("|---:|---:|---:|---:|---:|");
    for &(n, wall, cpu) in &rows {
        println!(
            "| {n} | {wall:.3} | {cpu:.3} | {:.0} % | {:.2} |",
            100.0 * cpu / wall,
            wall / rows[0].1
        );
    }
    Ok(())
}
