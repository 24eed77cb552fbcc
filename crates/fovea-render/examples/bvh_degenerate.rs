//! BVH build time on degenerate geometry (issue 39): `n` exact copies of one triangle,
//! `n / 12` identical cubes on one spot, and `n` different triangles sharing one bounding
//! box, for `n` from 10k to 1M, with
//! every backend this build has. Prints the time and `time / (n log₂ n)` (nanoseconds), which
//! stays roughly constant, or falls, for an O(n log n) build.
//!
//! ```sh
//! cargo run --release -p fovea-render --example bvh_degenerate
//! cargo run --release -p fovea-render --features embree --example bvh_degenerate
//! ```

use std::time::Instant;

use glam::Vec3;

use fovea_render::bvh::{build, Backend, Triangles};

fn triangles(verts: Vec<[Vec3; 3]>) -> Triangles {
    let source = (0..verts.len() as u32).map(|k| (0, k)).collect();
    Triangles { verts, source }
}

fn copies(n: usize) -> Triangles {
    let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
    triangles(vec![t; n])
}

/// `n` different triangles with one bounding box, `[0, 1]² × {0}`: `(0,0,0)`, `(1,1,0)` and a
/// third vertex on the other diagonal.
fn same_box(n: usize) -> Triangles {
    triangles(
        (0..n)
            .map(|k| {
                let s = 0.4 * k as f32 / n as f32;
                [
                    Vec3::ZERO,
                    Vec3::new(1.0, 1.0, 0.0),
                    Vec3::new(s, 1.0 - s, 0.0),
                ]
            })
            .collect(),
    )
}

fn cubes(n: usize) -> Triangles {
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let q = |a, b, cc, d| [[a, b, cc], [a, cc, d]];
    let cube: Vec<[Vec3; 3]> = [
        q(c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)),
        q(c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)),
        q(c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)),
        q(c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)),
        q(c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)),
        q(c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)),
    ]
    .into_iter()
    .flatten()
    .collect();
    triangles(cube.iter().copied().cycle().take(n / 12 * 12).collect())
}

fn main() {
    let mut backends = vec![Backend::Obvhs];
    if Backend::Embree.available() {
        backends.push(Backend::Embree);
    }
    println!("backend  case      triangles   build ms   ns/(n log2 n)");
    for backend in backends {
        for (case, make) in [
            ("copies", copies as fn(usize) -> Triangles),
            ("cubes", cubes),
            ("same-box", same_box),
        ] {
            for n in [10_000usize, 30_000, 100_000, 192_000, 300_000, 1_000_000] {
                let tris = make(n);
                let t0 = Instant::now();
                let caster = build(backend, &tris).expect("build");
                let s = t0.elapsed().as_secs_f64();
                drop(caster);
                let n = tris.len() as f64;
                println!(
                    "{:<8} {case:<8} {:>10} {:>10.1} {:>15.2}",
                    backend.name(),
                    tris.len(),
                    s * 1e3,
                    s * 1e9 / (n * n.log2())
                );
            }
        }
    }
}
