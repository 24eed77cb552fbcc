//! Random numbers that change from frame to frame and converge (issue 38): the frame index and
//! the eye enter every shading key ([`with_frame`]), and successive frames of one texel walk a
//! low-discrepancy sequence instead of repeating the same numbers, so that temporal
//! accumulation of a still view converges to the many-ray frame.
//!
//! **The frame's rotation.** Frame `f` rotates every texel's random points by the `f`-th point
//! of the (0, 2)-sequence in base 2 — the first two dimensions of Sobol's sequence (Sobol
//! 1967): the van der Corput radical inverse of `f` and its image under the Pascal matrix mod 2
//! (Kollig and Keller 2002, Sec. 2.1) — as a Cranley-Patterson rotation (Cranley and Patterson
//! 1976): `u' = frac(u + s_f)`. The first `2^k` points of the sequence form a (0, k, 2)-net:
//! one point in each of any `2^k` elementary boxes of area `2^−k`. So each of a texel's
//! random points, rotated frame after frame, is stratified over any run of `2^k` frames
//! starting at a multiple of `2^k`, while inside one frame the rotation, common to all texels,
//! keeps the spatial stratification of the environment light's R2 sequence (`env_light`)
//! untouched. Frame 0's rotation is zero: a single frame is the frame shaded before frames
//! entered the keys.
//!
//! Random numbers that are hashed, not sequenced (the path tracer's bounces beyond the first,
//! white-noise DOF roulette), change with the frame because the key they are hashed from
//! holds it. The ordered DOF roulette rotates its dither by the golden-ratio sequence
//! `frac(f·φ⁻¹)` (Weyl 1916), the one-dimensional low-discrepancy sequence.
//!
//! **Key layout** ([`texel_key`](super::texel_key)): bits 0–3 the texel's rank in its 4×4
//! tile, 4–17 the tile's column, 18–31 its row, 32–37 a sub-sample, 38 the eye, 39–57 the
//! frame (modulo 2¹⁹), 58–63 the layer. The frame and the eye are the only fields that change
//! between two frames of a still view.

use serde::Serialize;

/// First bit of the eye in a shading key.
pub const EYE_SHIFT: u32 = 38;
/// First bit of the frame in a shading key.
pub const FRAME_SHIFT: u32 = 39;
/// Bits of the frame in a shading key: frames repeat their random numbers after `2^19`.
pub const FRAME_BITS: u32 = 19;
/// The key's frame field, in place.
pub const FRAME_MASK: u64 = ((1 << FRAME_BITS) - 1) << FRAME_SHIFT;
/// The key's eye field, in place.
pub const EYE_MASK: u64 = 1 << EYE_SHIFT;
/// `φ⁻¹ = (√5 − 1)/2`, the golden-ratio sequence's step.
pub const GOLDEN_STEP: f64 = 0.618_033_988_749_894_8;

/// Which frame and which eye a frame's random numbers belong to: the plan's per-frame
/// constant that enters every shading key. The default (frame 0, eye 0) is a single frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameNoise {
    /// Frame index in its sequence (0 for a single frame).
    pub frame: u64,
    /// Eye: 0 left (or the only one), 1 right.
    pub eye: u32,
}

impl FrameNoise {
    /// Frame `frame` of eye `eye` (any non-zero eye is the right one).
    pub fn new(frame: u64, eye: u32) -> Self {
        Self {
            frame,
            eye: u32::from(eye != 0),
        }
    }
}

/// `key` (a [`texel_key`](super::texel_key), possibly with a sub-sample) of frame `noise`:
/// its frame and eye fields replaced.
#[inline]
pub fn with_frame(key: u64, noise: FrameNoise) -> u64 {
    let frame = (noise.frame & ((1 << FRAME_BITS) - 1)) << FRAME_SHIFT;
    let eye = u64::from(noise.eye != 0) << EYE_SHIFT;
    (key & !(FRAME_MASK | EYE_MASK)) | frame | eye
}

/// The frame field of `key` (the frame modulo `2^19`).
#[inline]
pub fn key_frame(key: u64) -> u32 {
    ((key & FRAME_MASK) >> FRAME_SHIFT) as u32
}

/// The eye field of `key`.
#[inline]
pub fn key_eye(key: u64) -> u32 {
    ((key & EYE_MASK) >> EYE_SHIFT) as u32
}

/// `key` without its frame: what a texel's random numbers share across frames (their
/// per-tile rotation), the eye kept.
#[inline]
pub fn without_frame(key: u64) -> u64 {
    key & !FRAME_MASK
}

/// The `i`-th point of the (0, 2)-sequence in base 2 as 32-bit fractions: `x` the radical
/// inverse of `i` (its bits reversed), `y` the Pascal matrix's image (module header).
#[inline]
pub fn sobol02_bits(i: u32) -> [u32; 2] {
    let x = i.reverse_bits();
    let (mut y, mut v, mut k) = (0u32, 1u32 << 31, i);
    while k != 0 {
        if k & 1 != 0 {
            y ^= v;
        }
        k >>= 1;
        v ^= v >> 1;
    }
    [x, y]
}

/// Bits of a random number (and of a rotation): numbers are multiples of `2^−24` in `[0, 1)`.
pub const UNIT_BITS: u32 = 24;
const UNIT_MASK: u32 = (1 << UNIT_BITS) - 1;

/// The rotation of frame `frame` (module header): the `frame`-th point of the (0, 2)-sequence,
/// its top 24 bits (a number in `[0, 1)` times `2^24`). Zero for frame 0.
#[inline]
pub fn frame_rotation(frame: u32) -> [u32; 2] {
    sobol02_bits(frame).map(|b| b >> (32 - UNIT_BITS))
}

/// The random number `bits / 2^24` rotated by `rotation / 2^24` (both below `2^24`):
/// `frac(u + s)`, exactly, in `[0, 1)`.
#[inline]
pub fn rotated_unit(bits: u32, rotation: u32) -> f32 {
    (bits.wrapping_add(rotation) & UNIT_MASK) as f32 / (1u32 << UNIT_BITS) as f32
}

/// The one-dimensional rotation of frame `frame` of eye `eye`: `frac(frame·φ⁻¹ + eye/2)`.
#[inline]
pub fn frame_rotation_1d(frame: u32, eye: u32) -> f64 {
    (frame as f64 * GOLDEN_STEP + 0.5 * eye as f64).fract()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_points_of_the_sequence_are_the_known_ones() {
        let p: Vec<[f32; 2]> = (0..4)
            .map(|f| frame_rotation(f).map(|b| rotated_unit(b, 0)))
            .collect();
        assert_eq!(p, vec![[0.0, 0.0], [0.5, 0.5], [0.25, 0.75], [0.75, 0.25]]);
    }

    #[test]
    fn every_run_of_2k_frames_is_a_net() {
        // Each elementary box of area 1/16 (1×16, 2×8, 4×4, 8×2, 16×1) holds exactly one of
        // the points 16m … 16m + 15.
        for m in [0u32, 1, 7, 1000] {
            for lx in 0..=4u32 {
                let ly = 4 - lx;
                let mut cells = vec![0; 16];
                for f in 16 * m..16 * m + 16 {
                    let [x, y] = frame_rotation(f).map(|b| rotated_unit(b, 0));
                    let cx = (x * (1 << lx) as f32) as usize;
                    let cy = (y * (1 << ly) as f32) as usize;
                    cells[cx + (cy << lx)] += 1;
                }
                assert!(cells.iter().all(|&c| c == 1), "m {m}, {lx}x{ly}: {cells:?}");
            }
        }
    }

    #[test]
    fn keys_carry_the_frame_and_the_eye_and_nothing_else_changes() {
        let key = super::super::texel_key(3, 1234, 5678);
        let k = with_frame(key, FrameNoise::new(77, 1));
        assert_eq!(key_frame(k), 77);
        assert_eq!(key_eye(k), 1);
        assert_eq!(without_frame(k) & !EYE_MASK, key);
        assert_eq!(with_frame(key, FrameNoise::default()), key);
        // Frames wrap after 2^19.
        assert_eq!(
            with_frame(key, FrameNoise::new(1 << FRAME_BITS, 0)),
            with_frame(key, FrameNoise::new(0, 0))
        );
        let s = super::super::subsample_key(k, 5);
        assert_eq!((key_frame(s), key_eye(s)), (77, 1));
    }

    #[test]
    fn the_golden_rotation_is_uniform() {
        let mut cells = [0; 10];
        for f in 0..100 {
            cells[(frame_rotation_1d(f, 0) * 10.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| (8..=12).contains(&c)), "{cells:?}");
        assert_eq!(rotated_unit(3 << 22, 1 << 23), 0.25);
    }
}
