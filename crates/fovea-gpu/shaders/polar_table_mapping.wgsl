// polar_table_mapping.wgsl: a polar mapping given by its tabulated radial profile, forward and
// inverse in f32, one invocation per point. Rings around the gaze: the ring of radius r lies
// at buffer column u(r) and holds period(r) rows per turn, rows uniform in the polar angle.
// Two mappings use it (src/mapping/polar_table.rs builds the table, every number in f64):
//   * VaFR with exact rings (Zhang, Gai, Li, Eq. 3–9 and 19 with each ring sized at its
//     worst on-screen point; fovea_core `vafr_rings.rs`): one segment per table step, u the
//     cubic Hermite of the step, period linear (src/mapping/vafr_rings.rs);
//   * visual-polar (Liu, Mantel, Forchhammer, Eq. 1–3): u = W·ρ(α(r)), period = H, the
//     mapping's own f64 ρ(α) tabulated densely with a knot at the foveal boundary
//     (src/mapping/visual_polar.rs). Prepended: common.wgsl.
//
// Segment [r₀, r₀ + w] of the table, t = (r − r₀)/w ∈ [0, 1]:
//   u = u₀ + t·(c₁ + t·(c₂ + t·c₃)),   period = p₀ + Δp·t
// Forward, screen pixel p → (u, v):
//   r = |p − gaze|; no sample where r > r_max; the segment with the largest r₀ ≤ r;
//   v = θ/360°·period.
// Inverse, (u, v) → screen:
//   no sample where u ∉ [0, u_max]; the segment with the largest u₀ < u (the first for
//   u = 0, so a flat segment is never picked and a jump in the inverse, e.g. the paper's fit
//   of visual-polar at its foveal boundary, goes to the side the reference takes); t from the
//   cubic = u − u₀ (safeguarded Newton from the quadratic's root); r = r₀ + w·t;
//   period ≤ 0 (the pole of VaFR's rings) has only v = 0, the gaze; else no sample where
//   v ∉ [0, period]; θ = 360°·v/period.
//
// Precision. r₀, u₀, p₀, the gaze, r_max and u_max come as f32 pairs hi + lo, so r − r₀ and
// u − u₀ are formed as (x − hi) − lo: the first difference is exact near the segment, and the
// offsets keep their relative precision however far out the segment lies (at 8K the outer
// rings move 14 px per column of visual-polar: u itself rounded to f32, 6e-5 at u = 930 or
// 4.9e-4 at u = 7680, would cost up to 7e-3 px, the offset from u₀ costs nothing). The angle
// uses the crate's own atan and cos/sin (common.wgsl).

struct PolarTableParams {
    // The gaze (the pole) as hi + lo f32 pairs, screen pixels.
    gaze_hi: vec2<f32>,
    gaze_lo: vec2<f32>,
    // The forward mapping's outer radius (hi, lo), pixels.
    r_max: vec2<f32>,
    // The buffer's continuous width (hi, lo), buffer pixels.
    u_max: vec2<f32>,
    // 2π and 1/(2π): unit conversions, uploaded like everything else.
    rad_per_turn: f32,
    turns_per_rad: f32,
    pad0: u32,
    pad1: u32,
}

// One segment of the radial profile, by increasing r₀ (contiguous; u₀ non-decreasing).
struct TableSegment {
    // (r₀ hi, r₀ lo, w, 1/w), pixels.
    r: vec4<f32>,
    // (u₀ hi, u₀ lo, c₁, c₂), buffer pixels.
    u: vec4<f32>,
    // (c₃, p₀ hi, p₀ lo, Δp): the cubic's last coefficient, rows per turn.
    ext: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: PolarTableParams;
@group(0) @binding(1) var<storage, read> points_in: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> points_out: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> segments: array<TableSegment>;

// x − (hi + lo) for x near hi + lo: x − hi is exact within a factor of two of hi.
fn minus_pair(x: f32, pair: vec2<f32>) -> f32 {
    return (x - pair.x) - pair.y;
}

// The last segment whose r₀ ≤ r (the first if none).
fn segment_of_r(r: f32) -> u32 {
    var lo = 0u;
    var hi = arrayLength(&segments);
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if minus_pair(r, segments[mid].r.xy) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// The last segment whose u₀ < u (the first if none).
fn segment_of_u(u: f32) -> u32 {
    var lo = 0u;
    var hi = arrayLength(&segments);
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if minus_pair(u, segments[mid].u.xy) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// The t ∈ [0, 1] with c₁·t + c₂·t² + c₃·t³ = du, the cubic increasing on [0, 1] (a Hermite
// segment of an increasing profile). Start: the root of the quadratic c₁·t + c₂·t² = du in
// its stable form 2·du/(c₁ + √(c₁² + 4·c₂·du)) — the answer itself when c₃ = 0, as for VaFR's
// rings, whose trapezoid rule makes c₃ vanish — or du over the segment's rise; then Newton
// steps kept inside [0, 1]. A flat segment (rise 0) answers its start.
fn solve_cubic(c1: f32, c2: f32, c3: f32, du: f32) -> f32 {
    let rise = c1 + c2 + c3;
    if !(rise > 0.0) || du <= 0.0 {
        return 0.0;
    }
    var t = du / rise;
    let disc = c1 * c1 + 4.0 * c2 * du;
    if disc >= 0.0 {
        let den = c1 + sqrt(disc);
        if den > 0.0 {
            t = 2.0 * du / den;
        }
    }
    t = clamp(t, 0.0, 1.0);
    for (var i = 0; i < 3; i = i + 1) {
        let f = t * (c1 + t * (c2 + t * c3)) - du;
        let df = c1 + t * (2.0 * c2 + 3.0 * c3 * t);
        if df > 0.0 {
            t = clamp(t - f / df, 0.0, 1.0);
        }
    }
    return t;
}

// Non-finite inputs never reach the shaders: the Rust side answers them itself.

fn table_forward(p: vec2<f32>) -> vec4<f32> {
    let d = offset_from_pole(p, params.gaze_hi, params.gaze_lo);
    let r = length(d);
    if minus_pair(r, params.r_max) > 0.0 {
        return unmapped();
    }
    let s = segments[segment_of_r(r)];
    let t = minus_pair(r, s.r.xy) * s.r.w;
    let u = s.u.x + (s.u.y + t * (s.u.z + t * (s.u.w + t * s.ext.x)));
    let period = s.ext.y + (s.ext.z + s.ext.w * t);
    let v = angle_turns(d.x, d.y, params.turns_per_rad, params.rad_per_turn) * period;
    return mapped(vec2<f32>(u, v));
}

fn table_inverse(q: vec2<f32>) -> vec4<f32> {
    let u = q.x;
    let v = q.y;
    if !(u >= 0.0 && minus_pair(u, params.u_max) <= 0.0) {
        return unmapped();
    }
    let s = segments[segment_of_u(u)];
    let t = solve_cubic(s.u.z, s.u.w, s.ext.x, minus_pair(u, s.u.xy));
    let r = s.r.x + (s.r.y + s.r.z * t);
    let period = s.ext.y + (s.ext.z + s.ext.w * t);
    if period <= 0.0 {
        if v == 0.0 {
            return mapped(point_from_pole(vec2<f32>(0.0, 0.0), params.gaze_hi, params.gaze_lo));
        }
        return unmapped();
    }
    if !(v >= 0.0 && v <= period) {
        return unmapped();
    }
    let dir = cos_sin_turns(v / period, params.rad_per_turn);
    return mapped(point_from_pole(r * dir, params.gaze_hi, params.gaze_lo));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn forward(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = table_forward(points_in[id.x]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn inverse(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&points_in) {
        return;
    }
    points_out[id.x] = table_inverse(points_in[id.x]);
}
