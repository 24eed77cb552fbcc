// fxaa.wgsl: FXAA inside a sample buffer after Lottes' FXAA 3.11 "quality" variant, as VaFR
// (Sec. 3.4 / 6) applies it in the log-polar buffer before the inverse mapping; stage 5 of
// DESIGN.md on the GPU, the twin of `fovea_post::fxaa::fxaa` (same neighbours through
// sample_grid.wgsl, with the polar seam wrapped and columns compared at equal angles; same
// arithmetic in the same order). Two entry points, dispatched one after the other:
//
// 1. `fxaa_luma`: per texel the perceptual luma √(Y/(1+Y)) of Rec. 601 Y (clamped at 0),
//    into `lum`;
// 2. `fxaa`: per valid texel the local contrast of the 4-neighbourhood against
//    max(edge_threshold_min, edge_threshold · max luma); where it is above, the edge
//    orientation from second differences of the 3×3 lumas, the edge followed both ways (at
//    most `search_steps` texels) until the mean luma of the texel pair leaves the edge, and
//    a blend towards the texel across the edge by ½ − (distance to the nearer end)/(edge
//    length) when the end's sign test passes, or by the sub-pixel estimate if larger.

@group(0) @binding(4) var<storage, read_write> lum: array<f32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn fxaa_luma(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    let p = vec2<u32>(gid.x, gid.y);
    let c = rgb_at(p);
    let y = max(0.299 * c.x + 0.587 * c.y + 0.114 * c.z, 0.0);
    lum[texel_index(p)] = sqrt(y / (1.0 + y));
}

fn l(p: vec2<u32>) -> f32 {
    return lum[texel_index(p)];
}

// Steps (at most `search_steps`) along the edge from `p` in direction `along` until the mean
// luma of the texel and its neighbour `across` leaves `edge_luma` by `limit`, or the grid
// ends (a step that stays put).
fn walk(p: vec2<u32>, along: vec2<i32>, across: vec2<i32>, edge_luma: f32, limit: f32) -> u32 {
    var c = p;
    for (var k = 1u; k <= params.search_steps; k = k + 1u) {
        let s = grid_step(c, along.x, along.y);
        if all(s == c) {
            return k - 1u;
        }
        c = s;
        let q = grid_step(c, across.x, across.y);
        let pair = 0.5 * (l(s) + l(q));
        if abs(pair - edge_luma) >= limit {
            return k;
        }
    }
    return params.search_steps;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn fxaa(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    let p = vec2<u32>(gid.x, gid.y);
    let own = rgb_at(p);
    write_rgb(p, own);
    if !is_valid(p) {
        return;
    }
    // The 3×3 neighbourhood: one column step, then one row step.
    let pw = grid_step(p, -1, 0);
    let pe = grid_step(p, 1, 0);
    let m = l(p);
    let n = l(step_row(p, -1));
    let s = l(step_row(p, 1));
    let wv = l(pw);
    let e = l(pe);
    let hi = max(max(max(max(m, n), s), wv), e);
    let lo = min(min(min(min(m, n), s), wv), e);
    let range = hi - lo;
    if range < max(params.edge_threshold_min, hi * params.edge_threshold) {
        return;
    }
    let nw = l(step_row(pw, -1));
    let ne = l(step_row(pe, -1));
    let sw = l(step_row(pw, 1));
    let se = l(step_row(pe, 1));
    // Sub-pixel aliasing estimate.
    let avg = (2.0 * (n + s + wv + e) + nw + ne + sw + se) / 12.0;
    var sub = clamp(abs(avg - m) / range, 0.0, 1.0);
    sub = (-2.0 * sub + 3.0) * sub * sub;
    sub = sub * sub * params.subpix;
    // Edge orientation: "horizontal" = the edge runs along i (columns), so the neighbour
    // across it is in j.
    let edge_h = abs(n + s - 2.0 * m) * 2.0 + abs(ne + se - 2.0 * e) + abs(nw + sw - 2.0 * wv);
    let edge_v = abs(wv + e - 2.0 * m) * 2.0 + abs(ne + nw - 2.0 * n) + abs(se + sw - 2.0 * s);
    let horizontal = edge_h >= edge_v;
    var l_neg = wv;
    var l_pos = e;
    var along = vec2<i32>(0, 1);
    if horizontal {
        l_neg = n;
        l_pos = s;
        along = vec2<i32>(1, 0);
    }
    let g_neg = abs(l_neg - m);
    let g_pos = abs(l_pos - m);
    var side = -1;
    var l_across = l_neg;
    var grad = g_neg;
    if g_pos >= g_neg {
        side = 1;
        l_across = l_pos;
        grad = g_pos;
    }
    var across = vec2<i32>(side, 0);
    if horizontal {
        across = vec2<i32>(0, side);
    }
    let edge_luma = 0.5 * (m + l_across);
    let limit = grad * 0.25;
    let d_neg = walk(p, -along, across, edge_luma, limit);
    let d_pos = walk(p, along, across, edge_luma, limit);
    let span = f32(d_neg + d_pos) + 1.0;
    let nearer = f32(min(d_neg, d_pos)) + 0.5;
    // FXAA's sign test: blend only when the texel's luma differs from the edge mean in the
    // direction of the nearer end's.
    var dir = along;
    if d_neg <= d_pos {
        dir = -along;
    }
    var q = p;
    let steps = min(d_neg, d_pos) + 1u;
    for (var k = 0u; k < steps; k = k + 1u) {
        q = grid_step(q, dir.x, dir.y);
    }
    let end_luma = 0.5 * (l(q) + l(grid_step(q, across.x, across.y)));
    let good = ((m - edge_luma) < 0.0) != ((end_luma - edge_luma) < 0.0);
    var edge_blend = 0.0;
    if good {
        edge_blend = 0.5 - nearer / span;
    }
    let blend = clamp(max(edge_blend, sub), 0.0, 0.5);
    if blend > 0.0 {
        let other = rgb_at(grid_step(p, across.x, across.y));
        write_rgb(p, own + (other - own) * blend);
    }
}
