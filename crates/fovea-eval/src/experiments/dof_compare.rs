//! Depth-of-field filters against the thin-lens reference (Konrad's protocol, Sec. IV): render
//! a scene's pinhole frame and its distributed-ray-traced thin-lens reference, focused on a
//! near and on a far object, run every filter on the pinhole frame with the thin-lens CoC, and
//! score each against the reference — luma PSNR (Konrad's metric), SSIM, ꟻLIP at the display's
//! pixels per degree — and time it per megapixel.
//!
//! **Window.** The reference costs `lens_samples` frames, so the comparison renders a window of
//! the display around the gaze, at the display's own resolution (so CoCs in pixels are those
//! of the headset). The pinhole frame is rendered `margin_px` larger on every side so filters
//! see what lies just outside; scores and crops cover the inner window.
//!
//! **Focus.** `near` and `far` are the 10th and 90th percentiles of the finite pinhole depths in
//! the window (Konrad focused once on the foreground object and once on the background);
//! `auto` is the gaze-depth estimate at the gaze; a number is metres.
//!
//! **Culling.** With [`DofCompareParams::culling`], each case also renders whole frames of a
//! foveation method through the pipeline with one filter, once with and once without Liu's
//! DOF-aware culling (Eq. 10–11), and scores both in the window against the same reference:
//! the shading saved and what it costs in luma PSNR. The frames cast the pinhole frame's rays
//! per pixel per texel, and when the filter is also among the compared ones the result says
//! how far the method with culling is from that filter on the full-resolution frame.

use std::time::Instant;

use serde::Serialize;

use fovea_core::display::Gaze;
use fovea_core::mapping::Method;
use fovea_core::optics::EyeModel;
use fovea_core::units::Metres;
use fovea_core::{FoveaError, Image};
use fovea_post::dof::coc::{coc_map, CocModel, CocParams};
use fovea_post::dof::{DofInput, FilterKind};
use fovea_post::Rgb;
use fovea_render::camera::EyeCamera;
use fovea_render::dof::{auto_focus_m, px_per_degree, DofSettings, FocusMode};
use fovea_render::pipeline::{render_frame, FrameSettings};
use fovea_render::shade::ShadingMode;
use fovea_render::thin_lens::{
    render_window, ThinLens, Window, MAX_LENS_SAMPLES, MAX_PIXEL_SAMPLES,
};
use fovea_render::world::World;

use crate::error::{EvalError, Result};
use crate::metrics::{crop, flip_mean, luma_psnr, Region};

/// Smallest and largest side of the scored window, pixels.
pub const WINDOW_SIDES_PX: std::ops::RangeInclusive<u32> = 8..=16384;

/// Largest margin, pixels.
pub const MAX_MARGIN_PX: u32 = 256;

/// Which focus distance a case uses.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FocusSpec {
    /// The 10th percentile of the window's depths.
    Near,
    /// The 90th percentile of the window's depths.
    Far,
    /// The gaze-depth estimate at the gaze.
    Auto,
    /// Metres.
    Metres(f64),
}

impl FocusSpec {
    /// Parses `near`, `far`, `auto` or metres.
    pub fn parse(text: &str) -> Result<Self> {
        let t = text.trim().to_ascii_lowercase();
        match t.as_str() {
            "near" => Ok(FocusSpec::Near),
            "far" => Ok(FocusSpec::Far),
            "auto" => Ok(FocusSpec::Auto),
            _ => match t.parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(FocusSpec::Metres(v)),
                _ => Err(EvalError::invalid(
                    "focus",
                    text,
                    "near, far, auto or a distance in metres > 0",
                )),
            },
        }
    }

    /// A label for tables.
    pub fn label(&self) -> String {
        match self {
            FocusSpec::Near => "near".into(),
            FocusSpec::Far => "far".into(),
            FocusSpec::Auto => "auto".into(),
            FocusSpec::Metres(m) => format!("{m} m"),
        }
    }
}

/// Settings of a comparison.
#[derive(Clone, Debug, Serialize)]
pub struct DofCompareParams {
    /// Inner window size (scored), pixels, sides in [`WINDOW_SIDES_PX`] (clipped to the
    /// screen). Default: 384 × 384.
    pub window: [u32; 2],
    /// Extra pinhole pixels on each side for the filters' context, 0 to [`MAX_MARGIN_PX`].
    /// Default: 32.
    pub margin_px: u32,
    /// Lens samples of the reference (Konrad: 55), 1 to [`MAX_LENS_SAMPLES`]. Default: 128.
    pub lens_samples: u32,
    /// Rays per pixel of the pinhole frame; above 1 both renders integrate over the pixel
    /// area (see [`fovea_render::thin_lens`]) so the scores isolate the blur from aliasing.
    /// The culling's method frames cast as many rays per texel.
    /// 1 to [`MAX_PIXEL_SAMPLES`] and at most `lens_samples`. Default: 16.
    pub pixel_samples: u32,
    /// Shading of both renders. Default: `ShadingMode::NOISE_FREE` (the comparison measures
    /// the blur, not the environment light's Monte Carlo noise).
    #[serde(skip)]
    pub shading: ShadingMode,
    /// The eye (pupil 0 to 12 mm; 0 is a pinhole). Default: [`EyeModel::default`].
    pub eye: EyeModel,
    /// CoC model given to the filters (the reference is a thin lens). Default: thin lens.
    pub coc_model: CocModel,
    /// Largest CoC diameter, 0 to 256 pixels. Default: 64.
    pub max_coc_px: f64,
    /// Filters to score (at least one). Default: every filter.
    pub filters: Vec<FilterKind>,
    /// Focus cases (at least one). Default: near and far.
    pub focus: Vec<FocusSpec>,
    /// Also measure DOF-aware culling: this foveation method with this filter, whole frames
    /// with and without culling. Default: none.
    pub culling: Option<(Method, FilterKind)>,
    /// The culling's `cull_hidden_coc_px` ([`DofSettings`]), 0 to 256 pixels. Default: 0.
    pub cull_hidden_coc_px: f64,
}

impl Default for DofCompareParams {
    fn default() -> Self {
        Self {
            window: [384, 384],
            margin_px: 32,
            lens_samples: 128,
            pixel_samples: 16,
            shading: ShadingMode::NOISE_FREE,
            eye: EyeModel::default(),
            coc_model: CocModel::ThinLens,
            max_coc_px: 64.0,
            filters: FilterKind::ALL.to_vec(),
            focus: vec![FocusSpec::Near, FocusSpec::Far],
            culling: None,
            cull_hidden_coc_px: DofSettings::new(None, FocusMode::Auto).cull_hidden_coc_px,
        }
    }
}

impl DofCompareParams {
    /// Checks every parameter's range (see the fields).
    pub fn validate(&self) -> Result<()> {
        let [ww, wh] = self.window;
        if !(WINDOW_SIDES_PX.contains(&ww) && WINDOW_SIDES_PX.contains(&wh)) {
            return Err(EvalError::invalid(
                "window",
                format!("{ww}x{wh}"),
                format!(
                    "WxH with sides {} to {}, or full",
                    WINDOW_SIDES_PX.start(),
                    WINDOW_SIDES_PX.end()
                ),
            ));
        }
        if !(1..=MAX_LENS_SAMPLES).contains(&self.lens_samples) {
            return Err(EvalError::invalid(
                "lens-samples",
                self.lens_samples,
                format!("1 to {MAX_LENS_SAMPLES}"),
            ));
        }
        if !(1..=MAX_PIXEL_SAMPLES).contains(&self.pixel_samples) {
            return Err(EvalError::invalid(
                "pixel-samples",
                self.pixel_samples,
                format!("1 to {MAX_PIXEL_SAMPLES}"),
            ));
        }
        if self.pixel_samples > self.lens_samples {
            return Err(EvalError::invalid(
                "pixel-samples",
                self.pixel_samples,
                format!(
                    "at most --lens-samples ({}), since each lens sample takes one pixel offset",
                    self.lens_samples
                ),
            ));
        }
        if self.margin_px > MAX_MARGIN_PX {
            return Err(EvalError::invalid(
                "margin",
                self.margin_px,
                format!("0 to {MAX_MARGIN_PX}"),
            ));
        }
        if !(self.cull_hidden_coc_px.is_finite()
            && (0.0..=256.0).contains(&self.cull_hidden_coc_px))
        {
            return Err(EvalError::invalid(
                "cull-hidden-coc",
                self.cull_hidden_coc_px,
                "0 to 256 pixels",
            ));
        }
        if !(self.max_coc_px.is_finite() && (0.0..=256.0).contains(&self.max_coc_px)) {
            return Err(EvalError::invalid(
                "max-coc",
                self.max_coc_px,
                "0 to 256 pixels",
            ));
        }
        if !(self.eye.pupil.0.is_finite() && (0.0..=12.0).contains(&self.eye.pupil.0)) {
            return Err(EvalError::invalid("pupil", self.eye.pupil.0, "0 to 12 mm"));
        }
        self.shading.validate()?;
        if self.filters.is_empty() {
            return Err(EvalError::invalid(
                "filters",
                "none",
                "at least one DOF filter",
            ));
        }
        if self.focus.is_empty() {
            return Err(EvalError::invalid(
                "cases",
                "none",
                "at least one focus case: near, far, auto or metres",
            ));
        }
        Ok(())
    }
}

/// One filter's scores in one case.
#[derive(Clone, Debug, Serialize)]
pub struct FilterScore {
    /// Filter name (`pinhole` for the unfiltered frame).
    pub name: String,
    /// Luma PSNR against the reference, dB.
    pub psnr_y_db: f64,
    /// Mean SSIM of luma against the reference.
    pub ssim: f64,
    /// Mean ꟻLIP error at the display's pixels per degree.
    pub flip: f64,
    /// Filter wall time per megapixel of filtered image, milliseconds (0 for `pinhole`).
    pub ms_per_megapixel: f64,
}

/// DOF-aware culling measured in one case.
#[derive(Clone, Debug, Serialize)]
pub struct CullingScore {
    /// Foveation method.
    pub method: String,
    /// DOF filter.
    pub filter: String,
    /// Surface samples shaded with culling.
    pub samples_shaded: u64,
    /// Surface samples culled.
    pub samples_culled: u64,
    /// `culled / (shaded + culled)`.
    pub saved_fraction: f64,
    /// Primary rays per texel of both frames: the pinhole frame's `pixel_samples`, so the
    /// method's frames are sampled like the full-resolution frame the filters are scored on.
    pub rays_per_texel: u32,
    /// Primary rays without and with culling.
    pub primary_rays: [u64; 2],
    /// Shadow rays (towards lights and the environment) without and with culling.
    pub shadow_rays: [u64; 2],
    /// Luma PSNR in the window against the reference, without culling, dB.
    pub psnr_without_db: f64,
    /// The same with culling, dB.
    pub psnr_with_db: f64,
    /// `psnr_without_db − psnr_with_db`: what culling costs.
    pub cost_db: f64,
    /// The same filter on the full-resolution frame, when it is one of the compared filters:
    /// its luma PSNR in the window, dB.
    pub full_frame_db: Option<f64>,
    /// `psnr_with_db − full_frame_db`: what the method with culling loses (negative) or gains
    /// against the same filter on the full-resolution frame, dB.
    pub gap_db: Option<f64>,
}

/// One focus case.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// `near`, `far`, …
    pub focus: String,
    /// Focus distance, metres (1e308 for infinity).
    pub focus_m: f64,
    /// Largest |CoC| in the scored window, pixels.
    pub max_coc_px: f64,
    /// Estimated luma PSNR of the reference against its converged value (from its two
    /// half-estimates), dB: scores far below it are the filters', not the reference's noise.
    pub reference_noise_floor_db: f64,
    /// Reference render time, milliseconds.
    pub reference_ms: f64,
    /// Scores: the unfiltered pinhole frame first, then each filter.
    pub filters: Vec<FilterScore>,
    /// DOF-aware culling, when asked for.
    pub culling: Option<CullingScore>,
    /// The reference over the inner window.
    #[serde(skip)]
    pub reference: Image<Rgb>,
    /// Inner-window crops, in the order of `filters`.
    #[serde(skip)]
    pub images: Vec<Image<Rgb>>,
}

/// Everything a comparison produced.
#[derive(Clone, Debug, Serialize)]
pub struct DofComparison {
    /// The scored window on the display.
    pub window: Window,
    /// Display pixels per degree used for ꟻLIP.
    pub pixels_per_degree: f64,
    /// Settings.
    pub params: DofCompareParams,
    /// Per focus case.
    pub cases: Vec<CaseResult>,
}

impl DofComparison {
    /// Each filter's scores averaged over the cases (PSNR averaged in dB, as Konrad's table).
    pub fn mean_scores(&self) -> Vec<FilterScore> {
        let Some(first) = self.cases.first() else {
            return Vec::new();
        };
        let n = self.cases.len() as f64;
        first
            .filters
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let mean = |g: &dyn Fn(&FilterScore) -> f64| {
                    self.cases.iter().map(|c| g(&c.filters[i])).sum::<f64>() / n
                };
                FilterScore {
                    name: f.name.clone(),
                    psnr_y_db: mean(&|s| s.psnr_y_db),
                    ssim: mean(&|s| s.ssim),
                    flip: mean(&|s| s.flip),
                    ms_per_megapixel: mean(&|s| s.ms_per_megapixel),
                }
            })
            .collect()
    }
}

impl DofComparison {
    /// `{"filters": [mean over cases], "cases": [...], ...}`: the JSON of `fovea dof-compare`
    /// (`dof-compare.json`) for a comparison on `scene` and `display`.
    pub fn to_json(&self, scene: &str, display: &str) -> serde_json::Value {
        serde_json::json!({
            "scene": scene,
            "display": display,
            "window": self.window,
            "pixels_per_degree": self.pixels_per_degree,
            "lens_samples": self.params.lens_samples,
            "pixel_samples": self.params.pixel_samples,
            "pupil_mm": self.params.eye.pupil.0,
            "coc_model": self.params.coc_model.name(),
            "filters": self.mean_scores(),
            "cases": self.cases,
        })
    }

    /// The comparison as Markdown (`dof-compare.md`): one table per focus case and the means.
    pub fn markdown(&self, scene: &str, display: &str) -> String {
        let r = self;
        let mut s = format!(
            "# Depth-of-field filters against the thin-lens reference\n\n{scene}, {display}, window {}x{} at ({}, {}), {:.1} px/deg, pupil {:.2} mm, {} lens samples, {} pixel samples, CoC {}.\n",
            r.window.width,
            r.window.height,
            r.window.x0,
            r.window.y0,
            r.pixels_per_degree,
            r.params.eye.pupil.0,
            r.params.lens_samples,
            r.params.pixel_samples,
            r.params.coc_model.name()
        );
        let table = |rows: &[FilterScore]| {
            let mut t = String::from(
                "\n| filter | luma PSNR (dB) | SSIM | ꟻLIP | ms / megapixel |\n|---|---:|---:|---:|---:|\n",
            );
            for f in rows {
                t += &format!(
                    "| {} | {} | {:.4} | {:.4} | {:.1} |\n",
                    f.name,
                    fmt_db(f.psnr_y_db),
                    f.ssim,
                    f.flip,
                    f.ms_per_megapixel
                );
            }
            t
        };
        for c in &r.cases {
            let focus = focus_label(c.focus_m);
            s += &format!(
                "\n## Focus {} ({focus}), largest CoC {:.1} px, reference noise floor {} dB\n",
                c.focus,
                c.max_coc_px,
                fmt_db(c.reference_noise_floor_db)
            );
            s += &table(&c.filters);
            if let Some(k) = &c.culling {
                s += &format!(
                    "\nDOF-aware culling, {} + {} (whole frames, {} rays per texel): {} of {} surface samples culled ({:.1} %), primary rays {} → {}, shadow rays {} → {}; window PSNR {} dB without, {} dB with culling (cost {:.2} dB)",
                    k.method,
                    k.filter,
                    k.rays_per_texel,
                    k.samples_culled,
                    k.samples_shaded + k.samples_culled,
                    k.saved_fraction * 100.0,
                    k.primary_rays[0],
                    k.primary_rays[1],
                    k.shadow_rays[0],
                    k.shadow_rays[1],
                    fmt_db(k.psnr_without_db),
                    fmt_db(k.psnr_with_db),
                    k.cost_db
                );
                s += &match (k.full_frame_db, k.gap_db) {
                    (Some(f), Some(g)) => format!(
                        "; {} on the full-resolution frame {} dB, so {} with culling is {:+.2} dB from it.\n",
                        k.filter,
                        fmt_db(f),
                        k.method,
                        g
                    ),
                    _ => ".\n".to_string(),
                };
            }
        }
        if r.cases.len() > 1 {
            s += "\n## Mean over the focus cases\n";
            s += &table(&r.mean_scores());
        }
        s
    }
}

/// A PSNR as tables print it: two decimals, or ∞.
pub fn fmt_db(v: f64) -> String {
    if v.is_infinite() {
        "∞".into()
    } else {
        format!("{v:.2}")
    }
}

/// A focus distance as printed: metres with three decimals, or ∞ (`focus_m` ≥ 1e308, the
/// JSON's stand-in for infinity).
pub fn focus_label(focus_m: f64) -> String {
    if focus_m >= 1e308 {
        "∞".to_string()
    } else {
        format!("{focus_m:.3} m")
    }
}

/// Percentile `q` in [0, 1] of the finite values.
fn percentile(values: &[f32], q: f64) -> Option<f64> {
    let mut v: Vec<f32> = values.iter().copied().filter(|d| d.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    Some(v[((v.len() - 1) as f64 * q).round() as usize] as f64)
}

/// Runs the comparison of `camera`'s view of `world` in a window around `gaze`.
/// `progress(stage)` names each step as it starts.
pub fn run(
    world: &World,
    camera: &EyeCamera,
    gaze: &Gaze,
    params: &DofCompareParams,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<DofComparison> {
    params.validate()?;
    let d = &camera.display;
    let (gx, gy) = (gaze.point.x_px, gaze.point.y_px);
    let inner = Window::centred(
        gx,
        gy,
        params.window[0],
        params.window[1],
        d.width_px,
        d.height_px,
    );
    // The outer window: the inner one grown by the margin, clipped to the screen.
    let x0 = inner.x0.saturating_sub(params.margin_px);
    let y0 = inner.y0.saturating_sub(params.margin_px);
    let x1 = (inner.x0 + inner.width + params.margin_px).min(d.width_px);
    let y1 = (inner.y0 + inner.height + params.margin_px).min(d.height_px);
    let outer = Window {
        x0,
        y0,
        width: x1 - x0,
        height: y1 - y0,
    };
    let inner_region = Region {
        x0: inner.x0 - x0,
        y0: inner.y0 - y0,
        x1: inner.x0 - x0 + inner.width,
        y1: inner.y0 - y0 + inner.height,
    };
    let ppd = px_per_degree(camera);

    progress("pinhole frame");
    let pin = render_window(
        world,
        camera,
        outer,
        None,
        params.pixel_samples,
        params.shading,
        &|_, _| {},
    )?;
    let pin_inner = crop(&pin.color, inner_region).ok_or_else(|| crop_error(inner_region))?;
    let depth_inner = crop(&pin.depth, inner_region).ok_or_else(|| crop_error(inner_region))?;
    let focal_px = d.focal_y_px();
    let coc_params = CocParams {
        eye: params.eye,
        focal_px,
        max_coc_px: params.max_coc_px,
        model: params.coc_model,
    };
    let mut cases = Vec::new();
    for spec in &params.focus {
        let focus_m = match spec {
            FocusSpec::Near => percentile(depth_inner.data(), 0.1),
            FocusSpec::Far => percentile(depth_inner.data(), 0.9),
            FocusSpec::Auto => Some(auto_focus_m(world, camera, gaze)?),
            FocusSpec::Metres(m) => Some(*m),
        }
        .unwrap_or(f64::INFINITY);
        progress(&format!(
            "{} focus ({focus_m:.2} m): thin-lens reference, {} lens samples",
            spec.label(),
            params.lens_samples
        ));
        let lens = ThinLens {
            pupil_m: params.eye.pupil.to_metres().0,
            focus_m,
            lens_samples: params.lens_samples,
        };
        let reference = render_window(
            world,
            camera,
            inner,
            Some(&lens),
            params.pixel_samples,
            params.shading,
            &|_, _| {},
        )?;
        let coc = coc_map(&coc_params, Metres(focus_m), &pin.depth)?;
        let max_coc = crop(&coc, inner_region)
            .map(|c| c.data().iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64)
            .unwrap_or(0.0);
        let input = DofInput {
            color: &pin.color,
            depth_m: &pin.depth,
            coc_px: &coc,
            focus_m: focus_m as f32,
            px_per_dioptre: coc_params.px_per_dioptre() as f32,
            gaze_px: [(gx - x0 as f64) as f32, (gy - y0 as f64) as f32],
            px_per_degree: ppd as f32,
        };
        let full = Region::full(inner.width, inner.height);
        let score = |name: &str, img: &Image<Rgb>, ms_per_mp: f64| -> FilterScore {
            FilterScore {
                name: name.to_string(),
                psnr_y_db: luma_psnr(&reference.color, img, full).unwrap_or(f64::NAN),
                ssim: crate::ssim::ssim(&reference.color, img, full).unwrap_or(f64::NAN),
                flip: flip_mean(&reference.color, img, full, ppd as f32).unwrap_or(f64::NAN),
                ms_per_megapixel: ms_per_mp,
            }
        };
        let mut scores = vec![score("pinhole", &pin_inner, 0.0)];
        let mut images = vec![pin_inner.clone()];
        for kind in &params.filters {
            progress(&format!("{} focus: {}", spec.label(), kind.name()));
            let filter = kind.build();
            let t = Instant::now();
            let out = filter.apply(&input)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let out_inner = crop(&out, inner_region).ok_or_else(|| crop_error(inner_region))?;
            scores.push(score(
                kind.name(),
                &out_inner,
                ms / (outer.pixels() as f64 / 1e6),
            ));
            images.push(out_inner);
        }
        let culling = match params.culling {
            Some((method, filter)) => {
                progress(&format!(
                    "{} focus: {} + {} with and without culling",
                    spec.label(),
                    method,
                    filter.name()
                ));
                let frame = |cull: bool| {
                    let mut s = FrameSettings::new(method);
                    s.shading = params.shading;
                    // The filters' input is the pinhole frame at `pixel_samples` rays per
                    // pixel; the method's frames get as many per texel, so the gap between
                    // them is the foveation's and the culling's, not one ray's aliasing
                    // against sixteen.
                    s.pixel_samples = params.pixel_samples;
                    let mut dof = DofSettings::new(Some(filter), FocusMode::Fixed(focus_m));
                    dof.eye = params.eye;
                    dof.coc_model = params.coc_model;
                    dof.max_coc_px = params.max_coc_px;
                    dof.cull = cull;
                    dof.cull_hidden_coc_px = params.cull_hidden_coc_px;
                    s.dof = Some(dof);
                    render_frame(world, camera, &s, *gaze, &|_, _| {})
                };
                let (plain, culled) = (frame(false)?, frame(true)?);
                let window_region = Region {
                    x0: inner.x0,
                    y0: inner.y0,
                    x1: inner.x0 + inner.width,
                    y1: inner.y0 + inner.height,
                };
                let score = |img: &Image<Rgb>| {
                    crop(img, window_region)
                        .and_then(|c| luma_psnr(&reference.color, &c, full))
                        .unwrap_or(f64::NAN)
                };
                let (a, b) = (score(&plain.color), score(&culled.color));
                let st = &culled.stats;
                let total = (st.samples_shaded + st.samples_culled).max(1);
                let full_frame_db = scores
                    .iter()
                    .find(|f| f.name == filter.name())
                    .map(|f| f.psnr_y_db);
                Some(CullingScore {
                    method: method.name().to_string(),
                    filter: filter.name().to_string(),
                    samples_shaded: st.samples_shaded,
                    samples_culled: st.samples_culled,
                    saved_fraction: st.samples_culled as f64 / total as f64,
                    rays_per_texel: params.pixel_samples,
                    primary_rays: [plain.stats.rays_primary, st.rays_primary],
                    shadow_rays: [
                        plain.stats.rays_shadow + plain.stats.rays_environment,
                        st.rays_shadow + st.rays_environment,
                    ],
                    psnr_without_db: a,
                    psnr_with_db: b,
                    cost_db: a - b,
                    full_frame_db,
                    gap_db: full_frame_db.map(|f| b - f),
                })
            }
            None => None,
        };
        cases.push(CaseResult {
            culling,
            focus: spec.label(),
            focus_m: focus_m.min(1e308),
            max_coc_px: max_coc,
            reference_noise_floor_db: noise_floor_db(&reference).min(1e308),
            reference_ms: reference.ms,
            filters: scores,
            reference: reference.color,
            images,
        });
    }
    Ok(DofComparison {
        window: inner,
        pixels_per_degree: ppd,
        params: params.clone(),
        cases,
    })
}

fn crop_error(r: Region) -> EvalError {
    EvalError::Core(FoveaError::invalid(
        "window",
        format!("{:?}", r),
        "a region inside the rendered window",
    ))
}

/// The reference's noise floor as luma PSNR, on the same display encoding as the scores
/// (tone curve, sRGB; [`crate::metrics`]): the two half-sample estimates against each other,
/// plus `10·log10(4)` (their difference has four times the variance of the whole estimate's
/// error). `∞` without halves or when they agree.
fn noise_floor_db(reference: &fovea_render::thin_lens::WindowRender) -> f64 {
    let Some((a, b)) = reference.halves.as_ref() else {
        return f64::INFINITY;
    };
    crate::metrics::luma_psnr(a, b, Region::full(a.width(), a.height()))
        .map_or(f64::INFINITY, |p| p + 10.0 * 4f64.log10())
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::experiments::invalid_parameter as invalid;

    #[test]
    fn default_params_are_valid() {
        DofCompareParams::default().validate().unwrap();
    }

    #[test]
    fn bad_params_give_typed_errors() {
        let bad = |f: &dyn Fn(&mut DofCompareParams)| {
            let mut p = DofCompareParams::default();
            f(&mut p);
            p.validate()
        };
        assert_eq!(invalid(bad(&|p| p.window = [3, 3])), "window");
        assert_eq!(invalid(bad(&|p| p.window = [64, 20_000])), "window");
        assert_eq!(invalid(bad(&|p| p.lens_samples = 0)), "lens-samples");
        assert_eq!(invalid(bad(&|p| p.pixel_samples = 0)), "pixel-samples");
        assert_eq!(
            invalid(bad(&|p| {
                p.lens_samples = 4;
                p.pixel_samples = 8;
            })),
            "pixel-samples"
        );
        assert_eq!(invalid(bad(&|p| p.margin_px = 300)), "margin");
        assert_eq!(
            invalid(bad(&|p| p.cull_hidden_coc_px = f64::NAN)),
            "cull-hidden-coc"
        );
        assert_eq!(invalid(bad(&|p| p.max_coc_px = 300.0)), "max-coc");
        assert_eq!(
            invalid(bad(&|p| p.eye.pupil = fovea_core::units::Millimetres(13.0))),
            "pupil"
        );
        assert_eq!(invalid(bad(&|p| p.filters.clear())), "filters");
        assert_eq!(invalid(bad(&|p| p.focus.clear())), "cases");
        assert!(matches!(
            bad(&|p| p.shading = ShadingMode::Path { bounces: 1, spp: 0, seed: 1 }),
            Err(EvalError::Render(fovea_render::RenderError::InvalidParameter { ref name, .. })) if name == "spp"
        ));
        assert_eq!(
            FocusSpec::parse("middle").unwrap_err().parameter(),
            Some("focus")
        );
        assert_eq!(FocusSpec::parse("2.5").unwrap(), FocusSpec::Metres(2.5));
    }

    #[test]
    fn labels() {
        assert_eq!(focus_label(1e308), "∞");
        assert_eq!(focus_label(1.25), "1.250 m");
        assert_eq!(fmt_db(f64::INFINITY), "∞");
        assert_eq!(fmt_db(31.234), "31.23");
    }
}
