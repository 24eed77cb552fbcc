// pull_push.wgsl: Weier et al. 2016's screen-aligned reconstruction of sparse samples — the
// pull-push hole filling of Gortler et al. 1996 for colour, the nearest shaded pixel for
// depth. The GPU twin of `fovea_post::pull_push::pull_push` and
// `fovea_post::inverse_map::nearest_fill_depth`; see src/pull_push.rs.
//
// Buffers (every level in one buffer, at the offsets the Rust side computes):
//
//   colour   3 f32 per pixel (as u32 bits), level 0 (the screen) first, then level 1, 2, …
//            of sizes ceil(w/2^l) × ceil(h/2^l) down to 1×1.
//   weight   1 f32 per pixel of levels 1, 2, …; level 0's weight is the mask (1 or 0).
//   mask     1 bit per screen pixel (bit k % 32 of word k / 32): shaded or not.
//   depth    1 f32 per screen pixel (as u32 bits), filled in place.
//
// pull (one dispatch per level l → l+1, one invocation per coarse pixel):
//   acc = Σ q·c, sw = Σ q over the 2×2 fine pixels inside the level (row by row),
//   c = acc / sw where sw > 0 (else 0), weight = min(sw, 1).
// push (one dispatch per level l+1 → l, coarsest first, one invocation per fine pixel):
//   where q < 1: c = q·c + (1 − q)·up, up = bilinear of level l+1 at the pixel's centre
//   ((x + ½)/2 − ½, clamped to the level), the CPU's lerp order (a + (b − a)·t).
//   Shaded pixels (q = 1) are never written: their bits stay the uploaded ones.
// fill_depth (one invocation per screen pixel): an unshaded pixel takes the depth of the
//   first shaded pixel on the rings of Chebyshev radius 1, 2, … ≤ max_radius, each ring
//   visited row by row and left to right (the CPU's order); none: +∞ (bits from the Rust
//   side). Shaded pixels are not written, so the pass reads and writes one buffer safely.
//
// The arithmetic is the CPU's in f32 and in the same order; a device may fuse a multiply and
// an add (WGSL allows it), which moves a value by about an ulp.

struct PullPushParams {
    // The level read (pull) or written (push): size and offset (pixels) in the colour buffer.
    fine_w: u32,
    fine_h: u32,
    fine_off: u32,
    // Its index (0: the screen, whose weight is the mask).
    fine_level: u32,
    // The coarser level: size, offset in the colour buffer, offset in the weight buffer.
    coarse_w: u32,
    coarse_h: u32,
    coarse_off: u32,
    coarse_wt_off: u32,
    // The fine level's offset in the weight buffer (levels ≥ 1).
    fine_wt_off: u32,
    // Invocations of the dispatch that do work (coarse pixels for pull, fine for push,
    // screen pixels for fill_depth).
    n: u32,
    // The depth search's largest ring, pixels.
    max_radius: u32,
    // f32::INFINITY's bits.
    miss_depth_bits: u32,
}

@group(0) @binding(0) var<uniform> params: PullPushParams;
@group(0) @binding(1) var<storage, read> mask: array<u32>;
@group(0) @binding(2) var<storage, read_write> colour: array<u32>;
@group(0) @binding(3) var<storage, read_write> weight: array<f32>;

// The invocation's index in a dispatch of (gx, gy) workgroups of 64 (rows of gx workgroups).
fn invocation(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.y * groups.x * WORKGROUP_SIZE + gid.x;
}

fn shaded(k: u32) -> bool {
    return ((mask[k >> 5u] >> (k & 31u)) & 1u) == 1u;
}

// The weight of pixel k of the fine level.
fn fine_weight(k: u32) -> f32 {
    if params.fine_level == 0u {
        return select(0.0, 1.0, shaded(k));
    }
    return weight[params.fine_wt_off + k];
}

fn load(off: u32, k: u32) -> vec3<f32> {
    let b = 3u * (off + k);
    return vec3<f32>(
        bitcast<f32>(colour[b]),
        bitcast<f32>(colour[b + 1u]),
        bitcast<f32>(colour[b + 2u])
    );
}

fn store(off: u32, k: u32, c: vec3<f32>) {
    let b = 3u * (off + k);
    colour[b] = bitcast<u32>(c.x);
    colour[b + 1u] = bitcast<u32>(c.y);
    colour[b + 2u] = bitcast<u32>(c.z);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn pull(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    let x = i % params.coarse_w;
    let y = i / params.coarse_w;
    var acc = vec3<f32>(0.0);
    var sw = 0.0;
    for (var dy = 0u; dy < 2u; dy++) {
        for (var dx = 0u; dx < 2u; dx++) {
            let sx = 2u * x + dx;
            let sy = 2u * y + dy;
            if sx < params.fine_w && sy < params.fine_h {
                let k = sy * params.fine_w + sx;
                let q = fine_weight(k);
                let c = load(params.fine_off, k);
                acc = vec3<f32>(acc.x + q * c.x, acc.y + q * c.y, acc.z + q * c.z);
                sw += q;
            }
        }
    }
    var c = vec3<f32>(0.0);
    if sw > 0.0 {
        c = vec3<f32>(acc.x / sw, acc.y / sw, acc.z / sw);
    }
    store(params.coarse_off, i, c);
    weight[params.coarse_wt_off + i] = min(sw, 1.0);
}

fn lerp3(a: vec3<f32>, b: vec3<f32>, t: f32) -> vec3<f32> {
    return vec3<f32>(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn push(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    let q = fine_weight(i);
    if q >= 1.0 {
        return;
    }
    let x = i % params.fine_w;
    let y = i / params.fine_w;
    // Bilinear in the coarse level at this pixel's centre.
    let cx = clamp((f32(x) + 0.5) / 2.0 - 0.5, 0.0, f32(params.coarse_w - 1u));
    let cy = clamp((f32(y) + 0.5) / 2.0 - 0.5, 0.0, f32(params.coarse_h - 1u));
    let x0 = u32(floor(cx));
    let y0 = u32(floor(cy));
    let x1 = min(x0 + 1u, params.coarse_w - 1u);
    let y1 = min(y0 + 1u, params.coarse_h - 1u);
    let tx = cx - f32(x0);
    let ty = cy - f32(y0);
    let cw = params.coarse_w;
    let off = params.coarse_off;
    let top = lerp3(load(off, y0 * cw + x0), load(off, y0 * cw + x1), tx);
    let bot = lerp3(load(off, y1 * cw + x0), load(off, y1 * cw + x1), tx);
    let up = lerp3(top, bot, ty);
    let c = load(params.fine_off, i);
    let p = 1.0 - q;
    store(params.fine_off, i, vec3<f32>(q * c.x + p * up.x, q * c.y + p * up.y, q * c.z + p * up.z));
}

@group(0) @binding(4) var<storage, read_write> depth: array<u32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn fill_depth(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation(gid, groups);
    if i >= params.n || shaded(i) {
        return;
    }
    let w = i32(params.fine_w);
    let h = i32(params.fine_h);
    let x = i32(i % params.fine_w);
    let y = i32(i / params.fine_w);
    for (var rad = 1i; rad <= i32(params.max_radius); rad++) {
        // Rows of the ring inside the screen, top to bottom.
        let dy0 = max(-rad, -y);
        let dy1 = min(rad, h - 1 - y);
        for (var dy = dy0; dy <= dy1; dy++) {
            let row = u32((y + dy) * w);
            if abs(dy) == rad {
                // The ring's top or bottom row, left to right.
                let dx0 = max(-rad, -x);
                let dx1 = min(rad, w - 1 - x);
                for (var dx = dx0; dx <= dx1; dx++) {
                    let k = row + u32(x + dx);
                    if shaded(k) {
                        depth[i] = depth[k];
                        return;
                    }
                }
            } else {
                // Its left then right side.
                if x - rad >= 0 {
                    let k = row + u32(x - rad);
                    if shaded(k) {
                        depth[i] = depth[k];
                        return;
                    }
                }
                if x + rad < w {
                    let k = row + u32(x + rad);
                    if shaded(k) {
                        depth[i] = depth[k];
                        return;
                    }
                }
            }
        }
    }
    depth[i] = params.miss_depth_bits;
}
