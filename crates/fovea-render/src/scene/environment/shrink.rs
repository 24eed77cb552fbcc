//! Reducing a latitude-longitude map by an integer factor `f` while its rows arrive, top to
//! bottom, so only the reduced map is ever held.
//!
//! Output pixel `(i', j')` gathers the input pixels `(i, j)` with `⌊i/f⌋ = i'` and
//! `⌊j/f⌋ = j'` (the last column and row of blocks may be narrower), each weighted by its
//! solid angle: `L' = Σ L_ij ΔΩ_j / Σ ΔΩ_j` with `ΔΩ_j ∝ cos(π j/h) − cos(π (j+1)/h)` (the
//! row's band; every pixel of a row spans the same `2π/w`). The reduced map's solid-angle
//! integral `Σ L' ΔΩ'` equals the input's exactly when `f` divides `h` (the output row's band
//! is then the union of its input rows' bands); otherwise it differs by the mismatch of the
//! last band, a fraction of one output row near the pole, where `ΔΩ → 0`.

use glam::{DVec3, Vec3};

/// The reduction in progress.
#[derive(Debug)]
pub struct Shrink {
    factor: u32,
    width: u32,
    height: u32,
    out_width: u32,
    /// Weighted sums of the output row being gathered.
    acc: Vec<DVec3>,
    /// Sum of the weights of each pixel of that row.
    weight: Vec<f64>,
    /// The reduced map, rows finished so far.
    out: Vec<Vec3>,
}

impl Shrink {
    /// A reduction of a `width × height` map by `factor` (≥ 1).
    pub fn new(width: u32, height: u32, factor: u32) -> Self {
        let factor = factor.max(1);
        let out_width = width.div_ceil(factor);
        let out_height = height.div_ceil(factor);
        Self {
            factor,
            width,
            height,
            out_width,
            acc: vec![DVec3::ZERO; out_width as usize],
            weight: vec![0.0; out_width as usize],
            out: Vec::with_capacity(out_width as usize * out_height as usize),
        }
    }

    /// Size of the reduced map.
    pub fn out_size(&self) -> (u32, u32) {
        (self.out_width, self.height.div_ceil(self.factor))
    }

    /// Adds input row `y` (rows must come in order, each `width` pixels long).
    pub fn push_row(&mut self, y: u32, row: &[Vec3]) {
        let h = f64::from(self.height);
        let pi = std::f64::consts::PI;
        let band = (pi * f64::from(y) / h).cos() - (pi * f64::from(y + 1) / h).cos();
        let f = self.factor as usize;
        for (i, &p) in row.iter().enumerate().take(self.width as usize) {
            self.acc[i / f] += p.as_dvec3() * band;
            self.weight[i / f] += band;
        }
        if (y + 1) % self.factor == 0 || y + 1 == self.height {
            for (a, w) in self.acc.iter_mut().zip(&mut self.weight) {
                let v = if *w > 0.0 { *a / *w } else { DVec3::ZERO };
                self.out.push(v.as_vec3());
                *a = DVec3::ZERO;
                *w = 0.0;
            }
        }
    }

    /// The reduced map, row-major from the top row.
    pub fn finish(self) -> Vec<Vec3> {
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_block_is_the_solid_angle_weighted_mean_of_its_pixels() {
        // 4 × 4 map, factor 2: rows 0 and 1 have bands 1 − cos(π/4) and cos(π/4) − 0.
        let mut s = Shrink::new(4, 4, 2);
        assert_eq!(s.out_size(), (2, 2));
        let rows = [1.0f32, 3.0, 5.0, 7.0];
        for (y, v) in rows.iter().enumerate() {
            s.push_row(y as u32, &[Vec3::splat(*v); 4]);
        }
        let out = s.finish();
        let c = std::f64::consts::FRAC_1_SQRT_2;
        let top = (1.0 * (1.0 - c) + 3.0 * c) / 1.0;
        assert!((f64::from(out[0].x) - top).abs() < 1e-6, "{out:?}");
        assert_eq!(out[0], out[1]);
        let bottom = (5.0 * c + 7.0 * (1.0 - c)) / 1.0;
        assert!((f64::from(out[2].x) - bottom).abs() < 1e-6, "{out:?}");
    }
}
