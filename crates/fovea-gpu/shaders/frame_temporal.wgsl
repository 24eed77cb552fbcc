// frame_temporal.wgsl: the resident frame's temporal accumulation in sample space — the GPU
// twin of `fovea_render::temporal::sample_space::blend` (VaFR's stated limitation is flicker:
// Zhang et al., Sec. 8; the running estimate after Weier et al. 2018, Sec. 3.1). One
// invocation per texel of this frame's sample layer, after the shading and before the screen
// side:
//
// 1. the texel's centre (i + ½, j + ½) through the inverse mapping — a polar column's ring
//    (the CPU mapping's f64 radius and rows per turn at u = i + ½, uploaded per column) at
//    (j + ½)/period turns (`Ring::point`, VaFR Eq. 11), or the pixel centre at full
//    resolution — to the screen point p;
// 2. p and the texel's depth z back into the world, `P = o + d·z/(d·f)`, and P seen from the
//    previous camera: the previous screen point q and the expected previous depth
//    `z' = (P − o')·f'` (misses reproject as directions, z' = ∞) — `temporal::reproject`;
// 3. q through the previous frame's forward map: its radius around the previous gaze gives
//    the column coordinate u by interpolating the previous columns' ring radii (each column's
//    exact radius at its centre, linear between neighbours), its angle the row coordinate
//    v = turns · period(u); at full resolution (u, v) = q;
// 4. the previous accumulated buffer read there: bilinear over the four nearest taps, each
//    weighted by its bilinear weight times its depth agreement with z' (1 within τ·z', 0 from
//    2τ·z'); taps the previous mapping did not shade (age 0) count zero; rows wrap in a column
//    that turns fully; Catmull-Rom instead where all 16 taps around agree in depth;
// 5. the weight v and age n scaled by the sample densities' ratio `(b/b_prev)²` where the
//    history was sampled coarser (`resolution_weight`: b from the plan's spacing table at the
//    eccentricity of p, b_prev from the previous one at q);
// 6. the history colour clamped to the fresh 3×3 neighbourhood (`Grid::step`'s neighbours:
//    across columns at the same angle, rows wrapping) and folded in with the new sample's
//    weight `α = 1 − (1 − max(α_min, 1/(n + 1)))·v` (`running_estimate`), the age n + 1 where
//    v ≥ ½ and 1 elsewhere.
//
// The result goes into the next history (colour + depth, and the age: 0 where the mapping
// does not shade); the Rust side copies its colour over the frame's samples after the pass.
//
// With `tp.moments` (the plan denoises and `TemporalSettings::variance` is on) the history also
// keeps the temporal moments [m₁, m₂, s] of the Monte Carlo part's demodulated luminance (SVGF,
// Schied et al. 2017, Sec. 4.2; `temporal::fold_moments`): the fresh y (the part — the colour
// less its exact part, or the whole colour where the part is unknown — over
// max(albedo, floor), its luma) gives [y, y², 1] where nothing is blended (or y is not finite:
// [0, 0, 1]); a blended texel folds y into the bilinear moments of the same taps as the colour
// (`SampleHistory::fetch`: no Catmull-Rom, no clamp) with the colour's weight α. Where the new
// age reaches VARIANCE_MIN_AGE the part's w lane gets `(m₂ − m₁²)·s/(1 − s)`
// (`moments_variance`), which the denoiser takes as its variance; elsewhere it keeps the
// sample side's −1 (the spatial estimate), as the CPU's NaN (`sample_space::variance_of`).

struct TemporalCamera {
    origin: vec3<f32>,
    fx: f32,
    forward: vec3<f32>,
    fy: f32,
    right: vec3<f32>,
    cx: f32,
    up: vec3<f32>,
    cy: f32,
}

// One frame's view of its sample layer: the camera, the gaze (the pole of a polar buffer)
// relative to the principal point, the layer, and where its columns and spacing table lie in
// `temporal_tables`.
struct TemporalView {
    camera: TemporalCamera,
    gaze: vec2<f32>,
    offset: u32,
    width: u32,
    height: u32,
    kind: u32,
    columns: u32,
    table: u32,
    spacing: u32,
    spacing_len: u32,
    steps_per_deg: f32,
    _pad0: u32,
}

struct TemporalParams {
    cur: TemporalView,
    prev: TemporalView,
    // The display, pixels.
    screen: vec2<f32>,
    alpha_min: f32,
    tau: f32,
    // The display's c_r (Eq. 3: e = atan(c_r · r)).
    c_r: f32,
    clamp: u32,
    // 1 where the previous frame is in `temporal_prev_*`, 0 for a first frame.
    history: u32,
    row_invocations: u32,
    inf_bits: u32,
    // 1 where `temporal_noisy` holds the denoiser's guides (the plan denoises), 0 for a
    // stand-in.
    guides: u32,
    // 1 where the moments are kept (`temporal_*_moments` and `temporal_albedo` are the real
    // buffers), 0 for stand-ins.
    moments: u32,
    // `fovea_post::denoise::ALBEDO_FLOOR`.
    albedo_floor: f32,
}

const TEMPORAL_POLAR: u32 = 0u;
const TEMPORAL_SCREEN: u32 = 1u;
// `SKY_DEPTH_M`: a stored depth at or beyond half of it is the sky.
const SKY_DEPTH_M: f32 = 1.0e9;
// `temporal::VARIANCE_MIN_AGE`: the age from which the moments' variance is given.
const VARIANCE_MIN_AGE: f32 = 4.0;

@group(0) @binding(0) var<uniform> tp: TemporalParams;
// This frame's shaded samples (rgb, depth), as the sample side wrote them.
@group(0) @binding(1) var<storage, read> temporal_samples: array<vec4<f32>>;
// The previous frame's accumulated samples and ages.
@group(0) @binding(2) var<storage, read> temporal_prev_color: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> temporal_prev_age: array<f32>;
// This frame's accumulated samples and ages (the next frame's history).
@group(0) @binding(4) var<storage, read_write> temporal_next_color: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> temporal_next_age: array<f32>;
// Per frame, at `view.table`: per column (ring radius px, ring rows per turn (< 0: no ring),
// the layout's rows, the layout's period); at `view.spacing`: the spacing table, px, every
// 1/steps_per_deg degrees of eccentricity.
@group(0) @binding(6) var<storage, read> temporal_tables: array<f32>;
// The sample side's column records (`FrameColumn`: .w is the first run) and runs of shaded
// rows, this frame's.
@group(0) @binding(7) var<storage, read> temporal_shade_columns: array<vec4<u32>>;
@group(0) @binding(8) var<storage, read> temporal_shade_runs: array<vec2<u32>>;
// The denoiser's Monte Carlo part of this frame's colour (`DeviceGuides::noisy`: rgb, NaN
// unknown; w the temporal variance), rewritten for the accumulated colour where a history is
// blended (`pipeline::sample_post::complement_part` before and after the CPU's blend): the
// fresh frame's exact part `colour − part` is kept, and the accumulated colour less it is the
// part the denoiser filters. A 16-byte stand-in when `tp.guides` is 0.
@group(0) @binding(9) var<storage, read_write> temporal_noisy: array<vec4<f32>>;
// The previous frame's and this frame's temporal moments (m₁, m₂, s, 0) of the Monte Carlo
// part's demodulated luminance, and the denoiser's albedo guide (`DeviceGuides::albedo`):
// 16-byte stand-ins when `tp.moments` is 0.
@group(0) @binding(10) var<storage, read> temporal_prev_moments: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> temporal_next_moments: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read> temporal_albedo: array<vec4<f32>>;

fn temporal_is_inf(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

fn temporal_is_sky(depth: f32) -> bool {
    return temporal_is_inf(depth) || depth >= SKY_DEPTH_M * 0.5;
}

fn temporal_finite3(v: vec3<f32>) -> bool {
    return !(temporal_is_inf(v.x) || temporal_is_inf(v.y) || temporal_is_inf(v.z));
}

// `sample_space::monte_carlo_luma` of texel `t` with colour `c` and Monte Carlo part `part`
// (NaN: unknown): the luma of the part (`c − e` where the exact part `e = c − part` is
// finite, else `c`) over max(albedo, floor) per channel (`demodulate`; a NaN albedo gives
// the floor, as Rust's `f32::max`).
fn temporal_mc_luma(t: u32, c: vec3<f32>, part: vec3<f32>) -> f32 {
    let e = c - part;
    var mc = c;
    if temporal_finite3(e) {
        mc = c - e;
    }
    let a = temporal_albedo[t].xyz;
    let f = vec3<f32>(tp.albedo_floor);
    let l = mc / select(f, a, a > f);
    return 0.299 * l.x + 0.587 * l.y + 0.114 * l.z;
}

// `sample_space::single`: the moments of one frame of luminance `y`.
fn temporal_single(y: f32) -> vec4<f32> {
    if temporal_is_inf(y) {
        return vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
    return vec4<f32>(y, y * y, 1.0, 0.0);
}

// `temporal::moments_variance`: NaN for a single frame (s = 1).
fn temporal_moments_variance(m: vec4<f32>) -> f32 {
    let rest = 1.0 - m.z;
    if rest <= 1e-6 {
        return bitcast<f32>(0x7fc00000u);
    }
    return max(m.y - m.x * m.x, 0.0) * m.z / rest;
}

// Column `i` of `view`: (radius, ring period, rows, layout period).
fn temporal_column(view: TemporalView, i: u32) -> vec4<f32> {
    let b = view.table + 4u * i;
    return vec4<f32>(
        temporal_tables[b],
        temporal_tables[b + 1u],
        temporal_tables[b + 2u],
        temporal_tables[b + 3u]
    );
}

// Whether this frame's mapping shades texel (i, j) (`FoveationMapping::is_shaded`).
fn temporal_shaded(i: u32, j: u32) -> bool {
    if i >= tp.cur.width || j >= tp.cur.height {
        return false;
    }
    if tp.cur.kind != TEMPORAL_POLAR {
        return true;
    }
    let a = temporal_shade_columns[i].w;
    let b = temporal_shade_columns[i + 1u].w;
    for (var r = a; r < b; r = r + 1u) {
        let run = temporal_shade_runs[r];
        if j >= run.x && j < run.y {
            return true;
        }
    }
    return false;
}

// `SpacingLut::at` of `view`'s table at radius `r_px` from its gaze.
fn temporal_spacing(view: TemporalView, r_px: f32) -> f32 {
    if view.spacing_len < 2u {
        return 1.0;
    }
    let e_deg = degrees(atan(tp.c_r * r_px));
    let last = f32(view.spacing_len - 1u);
    let x = min(max(e_deg, 0.0) * view.steps_per_deg, last);
    let k = min(u32(floor(x)), view.spacing_len - 2u);
    let f = x - f32(k);
    let a = temporal_tables[view.spacing + k];
    let b = temporal_tables[view.spacing + k + 1u];
    return a + (b - a) * f;
}

// The unit direction through the point `rel` (pixels from the principal point).
fn temporal_direction(cam: TemporalCamera, rel: vec2<f32>) -> vec3<f32> {
    let a = rel.x / cam.fx;
    let b = rel.y / cam.fy;
    return normalize(cam.forward + a * cam.right - b * cam.up);
}

// `EyeCamera::screen_point_of` without the principal point added: (x − c_x, y − c_y, ok).
fn temporal_project(cam: TemporalCamera, d: vec3<f32>) -> vec3<f32> {
    let z = dot(d, cam.forward);
    if !(z > 1e-6) {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    return vec3<f32>(cam.fx * dot(d, cam.right) / z, -cam.fy * dot(d, cam.up) / z, 1.0);
}

// `temporal::depth_weight`.
fn temporal_depth_weight(history: f32, expected: f32, expected_sky: bool) -> f32 {
    let h_sky = temporal_is_sky(history);
    if h_sky && expected_sky {
        return 1.0;
    }
    if h_sky || expected_sky {
        return 0.0;
    }
    let rel = abs(history - expected) / max(expected, 1e-4);
    return clamp(2.0 - rel / tp.tau, 0.0, 1.0);
}

// The previous layer's column coordinate at radius `r` from its gaze and the fraction of
// the way between the two column centres around it: (u, k, f), k the column below.
fn temporal_prev_u(r: f32) -> vec3<f32> {
    let n = tp.prev.columns;
    let r0 = temporal_tables[tp.prev.table];
    if n < 2u || r <= r0 {
        // Inside the first column's centre: from the pole (u = 0 at r = 0).
        var u = 0.5;
        if r0 > 0.0 {
            u = 0.5 * r / r0;
        }
        return vec3<f32>(u, 0.0, 0.0);
    }
    // The last column whose centre lies at or inside r.
    var lo = 0u;
    var hi = n - 1u;
    if r >= temporal_tables[tp.prev.table + 4u * hi] {
        lo = n - 2u;
    } else {
        while hi - lo > 1u {
            let mid = (lo + hi) / 2u;
            if temporal_tables[tp.prev.table + 4u * mid] <= r {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
    let ra = temporal_tables[tp.prev.table + 4u * lo];
    let rb = temporal_tables[tp.prev.table + 4u * (lo + 1u)];
    let f = (r - ra) / max(rb - ra, 1e-12);
    return vec3<f32>(f32(lo) + 0.5 + f, f32(lo), f);
}

// One tap of the previous layer: (colour, depth agreement) and its age, or age < 1 where it
// lies outside the layer or the previous mapping did not shade it.
struct Tap {
    color: vec3<f32>,
    dw: f32,
    age: f32,
    // The history's moments there where `with_moments` (else zero).
    moments: vec3<f32>,
}

fn temporal_tap(i: i32, j0: i32, expected: f32, expected_sky: bool, with_moments: bool) -> Tap {
    var out: Tap;
    out.age = 0.0;
    out.dw = 0.0;
    out.color = vec3<f32>(0.0);
    out.moments = vec3<f32>(0.0);
    let w = i32(tp.prev.width);
    let h = i32(tp.prev.height);
    if i < 0 || i >= w {
        return out;
    }
    var j = j0;
    if tp.prev.kind == TEMPORAL_POLAR {
        let c = temporal_column(tp.prev, u32(i));
        let rows = i32(c.z);
        if rows > 0 && abs(c.w - c.z) < 0.5 {
            j = ((j % rows) + rows) % rows;
        }
    }
    if j < 0 || j >= h {
        return out;
    }
    let t = tp.prev.offset + u32(j) * tp.prev.width + u32(i);
    let age = temporal_prev_age[t];
    if age < 1.0 {
        return out;
    }
    let s = temporal_prev_color[t];
    out.color = s.xyz;
    out.age = age;
    out.dw = temporal_depth_weight(s.w, expected, expected_sky);
    if with_moments {
        out.moments = temporal_prev_moments[t].xyz;
    }
    return out;
}

fn temporal_catmull_rom(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2)
    );
}

// `SampleHistory::fetch` at (u, v) of the previous layer: (colour, weight), the age and,
// with `tp.moments`, the bilinear moments of the same taps.
struct Fetched {
    color: vec3<f32>,
    valid: f32,
    age: f32,
    moments: vec3<f32>,
}

fn temporal_fetch(u: f32, v: f32, expected: f32, expected_sky: bool) -> Fetched {
    var out: Fetched;
    out.color = vec3<f32>(0.0);
    out.valid = 0.0;
    out.age = 0.0;
    out.moments = vec3<f32>(0.0);
    let with_moments = tp.moments != 0u;
    let uu = u - 0.5;
    let vv = v - 0.5;
    let fi = floor(uu);
    let fj = floor(vv);
    let i0 = i32(fi);
    let j0 = i32(fj);
    let fu = uu - fi;
    let fv = vv - fj;
    var acc = vec3<f32>(0.0);
    var macc = vec3<f32>(0.0);
    var valid = 0.0;
    var n = 0.0;
    var bw = array<f32, 4>((1.0 - fu) * (1.0 - fv), fu * (1.0 - fv), (1.0 - fu) * fv, fu * fv);
    for (var k = 0; k < 4; k = k + 1) {
        if bw[k] <= 0.0 {
            continue;
        }
        let tap = temporal_tap(
            i0 + (k & 1),
            j0 + (k >> 1u),
            expected,
            expected_sky,
            with_moments
        );
        if tap.age < 1.0 || tap.dw <= 0.0 {
            continue;
        }
        let q = bw[k] * tap.dw;
        acc = acc + q * tap.color;
        macc = macc + q * tap.moments;
        valid = valid + q;
        n = max(n, tap.age);
    }
    if valid <= 0.0 {
        return out;
    }
    out.valid = valid;
    out.age = n;
    out.color = acc / valid;
    out.moments = macc / valid;
    // Where all 16 taps around agree in depth, Catmull-Rom instead of the bilinear blur.
    let wx = temporal_catmull_rom(fu);
    let wy = temporal_catmull_rom(fv);
    var cr = vec3<f32>(0.0);
    for (var dj = 0; dj < 4; dj = dj + 1) {
        for (var di = 0; di < 4; di = di + 1) {
            let tap = temporal_tap(i0 + di - 1, j0 + dj - 1, expected, expected_sky, false);
            if tap.age < 1.0 || !(tap.dw >= 1.0) {
                return out;
            }
            cr = cr + (wx[di] * wy[dj]) * tap.color;
        }
    }
    out.color = max(cr, vec3<f32>(0.0));
    return out;
}

// `Grid::step` of this frame's layer: the texel reached from (i, j) by `di` columns (at the
// same angle) then `dj` rows.
fn temporal_step(i: u32, j: u32, di: i32, dj: i32) -> vec2<u32> {
    let w = i32(tp.cur.width);
    let h = i32(tp.cur.height);
    if tp.cur.kind != TEMPORAL_POLAR {
        return vec2<u32>(
            u32(clamp(i32(i) + di, 0, w - 1)),
            u32(clamp(i32(j) + dj, 0, h - 1))
        );
    }
    var ci = i;
    var cj = i32(j);
    let ni = i32(i) + di;
    if di != 0 && ni >= 0 && ni < i32(tp.cur.columns) {
        let nc = temporal_column(tp.cur, u32(ni));
        if nc.z > 0.0 {
            let own = temporal_column(tp.cur, i);
            let x = (f32(j) + 0.5) * (nc.w / max(own.w, 1e-12)) - 0.5;
            // Halves away from zero, as `f64::round`.
            cj = i32(sign(x) * floor(abs(x) + 0.5));
            ci = u32(ni);
        }
    }
    let rows = max(i32(temporal_column(tp.cur, ci).z), 1);
    let r = cj + dj;
    return vec2<u32>(ci, u32(((r % rows) + rows) % rows));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn temporal_blend(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x + id.y * tp.row_invocations;
    let w = tp.cur.width;
    if n >= w * tp.cur.height {
        return;
    }
    let i = n % w;
    let j = n / w;
    let t = tp.cur.offset + n;
    let s = temporal_samples[t];
    let c = s.xyz;
    let z = s.w;
    let moments = tp.moments != 0u;
    if !temporal_shaded(i, j) {
        temporal_next_color[t] = s;
        temporal_next_age[t] = 0.0;
        if moments {
            temporal_next_moments[t] = vec4<f32>(0.0, 0.0, 1.0, 0.0);
        }
        return;
    }
    // Fresh unless a history passes every test below.
    temporal_next_color[t] = s;
    temporal_next_age[t] = 1.0;
    // The fresh Monte Carlo luminance (before the part is rewritten below).
    var y = 0.0;
    if moments {
        y = temporal_mc_luma(t, c, temporal_noisy[t].xyz);
        temporal_next_moments[t] = temporal_single(y);
    }
    if tp.history == 0u {
        return;
    }
    // 1. The texel's centre on the screen (relative to the principal point), and its radius
    // from the gaze.
    var p: vec2<f32>;
    var r_cur: f32;
    if tp.cur.kind == TEMPORAL_POLAR {
        let col = temporal_column(tp.cur, i);
        let v = f32(j) + 0.5;
        if !(col.y > 0.0) || v > col.y {
            return;
        }
        p = tp.cur.gaze + col.x * cos_sin_turns(v / col.y, 6.283185307179586);
        r_cur = col.x;
    } else {
        let cam = tp.cur.camera;
        p = vec2<f32>(f32(i) + 0.5 - cam.cx, f32(j) + 0.5 - cam.cy);
        r_cur = length(p - tp.cur.gaze);
    }
    // 2. Reprojected into the previous camera.
    let cam = tp.cur.camera;
    let prev = tp.prev.camera;
    let d = temporal_direction(cam, p);
    let sky = temporal_is_sky(z);
    var expected = 0.0;
    var q: vec3<f32>;
    if sky {
        q = temporal_project(prev, d);
    } else {
        let cosv = dot(d, cam.forward);
        if !(cosv > 1e-6) {
            return;
        }
        let world = cam.origin + d * (z / cosv);
        let rel = world - prev.origin;
        expected = dot(rel, prev.forward);
        q = temporal_project(prev, rel);
    }
    if q.z < 0.5 {
        return;
    }
    let qa = vec2<f32>(q.x + prev.cx, q.y + prev.cy);
    if !(qa.x >= 0.0 && qa.y >= 0.0 && qa.x <= tp.screen.x && qa.y <= tp.screen.y) {
        return;
    }
    // 3. The previous layer's sample point at q.
    let dq = q.xy - tp.prev.gaze;
    let r_prev = length(dq);
    var u: f32;
    var v: f32;
    if tp.prev.kind == TEMPORAL_POLAR {
        let at = temporal_prev_u(r_prev);
        u = at.x;
        let k = u32(at.y);
        var period = temporal_column(tp.prev, k).y;
        if k + 1u < tp.prev.columns {
            let next = temporal_column(tp.prev, k + 1u).y;
            if next > 0.0 && period > 0.0 {
                period = period + (next - period) * at.z;
            }
        }
        var turns = atan2(dq.y, dq.x) / 6.283185307179586;
        if turns < 0.0 {
            turns = turns + 1.0;
        }
        if turns >= 1.0 {
            turns = turns - 1.0;
        }
        v = turns * period;
    } else {
        if !(qa.x < tp.screen.x && qa.y < tp.screen.y) {
            return;
        }
        u = qa.x;
        v = qa.y;
    }
    // 4. The history there.
    let h = temporal_fetch(u, v, expected, sky);
    if h.valid <= 0.0 {
        return;
    }
    // 5. Trust scaled by the sample densities where the history was sampled coarser.
    var weight = h.valid;
    var age = h.age;
    let b = temporal_spacing(tp.cur, r_cur);
    let b_prev = temporal_spacing(tp.prev, r_prev);
    if b_prev > b && b > 0.0 {
        let ratio = (b / b_prev) * (b / b_prev);
        weight = weight * ratio;
        age = max(floor(age * ratio), 1.0);
    }
    if weight <= 1e-3 {
        return;
    }
    // 6. Clamp to the fresh neighbourhood, then the running estimate.
    var hc = h.color;
    if tp.clamp != 0u {
        var lo = c;
        var hi = c;
        for (var dj = -1; dj <= 1; dj = dj + 1) {
            for (var di = -1; di <= 1; di = di + 1) {
                let nb = temporal_step(i, j, di, dj);
                if temporal_shaded(nb.x, nb.y) {
                    let qn = temporal_samples[tp.cur.offset + nb.y * w + nb.x].xyz;
                    lo = min(lo, qn);
                    hi = max(hi, qn);
                }
            }
        }
        hc = clamp(hc, lo, hi);
    }
    let a_hist = max(tp.alpha_min, 1.0 / (age + 1.0));
    let a = 1.0 - (1.0 - a_hist) * min(weight, 1.0);
    let out = a * c + (1.0 - a) * hc;
    var next_age = 1.0;
    if weight >= 0.5 {
        next_age = min(age + 1.0, 65535.0);
    }
    temporal_next_color[t] = vec4<f32>(out, z);
    temporal_next_age[t] = next_age;
    var variance = -1.0;
    if moments {
        // The moments with the colour's weight; a history without finite moments (or a
        // texel without a finite luminance) starts over.
        var m = temporal_single(y);
        if !temporal_is_inf(y) && temporal_finite3(h.moments) {
            m = vec4<f32>(
                a * y + (1.0 - a) * h.moments.x,
                a * y * y + (1.0 - a) * h.moments.y,
                a * a + (1.0 - a) * (1.0 - a) * h.moments.z,
                0.0
            );
        }
        temporal_next_moments[t] = m;
        if next_age >= VARIANCE_MIN_AGE {
            variance = temporal_moments_variance(m);
        }
    }
    if tp.guides != 0u {
        let part = temporal_noisy[t];
        if !moments {
            variance = part.w;
        }
        temporal_noisy[t] = vec4<f32>(out - (c - part.xyz), variance);
    }
}
