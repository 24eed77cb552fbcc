//! Coherent ray packets through a binary BVH: the obvhs backend's
//! [`RayCaster::intersect_batch`](super::RayCaster::intersect_batch) (the trace stage's
//! primary rays) and [`RayCaster::occluded_batch`](super::RayCaster::occluded_batch) (direct
//! shading's shadow rays towards one light).
//!
//! **Method.** Wald, Slusallek, Benthin and Wagner 2001, "Interactive rendering with coherent
//! ray tracing" (one traversal for a packet of rays, each node tested against the packet,
//! one shared stack), with the ranged ("partition") traversal of Overbeck, Ramamoorthi and Mark
//! 2008, "Large ray packets for real-time Whitted ray tracing": a packet is up to
//! [`PACKET`] = 64 rays in [`GROUPS`] groups of [`LANES`] = 8, and each stack entry carries the
//! first group that hits its node. A child is entered with the first group, from its parent's,
//! whose box test hits; if none does the child is culled, so an inner node costs one 8-lane
//! box test while the packet stays together. A leaf tests its box against every group from the
//! first on and runs the triangle tests only for the groups that hit it. Children go near one
//! first along the axis that separates their centres most, by the direction of the packet's
//! middle ray. The tree is the binary BVH that `obvhs` builds before widening it to its CWBVH
//! (PLOC, reinsertion), collapsed to leaves of up to [`LEAF_MAX`] triangles, laid out depth
//! first with siblings adjacent.
//!
//! **Box test** (Kay–Kajiya slabs), per lane: `t = (plane − o) · (1/d)` for the box's two
//! planes on each axis, the near plane picked by the sign of `d` (so a `d` of `+0.0`, whose
//! inverse is `+∞`, gives `−∞`/`+∞` or, for an origin on the plane, NaN); `t_near` = max of
//! `t_min` and the near planes, `t_far` = min of the ray's closest hit so far and the far
//! planes, each max/min written `if a > b { a } else { b }` so a NaN plane is ignored (the slab
//! does not bound the ray). The node is hit when `t_near ≤ t_far · (1 + 2⁻¹²)`: the slack keeps
//! the test conservative against rounding (a triangle lying in its box's face, a hit found
//! first at a near-equal distance), so the culling never removes the closest hit.
//!
//! **Triangle test.** Möller–Trumbore with the edges `e1 = v1 − v0`, `e2 = v2 − v0` stored per
//! triangle in BVH order (`e1`, `e2` are what [`super::intersect_triangle`] computes, bit for
//! bit), the same operations in the same order on 8 lanes: `p = d × e2`, `det = e1 · p`
//! (rejected when `|det| < 10⁻¹²`), `s = o − v0`, `u = (s · p) / det`, `q = s × e1`,
//! `w = (d · q) / det`, `t = (e2 · q) / det`, accepted when `0 ≤ u ≤ 1`, `w ≥ 0`, `u + w ≤ 1`
//! and `t_min ≤ t`. Rust contracts no multiply–add, so each lane's result is the scalar one.
//!
//! **The closest hit** of a ray is the least `(t, triangle index)` in `[t_min, t_max)`: the
//! least distance, ties to the lower index of [`super::Triangles`]. That does not depend on
//! the order in which leaves are met, so packets, single rays
//! ([`super::obvhs_bvh::ObvhsCaster::intersect`] keeps the same rule) and the brute-force scan
//! agree hit for hit (`tests/bvh.rs`). Shadow rays take any hit in `[t_min, t_max)`: the
//! ray ends there (its distance becomes `−∞`, which fails every later test), and the packet
//! ends when all of its rays have.
//!
//! One difference from `obvhs`' own single-ray traversal remains by construction: that one
//! starts its box intervals at `f32::EPSILON` instead of `t_min` and takes `±1/ε` for the
//! inverse of a direction component within `ε` of zero, so it can cull a hit nearer than `ε`
//! or one reached through such a component; the packets, whose box test is conservative,
//! find those. Rays with `±0.0` components give the same hits both ways in the tests.
//!
//! The inner loops are plain arrays of 8 lanes and auto-vectorise (SSE2 everywhere; the
//! same code compiled for AVX2 where the processor has it, chosen once at run time).

use glam::{Vec2, Vec3};
use obvhs::bvh2::Bvh2;

use super::{Hit, Ray};

/// Lanes of a group: rays tested together by one vector loop.
pub const LANES: usize = 8;
/// Groups of a packet.
pub const GROUPS: usize = 8;
/// Rays of a packet.
pub const PACKET: usize = LANES * GROUPS;
/// Most triangles in a leaf of the packet BVH.
pub const LEAF_MAX: u32 = 4;
/// The box test's relative slack on `t_far` (2⁻¹²).
const SLACK: f32 = 1.0 + 1.0 / 4096.0;

type L<T> = [T; LANES];

/// A node of the packet BVH, 32 bytes. An inner node's children are `first` and
/// `first + 1`; a leaf's triangles are `first .. first + count`.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Node {
    min: [f32; 3],
    first: u32,
    max: [f32; 3],
    /// Leaf: the triangle count (≥ 1). Inner: 0 in the low 16 bits, the split axis in
    /// bits 16–17 and, in bit 18, whether `first` lies below `first + 1` on it.
    meta: u32,
}

impl Node {
    #[inline(always)]
    fn count(&self) -> u32 {
        self.meta & 0xffff
    }
}

/// A triangle in BVH order: `v0`, the two edges from it, and its index in
/// [`super::Triangles`].
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    index: u32,
}

/// The binary BVH the packets traverse.
pub struct PacketBvh {
    nodes: Vec<Node>,
    tris: Vec<Tri>,
    /// Levels below the root (the most a traversal stack holds).
    depth: usize,
    avx2: bool,
}

impl PacketBvh {
    /// Lays out `bvh2` (leaves indexing `bvh2.primitive_indices`) over `verts`, the scene's
    /// triangles in their original order.
    pub fn new(bvh2: &Bvh2, verts: &[[Vec3; 3]]) -> Self {
        let mut out = Self {
            nodes: Vec::with_capacity(bvh2.nodes.len()),
            tris: Vec::with_capacity(verts.len()),
            depth: 0,
            avx2: detect_avx2(),
        };
        if bvh2.nodes.is_empty() || verts.is_empty() {
            return out;
        }
        out.nodes.push(Node::default());
        // (source node, slot in `out.nodes`, depth)
        let mut todo = vec![(0usize, 0usize, 0usize)];
        while let Some((src, dst, depth)) = todo.pop() {
            out.depth = out.depth.max(depth);
            let n = &bvh2.nodes[src];
            let mut node = Node {
                min: n.aabb.min.to_array(),
                max: n.aabb.max.to_array(),
                ..Node::default()
            };
            if n.prim_count > 0 {
                node.first = out.tris.len() as u32;
                node.meta = n.prim_count;
                for k in n.first_index..n.first_index + n.prim_count {
                    let index = bvh2.primitive_indices[k as usize];
                    let v = &verts[index as usize];
                    out.tris.push(Tri {
                        v0: v[0],
                        e1: v[1] - v[0],
                        e2: v[2] - v[0],
                        index,
                    });
                }
            } else {
                let (a, b) = (n.first_index as usize, n.first_index as usize + 1);
                let ca = bvh2.nodes[a].aabb.center();
                let cb = bvh2.nodes[b].aabb.center();
                let gap = (cb - ca).abs();
                let axis = if gap.x >= gap.y && gap.x >= gap.z {
                    0
                } else if gap.y >= gap.z {
                    1
                } else {
                    2
                };
                let lower = u32::from(ca[axis] <= cb[axis]);
                node.first = out.nodes.len() as u32;
                node.meta = ((axis as u32) << 16) | (lower << 18);
                out.nodes.push(Node::default());
                out.nodes.push(Node::default());
                // Right pushed first: the left subtree is laid out next, depth first.
                todo.push((b, node.first as usize + 1, depth + 1));
                todo.push((a, node.first as usize, depth + 1));
            }
            out.nodes[dst] = node;
        }
        out
    }

    /// The closest hit of every ray of `rays` into `out` (the same length), [`PACKET`] rays
    /// at a time.
    pub fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        let mut stack = Vec::with_capacity(self.depth + 1);
        for (rs, os) in rays.chunks(PACKET).zip(out.chunks_mut(PACKET)) {
            let mut p = Packet::new(rs);
            self.run::<false>(&mut p, &mut stack);
            p.write(rs.len(), os);
        }
    }

    /// Whether anything lies in `[t_min, t_max)` of every ray of `rays`, into `out` (the same
    /// length), [`PACKET`] rays at a time.
    pub fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        let mut stack = Vec::with_capacity(self.depth + 1);
        for (rs, os) in rays.chunks(PACKET).zip(out.chunks_mut(PACKET)) {
            let mut p = Packet::new(rs);
            self.run::<true>(&mut p, &mut stack);
            for (k, o) in os.iter_mut().enumerate().take(rs.len()) {
                let (g, l) = (k / LANES, k % LANES);
                *o = p.t[g][l] == f32::NEG_INFINITY && p.t_max[g][l] > f32::NEG_INFINITY;
            }
        }
    }

    #[inline]
    fn run<const ANY: bool>(&self, p: &mut Packet, stack: &mut Vec<(u32, usize)>) {
        if self.nodes.is_empty() {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the processor reports AVX2.
            unsafe { traverse_avx2::<ANY>(self, p, stack) };
            return;
        }
        traverse::<ANY>(self, p, stack);
    }
}

fn detect_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A packet's rays, structure of arrays, and each ray's closest hit so far.
struct Packet {
    groups: usize,
    o: [[L<f32>; GROUPS]; 3],
    d: [[L<f32>; GROUPS]; 3],
    inv: [[L<f32>; GROUPS]; 3],
    /// Whether the direction component is negative (all bits set) or not.
    neg: [[L<u32>; GROUPS]; 3],
    t_min: [L<f32>; GROUPS],
    t_max: [L<f32>; GROUPS],
    /// The closest hit's distance so far, `t_max` before any.
    t: [L<f32>; GROUPS],
    /// The closest hit's triangle index (0 before any: a hit at `t_max` is never taken).
    tri: [L<u32>; GROUPS],
    u: [L<f32>; GROUPS],
    w: [L<f32>; GROUPS],
    /// The ray whose direction orders the children.
    mid: Vec3,
}

impl Packet {
    fn new(rays: &[Ray]) -> Self {
        debug_assert!(rays.len() <= PACKET);
        let z = [[0.0; LANES]; GROUPS];
        let mut p = Packet {
            groups: rays.len().div_ceil(LANES),
            o: [z; 3],
            d: [z; 3],
            inv: [z; 3],
            neg: [[[0; LANES]; GROUPS]; 3],
            // Padding lanes: an empty interval, never hit.
            t_min: [[f32::INFINITY; LANES]; GROUPS],
            t_max: [[f32::NEG_INFINITY; LANES]; GROUPS],
            t: [[f32::NEG_INFINITY; LANES]; GROUPS],
            tri: [[0; LANES]; GROUPS],
            u: z,
            w: z,
            mid: rays.get(rays.len() / 2).map_or(Vec3::ONE, |r| r.dir),
        };
        for (k, r) in rays.iter().enumerate() {
            let (g, l) = (k / LANES, k % LANES);
            for a in 0..3 {
                // `-0.0` made `+0.0` (IEEE 754: -0.0 + 0.0 = +0.0), as `ObvhsCaster::to_obvhs`
                // does: a zero component's inverse is then `+∞`, its near plane the minimum.
                let d = r.dir[a] + 0.0;
                p.o[a][g][l] = r.origin[a];
                p.d[a][g][l] = r.dir[a];
                p.inv[a][g][l] = 1.0 / d;
                p.neg[a][g][l] = if d < 0.0 { u32::MAX } else { 0 };
            }
            p.t_min[g][l] = r.t_min;
            p.t_max[g][l] = r.t_max;
            p.t[g][l] = r.t_max;
        }
        p
    }

    /// Whether every ray has ended (an any-hit found, or padding).
    #[inline(always)]
    fn all_ended(&self) -> bool {
        let mut live = 0u32;
        for g in 0..self.groups {
            for l in 0..LANES {
                live |= u32::from(self.t[g][l] != f32::NEG_INFINITY);
            }
        }
        live == 0
    }

    fn write(&self, n: usize, out: &mut [Option<Hit>]) {
        for (k, o) in out.iter_mut().enumerate().take(n) {
            let (g, l) = (k / LANES, k % LANES);
            // A hit is only ever taken below `t_max`.
            let t = self.t[g][l];
            *o = (t < self.t_max[g][l]).then(|| Hit {
                t,
                tri: self.tri[g][l],
                bary: Vec2::new(self.u[g][l], self.w[g][l]),
            });
        }
    }
}

/// No group: the node misses the packet.
const NONE: usize = usize::MAX;

/// Whether any ray of group `g` enters `n`'s box before its closest hit so far.
#[inline(always)]
fn box_hits(p: &Packet, g: usize, n: &Node) -> bool {
    let mut near = p.t_min[g];
    let mut far = p.t[g];
    for a in 0..3 {
        let (lo, hi) = (n.min[a], n.max[a]);
        let (o, inv, neg) = (&p.o[a][g], &p.inv[a][g], &p.neg[a][g]);
        for l in 0..LANES {
            let t0 = (lo - o[l]) * inv[l];
            let t1 = (hi - o[l]) * inv[l];
            // The near and far planes by the direction's sign, as bit masks (a blend).
            let (b0, b1) = (t0.to_bits(), t1.to_bits());
            let tn = f32::from_bits((b0 & !neg[l]) | (b1 & neg[l]));
            let tf = f32::from_bits((b1 & !neg[l]) | (b0 & neg[l]));
            // A NaN plane (origin on it, direction 0) compares false and is ignored.
            near[l] = if tn > near[l] { tn } else { near[l] };
            far[l] = if tf < far[l] { tf } else { far[l] };
        }
    }
    let mut any = 0u32;
    for l in 0..LANES {
        any |= u32::from(near[l] <= far[l] * SLACK);
    }
    any != 0
}

/// The first group from `from` that hits `n`, or [`NONE`].
#[inline(always)]
fn first_hit(p: &Packet, n: &Node, from: usize) -> usize {
    (from..p.groups)
        .find(|&g| box_hits(p, g, n))
        .unwrap_or(NONE)
}

/// Möller–Trumbore of `tri` against group `g`'s rays, keeping each ray's least
/// `(t, triangle index)` (see the module's header: [`super::intersect_triangle`] lane by lane).
///
/// With `ANY` (shadow rays) a hit anywhere in `[t_min, t_max)` ends the ray: its distance
/// becomes `−∞`, which no box or triangle test passes again.
// The acceptance is written as the scalar test's comparisons, NaN behaviour included
// (`!(w < 0.0)` passes a NaN `w` as the scalar code does), joined with `&` so the lanes
// stay branch-free.
#[allow(clippy::neg_cmp_op_on_partial_ord, clippy::manual_range_contains)]
#[inline(always)]
fn hit_triangle<const ANY: bool>(p: &mut Packet, g: usize, tri: &Tri) {
    let (v0, e1, e2, index) = (tri.v0, tri.e1, tri.e2, tri.index);
    for l in 0..LANES {
        let (dx, dy, dz) = (p.d[0][g][l], p.d[1][g][l], p.d[2][g][l]);
        // p = d × e2
        let px = dy * e2.z - e2.y * dz;
        let py = dz * e2.x - e2.z * dx;
        let pz = dx * e2.y - e2.x * dy;
        let det = (e1.x * px) + (e1.y * py) + (e1.z * pz);
        let inv = 1.0 / det;
        // s = o − v0
        let sx = p.o[0][g][l] - v0.x;
        let sy = p.o[1][g][l] - v0.y;
        let sz = p.o[2][g][l] - v0.z;
        let u = ((sx * px) + (sy * py) + (sz * pz)) * inv;
        // q = s × e1
        let qx = sy * e1.z - e1.y * sz;
        let qy = sz * e1.x - e1.z * sx;
        let qz = sx * e1.y - e1.x * sy;
        let w = ((dx * qx) + (dy * qy) + (dz * qz)) * inv;
        let t = ((e2.x * qx) + (e2.y * qy) + (e2.z * qz)) * inv;
        let (bt, bi) = (p.t[g][l], p.tri[g][l]);
        let take = !(det.abs() < 1e-12)
            & (0.0 <= u)
            & (u <= 1.0)
            & !(w < 0.0)
            & !(u + w > 1.0)
            & (t >= p.t_min[g][l])
            & ((t < bt) | (!ANY & (t == bt) & (index < bi)));
        if ANY {
            p.t[g][l] = if take { f32::NEG_INFINITY } else { bt };
            continue;
        }
        p.t[g][l] = if take { t } else { bt };
        p.tri[g][l] = if take { index } else { bi };
        p.u[g][l] = if take { u } else { p.u[g][l] };
        p.w[g][l] = if take { w } else { p.w[g][l] };
    }
}

/// The packet through the tree, closest hits into `p` (with `ANY`, any hits: the traversal
/// ends when every ray has one).
#[inline(always)]
fn traverse_in<const ANY: bool>(bvh: &PacketBvh, p: &mut Packet, stack: &mut Vec<(u32, usize)>) {
    stack.clear();
    let nodes = &bvh.nodes;
    let mut cur = (0u32, first_hit(p, &nodes[0], 0));
    if cur.1 == NONE {
        return;
    }
    loop {
        let n = &nodes[cur.0 as usize];
        let count = n.count();
        if count > 0 {
            let tris = &bvh.tris[n.first as usize..(n.first + count) as usize];
            for g in cur.1..p.groups {
                if g == cur.1 || box_hits(p, g, n) {
                    for tri in tris {
                        hit_triangle::<ANY>(p, g, tri);
                    }
                }
            }
            if ANY && p.all_ended() {
                return;
            }
        } else {
            let axis = ((n.meta >> 16) & 3) as usize;
            let first_is_lower = (n.meta >> 18) & 1 != 0;
            let (near, far) = if (p.mid[axis] >= 0.0) == first_is_lower {
                (n.first, n.first + 1)
            } else {
                (n.first + 1, n.first)
            };
            let gn = first_hit(p, &nodes[near as usize], cur.1);
            let gf = first_hit(p, &nodes[far as usize], cur.1);
            match (gn != NONE, gf != NONE) {
                (true, true) => {
                    stack.push((far, gf));
                    cur = (near, gn);
                    continue;
                }
                (true, false) => {
                    cur = (near, gn);
                    continue;
                }
                (false, true) => {
                    cur = (far, gf);
                    continue;
                }
                (false, false) => {}
            }
        }
        // Pop the next node that some ray still enters (closer hits may have culled it).
        loop {
            let Some((node, g)) = stack.pop() else {
                return;
            };
            let g = first_hit(p, &nodes[node as usize], g);
            if g != NONE {
                cur = (node, g);
                break;
            }
        }
    }
}

fn traverse<const ANY: bool>(bvh: &PacketBvh, p: &mut Packet, stack: &mut Vec<(u32, usize)>) {
    traverse_in::<ANY>(bvh, p, stack);
}

/// [`traverse`] compiled for AVX2 (the same operations, 8 lanes per instruction).
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn traverse_avx2<const ANY: bool>(
    bvh: &PacketBvh,
    p: &mut Packet,
    stack: &mut Vec<(u32, usize)>,
) {
    traverse_in::<ANY>(bvh, p, stack);
}
