//! Edge-avoiding à-trous wavelet denoiser in sample space, after Schied et al. 2017,
//! "Spatiotemporal Variance-Guided Filtering: Real-Time Reconstruction for Path-Traced Global
//! Illumination" (SVGF, HPG 2017, Sec. 4.2–4.4), which builds on Dammertz et al. 2010,
//! "Edge-Avoiding À-Trous Wavelet Transform for Fast Global Illumination Filtering".
//!
//! **Input.** One sample buffer (a layer): colour, view depth, and per sample the surface's
//! albedo and shading normal (the guides) and, where the shading knows it, the part of the
//! colour it estimated by Monte Carlo (the *noisy* part: the occluded environment's in direct
//! shading; the lights' shadow rays are exact). Only that part is filtered — as SVGF filters
//! the direct and indirect components apart — and where it is unknown (NaN) the whole colour
//! is. The filtered part is demodulated by the albedo before filtering
//! (`light = noisy / max(albedo, ALBEDO_FLOOR)` per channel) and remodulated after, so texture
//! detail is never blurred: only the lighting is (SVGF Sec. 4.1); the exact part is added back
//! untouched.
//!
//! **Passes.**
//! 1. Demodulate; mark each texel a *source* (a surface sample with finite colour, read by its
//!    neighbours), a *receiver only* (a surface sample whose colour is NaN or infinite: it is
//!    filtered from its neighbours but never read, so a NaN cannot spread) or *passive* (sky,
//!    unshaded, prefilled without guides: left exactly as it is and never read).
//! 2. Depth gradient per axis (the smaller one-sided difference, so an edge texel keeps its own
//!    surface's slope), a per-sample luminance variance from the 3×3 neighbours on the same
//!    surface (normal weight above ½, depth within the gradient's prediction: SVGF's spatial
//!    estimate, Sec. 4.2, used where no temporal moments exist), and firefly clamping: a
//!    source's light is scaled down so its luminance is at most `μ + k·σ` of those neighbours
//!    (centre left out).
//! 3. `iterations` à-trous passes at step `2^i` (Eq. 1) with SVGF's 5×5 B3-spline kernel
//!    `h = [1, 4, 6, 4, 1]/16` or — the default, 2.2× cheaper at nearly the same error (docs/
//!    denoise.md) — the 3×3 linear B spline `[1, 2, 1]/4`: `c' = Σ h(q) w(p,q) c(q) / Σ h(q) w(p,q)`, with the edge-stopping weight
//!    (Eq. 3–5) `w = exp(−|z_p − z_q| / (σ_z |∇z_p · (p − q)| + ε_z) − |l_p − l_q| /
//!    (σ_l √g₃ₓ₃(Var(l_p)) + ε)) · max(0, n_p·n_q)^σ_n` and the variance filtered alongside
//!    with the squared weights (Eq. 2). For speed the normal term is evaluated as
//!    `e^(−σ_n (1 − n_p·n_q))` (equal to first order at `n_p = n_q`, zero for `n_p·n_q ≤ 0`),
//!    folded into one exponential with the others, which is computed by a polynomial
//!    (relative error below 3·10⁻⁴).
//! 4. Remodulate.
//!
//! **Topology.** Taps land through [`neighbour`]: clamped-away (skipped) past a screen-aligned
//! buffer's border; in a polar buffer (column = ring, row = angle) rows wrap around the angle
//! axis, a column step keeps the angle, and a step inside the innermost ring continues across
//! the fovea in the column mirrored through the centre at the angle rotated by π (column
//! `−1 − k` is column `k` half a turn on), as Koskela et al. (EGSR 2019) filter in visual-polar
//! space.
//!
//! **Footprint.** The kernel is fixed in texels. In a polar buffer the texels are spaced by the
//! acuity model (VaFR's rings follow the MAR), so the footprint in visual angle grows with
//! eccentricity exactly as the resolvable detail does; on the screen (full resolution, Weier's
//! sparse grid) a texel is a pixel. Only the demodulated lighting is smoothed, across texels
//! the edge-stopping weights call the same surface at a similar luminance, and the texture
//! (albedo) is put back per sample, so no detail the samples resolve is lost.

use rayon::prelude::*;
use serde::Serialize;

use fovea_core::{FoveaError, Image, Result};

use crate::grid::Grid;
use crate::{luma, Rgb};

/// The most à-trous iterations (step `2^(n−1)`; 6 reach 2·63 texels).
pub const MAX_ITERATIONS: u32 = 6;

/// Albedo below this (per channel) demodulates as this: a black albedo would turn specular
/// light into infinities.
pub const ALBEDO_FLOOR: f32 = 0.02;

/// Bytes per sample the denoiser holds: the guides (albedo and normal, 12 bytes each) and the
/// working buffers (normal and depth 16, depth gradient 8, role 1, same-surface mask 1, two
/// light-and-variance buffers 16 each).
pub const BYTES_PER_SAMPLE: u64 = 12 + 12 + 12 + 16 + 8 + 1 + 1 + 16 + 16;

/// B3-spline taps `[1, 4, 6, 4, 1]/16` at offsets −2..2.
const H5: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];
/// Linear B-spline taps `[1, 2, 1]/4` at offsets −1..1.
const H3: [f32; 3] = [0.25, 0.5, 0.25];

/// The à-trous kernel of each iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kernel {
    /// SVGF's and Dammertz et al.'s 5×5 B3 spline `[1 4 6 4 1]/16` (25 taps).
    B3Spline5x5,
    /// The 3×3 linear B spline `[1 2 1]/4` (9 taps, as A-SVGF's implementation; Schied et
    /// al. 2018): about 2.5× cheaper per iteration; one more iteration reaches as far.
    Linear3x3,
}

impl Kernel {
    /// The 1-D taps, centre in the middle.
    fn taps(self) -> &'static [f32] {
        match self {
            Kernel::B3Spline5x5 => &H5,
            Kernel::Linear3x3 => &H3,
        }
    }
}

/// Parameters of the filter (SVGF's defaults where it gives them).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DenoiseParams {
    /// À-trous iterations, 1 to [`MAX_ITERATIONS`] (SVGF: 5).
    pub iterations: u32,
    /// The kernel of each iteration.
    pub kernel: Kernel,
    /// σ_l: luminance tolerance in standard deviations of the local noise (SVGF: 4).
    pub sigma_luminance: f32,
    /// σ_n: exponent of the normal weight `max(0, n_p·n_q)^σ_n` (SVGF: 128).
    pub normal_power: u32,
    /// σ_z: depth tolerance in multiples of the linear prediction from the gradient (SVGF: 1).
    pub sigma_depth: f32,
    /// Firefly clamp: a sample's luminance is limited to its neighbours' `μ + k·σ` (`None`:
    /// no clamping).
    pub firefly_k: Option<f32>,
}

impl Default for DenoiseParams {
    fn default() -> Self {
        Self {
            iterations: 4,
            kernel: Kernel::Linear3x3,
            sigma_luminance: 4.0,
            normal_power: 128,
            sigma_depth: 1.0,
            firefly_k: Some(3.0),
        }
    }
}

impl DenoiseParams {
    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_ITERATIONS).contains(&self.iterations) {
            return Err(FoveaError::invalid(
                "denoise iterations",
                self.iterations,
                format!("1 to {MAX_ITERATIONS}"),
            ));
        }
        if !(self.sigma_luminance > 0.0 && self.sigma_luminance.is_finite()) {
            return Err(FoveaError::invalid(
                "denoise sigma-luminance",
                self.sigma_luminance,
                "a positive number of standard deviations, e.g. 4",
            ));
        }
        if !(1..=1024).contains(&self.normal_power) {
            return Err(FoveaError::invalid(
                "denoise normal-power",
                self.normal_power,
                "an exponent 1 to 1024, e.g. 128",
            ));
        }
        if !(self.sigma_depth > 0.0 && self.sigma_depth.is_finite()) {
            return Err(FoveaError::invalid(
                "denoise sigma-depth",
                self.sigma_depth,
                "a positive factor, e.g. 1",
            ));
        }
        if let Some(k) = self.firefly_k {
            if !(k > 0.0 && k.is_finite()) {
                return Err(FoveaError::invalid(
                    "denoise firefly-k",
                    k,
                    "a positive number of standard deviations, e.g. 3",
                ));
            }
        }
        Ok(())
    }
}

/// The guides of a frame's sample buffers, one image per layer, the buffers' sizes: the
/// albedo that demodulates the light, the shading normal (zero where a texel has no surface
/// record: it is then left as it is) and the colour's Monte Carlo part (NaN where unknown:
/// the whole colour is filtered).
#[derive(Clone, Debug, Default)]
pub struct DenoiseGuides {
    /// Albedo (base colour), linear RGB.
    pub albedo: Vec<Image<Rgb>>,
    /// Unit shading normal, world space; zero: no record.
    pub normal: Vec<Image<[f32; 3]>>,
    /// The part of the colour estimated by Monte Carlo, linear RGB; NaN: unknown.
    pub noisy: Vec<Image<Rgb>>,
    /// Per sample, the variance of the (accumulated) Monte Carlo part's demodulated
    /// luminance from its temporal moments (SVGF Sec. 4.2), where temporal accumulation
    /// kept enough frames; NaN, or no image for the layer: unknown (the filter estimates it
    /// spatially). Written by the temporal accumulation, not by [`fit`](Self::fit).
    pub variance: Vec<Image<f32>>,
}

impl DenoiseGuides {
    /// Guides of the sizes `sizes` (width, height per layer), reusing these images where the
    /// sizes already match. Contents are unspecified until written.
    pub fn fit(&mut self, sizes: &[(u32, u32)]) -> Result<()> {
        let fits = |imgs: &[Image<Rgb>]| {
            imgs.len() == sizes.len()
                && sizes
                    .iter()
                    .zip(imgs)
                    .all(|(&s, i)| (i.width(), i.height()) == s)
        };
        if !(fits(&self.albedo) && fits(&self.normal) && fits(&self.noisy)) {
            self.albedo = Vec::with_capacity(sizes.len());
            self.normal = Vec::with_capacity(sizes.len());
            self.noisy = Vec::with_capacity(sizes.len());
            for &(w, h) in sizes {
                self.albedo.push(Image::new(w, h, [0.0; 3])?);
                self.normal.push(Image::new(w, h, [0.0; 3])?);
                self.noisy.push(Image::new(w, h, [f32::NAN; 3])?);
            }
        }
        Ok(())
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        let n: usize = self.albedo.iter().map(|i| i.data().len()).sum();
        let v: usize = self.variance.iter().map(|i| i.data().len()).sum();
        (n * 3 * std::mem::size_of::<Rgb>() + v * 4) as u64
    }
}

/// Working buffers of the filter, kept from frame to frame (no allocation once sized).
#[derive(Clone, Debug, Default)]
pub struct DenoiseScratch {
    /// Normal and depth per texel.
    geom: Vec<[f32; 4]>,
    /// Depth gradient per texel (|∂z/∂x|, |∂z/∂y| per texel step).
    grad: Vec<[f32; 2]>,
    /// 0 passive, 1 receiver only, 2 source.
    role: Vec<u8>,
    /// Light (RGB) and variance, ping.
    a: Vec<[f32; 4]>,
    /// Light (RGB) and variance, pong.
    b: Vec<[f32; 4]>,
    /// Per source, which of its 3×3 neighbours the first iteration's variance prefilter
    /// reads (one bit each, [`cell_bit`]), found by the set-up pass.
    same: Vec<u8>,
    /// The receivers' texel indices and shading normals, in texel order (`geom` holds a
    /// zero normal for every texel that is not a source, so that no neighbour reads it).
    receivers: Vec<(u32, [f32; 3])>,
}

impl DenoiseScratch {
    fn fit(&mut self, n: usize) {
        self.geom.resize(n, [0.0; 4]);
        self.grad.resize(n, [0.0; 2]);
        self.role.resize(n, 0);
        self.same.resize(n, 0);
        self.a.resize(n, [0.0; 4]);
        self.b.resize(n, [0.0; 4]);
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        (self.geom.capacity() * 16
            + self.grad.capacity() * 8
            + self.role.capacity()
            + self.same.capacity()
            + (self.a.capacity() + self.b.capacity()) * 16
            + self.receivers.capacity() * 16) as u64
    }
}

/// What [`denoise`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DenoiseStats {
    /// Texels filtered (surface samples).
    pub filtered: u64,
    /// Sources whose luminance the firefly clamp lowered.
    pub clamped: u64,
}

impl std::ops::AddAssign for DenoiseStats {
    fn add_assign(&mut self, o: Self) {
        self.filtered += o.filtered;
        self.clamped += o.clamped;
    }
}

#[cfg(test)]
std::thread_local! {
    /// Test only: the first iteration tests the neighbours for its variance prefilter itself
    /// instead of reading the set-up pass's masks (the two must agree exactly).
    static PREFILTER_TESTS_ITSELF: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

const PASSIVE: u8 = 0;
const RECEIVER: u8 = 1;
const SOURCE: u8 = 2;

/// The texel `di` columns then `dj` rows from `(i, j)` in `grid`, or `None` where that leaves
/// the buffer. Rect: no clamping (a tap past the border is skipped). Polar: a column step keeps
/// the angle (`j' = (j + ½)·period[i']/period[i] − ½`, rounded), a step to column `c < 0`
/// lands in column `−1 − c` at the angle rotated by half a turn (across the fovea), rows wrap
/// modulo the column's rows, columns past the last or empty ones are outside.
#[inline]
pub fn neighbour(grid: &Grid, i: u32, j: u32, di: i32, dj: i32) -> Option<(u32, u32)> {
    let (c, row, rows) = column_at(grid, i, j, turn_of(grid, i, j), di)?;
    row_of(grid, row, rows, dj).map(|r| (c, r))
}

/// The column `di` columns from texel `(i, j)` with the row there that keeps its angle and
/// that column's row count, `turn = (j + ½)/period[i]` (the texel's angle in turns, given:
/// one lookup per tap column without a division): on a rect grid the same row, `None` past
/// the border; on a polar grid a step inside the innermost ring continues in column
/// `−1 − k`, half a turn on.
#[inline]
fn column_at(grid: &Grid, i: u32, j: u32, turn: f64, di: i32) -> Option<(u32, i64, u32)> {
    match grid {
        Grid::Rect { width, height } => {
            let c = i as i64 + di as i64;
            (0..*width as i64)
                .contains(&c)
                .then_some((c as u32, j as i64, *height))
        }
        Grid::Polar { rows, period } => {
            let mut c = i as i64 + di as i64;
            let mut half = 0.0;
            if c < 0 {
                c = -1 - c;
                half = 0.5;
            }
            let n = *rows.get(c as usize)?;
            if n == 0 {
                return None;
            }
            let row = if c == i as i64 && half == 0.0 {
                j as i64
            } else {
                let t = turn + half;
                let t = t - t.trunc();
                // t·period − ½ ≥ −½: truncating x + ½ rounds (without libm's `round`).
                (t * period[c as usize]) as i64
            };
            Some((c as u32, row, n))
        }
    }
}

/// The texel's angle in turns, `(j + ½)/period[i]` (0 on a rect grid, and past the grid's
/// columns: the eight-lane passes ask for every lane of a block, whose lanes past the last
/// column with a period — a padded buffer's — are passive and never read).
#[inline]
fn turn_of(grid: &Grid, i: u32, j: u32) -> f64 {
    match grid {
        Grid::Rect { .. } => 0.0,
        Grid::Polar { period, .. } => period
            .get(i as usize)
            .map_or(0.0, |p| (j as f64 + 0.5) / p.max(1e-12)),
    }
}

/// The angles in turns of the texels `(i0 + t, j)` of a block ([`turn_of`]; lanes past the
/// row's end `n` take the last texel's) and, for [`column_at`]'s step to another column at
/// half 0, their fractions `turn − trunc(turn)`. Without branches where the block's columns
/// all have periods (SIMD divisions and truncations in the AVX2 build).
#[inline(always)]
fn block_turns(grid: &Grid, i0: usize, n: usize, j: u32) -> ([f64; LANES], [f64; LANES]) {
    let turn: [f64; LANES] = match grid {
        Grid::Polar { period, .. } if n == LANES && i0 + LANES <= period.len() => {
            let p = &period[i0..i0 + LANES];
            std::array::from_fn(|t| (j as f64 + 0.5) / p[t].max(1e-12))
        }
        _ => std::array::from_fn(|t| turn_of(grid, (i0 + t.min(n - 1)) as u32, j)),
    };
    let frac = std::array::from_fn(|t| turn[t] - turn[t].trunc());
    (turn, frac)
}

/// `e^−x` for `x ≥ 0` (relative error below 3·10⁻⁴; 0 past `x` = 87): `2^−x·log₂e` split
/// into an integer power (the exponent bits) and a degree-5 polynomial of the fraction.
/// Branch-free, so that a loop over taps vectorizes.
#[inline(always)]
fn exp_neg(x: f32) -> f32 {
    // `max` returns −126 for NaN too, so `t` is finite and within [−126, 0] for x ≥ 0 (and at
    // most 2^24 otherwise): the conversion below is exact truncation.
    #[allow(clippy::manual_clamp)] // `clamp` keeps a NaN; `max` then `min` does not.
    let t = (-x * std::f32::consts::LOG2_E).max(-126.0).min(126.0);
    // SAFETY: `t` is finite and within i32's range (clamped above).
    let i: i32 = unsafe { t.to_int_unchecked() }; // toward zero: the fraction lies in (−1, 0]
    let f = t - i as f32;
    let p = 1.0
        + f * (std::f32::consts::LN_2
            + f * (0.240_226_5 + f * (0.055_504_1 + f * (0.009_618_1 + f * 0.001_333_4))));
    f32::from_bits(((i + 127) as u32) << 23) * p
}

/// Row `row + dj` of a column of `rows` rows: wrapped (polar) or `None` outside (rect).
#[inline]
fn row_of(grid: &Grid, row: i64, rows: u32, dj: i32) -> Option<u32> {
    let r = row + dj as i64;
    if (0..rows as i64).contains(&r) {
        return Some(r as u32);
    }
    match grid {
        Grid::Rect { .. } => None,
        Grid::Polar { .. } => Some(r.rem_euclid(rows.max(1) as i64) as u32),
    }
}

/// `colour / max(albedo, ALBEDO_FLOOR)` per channel.
#[inline]
pub fn demodulate(c: Rgb, albedo: Rgb) -> Rgb {
    std::array::from_fn(|k| c[k] / albedo[k].max(ALBEDO_FLOOR))
}

/// `light · max(albedo, ALBEDO_FLOOR)` per channel (the inverse of [`demodulate`]).
#[inline]
pub fn remodulate(l: Rgb, albedo: Rgb) -> Rgb {
    std::array::from_fn(|k| l[k] * albedo[k].max(ALBEDO_FLOOR))
}

/// A texel's Monte Carlo part: `m` (its `noisy` value) where given and finite, else its whole
/// colour `c`.
#[inline]
fn noisy_part(m: Option<Rgb>, c: Rgb) -> Rgb {
    match m {
        Some(m) if m.iter().all(|v| v.is_finite()) => m,
        _ => c,
    }
}

/// Denoises `color` (one sample buffer, laid out on `grid`: image x = column, y = row) in
/// place, guided by `depth` (view depth, ∞ for misses), `albedo` and `normal` (zero: no
/// surface record), all of `color`'s size. With `noisy` (same size) only each texel's Monte
/// Carlo part is filtered, the rest kept exactly; a NaN there, or no `noisy`, filters the
/// texel's whole colour. Sky, unshaded and unguided texels are left exactly as they are; NaN
/// or infinite colours are never read by their neighbours.
#[allow(clippy::too_many_arguments)]
pub fn denoise(
    color: &mut Image<Rgb>,
    depth: &Image<f32>,
    albedo: &Image<Rgb>,
    normal: &Image<[f32; 3]>,
    noisy: Option<&Image<Rgb>>,
    grid: &Grid,
    params: &DenoiseParams,
    scratch: &mut DenoiseScratch,
) -> Result<DenoiseStats> {
    denoise_with_variance(
        color, depth, albedo, normal, noisy, None, grid, params, scratch,
    )
}

/// [`denoise`] with a per-sample luminance variance `variance` (same size; the variance of
/// the demodulated Monte Carlo part's luminance, e.g. from temporal moments,
/// [`DenoiseGuides::variance`]) used in the luminance edge-stopping weight instead of the
/// spatial 3×3 estimate wherever it is finite and non-negative (SVGF Sec. 4.2: temporal
/// where the history is long enough, spatial elsewhere). The firefly clamp stays spatial.
#[allow(clippy::too_many_arguments)]
pub fn denoise_with_variance(
    color: &mut Image<Rgb>,
    depth: &Image<f32>,
    albedo: &Image<Rgb>,
    normal: &Image<[f32; 3]>,
    noisy: Option<&Image<Rgb>>,
    variance: Option<&Image<f32>>,
    grid: &Grid,
    params: &DenoiseParams,
    scratch: &mut DenoiseScratch,
) -> Result<DenoiseStats> {
    params.validate()?;
    let (w, h) = (color.width(), color.height());
    for (name, (iw, ih)) in [
        ("denoise depth", (depth.width(), depth.height())),
        ("denoise albedo", (albedo.width(), albedo.height())),
        ("denoise normal", (normal.width(), normal.height())),
        (
            "denoise noisy part",
            noisy.map_or((w, h), |n| (n.width(), n.height())),
        ),
        (
            "denoise variance",
            variance.map_or((w, h), |v| (v.width(), v.height())),
        ),
    ] {
        if (iw, ih) != (w, h) {
            return Err(FoveaError::invalid(
                name,
                format!("{iw}x{ih}"),
                format!("the colour buffer's size {w}x{h}"),
            ));
        }
    }
    let wu = w as usize;
    let n = wu * h as usize;
    if n == 0 {
        return Ok(DenoiseStats::default());
    }
    // Texel indices are computed in 32 bits.
    if n > u32::MAX as usize {
        return Err(FoveaError::invalid(
            "denoise buffer",
            format!("{w}x{h}"),
            "at most 2^32 − 1 texels",
        ));
    }
    // Rows are computed in 32 bits, with room for a tap's step.
    if h > MAX_ROWS {
        return Err(FoveaError::invalid(
            "denoise buffer",
            format!("{w}x{h}"),
            format!("at most {MAX_ROWS} rows"),
        ));
    }
    // The grid lies within the buffer, so that every tap lands in it (`Column`'s invariant,
    // on which the passes' unchecked reads rely).
    match grid {
        Grid::Polar { rows, period } => {
            if rows.len() > wu || period.len() != rows.len() || rows.iter().any(|&r| r > h) {
                return Err(FoveaError::invalid(
                    "denoise polar grid",
                    format!(
                        "{} columns of at most {} rows",
                        rows.len(),
                        rows.iter().max().unwrap_or(&0)
                    ),
                    format!("one period per column, at most {w} columns of at most {h} rows"),
                ));
            }
        }
        Grid::Rect { width, height } => {
            if *width > w || *height > h {
                return Err(FoveaError::invalid(
                    "denoise grid",
                    format!("{width}x{height}"),
                    format!("at most the colour buffer's size {w}x{h}"),
                ));
            }
        }
    }
    scratch.fit(n);
    let DenoiseScratch {
        geom,
        grad,
        role,
        a,
        b,
        same,
        receivers,
    } = scratch;

    // 1. Roles, geometry and demodulated light.
    geom.par_chunks_mut(wu)
        .zip(role.par_chunks_mut(wu))
        .zip(a.par_chunks_mut(wu))
        .enumerate()
        .for_each(|(j, ((g, r), l))| {
            let j = j as u32;
            // The row's slices, their lengths checked once.
            let row = j as usize * wu..(j as usize + 1) * wu;
            let (depth, normal) = (&depth.data()[row.clone()], &normal.data()[row.clone()]);
            let (color, albedo) = (&color.data()[row.clone()], &albedo.data()[row.clone()]);
            let noisy = noisy.map(|m| &m.data()[row]);
            let (g, r, l) = (&mut g[..wu], &mut r[..wu], &mut l[..wu]);
            // The columns with a texel in row `j`.
            let valid = match grid {
                Grid::Rect { width, height } => (j < *height).then_some(*width as usize),
                Grid::Polar { .. } => None,
            };
            for i in 0..wu {
                let z = depth[i];
                let nv = normal[i];
                let c = color[i];
                let al = albedo[i];
                let valid = match valid {
                    Some(w) => i < w,
                    None => grid.valid(i as u32, j),
                };
                let surface =
                    valid && z.is_finite() && nv.iter().all(|v| v.is_finite()) && nv != [0.0; 3];
                r[i] = if !surface {
                    PASSIVE
                } else if c.iter().chain(&al).all(|v| v.is_finite()) {
                    SOURCE
                } else {
                    RECEIVER
                };
                // A texel that is not a source has no normal here: every weight to it, and
                // the same-surface test, is then zero (`n_p·0 = 0`), with no test of its role.
                // A passive texel's depth is NaN: the set-up pass's gradient skips it without
                // reading its role (every weight to it is zero by its normal already).
                g[i] = match r[i] {
                    SOURCE => [nv[0], nv[1], nv[2], z],
                    RECEIVER => [0.0, 0.0, 0.0, z],
                    _ => [0.0, 0.0, 0.0, f32::NAN],
                };
                let lt = if r[i] == SOURCE {
                    demodulate(noisy_part(noisy.map(|m| m[i]), c), al)
                } else {
                    [0.0; 3]
                };
                l[i] = [lt[0], lt[1], lt[2], 0.0];
            }
        });

    // The receivers' own normals (rare: a NaN or infinite colour), for their own weights.
    receivers.clear();
    receivers.par_extend(
        role.par_iter()
            .enumerate()
            .filter(|&(_, &r)| r == RECEIVER)
            .map(|(k, _)| (k as u32, normal.data()[k])),
    );
    let receivers = &*receivers;

    // 2. Depth gradient, spatial variance and firefly clamp; with them, per row, the texels
    // filtered and whether any receiver or any Monte Carlo light is there (the idle test).
    let (geom, role) = (&*geom, &*role);
    let setup = Setup {
        grid,
        geom,
        role,
        light0: &*a,
        variance,
        wu,
        params,
    };
    let (clamped, filtered, busy) = grad
        .par_chunks_mut(wu)
        .zip(b.par_chunks_mut(wu))
        .zip(same.par_chunks_mut(wu))
        .enumerate()
        .map(|(j, ((gr, out), same))| setup.row(j as u32, gr, out, same))
        .reduce(|| (0, 0, false), |x, y| (x.0 + y.0, x.1 + y.1, x.2 || y.2));
    let stats = DenoiseStats { filtered, clamped };
    // No Monte Carlo light anywhere and nothing to refill (noise-free shading): filtering
    // zeros gives zeros and the exact part comes back as it was, so skip the passes.
    if !busy {
        return Ok(stats);
    }

    // 3. À-trous iterations, b → a → b …, all but the last.
    let grad = &*grad;
    #[cfg(test)]
    let tests_itself = PREFILTER_TESTS_ITSELF.with(|t| t.get());
    #[cfg(not(test))]
    let tests_itself = false;
    let mask = (!tests_itself).then_some(same.as_slice());
    let (mut src, mut dst) = (&mut *b, &mut *a);
    for it in 0..params.iterations - 1 {
        let pass = Pass {
            grid,
            geom,
            grad,
            role,
            src: &*src,
            same: mask,
            receivers,
            wu,
            step: 1i32 << it,
            params,
        };
        dst.par_chunks_mut(wu)
            .enumerate()
            .for_each(|(j, out)| pass.row(j as u32, out));
        std::mem::swap(&mut src, &mut dst);
    }

    // 4. The last iteration, remodulated row by row as it is filtered (its light goes through
    // a row buffer instead of a whole working buffer read back in another pass).
    let last = Pass {
        grid,
        geom,
        grad,
        role,
        src: &*src,
        same: mask,
        receivers,
        wu,
        step: 1i32 << (params.iterations - 1),
        params,
    };
    color
        .data_mut()
        .par_chunks_mut(wu)
        .zip(albedo.data().par_chunks(wu))
        .enumerate()
        .for_each_init(
            || vec![[0.0f32; 4]; wu],
            |light, (j, (c, al))| {
                last.row(j as u32, light);
                // The row's slices, their lengths checked once.
                let roles = &role[j * wu..(j + 1) * wu];
                let noisy = noisy.map(|m| &m.data()[j * wu..(j + 1) * wu]);
                let (light, al) = (&light[..wu], &al[..wu]);
                for i in 0..wu {
                    if roles[i] == PASSIVE {
                        continue;
                    }
                    let l = [light[i][0], light[i][1], light[i][2]];
                    let lit = remodulate(l, al[i]);
                    // The exact part kept (a receiver's colour is not finite: all of it
                    // refilled).
                    let out: Rgb = if roles[i] == SOURCE {
                        let m = noisy_part(noisy.map(|m| m[i]), c[i]);
                        std::array::from_fn(|ch| c[i][ch] - m[ch] + lit[ch])
                    } else {
                        lit
                    };
                    if out.iter().all(|v| v.is_finite()) {
                        c[i] = out;
                    }
                }
            },
        );
    Ok(stats)
}

/// What the set-up pass (depth gradient, spatial moments, firefly clamp) reads.
struct Setup<'a> {
    grid: &'a Grid,
    geom: &'a [[f32; 4]],
    role: &'a [u8],
    /// The demodulated light of pass 1.
    light0: &'a [[f32; 4]],
    variance: Option<&'a Image<f32>>,
    wu: usize,
    params: &'a DenoiseParams,
}

impl Setup<'_> {
    /// Row `j` of the set-up pass: the depth gradient of every texel not passive into `gr`,
    /// the (clamped) light and its variance into `out` (every texel's light as it is
    /// elsewhere), each source's same-surface mask for the variance's prefilter into `same`;
    /// returns the texels clamped and filtered and whether any receiver or any
    /// Monte Carlo light is there. In the AVX2 build where the CPU has it.
    #[inline]
    fn row(
        &self,
        j: u32,
        gr: &mut [[f32; 2]],
        out: &mut [[f32; 4]],
        same: &mut [u8],
    ) -> (u64, u64, bool) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked above); the function is safe Rust otherwise.
            return unsafe { setup_row_avx2(self, j, gr, out, same) };
        }
        setup_row(self, j, gr, out, same)
    }
}

/// [`setup_row`] compiled for AVX2 (no FMA: the SSE2 build's results bit for bit).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn setup_row_avx2(
    s: &Setup,
    j: u32,
    gr: &mut [[f32; 2]],
    out: &mut [[f32; 4]],
    same: &mut [u8],
) -> (u64, u64, bool) {
    setup_row(s, j, gr, out, same)
}

/// The bit of the 3×3 neighbour `[xi][yi]` (offset + 1; not the centre) in the same-surface
/// mask.
#[inline(always)]
fn cell_bit(xi: usize, yi: usize) -> u32 {
    let c = (xi * 3 + yi) as u32;
    c - (c > 4) as u32
}

/// Row `j` of the set-up pass, eight texels at a time, each lane's sums in the scalar
/// filter's order (the neighbours column by column): the scalar filter's result bit for bit.
#[inline(always)]
fn setup_row(
    s: &Setup,
    j: u32,
    gr: &mut [[f32; 2]],
    out: &mut [[f32; 4]],
    same: &mut [u8],
) -> (u64, u64, bool) {
    let Setup {
        grid,
        geom,
        role,
        light0,
        variance,
        wu,
        params,
    } = *s;
    let sigma_z = params.sigma_depth;
    // dot^σ_n > ½ ⇔ 1 − dot < ln 2 / σ_n (to first order): "the same surface".
    let same_normal = std::f32::consts::LN_2 / params.normal_power as f32;
    let base_row = j as usize * wu;
    out.copy_from_slice(&light0[base_row..base_row + wu]);
    let (mut clamped, mut filtered, mut busy) = (0u64, 0u64, false);
    let mut i0 = 0;
    while i0 < wu {
        let n = LANES.min(wu - i0);
        let base = base_row + i0;
        let k: [u32; LANES] = std::array::from_fn(|t| if t < n { base + t } else { base } as u32);
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let roles = unsafe { gather8(role, &k) };
        let live: [bool; LANES] = std::array::from_fn(|t| t < n && roles[t] != PASSIVE);
        if !live.contains(&true) {
            i0 += LANES;
            continue;
        }
        let source: [bool; LANES] = std::array::from_fn(|t| live[t] && roles[t] == SOURCE);
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let [lr, lg, lb, _] = unsafe { transpose8(light0, &k) };
        filtered += live.iter().map(|&l| l as u64).sum::<u64>();
        busy |= (0..LANES).fold(false, |b, t| {
            b | (live[t] & (!source[t] | (lr[t] != 0.0) | (lg[t] != 0.0) | (lb[t] != 0.0)))
        });
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let [px, py, pz, zp] = unsafe { transpose8(geom, &k) };
        let (turn, frac) = block_turns(grid, i0, n, j);
        // The 3×3 neighbourhood's other surface samples, [di + 1][dj + 1]: index and whether
        // it is one (the centre: none).
        let mut near = [[(k, [false; LANES]); 3]; 3];
        for (xi, col) in near.iter_mut().enumerate() {
            let column = Column::at(grid, i0, n, j, (&turn, &frac), xi as i32 - 1);
            for (yi, cell) in col.iter_mut().enumerate() {
                if xi == 1 && yi == 1 {
                    continue;
                }
                *cell = column.cells(grid, yi as i32 - 1, wu, &k);
            }
        }
        // Smaller one-sided depth difference per axis (x: the row's neighbours, y: the
        // column's), over the other texels that are not passive (a passive texel's depth is
        // NaN in `geom`; a cell outside the buffer reads the lane's centre, `cells`).
        let dz = |(q, _): ([u32; LANES], [bool; LANES])| -> F8 {
            // SAFETY: `Column::cells` lands inside the buffer (its invariant).
            let zq = unsafe { fourth8(geom, &q) };
            std::array::from_fn(|t| {
                let d = (zq[t] - zp[t]).abs();
                if q[t] != k[t] && !d.is_nan() {
                    d
                } else {
                    f32::INFINITY
                }
            })
        };
        let fin = |v: f32| if v.is_finite() { v } else { 0.0 };
        let (x0, x1, y0, y1) = (
            dz(near[0][1]),
            dz(near[2][1]),
            dz(near[1][0]),
            dz(near[1][2]),
        );
        let g0: F8 = std::array::from_fn(|t| fin(x0[t].min(x1[t])));
        let g1: F8 = std::array::from_fn(|t| fin(y0[t].min(y1[t])));
        for t in 0..n {
            if live[t] {
                gr[i0 + t] = [g0[t], g1[t]];
            }
        }
        if !source.contains(&true) {
            i0 += LANES;
            continue;
        }
        // Luminance moments of the neighbours on the same surface: normal weight above ½ and
        // depth within the gradient's prediction, `|z_p − z_q| ≤ σ_z |∇z·(p − q)| + ε_z` (the
        // depth weight's exponent at most 1, compared without dividing). With them, per
        // neighbour, the first à-trous iteration's verdict for the variance's prefilter (its
        // tolerance rounded as it adds it: `σ_z |∇z·(p − q)| + ε_z` with `ε_z` summed first;
        // the centre itself where a row wraps onto it: if it is a source), one bit each.
        let eps_z: F8 = std::array::from_fn(|t| 1e-3 * zp[t].abs() + 1e-9);
        let (mut sw, mut s1, mut s2) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        let mut bits = [0u8; LANES];
        for (xi, col) in near.iter().enumerate() {
            for (yi, &(q, inside)) in col.iter().enumerate() {
                if xi == 1 && yi == 1 {
                    continue;
                }
                let bit = 1u8 << cell_bit(xi, yi);
                // SAFETY: `Column::cells` lands inside the buffer (its invariant).
                let ([nx, ny, nz, zq], [r, g, b, _]) =
                    unsafe { (transpose8(geom, &q), transpose8(light0, &q)) };
                let (ax, ay) = (xi.abs_diff(1) as f32, yi.abs_diff(1) as f32);
                // Branch-free: a neighbour left out adds exact zeros. One that is not a source
                // has no normal in `geom`: never the same surface.
                for t in 0..LANES {
                    let dot = px[t] * nx[t] + py[t] * ny[t] + pz[t] * nz[t];
                    let dz = (zp[t] - zq[t]).abs();
                    let tol = sigma_z * (g0[t] * ax + g1[t] * ay);
                    let den = tol + 1e-3 * zp[t].abs() + 1e-9;
                    let other = inside[t] && q[t] != k[t];
                    let same = other && !(1.0 - dot > same_normal || dz > den);
                    let lq = luma([r[t], g[t], b[t]]);
                    sw[t] += if same { 1.0 } else { 0.0 };
                    s1[t] += if same { lq } else { 0.0 };
                    s2[t] += if same { lq * lq } else { 0.0 };
                    let prefilter = if q[t] == k[t] {
                        source[t]
                    } else {
                        !(1.0 - dot > same_normal || dz > tol + eps_z[t])
                    };
                    bits[t] |= if inside[t] && prefilter { bit } else { 0 };
                }
            }
        }
        // The firefly clamp and the variance, lane by lane without branches.
        let temporal: F8 = std::array::from_fn(|t| match variance {
            Some(v) if t < n => v.data()[base + t],
            _ => f32::NAN,
        });
        let (fire, kk) = (params.firefly_k.is_some(), params.firefly_k.unwrap_or(0.0));
        let mut res = [[0.0f32; 4]; LANES];
        let mut clamp = [false; LANES];
        for t in 0..LANES {
            let lp = [lr[t], lg[t], lb[t]];
            let yp = luma(lp);
            let mean = s1[t] / sw[t];
            let sd = (s2[t] / sw[t] - mean * mean).max(0.0).sqrt();
            let limit = mean + kk * sd;
            clamp[t] = fire && sw[t] >= 2.0 && yp > limit && yp > 0.0;
            let sc = limit.max(0.0) / yp;
            let lp = if clamp[t] { lp.map(|v| v * sc) } else { lp };
            let yp = if clamp[t] { luma(lp) } else { yp };
            // The temporal estimate where given, else the variance of the neighbourhood with
            // the (clamped) centre.
            let (tw, t1, t2) = (sw[t] + 1.0, s1[t] + yp, s2[t] + yp * yp);
            let m = t1 / tw;
            let spatial = (t2 / tw - m * m).max(0.0);
            let tv = temporal[t];
            let var = if tv >= 0.0 && tv.is_finite() {
                tv
            } else {
                spatial
            };
            res[t] = [lp[0], lp[1], lp[2], var];
        }
        for t in 0..n {
            if source[t] {
                out[i0 + t] = res[t];
                clamped += clamp[t] as u64;
            }
            if live[t] {
                same[i0 + t] = bits[t];
            }
        }
        i0 += LANES;
    }
    (clamped, filtered, busy)
}

/// Texels filtered together: eight consecutive texels of a row, one per lane. Every quantity
/// is a fixed-size lane array (structure of arrays), which the compiler turns into SIMD (SSE2
/// everywhere, AVX2 where the CPU has it); a tap's weight is computed for eight texels at
/// once and added to each texel's own sums, in the kernel's order.
const LANES: usize = 8;
/// One value per lane.
type F8 = [f32; LANES];

/// What an à-trous iteration reads, shared by every row.
struct Pass<'a> {
    grid: &'a Grid,
    geom: &'a [[f32; 4]],
    grad: &'a [[f32; 2]],
    role: &'a [u8],
    src: &'a [[f32; 4]],
    /// The set-up pass's same-surface masks, where it found them (else the first iteration
    /// tests the neighbours itself).
    same: Option<&'a [u8]>,
    receivers: &'a [(u32, [f32; 3])],
    wu: usize,
    step: i32,
    params: &'a DenoiseParams,
}

/// Records `rows[q[0..8]]` transposed: element `c` of the result is component `c` of the
/// eight records. On x86-64 each four-float record is loaded whole and the records are
/// transposed in registers (two 4×4 transposes with SSE, which every x86-64 has; the AVX2
/// build encodes the same operations in VEX); elsewhere each lane array is built whole from
/// its eight loads. The values are the same either way.
///
/// # Safety
///
/// Every `q[t] < rows.len()` (checked in tests and debug builds: [`CHECK_TAPS`]).
#[inline(always)]
unsafe fn transpose8(rows: &[[f32; 4]], q: &[u32; LANES]) -> [F8; 4] {
    check_taps(rows.len(), q);
    let q: [usize; LANES] = std::array::from_fn(|t| q[t] as usize);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let mut out = [[0.0f32; LANES]; 4];
        for half in 0..2 {
            let o = 4 * half;
            let at = |t: usize| {
                // SAFETY: every index is within `rows` (the caller's contract).
                unsafe { rows.as_ptr().add(q[t]).cast::<f32>() }
            };
            // SAFETY: SSE is part of x86-64; every pointer is a record of four floats within
            // `rows` (above) or a lane array with four floats from `o` on.
            unsafe {
                let (a, b) = (_mm_loadu_ps(at(o)), _mm_loadu_ps(at(o + 1)));
                let (c, d) = (_mm_loadu_ps(at(o + 2)), _mm_loadu_ps(at(o + 3)));
                // [a.x b.x a.y b.y], [a.z b.z a.w b.w], and the same of c, d.
                let (t0, t1) = (_mm_unpacklo_ps(a, b), _mm_unpackhi_ps(a, b));
                let (t2, t3) = (_mm_unpacklo_ps(c, d), _mm_unpackhi_ps(c, d));
                _mm_storeu_ps(out[0][o..].as_mut_ptr(), _mm_movelh_ps(t0, t2));
                _mm_storeu_ps(out[1][o..].as_mut_ptr(), _mm_movehl_ps(t2, t0));
                _mm_storeu_ps(out[2][o..].as_mut_ptr(), _mm_movelh_ps(t1, t3));
                _mm_storeu_ps(out[3][o..].as_mut_ptr(), _mm_movehl_ps(t3, t1));
            }
        }
        out
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // SAFETY: every index is within `rows` (the caller's contract).
        let r: [[f32; 4]; LANES] = std::array::from_fn(|t| unsafe { *rows.get_unchecked(q[t]) });
        std::array::from_fn(|c| std::array::from_fn(|t| r[t][c]))
    }
}

/// Whether the lanes' reads check their indices: in tests and debug builds. A release build
/// relies on the index arithmetic instead (a block's own texels, and `Column::cells`' taps,
/// which land inside the buffer by construction), so that a tap's eight reads cost no
/// bounds checks.
const CHECK_TAPS: bool = cfg!(any(test, debug_assertions));

/// Panics where an index is outside a buffer of `len` elements, if [`CHECK_TAPS`].
#[inline(always)]
fn check_taps(len: usize, q: &[u32; LANES]) {
    if CHECK_TAPS {
        assert!(
            q.iter().all(|&x| (x as usize) < len),
            "a tap outside the buffer"
        );
    }
}

/// `v[q[0..8]]`.
///
/// # Safety
///
/// Every `q[t] < v.len()` (checked in tests and debug builds: [`CHECK_TAPS`]).
#[inline(always)]
unsafe fn gather8<T: Copy>(v: &[T], q: &[u32; LANES]) -> [T; LANES] {
    check_taps(v.len(), q);
    // SAFETY: every index is within `v` (the caller's contract).
    std::array::from_fn(|t| unsafe { *v.get_unchecked(q[t] as usize) })
}

/// The fourth components `rows[q[0..8]][3]` (a depth, a variance).
///
/// # Safety
///
/// Every `q[t] < rows.len()` (checked in tests and debug builds: [`CHECK_TAPS`]).
#[inline(always)]
unsafe fn fourth8(rows: &[[f32; 4]], q: &[u32; LANES]) -> F8 {
    check_taps(rows.len(), q);
    // SAFETY: every index is within `rows` (the caller's contract).
    std::array::from_fn(|t| unsafe { rows.get_unchecked(q[t] as usize)[3] })
}

/// Where one kernel column's taps land for the lanes of a block: per lane the column, the row
/// at the texel's angle there (before wrapping) and that column's row count; `ok` false where
/// the column is outside the buffer or the lane past the row's end. Rows are 32-bit, so that
/// the lanes' arithmetic and range tests are SIMD: the buffer has at most [`MAX_ROWS`] rows
/// and a landing row is kept within `±MAX_ROWS` (a polar one farther away is first reduced
/// modulo its column's rows, which moves no tap: rows wrap there).
///
/// **Invariant**, on which the passes' unchecked reads rely: every index [`Column::cells`]
/// returns is a texel of the buffer — `r·w + c` with a row `0 ≤ r < rows ≤ h` and a column
/// `c < w` of the grid, which [`denoise_with_variance`] checks against the buffer's `w × h` —
/// or the lane's own texel `k`.
struct Column {
    c: [u32; LANES],
    row: [i32; LANES],
    rows: [i32; LANES],
    ok: [bool; LANES],
}

/// The most rows a buffer may have (so that a landing row plus a tap's step fits 32 bits).
pub const MAX_ROWS: u32 = 1 << 30;

impl Column {
    /// The kernel column `dx` texels from texels `(i0 + t, j)`, `t < n`, whose angles in turns
    /// are `turn[t]` and `frac[t]` their fractions `turn − ⌊turn⌋` ([`column_at`] per lane).
    /// Lane by lane without branches where the eight columns are consecutive columns of the
    /// buffer (the common case), else per lane.
    #[inline(always)]
    fn at(
        grid: &Grid,
        i0: usize,
        n: usize,
        j: u32,
        (turn, frac): (&[f64; LANES], &[f64; LANES]),
        dx: i32,
    ) -> Self {
        let mut col = Column {
            c: [0; LANES],
            row: [0; LANES],
            rows: [0; LANES],
            ok: [false; LANES],
        };
        let c0 = i0 as i64 + dx as i64;
        match grid {
            Grid::Rect { width, height } => {
                for t in 0..LANES {
                    let c = c0 + t as i64;
                    col.ok[t] = t < n && c >= 0 && c < *width as i64;
                    col.c[t] = if col.ok[t] { c as u32 } else { 0 };
                    col.row[t] = j as i32;
                    col.rows[t] = *height as i32;
                }
                return col;
            }
            Grid::Polar { rows, period } if c0 >= 0 && c0 as usize + LANES <= rows.len() => {
                let c0 = c0 as usize;
                let (rs, ps) = (&rows[c0..c0 + LANES], &period[c0..c0 + LANES]);
                // `column_at`'s row at the same angle (the same column: the same row), exact in
                // 32 bits where it lies within ±MAX_ROWS (NaN does not).
                let x: [f64; LANES] = std::array::from_fn(|t| frac[t] * ps[t]);
                let fits = (0..LANES).all(|t| x[t].abs() < MAX_ROWS as f64 || dx == 0);
                if fits {
                    for t in 0..LANES {
                        col.ok[t] = t < n && rs[t] != 0;
                        col.c[t] = (c0 + t) as u32;
                        col.rows[t] = rs[t] as i32;
                        col.row[t] = if dx == 0 {
                            j as i32
                        } else {
                            // SAFETY: |x| < 2^30 (`fits`): the truncation is exact.
                            unsafe { x[t].to_int_unchecked::<i32>() }
                        };
                    }
                    return col;
                }
            }
            Grid::Polar { .. } => {}
        }
        for t in 0..n {
            if let Some((c, row, rows)) = column_at(grid, (i0 + t) as u32, j, turn[t], dx) {
                // A polar row outside the column wraps: reduced modulo its rows first (`rows`
                // ≥ 1 here), it lands where it did. A rect row is the texel's own.
                let row = if (0..rows as i64).contains(&row) {
                    row
                } else {
                    row.rem_euclid(rows as i64)
                };
                (col.c[t], col.row[t], col.rows[t], col.ok[t]) = (c, row as i32, rows as i32, true);
            }
        }
        col
    }

    /// The texels `dy` rows on: per lane its index and whether it lies in the buffer (else
    /// the index is the lane's centre `k`).
    #[inline(always)]
    fn cells(
        &self,
        grid: &Grid,
        dy: i32,
        wu: usize,
        k: &[u32; LANES],
    ) -> ([u32; LANES], [bool; LANES]) {
        let r: [i32; LANES] = std::array::from_fn(|t| self.row[t] + dy);
        let within: [bool; LANES] = std::array::from_fn(|t| r[t] >= 0 && r[t] < self.rows[t]);
        if (0..LANES).all(|t| within[t] || !self.ok[t]) {
            // No row wraps: one multiply-add per lane, in 32 bits (the buffer has fewer than
            // 2^32 texels).
            let q = std::array::from_fn(|t| {
                let q = (r[t] as u32)
                    .wrapping_mul(wu as u32)
                    .wrapping_add(self.c[t]);
                if self.ok[t] {
                    q
                } else {
                    k[t]
                }
            });
            return (q, self.ok);
        }
        let (mut q, mut inside) = (*k, [false; LANES]);
        for t in 0..LANES {
            if !self.ok[t] {
                continue;
            }
            if let Some(r) = row_of(grid, self.row[t] as i64, self.rows[t] as u32, dy) {
                (q[t], inside[t]) = ((r as usize * wu + self.c[t] as usize) as u32, true);
            }
        }
        (q, inside)
    }
}

/// One à-trous iteration at `step` texels from `src` into `dst` (every texel not passive), from
/// any geometry `geom` (normal and depth per texel): prepared as the set-up does (no normal
/// for the texels that are not sources, the receivers' kept aside), then filtered as
/// [`denoise_with_variance`]'s iterations are.
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
fn atrous_pass(
    grid: &Grid,
    geom: &[[f32; 4]],
    grad: &[[f32; 2]],
    role: &[u8],
    src: &[[f32; 4]],
    dst: &mut [[f32; 4]],
    wu: usize,
    step: i32,
    params: &DenoiseParams,
) {
    let receivers: Vec<(u32, [f32; 3])> = (0..geom.len())
        .filter(|&k| role[k] == RECEIVER)
        .map(|k| (k as u32, [geom[k][0], geom[k][1], geom[k][2]]))
        .collect();
    let geom: Vec<[f32; 4]> = geom
        .iter()
        .zip(role)
        .map(|(g, &r)| {
            if r == SOURCE {
                *g
            } else {
                [0.0, 0.0, 0.0, g[3]]
            }
        })
        .collect();
    let pass = Pass {
        grid,
        geom: &geom,
        grad,
        role,
        src,
        same: None,
        receivers: &receivers,
        wu,
        step,
        params,
    };
    dst.par_chunks_mut(wu)
        .enumerate()
        .for_each(|(j, out)| pass.row(j as u32, out));
}

impl Pass<'_> {
    /// Row `j` of the iteration into `out` (the row's texels; passive ones left as they are),
    /// in the AVX2 build where the CPU has it.
    #[inline]
    fn row(&self, j: u32, out: &mut [[f32; 4]]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked above); the function is safe Rust otherwise.
            unsafe { atrous_row_avx2(self, j, out) };
            return;
        }
        atrous_row(self, j, out);
    }
}

/// [`atrous_row`] compiled for AVX2 (the same operations, 8 lanes wide; no FMA, so the
/// results equal the SSE2 build's bit for bit).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn atrous_row_avx2(pass: &Pass, j: u32, out: &mut [[f32; 4]]) {
    atrous_row(pass, j, out)
}

/// Row `j` of one à-trous iteration, eight texels at a time. Every sum adds its terms in the
/// order of the scalar filter (the centre, then the kernel's taps column by column), so the
/// result is the scalar filter's bit for bit: a tap that does not land on another source
/// reads the centre with kernel weight 0 and adds exact zeros.
#[inline(always)]
fn atrous_row(pass: &Pass, j: u32, out: &mut [[f32; 4]]) {
    let Pass {
        grid,
        geom,
        grad,
        role,
        src,
        same,
        receivers,
        wu,
        step,
        params,
    } = *pass;
    let sigma_l = params.sigma_luminance;
    let sigma_z = params.sigma_depth;
    let sigma_n = params.normal_power as f32;
    let same_normal = std::f32::consts::LN_2 / sigma_n;
    let h = params.kernel.taps();
    let half = h.len() / 2;
    let stepf = step as f32;
    let mut i0 = 0;
    while i0 < wu {
        let n = LANES.min(wu - i0);
        let base = j as usize * wu + i0;
        // Lanes past the row's end compute texel `base`'s and store nothing.
        let k: [u32; LANES] = std::array::from_fn(|t| if t < n { base + t } else { base } as u32);
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let roles = unsafe { gather8(role, &k) };
        let live: [bool; LANES] = std::array::from_fn(|t| t < n && roles[t] != PASSIVE);
        if !live.contains(&true) {
            i0 += LANES;
            continue;
        }
        let source: [bool; LANES] = std::array::from_fn(|t| roles[t] == SOURCE);
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let [mut px, mut py, mut pz, zp] = unsafe { transpose8(geom, &k) };
        // A receiver's own normal (`geom` has none for it).
        for t in 0..n {
            if live[t] && !source[t] {
                if let Ok(r) = receivers.binary_search_by_key(&k[t], |e| e.0) {
                    [px[t], py[t], pz[t]] = receivers[r].1;
                }
            }
        }
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let [lr, lg, lb, lv] = unsafe { transpose8(src, &k) };
        // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
        let gk = unsafe { gather8(grad, &k) };
        let g0: F8 = std::array::from_fn(|t| gk[t][0]);
        let g1: F8 = std::array::from_fn(|t| gk[t][1]);
        let yp: F8 = std::array::from_fn(|t| 0.299 * lr[t] + 0.587 * lg[t] + 0.114 * lb[t]);
        let eps_z: F8 = std::array::from_fn(|t| 1e-3 * zp[t].abs() + 1e-9);
        let (turn, frac) = block_turns(grid, i0, n, j);

        // 3×3 Gaussian of the variance over sources on the same surface (SVGF Eq. 5's g₃ₓ₃; a
        // neighbour across an edge has another noise level), in the first iteration; the
        // later ones read the variance the earlier ones filtered.
        let var: F8 = if let (1, Some(same)) = (step, same) {
            // The neighbours the set-up pass found on the same surface.
            // SAFETY: the block's texels `k` lie in the buffer (all its buffers hold `n` texels).
            let bits = unsafe { gather8(same, &k) };
            let (mut vw, mut vs) = ([0.0f32; LANES], [0.0f32; LANES]);
            for (xi, di) in (-1i32..=1).enumerate() {
                let col = Column::at(grid, i0, n, j, (&turn, &frac), di);
                for (yi, dj) in (-1i32..=1).enumerate() {
                    let wgt = H3[xi] * H3[yi];
                    if xi == 1 && yi == 1 {
                        for t in 0..LANES {
                            vw[t] += if source[t] { wgt } else { 0.0 };
                            vs[t] += if source[t] { wgt * lv[t] } else { 0.0 };
                        }
                        continue;
                    }
                    let (q, _) = col.cells(grid, dj, wu, &k);
                    // SAFETY: `Column::cells` lands inside the buffer (its invariant).
                    let vq = unsafe { fourth8(src, &q) };
                    let bit = 1u8 << cell_bit(xi, yi);
                    for t in 0..LANES {
                        let on = bits[t] & bit != 0;
                        vw[t] += if on { wgt } else { 0.0 };
                        vs[t] += if on { wgt * vq[t] } else { 0.0 };
                    }
                }
            }
            std::array::from_fn(|t| if vw[t] > 0.0 { vs[t] / vw[t] } else { 0.0 })
        } else if step == 1 {
            let (mut vw, mut vs) = ([0.0f32; LANES], [0.0f32; LANES]);
            for (xi, di) in (-1i32..=1).enumerate() {
                let col = Column::at(grid, i0, n, j, (&turn, &frac), di);
                for (yi, dj) in (-1i32..=1).enumerate() {
                    let (q, inside) = col.cells(grid, dj, wu, &k);
                    // SAFETY: `Column::cells` lands inside the buffer (its invariant).
                    let [nx, ny, nz, zq] = unsafe { transpose8(geom, &q) };
                    // SAFETY: `Column::cells` lands inside the buffer (its invariant).
                    let vq = unsafe { fourth8(src, &q) };
                    let wgt = H3[xi] * H3[yi];
                    let (ax, ay) = (di.abs() as f32, dj.abs() as f32);
                    for t in 0..LANES {
                        let dot = px[t] * nx[t] + py[t] * ny[t] + pz[t] * nz[t];
                        let dz = (zp[t] - zq[t]).abs();
                        let tol = sigma_z * (g0[t] * ax + g1[t] * ay);
                        // The centre itself if it is a source; another texel if it is on the
                        // same surface (one that is not a source has no normal in `geom`).
                        let same = if q[t] == k[t] {
                            source[t]
                        } else {
                            !(1.0 - dot > same_normal || dz > tol + eps_z[t])
                        };
                        // Branch-free: a cell left out adds exact zeros.
                        let on = inside[t] && same;
                        vw[t] += if on { wgt } else { 0.0 };
                        vs[t] += if on { wgt * vq[t] } else { 0.0 };
                    }
                }
            }
            std::array::from_fn(|t| if vw[t] > 0.0 { vs[t] / vw[t] } else { 0.0 })
        } else {
            lv
        };
        // A receiver-only texel has no light of its own to compare with.
        let inv_sl: F8 = std::array::from_fn(|t| {
            if source[t] {
                1.0 / (sigma_l * var[t].sqrt() + 1e-8)
            } else {
                0.0
            }
        });
        // 1 / (σ_z |∇z·(p − q)| + ε_z) for |Δx|, |Δy| in kernel steps (one division per
        // offset class and lane, not per tap).
        let mut inv_den = [[[0.0f32; LANES]; 3]; 3];
        for (ax, row) in inv_den.iter_mut().enumerate().take(half + 1) {
            for (ay, lanes) in row.iter_mut().enumerate().take(half + 1) {
                if ax + ay == 0 {
                    continue;
                }
                for t in 0..LANES {
                    let d = (g0[t] * ax as f32 + g1[t] * ay as f32) * stepf;
                    lanes[t] = 1.0 / (sigma_z * d + eps_z[t]);
                }
            }
        }
        // The sums (w, w·rgb, w²·var), the centre's first.
        let hc = h[half] * h[half];
        let mut sw: F8 = std::array::from_fn(|t| if source[t] { hc } else { 0.0 });
        let mut sr: F8 = std::array::from_fn(|t| if source[t] { lr[t] * hc } else { 0.0 });
        let mut sg: F8 = std::array::from_fn(|t| if source[t] { lg[t] * hc } else { 0.0 });
        let mut sb: F8 = std::array::from_fn(|t| if source[t] { lb[t] * hc } else { 0.0 });
        let mut sv: F8 = std::array::from_fn(|t| if source[t] { hc * hc * lv[t] } else { 0.0 });
        for (xi, &hx) in h.iter().enumerate() {
            let col = Column::at(
                grid,
                i0,
                n,
                j,
                (&turn, &frac),
                (xi as i32 - half as i32) * step,
            );
            for (yi, &hy) in h.iter().enumerate() {
                if xi == half && yi == half {
                    continue;
                }
                // A tap outside the buffer reads the lane's centre (`cells`), so a tap reads
                // another texel exactly where it lands inside on another texel.
                let (q, _) = col.cells(grid, (yi as i32 - half as i32) * step, wu, &k);
                // A tap outside or on the centre reads the centre with kernel weight 0; one on a
                // texel that is not a source has weight 0 too (it has no normal in `geom`:
                // `n_p·0 = 0`), and light 0 or a receiver's finite light.
                let hq: F8 = std::array::from_fn(|t| if q[t] != k[t] { hx * hy } else { 0.0 });
                // SAFETY: `Column::cells` lands inside the buffer (its invariant).
                let ([nx, ny, nz, zq], [r, g, b, v]) =
                    unsafe { (transpose8(geom, &q), transpose8(src, &q)) };
                let inv_den = &inv_den[xi.abs_diff(half)][yi.abs_diff(half)];
                for t in 0..LANES {
                    let dot = px[t] * nx[t] + py[t] * ny[t] + pz[t] * nz[t];
                    let yq = 0.299 * r[t] + 0.587 * g[t] + 0.114 * b[t];
                    // max(0, n·n')^σ_n ≈ e^(−σ_n (1 − n·n')) (equal to first order at
                    // n = n'), folded into the one exponential with the depth and luminance
                    // terms.
                    let arg = (zp[t] - zq[t]).abs() * inv_den[t]
                        + (yp[t] - yq).abs() * inv_sl[t]
                        + sigma_n * (1.0 - dot);
                    // A weight past the cut-off is not used: its exponential is taken at 31
                    // instead (no subnormal products in the unused lanes).
                    let e = exp_neg(arg.min(31.0));
                    let wgt = if dot > 0.0 && arg <= 30.0 {
                        hq[t] * e
                    } else {
                        0.0
                    };
                    sw[t] += wgt;
                    sr[t] += wgt * r[t];
                    sg[t] += wgt * g[t];
                    sb[t] += wgt * b[t];
                    sv[t] += wgt * wgt * v[t];
                }
            }
        }
        let res: [F8; 4] = [
            std::array::from_fn(|t| sr[t] / sw[t]),
            std::array::from_fn(|t| sg[t] / sw[t]),
            std::array::from_fn(|t| sb[t] / sw[t]),
            std::array::from_fn(|t| sv[t] / (sw[t] * sw[t])),
        ];
        for t in 0..n {
            if live[t] {
                out[i0 + t] = if sw[t] > 0.0 {
                    [res[0][t], res[1][t], res[2][t], res[3][t]]
                } else {
                    src[k[t] as usize]
                };
            }
        }
        i0 += LANES;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic uniform numbers in [0, 1) (xorshift64*).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
        }
        /// Zero-mean, unit-variance noise (sum of 4 uniforms, scaled).
        fn gauss(&mut self) -> f32 {
            let s: f32 = (0..4).map(|_| self.next()).sum::<f32>() - 2.0;
            s * (3.0f32).sqrt()
        }
    }

    /// A frame on a rect grid: light `light(i, j)` on albedo `albedo(i, j)`, depth
    /// `depth(i, j)`, normal `normal(i, j)`.
    struct Scene {
        color: Image<Rgb>,
        depth: Image<f32>,
        albedo: Image<Rgb>,
        normal: Image<[f32; 3]>,
        noisy: Option<Image<Rgb>>,
    }

    fn scene(
        (w, h): (u32, u32),
        light: impl Fn(u32, u32) -> Rgb,
        albedo: impl Fn(u32, u32) -> Rgb,
        depth: impl Fn(u32, u32) -> f32,
        normal: impl Fn(u32, u32) -> [f32; 3],
    ) -> Scene {
        let mk = |f: &dyn Fn(u32, u32) -> Rgb| {
            Image::from_vec(
                w,
                h,
                (0..h)
                    .flat_map(|j| (0..w).map(move |i| (i, j)))
                    .map(|(i, j)| f(i, j))
                    .collect(),
            )
            .unwrap()
        };
        let color = mk(&|i, j| {
            let (l, a) = (light(i, j), albedo(i, j));
            std::array::from_fn(|k| l[k] * a[k])
        });
        Scene {
            color,
            depth: Image::from_vec(
                w,
                h,
                (0..h)
                    .flat_map(|j| (0..w).map(move |i| (i, j)))
                    .map(|(i, j)| depth(i, j))
                    .collect(),
            )
            .unwrap(),
            albedo: mk(&albedo),
            normal: mk(&normal),
            noisy: None,
        }
    }

    fn rect(s: &Scene) -> Grid {
        Grid::Rect {
            width: s.color.width(),
            height: s.color.height(),
        }
    }

    fn run(s: &Scene, grid: &Grid, p: &DenoiseParams) -> (Image<Rgb>, DenoiseStats) {
        let mut c = s.color.clone();
        let mut scratch = DenoiseScratch::default();
        let st = denoise(
            &mut c,
            &s.depth,
            &s.albedo,
            &s.normal,
            s.noisy.as_ref(),
            grid,
            p,
            &mut scratch,
        )
        .unwrap();
        (c, st)
    }

    fn texture(i: u32, j: u32) -> Rgb {
        [
            0.1 + 0.8 * (((i * 7 + j * 3) % 11) as f32 / 10.0),
            0.5,
            0.05 + 0.01 * (j % 5) as f32,
        ]
    }

    /// The à-trous iteration as first written (scalar, tap by tap, in the order of the
    /// kernel): the reference the vectorized [`super::atrous_pass`] must equal to rounding.
    #[allow(clippy::too_many_arguments)]
    fn reference_pass(
        grid: &Grid,
        geom: &[[f32; 4]],
        grad: &[[f32; 2]],
        role: &[u8],
        src: &[[f32; 4]],
        dst: &mut [[f32; 4]],
        wu: usize,
        step: i32,
        params: &DenoiseParams,
    ) {
        let sigma_l = params.sigma_luminance;
        let sigma_z = params.sigma_depth;
        let sigma_n = params.normal_power as f32;
        let same_normal = std::f32::consts::LN_2 / sigma_n;
        dst.par_chunks_mut(wu).enumerate().for_each(|(j, out)| {
            let j = j as u32;
            for i in 0..wu {
                let k = j as usize * wu + i;
                if role[k] == PASSIVE {
                    continue;
                }
                let gp = geom[k];
                let g = grad[k];
                let lp = [src[k][0], src[k][1], src[k][2]];
                let yp = luma(lp);
                let turn = turn_of(grid, i as u32, j);
                let eps_z = 1e-3 * gp[3].abs() + 1e-9;
                // 3×3 Gaussian of the variance over sources on the same surface (SVGF Eq. 5's
                // g₃ₓ₃; a neighbour across an edge has another noise level), in the first
                // iteration; the later ones read the variance the earlier ones filtered.
                let (mut vw, mut vs) = (0.0f32, 0.0f32);
                if step > 1 {
                    (vw, vs) = (1.0, src[k][3]);
                }
                for di in (-1i32..=1).filter(|_| step == 1) {
                    let Some((c, row, rows)) = column_at(grid, i as u32, j, turn, di) else {
                        continue;
                    };
                    for dj in -1i32..=1 {
                        let Some(r) = row_of(grid, row, rows, dj) else {
                            continue;
                        };
                        let q = r as usize * wu + c as usize;
                        if role[q] != SOURCE {
                            continue;
                        }
                        if q != k {
                            let gq = geom[q];
                            let dot = gp[0] * gq[0] + gp[1] * gq[1] + gp[2] * gq[2];
                            let dz = (gp[3] - gq[3]).abs();
                            let tol = sigma_z * (g[0] * di.abs() as f32 + g[1] * dj.abs() as f32);
                            if 1.0 - dot > same_normal || dz > tol + eps_z {
                                continue;
                            }
                        }
                        let wgt = [0.25f32, 0.5, 0.25][(di + 1) as usize]
                            * [0.25f32, 0.5, 0.25][(dj + 1) as usize];
                        vw += wgt;
                        vs += wgt * src[q][3];
                    }
                }
                let var = if vw > 0.0 { vs / vw } else { 0.0 };
                // A receiver-only texel has no light of its own to compare with.
                let inv_sl = if role[k] == SOURCE {
                    1.0 / (sigma_l * var.sqrt() + 1e-8)
                } else {
                    0.0
                };
                // 1 / (σ_z |∇z·(p − q)| + ε_z) for |dx|, |dy| ∈ {0, 1, 2}·step (one division
                // each instead of one per tap).
                let inv_den: [[f32; 3]; 3] = std::array::from_fn(|ax| {
                    std::array::from_fn(|ay| {
                        let d = (g[0] * ax as f32 + g[1] * ay as f32) * step as f32;
                        1.0 / (sigma_z * d + eps_z)
                    })
                });
                let (mut sw, mut sl, mut sv) = (0.0f32, [0.0f32; 3], 0.0f32);
                let h = params.kernel.taps();
                let half = h.len() / 2;
                if role[k] == SOURCE {
                    let wgt = h[half] * h[half];
                    sw = wgt;
                    sl = lp.map(|v| v * wgt);
                    sv = wgt * wgt * src[k][3];
                }
                for (xi, hx) in h.iter().enumerate() {
                    let di = (xi as i32 - half as i32) * step;
                    let Some((c, row, rows)) = column_at(grid, i as u32, j, turn, di) else {
                        continue;
                    };
                    for (yi, hy) in h.iter().enumerate() {
                        if xi == half && yi == half {
                            continue;
                        }
                        let dj = (yi as i32 - half as i32) * step;
                        let Some(r) = row_of(grid, row, rows, dj) else {
                            continue;
                        };
                        let q = r as usize * wu + c as usize;
                        if role[q] != SOURCE || q == k {
                            continue;
                        }
                        let gq = geom[q];
                        let dot = gp[0] * gq[0] + gp[1] * gq[1] + gp[2] * gq[2];
                        if dot <= 0.0 {
                            continue;
                        }
                        let lq = [src[q][0], src[q][1], src[q][2]];
                        // max(0, n·n')^σ_n ≈ e^(−σ_n (1 − n·n')) (equal to first order at n = n'),
                        // folded into the one exponential with the depth and luminance terms.
                        let arg = (gp[3] - gq[3]).abs()
                            * inv_den[xi.abs_diff(half)][yi.abs_diff(half)]
                            + (yp - luma(lq)).abs() * inv_sl
                            + sigma_n * (1.0 - dot);
                        if arg > 30.0 {
                            continue;
                        }
                        let wgt = hx * hy * exp_neg(arg);
                        sw += wgt;
                        for ch in 0..3 {
                            sl[ch] += wgt * lq[ch];
                        }
                        sv += wgt * wgt * src[q][3];
                    }
                }
                out[i] = if sw > 0.0 {
                    [sl[0] / sw, sl[1] / sw, sl[2] / sw, sv / (sw * sw)]
                } else {
                    src[k]
                };
            }
        });
    }

    #[test]
    fn the_vectorized_pass_equals_the_scalar_reference() {
        // Random geometry (a few surfaces, some facing away, some passive and receiver
        // texels), random light and variance, on a polar and a rect grid, every step and both
        // kernels: the outputs agree to f32 rounding of the reordered sums.
        let rows = vec![6u32, 9, 14, 20, 27, 33, 40, 40, 40, 38];
        let period: Vec<f64> = rows.iter().map(|&r| r as f64 * 1.03).collect();
        let polar = Grid::Polar {
            rows: rows.clone(),
            period,
        };
        let rect = Grid::Rect {
            width: 37,
            height: 29,
        };
        let mut rng = Rng(21);
        for (grid, w, h) in [(&polar, 10usize, 40usize), (&rect, 37, 29)] {
            let n = w * h;
            let geom: Vec<[f32; 4]> = (0..n)
                .map(|_| {
                    let s = (rng.next() * 4.0) as u32;
                    let nv = [
                        [0.0, 0.0, 1.0],
                        [0.0, 0.6, 0.8],
                        [0.8, 0.0, 0.6],
                        [0.0, 0.0, -1.0],
                    ][s as usize];
                    let nv = [nv[0] + 0.01 * rng.next(), nv[1], nv[2]];
                    [nv[0], nv[1], nv[2], 1.0 + s as f32 + 0.05 * rng.next()]
                })
                .collect();
            let grad: Vec<[f32; 2]> = (0..n)
                .map(|_| [0.02 * rng.next(), 0.03 * rng.next()])
                .collect();
            let role: Vec<u8> = (0..n)
                .map(|k| {
                    let (i, j) = ((k % w) as u32, (k / w) as u32);
                    match (grid.valid(i, j), rng.next()) {
                        (false, _) => PASSIVE,
                        (true, x) if x < 0.05 => PASSIVE,
                        (true, x) if x < 0.1 => RECEIVER,
                        _ => SOURCE,
                    }
                })
                .collect();
            let src: Vec<[f32; 4]> = (0..n)
                .map(|_| {
                    let v = rng.next();
                    [v, 0.5 * v + 0.2 * rng.next(), rng.next(), 0.05 * rng.next()]
                })
                .collect();
            for kernel in [Kernel::Linear3x3, Kernel::B3Spline5x5] {
                let params = DenoiseParams {
                    kernel,
                    ..DenoiseParams::default()
                };
                for step in [1, 2, 4, 8] {
                    let mut fast = vec![[0.0f32; 4]; n];
                    let mut slow = vec![[0.0f32; 4]; n];
                    atrous_pass(grid, &geom, &grad, &role, &src, &mut fast, w, step, &params);
                    reference_pass(grid, &geom, &grad, &role, &src, &mut slow, w, step, &params);
                    for k in 0..n {
                        for c in 0..4 {
                            let (a, b) = (fast[k][c], slow[k][c]);
                            assert!(
                                (a - b).abs() <= 1e-5 * b.abs().max(1e-3),
                                "{kernel:?} step {step} texel {k} channel {c}: {a} vs {b}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_pass_equals_the_scalar_reference_exactly() {
        // Eight texels at a time, each texel's sums in the kernel's order as the scalar
        // filter adds them: the same numbers, not only to rounding (a zero may change sign).
        // Random geometry with passive and receiver texels, on a polar grid (with columns
        // whose angles cross the fovea) and a rect grid, every step and both kernels.
        let rows = vec![5u32, 11, 16, 21, 27, 30, 35, 40, 40, 40, 39, 37, 40];
        let period: Vec<f64> = rows.iter().map(|&r| r as f64 * 1.07 + 0.3).collect();
        let polar = Grid::Polar {
            rows: rows.clone(),
            period,
        };
        let rect = Grid::Rect {
            width: 45,
            height: 23,
        };
        let mut rng = Rng(77);
        for (grid, w, h) in [(&polar, 13usize, 40usize), (&rect, 45, 23)] {
            let n = w * h;
            let geom: Vec<[f32; 4]> = (0..n)
                .map(|_| {
                    let s = (rng.next() * 3.0) as u32;
                    let nv = [[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [0.8, 0.0, 0.6]][s as usize];
                    let nv = [nv[0], nv[1] + 0.02 * rng.next(), nv[2]];
                    [nv[0], nv[1], nv[2], 2.0 + s as f32 + 0.03 * rng.next()]
                })
                .collect();
            let grad: Vec<[f32; 2]> = (0..n)
                .map(|_| [0.03 * rng.next(), 0.02 * rng.next()])
                .collect();
            let role: Vec<u8> = (0..n)
                .map(|k| {
                    let (i, j) = ((k % w) as u32, (k / w) as u32);
                    match (grid.valid(i, j), rng.next()) {
                        (false, _) => PASSIVE,
                        (true, x) if x < 0.08 => PASSIVE,
                        (true, x) if x < 0.12 => RECEIVER,
                        _ => SOURCE,
                    }
                })
                .collect();
            let src: Vec<[f32; 4]> = (0..n)
                .map(|_| {
                    let v = rng.next();
                    [v, 0.3 * v + 0.4 * rng.next(), rng.next(), 0.08 * rng.next()]
                })
                .collect();
            for kernel in [Kernel::Linear3x3, Kernel::B3Spline5x5] {
                let params = DenoiseParams {
                    kernel,
                    ..DenoiseParams::default()
                };
                for step in [1, 2, 4, 8, 16] {
                    let mut fast = vec![[0.0f32; 4]; n];
                    let mut slow = vec![[0.0f32; 4]; n];
                    atrous_pass(grid, &geom, &grad, &role, &src, &mut fast, w, step, &params);
                    reference_pass(grid, &geom, &grad, &role, &src, &mut slow, w, step, &params);
                    for k in (0..n).filter(|&k| role[k] != PASSIVE) {
                        assert_eq!(fast[k], slow[k], "{kernel:?} step {step} texel {k}");
                    }
                }
            }
        }
    }

    #[test]
    fn the_set_up_masks_equal_the_prefilters_own_tests() {
        // The first iteration's variance prefilter reads which neighbours are on the same
        // surface from the set-up pass; testing them itself gives the same frame bit for bit.
        // A polar grid (with the fovea crossing) and a rect one, random surfaces, sky,
        // receivers (NaN colour), both kernels, one and four iterations.
        let rows = vec![4u32, 9, 15, 22, 28, 33, 36, 36, 36, 35, 36];
        let period: Vec<f64> = rows.iter().map(|&r| r as f64 * 1.05 + 0.2).collect();
        let polar = Grid::Polar {
            rows: rows.clone(),
            period,
        };
        let rect = Grid::Rect {
            width: 31,
            height: 20,
        };
        let mut rng = Rng(5);
        for (grid, w, h) in [(&polar, 11u32, 36u32), (&rect, 31, 20)] {
            let mut s = scene(
                (w, h),
                |i, j| [0.5 + 0.1 * (i % 3) as f32, 0.4, 0.3 + 0.05 * (j % 4) as f32],
                texture,
                |i, j| 2.0 + 0.02 * i as f32 + if (i + j) % 7 < 3 { 1.0 } else { 0.0 },
                |i, j| {
                    if (i / 3 + j / 5) % 3 == 0 {
                        [0.0, 0.6, 0.8]
                    } else {
                        [0.0, 0.0, 1.0]
                    }
                },
            );
            for k in 0..(w * h) as usize {
                let x = rng.next();
                let c = &mut s.color.data_mut()[k];
                *c = c.map(|v| v * (0.5 + rng.next()));
                if x < 0.05 {
                    s.depth.data_mut()[k] = f32::INFINITY;
                } else if x < 0.09 {
                    *c = [f32::NAN; 3];
                }
            }
            for kernel in [Kernel::Linear3x3, Kernel::B3Spline5x5] {
                for iterations in [1, 4] {
                    let p = DenoiseParams {
                        kernel,
                        iterations,
                        ..DenoiseParams::default()
                    };
                    let (masked, _) = run(&s, grid, &p);
                    PREFILTER_TESTS_ITSELF.with(|t| t.set(true));
                    let (tested, _) = run(&s, grid, &p);
                    PREFILTER_TESTS_ITSELF.with(|t| t.set(false));
                    let bits = |img: &Image<Rgb>| -> Vec<u32> {
                        img.data().iter().flatten().map(|v| v.to_bits()).collect()
                    };
                    assert_eq!(bits(&masked), bits(&tested), "{kernel:?} x{iterations}");
                    assert_ne!(bits(&masked), bits(&s.color), "{kernel:?} x{iterations}");
                }
            }
        }
    }

    #[test]
    fn a_given_variance_replaces_the_spatial_estimate() {
        // A noise-free lighting step on one plane: the spatial estimate sees the step as
        // variance and lets the filter through it; a given variance of zero (the temporal
        // moments' verdict: no noise) stops it, and the step comes back unchanged. NaN means
        // unknown: the same as no variance at all.
        let (w, h) = (32u32, 16u32);
        let s = scene(
            (w, h),
            |i, _| if i < 16 { [1.0; 3] } else { [1.3; 3] },
            |_, _| [0.5; 3],
            |_, _| 2.0,
            |_, _| [0.0, 0.0, 1.0],
        );
        let p = DenoiseParams {
            firefly_k: None,
            ..DenoiseParams::default()
        };
        let run_with = |v: Option<&Image<f32>>| {
            let mut c = s.color.clone();
            let mut scratch = DenoiseScratch::default();
            denoise_with_variance(
                &mut c,
                &s.depth,
                &s.albedo,
                &s.normal,
                None,
                v,
                &rect(&s),
                &p,
                &mut scratch,
            )
            .unwrap();
            c
        };
        let spatial = run_with(None);
        let blurred = (spatial.get(15, 8)[0] - s.color.get(15, 8)[0]).abs();
        assert!(
            blurred > 0.01,
            "the spatial estimate let the step through: {blurred}"
        );
        let zero = Image::new(w, h, 0.0f32).unwrap();
        let kept = run_with(Some(&zero));
        for (o, c) in kept.data().iter().zip(s.color.data()) {
            assert!((o[0] - c[0]).abs() <= 1e-6, "{o:?} vs {c:?}");
        }
        let unknown = Image::new(w, h, f32::NAN).unwrap();
        assert_eq!(run_with(Some(&unknown)).data(), spatial.data());
        // A variance of the wrong size is refused.
        let small = Image::new(w - 1, h, 0.0f32).unwrap();
        let mut c = s.color.clone();
        assert!(denoise_with_variance(
            &mut c,
            &s.depth,
            &s.albedo,
            &s.normal,
            None,
            Some(&small),
            &rect(&s),
            &p,
            &mut DenoiseScratch::default(),
        )
        .is_err());
    }

    #[test]
    fn a_constant_light_stays_constant_under_any_texture() {
        let s = scene(
            (40, 30),
            |_, _| [0.7, 0.3, 1.2],
            texture,
            |i, j| 2.0 + 0.01 * i as f32 + 0.02 * j as f32,
            |_, _| [0.0, 0.0, 1.0],
        );
        let (out, st) = run(&s, &rect(&s), &DenoiseParams::default());
        assert_eq!(st.filtered, 40 * 30);
        for (o, c) in out.data().iter().zip(s.color.data()) {
            for k in 0..3 {
                assert!((o[k] - c[k]).abs() <= 1e-5 * c[k].abs(), "{o:?} vs {c:?}");
            }
        }
    }

    #[test]
    fn demodulation_round_trip_is_exact_to_rounding() {
        let mut rng = Rng(7);
        for _ in 0..10_000 {
            let c: Rgb = std::array::from_fn(|_| rng.next() * 10.0);
            let a: Rgb = std::array::from_fn(|_| rng.next());
            let back = remodulate(demodulate(c, a), a);
            for k in 0..3 {
                // At most one rounding of the division and one of the product: 2 ulp.
                assert!(
                    (back[k] - c[k]).abs() <= 2.0 * f32::EPSILON * c[k],
                    "{c:?} {a:?}"
                );
            }
        }
        // A texel with no neighbour on its surface (every neighbour faces away) comes back
        // as it went in.
        let s = scene(
            (9, 9),
            |i, j| [1.0 + i as f32, 0.5 * j as f32, 0.3],
            texture,
            |_, _| 1.0,
            |i, j| {
                if (i + j) % 2 == 0 {
                    [0.0, 0.0, 1.0]
                } else {
                    [0.0, 0.0, -1.0]
                }
            },
        );
        // Same-parity neighbours share a normal; make each texel's light unique per parity
        // class and the luminance tolerance tiny so nothing is averaged.
        let p = DenoiseParams {
            sigma_luminance: 1e-6,
            firefly_k: None,
            ..DenoiseParams::default()
        };
        let (out, _) = run(&s, &rect(&s), &p);
        for j in 0..9 {
            for i in 0..9 {
                let (o, c) = (out.get(i, j), s.color.get(i, j));
                for k in 0..3 {
                    assert!((o[k] - c[k]).abs() <= 2.0 * f32::EPSILON * c[k].abs());
                }
            }
        }
    }

    #[test]
    fn depth_and_normal_edges_are_not_blurred_across() {
        let mut rng = Rng(11);
        let noise: Vec<f32> = (0..48 * 32).map(|_| rng.gauss()).collect();
        let light = |i: u32, j: u32| {
            let base = if i < 24 { 1.0 } else { 0.2 };
            let v = base * (1.0 + 0.5 * noise[(j * 48 + i) as usize]).max(0.0);
            [v, v, v]
        };
        // (depth, normal) on each side: a depth step, then a normal crease at one depth.
        type Side = fn(u32) -> (f32, [f32; 3]);
        let cases: [Side; 2] = [
            |i| (if i < 24 { 1.0 } else { 5.0 }, [0.0, 0.0, 1.0]),
            |i| {
                (
                    2.0,
                    if i < 24 {
                        [0.0, 0.0, 1.0]
                    } else {
                        [1.0, 0.0, 0.0]
                    },
                )
            },
        ];
        for side in cases {
            let full = scene(
                (48, 32),
                light,
                |_, _| [0.5; 3],
                |i, _| side(i).0,
                |i, _| side(i).1,
            );
            // The left half alone: the right half has no surface record.
            let left = scene(
                (48, 32),
                light,
                |_, _| [0.5; 3],
                |i, _| side(i).0,
                |i, _| if i < 24 { side(i).1 } else { [0.0; 3] },
            );
            let (a, _) = run(&full, &rect(&full), &DenoiseParams::default());
            let (b, _) = run(&left, &rect(&left), &DenoiseParams::default());
            let mut filtered = 0.0f64;
            for j in 0..32 {
                for i in 0..24 {
                    let (x, y) = (a.get(i, j), b.get(i, j));
                    assert!((x[0] - y[0]).abs() <= 1e-6 * y[0].abs().max(1.0), "{i},{j}");
                    filtered += (x[0] - full.color.get(i, j)[0]).abs() as f64;
                }
            }
            // And the left half was filtered at all.
            assert!(filtered > 1.0, "{filtered}");
        }
    }

    #[test]
    fn noise_on_a_flat_region_falls_by_a_measured_factor() {
        let (w, h) = (96u32, 96u32);
        let mut rng = Rng(3);
        let noise: Vec<f32> = (0..w * h).map(|_| rng.gauss()).collect();
        let s = scene(
            (w, h),
            |i, j| {
                let v = 1.0 + 0.3 * noise[(j * w + i) as usize];
                [v, v, v]
            },
            texture,
            |i, _| 3.0 + 0.002 * i as f32,
            |_, _| [0.0, 0.6, 0.8],
        );
        // Variance of the demodulated light in the interior (away from the border).
        let var = |img: &Image<Rgb>| {
            let v: Vec<f64> = (8..h - 8)
                .flat_map(|j| (8..w - 8).map(move |i| (i, j)))
                .map(|(i, j)| (img.get(i, j)[1] / s.albedo.get(i, j)[1]) as f64)
                .collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (
                v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64,
                m,
            )
        };
        // Measured: 80x (3x3, the default) and 168x (5x5), 4 iterations each.
        for (kernel, least) in [(Kernel::Linear3x3, 30.0), (Kernel::B3Spline5x5, 60.0)] {
            let p = DenoiseParams {
                kernel,
                ..DenoiseParams::default()
            };
            let (out, _) = run(&s, &rect(&s), &p);
            let ((before, m0), (after, m1)) = (var(&s.color), var(&out));
            let factor = before / after;
            eprintln!("flat region, {kernel:?}: variance {before:.5} -> {after:.6} (x{factor:.1} lower), mean {m0:.4} -> {m1:.4}");
            assert!(
                factor > least,
                "{kernel:?}: variance fell only {factor:.2}x"
            );
            // The mean survives (the firefly clamp takes a little off the top).
            assert!((m1 - m0).abs() < 0.02, "{m0} -> {m1}");
        }
    }

    #[test]
    fn a_firefly_is_clamped_and_nan_does_not_spread() {
        let (w, h) = (32u32, 32u32);
        let mut rng = Rng(5);
        let noise: Vec<f32> = (0..w * h).map(|_| rng.gauss()).collect();
        let light = |i: u32, j: u32| {
            let v = 1.0 + 0.2 * noise[(j * w + i) as usize];
            [v, v, v]
        };
        let mut s = scene(
            (w, h),
            light,
            |_, _| [0.5; 3],
            |_, _| 2.0,
            |_, _| [0.0, 0.0, 1.0],
        );
        // A firefly, a NaN and an infinity.
        *s.color.get_mut(10, 10) = [500.0; 3];
        *s.color.get_mut(20, 5) = [f32::NAN, 0.5, 0.5];
        *s.color.get_mut(5, 20) = [f32::INFINITY; 3];
        let (out, st) = run(&s, &rect(&s), &DenoiseParams::default());
        assert!(st.clamped >= 1);
        assert!(out.data().iter().all(|c| c.iter().all(|v| v.is_finite())));
        // The firefly's neighbourhood is not lifted: every texel within 1.5 of the base.
        for c in out.data() {
            assert!(c[0] < 0.75 && c[0] > 0.25, "{c:?}");
        }
        // The bad texels are filled from their neighbours, and nobody read them: the rest
        // equals the frame where they have no surface record at all.
        let mut masked = scene(
            (w, h),
            light,
            |_, _| [0.5; 3],
            |_, _| 2.0,
            |_, _| [0.0, 0.0, 1.0],
        );
        *masked.color.get_mut(10, 10) = [500.0; 3];
        for (i, j) in [(20, 5), (5, 20)] {
            *masked.normal.get_mut(i, j) = [0.0; 3];
        }
        let (m, _) = run(&masked, &rect(&masked), &DenoiseParams::default());
        for j in 0..h {
            for i in 0..w {
                if [(20, 5), (5, 20)].contains(&(i, j)) {
                    continue;
                }
                assert!((out.get(i, j)[0] - m.get(i, j)[0]).abs() < 1e-6, "{i},{j}");
            }
        }
    }

    #[test]
    fn only_the_monte_carlo_part_is_filtered() {
        let (w, h) = (64u32, 64u32);
        let mut rng = Rng(9);
        let noise: Vec<f32> = (0..w * h).map(|_| rng.gauss()).collect();
        // An exact part with sharp, strong detail (a light's hard shadows) and a noisy
        // environment part on a textured albedo.
        let exact = |i: u32, j: u32| -> Rgb {
            if (i / 4 + j / 4) % 2 == 0 {
                [5.0; 3]
            } else {
                [0.0; 3]
            }
        };
        let mut s = scene(
            (w, h),
            |i, j| {
                let v = 1.0 + 0.3 * noise[(j * w + i) as usize];
                [v, v, v]
            },
            texture,
            |_, _| 2.0,
            |_, _| [0.0, 0.0, 1.0],
        );
        let noisy = s.color.clone();
        for j in 0..h {
            for i in 0..w {
                let c = s.color.get_mut(i, j);
                let e = exact(i, j);
                *c = std::array::from_fn(|k| c[k] + e[k]);
            }
        }
        // The error against the exact part plus the noise-free environment (1 · albedo).
        let error = |out: &Image<Rgb>| {
            let mut e = 0.0f64;
            for j in 8..h - 8 {
                for i in 8..w - 8 {
                    let (o, x, a) = (out.get(i, j), exact(i, j), s.albedo.get(i, j));
                    e += (0..3)
                        .map(|k| ((o[k] - x[k] - a[k]) as f64).powi(2))
                        .sum::<f64>();
                }
            }
            e / ((w - 16) * (h - 16) * 3) as f64
        };
        let before = error(&s.color);
        let (whole, _) = run(&s, &rect(&s), &DenoiseParams::default());
        s.noisy = Some(noisy);
        let (split, _) = run(&s, &rect(&s), &DenoiseParams::default());
        let (e_whole, e_split) = (error(&whole), error(&split));
        eprintln!("MSE {before:.2e} noisy, {e_whole:.2e} whole colour filtered, {e_split:.2e} Monte Carlo part filtered");
        // Measured: 185x lower with the split (1.7e-2 -> 9.3e-5); filtering the whole colour
        // blurs the exact part's checker (4.7).
        assert!(before / e_split > 50.0, "{before} -> {e_split}");
        assert!(e_whole / e_split > 100.0, "{e_whole} vs {e_split}");
        // With no Monte Carlo part (noise-free shading) the frame comes back bit for bit.
        s.noisy = Some(Image::new(w, h, [0.0; 3]).unwrap());
        let (same, _) = run(&s, &rect(&s), &DenoiseParams::default());
        assert_eq!(same.data(), s.color.data());
    }

    /// Brute force: the texel nearest (in angle) to the point `i + di` columns out along
    /// `(i, j)`'s direction (a negative radius is the opposite direction), then `dj` rows.
    fn brute_neighbours(
        rows: &[u32],
        period: &[f64],
        i: u32,
        j: u32,
        di: i32,
        dj: i32,
    ) -> Vec<(u32, u32)> {
        use std::f64::consts::TAU;
        let theta = TAU * (j as f64 + 0.5) / period[i as usize];
        let s = i as f64 + di as f64 + 0.5;
        let (px, py) = (s * theta.cos(), s * theta.sin());
        let c = (s.abs() - 0.5).round() as usize;
        if c >= rows.len() {
            return Vec::new();
        }
        let d: Vec<f64> = (0..rows[c])
            .map(|r| {
                let t = TAU * (r as f64 + 0.5) / period[c];
                let r0 = c as f64 + 0.5;
                (r0 * t.cos() - px).hypot(r0 * t.sin() - py)
            })
            .collect();
        let best = d.iter().copied().fold(f64::INFINITY, f64::min);
        d.iter()
            .enumerate()
            .filter(|(_, &v)| v <= best + 1e-9)
            .map(|(r, _)| {
                let n = rows[c] as i64;
                (c as u32, (r as i64 + dj as i64).rem_euclid(n) as u32)
            })
            .collect()
    }

    #[test]
    fn polar_taps_wrap_in_angle_and_cross_the_fovea_by_half_a_turn() {
        let rows = vec![6u32, 9, 14, 20, 27, 33];
        let period: Vec<f64> = rows.iter().map(|&r| r as f64).collect();
        let grid = Grid::Polar {
            rows: rows.clone(),
            period: period.clone(),
        };
        let mut crossed = 0;
        for i in 0..rows.len() as u32 {
            for j in 0..rows[i as usize] {
                for di in -8i32..=8 {
                    for dj in -8i32..=8 {
                        let got = neighbour(&grid, i, j, di, dj);
                        let want = brute_neighbours(&rows, &period, i, j, di, dj);
                        match got {
                            None => assert!(want.is_empty(), "({i},{j})+({di},{dj})"),
                            Some(g) => assert!(
                                want.contains(&g),
                                "({i},{j})+({di},{dj}): {g:?} not in {want:?}"
                            ),
                        }
                        if (i as i32 + di) < 0 {
                            crossed += 1;
                        }
                    }
                }
            }
        }
        assert!(crossed > 1000);
        // The innermost ring's inner neighbour is itself half a turn on; the last row's next
        // row is the first.
        assert_eq!(neighbour(&grid, 0, 1, -1, 0), Some((0, 4)));
        assert_eq!(neighbour(&grid, 2, 13, 0, 1), Some((2, 0)));
        // Rect: past the border is outside, not clamped.
        let r = Grid::Rect {
            width: 4,
            height: 3,
        };
        assert_eq!(neighbour(&r, 0, 0, -1, 0), None);
        assert_eq!(neighbour(&r, 3, 2, 0, 1), None);
        assert_eq!(neighbour(&r, 1, 1, 2, 1), Some((3, 2)));
    }

    #[test]
    fn a_polar_buffer_filters_across_its_seams_and_keeps_constants() {
        let rows = vec![6u32, 9, 14, 20, 27, 33, 40];
        let period: Vec<f64> = rows.iter().map(|&r| r as f64).collect();
        let grid = Grid::Polar {
            rows: rows.clone(),
            period,
        };
        let (w, h) = (rows.len() as u32, 40u32);
        let valid = |i: u32, j: u32| j < rows[i as usize];
        let s = scene(
            (w, h),
            |_, _| [2.0, 1.0, 0.5],
            texture,
            |_, _| 1.5,
            |i, j| {
                if valid(i, j) {
                    [0.0, 0.0, 1.0]
                } else {
                    [0.0; 3]
                }
            },
        );
        let (out, st) = run(&s, &grid, &DenoiseParams::default());
        assert_eq!(st.filtered, rows.iter().map(|&r| r as u64).sum::<u64>());
        for (o, c) in out.data().iter().zip(s.color.data()) {
            for k in 0..3 {
                assert!((o[k] - c[k]).abs() <= 1e-5 * c[k].abs().max(1e-3));
            }
        }
    }

    #[test]
    fn the_fast_exponential_is_within_its_bound() {
        let mut worst = 0.0f64;
        for k in 0..=60_000 {
            let x = k as f32 * 0.001;
            let (got, want) = (exp_neg(x) as f64, (-(x as f64)).exp());
            worst = worst.max((got - want).abs() / want);
        }
        assert!(worst < 3e-4, "{worst}");
        assert_eq!(exp_neg(0.0), 1.0);
    }

    #[test]
    fn bad_parameters_and_sizes_are_refused() {
        for p in [
            DenoiseParams {
                iterations: 0,
                ..DenoiseParams::default()
            },
            DenoiseParams {
                iterations: MAX_ITERATIONS + 1,
                ..DenoiseParams::default()
            },
            DenoiseParams {
                sigma_luminance: f32::NAN,
                ..DenoiseParams::default()
            },
            DenoiseParams {
                normal_power: 0,
                ..DenoiseParams::default()
            },
            DenoiseParams {
                sigma_depth: -1.0,
                ..DenoiseParams::default()
            },
            DenoiseParams {
                firefly_k: Some(0.0),
                ..DenoiseParams::default()
            },
        ] {
            assert!(p.validate().is_err(), "{p:?}");
        }
        let mut c = Image::new(4, 4, [0.0f32; 3]).unwrap();
        let d = Image::new(4, 3, 1.0f32).unwrap();
        let a = Image::new(4, 4, [0.5f32; 3]).unwrap();
        let n = Image::new(4, 4, [0.0f32, 0.0, 1.0]).unwrap();
        let g = Grid::Rect {
            width: 4,
            height: 4,
        };
        let p = DenoiseParams::default();
        let mut s = DenoiseScratch::default();
        assert!(denoise(&mut c, &d, &a, &n, None, &g, &p, &mut s).is_err());
    }
}
