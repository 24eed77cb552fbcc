//! Stage 5 of the frame (DESIGN.md "How a frame flows"): **sample-space post** — temporal
//! accumulation (the previous frame reprojected and folded into the fresh samples, see
//! `crate::temporal`) and anti-aliasing inside the sample buffers: FXAA for VaFR and
//! visual-polar (VaFR Sec. 3.4, with the polar seam wrapped), the 3×3 Gaussian for KFR and LaFR
//! (Meng et al.), none for the others unless asked.

use fovea_core::Image;
use fovea_post::fxaa::{fxaa, FxaaParams};
use fovea_post::gaussian_aa::gaussian_3x3;
use fovea_post::grid::Grid;
use fovea_post::inverse_map::SampleBuffers;
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

/// Anti-aliases every layer of `color` with the plan's resolved AA mode.
pub fn anti_alias(plan: &FramePlan, color: &mut [Image<Rgb>]) {
    if plan.aa == AaMode::None {
        return;
    }
    let polar = plan.mapping().polar_layout();
    for c in color.iter_mut() {
        let grid = match &polar {
            Some(l) => Grid::polar(l),
            None => Grid::Rect {
                width: c.width(),
                height: c.height(),
            },
        };
        *c = match plan.aa {
            AaMode::Fxaa => fxaa(c, &grid, &FxaaParams::default()),
            AaMode::Gaussian => gaussian_3x3(c, &grid),
            // `FramePlan` resolves `Auto`; `None` returned above.
            AaMode::None | AaMode::Auto => return,
        };
    }
}
