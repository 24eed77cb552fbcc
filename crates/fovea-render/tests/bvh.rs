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
