//! What the measurements score (issue 38, item 5): frames shaded as a viewer shades them,
//! against a converged full-resolution reference of the same shading, beside the reference's
//! own noise floor.
//!
//! **The viewer's shading** ([`MeasuredShading::Viewer`]): the real-time preset
//! (`fovea_render::quality::Quality::Realtime`: direct light, one environment ray per sample
//! through shadow rays, one bounce of indirect light) with the sample-space denoiser at its defaults (3×3 kernel, 4
//! iterations), as `fovea view` renders; where frames follow each other the measurement adds
//! temporal accumulation, as the viewer does. [`MeasuredShading::NoiseFree`] is the old
//! behaviour: the unshadowed environment (`ShadingMode::NOISE_FREE`), no Monte Carlo noise, no
//! denoiser — the error of the foveation alone.
//!
//! **The reference** is the full-resolution frame of the same shading without the denoiser,
//! with `pixel_samples` stratified primary rays per pixel, each shaded with its own random
//! numbers: its Monte Carlo error falls as `1/√pixel_samples`.
//!
//! **Its noise floor** ([`noise_floor`]): a second reference, identical but for the seed of
//! its shading's random numbers (the frame index of `fovea_render::shade::FrameNoise`, which
//! enters every random key), scored against the first with the same metrics. Its two frames'
//! errors are independent estimates of the same image, so their difference holds twice the
//! variance of one reference's error (`PSNR(a, b) = PSNR(a, truth) − 3.01 dB` for white noise):
//! a frame that scores at the floor is as close to the reference as a second reference is, and
//! score differences smaller than the floor's distance from a perfect score are the
//! reference's noise, not the method's. The two references share their primary rays (the
//! pixel samples' stratification is deterministic), so the floor is the shading's noise, not
//! the primary rays' aliasing. With noise-free shading the two frames are identical: PSNR
//! `+∞`, ꟻLIP 0, SSIM 1 (each metric's convention for identical images).

use serde::Serialize;

use fovea_core::display::Gaze;
use fovea_core::mapping::Method;
use fovea_core::Image;
use fovea_post::denoise::DenoiseParams;
use fovea_post::Rgb;
use fovea_render::camera::EyeCamera;
use fovea_render::pipeline::{plan_frame, render_alone, Frame, FrameInputs, FrameSettings};
use fovea_render::quality::Quality;
use fovea_render::shade::{FrameNoise, ShadingMode};
use fovea_render::world::World;

use crate::error::{EvalError, Result};
use crate::metrics::{flip_mean, luma_psnr, Region};

/// Primary rays per pixel of a converged reference by default: four times the old cap of 64,
/// 256 shading estimates per pixel (the "≥ 256 rays per pixel").
pub const DEFAULT_REFERENCE_PIXEL_SAMPLES: u32 = 256;

/// The seeds (shading frame indices) of the reference and of its twin by default.
pub const DEFAULT_REFERENCE_SEEDS: [u64; 2] = [0, 1];

/// What the frames of a measurement are shaded with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MeasuredShading {
    /// What a viewer gets by default: the real-time preset (direct light, one environment ray
    /// per sample, one bounce of indirect light) with the sample-space denoiser; noisy, so scored against a converged
    /// reference with its noise floor.
    #[default]
    Viewer,
    /// The unshadowed environment without Monte Carlo noise and without the denoiser (the
    /// measurements before issue 38): the foveation's error alone.
    NoiseFree,
}

impl MeasuredShading {
    /// The name as the CLI spells it (`--shading viewer|noise-free`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Viewer => "viewer",
            Self::NoiseFree => "noise-free",
        }
    }

    /// Parses `viewer` or `noise-free`.
    pub fn parse(text: &str) -> Result<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "viewer" => Ok(Self::Viewer),
            "noise-free" => Ok(Self::NoiseFree),
            _ => Err(EvalError::invalid("shading", text, "viewer or noise-free")),
        }
    }

    /// The shading of the frames and of the reference.
    pub fn shading(self) -> ShadingMode {
        match self {
            Self::Viewer => Quality::Realtime.shading(),
            Self::NoiseFree => ShadingMode::NOISE_FREE,
        }
    }

    /// The denoiser of the measured frames (never of the reference): the viewer's defaults,
    /// none without noise.
    pub fn denoise(self) -> Option<DenoiseParams> {
        match self {
            Self::Viewer => Some(DenoiseParams::default()),
            Self::NoiseFree => None,
        }
    }

    /// Whether the shading carries Monte Carlo noise (the reference then needs many rays and
    /// has a noise floor).
    pub fn is_noisy(self) -> bool {
        self == Self::Viewer
    }

    /// Sets the shading and the denoiser of a measured frame.
    pub fn apply(self, settings: &mut FrameSettings) {
        settings.shading = self.shading();
        settings.denoise = self.denoise();
    }

    /// The settings of the full-resolution reference: this shading without the denoiser,
    /// `pixel_samples` stratified primary rays per pixel.
    pub fn reference_settings(self, pixel_samples: u32) -> FrameSettings {
        let mut s = FrameSettings::new(Method::Full);
        s.shading = self.shading();
        s.denoise = None;
        s.pixel_samples = pixel_samples;
        s
    }
}

/// Renders one frame of `settings` looking at `gaze` with the shading's random numbers of
/// seed `seed` (the frame index of [`FrameNoise`]; seed 0 is the frame `render_frame` gives).
pub fn render_seeded(
    world: &World,
    camera: &EyeCamera,
    settings: &FrameSettings,
    gaze: Gaze,
    seed: u64,
) -> Result<Frame> {
    let (plan, times) = plan_frame(world, camera, settings, gaze, [0.0, 0.0])?;
    let plan = plan.with_noise(FrameNoise::new(seed, 0));
    Ok(render_alone(
        world,
        camera,
        &plan,
        FrameInputs::default(),
        times,
        &|_, _| {},
    )?)
}

/// Two images of the same view scored against each other: the noise floor of a reference
/// (module header).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseFloor {
    /// The seeds of the two frames.
    pub seeds: [u64; 2],
    /// Luma PSNR of one against the other, dB (`+∞` when identical; serialised as `null`
    /// then, see [`NoiseFloor::json`]).
    pub psnr_db: f64,
    /// Mean ꟻLIP of one against the other (0 when identical).
    pub flip: f64,
}

impl NoiseFloor {
    /// Whether the two frames were identical (noise-free shading).
    pub fn is_exact(&self) -> bool {
        self.psnr_db == f64::INFINITY
    }

    /// As JSON: `psnr_db` as a number, or the string `"inf"` when the frames are identical
    /// (JSON has no infinity).
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "seeds": self.seeds,
            "psnr_db": if self.psnr_db.is_finite() {
                serde_json::json!(self.psnr_db)
            } else {
                serde_json::json!("inf")
            },
            "flip": self.flip,
        })
    }

    /// One line for a table's caption or a page: `noise floor 41.23 dB, ꟻLIP 0.0123 (seeds 0
    /// and 1)`.
    pub fn describe(&self) -> String {
        if self.is_exact() {
            format!(
                "noise floor: none (the references of seeds {} and {} are identical: PSNR ∞, ꟻLIP 0)",
                self.seeds[0], self.seeds[1]
            )
        } else {
            format!(
                "noise floor (the reference of seed {} against seed {}): luma PSNR {:.2} dB, ꟻLIP {:.4}",
                self.seeds[1], self.seeds[0], self.psnr_db, self.flip
            )
        }
    }
}

/// The noise floor of two frames of the same view and settings but for their seeds
/// (`seeds`), ꟻLIP at `pixels_per_degree`: [`luma_psnr`] and [`flip_mean`] of `b` against
/// `a` over the whole frame.
pub fn noise_floor(
    a: &Image<Rgb>,
    b: &Image<Rgb>,
    seeds: [u64; 2],
    pixels_per_degree: f64,
) -> Result<NoiseFloor> {
    let region = Region::full(a.width(), a.height());
    let bad = || {
        EvalError::invalid(
            "reference",
            format!(
                "{}×{} and {}×{}",
                a.width(),
                a.height(),
                b.width(),
                b.height()
            ),
            "two non-empty frames of one size",
        )
    };
    let psnr_db = luma_psnr(a, b, region).ok_or_else(bad)?;
    let flip = flip_mean(a, b, region, pixels_per_degree as f32).ok_or_else(bad)?;
    Ok(NoiseFloor {
        seeds,
        psnr_db,
        flip,
    })
}

/// A full-resolution reference, its twin of another seed (noisy shading only) and the two's
/// noise floor.
pub struct Reference {
    /// The reference (seed `floor.seeds[0]`).
    pub frame: Frame,
    /// Its twin (seed `floor.seeds[1]`): `None` for noise-free shading, whose frames are
    /// identical whatever the seed.
    pub twin: Option<Frame>,
    /// The twin scored against the reference.
    pub floor: NoiseFloor,
}

/// The full-resolution reference of `shading` at `pixel_samples` rays per pixel looking at
/// `gaze` (seed `seeds[0]`), and its noise floor against its twin of seed `seeds[1]`. The
/// twin is rendered only for noisy shading (noise-free frames are identical whatever the
/// seed: the floor is then exact without a second render).
pub fn render_reference(
    world: &World,
    camera: &EyeCamera,
    shading: MeasuredShading,
    pixel_samples: u32,
    gaze: Gaze,
    seeds: [u64; 2],
) -> Result<Reference> {
    let settings = shading.reference_settings(pixel_samples);
    let frame = render_seeded(world, camera, &settings, gaze, seeds[0])?;
    let ppd = camera.display.ppd();
    if shading.is_noisy() && seeds[0] != seeds[1] {
        let twin = render_seeded(world, camera, &settings, gaze, seeds[1])?;
        let floor = noise_floor(&frame.color, &twin.color, seeds, ppd)?;
        Ok(Reference {
            frame,
            twin: Some(twin),
            floor,
        })
    } else {
        let floor = noise_floor(&frame.color, &frame.color, seeds, ppd)?;
        Ok(Reference {
            frame,
            twin: None,
            floor,
        })
    }
}
