//! The binary BVH under the obvhs backend (and the GPU tracer): PLOC (Meister and Bittner
//! 2018, "Parallel locally-ordered clustering for bounding volume hierarchy construction")
//! and reinsertion (Meister and Bittner 2017) from the `obvhs` crate, over the distinct
//! triangles ([`Distinct`]), with triangles that share one bounding box gathered first.
//!
//! **Why the gathering.** PLOC merges a cluster with its nearest neighbour only when the two
//! choose each other. When many clusters have the same box, every candidate merge costs the
//! same (the union is that box), the choices do not agree, and a pass merges one pair: the
//! build becomes Θ(n²) and the tree Θ(n) deep (10,000 different triangles with one box took
//! 4 s, 30,000 took 33 s, 100,000 overflowed the stack). Exact duplicates are left out by
//! [`Distinct`]; triangles that differ but share a box (a fan of triangles spanning one
//! rectangle, one triangle with its vertices listed in several orders) are gathered here.
//!
//! **Method.** The triangles are grouped by their box, bit for bit (a hash table, O(n)).
//! PLOC and reinsertion run over one item per group, the group's box. Then the tree is laid out
//! anew, depth first with siblings adjacent (obvhs' layout): a leaf whose group holds `k > 1`
//! triangles becomes a balanced binary tree of `k` one-triangle leaves, all with the group's
//! box (split by index at the middle: the only split there is when every box is the same),
//! which adds `⌈log₂ k⌉` levels. Every step is O(n) or PLOC's own O(n log n) on distinct
//! boxes. When no two triangles share a box the gathering is skipped and the result is exactly
//! PLOC's.

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::PlocBuilder;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::Distinct;

/// The binary BVH (one triangle per leaf) over the triangles `distinct` keeps of `verts`;
/// its `primitive_indices` are indices into `verts`.
pub fn build_bvh2(verts: &[[Vec3; 3]], distinct: &Distinct) -> Bvh2 {
    let params = BvhBuildParams::medium_build();
    let count = distinct.len(verts.len());
    let boxes: Vec<Aabb> = (0..count as u32)
        .map(|k| {
            let v = &verts[distinct.original(k) as usize];
            Triangle {
                v0: Vec3A::from(v[0]),
                v1: Vec3A::from(v[1]),
                v2: Vec3A::from(v[2]),
            }
            .aabb()
        })
        .collect();
    let key = |b: &Aabb| -> [u32; 6] {
        let (lo, hi) = (b.min.to_array(), b.max.to_array());
        [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(f32::to_bits)
    };
    // Group of every triangle (in the order groups are first met).
    let mut group_of_key = std::collections::HashMap::with_capacity(count);
    let mut group = Vec::with_capacity(count);
    let mut group_box: Vec<Aabb> = Vec::new();
    for b in &boxes {
        let next = group_box.len() as u32;
        let g = *group_of_key.entry(key(b)).or_insert(next);
        if g == next {
            group_box.push(*b);
        }
        group.push(g);
    }
    drop(group_of_key);
    let ploc = |items: &[Aabb]| {
        let mut bvh2 = PlocBuilder::with_capacity(items.len()).build(
            params.ploc_search_distance,
            items,
            (0..items.len() as u32).collect::<Vec<_>>(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        bvh2
    };
    if group_box.len() == count {
        // No two triangles share a box: PLOC as is, leaves renamed to the scene's indices.
        let mut bvh2 = ploc(&boxes);
        if distinct.kept.is_some() {
            for i in &mut bvh2.primitive_indices {
                *i = distinct.original(*i);
            }
        }
        return bvh2;
    }
    // Members of each group, contiguous (counting sort by group), as scene indices.
    let mut start = vec![0u32; group_box.len() + 1];
    for &g in &group {
        start[g as usize + 1] += 1;
    }
    for g in 0..group_box.len() {
        start[g + 1] += start[g];
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; count];
    for (k, &g) in group.iter().enumerate() {
        members[fill[g as usize] as usize] = distinct.original(k as u32);
        fill[g as usize] += 1;
    }
    let tree = ploc(&group_box);
    splice(&tree, &group_box, &start, &members)
}

/// Where a node of the new tree comes from.
enum Source {
    /// A node of the groups' tree.
    Tree(u32),
    /// Members `start..end` of one group (all with the box `group`'s).
    Members { group: u32, start: u32, end: u32 },
}

/// Lays out the groups' tree with every group expanded into a balanced subtree of its
/// members (see the module header).
fn splice(tree: &Bvh2, group_box: &[Aabb], start: &[u32], members: &[u32]) -> Bvh2 {
    let mut nodes: Vec<Bvh2Node> = Vec::with_capacity(2 * members.len());
    let mut prims: Vec<u32> = Vec::with_capacity(members.len());
    nodes.push(Bvh2Node::default());
    let mut stack: Vec<(usize, Source, usize)> = vec![(0, Source::Tree(0), 1)];
    let mut max_depth = 1usize;
    while let Some((at, src, depth)) = stack.pop() {
        max_depth = max_depth.max(depth);
        let (aabb, children) = match src {
            Source::Tree(i) => {
                let n = &tree.nodes[i as usize];
                if n.is_leaf() {
                    // PLOC leaves hold one item: a group.
                    let g = tree.primitive_indices[n.first_index as usize];
                    let (s, e) = (start[g as usize], start[g as usize + 1]);
                    if e - s == 1 {
                        nodes[at] = Bvh2Node::new(*n.aabb(), 1, prims.len() as u32);
                        prims.push(members[s as usize]);
                        continue;
                    }
                    let half = s + (e - s) / 2;
                    (
                        group_box[g as usize],
                        [
                            Source::Members {
                                group: g,
                                start: s,
                                end: half,
                            },
                            Source::Members {
                                group: g,
                                start: half,
                                end: e,
                            },
                        ],
                    )
                } else {
                    (
                        *n.aabb(),
                        [Source::Tree(n.first_index), Source::Tree(n.first_index + 1)],
                    )
                }
            }
            Source::Members { group, start, end } => {
                let b = group_box[group as usize];
                if end - start == 1 {
                    nodes[at] = Bvh2Node::new(b, 1, prims.len() as u32);
                    prims.push(members[start as usize]);
                    continue;
                }
                let half = start + (end - start) / 2;
                (
                    b,
                    [
                        Source::Members {
                            group,
                            start,
                            end: half,
                        },
                        Source::Members {
                            group,
                            start: half,
                            end,
                        },
                    ],
                )
            }
        };
        let first = nodes.len();
        nodes.push(Bvh2Node::default());
        nodes.push(Bvh2Node::default());
        nodes[at] = Bvh2Node::new(aabb, 0, first as u32);
        let [left, right] = children;
        // Right pushed first so the left subtree is laid out first (depth first).
        stack.push((first + 1, right, depth + 1));
        stack.push((first, left, depth + 1));
    }
    Bvh2 {
        nodes,
        primitive_indices: prims,
        max_depth: max_depth.max(obvhs::bvh2::DEFAULT_MAX_STACK_DEPTH),
        ..Bvh2::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every leaf holds one triangle, every triangle is in one leaf, and every box contains
    /// its children's.
    /// Returns the tree's depth.
    fn check(bvh: &Bvh2, verts: &[[Vec3; 3]], distinct: &Distinct) -> usize {
        let mut seen = vec![0u32; verts.len()];
        let mut stack = vec![(0usize, 1usize)];
        let mut depth = 0;
        while let Some((i, d)) = stack.pop() {
            depth = depth.max(d);
            let n = &bvh.nodes[i];
            if n.is_leaf() {
                assert_eq!(n.prim_count, 1);
                let t = bvh.primitive_indices[n.first_index as usize] as usize;
                seen[t] += 1;
                for v in verts[t] {
                    assert!(n.aabb().contains_point(Vec3A::from(v)), "{i}");
                }
            } else {
                for c in [n.first_index as usize, n.first_index as usize + 1] {
                    let b = bvh.nodes[c].aabb();
                    assert!(n.aabb().contains_point(b.min) && n.aabb().contains_point(b.max));
                    stack.push((c, d + 1));
                }
            }
        }
        for (t, &s) in seen.iter().enumerate() {
            let kept = distinct.first.as_ref().is_none_or(|f| f[t] == t as u32);
            assert_eq!(s, kept as u32, "triangle {t}");
        }
        depth
    }

    #[test]
    fn triangles_sharing_a_box_build_a_shallow_tree_over_every_triangle() {
        let n = 5000;
        let mut verts: Vec<[Vec3; 3]> = (0..n)
            .map(|k| {
                let s = 0.4 * k as f32 / n as f32;
                [
                    Vec3::ZERO,
                    Vec3::new(1.0, 1.0, 0.0),
                    Vec3::new(s, 1.0 - s, 0.0),
                ]
            })
            .collect();
        // Some ordinary triangles, and exact duplicates of both kinds.
        for k in 0..50 {
            let o = Vec3::new(2.0 + k as f32, 0.0, 0.0);
            verts.push([o, o + Vec3::X, o + Vec3::Y]);
        }
        verts.extend_from_within(4990..5010);
        let distinct = Distinct::of(&verts);
        assert_eq!(distinct.duplicates, 20);
        let bvh = build_bvh2(&verts, &distinct);
        let depth = check(&bvh, &verts, &distinct);
        // 5,000 triangles in one box: a balanced subtree of depth 13 under PLOC's tree of 51
        // groups (PLOC alone made a chain thousands deep).
        assert!(depth <= 13 + 51, "depth {depth}");
        // Without a shared box the tree is PLOC's own.
        let plain: Vec<[Vec3; 3]> = verts[5000..5050].to_vec();
        let d = Distinct::of(&plain);
        check(&build_bvh2(&plain, &d), &plain, &d);
    }
}
