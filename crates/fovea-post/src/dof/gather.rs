//! Scatter-as-gather depth of field with near/far layers — the game-engine baseline
//! (Jimenez 2014, "Next-generation post-processing in Call of Duty: Advanced Warfare";
//! the same idea drives UE4's circle DOF). None of the five papers: this is the filter the
//! others are compared with, and the one tuned against the exact thin-lens ground truth of
//! [`super::planes`].
//!
//! ## What it computes
//!
//! A thin lens spreads the light of a pinhole pixel `P` uniformly over its circle of
//! confusion, a disc of radius `r_P = |c_P|/2` pixels (`c_P` the signed CoC diameter of
//! [`DofInput::coc_px`]). Scattering is inverted into a gather: the output pixel `C` visits
//! every `P` within the largest CoC that can reach it and takes
//!
//! ```text
//! w(P→C) = cov(ρ, |P−C|) / A(ρ_w)      cov(ρ, d) = clamp(ρ − d + ½, 0, 1)   (anti-aliased disc)
//! ```
//!
//! where `A(ρ) = Σ_o cov(ρ, |o|)` is the discrete area of that disc (≈ π ρ², exactly the sum
//! of the coverage over integer offsets, so a disc's weights sum to 1) and every radius is
//! clamped to `[0.5, max_radius_px]` (a pixel covers at least itself). Which disc `P` uses
//! depends on its depth `z_P` relative to `z_C` (relative tolerance `depth_tolerance`):
//!
//! * **in front** (`z_P < z_C(1 − tol)`): the *near layer*; `ρ = ρ_w = r_P`. A blurred
//!   foreground spreads over whatever lies behind it, giving soft silhouettes.
//! * **same surface**: the *far layer*; `ρ = ρ_w = r_P`.
//! * **behind** (`z_P > z_C(1 + tol)`): the far layer, with the *leakage clamp*. Classic
//!   (`fill_behind = false`, Jimenez): `ρ = min(r_P, r_C)`, `ρ_w = r_P` — a sharp `C`
//!   (`r_C = ½`) receives nothing from behind, so an in-focus foreground keeps its edge.
//!   Default (`fill_behind = true`): `ρ = ρ_w = r_C` — the background seen *near* `C`
//!   stands in for the background the thin lens sees *through* the blurred rim of a
//!   foreground at `C` (hidden in the pinhole image). Its weights then sum to the fraction
//!   of `C`'s own disc that the background occupies, which is the fraction of the lens that
//!   looks past the foreground edge. With `r_C = ½` it is as leak-free as the classic clamp.
//!
//! The layers are composited front to back, the near layer acting as a coverage mask:
//!
//! ```text
//! α = min(1, Σ_near w)      out = α · (Σ_near w c / Σ_near w) + (1 − α) · (Σ_far w c / Σ_far w)
//! ```
//!
//! which is the thin-lens result wherever the pinhole image shows what the lens sees
//! (`separate_near = false` puts every sample in one normalised sum instead, as simple
//! gather filters do). `C` itself is always in the far layer with weight > 0, so nothing
//! divides by zero, and with every CoC ≤ 1 px the output is the input, bit for bit.
//!
//! ## Cost
//!
//! The gather radius of a pixel is the largest CoC radius among the 16×16 tiles whose
//! pixels can reach it (a dilated tile-max, as in Jimenez's tile pass), never more than
//! `max_radius_px`: `O(π R²)` taps per pixel, rows in parallel, no allocation per pixel.
//! The disc offsets (sorted by distance) and the area table are built once per call.
//!
//! The loop is `disc_gather`, shared with [`super::bokeh_lca`] (Liu's disc with LCA rows,
//! through a per-channel mask hook; also the literal centre-CoC gather) and
//! [`super::chromatic`] (a radius per colour channel).

use fovea_core::{FoveaError, Image, Result};

use super::disc::{
    check_max_radius, coverage, for_each_tap, map_pixels, AreaLut, Disc, Prepared, Radii,
    TileReach, LUT_STEPS_PER_PX, TILE,
};
use super::{DofFilter, DofInput};
use crate::Rgb;

/// Scatter-as-gather near/far DOF filter (see the module docs for the formulas).
#[derive(Clone, Debug, PartialEq)]
pub struct ScatterAsGather {
    /// Largest gather radius in pixels; CoC radii are clamped to it. Default 32, valid
    /// `[0.5, 256]`.
    pub max_radius_px: f32,
    /// Relative depth difference below which two pixels count as one surface. Default 0.02
    /// (2 %), valid `[0, 1)`.
    pub depth_tolerance: f32,
    /// Background samples behind `C` use `C`'s CoC (`true`, default) or the classic
    /// `min(r_P, r_C)` clamp with `P`'s weight (`false`).
    pub fill_behind: bool,
    /// Composite the near layer over the far one by its coverage (`true`, default) or
    /// normalise all samples together (`false`).
    pub separate_near: bool,
}

impl Default for ScatterAsGather {
    fn default() -> Self {
        Self {
            max_radius_px: 32.0,
            depth_tolerance: 0.02,
            fill_behind: true,
            separate_near: true,
        }
    }
}

impl DofFilter for ScatterAsGather {
    fn name(&self) -> &'static str {
        "gather"
    }

    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>> {
        input.validate()?;
        self.validate()?;
        let prep = Prepared::new(input, self.max_radius_px);
        let planes = GatherPlanes {
            w: prep.w,
            h: prep.h,
            color: prep.color,
            depth_m: &prep.depth_m,
            radius_px: &prep.radius_px,
        };
        let occlusion = Occlusion::Layers {
            depth_tolerance: self.depth_tolerance,
            fill_behind: self.fill_behind,
            separate_near: self.separate_near,
        };
        disc_gather(&planes, self.max_radius_px, occlusion, NO_MASK)
    }
}

impl ScatterAsGather {
    /// Checks the parameters: `max_radius_px` in `[0.5, 256]`, `depth_tolerance` in `[0, 1)`.
    pub fn validate(&self) -> Result<()> {
        check_max_radius(self.max_radius_px, 0.5)?;
        if !(self.depth_tolerance >= 0.0 && self.depth_tolerance < 1.0) {
            return Err(FoveaError::invalid(
                "depth_tolerance",
                self.depth_tolerance,
                "a relative tolerance in [0, 1)",
            ));
        }
        Ok(())
    }

    /// The tables the filter builds once per call, for another executor of the same filter
    /// (the GPU's): the disc's offsets in the order the gather visits them and the `1/A(r)`
    /// table. Errors as [`Self::validate`].
    pub fn tables(&self) -> Result<GatherTables> {
        self.validate()?;
        let disc = Disc::new(self.max_radius_px);
        let area = AreaLut::new(&disc, self.max_radius_px);
        Ok(GatherTables {
            offsets: disc.offsets().to_vec(),
            inv_area: area.table().to_vec(),
            inv_area_steps_per_px: LUT_STEPS_PER_PX,
            tile_px: TILE as u32,
        })
    }
}

/// The constant tables of [`ScatterAsGather`] ([`ScatterAsGather::tables`]).
#[derive(Clone, Debug, PartialEq)]
pub struct GatherTables {
    /// Integer offsets `(dx, dy, |o|)` with `|o| ≤ max_radius_px + ½`, sorted by distance:
    /// a pixel's gather visits the prefix with `|o| < search + ½`.
    pub offsets: Vec<(i32, i32, f32)>,
    /// `1/A(r)` at `r = ½ + k / inv_area_steps_per_px`; between entries the filter
    /// interpolates linearly, `t = (r − ½)·steps`, `k = min(⌊t⌋, len − 2)`,
    /// `f = min(t − k, 1)`.
    pub inv_area: Vec<f32>,
    /// Entries of `inv_area` per pixel of radius (16).
    pub inv_area_steps_per_px: f32,
    /// Side of the square tiles whose largest CoC radius (dilated by each neighbour tile's
    /// reach) bounds a pixel's search, pixels (16).
    pub tile_px: u32,
}

/// What [`disc_gather`] reads per pixel, sanitised: colour, depth (no NaN; `+∞` for no hit)
/// and CoC radii clamped to `[½, max_radius_px]`.
pub(crate) struct GatherPlanes<'a, R> {
    pub w: usize,
    pub h: usize,
    pub color: &'a [Rgb],
    pub depth_m: &'a [f32],
    pub radius_px: &'a [R],
}

/// How [`disc_gather`] weighs a sample `P` for the centre `C`.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Occlusion {
    /// Liu's literal Algorithm 2: every sample with `C`'s own disc, one normalised sum; the
    /// search reaches `C`'s radius only.
    None,
    /// The near/far layers of the module docs, with [`ScatterAsGather`]'s parameters.
    Layers {
        depth_tolerance: f32,
        fill_behind: bool,
        separate_near: bool,
    },
}

/// Which pixel's disc weighs a sample.
#[derive(Clone, Copy)]
enum Kernel {
    /// The sample's own: `cov(r_P, d) / A(r_P)`.
    Sample,
    /// The centre's: `cov(r_C, d) / A(r_C)`.
    Centre,
    /// The classic leakage clamp: `cov(min(r_P, r_C), d) / A(r_P)`.
    Clamped,
}

/// A channel mask of [`disc_gather`]: `drops(owner, radius_px, dy, c)`.
pub(crate) type ChannelMask = fn(usize, f32, i32, usize) -> bool;

/// No channel mask for [`disc_gather`].
pub(crate) const NO_MASK: Option<ChannelMask> = None;

/// Per-channel weighted sums of one layer.
#[derive(Default)]
struct Layer {
    sum: [f32; 3],
    weight: [f32; 3],
}

impl Layer {
    /// Channel `c` of the normalised sum, `fallback` where nothing was gathered.
    #[inline]
    fn mean(&self, c: usize, fallback: f32) -> f32 {
        if self.weight[c] > 0.0 {
            self.sum[c] * (1.0 / self.weight[c])
        } else {
            fallback
        }
    }
}

/// The occlusion-aware disc gather of the module docs: every output pixel visits the pixels
/// whose discs can reach it (dilated tile-max radius, or the centre's own radius for
/// [`Occlusion::None`]), sorts them into near and far layers and composites
/// `α · near + (1 − α) · far` per channel.
///
/// `R` is one radius for all channels (`f32`) or one per channel (`[f32; 3]`, the physical
/// LCA). `drops(owner, radius, dy, c)`, if given, removes channel `c` from the disc of pixel
/// `owner` (the pixel whose disc weighs the sample, of radius `radius`) at row offset `dy`:
/// the hook for Liu's row-wise LCA.
pub(crate) fn disc_gather<R: Radii>(
    planes: &GatherPlanes<R>,
    max_radius_px: f32,
    occlusion: Occlusion,
    drops: Option<impl Fn(usize, f32, i32, usize) -> bool + Sync>,
) -> Result<Image<Rgb>> {
    let GatherPlanes {
        w,
        h,
        color,
        depth_m,
        radius_px,
    } = *planes;
    let disc = Disc::new(max_radius_px);
    let area = AreaLut::new(&disc, max_radius_px);
    let reach = match occlusion {
        Occlusion::None => None,
        Occlusion::Layers { .. } => Some(TileReach::new(radius_px, w, h, max_radius_px)),
    };
    // (z_P, r_P, 1/A(r_P)) per pixel: one load per tap.
    let pix: Vec<(f32, R, R)> = (0..w * h)
        .map(|i| {
            let r = radius_px[i];
            (depth_m[i], r, r.map_each(|r| area.inv(r)))
        })
        .collect();
    map_pixels(w, h, |x, y| {
        let i = y * w + x;
        let (zc, rc, inv_area_c) = pix[i];
        let search_px = match &reach {
            Some(reach) => reach.at(x, y),
            None => rc.largest(),
        };
        if search_px <= 0.5 {
            return color[i];
        }
        let mut near = Layer::default();
        let mut far = Layer::default();
        for_each_tap(disc.within(search_px), x, y, w, h, |j, dy, d| {
            let (zp, rp, inv_area_p) = pix[j];
            let (kernel, layer) = match occlusion {
                Occlusion::None => (Kernel::Centre, &mut far),
                Occlusion::Layers {
                    depth_tolerance,
                    fill_behind,
                    separate_near,
                } => {
                    if zp < zc * (1.0 - depth_tolerance) {
                        // In front of C: spreads over it with its own disc.
                        let layer = if separate_near { &mut near } else { &mut far };
                        (Kernel::Sample, layer)
                    } else if zp > zc * (1.0 + depth_tolerance) {
                        // Behind C: never wider than C's own disc (leakage clamp).
                        let kernel = if fill_behind {
                            Kernel::Centre
                        } else {
                            Kernel::Clamped
                        };
                        (kernel, &mut far)
                    } else {
                        (Kernel::Sample, &mut far)
                    }
                }
            };
            // Channel c's disc radius and weight.
            let weigh = |c: usize| match kernel {
                Kernel::Sample => {
                    let r = rp.channel(c);
                    (r, coverage(r, d) * inv_area_p.channel(c))
                }
                Kernel::Centre => {
                    let r = rc.channel(c);
                    (r, coverage(r, d) * inv_area_c.channel(c))
                }
                Kernel::Clamped => {
                    let r = rp.channel(c).min(rc.channel(c));
                    (r, coverage(r, d) * inv_area_p.channel(c))
                }
            };
            let c = color[j];
            match &drops {
                // One radius, no mask: one weight for all channels.
                None if R::MONO => {
                    let (_, wt) = weigh(0);
                    if wt > 0.0 {
                        for k in 0..3 {
                            layer.sum[k] += wt * c[k];
                            layer.weight[k] += wt;
                        }
                    }
                }
                _ => {
                    let owner = if let Kernel::Centre = kernel { i } else { j };
                    for k in 0..3 {
                        let (r, wt) = weigh(k);
                        if wt > 0.0 && !drops.as_ref().is_some_and(|f| f(owner, r, dy, k)) {
                            layer.sum[k] += wt * c[k];
                            layer.weight[k] += wt;
                        }
                    }
                }
            }
        });
        std::array::from_fn(|c| {
            let far_c = far.mean(c, color[i][c]);
            if near.weight[c] > 0.0 {
                let alpha = near.weight[c].min(1.0);
                alpha * near.mean(c, far_c) + (1.0 - alpha) * far_c
            } else {
                far_c
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::super::testkit::*;
    use super::*;

    fn f() -> ScatterAsGather {
        ScatterAsGather::default()
    }

    #[test]
    fn constant_plane_matches_thin_lens() {
        // Plane at 2 m, focus 0.5 m: c = 8·1.5 = 12 px.
        let case = Case::new(&single_plane(64, 48, 2.0), 8.0, 0.5, 256);
        let p = case.psnr(&f(), 8);
        eprintln!("gather plane: {p:.2} dB");
        assert!(p > 40.0, "gather on a plane: {p:.2} dB");
    }

    #[test]
    fn occluder_scenes_reach_33_db() {
        // |c| = 16 px for the blurred plane in each configuration.
        let k = 16.0 / 1.5;
        for edge in [Edge::Straight(40.0), Edge::Circle(40.0, 32.0, 18.0)] {
            let scene = occluder_scene(80, 64, edge, true);
            for focus in [0.5f32, 2.0] {
                let case = Case::new(&scene, k, focus, 400);
                let p = case.psnr(&f(), 8);
                let classic = case.psnr(
                    &ScatterAsGather {
                        fill_behind: false,
                        ..f()
                    },
                    8,
                );
                let one = case.psnr(
                    &ScatterAsGather {
                        separate_near: false,
                        ..f()
                    },
                    8,
                );
                eprintln!(
                    "gather {edge:?} focus {focus} m: {p:.2} dB (classic clamp {classic:.2}, one layer {one:.2})"
                );
                assert!(p >= 33.0, "{edge:?} focus {focus}: {p:.2} dB");
            }
        }
    }

    #[test]
    fn sharp_foreground_keeps_its_edge() {
        // Focus on the flat near occluder (x < 30); textured far plane blurred to c = 20 px.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(30.0), false),
            20.0 / 1.5,
            0.5,
            64,
        );
        let width = edge_width(&column_profile(&case.filtered(&f()), 4, 20), 6);
        let truth = edge_width(&column_profile(&case.truth, 4, 20), 6);
        eprintln!("gather sharp edge: {width:.2} px (thin lens {truth:.2} px)");
        assert!(width <= 1.5, "{width}");
    }

    #[test]
    fn blurred_foreground_has_soft_edges() {
        // Focus on the far plane; the flat near occluder blurred to c = −12 px.
        let case = Case::new(
            &occluder_scene(64, 24, Edge::Straight(32.0), false),
            12.0 / 1.5,
            2.0,
            256,
        );
        let width = edge_width(&column_profile(&case.filtered(&f()), 4, 20), 4);
        let truth = edge_width(&column_profile(&case.truth, 4, 20), 4);
        eprintln!("gather soft edge: {width:.2} px (thin lens {truth:.2} px)");
        assert!(
            width > 5.0 && (width - truth).abs() < 2.0,
            "{width} vs {truth}"
        );
    }

    #[test]
    fn bad_parameters_are_errors() {
        let frame = nan_frame();
        for bad in [
            ScatterAsGather {
                max_radius_px: f32::NAN,
                ..f()
            },
            ScatterAsGather {
                depth_tolerance: 1.0,
                ..f()
            },
        ] {
            assert!(bad.apply(&frame.input()).is_err());
        }
    }
}
