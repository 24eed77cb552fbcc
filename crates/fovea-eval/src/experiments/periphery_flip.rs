//! "No magnified noise" (issue 38): ꟻLIP (Andersson et al. 2020) in the band of eccentricity
//! beyond 30° from the gaze, where VaFR's reconstruction magnifies each texel into a blob of
//! several pixels, of two frames against a converged full-resolution reference of the same
//! shading:
//!
//! * **VaFR** as a viewer renders one frame: the real-time shading (direct light, one
//!   environment ray per sample) with the sample-space denoiser
//!   ([`MeasuredShading::Viewer`]);
//! * **the one-ray full-resolution frame without denoising**: the same shading, one primary
//!   ray per pixel, no denoiser — the noise a frame has when nothing magnifies it.
//!
//! VaFR is no worse than the one-ray frame there when its ꟻLIP beyond 30° is at most the
//! one-ray frame's. The reference has `reference_pixel_samples` rays per pixel; its noise floor
//! ([`crate::reference`]: a twin of another seed scored against it) is given over the whole
//! frame and in the same band, per gaze. The band is VaFR Eq. 3's eccentricity of the pixel
//! centre ([`crate::bands::band_mask`]); ꟻLIP is computed over the whole frame at the display's
//! pixels per degree and averaged over the band's pixels ([`crate::bands::masked_flip`]).

use serde::Serialize;

use fovea_core::display::{DisplayProfile, Gaze};
use fovea_core::mapping::Method;
use fovea_core::units::Degrees;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{FrameSettings, Stage};
use fovea_render::world::World;

use crate::bands::{band_mask, masked_flip};
use crate::error::{EvalError, Result};
use crate::reference::{
    noise_floor, render_seeded, MeasuredShading, NoiseFloor, DEFAULT_REFERENCE_PIXEL_SAMPLES,
    DEFAULT_REFERENCE_SEEDS,
};

/// Parameters of the measurement.
#[derive(Clone, Debug, Serialize)]
pub struct PeripheryFlipParams {
    /// Primary rays per pixel of the full-resolution reference, 2 to
    /// `fovea_render::settings::MAX_PIXEL_SAMPLES`. Default:
    /// [`DEFAULT_REFERENCE_PIXEL_SAMPLES`] (256).
    pub reference_pixel_samples: u32,
    /// Seeds of the reference and of its twin (the noise floor). Default: 0 and 1.
    pub seeds: [u64; 2],
    /// Inner edge of the band, degrees of eccentricity. Default: 30.
    pub band_lo_deg: f64,
}

impl Default for PeripheryFlipParams {
    fn default() -> Self {
        Self {
            reference_pixel_samples: DEFAULT_REFERENCE_PIXEL_SAMPLES,
            seeds: DEFAULT_REFERENCE_SEEDS,
            band_lo_deg: 30.0,
        }
    }
}

impl PeripheryFlipParams {
    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        let max = fovea_render::settings::MAX_PIXEL_SAMPLES;
        if !(2..=max).contains(&self.reference_pixel_samples) {
            return Err(EvalError::invalid(
                "reference-pixel-samples",
                self.reference_pixel_samples,
                format!("2 to {max} (a one-ray reference is the one-ray frame itself)"),
            ));
        }
        if self.seeds[0] == self.seeds[1] {
            return Err(EvalError::invalid(
                "seeds",
                format!("{:?}", self.seeds),
                "two different seeds (the same seed renders the same reference)",
            ));
        }
        if !(self.band_lo_deg.is_finite() && (0.0..90.0).contains(&self.band_lo_deg)) {
            return Err(EvalError::invalid(
                "band",
                self.band_lo_deg,
                "an eccentricity in [0, 90) degrees",
            ));
        }
        Ok(())
    }
}

/// The three gazes on `display`: the centre, 25° right of it (Eq. 3) and near the
/// top-left corner (7 % of the width, 6.25 % of the height in), as `fovea fidelity`.
pub fn standard_gazes(display: &DisplayProfile) -> Result<Vec<(String, Gaze)>> {
    let c = display.centre_gaze().point;
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    Ok(vec![
        ("centre".to_string(), display.centre_gaze()),
        (
            "25°".to_string(),
            display.gaze(c.x_px + display.radius_px(Degrees(25.0)), c.y_px)?,
        ),
        (
            "near-corner".to_string(),
            display.gaze(0.07 * w, 0.0625 * h)?,
        ),
    ])
}

/// One gaze.
#[derive(Clone, Debug, Serialize)]
pub struct GazeRow {
    /// The gaze's name (`centre`, `25°`, `near-corner`, or its pixels).
    pub gaze: String,
    /// The gaze point, pixels.
    pub gaze_px: [f64; 2],
    /// Pixels in the band.
    pub band_pixels: u64,
    /// VaFR (denoised) ꟻLIP in the band.
    pub vafr_flip: Option<f64>,
    /// The one-ray full-resolution frame's (not denoised) ꟻLIP in the band.
    pub one_ray_flip: Option<f64>,
    /// The reference's noise floor in the band: its twin's ꟻLIP there.
    pub floor_flip: Option<f64>,
    /// VaFR's ꟻLIP over the whole frame.
    pub vafr_flip_whole: f64,
    /// VaFR's frame CPU time and its denoise stage's, ms.
    pub vafr_cpu_ms: [f64; 2],
    /// VaFR's shaded samples.
    pub vafr_samples: u64,
}

impl GazeRow {
    /// VaFR's ꟻLIP in the band over the one-ray frame's (≤ 1: no magnified noise).
    pub fn ratio(&self) -> Option<f64> {
        Some(self.vafr_flip? / self.one_ray_flip?)
    }
}

/// The measurement.
#[derive(Clone, Debug, Serialize)]
pub struct PeripheryFlip {
    /// The scene's name.
    pub scene: String,
    /// The display's name.
    pub display: String,
    /// The parameters.
    pub params: PeripheryFlipParams,
    /// The reference's noise floor over the whole frame.
    pub floor: NoiseFloor,
    /// The one-ray frame's ꟻLIP over the whole frame.
    pub one_ray_flip_whole: f64,
    /// One row per gaze.
    pub rows: Vec<GazeRow>,
    /// CPU time of one reference, ms.
    pub reference_cpu_ms: f64,
}

impl PeripheryFlip {
    /// A Markdown table, one row per gaze.
    pub fn markdown(&self) -> String {
        let fmt = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.4}"));
        let lo = self.params.band_lo_deg;
        let mut s = format!(
            "{} on {}: ꟻLIP beyond {lo}° against full resolution with {} rays per pixel (the viewer's shading, not denoised); {}; the one-ray frame's ꟻLIP over the whole frame {:.4}\n\n",
            self.scene,
            self.display,
            self.params.reference_pixel_samples,
            self.floor.describe(),
            self.one_ray_flip_whole
        );
        s += &format!(
            "| gaze | pixels beyond {lo}° | VaFR, denoised | one-ray full, not denoised | VaFR / one-ray | reference floor | VaFR, whole frame | VaFR CPU ms (denoise) |\n|---|---|---|---|---|---|---|---|\n"
        );
        for r in &self.rows {
            s += &format!(
                "| {} ({:.0}, {:.0}) | {} | {} | {} | {} | {} | {:.4} | {:.0} ({:.0}) |\n",
                r.gaze,
                r.gaze_px[0],
                r.gaze_px[1],
                r.band_pixels,
                fmt(r.vafr_flip),
                fmt(r.one_ray_flip),
                r.ratio().map_or("—".into(), |v| format!("{v:.3}")),
                fmt(r.floor_flip),
                r.vafr_flip_whole,
                r.vafr_cpu_ms[0],
                r.vafr_cpu_ms[1],
            );
        }
        s
    }
}

/// Runs the measurement at each of `gazes` (name, gaze). `progress` is told each step.
pub fn run(
    world: &World,
    camera: &EyeCamera,
    gazes: &[(String, Gaze)],
    params: &PeripheryFlipParams,
    progress: &dyn Fn(&str),
) -> Result<PeripheryFlip> {
    params.validate()?;
    let display = &camera.display;
    let shading = MeasuredShading::Viewer;
    let centre = display.centre_gaze();
    // The full-resolution frames do not depend on the gaze (no depth of field).
    progress(&format!(
        "reference: full resolution, {} rays per pixel, seed {}",
        params.reference_pixel_samples, params.seeds[0]
    ));
    let ref_settings = shading.reference_settings(params.reference_pixel_samples);
    let reference = render_seeded(world, camera, &ref_settings, centre, params.seeds[0])?;
    progress(&format!("its twin, seed {}", params.seeds[1]));
    let twin = render_seeded(world, camera, &ref_settings, centre, params.seeds[1])?;
    let floor = noise_floor(&reference.color, &twin.color, params.seeds, display.ppd())?;
    progress("the one-ray full-resolution frame, not denoised");
    let mut one_ray_settings = FrameSettings::new(Method::Full);
    one_ray_settings.shading = shading.shading();
    one_ray_settings.denoise = None;
    let one_ray = render_seeded(world, camera, &one_ray_settings, centre, params.seeds[0])?;
    let all = vec![true; (display.width_px as usize) * (display.height_px as usize)];
    let whole = |img: &fovea_core::Image<fovea_post::Rgb>| -> Result<f64> {
        Ok(masked_flip(&reference.color, img, display, &all)?.map_or(f64::NAN, |(f, _)| f))
    };
    let one_ray_flip_whole = whole(&one_ray.color)?;
    let mut rows = Vec::new();
    for (name, gaze) in gazes {
        progress(&format!("VaFR, denoised, gaze {name}"));
        let mut s = FrameSettings::new(Method::Vafr);
        shading.apply(&mut s);
        let vafr = render_seeded(world, camera, &s, *gaze, params.seeds[0])?;
        let mask = band_mask(display, gaze, params.band_lo_deg, None);
        let band = |img: &fovea_core::Image<fovea_post::Rgb>| {
            masked_flip(&reference.color, img, display, &mask)
        };
        let (vafr_band, one_band, floor_band) = (
            band(&vafr.color)?,
            band(&one_ray.color)?,
            band(&twin.color)?,
        );
        let st = &vafr.stats;
        rows.push(GazeRow {
            gaze: name.clone(),
            gaze_px: [gaze.point.x_px, gaze.point.y_px],
            band_pixels: vafr_band.map_or(0, |b| b.1),
            vafr_flip: vafr_band.map(|b| b.0),
            one_ray_flip: one_band.map(|b| b.0),
            floor_flip: floor_band.map(|b| b.0),
            vafr_flip_whole: whole(&vafr.color)?,
            vafr_cpu_ms: [st.total_cpu_ms, st.stages_cpu_ms.get(Stage::Denoise)],
            vafr_samples: st.samples,
        });
    }
    Ok(PeripheryFlip {
        scene: world.scene.name.clone(),
        display: display.name.clone(),
        params: params.clone(),
        floor,
        one_ray_flip_whole,
        rows,
        reference_cpu_ms: reference.stats.total_cpu_ms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::experiments::invalid_parameter as invalid;

    #[test]
    fn params_are_checked() {
        PeripheryFlipParams::default().validate().unwrap();
        let bad = |f: &dyn Fn(&mut PeripheryFlipParams)| {
            let mut p = PeripheryFlipParams::default();
            f(&mut p);
            invalid(p.validate())
        };
        assert_eq!(
            bad(&|p| p.reference_pixel_samples = 1),
            "reference-pixel-samples"
        );
        assert_eq!(
            bad(&|p| p.reference_pixel_samples = 5000),
            "reference-pixel-samples"
        );
        assert_eq!(bad(&|p| p.seeds = [3, 3]), "seeds");
        assert_eq!(bad(&|p| p.band_lo_deg = f64::NAN), "band");
    }

    #[test]
    fn the_standard_gazes_are_where_they_say() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let g = standard_gazes(&d).unwrap();
        assert_eq!(g.len(), 3);
        let e = d.eccentricity(g[1].1.point, &g[0].1).0;
        assert!((e - 25.0).abs() < 1e-9, "{e}");
        assert!(g[2].1.point.x_px < 0.1 * d.width_px as f64);
    }
}
