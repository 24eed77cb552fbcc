//! The inset paper's gradient-intensity table (Liu et al., inset boundary smoothing, Sec. 4,
//! Fig. 8). A scene is rendered at full resolution (the reference), as a full-resolution inset
//! around the gaze, and as a periphery at reduced resolution — by default 1/4 per side, the
//! paper's "rendered at 1/4 normal resolution and then upsampled by 4×" (`periphery_factor` 2
//! for a quarter of the pixels) — rendered, not down-sampled. The two are composited with each
//! boundary-smoothing method (hard, alpha blend, 1D/2D Gaussian with and without alpha,
//! Laplacian pyramid) and every composite gets the gradient analysis
//! ([`crate::gradient_intensity`]: grey, 3×3 Sobel ×100, four areas across the inset
//! boundary).
//!
//! **Shading** ([`InsetParams::shading`], issue 38): by default the viewer's
//! ([`MeasuredShading::Viewer`]: the real-time preset with the sample-space denoiser): the
//! inset and the periphery are full-resolution pipeline frames of the screen and of the
//! reduced display, denoised, and the row `full` is a converged reference of the same shading
//! (`reference_pixel_samples` rays per pixel, not denoised), with its twin of another seed as
//! the row `full, seed 1 (noise floor)`: the two rows' difference is how far the reference's
//! own noise moves the gradients. [`MeasuredShading::NoiseFree`] renders every image with the
//! noise-free shading at pixel centres, the reference being the inset's own frame, as before.

use std::path::PathBuf;

use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::ScreenPoint;
use fovea_core::Image;
use fovea_post::inset_smoothing::{composite, Rect, Smoothing};
use fovea_post::Rgb;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::shade::ShadingMode;
use fovea_render::thin_lens::{render_window, Window};
use fovea_render::world::World;

use crate::error::{EvalError, Result};
use crate::gradient_intensity::{gradient_areas, GradientReport, DEFAULT_BAND_PX};
use crate::metrics::{crop, Region};
use crate::reference::{render_reference, MeasuredShading, NoiseFloor, DEFAULT_REFERENCE_SEEDS};

use super::{create_dir, write_png};

/// Widest Area2/Area3 band, pixels.
pub const MAX_BAND_PX: u32 = 256;

/// Smallest display side, pixels.
pub const MIN_SIDE_PX: u32 = 32;

/// Parameters of the inset analysis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InsetParams {
    /// Inset size `[w, h]` in pixels, at least 4 × `band_px` and smaller than the screen.
    /// Default: `None`, 1/4 of each side (the paper's "1/4 × 1/4 the size of the entire
    /// frame").
    pub inset_size: Option<[u32; 2]>,
    /// The periphery's resolution divisor per side: 4 (the paper's) or 2. Default: 4.
    pub periphery_factor: u32,
    /// Width in pixels of Area2 and Area3 on either side of the boundary, 1 to
    /// [`MAX_BAND_PX`]. Default: [`DEFAULT_BAND_PX`].
    pub band_px: u32,
    /// Write `full.png` and one PNG per composite (`none.png`, `alpha-blend.png`, …) into
    /// this folder. Default: none.
    pub images: Option<PathBuf>,
    /// The shading of every image (module header). Default: the viewer's.
    pub shading: MeasuredShading,
    /// Rays per pixel of the full-resolution reference with the viewer's shading, 2 to
    /// `fovea_render::settings::MAX_PIXEL_SAMPLES`. Default:
    /// [`DEFAULT_INSET_REFERENCE_PIXEL_SAMPLES`].
    pub reference_pixel_samples: u32,
}

/// Rays per pixel of the inset analysis' reference with the viewer's shading by default: the
/// gradients are means over bands of thousands of pixels, so the reference's noise moves them
/// less than a pixel-by-pixel score (the noise-floor row says by how much).
pub const DEFAULT_INSET_REFERENCE_PIXEL_SAMPLES: u32 = 64;

impl Default for InsetParams {
    fn default() -> Self {
        Self {
            inset_size: None,
            periphery_factor: 4,
            band_px: DEFAULT_BAND_PX,
            images: None,
            shading: MeasuredShading::Viewer,
            reference_pixel_samples: DEFAULT_INSET_REFERENCE_PIXEL_SAMPLES,
        }
    }
}

impl InsetParams {
    /// Checks the parameters on their own: a periphery factor of 2 or 4, a band of 1 to
    /// [`MAX_BAND_PX`] pixels, an inset of at least 4 bands per side.
    pub fn validate(&self) -> Result<()> {
        let f = self.periphery_factor;
        if f != 2 && f != 4 {
            return Err(EvalError::invalid("periphery-factor", f, "2 or 4"));
        }
        if !(1..=MAX_BAND_PX).contains(&self.band_px) {
            return Err(EvalError::invalid(
                "band",
                self.band_px,
                format!("1 to {MAX_BAND_PX}"),
            ));
        }
        if let Some([w, h]) = self.inset_size {
            if w < 4 * self.band_px || h < 4 * self.band_px {
                return Err(inset_size_error(w, h));
            }
        }
        let max = fovea_render::settings::MAX_PIXEL_SAMPLES;
        if !(2..=max).contains(&self.reference_pixel_samples) {
            return Err(EvalError::invalid(
                "reference-pixel-samples",
                self.reference_pixel_samples,
                format!("2 to {max}"),
            ));
        }
        Ok(())
    }

    /// Checks the parameters against `display`: sides of at least [`MIN_SIDE_PX`] divisible
    /// by the periphery factor, an inset smaller than the screen.
    pub fn check_display(&self, display: &DisplayProfile) -> Result<()> {
        let (w, h, f) = (display.width_px, display.height_px, self.periphery_factor);
        if f == 0 || w % f != 0 || h % f != 0 || w < MIN_SIDE_PX || h < MIN_SIDE_PX {
            return Err(EvalError::invalid(
                "display",
                format!("{w}x{h}"),
                format!("sides of at least {MIN_SIDE_PX} px divisible by the periphery factor {f}"),
            ));
        }
        if let Some([iw, ih]) = self.inset_size {
            if iw >= w || ih >= h {
                return Err(inset_size_error(iw, ih));
            }
        }
        Ok(())
    }

    /// The inset rectangle around `gaze` on `display` (clipped to stay on the screen).
    pub fn rect(&self, display: &DisplayProfile, gaze: &Gaze) -> Result<Rect> {
        self.check_display(display)?;
        let (w, h) = (display.width_px, display.height_px);
        let [iw, ih] = self.inset_size.unwrap_or([w / 4, h / 4]);
        let win = Window::centred(gaze.point.x_px, gaze.point.y_px, iw, ih, w, h);
        Ok(Rect {
            x0: win.x0,
            y0: win.y0,
            w: win.width,
            h: win.height,
        })
    }
}

fn inset_size_error(w: u32, h: u32) -> EvalError {
    EvalError::invalid(
        "inset-size",
        format!("{w}x{h}"),
        "WxH smaller than the screen and at least 4 × band",
    )
}

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `full` (the reference), `none` (hard composite) or the smoothing.
    pub method: String,
    /// The analysis.
    pub report: GradientReport,
    /// Mean gradient of Area2 over Area3 (just inside over just outside the boundary), x
    /// and y: the full frame's is the target.
    pub area2_over_area3: [f64; 2],
    /// Area1 mean gradient magnitude relative to the full frame's, minus 1.
    pub area1_change: f64,
}

/// What the analysis found.
#[derive(Clone, Debug, Serialize)]
pub struct InsetAnalysis {
    /// Scene name.
    pub scene: String,
    /// Display name.
    pub display: String,
    /// The inset on the screen.
    pub inset: Rect,
    /// The periphery's size, pixels.
    pub periphery_px: [u32; 2],
    /// The parameters.
    pub params: InsetParams,
    /// The full frame first, then the hard composite and each smoothing.
    pub rows: Vec<Row>,
    /// The reference's twin of another seed, analysed like the rows (viewer's shading only).
    pub floor_row: Option<Row>,
    /// The reference's noise floor (luma PSNR and ꟻLIP of the twin against it).
    pub floor: NoiseFloor,
}

impl InsetAnalysis {
    /// The JSON of `fovea inset-analysis --json` (`inset-analysis.json`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "scene": self.scene,
            "display": self.display,
            "inset": self.inset,
            "band_px": self.params.band_px,
            "periphery_factor": self.params.periphery_factor,
            "shading": self.params.shading.name(),
            "reference_pixel_samples": self.params.reference_pixel_samples,
            "noise_floor": self.floor.json(),
            "noise_floor_row": self.floor_row,
            "rows": self.rows,
        })
    }
}

/// The composites in table order: the hard one, then each smoothing, with their names
/// (Liu et al.'s inset paper, Sec. 3: [`Smoothing::ALL`]).
pub fn smoothings() -> Vec<(&'static str, Smoothing)> {
    Smoothing::ALL.to_vec()
}

/// Renders the full frame and the periphery seen by `camera`, composites them around `gaze`
/// with every smoothing and analyses each composite, shaded as `params.shading` says (module
/// header).
pub fn run(
    world: &World,
    camera: &EyeCamera,
    gaze: &Gaze,
    params: &InsetParams,
) -> Result<InsetAnalysis> {
    params.validate()?;
    let display = &camera.display;
    let rect = params.rect(display, gaze)?;
    let (w, h, f, band) = (
        display.width_px,
        display.height_px,
        params.periphery_factor,
        params.band_px,
    );
    let noisy = params.shading.is_noisy();
    let shading: ShadingMode = params.shading.shading();
    // A frame at pixel centres: noise-free, the ray caster's; with the viewer's shading, the
    // pipeline's full-resolution frame, denoised.
    let frame = |camera: &EyeCamera, w: u32, h: u32| -> Result<Image<Rgb>> {
        if noisy {
            let mut s = FrameSettings::new(Method::Full);
            params.shading.apply(&mut s);
            let g = camera.display.centre_gaze();
            Ok(render_frame(world, camera, &s, g, &|_, _| {})?.color)
        } else {
            let win = Window::full(w, h);
            Ok(render_window(world, camera, win, None, 1, shading, &|_, _| {})?.color)
        }
    };
    // The inset's frame, and the periphery on a display of 1/f of the pixels per side with
    // the same field of view.
    let full = frame(camera, w, h)?;
    // The inset's rays are the full frame's pixel-centre rays inside the rectangle.
    let inset = crop(
        &full,
        Region {
            x0: rect.x0,
            y0: rect.y0,
            x1: rect.x0 + rect.w,
            y1: rect.y0 + rect.h,
        },
    )
    .ok_or_else(|| EvalError::invalid("inset", format!("{rect:?}"), "a rectangle on the screen"))?;
    let low_display = DisplayProfile {
        name: format!("{}-div{f}", display.name),
        width_px: w / f,
        height_px: h / f,
        lens_centre_px: display
            .lens_centre_px
            .map(|p| ScreenPoint::new(p.x_px / f as f64, p.y_px / f as f64)),
        ..display.clone()
    };
    let low_camera = EyeCamera::new(camera.position, camera.forward, camera.up, &low_display)?;
    let low = frame(&low_camera, w / f, h / f)?;
    // The reference: the inset's own frame without noise; a converged frame and its twin
    // with the viewer's shading.
    let (reference_img, twin, floor) = if noisy {
        let r = render_reference(
            world,
            camera,
            params.shading,
            params.reference_pixel_samples,
            *gaze,
            DEFAULT_REFERENCE_SEEDS,
        )?;
        (r.frame.color, r.twin.map(|t| t.color), r.floor)
    } else {
        let floor =
            crate::reference::noise_floor(&full, &full, DEFAULT_REFERENCE_SEEDS, display.ppd())?;
        (full.clone(), None, floor)
    };

    if let Some(dir) = &params.images {
        create_dir(dir)?;
        write_png(&dir.join("full.png"), &reference_img)?;
    }
    let reference = gradient_areas(&reference_img, rect, band)?;
    let mut rows = vec![row("full", reference.clone(), &reference)];
    let floor_row = match &twin {
        Some(t) => Some(row(
            &format!("full, seed {} (noise floor)", floor.seeds[1]),
            gradient_areas(t, rect, band)?,
            &reference,
        )),
        None => None,
    };
    for (name, m) in smoothings() {
        let img: Image<Rgb> = composite(&inset, rect, &low, w, h, m)?;
        if let Some(dir) = &params.images {
            write_png(&dir.join(format!("{name}.png")), &img)?;
        }
        rows.push(row(name, gradient_areas(&img, rect, band)?, &reference));
    }
    Ok(InsetAnalysis {
        scene: world.scene.name.clone(),
        display: display.name.clone(),
        inset: rect,
        periphery_px: [w / f, h / f],
        params: params.clone(),
        rows,
        floor_row,
        floor,
    })
}

fn row(method: &str, report: GradientReport, full: &GradientReport) -> Row {
    let rel = |a: f64, b: f64| {
        if b.abs() > 1e-12 {
            (a - b) / b.abs()
        } else {
            0.0
        }
    };
    let div = |a: f64, b: f64| if b.abs() > 1e-12 { a / b } else { f64::NAN };
    let a = &report.areas;
    Row {
        method: method.to_string(),
        area2_over_area3: [div(a[1].mean_x, a[2].mean_x), div(a[1].mean_y, a[2].mean_y)],
        area1_change: rel(report.areas[0].mean_magnitude, full.areas[0].mean_magnitude),
        report,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::units::Degrees;

    use crate::experiments::invalid_parameter as invalid;

    #[test]
    fn default_params_are_valid_and_centre_a_quarter_inset() {
        let p = InsetParams::default();
        p.validate().unwrap();
        let d = DisplayProfile::with_vertical_fov("t", 1440, 1600, Degrees(110.0)).unwrap();
        p.check_display(&d).unwrap();
        let r = p.rect(&d, &d.centre_gaze()).unwrap();
        assert_eq!((r.w, r.h), (360, 400));
        assert_eq!((r.x0, r.y0), (540, 600));
        assert_eq!(smoothings().len(), 7);
    }

    #[test]
    fn bad_params_give_typed_errors() {
        let bad = |f: &dyn Fn(&mut InsetParams)| {
            let mut p = InsetParams::default();
            f(&mut p);
            p.validate()
        };
        assert_eq!(
            invalid(bad(&|p| p.periphery_factor = 3)),
            "periphery-factor"
        );
        assert_eq!(
            invalid(bad(&|p| p.periphery_factor = 0)),
            "periphery-factor"
        );
        assert_eq!(invalid(bad(&|p| p.band_px = 0)), "band");
        assert_eq!(invalid(bad(&|p| p.band_px = MAX_BAND_PX + 1)), "band");
        assert_eq!(
            invalid(bad(&|p| p.inset_size = Some([10, 10]))),
            "inset-size"
        );
        let p = InsetParams::default();
        let odd = DisplayProfile::with_vertical_fov("t", 322, 240, Degrees(90.0)).unwrap();
        let e = p.check_display(&odd).unwrap_err();
        assert_eq!(invalid(Err(e.clone())), "display");
        assert!(e.to_string().contains("periphery factor 4"), "{e}");
        let tiny = DisplayProfile::with_vertical_fov("t", 16, 16, Degrees(90.0)).unwrap();
        assert_eq!(invalid(p.check_display(&tiny)), "display");
        let d = DisplayProfile::with_vertical_fov("t", 128, 128, Degrees(90.0)).unwrap();
        let big = InsetParams {
            inset_size: Some([128, 64]),
            ..InsetParams::default()
        };
        assert_eq!(invalid(big.check_display(&d)), "inset-size");
    }
}
