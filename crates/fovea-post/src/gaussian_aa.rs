//! The 3×3 Gaussian (binomial `[1 2 1]/4` per axis, σ ≈ 0.71 px) that KFR/LMFR (Meng et
//! al. 2018) applies inside its log-polar buffer before the inverse mapping, to suppress the
//! aliasing that the buffer's undersampled periphery would otherwise magnify. Uses a [`Grid`],
//! so in a polar buffer it wraps across the angular seam.

use rayon::prelude::*;

use fovea_core::Image;

use crate::grid::Grid;
use crate::Rgb;

/// Applies the 3×3 binomial filter to the grid's valid pixels.
pub fn gaussian_3x3(img: &Image<Rgb>, grid: &Grid) -> Image<Rgb> {
    let w = img.width();
    let mut out = img.clone();
    out.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(j, row)| {
            let j = j as u32;
            for (i, o) in row.iter_mut().enumerate() {
                let i = i as u32;
                if !grid.valid(i, j) {
                    continue;
                }
                let mut acc = [0.0f32; 3];
                for (di, wi) in [(-1, 1.0), (0, 2.0), (1, 1.0)] {
                    for (dj, wj) in [(-1, 1.0), (0, 2.0), (1, 1.0)] {
                        let p = grid.step(i, j, di, dj);
                        let c = img.get(p.0, p.1);
                        let wgt: f32 = wi * wj / 16.0;
                        for k in 0..3 {
                            acc[k] += wgt * c[k];
                        }
                    }
                }
                *o = acc;
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_brute_force_convolution_inside_and_keeps_constants() {
        let (w, h) = (9u32, 7u32);
        let img = Image::from_vec(
            w,
            h,
            (0..w * h)
                .map(|k| [((k * 37) % 11) as f32, k as f32, 1.0])
                .collect(),
        )
        .unwrap();
        let grid = Grid::Rect {
            width: w,
            height: h,
        };
        let out = gaussian_3x3(&img, &grid);
        let k = [1.0, 2.0, 1.0];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let mut s = 0.0;
                for dy in 0..3 {
                    for dx in 0..3 {
                        s +=
                            k[dx] * k[dy] / 16.0 * img.get(x + dx as u32 - 1, y + dy as u32 - 1)[0];
                    }
                }
                assert!((out.get(x, y)[0] - s).abs() < 1e-5);
            }
        }
        assert!(out.data().iter().all(|c| (c[2] - 1.0).abs() < 1e-6));
    }
}
