//! Physically based longitudinal chromatic aberration: each colour channel is defocused by the
//! eye's own chromatic focus shift. None of the five papers has this; Liu et al. Sec. 3.3.2
//! only shifts colours row-wise ([`super::bokeh_lca`]) and cites Cholewiak et al.'s
//! "ChromaBlur" for the physical version. The chromatic eye model is Thibos, Ye, Zhang &
//! Bradley, "The chromatic eye" (Applied Optics 31(19), 1992), whose chromatic difference of
//! refraction is
//!
//! ```text
//! R(λ) = p − q / (λ − c)   dioptres,   p = 1.68524, q = 633.46, c = 214.102, λ in nm
//! ```
//!
//! (`R` is the refractive error at `λ`: negative = the eye is too strong, i.e. short
//! wavelengths focus in front of the retina.)
//!
//! **Model.** The eye is accommodated so that the reference wavelength (the green primary,
//! carrying most of the luminance) is in focus at `F`. Channel `c` then sees extra optical
//! power `P_c = R(λ_ref) − R(λ_c)` and its signed CoC diameter is
//!
//! ```text
//! coc_c = px_per_dioptre · (1/F + P_c − 1/D)   pixels
//! ```
//!
//! (the thin-lens CoC of [`super::coc`] with the focus moved by `P_c`). With the default
//! primaries R 610 nm, G 545 nm, B 465 nm (representative dominant wavelengths of sRGB/OLED
//! primaries; choose the display's own): `P_R = −0.314 D`, `P_G = 0`, `P_B = +0.611 D`, so blue
//! is in focus for nearer objects, red for farther ones, ≈ 0.93 D apart. An object at the
//! focus shows a blue halo of diameter `0.611·px_per_dioptre` and a red one of
//! `0.314·px_per_dioptre`; behind the focus blue blurs more than red, in front red blurs more.
//!
//! **Choices.** The CoC is computed here from `depth_m`, `focus_m` and `px_per_dioptre`; the
//! input's `coc_px` map is validated but not used, since this filter needs the thin-lens
//! eye's per-channel defocus (so `px_per_dioptre = 0` returns the input). Each channel is then
//! blurred by the occlusion-aware disc gather of [`super::gather`] with its own radius (no
//! depth tolerance): a neighbour in front of the centre scatters over its own disc (weight
//! coverage / disc area, summed into the front coverage `α`), neighbours behind are averaged
//! over the centre's disc (level ones over their own, the same radius here), and
//! `out = α · front + (1 − α) · behind`. So sharp foreground never leaks into
//! blurred background, and a neighbour behind a sharp centre is never gathered; behind a
//! *blurred near* centre it reaches `r_centre` rather than `min(r_centre, r_neighbour)`, which
//! makes blurred silhouettes semi-transparent on both sides, as the thin lens does. There
//! is no in-focus threshold: a CoC below one pixel blurs nothing anyway. CoC diameters are
//! clamped to `2 · max_radius_px`.

use fovea_core::{FoveaError, Image, Result};

use super::disc::{check_max_radius, sanitized_color, sanitized_depth};
use super::gather::{disc_gather, GatherPlanes, Occlusion, NO_MASK};
use super::{DofFilter, DofInput};
use crate::Rgb;

/// Thibos et al. 1992 constants of `R(λ) = p − q/(λ − c)`.
const THIBOS_P: f64 = 1.68524;
/// `q`, dioptre·nm.
const THIBOS_Q: f64 = 633.46;
/// `c`, nm.
const THIBOS_C: f64 = 214.102;

/// Thibos et al.'s chromatic difference of refraction `R(λ) = p − q/(λ − c)` in dioptres,
/// `λ` in nm (valid over the visible range, ≈ 400–700 nm; the formula has a pole at 214 nm).
pub fn thibos_refraction_d(wavelength_nm: f64) -> f64 {
    THIBOS_P - THIBOS_Q / (wavelength_nm - THIBOS_C)
}

/// Per-channel defocus by the eye's longitudinal chromatic aberration.
#[derive(Clone, Debug, PartialEq)]
pub struct PhysicalLca {
    /// Representative wavelengths of the display's R, G, B primaries, nm
    /// (default `[610, 545, 465]`).
    pub wavelengths_nm: [f32; 3],
    /// Wavelength the eye is accommodated for, nm (default 545, the green primary).
    pub reference_wavelength_nm: f32,
    /// Largest blur radius, pixels (default 32).
    pub max_radius_px: f32,
}

impl Default for PhysicalLca {
    fn default() -> Self {
        Self {
            wavelengths_nm: [610.0, 545.0, 465.0],
            reference_wavelength_nm: 545.0,
            max_radius_px: 32.0,
        }
    }
}

impl PhysicalLca {
    /// Extra power `P_c = R(λ_ref) − R(λ_c)` of each channel, dioptres (R, G, B).
    pub fn channel_power_d(&self) -> [f32; 3] {
        let r_ref = thibos_refraction_d(self.reference_wavelength_nm as f64);
        self.wavelengths_nm
            .map(|l| (r_ref - thibos_refraction_d(l as f64)) as f32)
    }

    fn check(&self) -> Result<()> {
        check_max_radius(self.max_radius_px, 0.0)?;
        for (name, l) in [
            ("wavelengths_nm[0]", self.wavelengths_nm[0]),
            ("wavelengths_nm[1]", self.wavelengths_nm[1]),
            ("wavelengths_nm[2]", self.wavelengths_nm[2]),
            ("reference_wavelength_nm", self.reference_wavelength_nm),
        ] {
            if !(300.0..=1000.0).contains(&l) {
                return Err(FoveaError::invalid(
                    name,
                    l,
                    "a wavelength in [300, 1000] nm",
                ));
            }
        }
        Ok(())
    }
}

impl DofFilter for PhysicalLca {
    fn name(&self) -> &'static str {
        "physical-lca"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        self.check()?;
        let (w, h) = input.size();
        let k = input.px_per_dioptre;
        if k == 0.0 {
            return Ok(input.color.clone());
        }
        let inv_f = if input.focus_m.is_finite() {
            1.0 / input.focus_m
        } else {
            0.0
        };
        let power = self.channel_power_d();
        let max_r = self.max_radius_px;
        let depth = sanitized_depth(input.depth_m);
        // Per-channel radius |½·k·(1/F + P_c − 1/D)|, clamped.
        let radius_px: Vec<[f32; 3]> = depth
            .iter()
            .map(|&d| {
                let inv_d = 1.0 / d; // +∞ → 0
                power.map(|p| {
                    let r = (0.5 * k * (inv_f + p - inv_d)).abs();
                    if r.is_finite() {
                        r.min(max_r)
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        if radius_px.iter().all(|r| r.iter().all(|&v| v < 0.5)) {
            return Ok(input.color.clone());
        }
        // A pixel covers at least itself (the gather's radii are ≥ ½).
        let radius_px: Vec<[f32; 3]> = radius_px.iter().map(|r| r.map(|v| v.max(0.5))).collect();
        let color = sanitized_color(input.color);
        let planes = GatherPlanes {
            w: w as usize,
            h: h as usize,
            color: &color,
            depth_m: &depth,
            radius_px: &radius_px,
        };
        let occlusion = Occlusion::Layers {
            depth_tolerance: 0.0,
            fill_behind: true,
            separate_near: true,
        };
        disc_gather(&planes, max_r, occlusion, NO_MASK)
    }
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;

    #[test]
    fn thibos_numbers() {
        // R is ≈ 0 near 589 nm (the model's reference) and the default channel powers are
        // the brief's: blue ≈ +0.6 D, red ≈ −0.3 D.
        assert!(thibos_refraction_d(589.0).abs() < 0.01);
        let p = PhysicalLca::default().channel_power_d();
        assert!((p[0] + 0.314).abs() < 0.002, "{p:?}");
        assert_eq!(p[1], 0.0);
        assert!((p[2] - 0.611).abs() < 0.002, "{p:?}");
        assert!((p[2] - p[0] - 0.925).abs() < 0.005);
        let k = crate::dof::FilterKind::PhysicalLca;
        assert_eq!(k.build().name(), k.name());
    }

    #[test]
    fn zero_aperture_is_identity() {
        let scene = edge_scene(40, 20, 20.0, 0.5, 3.0, [0.9, 0.5, 0.2], [0.1, 0.2, 0.8]);
        let mut f = Frame::from_scene(&scene, 0.0, 1.0);
        assert_eq!(PhysicalLca::default().apply(&f.input()).unwrap(), f.color);
        // A tiny aperture (all CoCs < 1 px) changes nothing either.
        f.k = 0.5;
        assert_eq!(PhysicalLca::default().apply(&f.input()).unwrap(), f.color);
    }

    /// A white point on a black plane at `depth_m`, eye focused at 1 m, `k` px/D.
    fn point(depth_m: f32, k: f32) -> Frame {
        let (w, h) = (33u32, 33u32);
        let mut color = vec![[0.0f32; 3]; (w * h) as usize];
        color[(16 * w + 16) as usize] = [1.0; 3];
        Frame {
            color: Image::from_vec(w, h, color).unwrap(),
            depth: Image::new(w, h, depth_m).unwrap(),
            coc: Image::new(w, h, 0.0).unwrap(),
            focus_m: 1.0,
            k,
            gaze: [16.0, 16.0],
            ppd: 1000.0,
        }
    }

    /// Largest distance from the centre at which channel `c` is non-zero.
    fn extent(img: &Image<Rgb>, c: usize) -> f32 {
        let mut m = 0.0f32;
        for y in 0..img.height() {
            for x in 0..img.width() {
                if img.get(x, y)[c] > 1e-6 {
                    m = m.max(((x as f32 - 16.0).powi(2) + (y as f32 - 16.0).powi(2)).sqrt());
                }
            }
        }
        m
    }

    #[test]
    fn in_focus_point_has_blue_and_red_fringes_of_predicted_radius() {
        let k = 20.0;
        let out = PhysicalLca::default()
            .apply(&point(1.0, k).input())
            .unwrap();
        let p = PhysicalLca::default().channel_power_d();
        let (rb, rr) = (0.5 * k * p[2], 0.5 * k * p[0].abs()); // 6.11, 3.14 px
        let (eb, er, eg) = (extent(&out, 2), extent(&out, 0), extent(&out, 1));
        eprintln!("fringe radii: blue {eb} (predicted {rb:.2}), red {er} (predicted {rr:.2})");
        // Anti-aliased disc: non-zero up to r + ½.
        assert!(eb > rb - 0.5 && eb < rb + 0.5, "{eb} vs {rb}");
        assert!(er > rr - 0.5 && er < rr + 0.5, "{er} vs {rr}");
        assert_eq!(eg, 0.0);
        assert_eq!(out.get(16, 16)[1], 1.0);
        // Energy is conserved per channel.
        for c in [0, 2] {
            let e: f32 = out.data().iter().map(|q| q[c]).sum();
            assert!((e - 1.0).abs() < 0.02, "channel {c}: {e}");
        }
    }

    #[test]
    fn blue_red_asymmetry_flips_between_near_and_far() {
        let k = 20.0;
        // Far object (2 m, green defocus +0.5 D): blue blurs by 1.11 D, red by 0.19 D.
        let far = PhysicalLca::default()
            .apply(&point(2.0, k).input())
            .unwrap();
        // Near object (0.667 m, −0.5 D): blue 0.11 D, red 0.81 D.
        let near = PhysicalLca::default()
            .apply(&point(1.0 / 1.5, k).input())
            .unwrap();
        let (fb, fr) = (extent(&far, 2), extent(&far, 0));
        let (nb, nr) = (extent(&near, 2), extent(&near, 0));
        eprintln!("far: blue {fb} red {fr}; near: blue {nb} red {nr}");
        assert!(fb > fr + 5.0, "far {fb} {fr}");
        assert!(nr > nb + 5.0, "near {nb} {nr}");
        assert!(far.get(16, 16)[2] < far.get(16, 16)[0]);
        assert!(near.get(16, 16)[0] < near.get(16, 16)[2]);
    }

    #[test]
    fn green_channel_matches_thin_lens() {
        // Green sees exactly the thin-lens blur; compare the green channel's luma-like PSNR
        // by feeding a grey texture through both and checking green alone.
        for (focus, k) in [(0.5f32, 10.0f32), (4.0, 10.0)] {
            let scene = plane_scene(64, 48, 1.0, checker_wave);
            let f = Frame::from_scene(&scene, k, focus);
            let gt = scene.thin_lens(k, focus, 400).unwrap();
            let out = PhysicalLca::default().apply(&f.input()).unwrap();
            let g = |img: &Image<Rgb>| img.map(|p| [p[1]; 3]);
            let m = (0.5 * k * 2.0f32).ceil() as u32 + 2;
            let psnr_g = luma_psnr(&g(&out), &g(&gt), m);
            let psnr = luma_psnr(&out, &gt, m);
            eprintln!(
                "physical-lca focus {focus}: green PSNR {psnr_g:.2} dB, luma PSNR {psnr:.2} dB"
            );
            assert!(psnr_g > 38.0, "{psnr_g}");
            assert!(psnr > 22.0, "{psnr}");
        }
    }

    #[test]
    fn two_textured_planes_green_matches_thin_lens() {
        for focus in [0.5f32, 2.0] {
            let scene = two_textured_planes();
            let gt = scene.thin_lens(8.0, focus, 400).unwrap();
            let f = Frame::from_scene(&scene, 8.0, focus);
            let out = PhysicalLca::default().apply(&f.input()).unwrap();
            let g = |img: &Image<Rgb>| img.map(|p| [p[1]; 3]);
            let (pg, pl) = (luma_psnr(&g(&out), &g(&gt), 8), luma_psnr(&out, &gt, 8));
            eprintln!(
                "physical-lca two textured planes focus {focus}: green PSNR {pg:.2} dB, luma PSNR {pl:.2} dB"
            );
            assert!(pg > 26.0, "{focus}: {pg}");
        }
    }

    #[test]
    fn sharp_foreground_edge_does_not_leak() {
        // White foreground at the (green) focus, 1 m, over black background at 4 m.
        let scene = edge_scene(64, 16, 30.0, 1.0, 4.0, [1.0; 3], [0.0; 3]);
        let f = Frame::from_scene(&scene, 10.0, 1.0);
        let out = PhysicalLca::default().apply(&f.input()).unwrap();
        // Green edge: sharp, and no green leaks into the background.
        let green = out.map(|p| [p[1]; 3]);
        let wg = row_edge_width(&green, 8);
        eprintln!("physical-lca sharp fg edge: green 10-90 rise {wg:.2} px");
        assert!(wg < 1.0, "{wg}");
        assert_eq!(out.get(31, 8)[1], 0.0);
        // Blue of the foreground (CoC 6.1 px) spreads a little beyond the edge: the
        // foreground is in front of the background, which is physically right.
        assert!(out.get(31, 8)[2] > 0.0);
    }

    #[test]
    fn blurred_foreground_over_sharp_background_is_soft() {
        let k = 20.0 / 3.0;
        let scene = edge_scene(64, 16, 32.0, 0.25, 1.0, [1.0; 3], [0.0; 3]);
        let f = Frame::from_scene(&scene, k, 1.0);
        let out = PhysicalLca::default().apply(&f.input()).unwrap();
        let gt = scene.thin_lens(k, 1.0, 256).unwrap();
        let (w, wg) = (row_edge_width(&out, 8), row_edge_width(&gt, 8));
        eprintln!("physical-lca blurred fg edge: 10-90 rise {w:.2} px (thin lens {wg:.2} px)");
        assert!(w > 0.7 * wg && w < 1.4 * wg, "{w} vs {wg}");
    }

    #[test]
    fn nan_inputs_give_finite_output() {
        let f = nan_frame();
        let out = PhysicalLca::default().apply(&f.input()).unwrap();
        assert!(all_finite(&out));
        let mut g = nan_frame();
        g.focus_m = f32::INFINITY;
        assert!(all_finite(
            &PhysicalLca::default().apply(&g.input()).unwrap()
        ));
        g.focus_m = f32::NAN;
        assert!(PhysicalLca::default().apply(&g.input()).is_err());
        let bad = PhysicalLca {
            wavelengths_nm: [610.0, 200.0, 465.0],
            ..Default::default()
        };
        assert!(bad.apply(&f.input()).is_err());
    }
}
