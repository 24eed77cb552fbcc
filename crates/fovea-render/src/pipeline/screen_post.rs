//! Stage 7 of the frame (DESIGN.md "How a frame flows"): **screen post** on the reconstructed
//! image — peripheral contrast enhancement (Weier Sec. 3.3, `fovea_post::contrast`), then the
//! depth-of-field filter with the eye's circle of confusion at the eye state's focus
//! (`crate::dof`).
//!
//! Another executor (the GPU's, `fovea-gpu`, plugged in by the CLI) can take over the CoC map
//! and the filter through [`DofExecutor`] for the filters and CoC models it
//! [`supports`](DofExecutor::supports); the frame's stats say which one ran
//! ([`super::FrameStats::dof_backend`]).

use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_post::contrast::enhance;
use fovea_post::dof::coc::{CocModel, CocParams};
use fovea_post::dof::FilterKind;
use fovea_post::Rgb;

use crate::camera::EyeCamera;
use crate::dof::{apply_dof, coc_params};
use crate::error::{RenderError, Result};
use crate::plan::FramePlan;

use super::reconstruct::CPU;

/// Another executor of the depth-of-field stage (e.g. the GPU's), kept in a
/// [`super::FrameContext`] from frame to frame. For the filters and CoC models it
/// [`supports`](Self::supports) it replaces `fovea_post::dof::coc::coc_map` followed by the
/// filter's `apply` (`crate::dof::apply_dof`) and must return what they return; other
/// filters stay on the CPU.
pub trait DofExecutor: Send {
    /// The backend's short name in stats and JSON, e.g. `gpu`.
    fn backend(&self) -> &str;
    /// Whether it runs `filter` (with its default parameters) on a CoC map of `coc_model`.
    fn supports(&self, filter: FilterKind, coc_model: &CocModel) -> bool;
    /// Whether an image of `width_px × height_px` fits it (a device's storage limits); the
    /// CPU filters the frames that do not. Every size, unless the executor says otherwise.
    fn fits(&self, width_px: u32, height_px: u32) -> bool {
        let _ = (width_px, height_px);
        true
    }
    /// The signed CoC map of `depth_m` with `coc` focused at `focus_m` metres, and `filter`
    /// applied to `color` with it: `(blurred, coc_px)`. An error is one line saying what to
    /// do.
    fn depth_of_field(
        &mut self,
        filter: FilterKind,
        coc: &CocParams,
        focus_m: f64,
        color: &Image<Rgb>,
        depth_m: &Image<f32>,
    ) -> std::result::Result<(Image<Rgb>, Image<f32>), String>;
}

/// Peripheral contrast enhancement of `color`, when the plan's settings ask for it: the new
/// image, or `None`.
pub fn contrast(plan: &FramePlan, color: &Image<Rgb>) -> Result<Option<Image<Rgb>>> {
    let Some(c) = &plan.settings.contrast else {
        return Ok(None);
    };
    let (display, gaze) = (&plan.display, plan.eye.gaze);
    let ecc = |x: u32, y: u32| {
        let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
        display.eccentricity(p, &gaze).0 as f32
    };
    let lut = &plan.spacing;
    Ok(Some(enhance(color, c, &ecc, &|e| lut.at(e as f64))?))
}

/// What [`depth_of_field`] produced.
pub struct DofOutput {
    /// The blurred image.
    pub color: Image<Rgb>,
    /// The signed CoC map, pixels.
    pub coc_px: Image<f32>,
    /// The backend that ran it: `cpu` or the executor's name.
    pub backend: String,
}

/// Depth of field of `color` with its `depth`, when the plan has DOF and a focus: the blurred
/// image, the signed CoC map (pixels) and the backend that ran it, or `None`. `executor`, when
/// given (the frame's [`super::StageBackends`] put the stage there), runs it.
pub fn depth_of_field(
    plan: &FramePlan,
    camera: &EyeCamera,
    color: &Image<Rgb>,
    depth: &Image<f32>,
    executor: Option<&mut (dyn DofExecutor + 'static)>,
) -> Result<Option<DofOutput>> {
    let (Some(d), Some(focus_m)) = (&plan.settings.dof, plan.focus_m()) else {
        return Ok(None);
    };
    if let Some(kind) = d.filter {
        if let Some(ex) = executor {
            let params = coc_params(d, camera);
            let (blurred, coc) = ex
                .depth_of_field(kind, &params, focus_m, color, depth)
                .map_err(|message| RenderError::Executor {
                    stage: "dof",
                    backend: ex.backend().to_string(),
                    message,
                })?;
            return Ok(Some(DofOutput {
                color: blurred,
                coc_px: coc,
                backend: ex.backend().to_string(),
            }));
        }
    }
    let p = plan.eye.gaze.point;
    let r = apply_dof(
        d,
        camera,
        color,
        depth,
        focus_m,
        [p.x_px as f32, p.y_px as f32],
    )?;
    Ok(Some(DofOutput {
        color: r.color,
        coc_px: r.coc_px,
        backend: CPU.to_string(),
    }))
}
