// common.wgsl: f32 helpers shared by the fovea compute shaders. The crate prepends this file
// to every module (WGSL has no include); see src/shaders.rs.
//
// These are numerical tools, not mapping math: every number that depends on a mapping, a
// display or a gaze is computed by the Rust side in f64 and uploaded. The literals below are
// Taylor coefficients (1/n, 1/n!) and the precision thresholds that pick a branch.
//
// Precision notes (f32, 24-bit significand, ulp(1) = 1.19e-7):
// * `log1p_f32` keeps log(1 + k) accurate relative to its own value for small |k|, where
//   `log(1.0 + k)` would lose the low bits of k when rounding 1 + k.
// * `expm1_f32` likewise for exp(x) − 1.
// * `cos_sin_turns` takes the angle in turns and reduces it exactly to |a| ≤ 1/8 turn before
//   calling cos/sin, so the error stays ~1e-7 rad for any angle on the circle instead of
//   growing with |angle| (a point 4400 px from the gaze moves 1e-7 · 4400 = 4.4e-4 px).

// Points are evaluated in batches: one invocation per point, 64 per workgroup, in a
// one-dimensional dispatch of at most 65535 workgroups (the Rust side splits larger batches).
const WORKGROUP_SIZE: u32 = 64u;

// ln(1 + k) for k > −1. Where |s| ≤ 0.2 with s = k / (2 + k) (k in about [−0.33, 0.5]) it is
// the series 2·atanh(s) = 2·(s + s³/3 + … + s¹³/13) (next term < 4e-11 relative); elsewhere
// ln(1 + k) ≥ 0.4 in magnitude, so the rounding of 1 + k costs at most ~1.5e-7 relative.
fn log1p_f32(k: f32) -> f32 {
    let s = k / (2.0 + k);
    if abs(s) <= 0.2 {
        let s2 = s * s;
        var p = 1.0 / 13.0;
        p = p * s2 + 1.0 / 11.0;
        p = p * s2 + 1.0 / 9.0;
        p = p * s2 + 1.0 / 7.0;
        p = p * s2 + 1.0 / 5.0;
        p = p * s2 + 1.0 / 3.0;
        p = p * s2 + 1.0;
        return 2.0 * s * p;
    }
    return log(1.0 + k);
}

// ln(num/den) for num, den > 0: log1p((num − den)/den) near 1, where num − den is exact and
// the result keeps its relative precision; log(num/den) below 1/2, where the quotient's
// rounding is relative to it.
fn log_ratio(num: f32, den: f32) -> f32 {
    if num < 0.5 * den {
        return log(num / den);
    }
    return log1p_f32((num - den) / den);
}

// exp(x) − 1. For |x| < 0.5 the Taylor series to x¹⁰/10! (next term < 2e-11 relative),
// in nested form x·(1 + x/2·(1 + x/3·(…))); elsewhere |exp(x) − 1| ≥ 0.39 and the
// subtraction costs at most ~3e-7 relative.
fn expm1_f32(x: f32) -> f32 {
    if abs(x) < 0.5 {
        var p = 1.0 + x / 10.0;
        p = 1.0 + x / 9.0 * p;
        p = 1.0 + x / 8.0 * p;
        p = 1.0 + x / 7.0 * p;
        p = 1.0 + x / 6.0 * p;
        p = 1.0 + x / 5.0 * p;
        p = 1.0 + x / 4.0 * p;
        p = 1.0 + x / 3.0 * p;
        p = 1.0 + x / 2.0 * p;
        return x * p;
    }
    return exp(x) - 1.0;
}

// (cos a, sin a) for |a| ≤ π/4 from their Taylor series to a¹⁴/14! and a¹³/13! (next terms
// below 3e-13), in nested form. WGSL leaves the precision of sin/cos/tan to the
// implementation (some GPUs' fast units are ~4e-7 off, 0.003 px at 8000 px), so the
// mappings use these instead.
fn cos_sin_small(a: f32) -> vec2<f32> {
    let a2 = a * a;
    var s = 1.0 - a2 / 156.0;
    s = 1.0 - a2 / 110.0 * s;
    s = 1.0 - a2 / 72.0 * s;
    s = 1.0 - a2 / 42.0 * s;
    s = 1.0 - a2 / 20.0 * s;
    s = 1.0 - a2 / 6.0 * s;
    var c = 1.0 - a2 / 182.0;
    c = 1.0 - a2 / 132.0 * c;
    c = 1.0 - a2 / 90.0 * c;
    c = 1.0 - a2 / 56.0 * c;
    c = 1.0 - a2 / 30.0 * c;
    c = 1.0 - a2 / 12.0 * c;
    c = 1.0 - a2 / 2.0 * c;
    return vec2<f32>(c, a * s);
}

// tan x for x ≥ 0: from cos_sin_small up to π/4 (0.125 · rad_per_turn), the driver's tan
// beyond (only reached by acuity segments wider than 45°, which VaFR's pivots never are).
fn tan_nonneg(x: f32, rad_per_turn: f32) -> f32 {
    if x <= 0.125 * rad_per_turn {
        let cs = cos_sin_small(x);
        return cs.y / cs.x;
    }
    return tan(x);
}

// (cos, sin) of the angle `turns` (1 = a full turn), given `rad_per_turn` (2π, uploaded).
// The nearest quarter turn q/4 is split off exactly (|f| ≤ 1/8), and the quadrant applied by
// swapping and negating, which is exact.
fn cos_sin_turns(turns: f32, rad_per_turn: f32) -> vec2<f32> {
    let q = round(4.0 * turns);
    let f = turns - 0.25 * q;
    let cs = cos_sin_small(f * rad_per_turn);
    let c = cs.x;
    let s = cs.y;
    let quadrant = ((i32(q) % 4) + 4) % 4;
    switch quadrant {
        case 1: {
            return vec2<f32>(-s, c);
        }
        case 2: {
            return vec2<f32>(-c, -s);
        }
        case 3: {
            return vec2<f32>(s, -c);
        }
        default: {
            return vec2<f32>(c, s);
        }
    }
}

// atan(num/den) in radians for 0 ≤ num ≤ den, den > 0 (so in [0, π/4]), without the driver's
// atan: WGSL leaves atan's precision to the implementation, and lavapipe's atan2 was measured
// ~1e-5 rad off for angles near 0 — 0.01 buffer px at the polar seam. Above tan(π/8) the
// angle is π/4 + atan((r − 1)/(r + 1)) (π/4 = rad_per_turn/8, an exact scaling); then
// |t| ≤ 0.4143 and the series t − t³/3 + … − t²¹/21 is within 6e-10 rad.
fn atan_ratio(num: f32, den: f32, rad_per_turn: f32) -> f32 {
    var t = num / den;
    var base = 0.0;
    if num > 0.41421356 * den {
        t = (num - den) / (num + den);
        base = 0.125 * rad_per_turn;
    }
    let t2 = t * t;
    var p = -1.0 / 21.0;
    p = p * t2 + 1.0 / 19.0;
    p = p * t2 - 1.0 / 17.0;
    p = p * t2 + 1.0 / 15.0;
    p = p * t2 - 1.0 / 13.0;
    p = p * t2 + 1.0 / 11.0;
    p = p * t2 - 1.0 / 9.0;
    p = p * t2 + 1.0 / 7.0;
    p = p * t2 - 1.0 / 5.0;
    p = p * t2 + 1.0 / 3.0;
    p = p * t2 - 1.0;
    return base - t * p;
}

// atan(x) in radians for x ≥ 0 (VaFR Eq. 3's e = atan(c_r·r)).
fn atan_nonneg(x: f32, rad_per_turn: f32) -> f32 {
    if x <= 1.0 {
        return atan_ratio(x, 1.0, rad_per_turn);
    }
    return 0.25 * rad_per_turn - atan_ratio(1.0, x, rad_per_turn);
}

// The angle of (dx, dy) in turns in [0, 1), measured from +x towards +y (screen down), as
// the Rust `polar_deg` measures it in degrees; 0 at the pole itself. Octant by octant: the
// eighth of a turn that holds the point is found exactly from the signs and the larger of
// |dx|, |dy|, and only the angle inside it comes from atan_ratio.
fn angle_turns(dx: f32, dy: f32, turns_per_rad: f32, rad_per_turn: f32) -> f32 {
    let ax = abs(dx);
    let ay = abs(dy);
    if ax == 0.0 && ay == 0.0 {
        return 0.0;
    }
    var t = 0.0;
    if ay <= ax {
        t = atan_ratio(ay, ax, rad_per_turn) * turns_per_rad;
    } else {
        t = 0.25 - atan_ratio(ax, ay, rad_per_turn) * turns_per_rad;
    }
    if dx < 0.0 {
        t = 0.5 - t;
    }
    if dy < 0.0 {
        t = 1.0 - t;
    }
    if t >= 1.0 {
        t = t - 1.0;
    }
    return t;
}

// The offset of a screen point from the pole, with the pole given as the f32 pair hi + lo
// (hi = f32(gaze), lo = f32(gaze − hi)): p − hi is exact for points within a factor of two
// of the pole and otherwise rounds once, so the pole's own f32 rounding (up to 2.4e-4 px at
// 4000 px) does not enter the offset.
fn offset_from_pole(p: vec2<f32>, pole_hi: vec2<f32>, pole_lo: vec2<f32>) -> vec2<f32> {
    return (p - pole_hi) - pole_lo;
}

// The screen point at `offset` from the pole (inverse of offset_from_pole).
fn point_from_pole(offset: vec2<f32>, pole_hi: vec2<f32>, pole_lo: vec2<f32>) -> vec2<f32> {
    return pole_hi + (pole_lo + offset);
}

// One mapped point: xy = the mapped coordinates, z = 1 when the mapping has a sample there
// (the Rust `Some`), 0 otherwise (`None`).
fn mapped(xy: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(xy, 1.0, 0.0);
}

fn unmapped() -> vec4<f32> {
    return vec4<f32>(0.0, 0.0, 0.0, 0.0);
}
