// frame_sparse.wgsl: Weier et al. 2018's sparse screen pattern (Sec. 3.1, Eq. 1–2), evaluated
// per pixel from tables built once per display and parameters (`fovea_gpu::frame::
// weier_pattern`): whether screen pixel (i, j) is ray-cast, and the ray cone of a sample at a
// screen point. Appended to a module that declares `frame_runs: array<vec2<u32>>` holding the
// pattern's words two a record (the resident shade kernels' binding 23, the mask pass's
// binding 1). The rule is `fovea_core::mapping::WeierSparse::selected`, bit for bit:
//
//   (dx, dy) = (i, j) − anchor (the point of regard, floored);
//   dx² + dy² < r₁² (as max_d2 = ⌈r₁²⌉ − 1 for integers): bit (dy + half, dx + half) of S_in;
//   else: bit (i, j) of S_out (the static R2 dither of density p_min).
//
// Words (u32): 0–1 the anchor (i32), 2–3 the point of regard (f32) — the only words written
// per frame —; 4 half, 5 max_d2, 6 S_in's side, 7 S_in's first word, 8 the screen width,
// 9 S_out's first word, 10 the cone table's first word, 11 its entries (0: none), 12 its
// entries per pixel of distance (f32); bits row-major, bit k % 32 of word k / 32.

fn sparse_word(k: u32) -> u32 {
    let pair = frame_runs[k >> 1u];
    return select(pair.x, pair.y, (k & 1u) == 1u);
}

fn sparse_bit(first: u32, k: u32) -> bool {
    return ((sparse_word(first + (k >> 5u)) >> (k & 31u)) & 1u) == 1u;
}

// Whether screen pixel (i, j) is one the pattern ray-casts.
fn sparse_shaded(i: u32, j: u32) -> bool {
    let dx = i32(i) - bitcast<i32>(sparse_word(0u));
    let dy = i32(j) - bitcast<i32>(sparse_word(1u));
    let half = i32(sparse_word(4u));
    if abs(dx) <= half && abs(dy) <= half && u32(dx * dx + dy * dy) <= sparse_word(5u) {
        return sparse_bit(sparse_word(7u), u32(dy + half) * sparse_word(6u) + u32(dx + half));
    }
    return sparse_bit(sparse_word(9u), j * sparse_word(8u) + i);
}

// The ray cone (radians) of a sample at screen point p: the table of
// `fovea_core::mapping::footprint::spread_with_floor_rad` against the distance from the point
// of regard (Weier's spacing depends on the eccentricity alone), linear between entries.
fn sparse_spread(p: vec2<f32>) -> f32 {
    let g = vec2<f32>(bitcast<f32>(sparse_word(2u)), bitcast<f32>(sparse_word(3u)));
    let n = sparse_word(11u);
    let first = sparse_word(10u);
    let x = length(p - g) * bitcast<f32>(sparse_word(12u));
    let k = min(u32(x), n - 2u);
    let t = min(x - f32(k), 1.0);
    let a = bitcast<f32>(sparse_word(first + k));
    let b = bitcast<f32>(sparse_word(first + k + 1u));
    return a + (b - a) * t;
}
