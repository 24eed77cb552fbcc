//! Disc bokeh with Liu's row-wise longitudinal chromatic aberration (Liu, Mantel & Forchhammer,
//! "Perception-driven hybrid foveated depth of field rendering", Sec. 3.3.1–3.3.2, Alg. 2).
//!
//! **Bokeh (Sec. 3.3.1).** The kernel is a disc of constant weight whose diameter is the
//! pixel's circle of confusion `C_e(p)` (Eq. 12; here the signed `coc_px` of [`DofInput`],
//! `|coc_px| = px_per_dioptre · |1/F − 1/D|` for the thin-lens eye). Algorithm 2 gathers, per
//! pixel, `color = sampler(uv, coc, kernel)`. Pixels inside the DOF (`|coc_px| <
//! in_focus_coc_px`, default 1 px) get no blur, as the paper says ("for `D_p` within DOF, no
//! Bokeh kernel applies").
//!
//! The disc's edge is anti-aliased: a sample at distance `d` from the centre has coverage
//! `clamp(r + ½ − d, 0, 1)` for a disc of radius `r = |coc_px|/2`, so the blur grows
//! continuously with the CoC instead of in integer steps.
//!
//! **Default: the literal Algorithm 2.** Every sample within the centre pixel's disc is
//! averaged with the centre's constant weight, whatever its depth. That is Liu's filter, and
//! it has the gather filters' intensity leakage: next to an in-focus foreground edge the
//! blurred background pulls in foreground colour (a bright in-focus edge over a background
//! blurred to 17.5 px widens from 0.8 px to ≈ 6.4 px, 10–90 %), and a blurred near object
//! cannot spread over a sharp background, so its silhouette stays hard.
//!
//! **`occlusion_aware: true`: Liu's kernel with [`super::gather`]'s occlusion handling.** The
//! occlusion-aware filter is [`super::gather::ScatterAsGather`]; this option runs its gather
//! core (`disc_gather`) with Liu's disc and LCA rows: a neighbour *in front*
//! of the centre (`depth_q < depth_p`, no depth tolerance) scatters over its own disc with
//! weight `coverage / A(r_q)` into a front layer of coverage `α`, so a sharp foreground never
//! reaches a blurred background; a neighbour *behind* is gathered with the centre's disc, so a
//! sharp centre gathers nothing from a blurred background, and a blurred near centre reaches
//! `r_p` (its silhouette becomes semi-transparent on both sides, as the thin lens makes it);
//! a neighbour at the same depth uses its own disc (for a thin-lens CoC, the centre's).
//! Composite `out = α · F̄ + (1 − α) · B̄`. The bokeh shaders Liu builds on (the Catlike
//! Coding / Unity disc kernels, Liu's refs. \[1\], \[63\]) split the samples by depth the same
//! way. For a constant CoC both variants are exactly Liu's constant-weight disc gather.
//!
//! **LCA (Sec. 3.3.2).** "If `D_p > D_F`, the top 2 rows of the kernel filter out blue, and
//! the bottom 2 rows filter out red. The other way around if `D_p < D_N`." We zero that
//! channel's weight in the top/bottom rows (`dy < 0` is *up*, i.e. smaller image `y`) and
//! normalise each channel over its own weights, so flat regions keep their colour and only
//! edges and highlights get coloured fringes. Which side is "far" follows the sign of the
//! CoC that defines the kernel (the sample's, for a sample scattering from in front).
//!
//! **Choice: how many rows.** Liu's kernel is a fixed sample pattern (the paper does not say
//! its size); read literally, "2 rows" is a large part of a 3-px kernel and invisible in a
//! 60-px one. We scale the band with the kernel: `h = clamp(lca_band_fraction · diameter,
//! 1, r − ½)` rows, with `lca_band_fraction = 2/9` (two rows of a 9-row kernel). A sample is
//! in the top band if `dy < −r + h` and in the bottom band if `dy > r − h`. So a 3-px kernel
//! has 1 row at each side, 9 px → 2 rows, 18 px → 4 rows, 64 px → 14 rows; the centre row
//! always keeps all three channels.
//!
//! Cost: one pass, rayon over rows; the disc offsets are precomputed and sorted by distance.
//! The literal gather visits the centre's disc; the occlusion-aware one every offset the
//! largest CoC within reach (dilated 16×16 tile-max) can cover.

use fovea_core::{FoveaError, Image, Result};

use super::disc::{check_max_radius, sanitized_color, sanitized_depth};
use super::gather::{disc_gather, GatherPlanes, Occlusion};
use super::{sanitize_coc, DofFilter, DofInput};
use crate::Rgb;

/// Liu's disc bokeh, optionally with the row-wise chromatic filter.
#[derive(Clone, Debug, PartialEq)]
pub struct BokehLca {
    /// Apply Liu's row-wise LCA colour filter (default `true`).
    pub lca: bool,
    /// Largest blur radius, pixels; CoCs are clamped to twice this diameter (default 32).
    pub max_radius_px: f32,
    /// CoC diameters below this many pixels count as inside the DOF and get no blur
    /// (default 1 px).
    pub in_focus_coc_px: f32,
    /// Height of the LCA band at the top and bottom of the kernel, as a fraction of the
    /// kernel's diameter, at least one row (default `2/9`: Liu's "2 rows" of a 9-row kernel).
    pub lca_band_fraction: f32,
    /// `false` (default): the literal Algorithm 2, a constant-weight disc gather with the
    /// centre pixel's CoC (leaks at in-focus foreground edges). `true`: Liu's kernel with the
    /// occlusion handling of [`super::gather`] (see the module header).
    pub occlusion_aware: bool,
}

impl Default for BokehLca {
    fn default() -> Self {
        Self {
            lca: true,
            max_radius_px: 32.0,
            in_focus_coc_px: 1.0,
            lca_band_fraction: 2.0 / 9.0,
            occlusion_aware: false,
        }
    }
}

impl BokehLca {
    fn check(&self) -> Result<()> {
        check_max_radius(self.max_radius_px, 0.0)?;
        if !(self.in_focus_coc_px.is_finite() && self.in_focus_coc_px >= 0.0) {
            return Err(FoveaError::invalid(
                "in_focus_coc_px",
                self.in_focus_coc_px,
                "a finite number ≥ 0 px",
            ));
        }
        if !(0.0..=0.5).contains(&self.lca_band_fraction) {
            return Err(FoveaError::invalid(
                "lca_band_fraction",
                self.lca_band_fraction,
                "a fraction of the kernel diameter in [0, 0.5]",
            ));
        }
        Ok(())
    }
}

impl DofFilter for BokehLca {
    fn name(&self) -> &'static str {
        if self.lca {
            "bokeh-lca"
        } else {
            "bokeh"
        }
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        self.check()?;
        let (w, h) = input.size();
        let thr = self.in_focus_coc_px.max(f32::MIN_POSITIVE);
        let coc: Vec<f32> = input
            .coc_px
            .data()
            .iter()
            .map(|&c| sanitize_coc(c))
            .collect();
        // Radius per pixel: 0 inside the DOF.
        let radius_px: Vec<f32> = coc
            .iter()
            .map(|&c| {
                if c.abs() < thr {
                    0.0
                } else {
                    (0.5 * c.abs()).min(self.max_radius_px)
                }
            })
            .collect();
        if radius_px.iter().all(|&r| r < 0.5) {
            // Nothing is blurred by more than the pixel itself.
            return Ok(input.color.clone());
        }
        // A pixel covers at least itself (the gather's radii are ≥ ½).
        let radius_px: Vec<f32> = radius_px.into_iter().map(|r| r.max(0.5)).collect();
        let color = sanitized_color(input.color);
        let depth_m = sanitized_depth(input.depth_m);
        let planes = GatherPlanes {
            w: w as usize,
            h: h as usize,
            color: &color,
            depth_m: &depth_m,
            radius_px: &radius_px,
        };
        let occlusion = if self.occlusion_aware {
            Occlusion::Layers {
                depth_tolerance: 0.0,
                fill_behind: true,
                separate_near: true,
            }
        } else {
            Occlusion::None
        };
        let frac = self.lca_band_fraction;
        let lca_rows =
            |owner: usize, r: f32, dy: i32, c: usize| lca_drops(frac, r, coc[owner] > 0.0, dy, c);
        disc_gather(
            &planes,
            self.max_radius_px,
            occlusion,
            self.lca.then_some(lca_rows),
        )
    }
}

/// Liu's row-wise LCA: does the kernel of radius `r_px` (behind the focus if `far`) drop
/// channel `c` (0 red, 2 blue; green never) at row offset `dy`?
#[inline]
fn lca_drops(frac: f32, r_px: f32, far: bool, dy: i32, c: usize) -> bool {
    if c == 1 {
        return false;
    }
    let band = (frac * 2.0 * r_px).max(1.0).min(r_px - 0.5);
    if band <= 0.0 {
        return false;
    }
    let dyf = dy as f32;
    let top = dyf < -r_px + band;
    let bottom = dyf > r_px - band;
    // Far: top rows drop blue, bottom rows drop red; near: the other way round.
    let (drop_blue, drop_red) = if far { (top, bottom) } else { (bottom, top) };
    (c == 2 && drop_blue) || (c == 0 && drop_red)
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;
    use crate::dof::FilterKind;
    use crate::luma;

    /// Liu's literal Algorithm 2 without LCA.
    fn plain() -> BokehLca {
        BokehLca {
            lca: false,
            ..Default::default()
        }
    }

    /// Liu's kernel with the gather filter's occlusion handling, without LCA.
    fn occlusion_aware() -> BokehLca {
        BokehLca {
            occlusion_aware: true,
            ..plain()
        }
    }

    #[test]
    fn names_and_defaults() {
        assert_eq!(BokehLca::default().name(), "bokeh-lca");
        assert_eq!(plain().name(), "bokeh");
        assert_eq!(FilterKind::Bokeh.build().name(), "bokeh");
        assert_eq!(FilterKind::BokehLca.build().name(), "bokeh-lca");
        assert!(BokehLca::default().lca);
        assert!(!BokehLca::default().occlusion_aware);
    }

    #[test]
    fn sub_threshold_coc_is_identity() {
        let mut f = Frame::from_scene(&plane_scene(40, 30, 1.0, checker_wave), 10.0, 1.0);
        f.coc = f.coc.map(|_| -0.9);
        for filt in [BokehLca::default(), occlusion_aware()] {
            assert_eq!(f.filtered(&filt), f.color);
        }
    }

    #[test]
    fn constant_plane_matches_thin_lens() {
        // Focus near (plane behind → far blur, +10 px) and focus far (plane in front, −7.5 px).
        for (focus, k) in [(0.5f32, 10.0f32), (4.0, 10.0)] {
            let case = Case::new(&plane_scene(64, 48, 1.0, checker_wave), k, focus, 400);
            let c = thin_lens_coc(k, focus, 1.0);
            let margin = (c.abs() / 2.0).ceil() as u32 + 1;
            for filt in [plain(), occlusion_aware(), BokehLca::default()] {
                let psnr = case.psnr(&filt, margin);
                eprintln!(
                    "{} (occlusion-aware {}) focus {focus} coc {c}: luma PSNR {psnr:.2} dB",
                    filt.name(),
                    filt.occlusion_aware
                );
                let tol = if filt.lca { 30.0 } else { 38.0 };
                assert!(psnr > tol, "{} focus {focus}: {psnr}", filt.name());
            }
        }
    }

    #[test]
    fn two_textured_planes_match_thin_lens_roughly() {
        // Textured near plane (0.5 m, left of x = 32) over a textured far plane (2 m); focus
        // on either. Occlusion boundaries are where gather filters differ from the lens: the
        // literal gather leaks there (≈ 29–30 dB at focus 0.5 m, ≈ 29 dB at 2 m), the
        // occlusion-aware one does not (≈ 48–50 dB and ≈ 35.5 dB).
        for focus in [0.5f32, 2.0] {
            let case = Case::new(&two_textured_planes(), 8.0, focus, 400);
            for lca in [false, true] {
                let literal = BokehLca {
                    lca,
                    ..Default::default()
                };
                let aware = BokehLca {
                    occlusion_aware: true,
                    ..literal.clone()
                };
                let (pl, pa) = (case.psnr(&literal, 8), case.psnr(&aware, 8));
                eprintln!(
                    "{} two textured planes focus {focus}: luma PSNR {pl:.2} dB literal, \
                     {pa:.2} dB occlusion-aware",
                    literal.name()
                );
                assert!(pl > 27.0, "{focus}: {pl}");
                assert!(pa > 32.0 && pa > pl + 5.0, "{focus}: {pa} vs {pl}");
            }
        }
    }

    #[test]
    fn literal_gather_leaks_a_sharp_foreground_edge() {
        // Bright foreground at the focus (0.5 m) left of x = 30, dark background at 4 m
        // (CoC 17.5 px) right of it. The literal centre-CoC gather pulls the foreground into
        // the blurred background beside it; the occlusion-aware gather keeps the lens's step.
        let case = Case::new(
            &edge_scene(64, 16, 30.0, 0.5, 4.0, [1.0; 3], [0.0; 3]),
            10.0,
            0.5,
            256,
        );
        let wg = row_edge_width(&case.truth, 8);
        let wl = row_edge_width(&case.filtered(&plain()), 8);
        let wo = row_edge_width(&case.filtered(&occlusion_aware()), 8);
        eprintln!(
            "sharp fg edge, 10-90 width: literal Alg. 2 {wl:.2} px, occlusion-aware {wo:.2} px \
             (thin lens {wg:.2} px)"
        );
        assert!(wl > 5.0 && wl < 8.0, "{wl}");
        assert!(wo < 1.0, "{wo}");
    }

    #[test]
    fn blurred_foreground_over_sharp_background() {
        // Bright foreground at 0.25 m (CoC −20 px with focus 1 m, k = 20/3) over a dark
        // in-focus background.
        let k = 20.0 / 3.0;
        let case = Case::new(
            &edge_scene(64, 16, 32.0, 0.25, 1.0, [1.0; 3], [0.0; 3]),
            k,
            1.0,
            256,
        );
        let gt = &case.truth;
        // Occlusion-aware: soft on both sides of the silhouette (x = 32): the background
        // next to it picks up foreground light, the foreground's edge shows the background.
        let out = case.filtered(&occlusion_aware());
        let (wo, wg) = (row_edge_width(&out, 8), row_edge_width(gt, 8));
        let (l31, l32) = (luma(*out.get(31, 8)), luma(*out.get(32, 8)));
        eprintln!(
            "blurred fg edge, occlusion-aware: 10-90 width {wo:.2} px (thin lens {wg:.2} px), \
             luma at the silhouette {l31:.2}/{l32:.2} (thin lens {:.2}/{:.2})",
            luma(*gt.get(31, 8)),
            luma(*gt.get(32, 8))
        );
        assert!(wo > 0.7 * wg && wo < 1.3 * wg, "{wo} vs {wg}");
        assert!(l31 < 0.7 && l32 > 0.3, "{l31} {l32}");
        // The literal Alg. 2 gather cannot spread the foreground over the sharp background.
        let literal = case.filtered(&plain());
        eprintln!(
            "blurred fg edge, literal Alg. 2: 10-90 width {:.2} px",
            row_edge_width(&literal, 8)
        );
        assert_eq!(*literal.get(33, 8), [0.0; 3]);
    }

    #[test]
    fn non_finite_colour_and_bad_parameters() {
        let mut f = nan_frame();
        f.color.data_mut()[37] = [f32::NAN, f32::INFINITY, 1.0];
        for filt in [BokehLca::default(), occlusion_aware()] {
            assert!(all_finite(&f.filtered(&filt)));
        }
        for bad in [
            BokehLca {
                max_radius_px: f32::NAN,
                ..Default::default()
            },
            BokehLca {
                lca_band_fraction: 0.7,
                ..Default::default()
            },
            BokehLca {
                in_focus_coc_px: -1.0,
                ..Default::default()
            },
        ] {
            assert!(bad.apply(&f.input()).is_err());
        }
    }

    /// A white point at the centre of a black `n × n` plane at 2 m with a constant CoC.
    fn point_frame(n: u32, coc: f32) -> Frame {
        let mut color = Image::new(n, n, [0.0f32; 3]).unwrap();
        *color.get_mut(n / 2, n / 2) = [1.0; 3];
        Frame {
            color,
            depth: Image::new(n, n, 2.0).unwrap(),
            coc: Image::new(n, n, coc).unwrap(),
            focus_m: 1.0,
            k: 1.0,
            gaze: [n as f32 / 2.0; 2],
            ppd: 1000.0,
        }
    }

    #[test]
    fn lca_rows_follow_liu() {
        // Far (CoC +9 px, r 4.5, 2-row bands). The point at (10,10) reaches pixel (10, 10+dy')
        // through kernel row dy = −dy'. Pixels below the point see it in their top rows.
        // A constant CoC: both variants are the same filter.
        for oa in [false, true] {
            let lca = BokehLca {
                occlusion_aware: oa,
                ..Default::default()
            };
            let out = point_frame(21, 9.0).filtered(&lca);
            let below = *out.get(10, 14); // point in this pixel's top row → no blue
            let above = *out.get(10, 6); // point in this pixel's bottom row → no red
            let mid = *out.get(10, 10);
            assert!(
                below[2] == 0.0 && below[0] > 0.0 && below[1] > 0.0,
                "{below:?}"
            );
            assert!(
                above[0] == 0.0 && above[2] > 0.0 && above[1] > 0.0,
                "{above:?}"
            );
            assert!(mid.iter().all(|&v| v > 0.0));
            assert_eq!(out.get(10, 13)[2], 0.0); // second row of the band
            assert!(out.get(10, 12)[2] > 0.0); // third row is outside it

            // Near: the other way round.
            let out = point_frame(21, -9.0).filtered(&lca);
            assert!(out.get(10, 14)[0] == 0.0 && out.get(10, 14)[2] > 0.0);
            assert!(out.get(10, 6)[2] == 0.0 && out.get(10, 6)[0] > 0.0);

            // Flat regions keep their colour: a grey plane stays grey.
            let mut f = point_frame(21, 9.0);
            f.color = f.color.map(|_| [0.3, 0.5, 0.7]);
            for p in f.filtered(&lca).data() {
                for c in 0..3 {
                    assert!((p[c] - [0.3, 0.5, 0.7][c]).abs() < 1e-5, "{p:?}");
                }
            }
        }
    }

    #[test]
    fn lca_band_scales_with_the_kernel() {
        // CoC 36 px (r 18): band = 2/9·36 = 8 rows.
        let out = point_frame(41, 36.0).filtered(&BokehLca::default());
        // Kernel rows dy < −18 + 8 = −10 drop blue → pixels 11..18 below the point.
        assert_eq!(out.get(20, 31)[2], 0.0);
        assert_eq!(out.get(20, 38)[2], 0.0);
        assert!(out.get(20, 30)[2] > 0.0);
        assert!(out.get(20, 31)[0] > 0.0);
    }
}
