// lafr_mapping.wgsl: LaFR (Shi et al.) in the form VaFR gives it, Eq. 15, on the kernel
// log-polar frame of KFR (Eq. 1), forward and inverse in f32, one invocation per point. The
// reference is the f64 Rust mapping `fovea_core::mapping::Lafr`; every constant comes from it
// through `LafrParams` (src/mapping/lafr.rs builds it). Prepended: common.wgsl.
//
// With z = ln r / ln L (0 within a pixel of the gaze, at most 1) and U = u/(W/δ):
//   fovea      z ≤ Z_ef:  U = (z·(1 − F))^(1/F),          z = U^F/(1 − F)
//   periphery  z > Z_ef:  U = q^k·(1 − U_ef) + U_ef,       q = (2·acos(Z_a) − π)/π,
//                         Z_a = (z − Z_ef)/(Z_ef − 1)
// The periphery is rewritten so that it works with quantities that vanish at the buffer's
// outer edge (z → 1, U → 1), where r is largest and acos has an infinite slope. With
// ε = 1 + Z_a = (1 − z)/(1 − Z_ef):
//   2·acos(Z_a) − π = 2·asin(−Z_a) = π − 4·asin(√(ε/2)),  so  1 − q = (4/π)·asin(√(ε/2)),
//   1 − U = (1 − U_ef)·(1 − (1 − (1 − q))^k) = −(1 − U_ef)·expm1(k·log1p(−(1 − q))),
// and backwards
//   1 − q = −expm1(log1p(−(1 − U)/(1 − U_ef))/k),
//   1 − z = (1 − Z_ef)·(1 − sin(qπ/2)) = (1 − Z_ef)·2·sin²((1 − q)·π/4),
//   r = L·exp(−(1 − z)·ln L).
// 1 − z comes from ln(r/L) (log_ratio, accurate near r = L) and 1 − U from W/δ − u (exact
// near the edge), so both directions keep their relative precision where r is largest.
// asin(s) = atan(s/√(1 − s²)) with s ≤ √½, through the crate's atan.

struct LafrParams {
    // The gaze (the pole) as hi + lo f32 pairs, screen pixels.
    gaze_hi: vec2<f32>,
    gaze_lo: vec2<f32>,
    // ln L, L the distance from the gaze to the farthest screen corner, pixels.
    ln_l: f32,
    // The forward mapping's outer radius, pixels.
    r_max_px: f32,
    // L = exp(ln L), pixels.
    l_px: f32,
    // The continuous buffer W/δ × H/δ, buffer pixels.
    width: f32,
    height: f32,
    // The foveal part: F, 1/F, ln(1 − F), 1/(1 − F).
    f: f32,
    inv_f: f32,
    ln_one_minus_f: f32,
    inv_one_minus_f: f32,
    // The boundary: Z_ef, 1 − Z_ef, U_ef, 1 − U_ef.
    z_ef: f32,
    one_minus_z_ef: f32,
    u_ef: f32,
    one_minus_u_ef: f32,
    // The periphery's exponent k = β/0.7 and 1/k.
    k: f32,
    inv_k: f32,
    // 4/π (radians of asin to 1 − q) and 1/8 (the turns of π/4 per unit of 1 − q).
    four_over_pi: f32,
    eighth_turn: f32,
    // 2π and 1/(2π): unit conversions, uploaded like everything else.
    rad_per_turn: f32,
    turns_per_rad: f32,
    pad0: u32,
}

@group(0) @binding(0) var<uniform> params: LafrParams;
@group(0) @binding(1) var<storage, read> points_in: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> points_out: array<vec4<f32>>;

// Non-finite inputs never reach the shaders: the Rust side answers them itself.

// u/(W/δ) of a point r pixels from the gaze, 1 < r ≤ L, as (U, 1 − U).
fn lafr_u_of_r(r: f32) -> vec2<f32> {
    let ln_r_over_l = min(log_ratio(r, params.l_px), 0.0);
    // 1 − z ≥ 0, z = 1 − (1 − z).
    let one_minus_z = -ln_r_over_l / params.ln_l;
    let z = 1.0 - one_minus_z;
    if z <= params.z_ef {
        // (z·(1 − F))^(1/F), z = ln r / ln L away from the edge (z ≤ Z_ef < 1).
        let z_fovea = log(r) / params.ln_l;
        let u = exp((log(z_fovea) + params.ln_one_minus_f) * params.inv_f);
        return vec2<f32>(u, 1.0 - u);
    }
    let eps = one_minus_z / params.one_minus_z_ef;
    let s = sqrt(0.5 * eps);
    let one_minus_q = params.four_over_pi * atan_ratio(s, sqrt(1.0 - s * s), params.rad_per_turn);
    let one_minus_u = -params.one_minus_u_ef * expm1_f32(params.k * log1p_f32(-one_minus_q));
    return vec2<f32>(1.0 - one_minus_u, one_minus_u);
}

fn lafr_forward(p: vec2<f32>) -> vec4<f32> {
    let d = offset_from_pole(p, params.gaze_hi, params.gaze_lo);
    let r = length(d);
    if r > params.r_max_px {
        return unmapped();
    }
    var u = 0.0;
    if r > 1.0 {
        let uu = lafr_u_of_r(r);
        u = params.width - uu.y * params.width;
        if uu.x < 0.5 {
            u = uu.x * params.width;
        }
    }
    let v = angle_turns(d.x, d.y, params.turns_per_rad, params.rad_per_turn) * params.height;
    return mapped(vec2<f32>(u, v));
}

fn lafr_inverse(s: vec2<f32>) -> vec4<f32> {
    let u = s.x;
    let v = s.y;
    if !(u >= 0.0 && u <= params.width && v >= 0.0 && v <= params.height) {
        return unmapped();
    }
    if u == 0.0 {
        return mapped(point_from_pole(vec2<f32>(0.0, 0.0), params.gaze_hi, params.gaze_lo));
    }
    let big_u = u / params.width;
    var one_minus_z = 0.0;
    if big_u <= params.u_ef {
        // z = U^F/(1 − F).
        let z = exp(params.f * log(big_u)) * params.inv_one_minus_f;
        one_minus_z = 1.0 - z;
    } else {
        // W/δ − u is exact near the edge.
        let one_minus_u = (params.width - u) / params.width;
        let one_minus_q = -expm1_f32(log1p_f32(-one_minus_u / params.one_minus_u_ef) * params.inv_k);
        let sc = cos_sin_turns(one_minus_q * params.eighth_turn, params.rad_per_turn);
        one_minus_z = params.one_minus_z_ef * 2.0 * sc.y * sc.y;
    }
    // r = exp(z·ln L) = L·exp(−(1 − z)·ln L) ≥ 1.
    let r = params.l_px * exp(-one_minus_z * params.ln_l);
    let dir = cos_sin_turns(v / params.height, params.rad_per_turn);
    return mapped(point_from_pole(r * dir, params.gaze_hi, params.gaze_lo));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn forward(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = lafr_forward(points_in[id.x]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn inverse(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = lafr_inverse(points_in[id.x]);
}
