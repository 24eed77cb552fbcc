//! Depth-aware bilateral DOF filter — Konrad, "Depth of Field Rendering Algorithms for
//! Virtual Reality", Sec. III-C, on the bilateral filter of Tomasi and Manduchi (1998).
//!
//! A bilateral filter whose spatial extent follows the centre pixel's circle of confusion,
//! with the range kernel on colour — replaced by a kernel on depth where the centre is
//! nearer than the focal plane, so that a blurred background does not bleed into a
//! foreground (Konrad: "I replaced the range filter with a depth filter which is used if a
//! pixel is closer than the focal plane"). With `r_C = clamp(|c_C|/2, ½, max_radius_px)` the
//! centre's CoC radius in pixels:
//!
//! ```text
//! σ_s = sigma_per_radius · r_C                     (a disc of radius r has σ = r/2 per axis)
//! G_s(P) = exp(−|P−C|² / 2σ_s²),  |P−C| ≤ 3 σ_s
//! G_r(P) = exp(−|rgb_P − rgb_C|² / 2σ_rgb²)       if c_C ≥ 0 (at or behind the focal plane)
//!        = exp(−(1/z_P − 1/z_C)² / 2σ_D²)          if c_C < 0 (in front of it; z in metres)
//! out(C) = Σ G_s G_r rgb_P / Σ G_s G_r
//! ```
//!
//! The depth kernel is in dioptres (`1/z`), so it is scale-free and `z = +∞` is 0 D.
//!
//! What it cannot do: it gathers with the *centre's* radius, so a blurred foreground never
//! spreads over an in-focus background — silhouettes of out-of-focus foreground objects stay
//! hard (Konrad's Fig. 4 artefact). Leakage onto an in-focus foreground cannot happen either
//! (its radius is ½ px: the pixel keeps its value). The colour range kernel also keeps
//! high-contrast texture inside a blurred region sharper than a lens would.
//!
//! Zero CoC everywhere returns the input unchanged; the support is bounded by
//! `max_radius_px`; rows run in parallel with one `exp` per tap.

use fovea_core::{FoveaError, Image, Result};

use super::disc::{
    accumulate, check_max_radius, for_each_tap, map_pixels, normalise, Disc, Prepared,
};
use super::{DofFilter, DofInput};
use crate::Rgb;

/// Konrad's depth-aware bilateral filter.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthBilateral {
    /// Largest support radius in pixels (radii are clamped to it). Default 32, valid
    /// `[0.5, 256]`.
    pub max_radius_px: f32,
    /// Spatial σ per pixel of CoC radius. Default 0.5 (the per-axis σ of a uniform disc),
    /// valid `(0, 2]`.
    pub sigma_per_radius: f32,
    /// Colour range σ (linear RGB, Euclidean). Default 1.0, valid `> 0`. Not physical: the
    /// larger, the closer to a plain Gaussian blur (0.3 keeps a sharp foreground's colour off
    /// the blurred background beside it but leaves textures behind the focus half sharp).
    pub sigma_rgb: f32,
    /// Depth range σ in dioptres, used where the centre is in front of the focal plane.
    /// Default 0.25 D, valid `> 0`.
    pub sigma_dioptre: f32,
    /// Use the depth kernel behind the focal plane too (default `false`, Konrad's filter).
    /// With `true` a sharp foreground no longer spreads a halo over the blurred background
    /// beside it and textures behind the focal plane blur like a plain Gaussian.
    pub depth_kernel_everywhere: bool,
}

impl Default for DepthBilateral {
    fn default() -> Self {
        Self {
            max_radius_px: 32.0,
            sigma_per_radius: 0.5,
            sigma_rgb: 1.0,
            sigma_dioptre: 0.25,
            depth_kernel_everywhere: false,
        }
    }
}

impl DepthBilateral {
    fn check(&self) -> Result<()> {
        check_max_radius(self.max_radius_px, 0.5)?;
        if !(self.sigma_per_radius > 0.0 && self.sigma_per_radius <= 2.0) {
            return Err(FoveaError::invalid(
                "sigma_per_radius",
                self.sigma_per_radius,
                "a ratio in (0, 2]",
            ));
        }
        for (name, v) in [
            ("sigma_rgb", self.sigma_rgb),
            ("sigma_dioptre", self.sigma_dioptre),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(FoveaError::invalid(name, v, "a finite number > 0"));
            }
        }
        Ok(())
    }
}

impl DofFilter for DepthBilateral {
    fn name(&self) -> &'static str {
        "bilateral"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        self.check()?;
        let prep = Prepared::new(input, self.max_radius_px);
        let (w, h) = (prep.w, prep.h);
        // Support is 3σ_s ≤ 3 · sigma_per_radius · max_radius_px.
        let disc = Disc::new(3.0 * self.sigma_per_radius * self.max_radius_px);
        let inv_dioptre: Vec<f32> = prep.depth_m.iter().map(|&z| 1.0 / z).collect();
        let k_rgb = 0.5 / (self.sigma_rgb * self.sigma_rgb);
        let k_d = 0.5 / (self.sigma_dioptre * self.sigma_dioptre);
        map_pixels(w, h, |x, y| {
            let i = y * w + x;
            let sigma = self.sigma_per_radius * prep.radius_px[i];
            let support = 3.0 * sigma;
            let cc = prep.color[i];
            if support < 1.0 {
                return cc;
            }
            let k_s = 0.5 / (sigma * sigma);
            let near = self.depth_kernel_everywhere || prep.coc_px[i] < 0.0;
            let dc = inv_dioptre[i];
            let mut acc = [0.0f32; 4];
            // `within(r)` yields |o| < r + ½; the Gaussian is cut at `support`.
            for_each_tap(disc.within(support - 0.5), x, y, w, h, |j, _, d| {
                let c = prep.color[j];
                let range = if near {
                    let dd = inv_dioptre[j] - dc;
                    k_d * dd * dd
                } else {
                    let (a, b, e) = (c[0] - cc[0], c[1] - cc[1], c[2] - cc[2]);
                    k_rgb * (a * a + b * b + e * e)
                };
                accumulate(&mut acc, (-(k_s * d * d) - range).exp(), c);
            });
            normalise(acc, cc)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;

    fn f() -> DepthBilateral {
        DepthBilateral::default()
    }

    #[test]
    fn constant_plane_against_thin_lens() {
        // A Gaussian of the disc's σ with an edge-preserving colour kernel: close to the
        // lens blur but not equal; the depth kernel on one plane is a plain Gaussian.
        let case = Case::new(&single_plane(64, 48, 2.0), 8.0, 0.5, 256);
        let p = case.psnr(&f(), 8);
        let depth = case.psnr(
            &DepthBilateral {
                depth_kernel_everywhere: true,
                ..f()
            },
            8,
        );
        eprintln!("bilateral plane: {p:.2} dB (depth kernel everywhere {depth:.2} dB)");
        assert!(p > 28.0, "{p:.2} dB");
        assert!(depth > 33.0, "{depth:.2} dB");
    }

    #[test]
    fn occluder_scenes_psnr() {
        let k = 16.0 / 1.5;
        for edge in [Edge::Straight(40.0), Edge::Circle(40.0, 32.0, 18.0)] {
            let scene = occluder_scene(80, 64, edge, true);
            for focus in [0.5f32, 2.0] {
                let case = Case::new(&scene, k, focus, 400);
                let p = case.psnr(&f(), 8);
                let depth = case.psnr(
                    &DepthBilateral {
                        depth_kernel_everywhere: true,
                        ..f()
                    },
                    8,
                );
                eprintln!(
                    "bilateral {edge:?} focus {focus} m: {p:.2} dB (depth kernel everywhere {depth:.2})"
                );
                assert!(p >= 21.0, "{edge:?} focus {focus}: {p:.2} dB");
                assert!(depth >= p - 0.01, "{edge:?} focus {focus}: {depth:.2} dB");
            }
        }
    }

    #[test]
    fn sharp_foreground_keeps_its_edge() {
        // Focus on the flat near occluder (x < 30), far plane blurred to c = 20 px.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(30.0), false),
            20.0 / 1.5,
            0.5,
            64,
        );
        // No leakage onto the foreground: every in-focus pixel keeps its value.
        let out = f().apply(&case.input()).unwrap();
        for y in 0..24 {
            for x in 0..30 {
                assert_eq!(out.get(x, y), case.color.get(x, y), "({x},{y})");
            }
        }
        // But with the colour kernel the foreground's colour spreads over the blurred
        // background beside it (a halo of several px on the background side).
        let halo = edge_width(&column_profile(&out, 4, 20), 6);
        let depth = DepthBilateral {
            depth_kernel_everywhere: true,
            ..f()
        }
        .apply(&case.input())
        .unwrap();
        let width = edge_width(&column_profile(&depth, 4, 20), 6);
        eprintln!("bilateral sharp edge: {halo:.2} px (depth kernel everywhere {width:.2} px)");
        assert!(halo > 1.5 && halo < 8.0, "{halo}");
        assert!(width <= 1.5, "{width}");
    }

    #[test]
    fn blurred_foreground_edge_stays_hard() {
        // Documented limitation: the centre's radius sets the support, so the foreground
        // (c = −12 px) does not spread over the in-focus background, and the depth kernel
        // keeps the background out of the foreground. The thin lens gives ~8.6 px.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(32.0), false),
            12.0 / 1.5,
            2.0,
            64,
        );
        let out = f().apply(&case.input()).unwrap();
        let width = edge_width(&column_profile(&out, 4, 20), 4);
        eprintln!("bilateral blurred-foreground edge: {width:.2} px");
        assert!(width <= 1.5, "{width}");
    }

    #[test]
    fn bad_parameters_are_errors() {
        let frame = nan_frame();
        for bad in [
            DepthBilateral {
                sigma_rgb: 0.0,
                ..f()
            },
            DepthBilateral {
                sigma_per_radius: 3.0,
                ..f()
            },
        ] {
            assert!(bad.apply(&frame.input()).is_err());
        }
    }
}
