//! Polar mappings given by a tabulated radial profile, as the uniform block and the segment
//! table of `shaders/polar_table_mapping.wgsl`: rings around the gaze, the ring of radius `r`
//! at buffer column `u(r)` with `period(r)` rows per turn, rows uniform in the polar angle
//! (`v = θ/360°·period(r)`). [`super::vafr_rings`] fills it with VaFR's exact rings,
//! [`super::visual_polar`] with Liu et al.'s visual-polar columns.
//!
//! The profile is a list of segments `[r₀, r₀ + w]` of radius, each with `u` a cubic in the
//! fraction `t = (r − r₀)/w` and `period` linear in `t`:
//!
//! ```text
//! u(t) = u₀ + c₁·t + c₂·t² + c₃·t³,   period(t) = p₀ + Δp·t,   r = r₀ + w·t
//! ```
//!
//! the cubic Hermite through `(u₀, m₀)` and `(u₁, m₁)` (`m = du/dr·w`): `c₁ = m₀`,
//! `c₂ = 3(u₁ − u₀) − 2m₀ − m₁`, `c₃ = m₀ + m₁ − 2(u₁ − u₀)`. Everything is computed here in f64
//! and rounded to f32 once; `r₀`, `u₀`, `p₀`, the gaze, `r_max` and `u_max` travel as f32 pairs
//! `hi + lo` so that the shader works with offsets from them (`r − r₀`, `u − u₀`), which keep
//! their relative precision however far out the segment lies.

use bytemuck::{Pod, Zeroable};
use fovea_core::units::ScreenPoint;

use super::vafr::split_f64;
use crate::error::{GpuError, Result};
use crate::shaders::ShaderSource;

/// The module: forward and inverse entry points, [`PolarTableUniform`] at binding 0, the
/// [`TableSegment`]s at binding 3 (the points in at 1, out at 2, as every mapping module).
pub const SHADER: ShaderSource = ShaderSource {
    file: "polar_table_mapping.wgsl",
    source: concat!(
        include_str!("../../shaders/common.wgsl"),
        include_str!("../../shaders/polar_table_mapping.wgsl")
    ),
    entry_points: &["forward", "inverse"],
    uniform: ("PolarTableParams", std::mem::size_of::<PolarTableUniform>()),
};

/// The storage record `TableSegment` of `polar_table_mapping.wgsl` and the size of its Rust
/// twin [`TableSegment`], bytes (checked by `tests/shaders.rs`).
pub const SEGMENT_STRUCT: (&str, usize) = ("TableSegment", std::mem::size_of::<TableSegment>());

/// Binding of the segment table in the module's group 0.
pub const TABLE_BINDING: u32 = 3;

/// The uniform block `PolarTableParams` of `polar_table_mapping.wgsl` (same field order).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct PolarTableUniform {
    /// Gaze (the pole), f32 high part, pixels.
    pub gaze_hi: [f32; 2],
    /// Gaze, f32 low part, pixels.
    pub gaze_lo: [f32; 2],
    /// The forward mapping's outer radius as `(hi, lo)`, pixels: no sample beyond it.
    pub r_max: [f32; 2],
    /// The buffer's continuous width as `(hi, lo)`, buffer pixels: no sample beyond it.
    pub u_max: [f32; 2],
    /// 2π.
    pub rad_per_turn: f32,
    /// 1/(2π).
    pub turns_per_rad: f32,
    /// Padding to 16 bytes.
    pub pad: [u32; 2],
}

/// One segment of the radial profile (`TableSegment` of `polar_table_mapping.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TableSegment {
    /// `(r₀ hi, r₀ lo, w, 1/w)`, pixels.
    pub r: [f32; 4],
    /// `(u₀ hi, u₀ lo, c₁, c₂)`, buffer pixels.
    pub u: [f32; 4],
    /// `(c₃, p₀ hi, p₀ lo, Δp)`: the cubic's last coefficient, the rows per turn.
    pub ext: [f32; 4],
}

/// One end of a segment: radius, column, `du/dr` (columns per pixel), rows per turn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Knot {
    /// Radius, pixels.
    pub r: f64,
    /// Column coordinate, buffer pixels.
    pub u: f64,
    /// `du/dr` here, columns per pixel (the side facing the segment).
    pub du_dr: f64,
    /// Rows per turn.
    pub period: f64,
}

impl TableSegment {
    /// The segment from `a` to `b` (`b.r > a.r`).
    pub fn between(a: &Knot, b: &Knot) -> Self {
        let w = b.r - a.r;
        let rise = b.u - a.u;
        let (m0, m1) = (a.du_dr * w, b.du_dr * w);
        let (r_hi, r_lo) = split_f64(a.r);
        let (u_hi, u_lo) = split_f64(a.u);
        let (p_hi, p_lo) = split_f64(a.period);
        Self {
            r: [r_hi, r_lo, w as f32, (1.0 / w) as f32],
            u: [u_hi, u_lo, m0 as f32, (3.0 * rise - 2.0 * m0 - m1) as f32],
            ext: [
                (m0 + m1 - 2.0 * rise) as f32,
                p_hi,
                p_lo,
                (b.period - a.period) as f32,
            ],
        }
    }
}

/// A polar mapping's uniform block and segment table, ready to upload.
#[derive(Clone, Debug)]
pub struct PolarTable {
    /// The uniform block.
    pub uniform: PolarTableUniform,
    /// The segments, by increasing radius, contiguous, `u` non-decreasing.
    pub segments: Vec<TableSegment>,
}

impl PolarTable {
    /// The table through `knots` (by strictly increasing radius, the first at `r = 0`; a
    /// knot repeated at the same radius starts a new segment with its own slope, as at a
    /// branch point) around `gaze`, with no sample beyond `r_max` or `u_max`.
    /// [`GpuError::Input`] when the knots are not finite, start elsewhere than `r = 0`, go
    /// backwards in `r` or in `u` (by more than 1e-9 relative), or are fewer than two.
    pub fn new(gaze: ScreenPoint, knots: &[Knot], r_max: f64, u_max: f64) -> Result<Self> {
        let bad = |why: String| Err(GpuError::Input(format!("a polar mapping table: {why}")));
        if knots.len() < 2 {
            return bad(format!("{} knots (at least 2)", knots.len()));
        }
        if knots[0].r != 0.0 || knots[0].u != 0.0 {
            return bad(format!(
                "starts at r = {}, u = {} (must be 0, 0)",
                knots[0].r, knots[0].u
            ));
        }
        let finite = |k: &Knot| {
            k.r.is_finite() && k.u.is_finite() && k.du_dr.is_finite() && k.period.is_finite()
        };
        if let Some(i) = knots.iter().position(|k| !finite(k)) {
            return bad(format!("knot {i} is not finite: {:?}", knots[i]));
        }
        let mut segments = Vec::with_capacity(knots.len() - 1);
        for (i, pair) in knots.windows(2).enumerate() {
            let (a, b) = (&pair[0], &pair[1]);
            // (A branch point may leave the next piece an f64 rounding below the last.)
            if b.r < a.r || b.u < a.u - 1e-9 * a.u.abs().max(1.0) {
                return bad(format!("knot {} goes backwards: {a:?} then {b:?}", i + 1));
            }
            if b.r > a.r {
                segments.push(TableSegment::between(a, b));
            }
        }
        if !(r_max.is_finite() && u_max.is_finite()) {
            return bad(format!("r_max = {r_max}, u_max = {u_max}"));
        }
        let (gx_hi, gx_lo) = split_f64(gaze.x_px);
        let (gy_hi, gy_lo) = split_f64(gaze.y_px);
        let (r_hi, r_lo) = split_f64(r_max);
        let (u_hi, u_lo) = split_f64(u_max);
        let pi = std::f64::consts::PI;
        Ok(Self {
            uniform: PolarTableUniform {
                gaze_hi: [gx_hi, gy_hi],
                gaze_lo: [gx_lo, gy_lo],
                r_max: [r_hi, r_lo],
                u_max: [u_hi, u_lo],
                rad_per_turn: (2.0 * pi) as f32,
                turns_per_rad: (0.5 / pi) as f32,
                pad: [0; 2],
            },
            segments,
        })
    }
}
