//! Analytic triangle meshes shared by the scene builders: UV sphere, box, quad, disk and
//! open tube. The built-in scenes ([`super::builtin`]) and the analytic shapes of the Mitsuba
//! loader ([`super::mitsuba`]) both build their meshes here.
//!
//! Each function performs the same floating-point operations, in the same order, as the code
//! it replaced. It also keeps the vertex order, triangle order, winding and tessellation
//! counts, so rendered images stay bit-identical. Where the callers' meshes differed (the
//! sphere's pole axis, the box's face layout, the direction of texture v), a parameter selects
//! the variant. The meshes are unit-sized or placed by their arguments, have material 0 and a
//! generic name; callers rename them, set the material and transform them.

use glam::{Vec2, Vec3};

use super::Mesh;

/// The axis through the poles of a [`uv_sphere`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Poles {
    /// Poles on ±Y: θ = 0 at +Y, φ from +X towards +Z (the built-in scenes' spheres).
    Y,
    /// Poles on ±Z: θ = 0 at +Z, φ from +X towards +Y (Mitsuba's `sphere`).
    Z,
}

/// How texture coordinates run over a quad or box face spanned by its axes u and v.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum UvLayout {
    /// uv = (0, 0) at the (−u, +v) corner: texture v runs against the v axis, so an image
    /// (v down the image) stands upright when the v axis points up (the built-in scenes).
    VAgainstAxis,
    /// uv = (0, 0) at the (−u, −v) corner: texture v runs along the v axis (Mitsuba's
    /// `rectangle` and `cube`).
    VAlongAxis,
}

/// One face of a box: outward normal, u axis, v axis, with u × v = normal (the face's
/// triangles are counter-clockwise seen from outside).
pub(crate) type BoxFace = (Vec3, Vec3, Vec3);

/// A unit UV sphere at the origin: `rings + 1` rings of `segments + 1` vertices (the seam
/// column is duplicated for the texture), pole to pole; normal = position; uv = (φ/2π, θ/π).
/// Quads touching a pole have one triangle, so there are `2 · segments · (rings − 1)`
/// triangles, counter-clockwise seen from outside.
pub(crate) fn uv_sphere(segments: u32, rings: u32, poles: Poles) -> Mesh {
    let mut m = Mesh {
        name: "sphere".into(),
        ..Mesh::default()
    };
    for ring in 0..=rings {
        let theta = std::f32::consts::PI * ring as f32 / rings as f32;
        for seg in 0..=segments {
            let phi = std::f32::consts::TAU * seg as f32 / segments as f32;
            let n = match poles {
                Poles::Y => Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ),
                Poles::Z => Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ),
            };
            m.positions.push(n);
            m.normals.push(n);
            m.uvs.push(Vec2::new(
                seg as f32 / segments as f32,
                ring as f32 / rings as f32,
            ));
        }
    }
    for ring in 0..rings {
        for seg in 0..segments {
            // `a` on this ring, `b` below it on the next ring.
            let a = ring * (segments + 1) + seg;
            let b = a + segments + 1;
            // The two pole axes mirror the sphere, so each keeps its own winding outward.
            let (upper, lower) = match poles {
                Poles::Y => ([a, a + 1, b], [a + 1, b + 1, b]),
                Poles::Z => ([a, b, a + 1], [a + 1, b, b + 1]),
            };
            // The first and last rings meet at the poles: one triangle per quad there.
            if ring > 0 {
                m.indices.push(upper);
            }
            if ring + 1 < rings {
                m.indices.push(lower);
            }
        }
    }
    m
}

/// Faces +Z, −Z, +X, −X, +Y, −Y; the four side faces have v = +Y, so that with
/// [`UvLayout::VAgainstAxis`] a texture stands upright on them (the built-in scenes' boxes).
pub(crate) fn box_faces_upright() -> [BoxFace; 6] {
    [
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, -Vec3::X, Vec3::Y),
        (Vec3::X, -Vec3::Z, Vec3::Y),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::X, -Vec3::Z),
        (-Vec3::Y, Vec3::X, Vec3::Z),
    ]
}

/// Faces +X, −X, +Y, −Y, +Z, −Z, each spanned by the two other axes (Mitsuba's `cube`).
pub(crate) fn box_faces_by_axis() -> [BoxFace; 6] {
    [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ]
}

/// An axis-aligned box centred at `centre` with half extents `half`: 4 vertices and 2
/// triangles per face, in the order of `faces`, each face mapping the whole texture.
pub(crate) fn cuboid(centre: Vec3, half: Vec3, faces: [BoxFace; 6], uv: UvLayout) -> Mesh {
    let mut m = Mesh {
        name: "box".into(),
        ..Mesh::default()
    };
    for (n, u, v) in faces {
        let base = m.positions.len() as u32;
        let face_centre = centre + n * half;
        let (hu, hv) = (u * half, v * half);
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push(face_centre + su * hu + sv * hv);
            m.normals.push(n);
            m.uvs.push(match uv {
                UvLayout::VAgainstAxis => Vec2::new(0.5 + 0.5 * su, 0.5 - 0.5 * sv),
                UvLayout::VAlongAxis => Vec2::new(0.5 * (su + 1.0), 0.5 * (sv + 1.0)),
            });
        }
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base + 2, base + 3]);
    }
    m
}

/// The parallelogram from `origin` spanning `du` and `dv` (normal `du × dv`), two triangles,
/// uv in `[0, uv_scale]`.
pub(crate) fn quad(origin: Vec3, du: Vec3, dv: Vec3, uv_scale: Vec2, uv: UvLayout) -> Mesh {
    let n = du.cross(dv).normalize();
    let (s, t) = (uv_scale.x, uv_scale.y);
    let uvs = match uv {
        UvLayout::VAgainstAxis => vec![
            Vec2::new(0.0, t),
            Vec2::new(s, t),
            Vec2::new(s, 0.0),
            Vec2::ZERO,
        ],
        UvLayout::VAlongAxis => vec![
            Vec2::ZERO,
            Vec2::new(s, 0.0),
            Vec2::new(s, t),
            Vec2::new(0.0, t),
        ],
    };
    Mesh {
        name: "quad".into(),
        positions: vec![origin, origin + du, origin + du + dv, origin + dv],
        normals: vec![n; 4],
        uvs,
        tangents: vec![],
        colors: vec![],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: 0,
    }
}

/// The unit disk in z = 0 facing +z: a centre vertex and `segments` rim vertices, one
/// triangle per segment; planar uv ((x+1)/2, (y+1)/2).
pub(crate) fn disk(segments: u32) -> Mesh {
    let mut m = Mesh {
        name: "disk".into(),
        positions: vec![Vec3::ZERO],
        normals: vec![Vec3::Z],
        uvs: vec![Vec2::splat(0.5)],
        ..Mesh::default()
    };
    for k in 0..segments {
        let phi = std::f32::consts::TAU * k as f32 / segments as f32;
        let p = Vec3::new(phi.cos(), phi.sin(), 0.0);
        m.positions.push(p);
        m.normals.push(Vec3::Z);
        m.uvs.push(Vec2::new(0.5 * (p.x + 1.0), 0.5 * (p.y + 1.0)));
        m.indices.push([0, 1 + k, 1 + (k + 1) % segments]);
    }
    m
}

/// The open unit tube along +z from z = 0 to 1, radius 1: `segments + 1` vertex pairs (the
/// seam duplicated), radial normals, uv = (φ/2π, z), triangles facing outward.
pub(crate) fn open_tube(segments: u32) -> Mesh {
    let s = segments;
    let mut m = Mesh {
        name: "tube".into(),
        ..Mesh::default()
    };
    for j in 0..=s {
        let phi = std::f32::consts::TAU * j as f32 / s as f32;
        let (x, y) = (phi.cos(), phi.sin());
        for z in [0.0, 1.0] {
            m.positions.push(Vec3::new(x, y, z));
            m.normals.push(Vec3::new(x, y, 0.0));
            m.uvs.push(Vec2::new(j as f32 / s as f32, z));
        }
    }
    for j in 0..s {
        let a = 2 * j;
        let (c, b) = (a + 1, a + 2);
        let d = b + 1;
        m.indices.push([a, b, c]);
        m.indices.push([b, d, c]);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Σ (b − a) × (c − a) (zero for a closed surface) and the signed volume (positive when
    /// the triangles face outward).
    fn closure_and_volume(m: &Mesh) -> (Vec3, f32) {
        let mut s = Vec3::ZERO;
        let mut vol = 0.0;
        for t in &m.indices {
            let (a, b, c) = (
                m.positions[t[0] as usize],
                m.positions[t[1] as usize],
                m.positions[t[2] as usize],
            );
            s += (b - a).cross(c - a);
            vol += a.dot(b.cross(c)) / 6.0;
        }
        (s, vol)
    }

    /// Total triangle area, in f64.
    fn area(m: &Mesh) -> f64 {
        m.indices
            .iter()
            .map(|t| {
                let p = |i: u32| m.positions[i as usize].as_dvec3();
                let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Moved from the Mitsuba loader, with its meshes: cube, sphere and tube.
    #[test]
    fn builtin_shapes_are_closed_and_outward() {
        let cube = cuboid(
            Vec3::ZERO,
            Vec3::ONE,
            box_faces_by_axis(),
            UvLayout::VAlongAxis,
        );
        for m in [cube, uv_sphere(64, 32, Poles::Z)] {
            // Σ A n = 0 for a closed surface; outward: the signed volume is positive.
            let (s, vol) = closure_and_volume(&m);
            assert!(s.length() < 1e-3, "{} {s}", m.name);
            assert!(vol > 0.0, "{}", m.name);
        }
        let t = open_tube(64);
        let a = t.positions[0];
        let tri = t.indices[0];
        let n = (t.positions[tri[1] as usize] - a).cross(t.positions[tri[2] as usize] - a);
        assert!(n.dot(Vec3::new(a.x, a.y, 0.0)) > 0.0);
    }

    #[test]
    fn unit_spheres_lie_on_the_unit_sphere_and_face_outward() {
        let (segments, rings) = (64u32, 32u32);
        for poles in [Poles::Y, Poles::Z] {
            let m = uv_sphere(segments, rings, poles);
            assert_eq!(m.positions.len(), ((segments + 1) * (rings + 1)) as usize);
            assert_eq!(m.indices.len(), (2 * segments * (rings - 1)) as usize);
            assert_eq!(m.normals, m.positions);
            for p in &m.positions {
                assert!((p.length() - 1.0).abs() <= 1e-6, "{poles:?} {p}");
            }
            for t in &m.indices {
                let (a, b, c) = (
                    m.positions[t[0] as usize],
                    m.positions[t[1] as usize],
                    m.positions[t[2] as usize],
                );
                let n = (b - a).cross(c - a);
                assert!(n.dot(a + b + c) > 0.0, "{poles:?} {t:?} faces inward");
            }
            let (s, vol) = closure_and_volume(&m);
            assert!(s.length() < 1e-3, "{poles:?} {s}");
            assert!(vol > 0.0);
            // An inscribed polyhedron: less than 4π, short of it by the second-order
            // deficit of inscribed polygons in both directions, ((π/s)² + (π/r)²)/6 of 4π.
            let full = 4.0 * std::f64::consts::PI;
            let step = |n: u32| std::f64::consts::PI / n as f64;
            let deficit = (step(segments).powi(2) + step(rings).powi(2)) / 6.0;
            let a = area(&m);
            assert!(
                a < full && a > full * (1.0 - 1.05 * deficit),
                "{poles:?} area {a}"
            );
        }
    }

    #[test]
    fn sphere_poles_are_on_their_axis() {
        let y = uv_sphere(8, 4, Poles::Y);
        let z = uv_sphere(8, 4, Poles::Z);
        assert_eq!(y.positions[0], Vec3::Y);
        assert_eq!(z.positions[0], Vec3::Z);
        assert!((y.positions.last().unwrap().y + 1.0).abs() < 1e-6);
        assert!((z.positions.last().unwrap().z + 1.0).abs() < 1e-6);
    }

    #[test]
    fn boxes_are_closed_and_outward() {
        let centre = Vec3::new(1.0, -2.0, 3.0);
        let half = Vec3::new(0.5, 1.0, 2.0);
        for faces in [box_faces_upright(), box_faces_by_axis()] {
            for uv in [UvLayout::VAgainstAxis, UvLayout::VAlongAxis] {
                let m = cuboid(centre, half, faces, uv);
                assert_eq!((m.positions.len(), m.indices.len()), (24, 12));
                for p in &m.positions {
                    assert_eq!((*p - centre).abs(), half);
                }
                let (s, vol) = closure_and_volume(&m);
                assert!(s.length() < 1e-4, "{s}");
                assert!((vol - 8.0 * half.element_product()).abs() < 1e-4, "{vol}");
                for t in &m.indices {
                    let p = |i: u32| m.positions[i as usize];
                    let n = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
                    assert!(n.dot(m.normals[t[0] as usize]) > 0.0);
                }
            }
        }
    }

    #[test]
    fn texture_v_runs_as_the_layout_says() {
        let (o, du, dv) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let against = quad(o, du, dv, Vec2::new(2.0, 3.0), UvLayout::VAgainstAxis);
        let along = quad(o, du, dv, Vec2::new(2.0, 3.0), UvLayout::VAlongAxis);
        assert_eq!(against.normals, vec![Vec3::Z; 4]);
        // Vertex 3 is origin + dv.
        assert_eq!(against.uvs[3], Vec2::ZERO);
        assert_eq!(along.uvs[0], Vec2::ZERO);
        assert_eq!(along.uvs[2], Vec2::new(2.0, 3.0));
        assert_eq!(against.positions, along.positions);
    }

    #[test]
    fn disk_and_tube_are_unit_sized_and_outward() {
        let d = disk(64);
        assert_eq!((d.positions.len(), d.indices.len()), (65, 64));
        for p in &d.positions[1..] {
            assert!((p.length() - 1.0).abs() <= 1e-6 && p.z == 0.0);
        }
        let (s, _) = closure_and_volume(&d);
        assert!(s.z > 0.0, "the disk faces +z");
        let a = area(&d);
        let pi = std::f64::consts::PI;
        // An inscribed 64-gon: π · sin(2π/64) / (2π/64).
        assert!((a - pi * (2.0 * pi / 64.0).sin() / (2.0 * pi / 64.0)).abs() < 1e-5);

        let t = open_tube(64);
        assert_eq!((t.positions.len(), t.indices.len()), (130, 128));
        for tri in &t.indices {
            let p = |i: u32| t.positions[i as usize];
            let n = (p(tri[1]) - p(tri[0])).cross(p(tri[2]) - p(tri[0]));
            let a = p(tri[0]);
            assert!(n.dot(Vec3::new(a.x, a.y, 0.0)) > 0.0);
        }
    }
}
