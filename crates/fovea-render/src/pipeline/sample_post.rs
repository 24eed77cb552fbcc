//! Stage 5 of the frame (DESIGN.md "How a frame flows"): **sample-space post** — temporal
//! accumulation (the previous frame reprojected and folded into the fresh samples, see
//! `crate::temporal`) and anti-aliasing inside the sample buffers: FXAA for VaFR and
//! visual-polar (VaFR Sec. 3.4, with the polar seam wrapped), the 3×3 Gaussian for KFR and LaFR
//! (Meng et al.), none for the others unless asked.

use fovea_core::Image;
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::{minified_columns, ReconstructFilter, SampleBuffers};
use fovea_post::Rgb;

use super::AaMode;
use crate::camera::EyeCamera;
use crate::error::Result;
use crate::plan::FramePlan;
use crate::temporal::{TemporalAccumulator, TemporalStats};

/// Folds the previous frame held by `accumulator` into this frame's `samples` (before AA).
pub fn accumulate(
    plan: &FramePlan,
    camera: &EyeCamera,
    accumulator: &mut TemporalAccumulator,
    samples: &mut SampleBuffers,
) -> Result<TemporalStats> {
    accumulator.accumulate(plan, camera, samples)
}

/// Anti-aliases every layer of `color` with the plan's resolved AA mode. With the footprint
/// reconstruction (the default), the columns of a polar buffer whose texels are smaller than a
/// screen pixel both ways ([`minified_columns`]: VaFR's and visual-polar's fovea) are left as
/// they are: the reconstruction averages every sample a pixel holds there, so an edge is
/// already anti-aliased and FXAA or the Gaussian would only blur it further (issue 17; the
/// measurements are in docs/rendering.md, "Anti-aliasing the fovea and the periphery").
pub fn anti_alias(plan: &FramePlan, color: &mut [Image<Rgb>]) {
    if plan.aa == AaMode::None {
        return;
    }
    let polar = plan.mapping().polar_layout();
    let keep = match plan.settings.reconstruct_filter {
        ReconstructFilter::Footprint => minified_columns(plan.mapping()),
        ReconstructFilter::Bilinear => None,
    };
    for c in color.iter_mut() {
        let grid = match &polar {
            Some(l) => Grid::polar(l),
            None => Grid::Rect {
                width: c.width(),
                height: c.height(),
            },
        };
        let mut out = match plan.aa {
            AaMode::Fxaa => fxaa(c, &grid, &FxaaParams::default()),
            AaMode::Gaussian => gaussian_3x3(c, &grid),
            // `FramePlan` resolves `Auto`; `None` returned above.
            AaMode::None | AaMode::Auto => return,
        };
        if let Some(keep) = &keep {
            restore_columns(&mut out, c, keep);
        }
        *c = out;
    }
}

/// Copies the columns `i` of `original` with `keep[i]` back into `out` (same size; a polar
/// buffer's x is its column `u`, so `keep` applies along every image row).
fn restore_columns(out: &mut Image<Rgb>, original: &Image<Rgb>, keep: &[bool]) {
    let w = out.width() as usize;
    if w == 0 {
        return;
    }
    for (dst, src) in out.data_mut().chunks_mut(w).zip(original.data().chunks(w)) {
        for ((d, s), _) in dst.iter_mut().zip(src).zip(keep).filter(|(_, &k)| k) {
            *d = *s;
        }
    }
}
