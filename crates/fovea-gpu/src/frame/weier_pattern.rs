//! Weier et al. 2018's sparse screen pattern (Sec. 3.1, Eq. 1–2;
//! `fovea_core::mapping::WeierSparse`) as tables on the device, so that the resident frame
//! decides per pixel which rays to cast and which pixels the pull-push reconstruction keeps
//! without a mask going up every frame.
//!
//! The pattern is `S_in` (a square table of bits centred on the point of regard: every pixel
//! within `r₀`, the transition's Halton draws of Eq. 1–2 between `r₀` and `r₁`) where a pixel
//! lies within `r₁` of the point of regard floored, else `S_out` (a static R2 dither of density
//! `p_min` over the screen). Neither table depends on the gaze: only the anchor moves. So the
//! words below are built once per display and parameters from the plan's own mapping (its
//! `s_in_bit` and `s_out_bit`, f64 as the CPU evaluates them — nothing re-derived in f32) and
//! per frame only the anchor and the point of regard go up (16 bytes an eye);
//! `shaders/frame_sparse.wgsl` evaluates `WeierSparse::selected` from them bit for bit.
//!
//! | words | what |
//! |---|---|
//! | 0–1 | the anchor, `⌊point of regard⌋` (i32), clamped to the screen ± `S_in`'s half side (the same bits) |
//! | 2–3 | the point of regard (f32), for the cone table |
//! | 4–12 | `S_in`'s half side, `⌈r₁²⌉ − 1`, `S_in`'s side and first word, the screen width, `S_out`'s first word, the cone table's first word, entries and entries per pixel |
//! | 16… | `S_in`'s bits, `S_out`'s bits (row-major, bit `k % 32` of word `k / 32`), the cone table (f32) |
//!
//! The sample side also needs each sample's ray cone (its texture filter): Weier's spacing
//! depends on the eccentricity alone, so it is tabulated against the distance from the point of
//! regard (`spread_with_floor_rad` of the plan's mapping, every ¼ pixel out to the farthest
//! any gaze the display accepts can be from a pixel) and read linearly between entries.
//! At the Vive Pro Eye the words are 0.33 MB (S_out 288 KB), sent with an eye's first Weier
//! frame and again only when the display or the parameters change.

use std::sync::Mutex;

use fovea_core::display::{DisplayProfile, Gaze, GAZE_MARGIN_FRACTION};
use fovea_core::mapping::footprint::spread_with_floor_rad;
use fovea_core::mapping::{FoveationMapping, WeierParams, WeierSparse};
use fovea_core::units::ScreenPoint;

use crate::device::GpuContext;

/// Words before the tables.
pub const HEADER_WORDS: usize = 16;

/// Entries of the cone table per pixel of distance from the point of regard.
pub const SPREAD_STEPS_PER_PX: f64 = 4.0;

/// What the tables were built from: the screen, the parameters, the radii, and for the cone
/// table the display's scale and the cone's floor.
#[derive(Clone, Debug, PartialEq)]
struct PatternKey {
    screen: (u32, u32),
    params: WeierParams,
    radii_bits: (u64, u64),
    spread: Option<(u64, u32)>,
}

fn key(m: &WeierSparse, spread: Option<&Spread<'_>>) -> PatternKey {
    let (r0, r1) = m.radii_px();
    PatternKey {
        screen: m.screen_px(),
        params: m.sparse_params(),
        radii_bits: (r0.to_bits(), r1.to_bits()),
        spread: spread.map(|s| (s.display.c_r().to_bits(), s.floor_rad.to_bits())),
    }
}

/// What the cone table is built from: the plan's mapping, display, gaze and cone floor.
pub struct Spread<'a> {
    /// The plan's mapping (Weier's).
    pub mapping: &'a dyn FoveationMapping,
    /// The plan's display.
    pub display: &'a DisplayProfile,
    /// The plan's gaze (any gaze gives the same table: the cone depends on the distance).
    pub gaze: Gaze,
    /// The narrowest cone, radians (`SampleFootprint::floor_rad`).
    pub floor_rad: f32,
}

/// Entries of the cone table of a `w`×`h` screen: every [`SPREAD_STEPS_PER_PX`]-th pixel out
/// to the farthest a pixel can be from a gaze the display accepts, and one more.
fn spread_entries(w: u32, h: u32) -> usize {
    let far = (f64::from(w) * (1.0 + GAZE_MARGIN_FRACTION))
        .hypot(f64::from(h) * (1.0 + GAZE_MARGIN_FRACTION))
        + 2.0;
    (far * SPREAD_STEPS_PER_PX).ceil() as usize + 2
}

/// Words of `m`'s tables, with the cone table when `spread` (the sample side) or without.
pub fn words_len(m: &WeierSparse, spread: bool) -> usize {
    let (w, h) = m.screen_px();
    let side = u64::from(m.s_in_side());
    let s_in = (side * side).div_ceil(32) as usize;
    let s_out = (u64::from(w) * u64::from(h)).div_ceil(32) as usize;
    let cones = if spread { spread_entries(w, h) } else { 0 };
    HEADER_WORDS + s_in + s_out + cones
}

/// The per-frame words 0–3 of `m` seen from `gaze` (the point of regard the mapping was built
/// for).
fn frame_words(m: &WeierSparse, gaze: [f64; 2]) -> [u32; 4] {
    let (w, h) = m.screen_px();
    let half = m.s_in_half();
    // Beyond a half side off the screen every pixel is outside S_in either way: the clamp
    // keeps the answers and fits an i32.
    let (ax, ay) = m.anchor_px();
    let ax = ax.clamp(-half - 2, i64::from(w) + half + 2) as i32;
    let ay = ay.clamp(-half - 2, i64::from(h) + half + 2) as i32;
    [
        ax as u32,
        ay as u32,
        (gaze[0] as f32).to_bits(),
        (gaze[1] as f32).to_bits(),
    ]
}

/// Every word of `m`'s tables (module header), the cone table from `spread` where given.
pub fn words(m: &WeierSparse, gaze: [f64; 2], spread: Option<&Spread<'_>>) -> Vec<u32> {
    let (w, h) = m.screen_px();
    let half = m.s_in_half();
    let side = m.s_in_side();
    let (_, r1) = m.radii_px();
    // `selected` asks `d² < r₁²` of an integer d²: `d² ≤ ⌈r₁²⌉ − 1`.
    let max_d2 = ((r1 * r1).ceil() - 1.0).clamp(0.0, f64::from(u32::MAX)) as u32;
    let mut out = vec![0u32; words_len(m, spread.is_some())];
    out[..4].copy_from_slice(&frame_words(m, gaze));
    let s_in_at = HEADER_WORDS;
    let s_out_at = s_in_at + (u64::from(side) * u64::from(side)).div_ceil(32) as usize;
    let cones_at = s_out_at + (u64::from(w) * u64::from(h)).div_ceil(32) as usize;
    let cones = if spread.is_some() {
        spread_entries(w, h)
    } else {
        0
    };
    let header = [
        half as u32,
        max_d2,
        side,
        s_in_at as u32,
        w,
        s_out_at as u32,
        cones_at as u32,
        cones as u32,
        (SPREAD_STEPS_PER_PX as f32).to_bits(),
    ];
    out[4..4 + header.len()].copy_from_slice(&header);
    let mut k = 0usize;
    for dy in -half..=half {
        for dx in -half..=half {
            if m.s_in_bit(dx, dy) {
                out[s_in_at + k / 32] |= 1 << (k % 32);
            }
            k += 1;
        }
    }
    let mut k = 0usize;
    for j in 0..h {
        for i in 0..w {
            if m.s_out_bit(i, j) {
                out[s_out_at + k / 32] |= 1 << (k % 32);
            }
            k += 1;
        }
    }
    if let Some(s) = spread {
        let g = s.gaze.point;
        for (e, word) in out[cones_at..cones_at + cones].iter_mut().enumerate() {
            let d = e as f64 / SPREAD_STEPS_PER_PX;
            let p = ScreenPoint::new(g.x_px + d, g.y_px);
            let cone =
                spread_with_floor_rad(s.mapping, s.display, &s.gaze, p, f64::from(s.floor_rad));
            *word = cone.to_bits();
        }
    }
    out
}

/// One device buffer's copy of a pattern's words: what it holds, so that a frame sends the
/// whole tables only when they change and the four per-frame words otherwise.
#[derive(Default)]
pub struct DevicePattern {
    held: Mutex<Option<PatternKey>>,
}

impl DevicePattern {
    /// Writes `m`'s words for this frame into `buffer` (at offset 0; sized for
    /// [`words_len`]): every word when the buffer holds another pattern's, else words 0–3.
    /// Returns the bytes written.
    pub fn write(
        &self,
        ctx: &GpuContext,
        buffer: &wgpu::Buffer,
        m: &WeierSparse,
        gaze: [f64; 2],
        spread: Option<&Spread<'_>>,
    ) -> u64 {
        let want = key(m, spread);
        let mut held = self.held.lock().unwrap_or_else(|e| e.into_inner());
        if held.as_ref() == Some(&want) {
            let words = frame_words(m, gaze);
            ctx.write_buffer(buffer, 0, bytemuck::cast_slice(&words));
            return std::mem::size_of_val(&words) as u64;
        }
        let all = words(m, gaze, spread);
        ctx.write_buffer(buffer, 0, bytemuck::cast_slice(&all));
        *held = Some(want);
        (all.len() * 4) as u64
    }

    /// Forgets what the buffer holds (a new buffer): the next write sends every word.
    pub fn forget(&self) {
        *self.held.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::mapping::{RadialDensity, WeierParams};

    /// `frame_sparse.wgsl`'s `sparse_shaded`, in Rust over the words.
    fn shaded(words: &[u32], i: u32, j: u32) -> bool {
        let bit = |first: u32, k: u32| (words[(first + k / 32) as usize] >> (k % 32)) & 1 == 1;
        let dx = i as i32 - words[0] as i32;
        let dy = j as i32 - words[1] as i32;
        let half = words[4] as i32;
        if dx.abs() <= half && dy.abs() <= half && ((dx * dx + dy * dy) as u32) <= words[5] {
            return bit(words[7], (dy + half) as u32 * words[6] + (dx + half) as u32);
        }
        bit(words[9], j * words[8] + i)
    }

    #[test]
    fn the_words_give_the_mappings_pattern_at_every_pixel() {
        // A small display, gazes inside, at the edge and off the screen, both radial modes.
        let d = DisplayProfile::with_vertical_fov("t", 160, 120, fovea_core::units::Degrees(100.0))
            .unwrap();
        for radial in [RadialDensity::PaperEq1, RadialDensity::AreaCorrected] {
            let params = WeierParams {
                radial,
                ..WeierParams::default()
            };
            for (x, y) in [(80.3, 60.7), (0.0, 0.0), (159.9, 5.5), (-7.5, 125.0)] {
                let gaze = d.gaze(x, y).unwrap();
                let m = WeierSparse::new(&d, gaze, params).unwrap();
                let w = words(&m, [x, y], None);
                assert_eq!(w.len(), words_len(&m, false));
                let mut differ = 0;
                for j in 0..120 {
                    for i in 0..160 {
                        differ += u32::from(shaded(&w, i, j) != m.selected(i, j));
                    }
                }
                assert_eq!(differ, 0, "{radial:?} at ({x}, {y})");
            }
        }
    }

    #[test]
    fn the_cone_table_follows_the_mappings_cone() {
        let d = DisplayProfile::with_vertical_fov("t", 160, 120, fovea_core::units::Degrees(100.0))
            .unwrap();
        let gaze = d.gaze(40.0, 30.0).unwrap();
        let m = WeierSparse::new(&d, gaze, WeierParams::default()).unwrap();
        let floor = (1.0 / d.focal_y_px()) as f32;
        let s = Spread {
            mapping: &m,
            display: &d,
            gaze,
            floor_rad: floor,
        };
        let w = words(&m, [40.0, 30.0], Some(&s));
        let (first, n) = (w[10] as usize, w[11] as usize);
        assert_eq!(n, spread_entries(160, 120));
        let per_px = f32::from_bits(w[12]);
        // Away from the steps at r₀ and r₁ the linear table is the cone to 1e-3 relative (the
        // largest differences sit at kinks: the one-pixel floor, the density's cap at 1; on
        // this coarse display a pixel spans ~1°, so the cone changes fast with distance).
        let (r0, r1) = m.radii_px();
        let mut worst = 0f32;
        for k in 0..400 {
            let dist = k as f64 * 0.37;
            if (dist - r0).abs() < 1.0 || (dist - r1).abs() < 1.0 {
                continue;
            }
            let x = dist as f32 * per_px;
            let e = (x as usize).min(n - 2);
            let t = (x - e as f32).min(1.0);
            let (a, b) = (
                f32::from_bits(w[first + e]),
                f32::from_bits(w[first + e + 1]),
            );
            let table = a + (b - a) * t;
            let p = ScreenPoint::new(40.0 + dist, 30.0);
            let want = spread_with_floor_rad(&m, &d, &gaze, p, f64::from(floor));
            let rel = ((table - want) / want).abs();
            worst = worst.max(rel);
            assert!(rel < 1e-3, "{dist} px: {table} vs {want}");
        }
        assert!(worst > 0.0 && worst < 1e-3, "{worst}");
    }
}
