//! Depth of field in the frame pipeline: the eye state it needs (focus, pupil), Liu et al.'s
//! DOF-aware culling of shading (Eq. 10–11) and the screen-space DOF filter stage.
//!
//! * **Focus**: fixed (metres, or infinity) or automatic — a depth patch around the gaze is
//!   ray cast at screen resolution and handed to the gaze-depth estimator
//!   ([`fovea_core::optics::gaze_depth`]), which looks at a Weier-Fig.-4-like pattern with a
//!   robust statistic rather than the single pixel under the gaze.
//! * **Culling** (Liu Sec. 3.3, Algorithm 1): after primary visibility, each sample's DOF
//!   weight `w_d` (Eq. 10; `D_M` = the farthest scene point from the eye) decides through a
//!   Russian roulette (Eq. 11: shade when `ε ≤ w_d`) whether it is shaded. Liu draws `ε` as
//!   white noise; by default we take it from an 8×8 ordered-dither (Bayer) matrix over the
//!   sample buffer, shifted by the seed: still uniform on [0, 1] for each sample, but the kept
//!   samples of a surface are spread evenly, so the fill between them is an interpolation
//!   rather than a guess across random clumps ([`CullNoise`]; `white` restores Liu's i.i.d.
//!   `ε`, hashed from the sample's index and the seed). Frames are reproducible either way. Eq. 10 falls to 0 at `D_M`, which would leave the
//!   farthest surface with no shaded sample at all (the pull-push fill then smears colour
//!   from far away across it); the weight is therefore floored at `min_keep` (default 0.25),
//!   a choice of ours, not Liu's. Culled samples keep their depth and get their colour
//!   by pull-push from the shaded ones in the sample buffer, before anti-aliasing,
//!   reconstruction and blur. Rays that hit nothing cost no shading and are never culled.
//! * **Blur**: the signed thin-lens (or Eq. 13 / Weier Eq. 3) CoC map of the screen depth,
//!   then one filter of [`fovea_post::dof`].

use serde::Serialize;

use fovea_core::optics::{dof_weight, russian_roulette, DofLimits, EyeModel};
use fovea_core::units::Metres;
use fovea_post::dof::coc::{coc_map, CocModel, CocParams};
use fovea_post::dof::{DofInput, FilterKind};
use fovea_post::Rgb;

use fovea_core::Image;

use crate::camera::EyeCamera;
use crate::error::Result;
use crate::world::World;

/// How the focus distance is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FocusMode {
    /// A fixed distance along the view axis, metres (`+∞` allowed).
    Fixed(f64),
    /// Estimated from the depth around the gaze point.
    Auto,
}

/// Where the roulette's `ε` comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CullNoise {
    /// An 8×8 Bayer matrix over the buffer: kept samples evenly spread (default).
    Ordered,
    /// I.i.d. uniform `ε` per sample (Liu's Eq. 11 as written).
    White,
}

/// Depth-of-field settings of a frame.
#[derive(Clone, Debug, Serialize)]
pub struct DofSettings {
    /// The screen-space filter; `None` renders sharp (culling alone).
    pub filter: Option<FilterKind>,
    /// Focus.
    pub focus: FocusMode,
    /// The eye (pupil, focal length, criterion).
    pub eye: EyeModel,
    /// CoC model of the blur.
    pub coc_model: CocModel,
    /// Largest CoC diameter, pixels.
    pub max_coc_px: f64,
    /// Liu's DOF-aware culling of shading (Eq. 10–11).
    pub cull: bool,
    /// Seed of the roulette.
    pub seed: u64,
    /// Floor of the culling weight: every surface keeps at least this share of its samples.
    pub min_keep: f64,
    /// The roulette's `ε`.
    pub noise: CullNoise,
    /// CoC diameter in pixels below which culling is never complete: the keep probability is
    /// at least `(cull_hidden_coc_px / |CoC|)²`, so a surface keeps about one shaded sample per
    /// disc of this diameter of its blur. 0 gives Liu's weight alone.
    pub cull_hidden_coc_px: f64,
}

impl DofSettings {
    /// Thin-lens CoC, the standard eye, no culling, `filter` at `focus`.
    pub fn new(filter: Option<FilterKind>, focus: FocusMode) -> Self {
        Self {
            filter,
            focus,
            eye: EyeModel::default(),
            coc_model: CocModel::ThinLens,
            max_coc_px: 64.0,
            cull: false,
            seed: 1,
            min_keep: 0.25,
            noise: CullNoise::Ordered,
            cull_hidden_coc_px: 0.0,
        }
    }
}

impl DofSettings {
    /// Checks the ranges: a fixed focus > 0 m (or ∞), the eye model's, a largest CoC of 0–256
    /// pixels, a culling floor in [0, 1] and a hidden-CoC diameter of 0–256 pixels.
    pub fn validate(&self) -> Result<()> {
        use crate::error::RenderError;
        if let FocusMode::Fixed(f) = self.focus {
            if f.is_nan() || f <= 0.0 {
                return Err(RenderError::invalid(
                    "focus",
                    f,
                    "a distance in metres > 0, inf or auto",
                ));
            }
        }
        let e = &self.eye;
        let pupil_ok = (0.0..=12.0).contains(&e.pupil.0);
        if !(pupil_ok && e.focal_length.0 > 0.0 && e.focal_length.0 <= 100.0) {
            return Err(RenderError::invalid(
                "eye",
                format!(
                    "pupil {} mm, focal length {} mm",
                    e.pupil.0, e.focal_length.0
                ),
                "a pupil of 0 to 12 mm and a focal length in (0, 100] mm",
            ));
        }
        if !(e.coc_criterion.0 > 0.0 && e.coc_criterion.0 <= 1.0) {
            return Err(RenderError::invalid(
                "coc-criterion",
                e.coc_criterion.0,
                "(0, 1] mm",
            ));
        }
        if !(self.max_coc_px.is_finite() && (0.0..=256.0).contains(&self.max_coc_px)) {
            return Err(RenderError::invalid(
                "max-coc",
                self.max_coc_px,
                "0 to 256 pixels",
            ));
        }
        if !(0.0..=1.0).contains(&self.min_keep) {
            return Err(RenderError::invalid("min-keep", self.min_keep, "0 to 1"));
        }
        if !(self.cull_hidden_coc_px.is_finite()
            && (0.0..=256.0).contains(&self.cull_hidden_coc_px))
        {
            return Err(RenderError::invalid(
                "cull-hidden-coc",
                self.cull_hidden_coc_px,
                "0 to 256 pixels",
            ));
        }
        Ok(())
    }
}

/// `D_M` of Liu's Eq. 10: the distance from the eye to the farthest triangle vertex (at least
/// 1 m beyond the focus), metres.
pub fn scene_max_depth_m(world: &World, camera: &EyeCamera) -> f64 {
    let far = world
        .tris
        .verts
        .iter()
        .flat_map(|v| v.iter())
        .map(|p| (*p - camera.position).length())
        .fold(0.0f32, f32::max) as f64;
    if far.is_finite() && far > 0.0 {
        far
    } else {
        fovea_core::optics::DEFAULT_MAX_DEPTH_M
    }
}

/// DOF limits for culling (all depths for a zero pupil). Focus nearer than 5 cm or beyond 1000 km is clamped into that range
/// so that Eq. 4–5 are defined (infinity focus gives the hyperfocal near limit).
pub fn culling_limits(eye: &EyeModel, focus_m: f64) -> Result<DofLimits> {
    if eye.pupil.0 <= 0.0 {
        // A pinhole eye: everything is in focus.
        return Ok(DofLimits {
            near: Metres(0.0),
            far: Metres(f64::INFINITY),
        });
    }
    let f = if focus_m.is_finite() {
        focus_m.clamp(0.05, 1e6)
    } else {
        1e6
    };
    Ok(eye.dof_limits(Metres(f))?)
}

/// The 8×8 Bayer (ordered-dither) matrix: each of 0…63 once, neighbours far apart in value.
const BAYER8: [[u8; 8]; 8] = [
    [0, 32, 8, 40, 2, 34, 10, 42],
    [48, 16, 56, 24, 50, 18, 58, 26],
    [12, 44, 4, 36, 14, 46, 6, 38],
    [60, 28, 52, 20, 62, 30, 54, 22],
    [3, 35, 11, 43, 1, 33, 9, 41],
    [51, 19, 59, 27, 49, 17, 57, 25],
    [15, 47, 7, 39, 13, 45, 5, 37],
    [63, 31, 55, 23, 61, 29, 53, 21],
];

/// The roulette's `ε` ∈ (0, 1) for buffer pixel `(i, j)` with unique sample `index` (a
/// shading key: its frame and eye, `crate::shade::frame_noise`, rotate the ordered dither by
/// the golden-ratio sequence, so a pixel's `ε` is stratified over successive frames; the
/// white noise hashes them with the rest of the key).
#[inline]
pub fn roulette_epsilon(noise: CullNoise, seed: u64, i: u32, j: u32, index: u64) -> f64 {
    use crate::shade::frame_noise::{frame_rotation_1d, key_eye, key_frame};
    match noise {
        CullNoise::Ordered => {
            let (si, sj) = ((seed % 8) as u32, ((seed / 8) % 8) as u32);
            let e = (BAYER8[((j + sj) % 8) as usize][((i + si) % 8) as usize] as f64 + 0.5) / 64.0;
            (e + frame_rotation_1d(key_frame(index), key_eye(index))).fract()
        }
        CullNoise::White => fovea_core::math::unit_from_seed(fovea_core::math::mix64(
            seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03),
        )),
    }
}

/// DOF-aware culling for one frame: Eq. 10's weight with our two floors, and the roulette.
#[derive(Clone, Debug, Serialize)]
pub struct Culling {
    /// DOF limits at the frame's focus.
    pub limits: DofLimits,
    /// `D_M`, metres.
    pub max_depth_m: f64,
    /// Floor of the weight.
    pub min_keep: f64,
    /// CoC diameter (pixels) below which the blur cannot hide a missing sample; the weight is
    /// at least `(hidden_coc_px / |CoC|)²`. 0 disables this floor.
    pub hidden_coc_px: f64,
    /// Thin-lens CoC in pixels per dioptre (`τ·f_px`) and `1/F`.
    coc_per_dioptre_px: f64,
    inv_focus: f64,
    seed: u64,
    noise: CullNoise,
}

impl Culling {
    /// The culling of `settings` for a frame focused at `focus_m` on `camera`.
    pub fn new(
        settings: &DofSettings,
        camera: &EyeCamera,
        world: &World,
        focus_m: f64,
    ) -> Result<Self> {
        Ok(Self {
            limits: culling_limits(&settings.eye, focus_m)?,
            max_depth_m: scene_max_depth_m(world, camera),
            min_keep: settings.min_keep.clamp(0.0, 1.0),
            hidden_coc_px: settings.cull_hidden_coc_px.max(0.0),
            coc_per_dioptre_px: settings.eye.pupil.to_metres().0 * camera.display.focal_y_px(),
            inv_focus: if focus_m.is_finite() {
                1.0 / focus_m
            } else {
                0.0
            },
            seed: settings.seed,
            noise: settings.noise,
        })
    }

    /// The probability of shading a sample at view depth `depth_m`: Eq. 10's `w_d`, at least
    /// `min_keep` and at least `(hidden_coc_px / |CoC|)²`.
    pub fn weight(&self, depth_m: f32) -> f64 {
        let d = depth_m as f64;
        let w = dof_weight(Metres(d), &self.limits, Metres(self.max_depth_m));
        let coc = (self.coc_per_dioptre_px * (self.inv_focus - 1.0 / d)).abs();
        let hidden = if self.hidden_coc_px > 0.0 {
            (self.hidden_coc_px / coc.max(1e-9)).powi(2).min(1.0)
        } else {
            0.0
        };
        w.max(self.min_keep).max(hidden)
    }

    /// The roulette (Eq. 11) of buffer pixel `(i, j)`, unique sample `index`: `true` to shade
    /// it. Misses (`depth_m` = ∞) are always shaded: they cost nothing.
    #[inline]
    pub fn keep(&self, depth_m: f32, i: u32, j: u32, index: u64) -> bool {
        if !(depth_m.is_finite() && depth_m > 0.0) {
            return true;
        }
        let eps = roulette_epsilon(self.noise, self.seed, i, j, index);
        russian_roulette(self.weight(depth_m), eps)
    }
}

/// Pixels per degree at the screen centre (`f_y · π/180`), the scale FLIP and foveal regions
/// use.
pub fn px_per_degree(camera: &EyeCamera) -> f64 {
    camera.display.focal_y_px() * std::f64::consts::PI / 180.0
}

/// The CoC parameters of `settings` for `camera`'s display.
pub fn coc_params(settings: &DofSettings, camera: &EyeCamera) -> CocParams {
    CocParams {
        eye: settings.eye,
        focal_px: camera.display.focal_y_px(),
        max_coc_px: settings.max_coc_px,
        model: settings.coc_model,
    }
}

/// Output of the DOF stage.
pub struct DofResult {
    /// The blurred image.
    pub color: Image<Rgb>,
    /// The signed CoC map, pixels.
    pub coc_px: Image<f32>,
}

/// Applies the blur of `settings` to a screen image with its depth, focused at `focus_m`.
/// `gaze_px` is the gaze point (the layered filter's fovea).
pub fn apply_dof(
    settings: &DofSettings,
    camera: &EyeCamera,
    color: &Image<Rgb>,
    depth_m: &Image<f32>,
    focus_m: f64,
    gaze_px: [f32; 2],
) -> Result<DofResult> {
    let params = coc_params(settings, camera);
    let coc = coc_map(&params, Metres(focus_m), depth_m)?;
    let out = match settings.filter {
        Some(kind) => {
            let input = DofInput {
                color,
                depth_m,
                coc_px: &coc,
                focus_m: focus_m as f32,
                px_per_dioptre: params.px_per_dioptre() as f32,
                gaze_px,
                px_per_degree: px_per_degree(camera) as f32,
            };
            kind.build().apply(&input)?
        }
        None => color.clone(),
    };
    Ok(DofResult {
        color: out,
        coc_px: coc,
    })
}

/// Half-size of the auto-focus depth patch, degrees of visual angle (the estimator's pattern
/// must fit inside).
pub const AUTO_FOCUS_PATCH_DEG: f64 = 2.0;

/// Casts the pinhole depth of a square patch of screen pixels around the gaze
/// ([`AUTO_FOCUS_PATCH_DEG`] each way, at most 161 × 161 rays) and returns it with the gaze's
/// position inside the patch.
pub fn depth_patch(
    world: &World,
    camera: &EyeCamera,
    gaze: &fovea_core::display::Gaze,
) -> Result<(Image<f32>, [f64; 2])> {
    let d = &camera.display;
    let half = (AUTO_FOCUS_PATCH_DEG * px_per_degree(camera)).clamp(2.0, 80.0);
    let (gx, gy) = (gaze.point.x_px, gaze.point.y_px);
    let x0 = (gx - half).floor().clamp(0.0, d.width_px as f64 - 1.0) as u32;
    let y0 = (gy - half).floor().clamp(0.0, d.height_px as f64 - 1.0) as u32;
    let x1 = (gx + half).ceil().clamp(x0 as f64 + 1.0, d.width_px as f64) as u32;
    let y1 = (gy + half)
        .ceil()
        .clamp(y0 as f64 + 1.0, d.height_px as f64) as u32;
    let (w, h) = (x1 - x0, y1 - y0);
    let spread = (1.0 / d.focal_y_px()) as f32;
    let data: Vec<f32> = {
        use rayon::prelude::*;
        (0..(w * h) as usize)
            .into_par_iter()
            .map(|k| {
                let x = (x0 + k as u32 % w) as f32 + 0.5;
                let y = (y0 + k as u32 / w) as f32 + 0.5;
                let dir = camera.direction(x, y);
                let g = crate::trace::trace_sample(
                    world,
                    &crate::bvh::Ray {
                        origin: camera.position,
                        dir,
                        t_min: 0.0,
                        t_max: f32::INFINITY,
                    },
                    spread,
                );
                camera.view_depth(dir, g.t)
            })
            .collect()
    };
    Ok((
        Image::from_vec(w, h, data)?,
        [gx - x0 as f64, gy - y0 as f64],
    ))
}

/// The automatic focus distance at `gaze`, metres: the gaze-depth estimator on
/// [`depth_patch`].
pub fn auto_focus_m(
    world: &World,
    camera: &EyeCamera,
    gaze: &fovea_core::display::Gaze,
) -> Result<f64> {
    auto_focus_with_prior_m(world, camera, gaze, f64::NAN)
}

/// [`auto_focus_m`] with a prior focus (metres; NaN for none), usually the accommodation
/// filter's current focus in a sequence: the depth cluster at the prior weighs double, which
/// keeps the focus on one object under tracker noise (see `docs/dof.md`).
pub fn auto_focus_with_prior_m(
    world: &World,
    camera: &EyeCamera,
    gaze: &fovea_core::display::Gaze,
    prior_m: f64,
) -> Result<f64> {
    let (patch, por) = depth_patch(world, camera, gaze)?;
    let est = fovea_core::optics::gaze_depth::estimate_gaze_depth_with_prior(
        &patch,
        fovea_core::units::ScreenPoint::new(por[0], por[1]),
        px_per_degree(camera),
        &fovea_core::optics::gaze_depth::GazeDepthParams::default(),
        prior_m,
    )?;
    Ok(est.focus_m)
}
