//! Small numerical helpers: the Lambert W function, low-discrepancy sequences, and the few
//! 3-vector operations the display geometry needs (eye rays, the angle between them).

/// Principal branch `W₀(x)` of the Lambert W function for `x ≥ −1/e`: the `w ≥ −1` with
/// `w·eʷ = x`. Halley iteration from a branch-point series or log start; accurate to ~1e-15.
pub fn lambert_w0(x: f64) -> f64 {
    let em1 = -(-1.0f64).exp(); // −1/e
    if x.is_nan() || x < em1 {
        return f64::NAN;
    }
    if x == 0.0 {
        return 0.0;
    }
    let mut w = if x < -0.3 {
        // Series around the branch point: p = √(2(ex + 1)).
        let p = (2.0 * (std::f64::consts::E * x + 1.0)).max(0.0).sqrt();
        -1.0 + p - p * p / 3.0 + 11.0 / 72.0 * p * p * p
    } else if x < 3.0 {
        0.5 * (1.0 + x).ln()
    } else {
        let l = x.ln();
        l - l.ln()
    };
    for _ in 0..50 {
        let ew = w.exp();
        let f = w * ew - x;
        let wp1 = w + 1.0;
        if wp1.abs() < 1e-300 {
            break;
        }
        let denom = ew * wp1 - (w + 2.0) * f / (2.0 * wp1);
        let step = f / denom;
        w -= step;
        if step.abs() <= 1e-15 * (1.0 + w.abs()) {
            break;
        }
    }
    w
}

/// The radical inverse of `index` in `base` (the Halton sequence's coordinate), in [0, 1).
pub fn radical_inverse(mut index: u64, base: u64) -> f64 {
    let inv = 1.0 / base as f64;
    let mut f = inv;
    let mut r = 0.0;
    while index > 0 {
        r += f * (index % base) as f64;
        index /= base;
        f *= inv;
    }
    r
}

/// The `index`-th point of the 2-D Halton sequence (bases 2 and 3), Cranley–Patterson
/// rotated by `shift` (a fixed seed gives a fixed, reproducible pattern).
pub fn halton2(index: u64, shift: (f64, f64)) -> (f64, f64) {
    let a = radical_inverse(index, 2) + shift.0;
    let b = radical_inverse(index, 3) + shift.1;
    (a - a.floor(), b - b.floor())
}

/// The constants of [`mix64`] (Steele, Lea and Flood 2014, SplitMix64; the finaliser's
/// multipliers and shifts are Stafford's "Mix13"), named so another executor of it (the GPU's
/// environment light, `fovea-gpu`) uploads these values instead of writing its own.
pub mod mix64_constants {
    /// Added first (the golden-ratio increment, 2⁶⁴ / φ).
    pub const INCREMENT: u64 = 0x9E37_79B9_7F4A_7C15;
    /// The two multipliers, in order.
    pub const MULTIPLIERS: [u64; 2] = [0xBF58_476D_1CE4_E5B9, 0x94D0_49BB_1331_11EB];
    /// The three right shifts xored in, in order.
    pub const SHIFTS: [u32; 3] = [30, 27, 31];
}

/// A 64-bit mix (SplitMix64 finaliser) used to derive rotations and dithers from a seed.
pub fn mix64(mut z: u64) -> u64 {
    use mix64_constants::{INCREMENT, MULTIPLIERS, SHIFTS};
    z = z.wrapping_add(INCREMENT);
    z = (z ^ (z >> SHIFTS[0])).wrapping_mul(MULTIPLIERS[0]);
    z = (z ^ (z >> SHIFTS[1])).wrapping_mul(MULTIPLIERS[1]);
    z ^ (z >> SHIFTS[2])
}

/// `mix64(seed)` as a float in [0, 1).
pub fn unit_from_seed(seed: u64) -> f64 {
    (mix64(seed) >> 11) as f64 / (1u64 << 53) as f64
}

/// `a − b`.
pub fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a × b`.
pub fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `|a|`.
pub fn norm3(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// The angle between two unit vectors in degrees, `atan2(|a×b|, a·b)` (accurate at small
/// angles, where `acos(a·b)` is not).
pub fn angle_between_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    norm3(cross3(a, b)).atan2(cos).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_w_identity() {
        for &x in &[-0.3678, -0.3, -0.1, -1e-6, 1e-6, 0.5, 1.0, 10.0, 1e6] {
            let w = lambert_w0(x);
            assert!(
                (w * w.exp() - x).abs() <= 1e-12 * (1.0 + x.abs()),
                "x={x} w={w}"
            );
        }
        assert!((lambert_w0(1.0) - 0.567_143_290_409_783_8).abs() < 1e-14);
        assert!((lambert_w0(-(-1.0f64).exp()) + 1.0).abs() < 1e-6);
        assert!(lambert_w0(-1.0).is_nan());
    }

    #[test]
    fn halton_is_stratified() {
        // The first 2^k points of base 2 put exactly one point in each interval of 1/2^k.
        let mut seen = [false; 64];
        for i in 0..64 {
            let x = radical_inverse(i, 2);
            seen[(x * 64.0) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
    }
}
