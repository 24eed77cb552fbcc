//! Gaze-contingent depth-of-field filters (DESIGN.md stage 7, "screen post").
//!
//! Every filter works on the same [`DofInput`]: the pinhole colour image, its view depth and a
//! signed circle-of-confusion map in screen pixels (near negative, far positive; see
//! [`coc`]). Each filter lives in its own file, named after the technique, with its paper in
//! the module header:
//!
//! | file | filter | paper |
//! |---|---|---|
//! | [`bokeh_lca`] | disc bokeh with Liu's row-wise chromatic filter | Liu et al. Sec. 3.3.1–3.3.2 |
//! | [`chromatic`] | per-channel defocus by the eye's chromatic focus shift | Thibos et al. 1992 (none of the papers) |
//! | [`layered`] | near/mid/far layers, Gaussian in the fovea, mip blur in the periphery | Weier et al. Sec. 3.2 |
//! | [`adaptive_coc`] | adaptive CoC gather with intensity-leakage control | Konrad III-B, Zhou et al. 2007 |
//! | [`bilateral`] | depth-aware bilateral filter | Konrad III-C |
//! | [`recursive`] | adaptive recursive filter, four directions, three passes | Konrad III-D, Xu et al. 2014 |
//! | [`gather`] | scatter-as-gather near/far filter (the game-engine baseline) | — |
//!
//! A filter never panics on its input: NaN depths count as "no hit" (infinitely far), NaN
//! CoCs as in focus, and a CoC map of another size than the colour image is an
//! [`fovea_core::FoveaError::InvalidParameter`].

use fovea_core::{FoveaError, Image, Result};

use crate::Rgb;

pub mod adaptive_coc;
pub mod bilateral;
pub mod bokeh_lca;
pub mod chromatic;
pub mod coc;
mod disc;
pub mod gather;
pub mod layered;
pub mod planes;
pub mod recursive;
#[cfg(test)]
pub(crate) mod testkit;

/// What every DOF filter reads.
#[derive(Clone, Copy, Debug)]
pub struct DofInput<'a> {
    /// Linear RGB of the pinhole (all-in-focus) frame.
    pub color: &'a Image<Rgb>,
    /// View depth in metres; `+∞` where no surface was hit. NaN is treated as `+∞`.
    pub depth_m: &'a Image<f32>,
    /// Signed CoC diameter in screen pixels: negative in front of the focus, positive
    /// behind, `0` in focus. Non-finite values are treated as `0`.
    pub coc_px: &'a Image<f32>,
    /// The focus distance in metres (finite, > 0; `+∞` for focus at infinity).
    pub focus_m: f32,
    /// CoC diameter in pixels per dioptre of defocus: `pupil (m) · focal length (px)`, so that
    /// the thin-lens eye's CoC is `px_per_dioptre · (1/focus − 1/depth)`. Filters that model
    /// per-channel focus shifts ([`chromatic`]) use it; `0` for a pinhole.
    pub px_per_dioptre: f32,
    /// Gaze point on the screen in pixels (filters that treat fovea and periphery apart).
    pub gaze_px: [f32; 2],
    /// Display pixels per degree near the gaze (foveal region sizes).
    pub px_per_degree: f32,
}

impl DofInput<'_> {
    /// Width and height of the frame.
    pub fn size(&self) -> (u32, u32) {
        (self.color.width(), self.color.height())
    }

    /// Checks that the depth and CoC maps match the colour image and the scalars are sane.
    pub fn validate(&self) -> Result<()> {
        let (w, h) = self.size();
        for (name, iw, ih) in [
            ("depth_m", self.depth_m.width(), self.depth_m.height()),
            ("coc_px", self.coc_px.width(), self.coc_px.height()),
        ] {
            if (iw, ih) != (w, h) {
                return Err(FoveaError::invalid(
                    name,
                    format!("{iw}x{ih}"),
                    format!("the colour image's size {w}x{h}"),
                ));
            }
        }
        if self.focus_m.is_nan() || self.focus_m <= 0.0 {
            return Err(FoveaError::invalid(
                "focus_m",
                self.focus_m,
                "a distance > 0 m (or +∞)",
            ));
        }
        if !(self.px_per_dioptre.is_finite() && self.px_per_dioptre >= 0.0) {
            return Err(FoveaError::invalid(
                "px_per_dioptre",
                self.px_per_dioptre,
                "a finite number ≥ 0",
            ));
        }
        if !(self.px_per_degree.is_finite() && self.px_per_degree > 0.0) {
            return Err(FoveaError::invalid(
                "px_per_degree",
                self.px_per_degree,
                "a finite number > 0",
            ));
        }
        if !(self.gaze_px[0].is_finite() && self.gaze_px[1].is_finite()) {
            return Err(FoveaError::invalid(
                "gaze_px",
                format!("{:?}", self.gaze_px),
                "a finite screen point",
            ));
        }
        Ok(())
    }

    /// Depth at `(x, y)` with NaN and non-positive values mapped to `+∞`.
    #[inline]
    pub fn depth_at(&self, x: u32, y: u32) -> f32 {
        sanitize_depth(*self.depth_m.get(x, y))
    }

    /// Signed CoC at `(x, y)` with non-finite values mapped to 0.
    #[inline]
    pub fn coc_at(&self, x: u32, y: u32) -> f32 {
        sanitize_coc(*self.coc_px.get(x, y))
    }
}

/// NaN and non-positive depths become `+∞` ("no hit").
#[inline]
pub fn sanitize_depth(d: f32) -> f32 {
    if d > 0.0 {
        d
    } else {
        f32::INFINITY
    }
}

/// Non-finite CoCs become 0 (in focus).
#[inline]
pub fn sanitize_coc(c: f32) -> f32 {
    if c.is_finite() {
        c
    } else {
        0.0
    }
}

/// A depth-of-field filter on (colour, depth, CoC).
pub trait DofFilter: Send + Sync {
    /// Short name as the CLI spells it (`bokeh-lca`, `layered`, …).
    fn name(&self) -> &'static str;
    /// Applies the filter; the result has the input's size.
    fn apply(&self, input: &DofInput) -> Result<Image<Rgb>>;
}

/// Every filter, by the name the CLI uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterKind {
    /// [`bokeh_lca::BokehLca`] with Liu's chromatic rows.
    BokehLca,
    /// [`bokeh_lca::BokehLca`] without LCA.
    Bokeh,
    /// [`chromatic::PhysicalLca`].
    PhysicalLca,
    /// [`layered::Layered`].
    Layered,
    /// [`adaptive_coc::AdaptiveCoc`].
    AdaptiveCoc,
    /// [`bilateral::DepthBilateral`].
    Bilateral,
    /// [`recursive::AdaptiveRecursive`].
    Recursive,
    /// [`gather::ScatterAsGather`].
    Gather,
}

impl FilterKind {
    /// All filters, in the order tables list them.
    pub const ALL: [FilterKind; 8] = [
        FilterKind::Bokeh,
        FilterKind::BokehLca,
        FilterKind::PhysicalLca,
        FilterKind::Layered,
        FilterKind::AdaptiveCoc,
        FilterKind::Bilateral,
        FilterKind::Recursive,
        FilterKind::Gather,
    ];

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::BokehLca => "bokeh-lca",
            FilterKind::Bokeh => "bokeh",
            FilterKind::PhysicalLca => "physical-lca",
            FilterKind::Layered => "layered",
            FilterKind::AdaptiveCoc => "adaptive-coc",
            FilterKind::Bilateral => "bilateral",
            FilterKind::Recursive => "recursive",
            FilterKind::Gather => "gather",
        }
    }

    /// Parses a CLI name.
    pub fn parse(s: &str) -> Result<Self> {
        let t = s.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|k| k.name() == t)
            .ok_or_else(|| {
                FoveaError::invalid("dof filter", s, Self::ALL.map(|k| k.name()).join(", "))
            })
    }

    /// The filter with its default parameters.
    pub fn build(self) -> Box<dyn DofFilter> {
        match self {
            FilterKind::BokehLca => Box::new(bokeh_lca::BokehLca {
                lca: true,
                ..Default::default()
            }),
            FilterKind::Bokeh => Box::new(bokeh_lca::BokehLca {
                lca: false,
                ..Default::default()
            }),
            FilterKind::PhysicalLca => Box::new(chromatic::PhysicalLca::default()),
            FilterKind::Layered => Box::new(layered::Layered::default()),
            FilterKind::AdaptiveCoc => Box::new(adaptive_coc::AdaptiveCoc::default()),
            FilterKind::Bilateral => Box::new(bilateral::DepthBilateral::default()),
            FilterKind::Recursive => Box::new(recursive::AdaptiveRecursive::default()),
            FilterKind::Gather => Box::new(gather::ScatterAsGather::default()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::testkit::*;
    use super::*;

    #[test]
    fn names_round_trip() {
        for kind in FilterKind::ALL {
            assert_eq!(kind.build().name(), kind.name());
            assert_eq!(FilterKind::parse(kind.name()).unwrap(), kind);
        }
        assert!(FilterKind::parse("blur").is_err());
    }

    #[test]
    fn every_filter_is_the_identity_without_blur() {
        // A pinhole (no aperture): every CoC is 0.
        let frame = Frame::from_scene(
            &occluder_scene(48, 32, Edge::Straight(20.0), true),
            0.0,
            1.0,
        );
        for kind in FilterKind::ALL {
            assert_eq!(frame.filtered(&*kind.build()), frame.color, "{kind:?}");
        }
    }

    #[test]
    fn every_filter_gives_finite_output_on_nan_depth_and_coc() {
        let frame = nan_frame();
        for kind in FilterKind::ALL {
            assert!(all_finite(&frame.filtered(&*kind.build())), "{kind:?}");
        }
    }

    #[test]
    fn tiny_and_odd_frames_work_for_every_filter() {
        for (w, h) in [(1u32, 1u32), (1, 7), (9, 1), (5, 3)] {
            let color = Image::new(w, h, [0.2f32, 0.4, 0.6]).unwrap();
            let depth =
                Image::from_vec(w, h, (0..w * h).map(|i| 0.3 + i as f32).collect()).unwrap();
            let coc = depth.map(|&d| thin_lens_coc(30.0, 1.0, d));
            for (ppd, gaze) in [(1000.0f32, [0.0f32, 0.0f32]), (0.05, [2.0, 1.0])] {
                let frame = Frame {
                    color: color.clone(),
                    depth: depth.clone(),
                    coc: coc.clone(),
                    focus_m: 1.0,
                    k: 30.0,
                    gaze,
                    ppd,
                };
                for kind in FilterKind::ALL {
                    let out = frame.filtered(&*kind.build());
                    assert_eq!((out.width(), out.height()), (w, h));
                    // A uniform colour stays uniform under every filter.
                    for p in out.data() {
                        for c in 0..3 {
                            assert!((p[c] - [0.2, 0.4, 0.6][c]).abs() < 1e-5, "{kind:?} {p:?}");
                        }
                    }
                }
            }
        }
    }
}
