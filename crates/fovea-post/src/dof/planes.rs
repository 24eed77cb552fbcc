//! An exact thin-lens image of a stack of fronto-parallel planes, for testing DOF filters
//! against ground truth without a ray tracer.
//!
//! A thin lens of aperture `τ` focused at `F`, placed at the pinhole, sees through pixel `x`
//! from lens point `a` (in the aperture disc) the scene point on the ray from `a` through the
//! focus-plane point of `x`. At depth `D` that ray meets the pinhole image at
//! `x + a·f_px·(1/D − 1/F) = x − u·c(D)/2`, with `u = 2a/τ` in the unit disc and
//! `c(D) = τ·f_px·(1/F − 1/D)` the signed CoC in pixels ([`super::coc`]). So for each lens
//! sample the pixel shows the nearest plane whose opaque region contains its own shifted
//! point; averaging over the disc gives the thin-lens image exactly (up to the number of lens
//! samples). With `u = 0` it is the pinhole image every filter starts from.

use rayon::prelude::*;

use fovea_core::{FoveaError, Image, Result};

use crate::Rgb;

/// Colour of a plane at a pinhole-image point (pixels, continuous).
pub type PlaneColor = Box<dyn Fn(f32, f32) -> Rgb + Send + Sync>;
/// Whether a plane is opaque at a pinhole-image point.
pub type PlaneMask = Box<dyn Fn(f32, f32) -> bool + Send + Sync>;

/// One fronto-parallel plane.
pub struct Plane {
    /// View depth, metres.
    pub depth_m: f32,
    /// Colour at a pinhole-image point.
    pub color: PlaneColor,
    /// Opaque region, in pinhole-image coordinates.
    pub opaque: PlaneMask,
}

/// Planes in front of a uniform background at infinity.
pub struct PlaneScene {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The planes, in any order.
    pub planes: Vec<Plane>,
    /// Colour where no plane is hit (depth `+∞`).
    pub background: Rgb,
}

impl PlaneScene {
    /// What a ray hitting the pinhole image at `(x, y)` from lens offset `u` sees.
    fn look(&self, x: f32, y: f32, u: [f32; 2], coc: &[f32]) -> (Rgb, f32) {
        let mut best: Option<(f32, usize, f32, f32)> = None;
        for (i, p) in self.planes.iter().enumerate() {
            let sx = x - u[0] * coc[i] * 0.5;
            let sy = y - u[1] * coc[i] * 0.5;
            if best.is_some_and(|b| b.0 <= p.depth_m) {
                continue;
            }
            if (p.opaque)(sx, sy) {
                best = Some((p.depth_m, i, sx, sy));
            }
        }
        match best {
            Some((d, i, sx, sy)) => ((self.planes[i].color)(sx, sy), d),
            None => (self.background, f32::INFINITY),
        }
    }

    /// The pinhole (all-in-focus) colour and depth, sampled at pixel centres.
    pub fn pinhole(&self) -> Result<(Image<Rgb>, Image<f32>)> {
        let (w, h) = (self.width, self.height);
        let coc = vec![0.0f32; self.planes.len()];
        let px: Vec<(Rgb, f32)> = (0..w as usize * h as usize)
            .into_par_iter()
            .map(|k| {
                let (x, y) = ((k % w as usize) as f32 + 0.5, (k / w as usize) as f32 + 0.5);
                self.look(x, y, [0.0, 0.0], &coc)
            })
            .collect();
        Ok((
            Image::from_vec(w, h, px.iter().map(|p| p.0).collect())?,
            Image::from_vec(w, h, px.iter().map(|p| p.1).collect())?,
        ))
    }

    /// The thin-lens image for `px_per_dioptre = τ·f_px` and focus `focus_m`, averaged over
    /// `lens_samples` stratified points of the unit disc (concentric mapping).
    pub fn thin_lens(
        &self,
        px_per_dioptre: f32,
        focus_m: f32,
        lens_samples: u32,
    ) -> Result<Image<Rgb>> {
        if lens_samples == 0
            || focus_m.is_nan()
            || focus_m <= 0.0
            || px_per_dioptre.is_nan()
            || px_per_dioptre < 0.0
        {
            return Err(FoveaError::invalid(
                "thin lens",
                format!("{lens_samples} samples, focus {focus_m} m, {px_per_dioptre} px/D"),
                "≥ 1 sample, focus > 0, px_per_dioptre ≥ 0",
            ));
        }
        let inv_f = if focus_m.is_finite() {
            1.0 / focus_m
        } else {
            0.0
        };
        let coc: Vec<f32> = self
            .planes
            .iter()
            .map(|p| px_per_dioptre * (inv_f - 1.0 / p.depth_m))
            .collect();
        let lens = disc_samples(lens_samples);
        let (w, h) = (self.width, self.height);
        let px: Vec<Rgb> = (0..w as usize * h as usize)
            .into_par_iter()
            .map(|k| {
                let (x, y) = ((k % w as usize) as f32 + 0.5, (k / w as usize) as f32 + 0.5);
                let mut acc = [0.0f32; 3];
                for &u in &lens {
                    let (c, _) = self.look(x, y, u, &coc);
                    for ch in 0..3 {
                        acc[ch] += c[ch];
                    }
                }
                acc.map(|v| v / lens.len() as f32)
            })
            .collect();
        Image::from_vec(w, h, px)
    }
}

/// `n` points of the unit disc: a stratified `m × m` grid (`m = ⌈√n⌉`, cell centres) through
/// Shirley's concentric square-to-disc map, first `n` taken. Uniform in area.
pub fn disc_samples(n: u32) -> Vec<[f32; 2]> {
    let m = (n as f64).sqrt().ceil() as u32;
    let mut out = Vec::with_capacity((m * m) as usize);
    for j in 0..m {
        for i in 0..m {
            let a = 2.0 * (i as f32 + 0.5) / m as f32 - 1.0;
            let b = 2.0 * (j as f32 + 0.5) / m as f32 - 1.0;
            out.push(concentric(a, b));
        }
    }
    // Keep the n points nearest a full stratification: drop evenly spread extras.
    if out.len() > n as usize {
        let stride = out.len() as f64 / n as f64;
        out = (0..n as usize)
            .map(|k| out[(k as f64 * stride) as usize])
            .collect();
    }
    out
}

/// Shirley–Chiu concentric map of `[-1, 1]²` onto the unit disc.
fn concentric(a: f32, b: f32) -> [f32; 2] {
    use std::f32::consts::FRAC_PI_4;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a / b))
    };
    [r * phi.cos(), r * phi.sin()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_samples_are_uniform() {
        let s = disc_samples(256);
        assert_eq!(s.len(), 256);
        assert!(s.iter().all(|p| p[0].hypot(p[1]) <= 1.0 + 1e-6));
        // Mean of r² over a uniform disc is 1/2; mean position 0.
        let r2: f32 = s.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum::<f32>() / 256.0;
        assert!((r2 - 0.5).abs() < 0.01, "{r2}");
        let mx: f32 = s.iter().map(|p| p[0]).sum::<f32>() / 256.0;
        assert!(mx.abs() < 0.01);
    }

    #[test]
    fn single_plane_is_a_disc_blur_of_its_texture() {
        // A bright dot on a dark plane at 2 m, focus 0.5 m: the dot spreads over a disc of
        // |c| = k·(2 − 0.5) pixels diameter, conserving energy.
        let k = 4.0;
        let scene = PlaneScene {
            width: 21,
            height: 21,
            planes: vec![Plane {
                depth_m: 2.0,
                color: Box::new(|x, y| {
                    if (x - 10.5).abs() < 0.5 && (y - 10.5).abs() < 0.5 {
                        [1.0; 3]
                    } else {
                        [0.0; 3]
                    }
                }),
                opaque: Box::new(|_, _| true),
            }],
            background: [0.0; 3],
        };
        let img = scene.thin_lens(k, 0.5, 1024).unwrap();
        let c = k * (1.0 / 0.5 - 1.0 / 2.0); // 6 px
        let total: f32 = img.data().iter().map(|p| p[0]).sum();
        assert!((total - 1.0).abs() < 0.05, "{total}");
        // Nothing beyond the disc radius (+1 px for the dot's extent).
        for y in 0..21u32 {
            for x in 0..21u32 {
                let r = ((x as f32 - 10.0).powi(2) + (y as f32 - 10.0).powi(2)).sqrt();
                if r > c / 2.0 + 1.5 {
                    assert_eq!(img.get(x, y)[0], 0.0);
                }
            }
        }
        let (pin, depth) = scene.pinhole().unwrap();
        assert_eq!(pin.get(10, 10)[0], 1.0);
        assert_eq!(*depth.get(0, 0), 2.0);
    }
}
