//! Stage 6 of the frame (DESIGN.md "How a frame flows"): **reconstruct** — the sample buffers
//! back to screen pixels through the plan's mapping (`fovea_post::inverse_map`: the inverse
//! mapping with filtered lookups for polar buffers, layer lookups for Guenter and insets,
//! pull-push for Weier's sparse set, the buffer itself at full resolution), then, for the
//! inset method, the boundary between the full-resolution inset and the upsampled periphery
//! smoothed with the chosen method of Liu et al.'s inset paper (`fovea_post::inset_smoothing`,
//! Sec. 3; alpha blend by default, the smoothing closest to the full frame's gradients in
//! `fovea report`'s inset table).
//!
//! Another executor (the GPU's, `fovea-gpu`, plugged in by the CLI) can take over the polar
//! lookup through [`ReconstructExecutor`]; the frame's stats say which one ran
//! ([`super::FrameStats::reconstruct_backend`]).

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{FoveationMapping, Method, SamplePoint};
use fovea_core::Image;
use fovea_post::inset_smoothing::{composite, Rect, Smoothing};
use fovea_post::inverse_map::{reconstruct_into, ReconstructFilter, SampleBuffers};
use fovea_post::Rgb;

use crate::error::{RenderError, Result};
use crate::plan::FramePlan;

/// Another executor of the reconstruct stage's lookup (e.g. the GPU's), kept in a
/// [`super::FrameContext`] from frame to frame. For the mappings it [`supports`](Self::supports)
/// it replaces `fovea_post::inverse_map::reconstruct_into` and must write every pixel of
/// `color` and `depth` as that function does; the rest of the stage (inset smoothing) and
/// every other stage stay on the CPU.
pub trait ReconstructExecutor: Send {
    /// The backend's short name in stats and JSON, e.g. `gpu`.
    fn backend(&self) -> &str;
    /// Whether it reconstructs `mapping`'s buffers (the CPU does the others).
    fn supports(&self, mapping: &dyn FoveationMapping) -> bool;
    /// `samples` through `mapping` to the screen of `display`, read with `filter`. An error is
    /// one line saying what to do.
    fn reconstruct_into(
        &mut self,
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        samples: &SampleBuffers,
        filter: ReconstructFilter,
        color: &mut Image<Rgb>,
        depth: &mut Image<f32>,
    ) -> std::result::Result<(), String>;
}

/// Reconstructs `samples` into the screen-sized `color` and `depth`, on `executor` when given
/// (the frame's [`super::StageBackends`] put the stage there) and on the CPU otherwise.
/// Returns the inset smoothing applied (`None` for other methods, and for an inset whose
/// periphery is not an exact 2× or 4× subsampling of the screen, which keeps the hard
/// boundary).
pub fn reconstruct(
    plan: &FramePlan,
    samples: &mut SampleBuffers,
    color: &mut Image<Rgb>,
    depth: &mut Image<f32>,
    executor: Option<&mut (dyn ReconstructExecutor + 'static)>,
) -> Result<Option<Smoothing>> {
    if plan.method() == Method::Full {
        // The buffer is the screen: handed over, nothing copied.
        std::mem::swap(&mut samples.color[0], color);
        std::mem::swap(&mut samples.depth[0], depth);
        return Ok(None);
    }
    if let Some(ex) = executor {
        ex.reconstruct_into(
            plan.mapping(),
            &plan.display,
            samples,
            plan.settings.reconstruct_filter,
            color,
            depth,
        )
        .map_err(|message| RenderError::Executor {
            stage: "reconstruct",
            backend: ex.backend().to_string(),
            message,
        })?;
        return Ok(None);
    }
    reconstruct_on_cpu(plan, samples, color, depth)
}

/// The name of the CPU backend in stats.
pub const CPU: &str = "cpu";

fn reconstruct_on_cpu(
    plan: &FramePlan,
    samples: &mut SampleBuffers,
    color: &mut Image<Rgb>,
    depth: &mut Image<f32>,
) -> Result<Option<Smoothing>> {
    reconstruct_into(
        plan.mapping(),
        &plan.display,
        samples,
        color,
        depth,
        plan.settings.reconstruct_filter,
    )?;
    let smoothing = plan.settings.inset_smoothing;
    if plan.method() != Method::Inset || smoothing == Smoothing::None {
        return Ok(None);
    }
    let Some(rect) = inset_rect(plan) else {
        return Ok(None);
    };
    let (w, h) = (plan.display.width_px, plan.display.height_px);
    let periphery = &samples.color[1];
    let factor = w / periphery.width().max(1);
    let exact = matches!(factor, 2 | 4)
        && periphery.width() * factor == w
        && periphery.height() * factor == h;
    if !exact {
        return Ok(None);
    }
    *color = composite(&samples.color[0], rect, periphery, w, h, smoothing)?;
    Ok(Some(smoothing))
}

/// The inset's screen rectangle: layer 0's first texel centre through the inverse mapping,
/// and the layer's size (the inset is sampled at screen resolution).
fn inset_rect(plan: &FramePlan) -> Option<Rect> {
    let b = plan.buffers.first()?;
    let p = plan.mapping().inverse(SamplePoint {
        layer: 0,
        u: 0.5,
        v: 0.5,
    })?;
    let (x0, y0) = ((p.x_px - 0.5).round(), (p.y_px - 0.5).round());
    (x0 >= 0.0 && y0 >= 0.0).then_some(Rect {
        x0: x0 as u32,
        y0: y0 as u32,
        w: b.width,
        h: b.height,
    })
}
