//! Piecewise-constant distributions in one and two dimensions, sampled by inverting their
//! CDF (pbrt-v4, Pharr, Jakob and Humphreys 2023, Sec. A.1 "Sampling 1D functions" and
//! Sec. A.5.2 `PiecewiseConstant2D`; the same construction as pbrt-v3 `Distribution1D` /
//! `Distribution2D`, Sec. 13.3.1 and 13.6.7).
//!
//! 1D: `n` equal bins over `[0, 1)` with non-negative values `f_i`; `∫f = Σ f_i / n`,
//! `cdf_0 = 0`, `cdf_{i+1} = cdf_i + f_i / (n ∫f)`, `cdf_n = 1`. Sampling `u ∈ [0, 1)` finds
//! the bin `o` with `cdf_o ≤ u < cdf_{o+1}` and returns `x = (o + (u − cdf_o)/(cdf_{o+1} −
//! cdf_o)) / n` with density `p(x) = f_o / ∫f`; [`Distribution1D::invert`] maps `x` back to
//! `u`. A function that is zero everywhere (or not finite) is replaced by a constant, so
//! every distribution can be sampled.
//!
//! 2D over `[0, 1)²`: one conditional 1D distribution per row (along `u`) and a marginal over
//! the rows' integrals (along `v`); `p(u, v) = p(v) · p(u | v) = f(u, v) / ∫∫f`.

/// A piecewise-constant density on `[0, 1)` with `n` equal bins.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// Bin values (non-negative).
    func: Vec<f32>,
    /// `n + 1` cumulative values, `cdf[0] = 0`, `cdf[n] = 1`.
    cdf: Vec<f32>,
    /// `∫₀¹ f = Σ f_i / n`.
    func_int: f32,
}

impl Distribution1D {
    /// The distribution of `func` (at least one bin; negative or non-finite values count as 0;
    /// an all-zero function becomes a constant one).
    pub fn new(func: &[f32]) -> Self {
        let n = func.len().max(1);
        let mut f: Vec<f32> = func
            .iter()
            .map(|&v| if v.is_finite() && v > 0.0 { v } else { 0.0 })
            .collect();
        f.resize(n, 0.0);
        // Accumulate in f64: a row of 16k bins keeps full f32 precision.
        let mut sum = 0.0f64;
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f64);
        for &v in &f {
            sum += v as f64;
            cdf.push(sum);
        }
        if !(sum > 0.0 && sum.is_finite()) {
            f.iter_mut().for_each(|v| *v = 1.0);
            sum = n as f64;
            cdf = (0..=n).map(|i| i as f64).collect();
        }
        let mut cdf: Vec<f32> = cdf.iter().map(|&c| (c / sum) as f32).collect();
        cdf[n] = 1.0;
        Self {
            func: f,
            cdf,
            func_int: (sum / n as f64) as f32,
        }
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Always false: a distribution has at least one bin.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// `∫₀¹ f(x) dx` (of the function after the constant fallback).
    pub fn integral(&self) -> f32 {
        self.func_int
    }

    /// The bin values (after the constant fallback): another executor's copy of the table.
    pub fn values(&self) -> &[f32] {
        &self.func
    }

    /// The `n + 1` cumulative values, `cdf[0] = 0`, `cdf[n] = 1`.
    pub fn cdf(&self) -> &[f32] {
        &self.cdf
    }

    /// The largest `x` [`Self::sample`] returns (`1 − ε/2`).
    pub const X_MAX: f32 = 1.0 - f32::EPSILON / 2.0;

    /// Bin holding `x ∈ [0, 1]` (clamped).
    #[inline]
    fn bin(&self, x: f32) -> usize {
        let n = self.func.len();
        let k = (x * n as f32).floor();
        if k.is_finite() && k > 0.0 {
            (k as usize).min(n - 1)
        } else {
            0
        }
    }

    /// Samples `u ∈ [0, 1)`: `(x ∈ [0, 1), p(x), bin)`.
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // Last bin whose cdf ≤ u (zero-width bins are skipped).
        let o = self
            .cdf
            .partition_point(|&c| c <= u)
            .saturating_sub(1)
            .min(n - 1);
        let width = self.cdf[o + 1] - self.cdf[o];
        let du = if width > 0.0 {
            ((u - self.cdf[o]) / width).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = ((o as f32 + du) / n as f32).min(Self::X_MAX);
        (x, self.func[o] / self.func_int, o)
    }

    /// Density at `x ∈ [0, 1]`: `f(x) / ∫f`.
    pub fn pdf(&self, x: f32) -> f32 {
        self.func[self.bin(x)] / self.func_int
    }

    /// The `u` that [`Self::sample`] maps to `x`; `None` when `x` lies in a zero bin (never
    /// sampled).
    pub fn invert(&self, x: f32) -> Option<f32> {
        let o = self.bin(x);
        if self.func[o] == 0.0 {
            return None;
        }
        let n = self.func.len() as f32;
        let delta = (x * n - o as f32).clamp(0.0, 1.0);
        Some(self.cdf[o] + delta * (self.cdf[o + 1] - self.cdf[o]))
    }
}

/// A piecewise-constant density on `[0, 1)²` from a `width × height` grid of values, row-major
/// with `v` (rows) down.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    /// One distribution along `u` per row.
    conditional: Vec<Distribution1D>,
    /// The distribution of rows, by their integrals.
    marginal: Distribution1D,
}

impl Distribution2D {
    /// The distribution of `func` (`width · height` values, row-major; `width`, `height` ≥ 1).
    pub fn new(func: &[f32], width: usize, height: usize) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let conditional: Vec<Distribution1D> = (0..height)
            .map(|j| {
                let row = func.get(j * width..(j + 1) * width).unwrap_or(&[]);
                Distribution1D::new(row)
            })
            .collect();
        // Rows that were all zero became constant: their weight in the marginal stays 0.
        let row_int: Vec<f32> = (0..height)
            .map(|j| {
                let row = func.get(j * width..(j + 1) * width).unwrap_or(&[]);
                let s: f64 = row
                    .iter()
                    .filter(|v| v.is_finite() && **v > 0.0)
                    .map(|&v| v as f64)
                    .sum();
                (s / width as f64) as f32
            })
            .collect();
        Self {
            conditional,
            marginal: Distribution1D::new(&row_int),
        }
    }

    /// The distributions along `u`, one per row.
    pub fn conditionals(&self) -> &[Distribution1D] {
        &self.conditional
    }

    /// The distribution of rows.
    pub fn marginal(&self) -> &Distribution1D {
        &self.marginal
    }

    /// Samples `u ∈ [0, 1)²`: `((u, v), p(u, v))`.
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let (v, pdf_v, row) = self.marginal.sample(u[1]);
        let (x, pdf_u, _) = self.conditional[row].sample(u[0]);
        ([x, v], pdf_u * pdf_v)
    }

    /// Density at `(u, v) ∈ [0, 1]²`.
    pub fn pdf(&self, uv: [f32; 2]) -> f32 {
        let row = self.marginal.bin(uv[1]);
        self.marginal.pdf(uv[1]) * self.conditional[row].pdf(uv[0])
    }

    /// The `u` that [`Self::sample`] maps to `uv`; `None` where the density is 0.
    pub fn invert(&self, uv: [f32; 2]) -> Option<[f32; 2]> {
        let v = self.marginal.invert(uv[1])?;
        let row = self.marginal.bin(uv[1]);
        let u = self.conditional[row].invert(uv[0])?;
        Some([u, v])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_dimensional_sample_invert_and_pdf_agree() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]);
        assert!((d.integral() - 2.0).abs() < 1e-6);
        for k in 0..1000 {
            let u = (k as f32 + 0.5) / 1000.0;
            let (x, pdf, o) = d.sample(u);
            assert_ne!(o, 1, "a zero bin is never sampled (u = {u})");
            assert!((pdf - d.pdf(x)).abs() < 1e-6);
            let back = d.invert(x).unwrap();
            assert!((back - u).abs() < 1e-5, "u {u} → x {x} → {back}");
        }
        // Bin shares: 1/8, 0, 3/8, 4/8.
        assert!((d.sample(0.124).0 - 0.248).abs() < 1e-5);
        assert!(d.invert(0.3).is_none());
        // All-zero and NaN functions sample uniformly.
        let z = Distribution1D::new(&[0.0, f32::NAN, 0.0]);
        assert!((z.pdf(0.5) - 1.0).abs() < 1e-6);
        assert!((z.sample(0.5).0 - 0.5).abs() < 1e-6);
    }

    #[test]
    fn two_dimensional_density_integrates_to_one_and_matches_a_histogram() {
        let (w, h) = (8usize, 4usize);
        let func: Vec<f32> = (0..w * h)
            .map(|k| ((k * 7) % 5) as f32 + if k % 3 == 0 { 0.0 } else { 0.5 })
            .collect();
        let d = Distribution2D::new(&func, w, h);
        // ∫∫ p = Σ p(bin centre) / (w h).
        let integral: f32 = (0..w * h)
            .map(|k| {
                let uv = [
                    ((k % w) as f32 + 0.5) / w as f32,
                    ((k / w) as f32 + 0.5) / h as f32,
                ];
                d.pdf(uv)
            })
            .sum::<f32>()
            / (w * h) as f32;
        assert!((integral - 1.0).abs() < 1e-5, "{integral}");
        // A stratified 256² sample set lands in each bin in proportion to its value.
        let total: f32 = func.iter().sum();
        let mut hist = vec![0u32; w * h];
        let n = 256;
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                let (uv, pdf) = d.sample(u);
                assert!((pdf - d.pdf(uv)).abs() < 1e-4 * pdf.max(1.0));
                let back = d.invert(uv).unwrap();
                assert!((back[0] - u[0]).abs() < 1e-4 && (back[1] - u[1]).abs() < 1e-4);
                let bin = (uv[1] * h as f32) as usize * w + (uv[0] * w as f32) as usize;
                hist[bin] += 1;
            }
        }
        for (k, &c) in hist.iter().enumerate() {
            let expected = func[k] / total;
            let got = c as f32 / (n * n) as f32;
            assert!(
                (got - expected).abs() < 2e-3,
                "bin {k}: {got} vs {expected}"
            );
        }
    }
}
