// vafr_mapping.wgsl: the VaFR log-polar mapping (Zhang, Gai, Li), forward Eq. 3, 5/12, 8/19 and
// inverse Eq. 10, 11, in f32, one invocation per point. The reference is the f64 Rust mapping
// `fovea_core::mapping::Vafr`; every constant below comes from it through `VafrParams`
// (src/mapping/vafr.rs builds it). Prepended: common.wgsl.
//
// Forward, screen pixel p → LP buffer (u, v):
//   r = |p − gaze|, t = c_r·r, e = atan(t)                               (Eq. 3)
//   u = u_i + 2·ln(1 + k)/m_i, k = m_i·(e − e_i)/ω_i in the MAR segment i  (Eq. 5, 12)
//       (2·(e − e_i)/ω_i · ln(1 + k)/k, the same value, on a flat segment, m_i = 0)
//   v = θ/360° · l(e), l(e) = Δ(e)·360·sin 2e / ω(e)                      (Eq. 8, 9, 19)
//       with sin 2e = 2t/(1 + t²), exact for e = atan t and free of trigonometry
//   no sample where r > tan(e_max)/c_r.
// Inverse, (u, v) → screen:
//   e = e_i + ω_i·(exp(m_i·(u − u_i)/2) − 1)/m_i in the segment with u_i ≤ u (Eq. 10)
//   r = tan(e)/c_r, θ = 360°·v/l(e)                                        (Eq. 3, 11)
//   no sample where u ∉ [0, u_max] or v ∉ [0, l(e)]; at u = 0 only v = 0 (the gaze).
//
// Precision of the inverse. Far out, r = tan(e)/c_r moves fast: at 75° on the 8K preset
// 563 px per degree, and one f32 ulp of e in degrees (7.6e-6) is 0.004 px; the angle
// θ = 360°·v/l(e) depends on e through l as well. So the inverse never rounds e itself: it
// keeps e = e_i + δe (segment start, exact in f64 on the Rust side, plus an f32 offset) and
//   tan e = (tan e_i + tan δe)/(1 − tan e_i · tan δe)   with tan e_i uploaded,
//   ω(e) = ω_i + m_i·δe,   Δ(e) from (e_i − e_j) + δe,
// and u − u_i from u_i as an f32 pair hi + lo.

struct VafrParams {
    // The gaze (the pole) as hi + lo f32 pairs, screen pixels.
    gaze_hi: vec2<f32>,
    gaze_lo: vec2<f32>,
    // VaFR Eq. 3: e = atan(c_r · r), per pixel.
    c_r: f32,
    // tan(e_max)/c_r: the buffer's edge on the screen, pixels.
    r_max_px: f32,
    // u(e_max): the continuous buffer width, buffer pixels.
    u_max: f32,
    // 180/π, π/180, 360, 2π and 1/(2π): unit conversions, uploaded like everything else.
    deg_per_rad: f32,
    rad_per_deg: f32,
    deg_per_turn: f32,
    rad_per_turn: f32,
    turns_per_rad: f32,
    // How many of `segments` and `tangential` are used.
    n_segments: u32,
    n_tangential: u32,
    pad0: u32,
    pad1: u32,
    // MAR segments (Eq. 12): (e_i degrees, ω_i = ω(e_i) degrees per cycle,
    // m_i = dω/de, u_i = u(e_i), f32 high part), by increasing e_i; the last one extends to
    // infinity.
    segments: array<vec4<f32>, 16>,
    // The same segments' (u_i low part, tan e_i, 0, 0).
    segments_ext: array<vec4<f32>, 16>,
    // Δ(e) of Eq. 19, linear pieces: (e_j degrees, Δ(e_j), dΔ/de on [e_j, e_{j+1}), 0);
    // constant Δ(e_0) before the first.
    tangential: array<vec4<f32>, 16>,
}

@group(0) @binding(0) var<uniform> params: VafrParams;
@group(0) @binding(1) var<storage, read> points_in: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> points_out: array<vec4<f32>>;

// The MAR segment that holds eccentricity `e_deg`: the last one with e_i ≤ e.
fn segment_of_e(e_deg: f32) -> vec4<f32> {
    var s = params.segments[0];
    for (var i = 1u; i < params.n_segments; i = i + 1u) {
        let next = params.segments[i];
        if next.x <= e_deg {
            s = next;
        }
    }
    return s;
}

// The index of the MAR segment that holds buffer column `u`: the last one with u_i ≤ u.
fn segment_of_u(u: f32) -> u32 {
    var found = 0u;
    for (var i = 1u; i < params.n_segments; i = i + 1u) {
        if params.segments[i].w <= u {
            found = i;
        }
    }
    return found;
}

// ω(e), degrees per cycle (Eq. 12).
fn mar_deg(e_deg: f32) -> f32 {
    let s = segment_of_e(e_deg);
    return s.y + s.z * (e_deg - s.x);
}

// Δ(e) (Eq. 19) at e = start + offset (degrees; pass offset 0 for a plain e).
fn tangential_factor(start_deg: f32, offset_deg: f32) -> f32 {
    let e_deg = start_deg + offset_deg;
    var d = params.tangential[0].y;
    for (var j = 0u; j < params.n_tangential; j = j + 1u) {
        let piece = params.tangential[j];
        if piece.x <= e_deg {
            d = piece.y + piece.z * ((start_deg - piece.x) + offset_deg);
        }
    }
    return d;
}

// u(e) = ∫₀ᵉ 2/ω (Eq. 5, 12).
fn u_of_e(e_deg: f32) -> f32 {
    let s = segment_of_e(e_deg);
    let de = e_deg - s.x;
    let k = s.z * de / s.y;
    var ratio = 1.0;
    if k != 0.0 {
        ratio = log1p_f32(k) / k;
    }
    return s.w + 2.0 * de / s.y * ratio;
}

// l(e) of Eq. 9 with Δ (Eq. 19), given Δ(e), ω(e) and t = tan e: Δ·360·(2t/(1 + t²))/ω.
fn shading_height(delta: f32, omega_deg: f32, t: f32) -> f32 {
    let sin_2e = 2.0 * t / (1.0 + t * t);
    return delta * params.deg_per_turn * sin_2e / omega_deg;
}

// Non-finite inputs never reach the shaders: the Rust side answers them itself (WGSL lets an
// implementation assume that no value is NaN or infinite, so a test here could be optimised away).

fn vafr_forward(p: vec2<f32>) -> vec4<f32> {
    let d = offset_from_pole(p, params.gaze_hi, params.gaze_lo);
    let r = length(d);
    if r > params.r_max_px {
        return unmapped();
    }
    let t = params.c_r * r;
    let e_deg = atan_nonneg(t, params.rad_per_turn) * params.deg_per_rad;
    let u = u_of_e(e_deg);
    let l = shading_height(tangential_factor(e_deg, 0.0), mar_deg(e_deg), t);
    let v = angle_turns(d.x, d.y, params.turns_per_rad, params.rad_per_turn) * l;
    return mapped(vec2<f32>(u, v));
}

fn vafr_inverse(s: vec2<f32>) -> vec4<f32> {
    let u = s.x;
    let v = s.y;
    if !(u >= 0.0 && u <= params.u_max) {
        return unmapped();
    }
    // e = e_i + δe (Eq. 10), never rounded as a whole (see the header).
    let i = segment_of_u(u);
    let seg = params.segments[i];
    let ext = params.segments_ext[i];
    let du = (u - seg.w) - ext.x;
    let x = seg.z * du / 2.0;
    var ratio = 1.0;
    if x != 0.0 {
        ratio = expm1_f32(x) / x;
    }
    let de_deg = seg.y * du / 2.0 * ratio;
    let tan_de = tan_nonneg(de_deg * params.rad_per_deg, params.rad_per_turn);
    let t = (ext.y + tan_de) / (1.0 - ext.y * tan_de);
    let l = shading_height(tangential_factor(seg.x, de_deg), seg.y + seg.z * de_deg, t);
    if l <= 0.0 {
        if v == 0.0 {
            return mapped(point_from_pole(vec2<f32>(0.0, 0.0), params.gaze_hi, params.gaze_lo));
        }
        return unmapped();
    }
    if !(v >= 0.0 && v <= l) {
        return unmapped();
    }
    let r = t / params.c_r;
    let dir = cos_sin_turns(v / l, params.rad_per_turn);
    return mapped(point_from_pole(r * dir, params.gaze_hi, params.gaze_lo));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn forward(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = vafr_forward(points_in[id.x]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn inverse(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = vafr_inverse(points_in[id.x]);
}
