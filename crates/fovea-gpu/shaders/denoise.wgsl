// denoise.wgsl: the sample-space SVGF à-trous denoiser (Schied et al. 2017, Sec. 4; Dammertz
// et al. 2010), the twin of `fovea_post::denoise::denoise` — same roles, same depth gradient,
// same 3×3 moments and firefly clamp, same kernels, edge-stopping weights and fast exponential,
// same polar seams (rows wrap around the angle axis, a column step keeps the angle, a step
// inside the innermost ring continues half a turn on across the fovea), the arithmetic in the
// same order. See src/denoise.rs for the buffers and the passes' order.
//
// One invocation per texel of every layer of the frame's sample buffers (`DeviceSamples`:
// `vec4` RGB + depth, layers one after another, each row-major), in a two-dimensional dispatch
// read as one linear index. Five entry points, each a full pass over the texels:
//   denoise_prepare  roles, normal + depth, demodulated Monte Carlo light     → light_dst
//   denoise_variance count, depth gradient, 3×3 luminance moments, firefly clamp light_src → light_dst
//   denoise_atrous_first  the first à-trous iteration (step 1, the variance prefiltered) light_src → light_dst
//   denoise_atrous   each later à-trous iteration at `step` (the uniform's slot)   light_src → light_dst
//   denoise_finish   remodulate, add the exact part back                         light_src → samples
//
// `aux` per texel: x, y the depth gradient per texel step (written by denoise_variance, one
// component each, while the neighbours read only z), z the role (0 passive, 1 receiver only,
// 2 source; written by denoise_prepare), w the per-sample temporal variance given with the
// guides (the Monte Carlo part's w lane; −1 where none is given: the spatial estimate), as
// `fovea_post::denoise::denoise_with_variance` takes it.

struct DenoiseParams {
    // Texels of all layers.
    texels: u32,
    // Layers in `layers`.
    layer_count: u32,
    // À-trous step of this slot's iteration, texels (2^iteration).
    atrous_step: i32,
    // Kernel taps per axis: 3 (linear B spline) or 5 (B3 spline).
    taps: i32,
    // σ_l, σ_z, σ_n of SVGF.
    sigma_l: f32,
    sigma_z: f32,
    sigma_n: f32,
    // Firefly clamp's k (standard deviations); ≤ 0: no clamp.
    firefly_k: f32,
    // ln 2 / σ_n: `1 − n_p·n_q` below this is "the same surface".
    same_normal: f32,
    // 1: `denoise_prepare` lists the texels that are not passive (`work_list`, counted in
    // `counters[2]`) and the later passes run over that list; 0: every pass over every texel.
    listed: u32,
    pad1: u32,
    pad2: u32,
    // Per layer: first texel, width, height, and 0 for a rectangle or 1 + the index of the
    // layer's first column in `columns` for a polar grid.
    layers: array<vec4<u32>, 8>,
};

// The guides, one vec4 per texel in each of three buffers (each within one storage binding):
// albedo (linear RGB), unit shading normal (zero: no surface record) and the Monte Carlo part
// of the colour (NaN: unknown, the whole colour is filtered). The Monte Carlo part's w lane is
// the temporal variance of its demodulated luminance (`DenoiseGuides::variance`: NaN or
// negative where none, the spatial estimate then); the other w lanes are unused (0).

@group(0) @binding(0) var<uniform> params: DenoiseParams;
@group(0) @binding(1) var<storage, read_write> samples: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> guide_albedo: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> guide_normal: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> guide_noisy: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> geom: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> aux: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> light_src: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> light_dst: array<vec4<f32>>;
// Per polar column: shaded rows, and the rows per full turn (f32 bits).
@group(0) @binding(7) var<storage, read> columns: array<vec2<u32>>;
// [texels filtered, sources clamped, texels listed].
@group(0) @binding(8) var<storage, read_write> counters: array<atomic<u32>, 3>;
// With `params.listed`: the texels that are not passive (their index k), in the device's
// order; the first `counters[2]` are this call's. Lavapipe (Mesa 22.3) runs both sides of
// every `if` under a lane mask, so a passive texel's early return saves nothing there; over
// the list, the passes' lanes are all texels that filter (issue 37,
// docs/gpu-measurements.md). Each texel's result depends on the previous pass's buffers
// only, so the order does not change a bit.
@group(0) @binding(11) var<storage, read_write> work_list: array<u32>;

const PASSIVE: u32 = 0u;
const RECEIVER: u32 = 1u;
const SOURCE: u32 = 2u;
const ALBEDO_FLOOR: f32 = 0.02;

// A texel: its index, layer record, column and row.
struct Texel {
    k: u32,
    layer: vec4<u32>,
    i: i32,
    j: i32,
};

// Where a column step lands: column (−1: outside), the row at the texel's angle there, the
// column's rows.
struct Column {
    c: i32,
    row: i32,
    rows: i32,
};

fn texel_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WORKGROUP_SIZE;
}

// The texel of a pass after `denoise_prepare`: the invocation's index, or with
// `params.listed` the listed texel it names (`params.texels`, none, past the count; the host
// sizes that dispatch by a bound of the count).
fn work_texel(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    let n = texel_index(gid, groups);
    if params.listed == 0u {
        return n;
    }
    if n >= atomicLoad(&counters[2]) {
        return params.texels;
    }
    return work_list[n];
}

fn locate(k: u32) -> Texel {
    var t: Texel;
    t.k = k;
    for (var l = 0u; l < params.layer_count; l = l + 1u) {
        let layer = params.layers[l];
        let n = layer.y * layer.z;
        if k < layer.x + n {
            let rel = k - layer.x;
            t.layer = layer;
            t.i = i32(rel % layer.y);
            t.j = i32(rel / layer.y);
            return t;
        }
    }
    return t;
}

fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn finite3(v: vec3<f32>) -> bool {
    return finite(v.x) && finite(v.y) && finite(v.z);
}

fn luma(c: vec3<f32>) -> f32 {
    return 0.299 * c.x + 0.587 * c.y + 0.114 * c.z;
}

// e^−x for x ≥ 0 (relative error below 3·10⁻⁴), `fovea_post::denoise::exp_neg`'s polynomial.
fn exp_neg(x: f32) -> f32 {
    let t = max(-x * 1.442695, -126.0);
    let i = i32(t); // toward zero: the fraction lies in (−1, 0]
    let f = t - f32(i);
    let p = 1.0
        + f * (0.6931472
            + f * (0.2402265 + f * (0.0555041 + f * (0.0096181 + f * 0.0013334))));
    return bitcast<f32>(u32(i + 127) << 23u) * p;
}

fn column_record(layer: vec4<u32>, c: i32) -> vec2<u32> {
    return columns[layer.w - 1u + u32(c)];
}

// Whether (i, j) holds a sample of the layer's grid.
fn valid(layer: vec4<u32>, i: i32, j: i32) -> bool {
    if layer.w == 0u {
        return true;
    }
    return u32(j) < column_record(layer, i).x;
}

// The texel's angle in turns, (j + ½)/period[i] (0 on a rectangle).
fn turn_of(layer: vec4<u32>, i: i32, j: i32) -> f32 {
    if layer.w == 0u {
        return 0.0;
    }
    let period = bitcast<f32>(column_record(layer, i).y);
    return (f32(j) + 0.5) / max(period, 1e-12);
}

// `fovea_post::denoise::column_at`.
fn column_at(layer: vec4<u32>, i: i32, j: i32, turn: f32, di: i32) -> Column {
    var none = Column(-1, 0, 0);
    if layer.w == 0u {
        let c = i + di;
        if c >= 0 && c < i32(layer.y) {
            return Column(c, j, i32(layer.z));
        }
        return none;
    }
    var c = i + di;
    var half_turn = 0.0;
    if c < 0 {
        c = -1 - c;
        half_turn = 0.5;
    }
    if c >= i32(layer.y) {
        return none;
    }
    let rec = column_record(layer, c);
    let n = i32(rec.x);
    if n == 0 {
        return none;
    }
    var row = j;
    if !(c == i && half_turn == 0.0) {
        var t = turn + half_turn;
        t = t - floor(t);
        // t·period − ½ ≥ −½: truncating x + ½ rounds.
        row = i32(t * bitcast<f32>(rec.y));
    }
    return Column(c, row, n);
}

// Row `row + dj` of a column of `rows` rows: wrapped (polar) or −1 outside (rectangle).
fn row_of(layer: vec4<u32>, row: i32, rows: i32, dj: i32) -> i32 {
    let r = row + dj;
    if r >= 0 && r < rows {
        return r;
    }
    if layer.w == 0u {
        return -1;
    }
    let n = max(rows, 1);
    return ((r % n) + n) % n;
}

fn index_of(layer: vec4<u32>, c: i32, r: i32) -> u32 {
    return layer.x + u32(r) * layer.y + u32(c);
}

fn role_of(q: u32) -> u32 {
    return u32(aux[q].z);
}

// max(albedo, ALBEDO_FLOOR) per channel as Rust's `f32::max` takes it: NaN gives the floor.
fn floored(a: vec3<f32>) -> vec3<f32> {
    return select(vec3<f32>(ALBEDO_FLOOR), a, a > vec3<f32>(ALBEDO_FLOOR));
}

// The texel's Monte Carlo part: the guide's where finite, else its whole colour.
fn noisy_part(m: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    if finite3(m) {
        return m;
    }
    return c;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_prepare(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let k = texel_index(gid, groups);
    if k >= params.texels {
        return;
    }
    let t = locate(k);
    let s = samples[k];
    let z = s.w;
    let nv = guide_normal[k].xyz;
    let c = s.xyz;
    let al = guide_albedo[k].xyz;
    let surface = valid(t.layer, t.i, t.j) && finite(z) && finite3(nv)
        && any(nv != vec3<f32>(0.0));
    var role = PASSIVE;
    if surface {
        role = RECEIVER;
        if finite3(c) && finite3(al) {
            role = SOURCE;
        }
    }
    geom[k] = vec4<f32>(nv, z);
    let m = guide_noisy[k];
    // The temporal variance where given (finite, ≥ 0), else −1: the spatial estimate.
    var temporal = -1.0;
    if finite(m.w) && m.w >= 0.0 {
        temporal = m.w;
    }
    aux[k] = vec4<f32>(0.0, 0.0, f32(role), temporal);
    if params.listed != 0u && role != PASSIVE {
        work_list[atomicAdd(&counters[2], 1u)] = k;
    }
    var lt = vec3<f32>(0.0);
    if role == SOURCE {
        lt = noisy_part(m.xyz, c) / floored(al);
    }
    light_dst[k] = vec4<f32>(lt, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_variance(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let k = work_texel(gid, groups);
    if k >= params.texels {
        return;
    }
    let l0 = light_src[k];
    light_dst[k] = l0;
    let role = role_of(k);
    if role == PASSIVE {
        return;
    }
    atomicAdd(&counters[0], 1u);
    let t = locate(k);
    let gp = geom[k];
    let zp = gp.w;
    let turn = turn_of(t.layer, t.i, t.j);
    // The 3×3 neighbourhood's surface samples.
    var nq: array<u32, 8>;
    var ndi: array<i32, 8>;
    var ndj: array<i32, 8>;
    var count = 0;
    for (var di = -1; di <= 1; di = di + 1) {
        let col = column_at(t.layer, t.i, t.j, turn, di);
        if col.c < 0 {
            continue;
        }
        for (var dj = -1; dj <= 1; dj = dj + 1) {
            if di == 0 && dj == 0 {
                continue;
            }
            let r = row_of(t.layer, col.row, col.rows, dj);
            if r < 0 {
                continue;
            }
            let q = index_of(t.layer, col.c, r);
            if role_of(q) != PASSIVE && q != k {
                nq[count] = q;
                ndi[count] = di;
                ndj[count] = dj;
                count = count + 1;
            }
        }
    }
    // Smaller one-sided depth difference per axis.
    var slope = vec2<f32>(0.0);
    var found = vec2<bool>(false);
    for (var n = 0; n < count; n = n + 1) {
        let d = abs(geom[nq[n]].w - zp);
        if ndj[n] == 0 {
            slope.x = select(d, min(slope.x, d), found.x);
            found.x = true;
        }
        if ndi[n] == 0 {
            slope.y = select(d, min(slope.y, d), found.y);
            found.y = true;
        }
    }
    let g = vec2<f32>(select(0.0, slope.x, finite(slope.x)), select(0.0, slope.y, finite(slope.y)));
    aux[k].x = g.x;
    aux[k].y = g.y;
    if role != SOURCE {
        return;
    }
    // Luminance moments of the neighbours on the same surface.
    var sw = 0.0;
    var s1 = 0.0;
    var s2 = 0.0;
    for (var n = 0; n < count; n = n + 1) {
        let q = nq[n];
        let gq = geom[q];
        let dot_n = gp.x * gq.x + gp.y * gq.y + gp.z * gq.z;
        let dz = abs(zp - gq.w) / (params.sigma_z * (g.x * abs(f32(ndi[n])) + g.y * abs(f32(ndj[n])))
            + 1e-3 * abs(zp) + 1e-9);
        if role_of(q) != SOURCE || 1.0 - dot_n > params.same_normal || dz > 1.0 {
            continue;
        }
        let lq = luma(light_src[q].xyz);
        sw = sw + 1.0;
        s1 = s1 + lq;
        s2 = s2 + lq * lq;
    }
    var lp = l0.xyz;
    var yp = luma(lp);
    if params.firefly_k > 0.0 && sw >= 2.0 {
        let mean = s1 / sw;
        let sd = sqrt(max(s2 / sw - mean * mean, 0.0));
        let limit = mean + params.firefly_k * sd;
        if yp > limit && yp > 0.0 {
            let sc = max(limit, 0.0) / yp;
            lp = lp * sc;
            yp = luma(lp);
            atomicAdd(&counters[1], 1u);
        }
    }
    // The temporal estimate where given, else the variance of the neighbourhood with the
    // (clamped) centre.
    var variance = aux[k].w;
    if variance < 0.0 {
        let tw = sw + 1.0;
        let t1 = s1 + yp;
        let t2 = s2 + yp * yp;
        let mean = t1 / tw;
        variance = max(t2 / tw - mean * mean, 0.0);
    }
    light_dst[k] = vec4<f32>(lp, variance);
}

// The kernel's 1-D tap `x` (0 ..< taps).
fn kernel_tap(x: i32) -> f32 {
    if params.taps == 3 {
        return select(0.25, 0.5, x == 1);
    }
    if x == 2 {
        return 6.0 / 16.0;
    }
    if x == 1 || x == 3 {
        return 4.0 / 16.0;
    }
    return 1.0 / 16.0;
}

fn linear_tap(x: i32) -> f32 {
    return select(0.25, 0.5, x == 0);
}

// One à-trous iteration; `prefilter` (a constant at each call, so the compiler drops the
// branch it does not take) is whether this is the first iteration (step 1), which filters the
// variance over 3×3 first. Two entry points rather than a test of the uniform's step: lavapipe
// (Mesa 22.3) runs both sides of every `if` under a lane mask, so a branch that the step turns
// off still cost the later iterations its nine taps (docs/gpu-measurements.md, issue 37).
fn atrous(gid: vec3<u32>, groups: vec3<u32>, prefilter: bool) {
    let k = work_texel(gid, groups);
    if k >= params.texels {
        return;
    }
    let role = role_of(k);
    if role == PASSIVE {
        return;
    }
    let t = locate(k);
    let stride = params.atrous_step;
    let gp = geom[k];
    let a = aux[k];
    let g = a.xy;
    let src_k = light_src[k];
    let lp = src_k.xyz;
    let yp = luma(lp);
    let turn = turn_of(t.layer, t.i, t.j);
    let eps_z = 1e-3 * abs(gp.w) + 1e-9;
    let sigma_z = params.sigma_z;
    // 3×3 Gaussian of the variance over sources on the same surface, in the first iteration;
    // the later ones read the variance the earlier ones filtered.
    var vw = 0.0;
    var vs = 0.0;
    if !prefilter {
        vw = 1.0;
        vs = src_k.w;
    } else {
        for (var di = -1; di <= 1; di = di + 1) {
            let col = column_at(t.layer, t.i, t.j, turn, di);
            if col.c < 0 {
                continue;
            }
            for (var dj = -1; dj <= 1; dj = dj + 1) {
                let r = row_of(t.layer, col.row, col.rows, dj);
                if r < 0 {
                    continue;
                }
                let q = index_of(t.layer, col.c, r);
                if role_of(q) != SOURCE {
                    continue;
                }
                if q != k {
                    let gq = geom[q];
                    let dot_n = gp.x * gq.x + gp.y * gq.y + gp.z * gq.z;
                    let dz = abs(gp.w - gq.w);
                    let tol = sigma_z * (g.x * f32(abs(di)) + g.y * f32(abs(dj)));
                    if 1.0 - dot_n > params.same_normal || dz > tol + eps_z {
                        continue;
                    }
                }
                let w = linear_tap(di) * linear_tap(dj);
                vw = vw + w;
                vs = vs + w * light_src[q].w;
            }
        }
    }
    var variance = 0.0;
    if vw > 0.0 {
        variance = vs / vw;
    }
    // A receiver-only texel has no light of its own to compare with.
    var inv_sl = 0.0;
    if role == SOURCE {
        inv_sl = 1.0 / (params.sigma_l * sqrt(variance) + 1e-8);
    }
    let mid = params.taps / 2;
    var sw = 0.0;
    var sl = vec3<f32>(0.0);
    var sv = 0.0;
    if role == SOURCE {
        let w = kernel_tap(mid) * kernel_tap(mid);
        sw = w;
        sl = lp * w;
        sv = w * w * src_k.w;
    }
    for (var xi = 0; xi < params.taps; xi = xi + 1) {
        let di = (xi - mid) * stride;
        let col = column_at(t.layer, t.i, t.j, turn, di);
        if col.c < 0 {
            continue;
        }
        let hx = kernel_tap(xi);
        let ax = f32(abs(xi - mid));
        for (var yi = 0; yi < params.taps; yi = yi + 1) {
            if xi == mid && yi == mid {
                continue;
            }
            let dj = (yi - mid) * stride;
            let r = row_of(t.layer, col.row, col.rows, dj);
            if r < 0 {
                continue;
            }
            let q = index_of(t.layer, col.c, r);
            if role_of(q) != SOURCE || q == k {
                continue;
            }
            let gq = geom[q];
            let dot_n = gp.x * gq.x + gp.y * gq.y + gp.z * gq.z;
            if dot_n <= 0.0 {
                continue;
            }
            let src_q = light_src[q];
            let lq = src_q.xyz;
            // 1 / (σ_z |∇z·(p − q)| + ε_z).
            let ay = f32(abs(yi - mid));
            let inv_den = 1.0 / (sigma_z * ((g.x * ax + g.y * ay) * f32(stride)) + eps_z);
            // max(0, n·n')^σ_n ≈ e^(−σ_n (1 − n·n')), folded into the one exponential.
            let arg = abs(gp.w - gq.w) * inv_den + abs(yp - luma(lq)) * inv_sl
                + params.sigma_n * (1.0 - dot_n);
            if arg > 30.0 {
                continue;
            }
            let w = hx * kernel_tap(yi) * exp_neg(arg);
            sw = sw + w;
            sl = sl + w * lq;
            sv = sv + w * w * src_q.w;
        }
    }
    if sw > 0.0 {
        light_dst[k] = vec4<f32>(sl / sw, sv / (sw * sw));
    } else {
        light_dst[k] = src_k;
    }
}

// The first iteration (step 1): the variance filtered over 3×3 first.
@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_atrous_first(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    atrous(gid, groups, true);
}

// Every later iteration (step 2^i, i ≥ 1): the variance the earlier ones filtered.
@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_atrous(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    atrous(gid, groups, false);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_finish(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let k = work_texel(gid, groups);
    if k >= params.texels {
        return;
    }
    let role = role_of(k);
    if role == PASSIVE {
        return;
    }
    let s = samples[k];
    let lit = light_src[k].xyz * floored(guide_albedo[k].xyz);
    var res = lit;
    if role == SOURCE {
        // The exact part kept (a receiver's colour is not finite: all of it refilled).
        res = s.xyz - noisy_part(guide_noisy[k].xyz, s.xyz) + lit;
    }
    if finite3(res) {
        samples[k] = vec4<f32>(res, s.w);
    }
}
