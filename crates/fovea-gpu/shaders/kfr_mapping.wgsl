// kfr_mapping.wgsl: the kernel log-polar mapping of KFR / LMFR (Meng et al.) in the form VaFR
// gives it, Eq. 1 with K(z) = z^α (Eq. 14), forward and inverse in f32, one invocation per
// point. The reference is the f64 Rust mapping `fovea_core::mapping::Kfr` (through its
// `LogPolarGeometry`); every constant comes from it through `KfrParams`
// (src/mapping/kfr.rs builds it). Prepended: common.wgsl.
//
// Forward, screen pixel p → LP buffer (u, v):
//   r = |p − gaze|; z = 0 for r ≤ 1, else min(ln r / ln L, 1)
//   u = z^α · W/δ, v = θ/360° · H/δ
//   no sample where r > L (the farthest screen corner, plus rounding).
// Inverse, (u, v) → screen:
//   z = (u/(W/δ))^(1/α), r = exp(z · ln L), θ = 360° · v/(H/δ); u = 0 is the gaze
//   no sample where u ∉ [0, W/δ] or v ∉ [0, H/δ].
//
// In f32, ln r near the buffer's outer edge (ln r ≈ 9 at 8K) carries an absolute rounding of
// ~5e-7, which exp turns into 0.004 px at r = 8800. So both directions work with quantities
// that vanish at the edge, exactly where r is largest:
//   forward  ln(r/L) (log_ratio),  ln z = log1p(ln(r/L)/ln L),  u = W/δ · exp(α · ln z)
//   inverse  ln(u/(W/δ)) (log_ratio),  z − 1 = expm1(ln(u/(W/δ))/α),
//            r = L · exp((z − 1) · ln L)
// (the same formulas rearranged; the error of r is then ~1e-7 · r·|ln(r/L)| ≤ 1e-7 · L/e).

struct KfrParams {
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
    // The kernel exponent α and 1/α.
    alpha: f32,
    inv_alpha: f32,
    // 2π and 1/(2π): unit conversions, uploaded like everything else.
    rad_per_turn: f32,
    turns_per_rad: f32,
    pad0: u32,
}

@group(0) @binding(0) var<uniform> params: KfrParams;
@group(0) @binding(1) var<storage, read> points_in: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> points_out: array<vec4<f32>>;

// Non-finite inputs never reach the shaders: the Rust side answers them itself.

fn kfr_forward(p: vec2<f32>) -> vec4<f32> {
    let d = offset_from_pole(p, params.gaze_hi, params.gaze_lo);
    let r = length(d);
    if r > params.r_max_px {
        return unmapped();
    }
    var u = 0.0;
    if r > 1.0 {
        let ln_r_over_l = min(log_ratio(r, params.l_px), 0.0);
        let ln_z = log1p_f32(ln_r_over_l / params.ln_l);
        u = exp(params.alpha * ln_z) * params.width;
    }
    let v = angle_turns(d.x, d.y, params.turns_per_rad, params.rad_per_turn) * params.height;
    return mapped(vec2<f32>(u, v));
}

fn kfr_inverse(s: vec2<f32>) -> vec4<f32> {
    let u = s.x;
    let v = s.y;
    if !(u >= 0.0 && u <= params.width && v >= 0.0 && v <= params.height) {
        return unmapped();
    }
    if u == 0.0 {
        return mapped(point_from_pole(vec2<f32>(0.0, 0.0), params.gaze_hi, params.gaze_lo));
    }
    let ln_u = log_ratio(u, params.width);
    let z_minus_1 = expm1_f32(ln_u * params.inv_alpha);
    let r = params.l_px * exp(z_minus_1 * params.ln_l);
    let dir = cos_sin_turns(v / params.height, params.rad_per_turn);
    return mapped(point_from_pole(r * dir, params.gaze_hi, params.gaze_lo));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn forward(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = kfr_forward(points_in[id.x]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn inverse(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = kfr_inverse(points_in[id.x]);
}
