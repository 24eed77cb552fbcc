//! Exact duplicate triangles, found before a BVH is built.
//!
//! **Why.** A builder that clusters or splits by bounding boxes meets a tie on every
//! comparison when many triangles share one box: `obvhs`' PLOC (Meister and Bittner 2018)
//! pairs a node only with a *mutual* nearest neighbour, and when every candidate costs the
//! same only the last pair of the sorted list agrees, so each pass merges one pair and the
//! build takes Θ(n²) (100,000 copies of one triangle: over a minute). CAD and game exports
//! repeat geometry often (an OBJ that lists a face twice, identical instances on one spot).
//!
//! **Rule.** Triangles whose nine vertex coordinates are equal bit for bit are one triangle
//! for the acceleration structure: only the first (lowest index) goes into the BVH. That
//! changes no query: the closest hit is the least `(t, index)` (see `packet`'s header), two
//! bit-identical triangles give the same `t`, `u`, `v` for every ray (the same operations on
//! the same numbers), so the lower index always wins the tie and a shadow ray blocked by one
//! is blocked by the other. Triangles that only coincide (vertices listed in another order,
//! `−0.0` for `+0.0`) are kept: their `t` may differ in the last bit, so dropping one could
//! change which triangle a ray hits.
//!
//! The search is one hash-table pass, O(n) expected.

use std::collections::HashMap;

use glam::Vec3;

/// The triangles a BVH is built over.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Distinct {
    /// Indices (into the scene's triangles) of the first occurrence of every distinct
    /// triangle, ascending; `None` when every triangle is distinct (the identity).
    pub kept: Option<Vec<u32>>,
    /// Every triangle's first occurrence (its own index when it is the first); `None` when
    /// every triangle is distinct.
    pub first: Option<Vec<u32>>,
    /// How many triangles repeat an earlier one exactly.
    pub duplicates: usize,
}

impl Distinct {
    /// Finds the exact duplicates among `verts`.
    pub fn of(verts: &[[Vec3; 3]]) -> Self {
        let key = |t: &[Vec3; 3]| -> [u32; 9] {
            let mut k = [0u32; 9];
            for (c, v) in t.iter().enumerate() {
                k[3 * c] = v.x.to_bits();
                k[3 * c + 1] = v.y.to_bits();
                k[3 * c + 2] = v.z.to_bits();
            }
            k
        };
        let mut seen: HashMap<[u32; 9], u32> = HashMap::with_capacity(verts.len());
        let mut kept = Vec::new();
        let mut first = Vec::with_capacity(verts.len());
        for (i, t) in verts.iter().enumerate() {
            let f = *seen.entry(key(t)).or_insert(i as u32);
            if f == i as u32 {
                kept.push(f);
            }
            first.push(f);
        }
        let duplicates = verts.len() - kept.len();
        Self {
            kept: (duplicates > 0).then_some(kept),
            first: (duplicates > 0).then_some(first),
            duplicates,
        }
    }

    /// Number of triangles that go into the BVH (`total` is the scene's count).
    pub fn len(&self, total: usize) -> usize {
        self.kept.as_ref().map_or(total, Vec::len)
    }

    /// The scene index of the `k`-th triangle that goes into the BVH.
    #[inline]
    pub fn original(&self, k: u32) -> u32 {
        self.kept.as_ref().map_or(k, |v| v[k as usize])
    }

    /// Nothing left out: every triangle goes into the BVH (what the brute-force scan uses).
    pub fn all() -> Self {
        Self {
            kept: None,
            first: None,
            duplicates: 0,
        }
    }

    /// The one-line warning for the scene's log, when there are duplicates.
    pub fn warning(&self) -> Option<String> {
        (self.duplicates > 0).then(|| {
            format!(
                "{} triangle(s) repeat an earlier one exactly (the same vertices): the BVH holds \
                 each once (a ray hits the first)",
                self.duplicates
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_bit_identical_triangles_are_duplicates() {
        let a = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let rotated = [Vec3::X, Vec3::Y, Vec3::ZERO];
        let neg_zero = [Vec3::new(-0.0, 0.0, 0.0), Vec3::X, Vec3::Y];
        let d = Distinct::of(&[a, rotated, a, neg_zero, a]);
        assert_eq!(d.duplicates, 2);
        assert_eq!(d.kept, Some(vec![0, 1, 3]));
        assert_eq!(d.len(5), 3);
        assert_eq!(d.original(2), 3);
        assert_eq!(d.first, Some(vec![0, 1, 0, 3, 0]));
        assert!(d.warning().unwrap().starts_with("2 triangle(s)"));
        let none = Distinct::of(&[a, rotated]);
        assert_eq!(none.kept, None);
        assert_eq!(none.original(1), 1);
        assert!(none.warning().is_none());
    }
}
