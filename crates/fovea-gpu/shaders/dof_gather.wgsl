// dof_gather.wgsl: the scatter-as-gather near/far depth-of-field filter (Jimenez 2014,
// "Next-generation post-processing in Call of Duty: Advanced Warfare"; the game-engine
// baseline of DESIGN.md stage 7, compared with the papers' filters). The GPU twin of
// `fovea_post::dof::gather::ScatterAsGather` (read its module docs for the formulas); see
// src/dof.rs. Three entry points, dispatched in this order on the planes `dof_coc.wgsl` wrote:
//
// 1. `tile_max`: per 16×16 tile, the largest CoC radius of its pixels;
// 2. `tile_reach`: per tile, the largest radius of any tile whose discs can reach it (the
//    CPU's `disc::TileReach`, same loop);
// 3. `gather`: per pixel, the disc offsets (uploaded, sorted by distance as the CPU visits
//    them) with |o| < reach + ½, each sample P weighted by the anti-aliased disc
//    cov(ρ, d) = clamp(ρ − d + ½, 0, 1) over the area 1/A(ρ_w) and sorted into the near
//    layer (in front of C: z_P < z_C·(1 − tol)), or the far layer (same surface: P's disc;
//    behind: C's disc with fill_behind, else min(r_P, r_C) with P's area), composited
//    α·near + (1 − α)·far, α = min(1, Σ_near w).
//
// Constants from the Rust side: the offsets, 1 − tol and 1 + tol (rounded as the CPU's f32),
// the tile size and the dilation span. Depths of pixels with no hit (+∞ on the CPU) are
// stored as 0 bits instead (a surface's depth never has them): WGSL may assume no float is
// infinite, so the comparisons with +∞ are written out (a pixel with no hit is behind every
// surface and the same surface as another with none).
//
// Every per-pixel buffer holds one 4-byte value a pixel — the planes `dof_coc.wgsl` wrote, the
// colour and the output as three planes of one channel each — so that an 8K screen's (126.6
// MiB a buffer) fits lavapipe's 128 MiB storage bindings (issue 37). The gather binds 11
// storage buffers (checked against the adapter's per-stage limit on the Rust side).

struct GatherParams {
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    // Tile side, pixels (16).
    tile_px: u32,
    // Tiles either way a tile's reach looks at: ceil((max_radius + ½)/tile) + 1.
    span: i32,
    // Offsets in the table.
    n_offsets: u32,
    // Bit 0: fill_behind; bit 1: separate_near.
    flags: u32,
    // 1 − depth_tolerance and 1 + depth_tolerance, f32 as the CPU rounds them.
    near_factor: f32,
    far_factor: f32,
    pad0: u32,
    pad1: u32,
}

// One pixel's planes, as the gather reads them.
struct Plane {
    // View depth, metres (0 where `hit` is false).
    depth_m: f32,
    radius_px: f32,
    inv_area: f32,
    hit: bool,
}

// One disc offset: (dx, dy) and its length |o|.
struct Offset {
    dx: i32,
    dy: i32,
    d: f32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> params: GatherParams;
@group(0) @binding(1) var<storage, read> plane_depth: array<u32>;
@group(0) @binding(2) var<storage, read> plane_radius: array<f32>;
@group(0) @binding(3) var<storage, read> plane_inv_area: array<f32>;
@group(0) @binding(4) var<storage, read> color_r: array<f32>;
@group(0) @binding(5) var<storage, read> color_g: array<f32>;
@group(0) @binding(6) var<storage, read> color_b: array<f32>;
@group(0) @binding(7) var<storage, read> offsets: array<Offset>;
@group(0) @binding(8) var<storage, read_write> tile_max_px: array<f32>;
@group(0) @binding(9) var<storage, read_write> reach_px: array<f32>;
@group(0) @binding(10) var<storage, read_write> out_r: array<f32>;
@group(0) @binding(11) var<storage, read_write> out_g: array<f32>;
@group(0) @binding(12) var<storage, read_write> out_b: array<f32>;

// Pixel i's planes (the hit flag from the depth's bits).
fn plane(i: u32) -> Plane {
    let bits = plane_depth[i];
    return Plane(bitcast<f32>(bits), plane_radius[i], plane_inv_area[i], bits != 0u);
}

fn store(i: u32, c: vec3<f32>) {
    out_r[i] = c.x;
    out_g[i] = c.y;
    out_b[i] = c.z;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tile_max(@builtin(global_invocation_id) id: vec3<u32>) {
    let tx = id.x;
    let ty = id.y;
    if tx >= params.tiles_x || ty >= params.tiles_y {
        return;
    }
    let x0 = tx * params.tile_px;
    let y0 = ty * params.tile_px;
    let x1 = min(x0 + params.tile_px, params.width);
    let y1 = min(y0 + params.tile_px, params.height);
    var m = 0.0;
    for (var y = y0; y < y1; y++) {
        for (var x = x0; x < x1; x++) {
            m = max(m, plane_radius[y * params.width + x]);
        }
    }
    tile_max_px[ty * params.tiles_x + tx] = m;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn tile_reach(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.tiles_x || id.y >= params.tiles_y {
        return;
    }
    let tx = i32(id.x);
    let ty = i32(id.y);
    let tw = i32(params.tiles_x);
    let th = i32(params.tiles_y);
    let tile = f32(params.tile_px);
    var r = tile_max_px[ty * tw + tx];
    for (var sy = max(ty - params.span, 0); sy <= min(ty + params.span, th - 1); sy++) {
        for (var sx = max(tx - params.span, 0); sx <= min(tx + params.span, tw - 1); sx++) {
            let m = tile_max_px[sy * tw + sx];
            if m <= r {
                continue;
            }
            // Gap between the two tiles' nearest pixel centres, pixels.
            var gx = 0.0;
            var gy = 0.0;
            if sx != tx {
                gx = f32(max(abs(sx - tx) - 1, 0)) * tile + 1.0;
            }
            if sy != ty {
                gy = f32(max(abs(sy - ty) - 1, 0)) * tile + 1.0;
            }
            if sqrt(gx * gx + gy * gy) < m + 0.5 {
                r = m;
            }
        }
    }
    reach_px[id.y * params.tiles_x + id.x] = r;
}

// Anti-aliased disc coverage: clamp(r − d + ½, 0, 1).
fn coverage(radius_px: f32, d_px: f32) -> f32 {
    return clamp(radius_px - d_px + 0.5, 0.0, 1.0);
}

fn rgb(i: u32) -> vec3<f32> {
    return vec3<f32>(color_r[i], color_g[i], color_b[i]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let w = params.width;
    let i = y * w + x;
    let c_self = rgb(i);
    let search_px = reach_px[(y / params.tile_px) * params.tiles_x + x / params.tile_px];
    if search_px <= 0.5 {
        store(i, c_self);
        return;
    }
    let pc = plane(i);
    let fill_behind = (params.flags & 1u) != 0u;
    let separate_near = (params.flags & 2u) != 0u;
    let near_limit = pc.depth_m * params.near_factor;
    let far_limit = pc.depth_m * params.far_factor;
    let reach = search_px + 0.5;
    var near_sum = vec3<f32>(0.0);
    var near_w = 0.0;
    var far_sum = vec3<f32>(0.0);
    var far_w = 0.0;
    for (var k = 0u; k < params.n_offsets; k++) {
        let o = offsets[k];
        if !(o.d < reach) {
            break;
        }
        let px = i32(x) + o.dx;
        let py = i32(y) + o.dy;
        if px < 0 || py < 0 || px >= i32(w) || py >= i32(params.height) {
            continue;
        }
        let j = u32(py) * w + u32(px);
        let pp = plane(j);
        // In front of C (near layer), behind it, or the same surface; +∞ written out.
        var in_front = false;
        var behind = false;
        if !pc.hit {
            in_front = pp.hit;
        } else if !pp.hit {
            behind = true;
        } else {
            in_front = pp.depth_m < near_limit;
            behind = pp.depth_m > far_limit;
        }
        var wt = 0.0;
        if behind {
            if fill_behind {
                wt = coverage(pc.radius_px, o.d) * pc.inv_area;
            } else {
                wt = coverage(min(pp.radius_px, pc.radius_px), o.d) * pp.inv_area;
            }
        } else {
            wt = coverage(pp.radius_px, o.d) * pp.inv_area;
        }
        if wt > 0.0 {
            let c = rgb(j);
            if in_front && separate_near {
                near_sum += wt * c;
                near_w += wt;
            } else {
                far_sum += wt * c;
                far_w += wt;
            }
        }
    }
    var far = c_self;
    if far_w > 0.0 {
        far = far_sum * (1.0 / far_w);
    }
    var result = far;
    if near_w > 0.0 {
        let alpha = min(near_w, 1.0);
        result = alpha * (near_sum * (1.0 / near_w)) + (1.0 - alpha) * far;
    }
    store(i, result);
}
