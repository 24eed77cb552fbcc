//! What decides a frame besides the scene, the camera and the eye: the method and its
//! parameters, shading, anti-aliasing, depth of field, contrast, memory limit
//! ([`FrameSettings`]), each range-checked by `validate()` before any work.

use serde::Serialize;

use fovea_core::mapping::{MappingConfig, Method};
use fovea_post::contrast::PeripheralContrast;
use fovea_post::denoise::DenoiseParams;
use fovea_post::inset_smoothing::Smoothing;
use fovea_post::inverse_map::ReconstructFilter;

use crate::dof::DofSettings;
use crate::error::{RenderError, Result};
use crate::shade::ShadingMode;

/// Sample-space anti-aliasing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AaMode {
    /// The method's own: FXAA for VaFR and visual-polar, Gaussian for KFR and LaFR, none
    /// otherwise.
    Auto,
    /// No anti-aliasing.
    None,
    /// FXAA in sample space.
    Fxaa,
    /// 3×3 Gaussian in sample space.
    Gaussian,
}

impl AaMode {
    /// Parses `auto`, `none`, `fxaa`, `gaussian`.
    pub fn parse(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(AaMode::Auto),
            "none" | "off" => Ok(AaMode::None),
            "fxaa" => Ok(AaMode::Fxaa),
            "gaussian" | "gauss" => Ok(AaMode::Gaussian),
            _ => Err(RenderError::invalid(
                "aa",
                s,
                "auto, none, fxaa or gaussian",
            )),
        }
    }

    /// What `Auto` means for `method`.
    pub fn resolve(self, method: Method) -> AaMode {
        match (self, method) {
            (AaMode::Auto, Method::Vafr | Method::VisualPolar) => AaMode::Fxaa,
            (AaMode::Auto, Method::Kfr | Method::Lafr) => AaMode::Gaussian,
            (AaMode::Auto, _) => AaMode::None,
            (m, _) => m,
        }
    }
}

/// Most primary rays per sample ([`FrameSettings::pixel_samples`]): enough for a converged
/// reference (issue 38 asks for ≥ 256 rays per pixel). Memory does not grow with it: the trace
/// runs in chunks of about `plan::CHUNK_SAMPLES` rays (at least one buffer row:
/// `width × pixel_samples` G-buffer records, 7.9 M at 8K and 1,024 rays); time does, linearly.
pub const MAX_PIXEL_SAMPLES: u32 = 1024;

/// Most rays per texel of [`FrameSettings::periphery_rays`] (its per-column counts are bytes).
pub const MAX_PERIPHERY_RAYS: u32 = 64;

/// Default of [`FrameSettings::periphery_rays`].
///
/// One: measured on three scenes at three gazes (docs/rendering.md), four rays per texel
/// where texels span several pixels cost twice VaFR's primary rays, made ꟻLIP beyond 30°
/// against a 16-ray frame worse on two scenes of three (the averaged texels are blurrier
/// than point samples) and raised the foveated JOD by 0.02–0.2; the footprint reconstruction,
/// which costs no ray, is the anti-aliasing on by default.
pub const DEFAULT_PERIPHERY_RAYS: u32 = 1;

/// Everything that decides a frame besides the scene, the camera and the eye.
#[derive(Clone, Debug, Serialize)]
pub struct FrameSettings {
    /// Foveation method.
    pub method: Method,
    /// Parameters of every method.
    pub mapping: MappingConfig,
    /// Shading.
    pub shading: ShadingMode,
    /// Sample-space anti-aliasing.
    pub aa: AaMode,
    /// Also produce the sample-density view.
    pub density_view: bool,
    /// Refuse frames whose buffers would need more than this many bytes. Not serialised: it
    /// follows the machine's free memory and decides no pixel.
    #[serde(skip)]
    pub memory_limit_bytes: u64,
    /// Depth of field: focus policy, DOF-aware culling and the screen-space filter (`None`:
    /// sharp). The focus value itself comes from the [`EyeState`].
    pub dof: Option<DofSettings>,
    /// Peripheral contrast enhancement after reconstruction (`None`: off).
    pub contrast: Option<PeripheralContrast>,
    /// Keep the shaded sample buffers (before AA) in `Frame::samples`.
    pub keep_samples: bool,
    /// Primary rays per sample (texel), stratified over the texel in sample space and
    /// averaged (1 to 1,024; 1: one ray through the texel's centre). At full resolution this
    /// supersamples every pixel, the reference the foveated frames are scored against.
    pub pixel_samples: u32,
    /// Boundary smoothing of the inset method (Liu et al.'s inset paper, Sec. 3): alpha blend
    /// by default; ignored by the other methods.
    pub inset_smoothing: Smoothing,
    /// How polar buffers are read back at each pixel: the pixel's footprint by default (a
    /// box over every texel it covers where the buffer is denser than the screen), or the
    /// paper's bilinear lookup at its centre.
    pub reconstruct_filter: ReconstructFilter,
    /// With one ray per sample, the most primary rays a texel of a polar buffer (VaFR, KFR,
    /// LaFR, visual-polar) casts where it covers several screen pixels: one per pixel it
    /// covers, up to this (1: one ray everywhere; at most [`MAX_PERIPHERY_RAYS`]).
    pub periphery_rays: u32,
    /// The sample-space denoiser (`fovea_post::denoise`, SVGF's à-trous filter before the
    /// reconstruction; `None`: off, the library's default so that a frame's settings name
    /// it on purpose — `fovea`'s commands turn it on with `--denoise on`).
    pub denoise: Option<DenoiseParams>,
}

impl FrameSettings {
    /// Defaults: direct shading (the environment through shadow rays,
    /// [`crate::shade::EnvLight::DEFAULT`]) plus one bounce of indirect light
    /// ([`ShadingMode::DEFAULT`]), the method's own AA, a memory limit from
    /// [`default_memory_limit`].
    pub fn new(method: Method) -> Self {
        Self {
            method,
            mapping: MappingConfig::default(),
            shading: ShadingMode::DEFAULT,
            aa: AaMode::Auto,
            density_view: false,
            memory_limit_bytes: default_memory_limit(),
            dof: None,
            contrast: None,
            keep_samples: false,
            pixel_samples: 1,
            inset_smoothing: Smoothing::ALPHA_BLEND,
            reconstruct_filter: ReconstructFilter::Footprint,
            periphery_rays: DEFAULT_PERIPHERY_RAYS,
            denoise: None,
        }
    }

    /// Checks every setting's range (shading, DOF, contrast, memory limit); the frame plan
    /// calls it, so a bad setting is refused before any work.
    pub fn validate(&self) -> Result<()> {
        self.shading.validate()?;
        if let Some(d) = &self.dof {
            d.validate()?;
        }
        if let Some(c) = &self.contrast {
            c.validate()?;
        }
        if let Some(d) = &self.denoise {
            d.validate()?;
        }
        if !(1..=MAX_PIXEL_SAMPLES).contains(&self.pixel_samples) {
            return Err(RenderError::invalid(
                "pixel-samples",
                self.pixel_samples,
                format!("1 to {MAX_PIXEL_SAMPLES} rays per sample"),
            ));
        }
        if !(1..=MAX_PERIPHERY_RAYS).contains(&self.periphery_rays) {
            return Err(RenderError::invalid(
                "periphery-rays",
                self.periphery_rays,
                format!("1 to {MAX_PERIPHERY_RAYS} rays per texel (1: off)"),
            ));
        }
        if self.memory_limit_bytes == 0 {
            return Err(RenderError::invalid(
                "max-memory",
                0,
                "a positive number of bytes, e.g. 8G",
            ));
        }
        Ok(())
    }
}

/// 80 % of the memory the OS reports available (`MemAvailable`), or 16 GiB where unknown.
pub fn default_memory_limit() -> u64 {
    let avail = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
    });
    avail.map_or(16 << 30, |kb| kb * 1024 / 10 * 8)
}
