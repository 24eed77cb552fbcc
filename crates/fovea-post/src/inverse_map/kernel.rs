//! The polar reconstruction's per-row loops (VaFR Sec. 3.4, the inverse mapping of Eq. 10–11;
//! the method is described in the parent module), in two kernels that compute the same
//! numbers:
//!
//! * [`PolarKernel::Scalar`], one pixel at a time, the reference and the fallback on every
//!   processor;
//! * [`PolarKernel::Avx2`], eight pixels per instruction on x86-64 processors with AVX2 (chosen
//!   at run time by [`PolarKernel::detect`]): the pixels' buffer coordinates (square root, the
//!   `u(r)` table read by gather, the atan2 polynomial) and the texel addresses of the two
//!   columns each pixel reads (the columns' bases, rows and periods by gather) and its
//!   nearest texel (for depth), then each pixel's two row pairs blended in one 256-bit
//!   register and the two columns in a 128-bit one.
//!
//! Both evaluate the same IEEE operations in the same order (no fused multiply-add, the
//! same selects), so their frames agree bit for bit; `tests` holds them to within 1/255 on
//! random texels and a rendered frame, as the CPU issue asks. Blocks the vector path does not
//! take — pixels with no sample, and the fovea's footprint box over several columns — go
//! through the scalar code inside the AVX2 kernel.

use fovea_core::FoveaError;

use super::{blend, box_across_columns, PolarColumns, COORD_TOLERANCE_TEXELS};
use crate::Rgb;

/// Which implementation of the polar reconstruction's inner loops runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PolarKernel {
    /// One pixel at a time; every processor.
    Scalar,
    /// Eight pixels per instruction (x86-64 with AVX2).
    Avx2,
}

impl PolarKernel {
    /// The fastest kernel this processor runs: [`Self::Avx2`] where the CPU reports AVX2,
    /// [`Self::Scalar`] otherwise.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Self::Avx2;
        }
        Self::Scalar
    }

    /// Short name in stats and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Scalar => "scalar",
            Self::Avx2 => "avx2",
        }
    }

    /// Whether this processor runs the kernel.
    pub fn available(self) -> bool {
        match self {
            Self::Scalar => true,
            Self::Avx2 => Self::detect() == Self::Avx2,
        }
    }

    /// `Ok` when this processor runs the kernel; an actionable error otherwise.
    pub fn check(self) -> fovea_core::Result<()> {
        if self.available() {
            Ok(())
        } else {
            Err(FoveaError::Unsupported(format!(
                "the {} reconstruction kernel on this processor (it lacks the instructions); \
                 use the scalar kernel",
                self.name()
            )))
        }
    }
}

/// Pixels between exactly computed coordinates in pass 1 (a power of two).
pub(super) const SPAN: usize = 8;

/// Everything a row of the polar reconstruction reads: the `u(r)` table and the screen
/// geometry of pass 1, the columns and the footprint of pass 2.
pub(super) struct PolarRows<'a> {
    /// `u(r)` table (see `PolarTables::lut`).
    pub lut: &'a [f32],
    /// The pole's x, screen pixels.
    pub cx: f32,
    /// The pole's y, screen pixels.
    pub cy: f32,
    /// Table entries per pixel of radius.
    pub inv_step: f32,
    /// `last + 1`: column coordinates beyond it have no sample.
    pub cols_end: f32,
    /// The last column with shaded rows.
    pub last: usize,
    /// Largest error allowed in a linearly interpolated angle, turns.
    pub turn_tolerance: f32,
    /// The columns' texels.
    pub columns: &'a PolarColumns,
    /// Columns per pixel radially (the footprint filter), or `None` (bilinear).
    pub radial: Option<&'a [f32]>,
    /// With `radial`: the first column from which every column is at most one texel per
    /// pixel, so a pixel reading columns at or past it is a plain bilinear lookup.
    pub dense_end: usize,
    /// [`span_points`] of the screen's width.
    pub points: &'a [f32],
}

/// The pixel columns where pass 1 computes every row's coordinates exactly, in order: each
/// span's start, its middle, …, the last span's end (`0, 4, 8, …, w − 1`, the middles
/// between), padded with the last to a multiple of [`SPAN`].
pub(super) fn span_points(w: usize) -> Vec<f32> {
    if w == 0 {
        return Vec::new();
    }
    let end = |s: usize| (s * SPAN).min(w - 1);
    let spans = (w - 1).div_ceil(SPAN);
    let mut points: Vec<f32> = (0..spans)
        .flat_map(|s| [end(s), (end(s) + end(s + 1)) / 2])
        .chain([w - 1])
        .map(|x| x as f32)
        .collect();
    let last = points[points.len() - 1];
    points.resize(points.len().next_multiple_of(SPAN), last);
    points
}

/// One row's working space: its pixels' buffer coordinates, and the exact ones at the
/// [`span_points`].
pub(super) struct RowScratch {
    us: Vec<f32>,
    turns: Vec<f32>,
    eu: Vec<f32>,
    et: Vec<f32>,
}

impl PolarRows<'_> {
    /// Row `y` of the screen into `row_c` and `row_d`, with `scratch` for the pixels'
    /// buffer coordinates.
    pub fn row(
        &self,
        kernel: PolarKernel,
        y: usize,
        scratch: &mut RowScratch,
        row_c: &mut [Rgb],
        row_d: &mut [f32],
    ) {
        match kernel {
            #[cfg(target_arch = "x86_64")]
            PolarKernel::Avx2 if PolarKernel::detect() == PolarKernel::Avx2 => {
                // SAFETY: the processor reports AVX2 (checked just above).
                unsafe { avx2::row(self, y, scratch, row_c, row_d) }
            }
            _ => self.row_scalar(y, scratch, row_c, row_d),
        }
    }

    /// Scratch space for one row at a time, the screen's width.
    pub fn scratch(&self, width: usize) -> RowScratch {
        RowScratch {
            us: vec![0.0; width],
            turns: vec![0.0; width],
            eu: vec![0.0; self.points.len()],
            et: vec![0.0; self.points.len()],
        }
    }

    fn row_scalar(&self, y: usize, scratch: &mut RowScratch, row_c: &mut [Rgb], row_d: &mut [f32]) {
        let dy = y as f32 + 0.5 - self.cy;
        self.coordinates(
            scratch,
            |xs, u, t| {
                for l in 0..SPAN {
                    (u[l], t[l]) = self.exact(dy, xs[l]);
                }
            },
            Self::fill_linear,
        );
        for (x, (c, d)) in row_c.iter_mut().zip(row_d.iter_mut()).enumerate() {
            (*c, *d) = self.pixel(scratch.us[x], scratch.turns[x]);
        }
    }

    /// Pass 1 at one pixel: the column coordinate `u` (column centres at integers, clamped to
    /// the shaded columns; infinite where no sample covers the pixel) and the angle in turns
    /// of the pixel whose column is `x` (as a float) on the row `dy` from the pole.
    #[inline(always)]
    fn exact(&self, dy: f32, x: f32) -> (f32, f32) {
        let lut = self.lut;
        let n = lut.len();
        let dx = x + 0.5 - self.cx;
        let t = (dx * dx + dy * dy).sqrt() * self.inv_step;
        let k = (t as usize).min(n - 2);
        let f = (t - k as f32).min(1.0);
        // (`f > 0` keeps a covered entry next to an uncovered one finite.)
        let u = if f > 0.0 {
            lut[k] + (lut[k + 1] - lut[k]) * f
        } else {
            lut[k]
        } - 0.5;
        // Beyond the buffer (infinite: no sample covers it) or past the last column's outer
        // edge: uncovered.
        let lastf = self.last as f32;
        let u = if u <= self.cols_end {
            // Written as the vector kernel's max/min (a −0 stays −0).
            let u = if 0.0 > u { 0.0 } else { u };
            if lastf < u {
                lastf
            } else {
                u
            }
        } else {
            f32::INFINITY
        };
        (u, turn_of(dy, dx))
    }

    /// Buffer coordinates `(u, turn)` of every pixel of a row, from `exact8(xs, u, turn)`,
    /// which evaluates [`Self::exact`] at [`SPAN`] pixel columns `xs` at once: exact at the
    /// span ends [`span_points`] lists (every [`SPAN`]-th pixel and the last); in between,
    /// linear between the span's ends wherever the exact value at the span's middle lies
    /// within [`COORD_TOLERANCE_TEXELS`] of the line (in `u`, and in the angle at the largest
    /// period), exact otherwise — near the pole, where the coordinates curve fast, and across
    /// the angular wrap, where the angle jumps from 1 back to 0. The coordinates are smooth
    /// elsewhere, so the middle's deviation bounds the span's.
    #[inline(always)]
    fn coordinates(
        &self,
        scratch: &mut RowScratch,
        mut exact8: impl FnMut(&[f32; SPAN], &mut [f32; SPAN], &mut [f32; SPAN]),
        mut fill: impl FnMut(&mut [f32], &mut [f32], usize, usize, [f32; 4]),
    ) {
        let RowScratch { us, turns, eu, et } = scratch;
        let w = us.len();
        if w == 0 {
            return;
        }
        // Span s runs from pixel end(s) to end(s + 1); point 2s is its start, 2s + 1 its
        // middle.
        for ((xs, u), t) in self
            .points
            .chunks_exact(SPAN)
            .zip(eu.chunks_exact_mut(SPAN))
            .zip(et.chunks_exact_mut(SPAN))
        {
            exact8(
                xs.try_into().expect("SPAN lanes"),
                u.try_into().expect("SPAN lanes"),
                t.try_into().expect("SPAN lanes"),
            );
        }
        let end = |s: usize| (s * SPAN).min(w - 1);
        (us[0], turns[0]) = (eu[0], et[0]);
        let mut xs = [0.0f32; SPAN];
        let (mut u, mut t) = ([0.0f32; SPAN], [0.0f32; SPAN]);
        for s in 0..(w - 1).div_ceil(SPAN) {
            let (x0, x1) = (end(s), end(s + 1));
            let (u0, t0) = (eu[2 * s], et[2 * s]);
            let (u1, t1) = (eu[2 * s + 2], et[2 * s + 2]);
            if x1 - x0 < 2 {
                (us[x1], turns[x1]) = (u1, t1);
                continue;
            }
            let (um, tm) = (eu[2 * s + 1], et[2 * s + 1]);
            let xm = (x0 + x1) / 2;
            let fm = (xm - x0) as f32 / (x1 - x0) as f32;
            let linear = (u0 + (u1 - u0) * fm - um).abs() <= COORD_TOLERANCE_TEXELS
                && (t0 + (t1 - t0) * fm - tm).abs() <= self.turn_tolerance;
            if linear {
                fill(us, turns, x0, x1, [u0, u1 - u0, t0, t1 - t0]);
            } else {
                for (l, v) in xs.iter_mut().enumerate() {
                    *v = (x0 + 1 + l).min(x1 - 1) as f32;
                }
                exact8(&xs, &mut u, &mut t);
                let n = x1 - x0 - 1;
                us[x0 + 1..x1].copy_from_slice(&u[..n]);
                turns[x0 + 1..x1].copy_from_slice(&t[..n]);
            }
            (us[x1], turns[x1]) = (u1, t1);
        }
    }

    /// The linear fill of pass 1: pixels `x0 + 1 .. x1` of `us` and `turns` at
    /// `u0 + du·f`, `t0 + dt·f`, `f = (x − x0)/(x1 − x0)` (`line = [u0, du, t0, dt]`).
    #[inline(always)]
    fn fill_linear(us: &mut [f32], turns: &mut [f32], x0: usize, x1: usize, line: [f32; 4]) {
        let [u0, du, t0, dt] = line;
        let inv = 1.0 / (x1 - x0) as f32;
        let (su, st) = (&mut us[x0 + 1..x1], &mut turns[x0 + 1..x1]);
        for (l, (u, t)) in su.iter_mut().zip(st.iter_mut()).enumerate() {
            let f = (l + 1) as f32 * inv;
            (*u, *t) = (u0 + du * f, t0 + dt * f);
        }
    }

    /// Pass 2 at one pixel: bilinear across the two nearest columns, each read at its angle
    /// (or, with the footprint filter where the columns are denser than the screen, a box
    /// over the columns the pixel covers); black at infinite depth where no sample covers it.
    #[inline(always)]
    fn pixel(&self, uc: f32, turn: f32) -> (Rgb, f32) {
        if !uc.is_finite() {
            return ([0.0; 3], f32::INFINITY);
        }
        let last = self.last;
        let i0 = uc as usize;
        let i1 = (i0 + 1).min(last);
        let fu = uc - i0 as f32;
        let [r, g, b, d] = blend(self.columns.read(i0, turn), self.columns.read(i1, turn), fu);
        let c = match self.radial {
            Some(t) if t[i0].max(t[i1]) > 1.0 => {
                let width = t[i0] + (t[i1] - t[i0]) * fu;
                box_across_columns(self.columns, uc, width.max(1.0), last, turn)
            }
            _ => [r, g, b],
        };
        (c, d)
    }
}

/// The angle of `(dx, dy)` in turns, in `[0, 1)`.
#[inline(always)]
pub(super) fn turn_of(dy: f32, dx: f32) -> f32 {
    let t = fast_atan2(dy, dx) * (1.0 / std::f32::consts::TAU);
    if t < 0.0 {
        t + 1.0
    } else {
        t
    }
}

/// Coefficients of the odd minimax polynomial of [`fast_atan2`], highest first, then the
/// linear term.
const ATAN: [f32; 6] = [
    -0.011_719_12,
    0.052_653_32,
    -0.116_432_87,
    0.193_543_46,
    -0.332_623_47,
    0.999_977_26,
];

/// `atan2(y, x)` in radians with |error| < 1e-5 (octant reduction and a degree-11 odd
/// minimax polynomial for atan on [0, 1]); about 5× faster than the libm call, which matters
/// at tens of millions of pixels per frame.
#[inline(always)]
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (mn, mx) = (ax.min(ay), ax.max(ay));
    // Written with selects rather than branches so that rows of pixels vectorise.
    let a = if mx > 0.0 { mn / mx } else { 0.0 };
    let s = a * a;
    let r = ((((ATAN[0] * s + ATAN[1]) * s + ATAN[2]) * s + ATAN[3]) * s + ATAN[4]) * s * a
        + ATAN[5] * a;
    let r = if ay > ax {
        std::f32::consts::FRAC_PI_2 - r
    } else {
        r
    };
    let r = if x < 0.0 { std::f32::consts::PI - r } else { r };
    if y < 0.0 {
        -r
    } else {
        r
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! The AVX2 kernel: [`row`] is [`PolarRows::row_scalar`] eight pixels at a time.

    use std::arch::x86_64::*;

    use super::{PolarRows, RowScratch, ATAN, SPAN};
    use crate::Rgb;

    /// [`PolarRows::row_scalar`] with pass 1's exact coordinates and pass 2's texel
    /// addresses eight pixels per instruction.
    ///
    /// # Safety
    /// The processor must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn row(
        rows: &PolarRows<'_>,
        y: usize,
        scratch: &mut RowScratch,
        row_c: &mut [Rgb],
        row_d: &mut [f32],
    ) {
        let dy = y as f32 + 0.5 - rows.cy;
        rows.coordinates(
            scratch,
            // SAFETY (both): AVX2 is present (this function's contract).
            |xs, u, t| unsafe { exact8(rows, dy, xs, u, t) },
            |us, turns, x0, x1, line| unsafe { fill8(us, turns, x0, x1, line) },
        );
        // SAFETY: as above.
        unsafe { pass2(rows, &scratch.us, &scratch.turns, row_c, row_d) }
    }

    /// [`PolarRows::fill_linear`], a whole span as eight lanes (the eighth lands on `x1`,
    /// which the caller writes afterwards).
    #[target_feature(enable = "avx2")]
    unsafe fn fill8(us: &mut [f32], turns: &mut [f32], x0: usize, x1: usize, line: [f32; 4]) {
        if x1 - x0 != SPAN {
            return PolarRows::fill_linear(us, turns, x0, x1, line);
        }
        let [u0, du, t0, dt] = line;
        // `(l + 1) as f32 * (1 / SPAN)`, exact.
        let f = _mm256_mul_ps(
            _mm256_setr_ps(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0),
            _mm256_set1_ps(1.0 / SPAN as f32),
        );
        let u = _mm256_add_ps(_mm256_set1_ps(u0), _mm256_mul_ps(_mm256_set1_ps(du), f));
        let t = _mm256_add_ps(_mm256_set1_ps(t0), _mm256_mul_ps(_mm256_set1_ps(dt), f));
        _mm256_storeu_ps(us[x0 + 1..x1 + 1].as_mut_ptr(), u);
        _mm256_storeu_ps(turns[x0 + 1..x1 + 1].as_mut_ptr(), t);
    }

    /// [`PolarRows::exact`] at the eight pixel columns `xs`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn exact8(
        rows: &PolarRows<'_>,
        dy: f32,
        xs: &[f32; SPAN],
        u_out: &mut [f32; SPAN],
        t_out: &mut [f32; SPAN],
    ) {
        let lut = rows.lut;
        let n = lut.len();
        let zero = _mm256_setzero_ps();
        let x = _mm256_loadu_ps(xs.as_ptr());
        let dx = _mm256_sub_ps(
            _mm256_add_ps(x, _mm256_set1_ps(0.5)),
            _mm256_set1_ps(rows.cx),
        );
        let r2 = _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_set1_ps(dy * dy));
        let t = _mm256_mul_ps(_mm256_sqrt_ps(r2), _mm256_set1_ps(rows.inv_step));
        // `(t as usize).min(n − 2)`: truncation of the clamped value (n − 2 < 2^24 is exact).
        let tk = _mm256_min_ps(_mm256_max_ps(t, zero), _mm256_set1_ps((n - 2) as f32));
        let k = _mm256_cvttps_epi32(tk);
        let f = _mm256_min_ps(_mm256_sub_ps(t, _mm256_cvtepi32_ps(k)), _mm256_set1_ps(1.0));
        // SAFETY: 0 ≤ k ≤ n − 2, so k and k + 1 index the table.
        let l0 = _mm256_i32gather_ps::<4>(lut.as_ptr(), k);
        let l1 = _mm256_i32gather_ps::<4>(lut.as_ptr(), _mm256_add_epi32(k, _mm256_set1_epi32(1)));
        let lerp = _mm256_add_ps(l0, _mm256_mul_ps(_mm256_sub_ps(l1, l0), f));
        let u = _mm256_blendv_ps(l0, lerp, _mm256_cmp_ps::<_CMP_GT_OQ>(f, zero));
        let u = _mm256_sub_ps(u, _mm256_set1_ps(0.5));
        let covered = _mm256_cmp_ps::<_CMP_LE_OQ>(u, _mm256_set1_ps(rows.cols_end));
        // `0 > u ? 0 : u`, then `last < u ? last : u`: maxps/minps return their second
        // operand unless the first wins strictly.
        let clamped = _mm256_min_ps(_mm256_set1_ps(rows.last as f32), _mm256_max_ps(zero, u));
        let u = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), clamped, covered);
        _mm256_storeu_ps(u_out.as_mut_ptr(), u);
        _mm256_storeu_ps(t_out.as_mut_ptr(), turn8(dy, dx));
    }

    /// [`super::turn_of`] of `(dx, dy)` in each lane.
    #[target_feature(enable = "avx2")]
    unsafe fn turn8(dy: f32, dx: __m256) -> __m256 {
        let zero = _mm256_setzero_ps();
        let sign = _mm256_set1_ps(-0.0);
        let ax = _mm256_andnot_ps(sign, dx);
        let ay = _mm256_set1_ps(dy.abs());
        // `ax.min(ay)` and `ax.max(ay)`: equal operands give the same value either way.
        let (mn, mx) = (_mm256_min_ps(ax, ay), _mm256_max_ps(ax, ay));
        let a = _mm256_blendv_ps(
            zero,
            _mm256_div_ps(mn, mx),
            _mm256_cmp_ps::<_CMP_GT_OQ>(mx, zero),
        );
        let s = _mm256_mul_ps(a, a);
        let c = |k: usize| _mm256_set1_ps(ATAN[k]);
        let mut p = _mm256_add_ps(_mm256_mul_ps(c(0), s), c(1));
        p = _mm256_add_ps(_mm256_mul_ps(p, s), c(2));
        p = _mm256_add_ps(_mm256_mul_ps(p, s), c(3));
        p = _mm256_add_ps(_mm256_mul_ps(p, s), c(4));
        p = _mm256_mul_ps(_mm256_mul_ps(p, s), a);
        let r = _mm256_add_ps(p, _mm256_mul_ps(c(5), a));
        let r = _mm256_blendv_ps(
            r,
            _mm256_sub_ps(_mm256_set1_ps(std::f32::consts::FRAC_PI_2), r),
            _mm256_cmp_ps::<_CMP_GT_OQ>(ay, ax),
        );
        let r = _mm256_blendv_ps(
            r,
            _mm256_sub_ps(_mm256_set1_ps(std::f32::consts::PI), r),
            _mm256_cmp_ps::<_CMP_LT_OQ>(dx, zero),
        );
        let r = if dy < 0.0 { _mm256_xor_ps(r, sign) } else { r };
        let t = _mm256_mul_ps(r, _mm256_set1_ps(1.0 / std::f32::consts::TAU));
        _mm256_blendv_ps(
            t,
            _mm256_add_ps(t, _mm256_set1_ps(1.0)),
            _mm256_cmp_ps::<_CMP_LT_OQ>(t, zero),
        )
    }

    /// What pass 2 reads for eight pixels: each pixel's two texel pairs (`k0`, `k0 + 1` in
    /// the first column, `k1`, `k1 + 1` in the second) and its weights, and the nearest
    /// texel (for depth).
    pub(super) struct Block {
        k0: [u32; SPAN],
        k1: [u32; SPAN],
        fv0: [f32; SPAN],
        fv1: [f32; SPAN],
        fu: [f32; SPAN],
        near: [u32; SPAN],
    }

    /// Pass 2 of a row's pixels, eight at a time ([`address8`], then [`blend8`]);
    /// blocks the vector path does not take, and the last pixels, by [`PolarRows::pixel`].
    #[target_feature(enable = "avx2")]
    unsafe fn pass2(
        rows: &PolarRows<'_>,
        us: &[f32],
        turns: &[f32],
        row_c: &mut [Rgb],
        row_d: &mut [f32],
    ) {
        let w = us.len().min(row_c.len());
        let mut x = 0;
        while x + SPAN <= w {
            // SAFETY: AVX2 is present (this function's contract); the block lies in the row
            // and its indices are texels (`address8`).
            match unsafe { address8(rows, x, us, turns) } {
                Some(k) => unsafe { blend8(rows, &k, x, row_c, row_d) },
                None => {
                    for p in x..x + SPAN {
                        (row_c[p], row_d[p]) = rows.pixel(us[p], turns[p]);
                    }
                }
            }
            x += SPAN;
        }
        for p in x..w {
            (row_c[p], row_d[p]) = rows.pixel(us[p], turns[p]);
        }
    }

    /// The [`Block`] of the eight pixels from `x`, when each is a bilinear lookup of two
    /// columns (covered, and with the footprint filter no column denser than the screen);
    /// `None` for a block the scalar code must do.
    #[target_feature(enable = "avx2")]
    unsafe fn address8(rows: &PolarRows<'_>, x: usize, us: &[f32], turns: &[f32]) -> Option<Block> {
        let u = _mm256_loadu_ps(us[x..x + SPAN].as_ptr());
        let turn = _mm256_loadu_ps(turns[x..x + SPAN].as_ptr());
        if _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(
            u,
            _mm256_set1_ps(f32::INFINITY),
        )) != 0xff
        {
            return None;
        }
        // Covered coordinates lie in [0, last]: truncation is the floor.
        let i0 = _mm256_cvttps_epi32(u);
        if rows.radial.is_some()
            && _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(
                _mm256_set1_epi32(rows.dense_end as i32),
                i0,
            ))) != 0
        {
            return None;
        }
        let i1 = _mm256_min_epi32(
            _mm256_add_epi32(i0, _mm256_set1_epi32(1)),
            _mm256_set1_epi32(rows.last as i32),
        );
        let fu = _mm256_sub_ps(u, _mm256_cvtepi32_ps(i0));
        let cols = rows.columns;
        // SAFETY: 0 ≤ i0 ≤ i1 ≤ last < the number of columns, and a `Column` (repr(C)) is
        // the three 32-bit words base, rows, period.
        let words = cols.columns.as_ptr() as *const i32;
        let address = |i: __m256i| {
            let at = _mm256_add_epi32(_mm256_add_epi32(i, i), i);
            let base = _mm256_i32gather_epi32::<4>(words, at);
            let count = _mm256_i32gather_epi32::<4>(words.add(1), at);
            let period = _mm256_i32gather_ps::<4>(words.add(2) as *const f32, at);
            // `PolarColumns::read`: v = turn·period + ½, jf = min(⌊v⌋, rows).
            let v = _mm256_add_ps(_mm256_mul_ps(turn, period), _mm256_set1_ps(0.5));
            let jf = _mm256_min_epu32(_mm256_cvttps_epi32(v), count);
            let fv = _mm256_sub_ps(v, _mm256_cvtepi32_ps(jf));
            (_mm256_add_epi32(base, jf), fv)
        };
        let (k0, fv0) = address(i0);
        let (k1, fv1) = address(i1);
        // The nearest of the four texels (`blend`'s choice for depth: the nearer row of each
        // column, then the nearer column). A comparison mask is −1 where true, so
        // k + 1 + mask is k where the first row is nearer.
        let one = _mm256_set1_epi32(1);
        let half = _mm256_set1_ps(0.5);
        let nearer = |k: __m256i, f: __m256| {
            _mm256_add_epi32(
                _mm256_add_epi32(k, one),
                _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(f, half)),
            )
        };
        let near = _mm256_castps_si256(_mm256_blendv_ps(
            _mm256_castsi256_ps(nearer(k1, fv1)),
            _mm256_castsi256_ps(nearer(k0, fv0)),
            _mm256_cmp_ps::<_CMP_LT_OQ>(fu, half),
        ));
        let mut block = Block {
            k0: [0; SPAN],
            k1: [0; SPAN],
            fv0: [0.0; SPAN],
            fv1: [0.0; SPAN],
            fu: [0.0; SPAN],
            near: [0; SPAN],
        };
        _mm256_storeu_si256(block.k0.as_mut_ptr() as *mut __m256i, k0);
        _mm256_storeu_si256(block.k1.as_mut_ptr() as *mut __m256i, k1);
        _mm256_storeu_si256(block.near.as_mut_ptr() as *mut __m256i, near);
        _mm256_storeu_ps(block.fv0.as_mut_ptr(), fv0);
        _mm256_storeu_ps(block.fv1.as_mut_ptr(), fv1);
        _mm256_storeu_ps(block.fu.as_mut_ptr(), fu);
        Some(block)
    }

    /// Pass 2 of the eight pixels from `x` from their [`Block`]: each pixel's four texels
    /// blended (colour as `blend`, bit for bit), the nearest texel's depth.
    #[target_feature(enable = "avx2")]
    unsafe fn blend8(
        rows: &PolarRows<'_>,
        k: &Block,
        x: usize,
        row_c: &mut [Rgb],
        row_d: &mut [f32],
    ) {
        let cols = rows.columns;
        let tex = cols.texels.as_ptr() as *const f32;
        let out = row_c[x..x + SPAN].as_mut_ptr() as *mut f32;
        let depth = &mut row_d[x..x + SPAN];
        for l in 0..SPAN {
            let (k0, k1) = (k.k0[l] as usize, k.k1[l] as usize);
            debug_assert!(k0.max(k1) + 1 < cols.texels.len());
            // SAFETY: k = base + min(⌊v⌋, rows) ≤ base + rows, and a column's texels run
            // from base to base + rows + 1, so k and k + 1 are texels (and the nearest is
            // one of them).
            let (first, second) = unsafe {
                depth[l] = *tex.add(4 * k.near[l] as usize + 3);
                (
                    _mm256_loadu2_m128(tex.add(4 * k1), tex.add(4 * k0)),
                    _mm256_loadu2_m128(tex.add(4 * k1 + 4), tex.add(4 * k0 + 4)),
                )
            };
            // Both columns' row blends at once (colour as `blend`; lane 3 unused), then
            // across the columns.
            let f = _mm256_set_m128(_mm_set1_ps(k.fv1[l]), _mm_set1_ps(k.fv0[l]));
            let rows = _mm256_add_ps(first, _mm256_mul_ps(_mm256_sub_ps(second, first), f));
            let (a, b) = (
                _mm256_castps256_ps128(rows),
                _mm256_extractf128_ps::<1>(rows),
            );
            let c = _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(b, a), _mm_set1_ps(k.fu[l])));
            // SAFETY: pixel l's colour is floats 3l..3l + 3 of the block's 24; the 16-byte
            // store of all but the last pixel spills only into the next pixel's red, which
            // the next iteration writes.
            unsafe {
                if l + 1 < SPAN {
                    _mm_storeu_ps(out.add(3 * l), c);
                } else {
                    _mm_storel_pd(out.add(3 * l) as *mut f64, _mm_castps_pd(c));
                    _mm_store_ss(out.add(3 * l + 2), _mm_movehl_ps(c, c));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use fovea_core::display::DisplayProfile;
    use fovea_core::mapping::{build, MappingConfig, Method};
    use fovea_core::units::Degrees;
    use fovea_core::Image;

    use super::*;
    use crate::inverse_map::{reconstruct_into_with_kernel, ReconstructFilter, SampleBuffers};

    /// The frame of `buffers` through `mapping` with `kernel`.
    fn frame(
        mapping: &dyn fovea_core::mapping::FoveationMapping,
        display: &DisplayProfile,
        buffers: &SampleBuffers,
        filter: ReconstructFilter,
        kernel: PolarKernel,
    ) -> (Image<Rgb>, Image<f32>) {
        let (w, h) = (display.width_px, display.height_px);
        let mut color = Image::new(w, h, [-1.0f32; 3]).unwrap();
        let mut depth = Image::new(w, h, -1.0f32).unwrap();
        let mut buffers = buffers.clone();
        reconstruct_into_with_kernel(
            mapping,
            display,
            &mut buffers,
            &mut color,
            &mut depth,
            filter,
            kernel,
        )
        .unwrap();
        (color, depth)
    }

    /// The largest colour difference between two frames, and how many depths differ.
    fn differences(a: &(Image<Rgb>, Image<f32>), b: &(Image<Rgb>, Image<f32>)) -> (f32, usize) {
        let worst =
            a.0.data()
                .iter()
                .zip(b.0.data())
                .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).abs()))
                .fold(0.0f32, f32::max);
        let depths =
            a.1.data()
                .iter()
                .zip(b.1.data())
                .filter(|(p, q)| p.to_bits() != q.to_bits())
                .count();
        (worst, depths)
    }

    /// The vector kernel against the scalar one on random texels (every texel independent:
    /// any misplaced read shows): every polar method, both filters, gazes at the centre, off
    /// centre and in a corner, on screens whose width is not a multiple of the vector's
    /// eight pixels: colour within 1/255 everywhere (the CPU issue's bar; the kernels compute
    /// the same operations, so the difference is expected to be zero) and the same depths.
    #[test]
    fn vector_and_scalar_kernels_agree_on_random_texels() {
        if !PolarKernel::Avx2.available() {
            println!("skipped: this processor has no AVX2, only the scalar kernel runs");
            assert!(PolarKernel::Avx2.check().is_err());
            return;
        }
        let odd = DisplayProfile::with_vertical_fov("odd", 1003, 997, Degrees(100.0)).unwrap();
        let vive = DisplayProfile::preset("vive-pro-eye").unwrap();
        let mut cases = 0;
        for (d, gazes) in [
            (&vive, [(0.5, 0.5), (0.2, 0.7), (0.97, 0.02)]),
            (&odd, [(0.5, 0.5), (0.63, 0.31), (0.01, 0.99)]),
        ] {
            for method in [Method::Vafr, Method::Kfr, Method::Lafr, Method::VisualPolar] {
                for (gx, gy) in gazes {
                    let gaze = d
                        .gaze(gx * d.width_px as f64, gy * d.height_px as f64)
                        .unwrap();
                    let m = build(method, d, gaze, &MappingConfig::default()).unwrap();
                    let bufs = SampleBuffers::random(m.as_ref(), cases).unwrap();
                    for filter in [ReconstructFilter::Footprint, ReconstructFilter::Bilinear] {
                        let scalar = frame(m.as_ref(), d, &bufs, filter, PolarKernel::Scalar);
                        let vector = frame(m.as_ref(), d, &bufs, filter, PolarKernel::Avx2);
                        let (worst, depths) = differences(&scalar, &vector);
                        assert!(
                            worst <= 1.0 / 255.0 && depths == 0,
                            "{method} on {} at ({gx}, {gy}), {filter:?}: colour {worst}, \
                             {depths} depths differ",
                            d.name
                        );
                        // Both wrote every pixel.
                        assert!(vector.1.data().iter().all(|&z| z >= 0.0));
                        cases += 1;
                    }
                }
            }
        }
        println!("{cases} cases: the vector and scalar kernels agree");
    }

    /// The exact coordinates of pass 1 eight at a time equal the one-pixel ones bit for bit,
    /// across the angular seam, the pole and past the buffer's edge.
    #[test]
    fn exact_coordinates_eight_at_a_time_equal_one_at_a_time() {
        if !PolarKernel::Avx2.available() {
            println!("skipped: this processor has no AVX2");
            return;
        }
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let gaze = d.gaze(1100.0, 1200.0).unwrap();
        let m = build(Method::Vafr, &d, gaze, &MappingConfig::default()).unwrap();
        let bufs = SampleBuffers::random(m.as_ref(), 3).unwrap();
        let tables = crate::inverse_map::PolarTables::new(
            m.as_ref(),
            &d,
            &bufs,
            ReconstructFilter::Bilinear,
        )
        .unwrap();
        let max_period = m
            .polar_layout()
            .unwrap()
            .period
            .iter()
            .fold(1.0f64, |a, &b| a.max(b));
        let points = span_points(d.width_px as usize);
        let rows = PolarRows {
            lut: &tables.lut,
            cx: tables.centre.x_px as f32,
            cy: tables.centre.y_px as f32,
            inv_step: (1.0 / tables.lut_step_px) as f32,
            cols_end: (tables.last + 1) as f32,
            last: tables.last,
            turn_tolerance: COORD_TOLERANCE_TEXELS / max_period as f32,
            columns: &tables.columns,
            radial: None,
            dense_end: 0,
            points: &points,
        };
        let mut checked = 0;
        for y in [0usize, 600, 1199, 1200, 1201, 1599] {
            let dy = y as f32 + 0.5 - rows.cy;
            for x0 in (0..1440).step_by(8) {
                let xs: [f32; SPAN] = std::array::from_fn(|l| (x0 + l) as f32);
                let (mut u, mut t) = ([0.0f32; SPAN], [0.0f32; SPAN]);
                // SAFETY: AVX2 is present (checked above).
                unsafe { avx2::exact8(&rows, dy, &xs, &mut u, &mut t) };
                for l in 0..SPAN {
                    let (su, st) = rows.exact(dy, xs[l]);
                    assert_eq!(
                        (u[l].to_bits(), t[l].to_bits()),
                        (su.to_bits(), st.to_bits()),
                        "pixel ({}, {y}): vector ({}, {}), scalar ({su}, {st})",
                        xs[l],
                        u[l],
                        t[l]
                    );
                    checked += 1;
                }
            }
        }
        println!("{checked} pixels");
    }
}
