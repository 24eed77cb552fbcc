//! Stage 7 of the frame (DESIGN.md "How a frame flows"): **screen post** on the reconstructed
//! image — peripheral contrast enhancement (Weier Sec. 3.3, `fovea_post::contrast`), then the
//! depth-of-field filter with the eye's circle of confusion at the eye state's focus
//! (`crate::dof`).

use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_post::contrast::enhance;
use fovea_post::Rgb;

use crate::camera::EyeCamera;
use crate::dof::apply_dof;
use crate::error::Result;
use crate::plan::FramePlan;

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

/// Depth of field of `color` with its `depth`, when the plan has DOF and a focus: the blurred
/// image and the signed CoC map (pixels), or `None`.
pub fn depth_of_field(
    plan: &FramePlan,
    camera: &EyeCamera,
    color: &Image<Rgb>,
    depth: &Image<f32>,
) -> Result<Option<(Image<Rgb>, Image<f32>)>> {
    let (Some(d), Some(focus_m)) = (&plan.settings.dof, plan.focus_m()) else {
        return Ok(None);
    };
    let p = plan.eye.gaze.point;
    let r = apply_dof(
        d,
        camera,
        color,
        depth,
        focus_m,
        [p.x_px as f32, p.y_px as f32],
    )?;
    Ok(Some((r.color, r.coc_px)))
}
