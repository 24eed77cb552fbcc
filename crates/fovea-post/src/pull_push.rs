//! Pull-push hole filling (Gortler et al. 1996, as used by Weier et al. 2016 to reconstruct
//! their sparse foveated samples): a pyramid where each coarser level averages the weighted
//! samples below it (pull, weights capped at 1), then each finer level fills what it lacks
//! from the bilinearly upsampled coarser level in proportion to its missing weight (push).
//! Shaded pixels keep their value exactly.

use fovea_core::{Image, Result};

use crate::Rgb;

#[derive(Clone)]
struct Level {
    w: u32,
    h: u32,
    c: Vec<Rgb>,
    wt: Vec<f32>,
}

/// Fills the pixels where `mask` is false from the shaded ones.
pub fn pull_push(img: &Image<Rgb>, mask: &Image<bool>) -> Result<Image<Rgb>> {
    let (w, h) = (img.width(), img.height());
    let mut levels = vec![Level {
        w,
        h,
        c: img.data().to_vec(),
        wt: mask
            .data()
            .iter()
            .map(|&m| if m { 1.0 } else { 0.0 })
            .collect(),
    }];
    // Pull.
    while levels.last().is_some_and(|l| l.w > 1 || l.h > 1) {
        let f = levels.last().expect("non-empty");
        let (nw, nh) = (f.w.div_ceil(2), f.h.div_ceil(2));
        let mut c = vec![[0.0f32; 3]; (nw * nh) as usize];
        let mut wt = vec![0.0f32; (nw * nh) as usize];
        for y in 0..nh {
            for x in 0..nw {
                let mut acc = [0.0f32; 3];
                let mut sw = 0.0;
                for dy in 0..2 {
                    for dx in 0..2 {
                        let (sx, sy) = (2 * x + dx, 2 * y + dy);
                        if sx < f.w && sy < f.h {
                            let k = (sy * f.w + sx) as usize;
                            let q = f.wt[k];
                            for ch in 0..3 {
                                acc[ch] += q * f.c[k][ch];
                            }
                            sw += q;
                        }
                    }
                }
                let k = (y * nw + x) as usize;
                if sw > 0.0 {
                    c[k] = acc.map(|a| a / sw);
                }
                wt[k] = sw.min(1.0);
            }
        }
        levels.push(Level {
            w: nw,
            h: nh,
            c,
            wt,
        });
    }
    // Push.
    for l in (0..levels.len() - 1).rev() {
        let (coarse, fine) = {
            let (a, b) = levels.split_at_mut(l + 1);
            (&b[0], &mut a[l])
        };
        for y in 0..fine.h {
            for x in 0..fine.w {
                let k = (y * fine.w + x) as usize;
                let q = fine.wt[k];
                if q >= 1.0 {
                    continue;
                }
                // Bilinear in the coarse level at this pixel's centre.
                let cx = ((x as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (coarse.w - 1) as f32);
                let cy = ((y as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (coarse.h - 1) as f32);
                let (x0, y0) = (cx.floor() as u32, cy.floor() as u32);
                let (x1, y1) = ((x0 + 1).min(coarse.w - 1), (y0 + 1).min(coarse.h - 1));
                let (tx, ty) = (cx - x0 as f32, cy - y0 as f32);
                let at = |xx: u32, yy: u32| coarse.c[(yy * coarse.w + xx) as usize];
                let top = crate::lerp3(at(x0, y0), at(x1, y0), tx);
                let bot = crate::lerp3(at(x0, y1), at(x1, y1), tx);
                let up = crate::lerp3(top, bot, ty);
                for ch in 0..3 {
                    fine.c[k][ch] = q * fine.c[k][ch] + (1.0 - q) * up[ch];
                }
                fine.wt[k] = 1.0;
            }
        }
    }
    Image::from_vec(w, h, std::mem::take(&mut levels[0].c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shaded_pixels_are_kept_and_holes_take_nearby_values() {
        let (w, h) = (32u32, 16u32);
        let img = Image::from_vec(
            w,
            h,
            (0..w * h)
                .map(|k| {
                    if k % w < w / 2 {
                        [1.0, 0.0, 0.0]
                    } else {
                        [0.0, 0.0, 1.0]
                    }
                })
                .collect(),
        )
        .unwrap();
        let mask =
            Image::from_vec(w, h, (0..w * h).map(|k| (k * 7919) % 5 == 0).collect()).unwrap();
        let out = pull_push(&img, &mask).unwrap();
        for k in 0..(w * h) as usize {
            if mask.data()[k] {
                assert_eq!(out.data()[k], img.data()[k]);
            }
        }
        // Far from the colour boundary, holes get the side's colour.
        assert!(out.get(2, 8)[0] > 0.95);
        assert!(out.get(29, 8)[2] > 0.95);
        // A constant image stays constant whatever the mask.
        let flat = Image::new(w, h, [0.25f32; 3]).unwrap();
        let o = pull_push(&flat, &mask).unwrap();
        assert!(o.data().iter().all(|c| (c[1] - 0.25).abs() < 1e-6));
    }
}
