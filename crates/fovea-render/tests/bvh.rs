//! Every ray-casting backend against the brute-force linear scan: closest hits (distance and
//! triangle) and shadow-ray occlusion on random triangle soups and random rays.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use fovea_render::bvh::{build, Backend, Ray, Triangles};

/// `n` random triangles in the unit cube, sizes from slivers to a third of the cube.
fn soup(n: usize, rng: &mut Pcg64) -> Triangles {
    let mut tris = Triangles::default();
    for k in 0..n {
        let c = Vec3::new(rng.random(), rng.random(), rng.random());
        let size = 0.01 + 0.3 * rng.random::<f32>().powi(2);
        let mut v = || c + size * (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5);
        tris.verts.push([v(), v(), v()]);
        tris.source.push((0, k as u32));
    }
    tris
}

/// Rays from inside and outside the cube, in random directions, some with short `t_max`.
fn rays(n: usize, rng: &mut Pcg64) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let o = Vec3::new(rng.random(), rng.random(), rng.random()) * 1.6 - 0.3;
            let d = loop {
                let d = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
                if d.length_squared() > 1e-4 {
                    break d;
                }
            };
            let t_max = if rng.random::<f32>() < 0.3 {
                rng.random::<f32>() * 0.5
            } else {
                f32::INFINITY
            };
            Ray::new(o, d, 1e-4, t_max)
        })
        .collect()
}

fn check_against_brute_force(backend: Backend) {
    let mut rng = Pcg64::seed_from_u64(7);
    for n in [1usize, 50, 3000] {
        let tris = soup(n, &mut rng);
        let reference = build(Backend::BruteForce, &tris).unwrap();
        let caster = build(backend, &tris).unwrap();
        let (mut hits, mut tri_mismatch) = (0, 0);
        let rays = rays(4000, &mut rng);
        for r in &rays {
            let a = reference.intersect(r);
            let b = caster.intersect(r);
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    assert!(
                        (a.t - b.t).abs() <= 1e-4 * a.t.max(1.0),
                        "{} triangles: t {} vs brute force {}",
                        n,
                        b.t,
                        a.t
                    );
                    // Two triangles may lie at the same distance (coplanar overlaps).
                    tri_mismatch += (a.tri != b.tri) as usize;
                    if a.tri == b.tri {
                        assert!((a.bary - b.bary).abs().max_element() < 1e-3);
                    }
                }
                (a, b) => {
                    // A ray grazing a triangle's edge may go either way in float arithmetic;
                    // such a hit lies on the triangle's boundary.
                    let h = a.or(b).unwrap();
                    let (u, v) = (h.bary.x, h.bary.y);
                    let edge = u.min(v).min(1.0 - u - v);
                    assert!(
                        edge < 1e-4,
                        "{n} triangles: {backend:?} {b:?}, brute force {a:?}"
                    );
                }
            }
            let occluded = reference.occluded(r);
            if occluded != caster.occluded(r) {
                // Only a boundary graze may disagree.
                let h = reference.intersect(r).or(caster.intersect(r)).unwrap();
                let (u, v) = (h.bary.x, h.bary.y);
                assert!(u.min(v).min(1.0 - u - v) < 1e-4, "{n}: occlusion differs");
            }
        }
        println!("{backend:?}, {n} triangles: {hits} hits of 4000 rays, {tri_mismatch} ties");
        assert!(
            n < 1000 || hits > 1000,
            "too few hits to mean anything: {hits}"
        );
        assert!(tri_mismatch <= hits / 100);
    }
}

#[test]
fn obvhs_matches_brute_force() {
    check_against_brute_force(Backend::Obvhs);
}

/// The batch queries (`intersect_batch`, `occluded_batch`: Embree's ray streams) give what the
/// one-ray queries give, ray for ray, on coherent batches (one origin region, one target)
/// and incoherent ones, of every length from 0 to beyond a packet.
fn check_batches(backend: Backend) {
    let mut rng = Pcg64::seed_from_u64(11);
    let tris = soup(2000, &mut rng);
    let caster = build(backend, &tris).unwrap();
    let mut coherent = Vec::new();
    let target = Vec3::new(0.5, 2.0, 0.5);
    for _ in 0..700 {
        let o = Vec3::new(rng.random(), rng.random::<f32>() * 0.2, rng.random());
        let d = target - o;
        coherent.push(Ray::new(o, d.normalize(), 1e-4, d.length()));
    }
    let incoherent = rays(700, &mut rng);
    let (mut hit_diff, mut occ_diff, mut total) = (0, 0, 0);
    for batch in [&coherent, &incoherent] {
        for len in [0usize, 1, 7, 16, 17, 700] {
            let rs = &batch[..len];
            let mut hits = vec![None; len];
            caster.intersect_batch(rs, &mut hits);
            let mut occ = vec![false; len];
            caster.occluded_batch(rs, &mut occ);
            for (r, (h, o)) in rs.iter().zip(hits.iter().zip(&occ)) {
                total += 1;
                let one = caster.intersect(r);
                match (one, h) {
                    (None, None) => {}
                    (Some(a), Some(b)) if a.tri == b.tri => {
                        assert!((a.t - b.t).abs() <= 1e-5 * a.t.max(1.0), "{a:?} {b:?}");
                    }
                    _ => hit_diff += 1,
                }
                occ_diff += usize::from(caster.occluded(r) != *o);
            }
        }
    }
    println!("{backend:?}: {total} rays in batches, {hit_diff} hits and {occ_diff} occlusions differ from one-ray queries");
    // Packet traversal may settle an edge graze the other way; nothing more.
    assert!(hit_diff <= total / 1000 && occ_diff <= total / 1000);
}

#[test]
fn obvhs_batches_match_single_rays() {
    check_batches(Backend::Obvhs);
    check_batches(Backend::BruteForce);
}

#[cfg(feature = "embree")]
#[test]
fn embree_batches_match_single_rays() {
    check_batches(Backend::Embree);
}

#[cfg(feature = "embree")]
#[test]
fn embree_matches_brute_force() {
    check_against_brute_force(Backend::Embree);
}

#[test]
fn embree_is_refused_clearly_when_not_built_in() {
    if Backend::Embree.available() {
        return;
    }
    let err = build(Backend::Embree, &Triangles::default()).err().unwrap();
    assert!(err.to_string().contains("--features embree"), "{err}");
}

/// Axis-aligned and signed-zero directions: `-(0, -1.5, -1)` has a `-0.0` component, which
/// `obvhs` 0.4 alone would send down the wrong octant (the ray missed everything). Every
/// component of `±0.0` and its neighbours must hit what the brute-force scan hits.
#[test]
fn signed_zero_direction_components_hit_like_positive_zero() {
    let mut rng = Pcg64::seed_from_u64(17);
    let tris = soup(400, &mut rng);
    let brute = build(Backend::BruteForce, &tris).unwrap();
    let obvhs = build(Backend::Obvhs, &tris).unwrap();
    let mut checked = 0;
    for _ in 0..400 {
        let o = Vec3::new(rng.random(), rng.random(), rng.random());
        let d = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
        for axis in 0..3 {
            for zero in [0.0f32, -0.0] {
                let mut dir = d.normalize();
                dir[axis] = zero;
                let ray = Ray {
                    origin: o,
                    dir: dir.normalize(),
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                let want = brute.intersect(&ray).map(|h| h.tri);
                assert_eq!(obvhs.intersect(&ray).map(|h| h.tri), want, "{ray:?}");
                assert_eq!(obvhs.occluded(&ray), want.is_some(), "{ray:?}");
                checked += want.is_some() as u32;
            }
        }
    }
    assert!(checked > 500, "{checked} hits checked");
}

/// Batches of the obvhs backend (its packet traversal, `bvh::packet`) give exactly the
/// one-ray query's closest hit and the brute-force scan's: the same triangle, distance and
/// barycentrics, bit for bit (and shadow-ray batches the one-ray occlusion), on coherent packets (a pinhole camera's neighbouring pixels,
/// some through axis-aligned and `-0.0` directions, some with `t_min`/`t_max` cutting the
/// scene), incoherent rays, rays that miss everything, and duplicated triangles (ties in `t`
/// go to the lower index), in batches of every length around a packet's 64.
#[test]
fn obvhs_packets_give_the_single_ray_and_brute_force_hits_exactly() {
    let mut rng = Pcg64::seed_from_u64(23);
    let mut tris = soup(3000, &mut rng);
    // Exact duplicates and an axis-aligned floor and wall (triangles in their box's face).
    for k in 0..200 {
        let v = tris.verts[k * 7];
        tris.verts.push(v);
        tris.source.push((0, tris.source.len() as u32));
    }
    for v in [
        [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, 2.0),
        ],
        [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(-1.0, 0.0, 2.0),
        ],
        [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(2.0, -1.0, 1.0),
            Vec3::new(2.0, 2.0, 1.0),
        ],
        [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(2.0, 2.0, 1.0),
            Vec3::new(-1.0, 2.0, 1.0),
        ],
    ] {
        tris.verts.push(v);
        tris.source.push((0, tris.source.len() as u32));
    }
    let brute = build(Backend::BruteForce, &tris).unwrap();
    let obvhs = build(Backend::Obvhs, &tris).unwrap();
    let mut all: Vec<Vec<Ray>> = Vec::new();
    // Pinhole cameras: 16×16 pixels row by row, so a batch of 64 is four rows.
    for cam in 0..24 {
        let eye = Vec3::new(rng.random(), rng.random(), rng.random()) * 3.0 - 1.0;
        let look = Vec3::new(rng.random(), rng.random(), rng.random());
        let fwd = (look - eye).normalize();
        let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        let fov = 0.02 + 0.5 * rng.random::<f32>();
        let (t_min, t_max) = match cam % 4 {
            0 => (0.0, f32::INFINITY),
            1 => (1e-4, (look - eye).length()),
            2 => ((look - eye).length() * 0.8, f32::INFINITY),
            _ => (1e-3, 1e3),
        };
        let mut batch = Vec::new();
        for j in 0..16 {
            for i in 0..16 {
                let x = (i as f32 - 7.5) / 8.0 * fov;
                let y = (j as f32 - 7.5) / 8.0 * fov;
                batch.push(Ray::new(eye, fwd + x * right + y * up, t_min, t_max));
            }
        }
        all.push(batch);
    }
    // Axis-aligned directions with ±0.0 components, from one origin and from a grid.
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut batch = Vec::new();
            for k in 0..70 {
                let mut o = Vec3::new(rng.random(), rng.random(), rng.random());
                if k % 5 == 0 {
                    // In the floor's or the wall's plane, running along it: the box test's
                    // slabs of zero thickness and zero direction (NaN distances).
                    if axis == 1 {
                        o.z = 1.0;
                    } else {
                        o.y = 0.0;
                    }
                }
                let mut d = Vec3::ZERO;
                d[axis] = sign;
                for (a, c) in [0.0f32, -0.0]
                    .iter()
                    .cycle()
                    .skip(k % 2)
                    .take(3)
                    .enumerate()
                {
                    if a != axis {
                        d[a] = *c;
                    }
                }
                batch.push(Ray {
                    origin: o,
                    dir: d,
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                });
            }
            all.push(batch);
        }
    }
    all.push(rays(500, &mut rng));
    // Misses: from outside, pointing away.
    all.push(
        (0..100)
            .map(|k| {
                Ray::new(
                    Vec3::new(5.0, 5.0, 5.0),
                    Vec3::new(1.0, 0.1 * k as f32 / 100.0, 0.3),
                    0.0,
                    f32::INFINITY,
                )
            })
            .collect(),
    );
    let (mut total, mut hits) = (0usize, 0usize);
    for batch in &all {
        for len in [batch.len(), 1, 63, 64, 65] {
            let rs = &batch[..len.min(batch.len())];
            let mut got = vec![None; rs.len()];
            obvhs.intersect_batch(rs, &mut got);
            let mut occ = vec![false; rs.len()];
            obvhs.occluded_batch(rs, &mut occ);
            for (r, (g, o)) in rs.iter().zip(got.iter().zip(&occ)) {
                let one = obvhs.intersect(r);
                let reference = brute.intersect(r);
                assert_eq!(*g, one, "packet against one ray: {r:?}");
                assert_eq!(*g, reference, "packet against brute force: {r:?}");
                assert_eq!(
                    *o,
                    obvhs.occluded(r),
                    "shadow packet against one ray: {r:?}"
                );
                assert_eq!(
                    *o,
                    g.is_some(),
                    "shadow packet against the closest hit: {r:?}"
                );
                total += 1;
                hits += usize::from(g.is_some());
            }
        }
    }
    println!("{total} rays, {hits} hits, all equal");
    assert!(hits > total / 4 && hits < total, "{hits} of {total}");
}

/// Degenerate geometry (issue 39): many exact copies of a triangle, identical cubes on one
/// spot, copies with their vertices listed in another order (coincident, not bit-identical),
/// among a few ordinary triangles. Every backend must give the brute-force scan's closest hit
/// exactly (distance, triangle: the lowest index among copies, barycentrics) and the same
/// occlusion, for rays through the copies and around them.
fn degenerate_scene() -> Triangles {
    let mut rng = Pcg64::seed_from_u64(39);
    let mut tris = soup(40, &mut rng);
    let one = [
        Vec3::new(0.2, 0.2, 0.5),
        Vec3::new(0.8, 0.3, 0.5),
        Vec3::new(0.4, 0.9, 0.55),
    ];
    // A unit cube's 12 triangles at (0.3, 0.3, 0.3), side 0.4.
    let cube: Vec<[Vec3; 3]> = {
        let c = |x: f32, y: f32, z: f32| Vec3::new(0.3, 0.3, 0.3) + 0.4 * Vec3::new(x, y, z);
        let q = |a, b, cc, d| [[a, b, cc], [a, cc, d]];
        [
            q(c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)),
            q(c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)),
            q(c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)),
            q(c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)),
            q(c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)),
            q(c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)),
        ]
        .into_iter()
        .flatten()
        .collect()
    };
    let mut push = |t: [Vec3; 3]| {
        let k = tris.verts.len() as u32;
        tris.verts.push(t);
        tris.source.push((1, k));
    };
    for k in 0..3000 {
        push(one);
        if k % 10 == 0 {
            // The same triangle, vertices rotated: coincident but not a duplicate.
            push([one[1], one[2], one[0]]);
        }
    }
    for _ in 0..200 {
        for &t in &cube {
            push(t);
        }
    }
    tris
}

fn check_degenerate(backend: Backend) {
    let tris = degenerate_scene();
    let reference = build(Backend::BruteForce, &tris).unwrap();
    let caster = build(backend, &tris).unwrap();
    let mut rng = Pcg64::seed_from_u64(40);
    let mut rays = rays(3000, &mut rng);
    // Rays aimed at the copied triangle and through the cube, from both sides.
    for k in 0..1000 {
        let target = Vec3::new(
            0.25 + 0.5 * rng.random::<f32>(),
            0.25 + 0.6 * rng.random::<f32>(),
            0.5,
        );
        let o = Vec3::new(
            rng.random(),
            rng.random(),
            if k % 2 == 0 { -1.0 } else { 2.0 },
        );
        rays.push(Ray::new(o, target - o, 1e-4, f32::INFINITY));
    }
    // obvhs runs our triangle test: hits equal bit for bit. Embree runs its own, so its
    // distances agree to rounding and a tie between coincident triangles may go to another
    // copy of the same vertices.
    let exact = backend == Backend::Obvhs;
    let same = |a: Option<fovea_render::bvh::Hit>, b: Option<fovea_render::bvh::Hit>| {
        if exact {
            return a == b;
        }
        match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                let set = |t: u32| {
                    let mut v = tris.verts[t as usize].map(|p| p.to_array());
                    v.sort_by(|x, y| x.partial_cmp(y).unwrap());
                    v
                };
                (a.t - b.t).abs() <= 1e-5 * a.t.max(1.0)
                    && (a.tri == b.tri || set(a.tri) == set(b.tri))
            }
            _ => false,
        }
    };
    let mut hits = 0;
    for r in &rays {
        let want = reference.intersect(r);
        let got = caster.intersect(r);
        assert!(
            same(want, got),
            "{backend:?}: {r:?}: {got:?}, brute force {want:?}"
        );
        hits += want.is_some() as usize;
        assert_eq!(
            caster.occluded(r),
            reference.occluded(r),
            "{backend:?}: {r:?}"
        );
    }
    let mut batch = vec![None; rays.len()];
    caster.intersect_batch(&rays, &mut batch);
    for (r, b) in rays.iter().zip(&batch) {
        let want = reference.intersect(r);
        assert!(
            same(want, *b),
            "{backend:?} batch: {r:?}: {b:?}, brute force {want:?}"
        );
    }
    println!(
        "{backend:?}: {} triangles, {hits} hits of {} rays",
        tris.len(),
        rays.len()
    );
    assert!(hits > 1000, "too few hits to mean anything: {hits}");
}

#[test]
fn obvhs_on_duplicate_and_coincident_triangles_matches_brute_force() {
    check_degenerate(Backend::Obvhs);
}

#[cfg(feature = "embree")]
#[test]
fn embree_on_duplicate_and_coincident_triangles_matches_brute_force() {
    check_degenerate(Backend::Embree);
}

#[test]
fn exact_duplicates_are_counted_for_the_warning() {
    let tris = degenerate_scene();
    let d = fovea_render::bvh::Distinct::of(&tris.verts);
    // 2999 copies of the triangle, 199 · 12 of the cube's; the rotated copies repeat each
    // other (299 of them after the first).
    assert_eq!(d.duplicates, 2999 + 199 * 12 + 299);
    assert!(d.warning().unwrap().contains(&d.duplicates.to_string()));
}
