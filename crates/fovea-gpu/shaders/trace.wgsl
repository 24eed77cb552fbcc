// trace.wgsl: the trace stage's ray casting — closest hits and occlusion of batches of rays
// against triangles, through a binary BVH built on the CPU by obvhs (PLOC, src/trace.rs) and
// traversed here with a short stack, one invocation per ray.
//
// The triangles are stored in the BVH's leaf order (a leaf's `first_index` indexes them
// directly); `prim_ids` maps each back to its index in the caller's list. The ray/triangle test
// is the CPU's (`fovea_render::bvh::intersect_triangle`, Möller–Trumbore, both faces, the same
// determinant threshold and the same closed bounds `t_min ≤ t ≤ t_max`).
//
// The Rust side checks the tree's depth against STACK_SIZE before uploading it: a node's far
// child is pushed once per level at most, so the stack cannot overflow.

struct TraceParams {
    // Rays in this batch (direct_light.wgsl: surface samples).
    ray_count: u32,
    // direct_light.wgsl: the lights, and the shading model's constants
    // (`fovea_render::shade::constants`, π, the largest distance); unused by the traversal.
    light_count: u32,
    _pad0: u32,
    _pad1: u32,
    pi: f32,
    offset_per_t: f32,
    offset_t_cap: f32,
    shadow_shorten: f32,
    min_light_distance: f32,
    spot_min_width: f32,
    min_nv: f32,
    d_floor: f32,
    vis_floor: f32,
    max_distance: f32,
    _pad2: f32,
    _pad3: f32,
}

// obvhs's Bvh2Node, repacked: an inner node when prim_count == 0 (children at first_index and
// first_index + 1), else a leaf of prim_count triangles from first_index.
struct Node {
    min: vec3<f32>,
    prim_count: u32,
    max: vec3<f32>,
    first_index: u32,
}

struct Tri {
    v0: vec4<f32>,
    v1: vec4<f32>,
    v2: vec4<f32>,
}

struct Ray {
    origin: vec3<f32>,
    t_min: f32,
    dir: vec3<f32>,
    t_max: f32,
}

// prim == MISS: no hit. (u, v): barycentrics of vertices 1 and 2.
struct Hit {
    t: f32,
    prim: u32,
    u: f32,
    v: f32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> tris: array<Tri>;
@group(0) @binding(3) var<storage, read> prim_ids: array<u32>;
@group(0) @binding(4) var<storage, read> rays: array<Ray>;
@group(0) @binding(5) var<storage, read_write> hits: array<Hit>;

const STACK_SIZE: u32 = 64u;
const MISS: u32 = 0xffffffffu;
// A distance no hit reaches, standing in for +∞ (WGSL may assume no infinities).
const FAR: f32 = 3.0e38;
// The reciprocal used for a direction component of magnitude < 1e-30 (also ±0): finite, so
// the slab products stay finite for the scene sizes the loaders accept.
const HUGE: f32 = 1.0e30;

// glam's normalize_or_zero (direct_light.wgsl, surface.wgsl).
fn normalize_or_zero(x: vec3<f32>) -> vec3<f32> {
    let len = length(x);
    if len > 0.0 && len < FAR {
        return x * (1.0 / len);
    }
    return vec3<f32>(0.0);
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = abs(d) < vec3<f32>(1.0e-30);
    let big = select(vec3<f32>(HUGE), vec3<f32>(-HUGE), d < vec3<f32>(0.0));
    return select(1.0 / d, big, tiny);
}

// Entry distance of the ray into the box within [t_min, t_max], or FAR when it misses.
fn slab(o: vec3<f32>, inv_d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    let t0 = (lo - o) * inv_d;
    let t1 = (hi - o) * inv_d;
    let near = min(t0, t1);
    let far = max(t0, t1);
    let enter = max(max(near.x, near.y), max(near.z, t_min));
    let leave = min(min(far.x, far.y), min(far.z, t_max));
    return select(FAR, enter, enter <= leave);
}

// Möller–Trumbore as the CPU's: vec3(t, u, v), or t = FAR when there is no hit in [t_min, t_max].
fn intersect(ray: Ray, tri: Tri, t_max: f32) -> vec3<f32> {
    let v0 = tri.v0.xyz;
    let e1 = tri.v1.xyz - v0;
    let e2 = tri.v2.xyz - v0;
    let p = cross(ray.dir, e2);
    let det = dot(e1, p);
    if abs(det) < 1.0e-12 {
        return vec3<f32>(FAR, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    let s = ray.origin - v0;
    let u = dot(s, p) * inv;
    if u < 0.0 || u > 1.0 {
        return vec3<f32>(FAR, 0.0, 0.0);
    }
    let q = cross(s, e1);
    let w = dot(ray.dir, q) * inv;
    if w < 0.0 || u + w > 1.0 {
        return vec3<f32>(FAR, 0.0, 0.0);
    }
    let t = dot(e2, q) * inv;
    if t < ray.t_min || t > t_max {
        return vec3<f32>(FAR, 0.0, 0.0);
    }
    return vec3<f32>(t, u, w);
}

// The closest hit (any_hit = false), or the first hit found (any_hit = true: occlusion).
fn traverse(ray: Ray, any_hit: bool) -> Hit {
    var best = Hit(ray.t_max, MISS, 0.0, 0.0);
    let inv_d = safe_inverse(ray.dir);
    var stack: array<u32, STACK_SIZE>;
    var sp = 0u;
    var node = 0u;
    let root = nodes[0];
    if root.prim_count == 0u && slab(ray.origin, inv_d, root.min, root.max, ray.t_min, ray.t_max) == FAR {
        return best;
    }
    loop {
        let n = nodes[node];
        if n.prim_count > 0u {
            for (var i = n.first_index; i < n.first_index + n.prim_count; i = i + 1u) {
                let h = intersect(ray, tris[i], best.t);
                if h.x != FAR && (best.prim == MISS || h.x < best.t) {
                    best = Hit(h.x, prim_ids[i], h.y, h.z);
                    if any_hit {
                        return best;
                    }
                }
            }
            if sp == 0u {
                break;
            }
            sp = sp - 1u;
            node = stack[sp];
            continue;
        }
        let a = n.first_index;
        let b = a + 1u;
        let na = nodes[a];
        let nb = nodes[b];
        let ta = slab(ray.origin, inv_d, na.min, na.max, ray.t_min, best.t);
        let tb = slab(ray.origin, inv_d, nb.min, nb.max, ray.t_min, best.t);
        if ta == FAR && tb == FAR {
            if sp == 0u {
                break;
            }
            sp = sp - 1u;
            node = stack[sp];
        } else if ta == FAR {
            node = b;
        } else if tb == FAR {
            node = a;
        } else {
            let a_first = ta <= tb;
            node = select(b, a, a_first);
            stack[sp] = select(a, b, a_first);
            sp = sp + 1u;
        }
    }
    return best;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn closest_hit(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    hits[i] = traverse(rays[i], false);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn any_hit(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= params.ray_count {
        return;
    }
    hits[i] = traverse(rays[i], true);
}
