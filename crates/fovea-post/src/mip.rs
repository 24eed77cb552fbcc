//! Mip pyramid of a `C`-channel image (2×2 box reduction) with bilinear and Quincunx
//! lookups, as Weier et al. 2018 use it three times: the reprojection cache (Sec. 3.1, Fig. 3),
//! the peripheral blur of the layered DOF filter (Sec. 3.2) and the eccentricity-wide blur of
//! the peripheral contrast enhancement ("DoF Combine").
//!
//! **Footprint.** A level-`L` texel of side `b = 2^L` (box, variance `b²/12`), bilinear
//! reconstruction (tent, `b²/6`) and the Quincunx taps (centre ½, four corners ⅛ at
//! `(±b/2, ±b/2)`, `b²/8`) add up to `σ² ≈ 0.375·b²`, so a footprint of standard deviation
//! `σ` reads level `L = log₂(σ / 0.612)`, fractional levels blended trilinearly.

use rayon::prelude::*;

/// σ of the footprint of one Quincunx-sampled mip texel of side `b`, over `b`.
pub const MIP_SIGMA_PER_TEXEL: f32 = 0.612;

/// A 2×2-box mip pyramid of a `C`-channel layer.
pub struct MipPyramid<const C: usize> {
    levels: Vec<(usize, usize, Vec<[f32; C]>)>,
}

impl<const C: usize> MipPyramid<C> {
    /// A pyramid deep enough for Quincunx footprints up to `max_sigma_px` (one more level
    /// for the trilinear blend).
    pub fn for_sigma(w: usize, h: usize, layer: &[[f32; C]], max_sigma_px: f32) -> Self {
        let top = (max_sigma_px / MIP_SIGMA_PER_TEXEL).max(1.0).log2().ceil() as usize + 1;
        Self::new(w, h, layer, top)
    }

    /// Levels `0 ..= top` (fewer where the image reaches 1×1 first); level 0 is `layer`.
    /// `layer.len()` must be `w·h`.
    pub fn new(w: usize, h: usize, layer: &[[f32; C]], top: usize) -> Self {
        assert_eq!(layer.len(), w * h, "layer size");
        let mut levels = vec![(w, h, layer.to_vec())];
        while levels.len() <= top {
            let (pw, ph, prev) = levels.last().expect("level 0 exists");
            let (pw, ph) = (*pw, *ph);
            if pw == 1 && ph == 1 {
                break;
            }
            let (nw, nh) = (pw.div_ceil(2), ph.div_ceil(2));
            let next: Vec<[f32; C]> = (0..nw * nh)
                .into_par_iter()
                .map(|k| {
                    let (x, y) = (k % nw, k / nw);
                    let mut acc = [0.0f32; C];
                    let mut n = 0.0f32;
                    for yy in 2 * y..(2 * y + 2).min(ph) {
                        for xx in 2 * x..(2 * x + 2).min(pw) {
                            let q = &prev[yy * pw + xx];
                            for c in 0..C {
                                acc[c] += q[c];
                            }
                            n += 1.0;
                        }
                    }
                    acc.map(|v| v / n)
                })
                .collect();
            levels.push((nw, nh, next));
        }
        Self { levels }
    }

    /// Bilinear sample of level `l` at screen position `(sx, sy)` (pixels, continuous).
    #[inline]
    pub fn bilinear(&self, l: usize, sx: f32, sy: f32) -> [f32; C] {
        let (lw, lh, data) = &self.levels[l];
        let scale = (1u32 << l) as f32;
        let u = (sx / scale - 0.5).clamp(0.0, (*lw - 1) as f32);
        let v = (sy / scale - 0.5).clamp(0.0, (*lh - 1) as f32);
        let (x0, y0) = (u.floor() as usize, v.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(lw - 1), (y0 + 1).min(lh - 1));
        let (fx, fy) = (u - x0 as f32, v - y0 as f32);
        let p = |x: usize, y: usize| &data[y * lw + x];
        let (a, b, c, d) = (p(x0, y0), p(x1, y0), p(x0, y1), p(x1, y1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bot = c[k] + (d[k] - c[k]) * fx;
            top + (bot - top) * fy
        })
    }

    /// Number of levels.
    pub fn len(&self) -> usize {
        self.levels.len()
    }

    /// Always false: level 0 exists.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Level `l`: `(width, height, texels)`.
    pub fn level(&self, l: usize) -> (usize, usize, &[[f32; C]]) {
        let (w, h, d) = &self.levels[l];
        (*w, *h, d)
    }

    /// Quincunx (centre ½, corners ⅛ at `±b/2`) trilinear sample whose footprint has
    /// standard deviation ≈ `sigma_px`.
    pub fn quincunx(&self, sx: f32, sy: f32, sigma_px: f32) -> [f32; C] {
        let b = sigma_px / MIP_SIGMA_PER_TEXEL;
        let lf = b.max(1.0).log2().min((self.levels.len() - 1) as f32);
        let l0 = lf.floor() as usize;
        let l1 = (l0 + 1).min(self.levels.len() - 1);
        let f = lf - l0 as f32;
        let o = 0.5 * b;
        let taps = [
            (0.0, 0.0, 0.5),
            (-o, -o, 0.125),
            (o, -o, 0.125),
            (-o, o, 0.125),
            (o, o, 0.125),
        ];
        let mut acc = [0.0f32; C];
        for (dx, dy, wt) in taps {
            let s0 = self.bilinear(l0, sx + dx, sy + dy);
            let s1 = if f > 0.0 {
                self.bilinear(l1, sx + dx, sy + dy)
            } else {
                s0
            };
            for c in 0..C {
                acc[c] += wt * (s0[c] + (s1[c] - s0[c]) * f);
            }
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_footprint_sigma_matches_the_target() {
        // A single bright pixel sampled through the pyramid: the second moment of the
        // response, averaged over the pixel's position within the mip blocks, should be
        // close to the requested σ.
        let (w, h) = (96usize, 8usize);
        for sigma in [2.0f32, 3.0, 4.0, 6.0, 8.0] {
            let mut var = 0.0f32;
            for p in 40..56usize {
                let mut layer = vec![[0.0f32; 1]; w * h];
                layer[4 * w + p] = [1.0];
                let pyr = MipPyramid::for_sigma(w, h, &layer, sigma);
                let (mut m0, mut m2) = (0.0f32, 0.0f32);
                for y in 0..h {
                    for x in 0..w {
                        let v = pyr.quincunx(x as f32 + 0.5, y as f32 + 0.5, sigma)[0];
                        let dx = x as f32 - p as f32;
                        m0 += v;
                        m2 += v * dx * dx;
                    }
                }
                var += m2 / m0 / 16.0;
            }
            let s = var.sqrt();
            eprintln!("mip footprint: target σ {sigma}, measured {s:.2}");
            assert!((s / sigma - 1.0).abs() < 0.15, "{sigma}: {s}");
        }
    }
    #[test]
    fn levels_halve_and_average() {
        let layer: Vec<[f32; 1]> = (0..12).map(|k| [k as f32]).collect();
        let p = MipPyramid::new(4, 3, &layer, 5);
        assert_eq!(p.len(), 3);
        let (w1, h1, l1) = p.level(1);
        assert_eq!((w1, h1), (2, 2));
        assert_eq!(l1[0][0], (0.0 + 1.0 + 4.0 + 5.0) / 4.0);
        assert_eq!(l1[2][0], (8.0 + 9.0) / 2.0);
        let (w2, h2, l2) = p.level(2);
        assert_eq!((w2, h2), (1, 1));
        assert!((l2[0][0] - (2.5 + 4.5 + 8.5 + 10.5) / 4.0).abs() < 1e-6);
    }
}
